"""A restart is checked before a run resumes from it; a damaged one is set aside.

The runner renames a segment's restart into place only when LAMMPS finished it cleanly, and
then *seals* it: ``<name>.restart.sha256`` beside it holds its SHA-256 and size. Before a run
resumes, the restart it would resume from is checked (:func:`damage`):

1. its size: not empty, and the size it had when sealed;
2. its SHA-256, against the seal (64 random bytes written into a restart: LAMMPS read it, ran,
   and the case ended ``unstable: lost atoms``, the corruption blamed on the physics);
3. LAMMPS's own read of it, in a dry run (``read_restart`` alone, one process, bounded time): a
   truncated restart stops it with ``ERROR: Incomplete or corrupted LAMMPS restart file``, and
   one with random bytes in its atoms can make it read forever (seen: still reading after 60 s).

A damaged restart is renamed ``<name>.restart.damaged-<time>`` (kept, never deleted), and the
run resumes from the restart before it, rerunning the segment whose restart it was
(:func:`latest`, :func:`set_aside`); the runner logs which.
"""
from __future__ import annotations

import hashlib
import os
import re
import signal
import subprocess
import time
from pathlib import Path

from .interrupts import lammps_preexec

#: the seal of a restart, beside it
SEAL_SUFFIX = ".sha256"
#: the deck of the dry read, written into the run directory
CHECK_DECK = "restart_check.lmp"
#: seconds LAMMPS's dry read of a restart may take (a 36 kB restart: 0.4 s; a read of a restart with
#: random bytes in its atom data did not end in 60 s)
READ_TIMEOUT_S = 120.0
_ORDER = {"init": 0, "flow": 1, "average": 2}


def _sha256(path: Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def seal(restart: Path) -> None:
    """Record ``restart``'s SHA-256 and size beside it (``<name>.restart.sha256``)."""
    restart = Path(restart)
    tmp = restart.with_name(restart.name + SEAL_SUFFIX + ".partial")
    tmp.write_text(f"{_sha256(restart)} {restart.stat().st_size}\n")
    tmp.rename(restart.with_name(restart.name + SEAL_SUFFIX))


def _segment_key(path: Path) -> tuple[int, int] | None:
    """Where a restart's segment comes in the protocol (init, flow_NNN, average_NNN), or None."""
    m = re.fullmatch(r"(init|flow|average)(?:_(\d+))?\.restart", path.name)
    if not m or (m.group(1) == "init") != (m.group(2) is None):
        return None
    return _ORDER[m.group(1)], int(m.group(2) or 0)


def latest(run_dir: Path) -> Path | None:
    """The restart a resumed run starts from: the last segment's, in protocol order."""
    found = [p for p in Path(run_dir).glob("*.restart") if _segment_key(p) is not None]
    return max(found, key=_segment_key, default=None)


def damage(restart: Path, lmp: str, timeout: float | None = None) -> str | None:
    """Why ``restart`` cannot be resumed from (size, seal, LAMMPS's dry read), or None if it can."""
    restart = Path(restart)
    size = restart.stat().st_size
    if size == 0:
        return "it is empty (0 bytes)"
    sealed = restart.with_name(restart.name + SEAL_SUFFIX)
    if sealed.exists():
        words = sealed.read_text().split()
        if len(words) == 2 and words[1].isdigit():
            if int(words[1]) != size:
                return f"it has {size:,} bytes, {int(words[1]):,} when it was written"
            if _sha256(restart) != words[0]:
                return "its bytes changed since it was written (SHA-256 differs from its seal)"
    return dry_read(restart, lmp, READ_TIMEOUT_S if timeout is None else timeout)


def dry_read(restart: Path, lmp: str, timeout: float) -> str | None:
    """LAMMPS's ``read_restart`` of ``restart`` alone, in its directory; why it failed, or None."""
    restart = Path(restart)
    deck = restart.parent / CHECK_DECK
    deck.write_text("# granflow: LAMMPS reads a restart before a run resumes from it (granflow.restarts)\n"
                    "read_restart ${restart_in}\n")
    proc = subprocess.Popen([lmp, "-in", deck.name, "-var", "restart_in", restart.name, "-log", "none",
                             "-nocite"], cwd=restart.parent, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, preexec_fn=lammps_preexec())
    try:
        out, _ = proc.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.communicate()
        return f"LAMMPS's read of it did not end within {timeout:g} s"
    finally:
        deck.unlink(missing_ok=True)
    text = out.decode(errors="replace")
    bad = next((line.strip() for line in text.splitlines() if line.strip().startswith("ERROR")), None)
    if bad or proc.returncode != 0:
        return f"LAMMPS cannot read it: {bad or f'exit status {proc.returncode}'}"
    return None


def set_aside(restart: Path) -> Path:
    """Rename a damaged restart (and its seal) out of the way; returns its new path."""
    restart = Path(restart)
    aside = restart.with_name(f"{restart.name}.damaged-{time.strftime('%Y%m%d-%H%M%S')}")
    restart.rename(aside)
    sealed = restart.with_name(restart.name + SEAL_SUFFIX)
    if sealed.exists():
        sealed.rename(aside.with_name(aside.name + SEAL_SUFFIX))
    return aside
