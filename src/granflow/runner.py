"""Run a rendered case with LAMMPS under MPI, in resumable segments.

A case directory holds the decks written by :func:`granflow.deck.render_case`
(``init.lmp``, ``flow.lmp``, ``average.lmp``, ``params.json``). The runner

1. runs ``init`` (rain, settle, pack, open the periodic direction);
2. runs flow segments until the centre-of-mass speed is steady (judged by
   :func:`postproc.steady.detect_steady_state`, not assumed) or ``t_flow_max``
   is reached;
3. runs the averaging segments, each with its own binary particle dump.

Every segment ends with a restart file, written under a temporary name and
renamed only when LAMMPS finished cleanly, so a killed run resumes from the last
complete segment and never mistakes a partial file for a finished one. Each
segment keeps its full LAMMPS log in ``run/logs``. A LAMMPS ``ERROR`` line (or our
own ``GRANFLOW_ERROR`` line) becomes a :class:`RunError` quoting that line; SIGINT or SIGTERM
ends a run ``interrupted`` (:mod:`granflow.interrupts`); :mod:`granflow.caselock` refuses a second run.
MPI ranks, not OpenMP threads, parallelise a run: measured faster for
``gran/hooke/history`` on 2 cores (8.8 vs 6.0 Matom-step/s for a 10k bed).
Small cases of a campaign are better run one rank each, side by side (see
``simulate_threads`` in ``workflows/rules/common.smk``).
"""
from __future__ import annotations

import json
import os
import re
import resource
import shlex
import socket
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from . import registry, restarts
from .caselock import LOCK_NAME, case_lock
from .deck import check_case_decks
from .interrupts import (INTERRUPTING, Interrupted, as_interrupted, interrupted_reason, lammps_preexec,
                         launch_signal, sigterm_interrupts, stop)
from .launch import RANKS, SRUN_MPI_TYPES, LauncherError, Tools, launcher_argv  # noqa: F401 (re-exported)
from .preflight import read_record
from .progress import SegmentProgress, Target, progress_interval
from .provenance import git_state


class RunError(RuntimeError):
    """A LAMMPS run that failed; the message quotes the failing line and names the log."""


class StoppedByOS(RunError):
    """An OS error (disk full, ...) stopped a run: status ``interrupted``, a rerun resumes."""


class UnstableRun(RunError):
    """A run stopped by one of the deck's guards (``fix halt``): a named, expected outcome."""

    def __init__(self, message: str, reason: str):
        super().__init__(message)
        self.reason = reason


#: fix-id of each guard in lammps_inputs/include/guards.lmp.j2 -> what it means
GUARDS = {
    "halt_overlap": "largest contact overlap exceeded guards.max_overlap of the smallest diameter",
    "halt_speed": "rms particle speed exceeded guards.max_speed (kinetic-energy runaway)",
}


#: what LAMMPS's "Lost atoms" means in a walled granular box
LOST_ATOMS = ("lost atoms: a particle left the box, through a wall it was pushed beyond its own radius "
              "(contacts too soft for the impact speeds) or past a fixed box face it was thrown through")


def overlap_history(thermo: pd.DataFrame) -> str:
    """How the largest overlap reached the guard, from the run's thermo (``Time``, ``v_overlap``): one impact
    (the last thermo interval holds most of it: contacts too soft for the speed of a collision), or a steady
    rise (one contact loaded ever harder, as a particle wedged between fixed ones or pressed into a wall is,
    which no time step cures), or else the rise in numbers. Empty without the columns or three samples."""
    if not {"Time", "v_overlap"} <= set(thermo) or len(thermo) < 3:
        return ""
    t, ov = thermo["Time"].to_numpy(float), thermo["v_overlap"].to_numpy(float)
    ok = np.isfinite(t) & np.isfinite(ov)
    t, ov = t[ok], ov[ok]
    if len(t) < 3 or not ov[-1] > 0:
        return ""
    jump = ov[-1] - ov[-2]
    if jump > 0.5 * ov[-1]:
        return (f"the largest overlap jumped {ov[-2]:.3g} → {ov[-1]:.3g} d_min within one thermo interval "
                f"(t = {t[-2]:.4g}-{t[-1]:.4g}): an impact faster than the contacts' stiffness allows")
    # a steady rise: the overlap rises with time over the run (rank correlation) and has climbed from a small start
    from scipy.stats import spearmanr

    ranks = float(spearmanr(t, ov).statistic)
    if ranks > 0.9 and ov[0] < 0.25 * ov[-1]:
        return (f"the largest overlap rose steadily, {ov[0]:.3g} → {ov[-1]:.3g} d_min over t = {t[0]:.4g}-{t[-1]:.4g} "
                f"(rank correlation with time {ranks:.2f}): one contact loaded ever harder, as a particle wedged "
                f"between fixed particles or pressed into a wall is, not an impact")
    return (f"the largest overlap rose {ov[-2]:.3g} → {ov[-1]:.3g} d_min over the last thermo interval, "
            f"{float(np.median(ov)):.3g} its median over the run")


