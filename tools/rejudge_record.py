"""Judge a committed validation record again by today's rules, without its runs.

  python tools/rejudge_record.py heap silo            # rewrites validation/<scene>/summary.json, checks.csv
                                                       # and validation/changes/<scene>_rejudged.md, then README.md

The numbers stay as measured; each check takes its scene's kind and today's verdict, and the checks
a scene makes from its record's profiles are recomputed (granflow.rejudge). The changes file lists
every verdict that changed, old beside new.
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "src"))

from granflow import registry  # noqa: E402
from granflow.rejudge import HOW, changed_verdicts, rejudge  # noqa: E402
from granflow.validation import write_readme  # noqa: E402


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("scenes", nargs="+", help=f"scenes whose record to judge again ({', '.join(registry.names())})")
    ap.add_argument("--folder", default=str(ROOT / "validation"), help="the record's folder (default: validation/)")
    args = ap.parse_args(argv)
    folder = Path(args.folder)
    for name in args.scenes:
        if name not in registry.names() or not (folder / name / "summary.json").is_file():
            print(f"rejudge_record: scene {name!r} has no record {folder / name / 'summary.json'}: allowed "
                  f"{', '.join(p.parent.name for p in sorted(folder.glob('*/summary.json')))}", file=sys.stderr)
            return 2
    for name in args.scenes:
        before = json.loads((folder / name / "summary.json").read_text())
        after = rejudge(folder / name, name)
        rows = changed_verdicts(before, after)
        text = (f"### {name}: the record judged again by the rules of {after['rejudged']['commit'][:10]} "
                f"({after['rejudged']['date']})\n\n`python tools/rejudge_record.py {name}`: {HOW}.\n\n"
                "| quantity | case | verdict before | verdict now |\n|---|---|---|---|\n")
        text += "".join(f"| {q} | {c} | {b} | {a} |\n" for q, c, b, a in rows) + "\n"
        (folder / "changes").mkdir(exist_ok=True)
        (folder / "changes" / f"{name}_rejudged.md").write_text(text)
        print(text)
    write_readme(folder)
    return 0


if __name__ == "__main__":
    sys.exit(main())
