"""Provenance of one run case: what produced its results, written beside them.

:func:`case_provenance` reads a case directory after its run (``params.json``,
the rendered decks, ``run/status.json``, the LAMMPS logs in ``run/logs``) and
the git state of the granflow checkout it is imported from; the workflow writes
it to ``<case>/provenance.json`` and gathers the cases of a scene into
``provenance.csv`` (:func:`provenance_table`), which the Snakemake report shows.

Nothing here is scene-specific: seeds are every key named ``seed`` or ending in
``_seed`` of the record's ``parameters`` and ``case``; the hashed inputs are
every deck (``*.lmp``), LAMMPS data file (``*.data``) and ``params.json`` at the
top of the case directory. What cannot be known (no git checkout, no LAMMPS log,
a status without ``host``) is written ``"unknown"``, never guessed; missing
numbers are ``null``.
"""
from __future__ import annotations

import hashlib
import json
import math
import re
import subprocess
from datetime import datetime, timezone
from pathlib import Path

UNKNOWN = "unknown"
#: the package directory: its git checkout is the code that ran
PACKAGE_DIR = Path(__file__).resolve().parent
#: the rendered inputs of a case, at the top of its directory
INPUT_PATTERNS = ("*.lmp", "*.data", "params.json")
#: folders of the checkout (from its top) whose untracked, not ignored files make it dirty:
#: the code and the scene files a run can use without their being committed
UNTRACKED_COUNTED = ("src", "config")
_VERSION = re.compile(r"^LAMMPS \(.+\)\s*$")


