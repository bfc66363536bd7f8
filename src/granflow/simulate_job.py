"""The workflow's simulate job: run (or resume) one case, its messages in the rule's log.

Snakemake deletes a job's log (and outputs) before the job starts. A second Snakemake on the
same results (``--nolock``, or two checkouts sharing ``results_dir``) thus deleted the log of the
job that was running the case, and its own refused job then wrote a traceback there: the first,
successful job's ``simulate.log`` was lost. Here the case lock is taken *before* the log is
opened: a refused job writes nothing of the running case's (its one line goes to the terminal);
the job that holds the lock writes its log and, when it ends, puts it back in place if someone
deleted or replaced it meanwhile (:func:`kept_log`). Every other ending is one line too: a
refusal (exit 2), a failed or OS-stopped run (exit 1), an interruption (exit 130).
"""
from __future__ import annotations

import os
import sys
from contextlib import contextmanager
from pathlib import Path
from typing import IO, Iterator

from .caselock import CaseLocked, case_lock
from .interrupts import sigterm_interrupts
from .intermediates import DamagedIntermediate, read_json
from .preflight import PreflightError, read_record
from .runner import CaseRunner, RunError, StoppedByOS, Tools


@contextmanager
def kept_log(path: str | Path) -> Iterator[IO[str]]:
    """``sys.stderr`` appended to the log ``path`` while the block runs; afterwards, if ``path`` no
    longer is the file written (deleted, or replaced by another job's), its text is put back."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "a+") as log:
        mine = os.fstat(log.fileno())
        previous, sys.stderr = sys.stderr, log
        try:
            yield log
        finally:
            sys.stderr = previous
            log.flush()
            try:
                now = os.stat(path)
                same = (now.st_dev, now.st_ino) == (mine.st_dev, mine.st_ino)
            except FileNotFoundError:
                same = False
            if not same:
                log.seek(0)
                tmp = path.with_name(path.name + ".restored")
                tmp.write_text(log.read())
                tmp.replace(path)


def _say(line: str, *streams) -> None:
    for stream in dict.fromkeys(s for s in streams if s is not None):
        print(line, file=stream, flush=True)


def simulate(log: str | Path, params: str | Path, nprocs: int, launcher: str | None = None) -> int:
    """Run the case of ``params`` (its ``params.json``) on ``nprocs`` ranks, messages in ``log``.

    Returns the exit status: 0 done, 2 refused (nothing written of a case another process runs),
    1 failed or stopped by an OS error (status ``interrupted``), 130 interrupted by a signal.
    """
    terminal = sys.stderr
    case_dir = Path(params).parent
    try:
        read_json(params, keys=("scene",))  # a damaged one named with the command that rebuilds it
        read_record(case_dir)
        runner = CaseRunner(case_dir, nprocs, tools=Tools.default(launcher))
        with case_lock(case_dir):
            with kept_log(log) as out:
                try:
                    with sigterm_interrupts():
                        status = runner.run()
                except StoppedByOS as exc:
                    _say(f"granflow: interrupted: {exc}", out, terminal)
                    return 1
                except RunError as exc:
                    _say(f"granflow: failed: {exc}", out, terminal)
                    return 1
                except KeyboardInterrupt:
                    _say("granflow: interrupted; a rerun resumes after the last complete segment", out, terminal)
                    return 130
                _say(f"finished: {status['status']} on {status['nprocs']} rank(s) via {status['launcher']}", out)
                return 0
    except CaseLocked as exc:  # the running case's log is not ours to write
        _say(f"granflow: refused: {exc}", terminal)
        return 2
    except (PreflightError, DamagedIntermediate) as exc:
        line = f"granflow: {'refused' if isinstance(exc, PreflightError) else 'damaged intermediate'}: {exc}"
        _say(line, terminal)
        Path(log).parent.mkdir(parents=True, exist_ok=True)
        with open(log, "a") as out:
            _say(line, out)
        return 2 if isinstance(exc, PreflightError) else 1