def dangerous_builds(log_text: str) -> int:
    """Sum of LAMMPS's ``Dangerous builds = N`` lines in a log."""
    return sum(int(l.split("=")[1]) for l in log_text.splitlines() if l.startswith("Dangerous builds ="))


def log(msg: str) -> None:
    print(f"[granflow {time.strftime('%H:%M:%S')}] {msg}", file=sys.stderr, flush=True)


# ------------------------------------------------------------------ log parsing
def _thermo_row(words: list[str], header: list[str]) -> list[float] | None:
    """The numbers of one thermo line under ``header``, or None if the line is not one."""
    if len(words) != len(header):
        return None
    try:
        return [float(w) for w in words]
    except ValueError:
        return None


def parse_thermo(log_path: str | Path) -> pd.DataFrame:
    """All thermo blocks of a LAMMPS log as one DataFrame (columns as LAMMPS names them).

    A block starts at its ``Step ...`` header and ends at ``Loop time`` (or at the
    next header, or the end of a log cut short). Inside a block, a line that is not a
    row of as many numbers as the header has columns is skipped, not taken as the end:
    LAMMPS prints its warnings there, e.g. ``WARNING: Lost atoms: original 2000 current
    1998`` and its ``For more information see ...`` line under ``thermo_modify lost warn``.
    """
    frames = []
    header = None
    rows: list[list[float]] = []

    def close() -> None:
        if header is not None and rows:
            frames.append(pd.DataFrame(rows, columns=header))

    for line in Path(log_path).read_text(errors="replace").splitlines():
        words = line.split()
        if words[:1] == ["Step"]:
            close()
            header, rows = words, []
            continue
        if header is None:
            continue
        if line.startswith("Loop time"):
            close()
            header, rows = None, []
            continue
        row = _thermo_row(words, header)
        if row is not None:
            rows.append(row)
    close()
    if not frames:
        return pd.DataFrame()
    return pd.concat(frames, ignore_index=True)


def error_line(log_text: str) -> str | None:
    """The first LAMMPS ``ERROR`` or granflow ``GRANFLOW_ERROR`` line of a log, if any."""
    for line in log_text.splitlines():
        s = line.strip()
        if s.startswith("ERROR") or s.startswith("GRANFLOW_ERROR"):
            return s
    return None


def performance(log_text: str) -> list[float]:
    """Matom-step/s figures of every run in a log."""
    out = []
    for line in log_text.splitlines():
        if line.startswith("Performance:") and "Matom-step/s" in line:
            out.append(float(line.split(",")[-1].split()[0]))
    return out


#: LAMMPS's line after every run (``run ... every`` too): wall seconds, steps and, where printed, atoms
_LOOP = re.compile(r"^Loop time of (\S+) on \d+ procs for (\d+) steps(?: with (\d+) atoms)?", re.M)


def loop_totals(log_text: str) -> tuple[float, float, float]:
    """Total LAMMPS loop time (s, wall), time steps and atom-steps of every run in a log, from its
    ``Loop time of X on P procs for S steps with N atoms`` lines (a line without its atoms adds no atom-steps)."""
    seconds = steps = atom_steps = 0.0
    for t, s, n in _LOOP.findall(log_text):
        seconds, steps = seconds + float(t), steps + float(s)
        atom_steps += float(s) * float(n) if n else 0.0
    return seconds, steps, atom_steps


