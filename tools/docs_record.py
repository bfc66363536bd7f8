"""Fill the record's marks in README.md and docs/*.md from the committed validation record.

  python tools/docs_record.py            # rewrite every mark from validation/<scene>/summary.json
  python tools/docs_record.py --check    # change nothing; exit 1 naming each page and mark that differs

Run it whenever the record changes (``make validate``, ``tools/rejudge_record.py``, a rerun written into
``validation/``); ``tests/unit/test_docs_record.py`` fails until the pages say what the record holds.
The marks (``<!-- record: SCENE | QUANTITY | CASE | FORM -->…<!-- /record -->`` and
``<!-- record-table: SCENE -->`` … ``<!-- /record-table -->``) are described in
:mod:`granflow.docs_record`.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "src"))

from granflow.docs_record import RecordMarkError, load_record, pages, refresh, stale_marks  # noqa: E402


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--check", action="store_true", help="change nothing; exit 1 if a mark differs")
    parser.add_argument("--validation", type=Path, default=ROOT / "validation", help="the record's folder")
    args = parser.parse_args(argv)
    record = load_record(args.validation)
    stale = []
    for page in pages(ROOT):
        try:
            if args.check:
                stale += [(page, m) for m in stale_marks(page.read_text(), record)]
            elif refresh([page], record):
                print(f"rewrote {page.relative_to(ROOT)}")
        except RecordMarkError as err:
            print(f"error: {page.relative_to(ROOT)}: {err}", file=sys.stderr)
            return 2
    for page, m in stale:
        print(f"{page.relative_to(ROOT)}:{m.line}: <!-- {m.kind}: {m.args} --> says {m.body.strip()!r}, "
              f"the record {m.want.strip()!r}")
    return 1 if stale else 0


if __name__ == "__main__":
    sys.exit(main())
