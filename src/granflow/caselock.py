"""One run per case directory: the OS's advisory lock on ``run/runner.lock``.

``granflow run`` (and the workflow's simulate job) holds ``fcntl.flock`` on the lock file for
the whole run. A second run of the same case finds it held and is refused at once, naming
the process that holds it, before it reads or writes anything else under ``run/``: two runs
would otherwise write the same restarts (one dying on the other's ``…restart.partial``) and
``status.json``. The kernel releases the lock when its process ends, however it ends, so a
lock file left by a killed run never blocks: only a held lock refuses. The file stays (deleting
it could let two runs lock two different files); its text, the holder's PID, host and start
time, is for the refusal message only. The lock is not inherited by LAMMPS (Python opens files
close-on-exec), so it lasts exactly as long as the runner.
"""
from __future__ import annotations

import errno
import fcntl
import json
import os
import socket
import time
from contextlib import contextmanager
from pathlib import Path
from typing import Iterator

from .preflight import PreflightError

#: the lock file, inside the case's ``run/`` directory
LOCK_NAME = "runner.lock"


class CaseLocked(PreflightError):
    """Another process is running this case (exit 2: nothing was done)."""


def _holder_text(fd: int) -> str:
    """Who holds the lock, from the text the holder wrote (which may not be there yet)."""
    try:
        holder = json.loads(os.pread(fd, 4096, 0).decode(errors="replace") or "null")
    except ValueError:
        holder = None
    if not isinstance(holder, dict) or "pid" not in holder:
        return "another process (it has not written its PID yet)"
    return f"process {holder['pid']} on {holder.get('host', '?')}, started {holder.get('started', '?')}"


@contextmanager
def case_lock(case_dir: str | Path) -> Iterator[Path]:
    """Hold the run lock of ``case_dir`` while the block runs; yields the lock file's path.

    Raises :class:`CaseLocked` (a :class:`~granflow.preflight.PreflightError`) at once if
    another process holds it. Creates ``run/`` and the lock file if missing, and writes only
    the lock file.
    """
    case_dir = Path(case_dir)
    run_dir = case_dir / "run"
    run_dir.mkdir(parents=True, exist_ok=True)
    path = run_dir / LOCK_NAME
    fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError as exc:
            if exc.errno not in (errno.EWOULDBLOCK, errno.EAGAIN, errno.EACCES):
                raise
            raise CaseLocked(
                f"{case_dir} is being run by {_holder_text(fd)}: a second run would write over its restart "
                f"files and run/status.json; wait for it to end, or stop it and rerun (a rerun resumes "
                f"after the last complete segment)") from None
        holder = {"pid": os.getpid(), "host": socket.gethostname(),
                  "started": time.strftime("%Y-%m-%d %H:%M:%S %z")}
        os.ftruncate(fd, 0)
        os.pwrite(fd, (json.dumps(holder) + "\n").encode(), 0)
        yield path
    finally:
        os.close(fd)  # releases the lock (and so does the end of this process, however it ends)