def loop_cost(log_text: str) -> tuple[float, float]:
    """Total LAMMPS loop time (s, wall) and atom-steps of every run in a log (:func:`loop_totals`)."""
    seconds, _, atom_steps = loop_totals(log_text)
    return seconds, atom_steps


# ---------------------------------------------------------------------- runner
@dataclass
class ScheduleDone:
    """Verdict of a fixed schedule: every segment ran; steadiness is judged by the analysis."""

    status: str = "completed"
    reason: str = "fixed schedule ran to its end; the analysis judges steadiness"


class CaseRunner:
    """Resumable, segmented execution of one rendered case."""

    def __init__(self, case_dir: str | Path, nprocs: int = 1, tools: Tools | None = None):
        self.case_dir = Path(case_dir).resolve()
        self.run_dir = self.case_dir / "run"
        self.log_dir = self.run_dir / "logs"
        self.running: str | None = None  # the segment LAMMPS runs now
        self.nprocs = max(1, int(nprocs))
        self.tools = tools or Tools.default()
        #: argv before ``lmp``; built (and a bad launcher refused) before anything runs
        self.launch = self.tools.launch(self.nprocs)
        self.record = json.loads((self.case_dir / "params.json").read_text())
        # the scene's hooks (flow verdict, early stop); a bare record gets the defaults
        self.scene = registry.get(self.record["scene"]) if "scene" in self.record else registry.Scene()
        #: seconds between progress lines while a segment runs (GRANFLOW_PROGRESS_SECONDS; refused if bad)
        self.progress_seconds = progress_interval()
        init = self.case_dir / "init.lmp"
        units = re.search(r"^units\s+(\w+)", init.read_text(), re.M) if init.exists() else None
        self.time_unit = {"si": "s", "lj": "tau", "cgs": "s", "metal": "ps", "real": "fs"}.get(
            units.group(1) if units else "", "time units")

    def _guard_stale(self) -> None:
        """Keep finished results of other parameters: move an old run aside, never overwrite it."""
        stamp = self.run_dir / "params.json"
        current = (self.case_dir / "params.json").read_text()
        if self.run_dir.exists() and stamp.exists() and stamp.read_text() != current:
            aside = self.case_dir / f"run.stale-{time.strftime('%Y%m%d-%H%M%S')}"
            aside.mkdir()
            for entry in self.run_dir.iterdir():  # all but the lock this run holds
                if entry.name != LOCK_NAME:
                    entry.rename(aside / entry.name)
            log(f"parameters changed since the last run: kept the old run as {aside.name}, starting afresh")
        self.run_dir.mkdir(parents=True, exist_ok=True)
        stamp.write_text(current)

    def _target(self, name: str) -> Target:
        """Where segment ``name`` (``flow_003``, ``average_001``, ``init``) sits, for its progress lines."""
        rec = self.record
        stage, _, index = name.rpartition("_")
        count = {"flow": rec.get("n_flow_segments", 0), "average": rec.get("n_average_segments", 0)}.get(stage, 0)
        n_steps = int(rec.get("parameters", {}).get("n_segment", 0)) if count else 0
        return Target(stage=stage or name, index=int(index) if index.isdigit() and count else 0, count=count,
                      n_steps=n_steps, dt=float(rec.get("dt", 0.0)), unit=self.time_unit,
                      t_segment=float(rec.get("t_segment", 0.0)))

    # -- one LAMMPS invocation ---------------------------------------------------
    def _lammps(self, deck: str, name: str, variables: dict[str, str]) -> Path:
        self.log_dir.mkdir(parents=True, exist_ok=True)
        log_path = self.log_dir / f"{name}.log"
        screen_path = self.log_dir / f"{name}.screen"
        cmd = [*self.launch, self.tools.lmp, "-in", str(self.case_dir / deck), "-log", str(log_path), "-nocite"]
        for k, v in variables.items():
            cmd += ["-var", k, str(v)]
        t0 = time.time()
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        # one thread per rank: Snakemake exports OMP_NUM_THREADS = the job's threads (= ranks
        # locally), which every rank would inherit. Measured on 2 cores, smoke channel on 2
        # ranks: 47 s with 1 thread per rank, 157 s with 2 (same numbers: no /omp styles run).
        env = dict(os.environ, OMP_NUM_THREADS="1")
        progress = SegmentProgress(name, log_path, self._target(name), self.progress_seconds)
        with open(screen_path, "w") as screen:
            # its own process group (a terminal's signals reach the runner, which passes them on), no
            # terminal input (a background group reading it would stop), SIGTERM if the runner dies
            proc = subprocess.Popen(cmd, cwd=self.run_dir, stdin=subprocess.DEVNULL, stdout=screen,
                                    stderr=subprocess.STDOUT, env=env, preexec_fn=lammps_preexec())
            try:
                while True:
                    try:
                        proc.wait(timeout=min(self.progress_seconds, 2.0) if self.progress_seconds > 0 else None)
                        break
                    except subprocess.TimeoutExpired:
                        line = progress.update()
                        if line:
                            log(line)
            finally:
                if proc.poll() is None:  # interrupted (Ctrl-C, SIGTERM to the runner): stop LAMMPS too
                    stop(proc)
        self._record_usage(name, before, time.time() - t0)
        text = (log_path.read_text(errors="replace") if log_path.exists() else "") + "\n" + \
            screen_path.read_text(errors="replace")
        bad = error_line(text)
        signum = launch_signal(proc.returncode, text) if proc.returncode != 0 else None
        if signum in INTERRUPTING and not bad:
            raise Interrupted(signum, "LAMMPS")
        if proc.returncode != 0 or bad:
            reason = bad or f"LAMMPS exited with status {proc.returncode} and no ERROR line"
            message = f"{self.case_dir.name}: segment {name} failed: {reason} (full log: {log_path})"
            for fix_id, meaning in GUARDS.items():
                if bad and f"fix-id {fix_id} " in bad:
                    raise UnstableRun(message, f"{meaning}, in segment {name}: {bad}")
            if bad and bad.startswith("ERROR: Lost atoms"):
                raise UnstableRun(message, f"{LOST_ATOMS}, in segment {name}: {bad}")
            raise RunError(message)
        perf = performance(text)
        log(f"{name}: {time.time() - t0:.1f} s" + (f", {max(perf):.2f} Matom-step/s" if perf else ""))
        return log_path

    def _record_usage(self, name: str, before, wall: float) -> None:
        """CPU-seconds (all ranks, user + system) and peak memory of one LAMMPS invocation,
        in ``logs/<segment>.usage.json`` beside its log (kept across resumptions).

        From ``getrusage(RUSAGE_CHILDREN)``, which counts every waited-for descendant
        (mpirun and its LAMMPS ranks); its ``ru_maxrss`` is the largest single process
        seen so far (KiB on Linux), an upper bound of this segment's peak rank.
        """
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
        usage = {"cpu_s": cpu, "wall_s": wall, "peak_rss_mb": after.ru_maxrss / 1024.0, "nprocs": self.nprocs}
        (self.log_dir / f"{name}.usage.json").write_text(json.dumps(usage) + "\n")

    def usage(self) -> dict:
        """CPU-seconds, wall seconds and peak memory of every LAMMPS invocation of this run so far."""
        parts = [json.loads(p.read_text()) for p in sorted(self.log_dir.glob("*.usage.json"))]
        return {"cpu_seconds": sum(u["cpu_s"] for u in parts), "wall_seconds": sum(u["wall_s"] for u in parts),
                "peak_rss_mb": max((u["peak_rss_mb"] for u in parts), default=float("nan"))}

    def _segment(self, deck: str, name: str, restart_in: Path | None, extra: dict | None = None) -> Path:
        """Run a segment unless its restart exists; return the restart path."""
        out = self.run_dir / f"{name}.restart"
        if out.exists():
            log(f"{name}: done earlier, resuming after it")
            return out
        tmp = self.run_dir / f"{name}.restart.partial"
        index = name.rsplit("_", 1)[-1]
        variables = {"restart_out": tmp.name, "segment": int(index) if index.isdigit() else 0,
                     # used by decks that write a particle snapshot (effect snapshots)
                     "snapshot_file": f"snapshot_{name}.jpg"}
        if restart_in is not None:
            variables["restart_in"] = restart_in.name
        variables.update(extra or {})
        self.running = name
        self._lammps(deck, name, variables)
        tmp.rename(out)
        restarts.seal(out)  # its SHA-256 and size, checked before a run resumes from it
        self.running = None
        return out

    def _check_resume(self) -> None:
        """Check the restart this run would resume from (:func:`granflow.restarts.damage`); set a
        damaged one aside and check the one before it, until a good one or none is left."""
        while (last := restarts.latest(self.run_dir)) is not None:
            why = restarts.damage(last, self.tools.lmp)
            if why is None:
                return
            aside = restarts.set_aside(last)
            before = restarts.latest(self.run_dir)
            log(f"{last.name} is damaged: {why}; set aside as {aside.name}; "
                + (f"resuming from {before.name} (segment {last.stem} runs again)" if before else
                   "no good restart is left: the run starts from the beginning (segment init)"))

    def thermo(self, prefix: str, upto: int | None = None) -> pd.DataFrame:
        """Thermo rows of the *completed* segments ``prefix_001 .. prefix_upto``.

        A log whose segment has no restart (killed part-way) is left out.
        """
        logs = [p for p in sorted(self.log_dir.glob(f"{prefix}_*.log"))
                if (self.run_dir / f"{p.stem}.restart").exists()
                and (upto is None or int(p.stem.rsplit("_", 1)[1]) <= upto)]
        parts = [parse_thermo(p).assign(segment=p.stem) for p in logs]
        parts = [p for p in parts if not p.empty]
        if not parts:
            return pd.DataFrame()
        df = pd.concat(parts, ignore_index=True)
        # A segment's first row repeats the previous segment's last step; keep the
        # earlier one, whose interval-averaged wall force covers a full interval.
        return df.drop_duplicates(subset="Step", keep="first").reset_index(drop=True)

    # -- the protocol --------------------------------------------------------------
    def run(self) -> dict:
        """Run or resume the protocol; returns (and writes) ``run/status.json``.

        ``status`` is ``steady`` (averaged), or a named reason without averaging:
        ``jammed``, ``no_steady_state`` or ``unstable`` (a guard stopped LAMMPS,
        or the log shows dangerous neighbour builds), or ``interrupted`` (SIGINT, SIGTERM;
        then :class:`~granflow.interrupts.Interrupted` is raised). Other LAMMPS errors raise
        :class:`RunError` and the rule fails.
        """
        from postproc.steady import detect_steady_state

        rec = self.record
        proto = rec["protocol"]
        t_seg = rec["t_segment"]
        n = rec["parameters"].get("n_particles", rec.get("n_particles_estimate"))
        log(f"case {self.case_dir}: {n} particles, "
            f"dt = {rec['dt']:.3g}, {self.nprocs} MPI rank(s)")
        steady, k, n_avg, unstable = None, 0, 0, None
        try:
            self._guard_stale()
            self._check_resume()  # a damaged restart is set aside: the run resumes from the one before
            restart = self._segment("init.lmp", "init", None)
            n_flow = rec["n_flow_segments"]
            if rec.get("schedule") == "fixed":
                # a fixed schedule (the heap: filling until the estimated steady time);
                # the analysis judges steadiness from the particle data
                for k in range(1, n_flow + 1):
                    restart = self._segment("flow.lmp", f"flow_{k:03d}", restart)
                    log(f"flow {k}/{n_flow} done ({k * t_seg:.3g} of {n_flow * t_seg:.3g} before averaging)")
                steady = ScheduleDone()
            for k in ([] if rec.get("schedule") == "fixed" else range(1, n_flow + 1)):
                restart = self._segment("flow.lmp", f"flow_{k:03d}", restart)
                th = self.thermo("flow", upto=k)
                t, u = th["Time"].to_numpy(), th["v_ucm"].to_numpy()
                t = t - t[0]
                window = min(proto["steady_window"], 0.5 * t_seg * n_flow)
                steady = detect_steady_state(t, u, window=window, rel_tol=proto["steady_rel_tol"],
                                             fluct_tol=proto["steady_fluct_tol"])
                steady = self.scene.flow_verdict(steady, th, rec)
                log(f"flow {k}/{n_flow}: t = {t[-1]:.0f}, u_cm = {u[-1]:.4g}, {steady.status}"
                    + (f" ({steady.reason})" if steady.reason else ""))
                if steady.status in ("steady", "jammed", *self.scene.stop_statuses):
                    break
            if steady.status in ("steady", "completed") or proto.get("average_unsteady"):
                n_planned = rec["n_average_segments"]
                for n_avg in range(1, n_planned + 1):
                    restart = self._segment("average.lmp", f"average_{n_avg:03d}", restart,
                                            {"dump_file": f"dump_{n_avg:03d}.bin",
                                             "contacts_file": f"contacts_{n_avg:03d}.dump"})
                    log(f"average {n_avg}/{n_planned} done")
                    verdict = self._early_stop(n_avg)
                    if verdict:
                        steady = ScheduleDone(*verdict)
                        log(f"stopped after segment {n_avg}: {verdict[0]}: {verdict[1]}")
                        break
            else:
                log(f"not averaged: {steady.status} is not a steady flow (protocol.average_unsteady is false)")
        except UnstableRun as exc:
            unstable = exc.reason
            log(f"stopped by a guard: {exc.reason}")
        except KeyboardInterrupt as exc:  # Ctrl-C, SIGTERM, or a LAMMPS launch ended by one of them
            self._interrupted(steady, as_interrupted(exc))
            raise as_interrupted(exc) from None
        except OSError as exc:  # a full disk, a quota, a directory made read-only: nothing lost
            raise self._stopped_by_os(steady, exc) from None
        return self._conclude(steady, k, n_avg, unstable)

    def _with_halted(self, thermo: pd.DataFrame, reason: str) -> pd.DataFrame:
        """``thermo`` and the rows of the segment a guard halted (named in ``reason``; it left no restart)."""
        m = re.search(r"in segment (\w+):", reason)
        log_path = self.log_dir / f"{m[1]}.log" if m else None
        if log_path is None or not log_path.exists():
            return thermo
        tail = parse_thermo(log_path)
        return pd.concat([thermo, tail], ignore_index=True).drop_duplicates(subset="Step", keep="first") \
            if "Step" in tail and "Step" in thermo else thermo

    def _stopped_by_os(self, steady, exc: OSError) -> "StoppedByOS":
        """Status ``interrupted`` naming the OS error and its path, as a signal's interruption does
        (written if the disk takes it); the error to raise, one line."""
        what = f"{exc.strerror or exc}" + (f": {exc.filename}" if exc.filename else "")
        last = restarts.latest(self.run_dir)
        segment = f" during segment {self.running}" if self.running else ""
        then = (f"a rerun resumes from the last restart, {last.name}" if last else
                "no segment had finished: a rerun starts from the beginning")
        reason = f"stopped by an OS error{segment} ({what}); fix its cause (free the disk) and rerun: {then}"
        try:
            self._conclude(steady, len(list(self.run_dir.glob("flow_*.restart"))),
                           len(list(self.run_dir.glob("average_*.restart"))), None, interrupted=reason)
            (self.run_dir / "thermo.csv").unlink()
        except OSError as again:
            reason += f" (run/status.json could not be written either: {again.strerror or again})"
        return StoppedByOS(f"{self.case_dir.name}: {reason}")

    def _interrupted(self, steady, exc: Interrupted) -> None:
        """Status ``interrupted`` with the segments complete so far, and no ``thermo.csv``: the
        workflow's simulate job (outputs ``status.json``, ``thermo.csv``) stays unfinished."""
        done = {stage: len(list(self.run_dir.glob(f"{stage}_*.restart"))) for stage in ("flow", "average")}
        last = max(self.run_dir.glob("*.restart"), key=lambda p: p.stat().st_mtime, default=None)
        log_path = self.log_dir / f"{self.running}.log" if self.running else None
        self._conclude(steady, done["flow"], done["average"], None,
                       interrupted=interrupted_reason(exc, self.running, log_path, last))
        (self.run_dir / "thermo.csv").unlink()

    def _early_stop(self, j: int) -> tuple[str, str] | None:
        """The scene's named reason to end its schedule after averaging segment ``j``, or None."""
        th = self.thermo("average", upto=j)
        return self.scene.after_segment(th[th["segment"] == f"average_{j:03d}"] if not th.empty else None,
                                        self.record)

    def _conclude(self, steady, k: int, n_avg: int, unstable: str | None, interrupted: str | None = None) -> dict:
        rec = self.record
        parts = [self.thermo("flow", upto=k).assign(stage="flow")]
        if n_avg:
            parts.append(self.thermo("average", upto=n_avg).assign(stage="average"))
        thermo = pd.concat(parts, ignore_index=True)
        thermo.to_csv(self.run_dir / "thermo.csv", index=False)
        texts = [f.read_text(errors="replace") for f in sorted(self.log_dir.glob("*.log"))]
        costs = [loop_cost(text) for text in texts]
        loop_seconds, atom_steps = sum(c[0] for c in costs), sum(c[1] for c in costs)
        n_dangerous = sum(dangerous_builds(text) for text in texts)
        max_overlap = float(thermo["v_overlap"].max()) if "v_overlap" in thermo else float("nan")
        status, reason = (steady.status, steady.reason) if steady else ("unknown", "no flow segment ran")
        if interrupted:
            status, reason = "interrupted", interrupted
        elif unstable:
            history = overlap_history(self._with_halted(thermo, unstable)) if "halt_overlap" in unstable else ""
            status, reason = "unstable", unstable + (f"; {history}" if history else "")
        elif n_dangerous:
            status, reason = "unstable", f"{n_dangerous} dangerous neighbour builds in the logs"
        git = git_state()
        out = {
            "status": status,
            "reason": reason,
            "steady": {key: (float(v) if isinstance(v, (int, float, np.floating)) else v)
                       for key, v in vars(steady).items()} if steady else None,
            "flow_segments": k,
            "average_segments": n_avg,
            "dumps": [f"dump_{j:03d}.bin" for j in range(1, n_avg + 1)],
            "contact_dumps": [f"contacts_{j:03d}.dump" for j in range(1, n_avg + 1)
                              if (self.run_dir / f"contacts_{j:03d}.dump").exists()],
            "dangerous_builds": n_dangerous,
            "max_overlap": max_overlap,
            "overlap_below_report_limit": bool(max_overlap < rec["guards"]["report_overlap"]),
            "matom_step_per_s": atom_steps / loop_seconds / 1e6 if loop_seconds > 0 else None,
            "loop_seconds": loop_seconds,
            "atom_steps": atom_steps,
            "nprocs": self.nprocs,
            "host": socket.gethostname(),
            "launcher": shlex.join(self.launch),
            # the LAMMPS that ran: its path and the version of its -h banner (None: not asked)
            "lammps": {"path": self.tools.lmp, "version": self.tools.version},
            "slurm": slurm_allocation(),
            # the code that finished the run (a resumed run may have started under an earlier one)
            "granflow_commit": git["commit"],
            "granflow_dirty": git["dirty"],
            **self.usage(),
        }
        (self.run_dir / "status.json").write_text(json.dumps(out, indent=2) + "\n")
        log(f"status {status}: {reason}; largest overlap {max_overlap:.3g} d_min, "
            f"{n_dangerous} dangerous builds")
        return out


