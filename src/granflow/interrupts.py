"""Signals that stop a run: telling an interrupted run from a failed one, and stopping LAMMPS.

A run is *interrupted* when the runner or its LAMMPS launch gets SIGINT (Ctrl-C, which the
terminal sends to the whole process group) or SIGTERM (``kill``, a scheduler's time limit).
The runner then gets :class:`Interrupted` (a ``KeyboardInterrupt``), either from its own
signal handler or because the launch it waited for reports one of those signals (a runner
started in the background ignores SIGINT, while MPICH's ``mpirun`` still passes it to the
ranks and exits 2 with ``EXIT STRING: Interrupt (signal 2)``). Other deaths, e.g. SIGKILL of
LAMMPS, stay failures.

LAMMPS runs in its own process group (:func:`lammps_preexec`), so that the runner can stop all of
it (launcher, proxies, ranks) and nothing of it outlives the runner: the kernel sends the launcher
SIGTERM when the runner dies, however it dies (``kill -9`` included; Linux's ``PR_SET_PDEATHSIG``),
and the launcher passes it to its ranks. A signal to the runner's process group therefore no
longer reaches LAMMPS directly: the runner passes SIGINT and SIGTERM on, also a SIGINT it was
started ignoring (a run started in the background), which mpirun used to receive itself.
"""
from __future__ import annotations

import ctypes
import os
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


#: Linux's prctl option: the signal a process gets when its parent dies
PR_SET_PDEATHSIG = 1


def lammps_preexec():
    """A ``preexec_fn`` for the LAMMPS launch: its own process group, and SIGTERM from the kernel
    when the runner dies (Linux; elsewhere only the process group). Built in the runner before the
    fork, so that the child calls only ``setpgid`` and ``prctl``."""
    parent = os.getpid()
    try:
        prctl = ctypes.CDLL(None, use_errno=True).prctl
    except (OSError, AttributeError):
        prctl = None

    def preexec() -> None:
        os.setpgid(0, 0)
        if prctl is not None:
            prctl(PR_SET_PDEATHSIG, int(signal.SIGTERM), 0, 0, 0)
        if os.getppid() != parent:  # the runner died before the request took hold
            os.kill(os.getpid(), signal.SIGTERM)

    return preexec


def stop(proc: subprocess.Popen, grace: float = STOP_GRACE_SECONDS) -> None:
    """Stop a running LAMMPS launch: SIGTERM (mpirun passes it to its ranks), SIGKILL after ``grace`` s;
    then SIGKILL to whatever is left of its process group (the launch leads its own group).

    SIGKILL alone would stop the launcher but leave its ranks running and writing into
    ``run/`` (seen with the wheel's mpirun), where a rerun would meet them.
    """
    proc.terminate()
    try:
        proc.wait(timeout=grace)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait()
    try:
        os.killpg(proc.pid, signal.SIGKILL)
    except (ProcessLookupError, PermissionError):
        pass  # the group is gone: every process of the launch has ended


def _raise_interrupted(signum, frame):
    raise Interrupted(signum)


@contextmanager
def sigterm_interrupts() -> Iterator[None]:
    """While the block runs, SIGTERM and SIGINT to this process raise :class:`Interrupted`, so that
    the running LAMMPS segment (in its own process group, which the signal does not reach) is
    stopped too and the run says it was interrupted (instead of the runner ending alone and
    leaving LAMMPS running). SIGINT too when this process was started ignoring it: LAMMPS's
    launcher used to receive that SIGINT itself. Only in the main thread (Python delivers
    signals there).
    """
    main = threading.current_thread() is threading.main_thread()
    previous = {sig: signal.signal(sig, _raise_interrupted) for sig in INTERRUPTING} if main else {}
    try:
        yield
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)
