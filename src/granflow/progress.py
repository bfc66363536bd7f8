"""Progress lines while a LAMMPS segment runs: simulated time against the target, steps per
second and an estimated end, read from the segment's own log (its thermo rows).

:class:`SegmentProgress` is fed the log file between polls of the LAMMPS process
(:meth:`granflow.runner.CaseRunner._lammps`) and returns a line at most every
``interval`` seconds, e.g. ::

    flow_003: t = 1.23 of 3.47 s before averaging (segment 41 %), 5,400 steps/s, segment ends ~02:43:10, flow stage ~02:58:40

The interval is ``GRANFLOW_PROGRESS_SECONDS`` (default :data:`DEFAULT_SECONDS`; 0 turns the
lines off). Steps per second come from the step advance between two readings and the wall
time between them, so the first line needs two thermo rows; the end estimates extrapolate
that rate (the heap's later segments are slower: its particle count grows).
"""
from __future__ import annotations

import math
import os
import time
from dataclasses import dataclass
from pathlib import Path

from .config import ConfigError

#: seconds between progress lines unless GRANFLOW_PROGRESS_SECONDS says otherwise
DEFAULT_SECONDS = 10.0
ENV = "GRANFLOW_PROGRESS_SECONDS"


class ProgressSettingError(ConfigError):
    """GRANFLOW_PROGRESS_SECONDS holds something other than a number of seconds >= 0."""


def progress_interval(environ: dict | None = None) -> float:
    """Seconds between progress lines, from ``GRANFLOW_PROGRESS_SECONDS`` (0: no lines)."""
    raw = (os.environ if environ is None else environ).get(ENV, "").strip()
    if not raw:
        return DEFAULT_SECONDS
    try:
        value = float(raw)
    except ValueError:
        value = float("nan")
    if not (math.isfinite(value) and value >= 0):
        raise ProgressSettingError(
            f"{ENV} = {raw!r} is not allowed: allowed a number of seconds >= 0 "
            f"(0 turns the progress lines off; unset, one line every {DEFAULT_SECONDS:g} s at most)")
    return value


@dataclass
class Target:
    """Where a segment sits in its stage: ``index`` of ``count`` segments of ``n_steps`` steps."""
    stage: str          # "flow", "average" or "init"
    index: int          # 1-based segment number within the stage (0: no stage target)
    count: int          # segments planned in the stage (0: unknown)
    n_steps: int        # steps per segment (0: unknown)
    dt: float           # time step, in the deck's time unit
    unit: str           # the deck's time unit, for the line ("s", "tau")
    t_segment: float    # simulated time per segment


@dataclass
class SegmentProgress:
    """Follows one segment's LAMMPS log; :meth:`update` returns a progress line when one is due."""
    name: str
    log_path: Path
    target: Target
    interval: float
    clock: object = time.time
    _pos: int = 0
    _tail: str = ""
    _header: list[str] | None = None
    _start: float | None = None                   # step of the segment's first row
    _first: tuple[float, float] | None = None     # (step, wall) of the newest row at the first read with rows
    _last: tuple[float, float] | None = None      # (step, wall) of the newest row at the latest read
    _emitted: float | None = None

    def _read(self) -> None:
        """Read what LAMMPS appended since the last call; keep a partial last line for later."""
        try:
            with open(self.log_path, "r", errors="replace") as fh:
                fh.seek(self._pos)
                text = fh.read()
                self._pos = fh.tell()
        except FileNotFoundError:
            return
        now = self.clock()
        text = self._tail + text
        lines = text.split("\n")
        self._tail = lines.pop()           # "" after a complete line, else a partial one
        newest = None
        for line in lines:  # header and rows; warnings inside a thermo block are skipped
            words = line.split()
            if words and words[0] == "Step":
                self._header = words
                continue
            if not self._header or len(words) != len(self._header):
                continue
            try:
                row = [float(w) for w in words]
            except ValueError:
                continue
            if self._start is None:
                self._start = row[0]
            newest = row[0]
        # the newest row of a read was printed about when it is read; older rows of the same
        # read were printed earlier, so only the newest one times the rate
        if newest is not None:
            self._last = (newest, now)
            if self._first is None:
                self._first = self._last

    def update(self) -> str | None:
        """A progress line if one is due (at most one per ``interval``), else None."""
        if self.interval <= 0:
            return None
        self._read()
        now = self.clock()
        if self._emitted is not None and now - self._emitted < self.interval:
            return None
        if self._first is None or self._last is None or self._last[0] <= self._first[0] \
                or self._last[1] <= self._first[1]:
            return None
        self._emitted = now
        return self.line(now)

    def line(self, now: float) -> str:
        (s0, w0), (s1, w1) = self._first, self._last
        rate = (s1 - s0) / (w1 - w0)
        tg = self.target
        done = s1 - self._start
        parts = [f"{self.name}: step {int(s1):,}"]
        if tg.n_steps > 0 and tg.index > 0:
            t_in = done * tg.dt
            t_stage = (tg.index - 1) * tg.t_segment + t_in
            what = "before averaging" if tg.stage == "flow" else f"of {tg.stage}"
            stage_total = tg.count * tg.t_segment
            parts = [f"{self.name}: t = {t_stage:.4g} of {stage_total:.4g} {tg.unit} {what} "
                     f"(segment {min(100.0, 100.0 * done / tg.n_steps):.0f} %)"]
        parts.append(f"{rate:,.0f} steps/s")
        if tg.n_steps > 0 and rate > 0:
            left = max(0.0, tg.n_steps - done) / rate
            parts.append(f"segment ends ~{time.strftime('%H:%M:%S', time.localtime(now + left))}")
            if tg.count > tg.index > 0:
                stage_left = left + (tg.count - tg.index) * tg.n_steps / rate
                parts.append(f"{tg.stage} stage ~{time.strftime('%H:%M:%S', time.localtime(now + stage_left))}"
                             " at this rate")
        return ", ".join(parts)