def slurm_allocation() -> dict | None:
    """The SLURM allocation this process runs in (job id, CPUs on this node), or None outside SLURM."""
    job = os.environ.get("SLURM_JOB_ID")
    if not job:
        return None
    cpus = os.environ.get("SLURM_CPUS_ON_NODE")
    return {"job_id": job, "cpus_on_node": int(cpus) if cpus and cpus.isdigit() else None,
            "partition": os.environ.get("SLURM_JOB_PARTITION")}


def run_case(case_dir: str | Path, nprocs: int = 1, launcher: str | None = None) -> dict:
    """Run (or resume) the case in ``case_dir`` on ``nprocs`` ranks; see :class:`CaseRunner`.

    ``launcher`` replaces the default mpirun (see :func:`launcher_argv`), e.g. ``srun --mpi=pmi2``.
    Refused (:class:`~granflow.caselock.CaseLocked`) while another process runs the same case.
    While it runs, SIGTERM to this process stops the running LAMMPS segment as Ctrl-C does
    (its log stays; a rerun resumes after the last complete segment), instead of ending the
    runner alone and leaving LAMMPS running; either ends the run with status ``interrupted``.
    """
    record = read_record(case_dir)  # a hand-edited params.json is refused naming its key, before anything runs
    check_case_decks(case_dir, record)  # so is a deck edited after rendering (a shell line, ...)
    runner = CaseRunner(case_dir, nprocs, tools=Tools.default(launcher))
    with case_lock(runner.case_dir), sigterm_interrupts():
        return runner.run()
