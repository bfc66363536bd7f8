"""One-knob experiments against the committed validation record: old and new headline side by side.

  python tools/compare_record.py heap /work/keep/results_walls/heap/validation mix~bi1-2/mdot~33 \\
      --title "walls: granular syntax (issue 27)" --out validation/changes/heap_walls.md

Runs the scene's own validation (``Scene.validation``, exactly what ``make validate`` runs) on
the analysed cases named, from a results directory of any campaign at the validation rung, and
sets every check that names one of those cases beside the same check of the committed record
(``validation/<scene>/summary.json``), with both runs' CPU-hours. Sweep-wide checks (fits over
every case) are left out when only some cases reran. Nothing of the committed record changes;
the table goes to stdout and, with ``--out``, to a markdown file.
"""
from __future__ import annotations

import argparse
import json
import math
import shlex
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "src"))

from granflow import registry  # noqa: E402
from granflow.validation import case_summary  # noqa: E402


def _fmt(x, err=float("nan")) -> str:
    if x is None or (isinstance(x, float) and math.isnan(x)):
        return "–"
    s = f"{x:.4g}"
    return s if err is None or math.isnan(err) else f"{s} ± {err:.2g}"


def compare(scene: str, scene_dir: Path, cases: list[str], record: Path) -> tuple[list[dict], dict, dict]:
    """(rows, old case summaries, new case summaries) for the checks of ``cases``."""
    old = json.loads(record.read_text())
    result = registry.get(scene).validation(scene_dir, {c: scene_dir / c for c in cases})
    new_checks = {(c.quantity, c.case): c for c in result.checks if c.case in cases}
    rows = []
    for oc in old["checks"]:
        key = (oc["quantity"], oc["case"])
        if key not in new_checks:
            continue
        nc = new_checks[key]
        rows.append({"quantity": oc["quantity"], "case": oc["case"], "paper": oc["paper"],
                     "old": oc["ours"], "old_error": oc.get("error"), "old_verdict": oc["verdict"],
                     "new": nc.ours, "new_error": nc.error, "new_verdict": nc.verdict, "unit": oc.get("unit", "")})
    old_cases = {c["dir"]: c for c in old["cases"] if c["dir"] in cases}
    new_cases = {c: case_summary(scene_dir / c) for c in cases}
    return rows, old_cases, new_cases


def case_scalars(record: Path, scene_dir: Path, cases: list[str]) -> list[tuple[str, str, float, float]]:
    """(case, name, before, after) for every number of a case's row in the record's ``profiles/sweep.csv``
    (the per-case scalars a sweep fit rests on) that the rerun's ``analysis/scalars.json`` also has."""
    import pandas as pd

    sweep = record.parent / "profiles" / "sweep.csv"
    if not sweep.exists():
        return []
    old = pd.read_csv(sweep).set_index("case")
    out = []
    for c in cases:
        path = scene_dir / c / "analysis" / "scalars.json"
        if c not in old.index or not path.exists():
            continue
        new = json.loads(path.read_text())
        for name, value in old.loc[c].items():
            if isinstance(new.get(name), (int, float)) and isinstance(value, (int, float)) and not isinstance(value, bool):
                out.append((c, name, float(value), float(new[name])))
    return out


def markdown(title: str, command: str, rows: list[dict], old_cases: dict, new_cases: dict,
             scalars: list | None = None) -> str:
    text = f"### {title}\n\n`{command}`\n\n| quantity | case | paper | before | after | verdict after |\n|---|---|---|---|---|---|\n"
    for r in rows:
        oe = r["old_error"] if isinstance(r["old_error"], float) else float("nan")
        text += (f"| {r['quantity']} | {r['case']} | {r['paper']} | {_fmt(r['old'], oe)} {r['unit']} | "
                 f"{_fmt(r['new'], r['new_error'])} {r['unit']} | {r['new_verdict']} |\n")
    if scalars:
        text += "\n| case | per-case number (profiles/sweep.csv) | before | after | after / before |\n|---|---|---|---|---|\n"
        for c, name, b, a in scalars:
            ratio = a / b if b else float("nan")
            text += f"| {c} | {name} | {_fmt(b)} | {_fmt(a)} | {_fmt(ratio)} |\n"
    text += "\n| case | before: status, particles, CPU-h, commit | after: status, particles, CPU-h, commit |\n|---|---|---|\n"
    for c, n in new_cases.items():
        o = old_cases.get(c, {})
        text += (f"| {c} | {o.get('status', '–')}, {o.get('particles', '–')}, {_fmt(o.get('cpu_hours'))}, "
                 f"{str(o.get('granflow_commit', ''))[:7]} | {n.get('status')}, {n.get('particles')}, "
                 f"{_fmt(n.get('cpu_hours'))}, {str(n.get('granflow_commit', ''))[:7]} |\n")
    return text + "\n"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("scene")
    ap.add_argument("scene_dir", type=Path, help="results/<scene>/validation of the new campaign")
    ap.add_argument("cases", nargs="+", help="case directories under scene_dir (as in the record)")
    ap.add_argument("--title", default="rerun")
    ap.add_argument("--record", type=Path, default=None, help="default validation/<scene>/summary.json")
    ap.add_argument("--out", type=Path, default=None)
    a = ap.parse_args(argv)
    record = a.record or ROOT / "validation" / a.scene / "summary.json"
    rows, old_cases, new_cases = compare(a.scene, a.scene_dir, a.cases, record)
    command = "python tools/compare_record.py " + shlex.join(sys.argv[1:] if argv is None else argv)
    text = markdown(a.title, command, rows, old_cases, new_cases, case_scalars(record, a.scene_dir, a.cases))
    print(text)
    if a.out:
        a.out.parent.mkdir(parents=True, exist_ok=True)
        a.out.write_text(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