def sha256(path: str | Path) -> str:
    """SHA-256 (hex) of a file's bytes, read in chunks."""
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for chunk in iter(lambda: f.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def _git(where: Path, *args: str) -> str | None:
    try:
        proc = subprocess.run(["git", "-C", str(where), *args], capture_output=True, text=True, timeout=30)
    except (OSError, subprocess.SubprocessError):
        return None
    return proc.stdout if proc.returncode == 0 else None


def git_state(where: str | Path = PACKAGE_DIR) -> dict:
    """Commit and dirtiness of the git checkout holding ``where`` (a directory).

    ``where`` must hold files tracked by that checkout (so a granflow installed
    inside some other repository's untracked tree is not credited with that
    repository's commit). ``dirty`` is true when a tracked file differs from the
    commit (``git status --porcelain --untracked-files=no``) or when a file under
    ``src/`` or ``config/`` of the checkout (:data:`UNTRACKED_COUNTED`) is
    untracked and not ignored (``git ls-files --others --exclude-standard``): a
    new scene file or module the run may have used. ``dirty_files`` names both
    kinds, ``untracked_files`` the second (paths from the checkout's top).
    Untracked files elsewhere (notes, results) do not count. Without git or a
    checkout every field is ``"unknown"``.
    """
    unknown = {"commit": UNKNOWN, "dirty": UNKNOWN, "dirty_files": UNKNOWN, "untracked_files": UNKNOWN}
    where = Path(where)
    if not where.is_dir() or not _git(where, "ls-files", "--error-unmatch", "."):
        return unknown
    commit = _git(where, "rev-parse", "HEAD")
    status = _git(where, "status", "--porcelain", "--untracked-files=no")
    others = _git(where, "ls-files", "-z", "--others", "--exclude-standard", "--full-name", "--",
                  *(f":(top){folder}" for folder in UNTRACKED_COUNTED))
    if commit is None or status is None or others is None:
        return unknown
    untracked = sorted(name for name in others.split("\0") if name)
    files = sorted({line[3:] for line in status.splitlines() if line.strip()} | set(untracked))
    return {"commit": commit.strip(), "dirty": bool(files), "dirty_files": files, "untracked_files": untracked}


def lammps_version(log_dir: str | Path) -> str:
    """The ``LAMMPS (<date> - Update N)`` line of the run's logs (``*.log``, else ``*.screen``).

    Several different lines (a run resumed with another LAMMPS) are joined with
    ``"; "`` in the order of the logs' names; none gives ``"unknown"``.
    """
    log_dir = Path(log_dir)
    for pattern in ("*.log", "*.screen"):
        found: list[str] = []
        for path in sorted(log_dir.glob(pattern)):
            with open(path, errors="replace") as f:
                for _, line in zip(range(20), f):  # the version is LAMMPS's first line
                    if _VERSION.match(line):
                        if line.strip() not in found:
                            found.append(line.strip())
                        break
        if found:
            return "; ".join(found)
    return UNKNOWN


def _walk(tree, prefix: str = ""):
    if isinstance(tree, dict):
        for key, value in tree.items():
            yield from _walk(value, f"{prefix}{key}.")
            if not isinstance(value, dict):
                yield f"{prefix}{key}", value


def seeds(record: dict) -> dict:
    """Every key named ``seed`` or ending in ``_seed`` in the record's ``parameters`` and ``case``.

    Keyed by the key's (dotted) name; a name found in both sections with different
    values keeps the ``parameters`` one and adds ``case.<name>``.
    """
    out: dict = {}
    for section in ("parameters", "case"):
        for key, value in _walk(record.get(section) or {}):
            name = key.rsplit(".", 1)[-1]
            if name != "seed" and not name.endswith("_seed"):
                continue
            if key in out and out[key] != value:
                out[f"{section}.{key}"] = value
            else:
                out.setdefault(key, value)
    return out


def input_hashes(case_dir: str | Path) -> dict:
    """SHA-256 of each rendered input of the case (``INPUT_PATTERNS``), by file name."""
    case_dir = Path(case_dir)
    files = sorted({p for pattern in INPUT_PATTERNS for p in case_dir.glob(pattern) if p.is_file()})
    return {p.name: sha256(p) for p in files}


def _number(value):
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return None
    return None if isinstance(value, float) and not math.isfinite(value) else value


def _stamp(t: float) -> str:
    return datetime.fromtimestamp(t, timezone.utc).isoformat(timespec="seconds")


def case_provenance(case_dir: str | Path, repo: str | Path = PACKAGE_DIR) -> dict:
    """Provenance of the run case in ``case_dir`` (see the module docstring).

    ``repo`` is where to read the git state (default: this package's checkout).
    ``run_finished`` is when ``run/status.json`` was written, ``written`` now: the
    git state is the one at ``written``, the same code as the run when both come
    from one workflow invocation.
    """
    case_dir = Path(case_dir)
    record = json.loads((case_dir / "params.json").read_text())
    status_path = case_dir / "run" / "status.json"
    status = json.loads(status_path.read_text()) if status_path.exists() else {}
    git = git_state(repo)
    return {
        "scene": record.get("scene", UNKNOWN),
        "rung": record.get("rung", UNKNOWN),
        "case": record.get("case") or {},
        "status": status.get("status", UNKNOWN),
        "granflow_commit": git["commit"],
        "granflow_dirty": git["dirty"],
        "granflow_dirty_files": git["dirty_files"],
        "granflow_untracked_files": git["untracked_files"],
        "lammps_version": lammps_version(case_dir / "run" / "logs"),
        "inputs_sha256": input_hashes(case_dir),
        "seeds": seeds(record),
        "ranks": _number(status.get("nprocs")),
        "wall_seconds": _number(status.get("wall_seconds")),
        "cpu_seconds": _number(status.get("cpu_seconds")),
        "host": status.get("host", UNKNOWN),
        "launcher": status.get("launcher", UNKNOWN),
        "run_finished": _stamp(status_path.stat().st_mtime) if status_path.exists() else UNKNOWN,
        "written": datetime.now(timezone.utc).isoformat(timespec="seconds"),
    }


def _cell(value):
    if isinstance(value, (dict, list)):
        return json.dumps(value, sort_keys=True)
    return value


def provenance_row(prov: dict, case: str) -> dict:
    """One flat table row of a provenance record, first column ``case`` (the case directory, which
    names its sweep values); each seed a column of its own name, each hash ``sha256:<file>``
    (the names of dirty and untracked files stay in the JSON)."""
    row = {"case": case}
    for key, value in prov.items():
        if key == "seeds":
            row.update(value)
        elif key == "inputs_sha256":
            row.update({f"sha256:{k}": v for k, v in value.items()})
        elif key not in ("case", "granflow_dirty_files", "granflow_untracked_files"):
            row[key] = _cell(value)
    return row


def provenance_table(records: dict):
    """A DataFrame with one row per case from ``{case: provenance record}``, in the given order."""
    import pandas as pd

    return pd.DataFrame([provenance_row(prov, case) for case, prov in records.items()])


def write_case_provenance(case_dir: str | Path, out: str | Path | None = None) -> dict:
    """Write :func:`case_provenance` of ``case_dir`` to ``out`` (default ``<case>/provenance.json``)."""
    prov = case_provenance(case_dir)
    out = Path(out) if out is not None else Path(case_dir) / "provenance.json"
    out.write_text(json.dumps(prov, indent=2) + "\n")
    return prov


__all__ = ["case_provenance", "git_state", "lammps_version", "seeds", "input_hashes", "sha256",
           "provenance_row", "provenance_table", "write_case_provenance", "UNKNOWN"]
