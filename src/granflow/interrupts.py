"""Signals that stop a run: telling an interrupted run from a failed one, and stopping LAMMPS.

A run is *interrupted* when the runner or its LAMMPS launch gets SIGINT (Ctrl-C, which the
terminal sends to the whole process group) or SIGTERM (``kill``, a scheduler's time limit).
The runner then gets :class:`Interrupted` (a ``KeyboardInterrupt``), either from its own
signal handler or because the launch it waited for reports one of those signals (a runner
started in the background ignores SIGINT, while MPICH's ``mpirun`` still passes it to the
ranks and exits 2 with ``EXIT STRING: Interrupt (signal 2)``). Other deaths, e.g. SIGKILL of
LAMMPS, stay failures.
"""
from __future__ import annotations

import re
import signal
import subprocess
import threading
from contextlib import contextmanager
from pathlib import Path
from typing import Iterator

#: signals by which a user or a scheduler stops a run on purpose
INTERRUPTING = (signal.SIGINT, signal.SIGTERM)
#: seconds LAMMPS's launcher gets to stop its ranks after SIGTERM before it is killed
STOP_GRACE_SECONDS = 10.0
#: how MPICH's mpirun (hydra) reports ranks ended by a signal, e.g. "Interrupt (signal 2)"
_HYDRA_SIGNAL = re.compile(r"TERMINATED WITH THE EXIT STRING: .*\(signal (\d+)\)")


class Interrupted(KeyboardInterrupt):
    """A run stopped by ``signum`` (SIGINT or SIGTERM), received by ``who`` (the runner or LAMMPS)."""

    def __init__(self, signum: int, who: str = "the runner"):
        super().__init__(f"{signal.Signals(signum).name} received by {who}")
        self.signum, self.who = int(signum), who


def as_interrupted(exc: KeyboardInterrupt) -> Interrupted:
    """Any ``KeyboardInterrupt`` as :class:`Interrupted` (a bare one is Python's SIGINT handler's)."""
    return exc if isinstance(exc, Interrupted) else Interrupted(signal.SIGINT)


def interrupted_reason(exc: Interrupted, segment: str | None, log: Path | None, restart: Path | None) -> str:
    """The reason of status ``interrupted``: the signal, who got it, the ``segment`` it stopped (whose
    ``log`` is kept) and the ``restart`` a rerun resumes from (None: nothing had finished)."""
    where = f" during segment {segment}; its log is kept: {log}" if segment else ""
    then = (f"a rerun resumes from the last restart, {restart.name}" if restart else
            "no segment had finished: a rerun starts from the beginning")
    return f"interrupted by {signal.Signals(exc.signum).name} (received by {exc.who}){where}; {then}"


def launch_signal(returncode: int, screen: str) -> int | None:
    """The signal that ended a LAMMPS launch, if its exit says one did, else None.

    A launcher killed by it (negative ``returncode``), MPICH's mpirun, which exits N and prints
    the ranks' ``(signal N)``, or one that exits ``128 + N`` as shells and srun do. The runner
    calls only SIGINT and SIGTERM an interruption (:data:`INTERRUPTING`); SIGKILL, e.g. of the
    kernel's out-of-memory killer, stays a failure.
    """
    if returncode < 0:
        return -returncode
    m = _HYDRA_SIGNAL.search(screen)
    if m:
        return int(m.group(1))
    return returncode - 128 if 128 < returncode < 128 + signal.NSIG else None


def stop(proc: subprocess.Popen, grace: float = STOP_GRACE_SECONDS) -> None:
    """Stop a running LAMMPS launch: SIGTERM (mpirun passes it to its ranks), SIGKILL after ``grace`` s.

    SIGKILL alone would stop the launcher but leave its ranks running and writing into
    ``run/`` (seen with the wheel's mpirun), where a rerun would meet them.
    """
    proc.terminate()
    try:
        proc.wait(timeout=grace)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait()


def _raise_interrupted(signum, frame):
    raise Interrupted(signum)


@contextmanager
def sigterm_interrupts() -> Iterator[None]:
    """While the block runs, SIGTERM to this process raises :class:`Interrupted` as Ctrl-C raises
    ``KeyboardInterrupt``, so that the running LAMMPS segment is stopped too and the run says it
    was interrupted (instead of the runner ending alone and leaving LAMMPS running). Only in the
    main thread (Python delivers signals there); SIGINT keeps its handler (ignored stays ignored).
    """
    main = threading.current_thread() is threading.main_thread()
    previous = signal.signal(signal.SIGTERM, _raise_interrupted) if main else None
    try:
        yield
    finally:
        if main:
            signal.signal(signal.SIGTERM, previous)
