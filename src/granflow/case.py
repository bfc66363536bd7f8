"""The files of one rendered and run case: its parameter record and run status."""
from __future__ import annotations

import json
from pathlib import Path


def case_inputs(case_dir: str | Path, record: dict | None = None) -> tuple[Path, dict, dict]:
    """The case directory, its parameter record (or ``record``, e.g. with other bin widths) and run status."""
    case_dir = Path(case_dir)
    if record is None:
        record = json.loads((case_dir / "params.json").read_text())
    status = json.loads((case_dir / "run" / "status.json").read_text())
    return case_dir, record, status
