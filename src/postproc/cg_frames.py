"""The frames ``granflow cg`` (:mod:`postproc.cg`) reads: the first selected ones, the atoms no particle
can have (refused or dropped), atom and contact frames paired by step, the progress line and the
inputs' SHA-256 (moved out of :mod:`postproc.cg`)."""
from __future__ import annotations

import hashlib
import math
import os
import time
from typing import Callable, Iterable, Iterator, Sequence

import numpy as np

from .cg_output import CGInputError
from .contacts import ContactFrame
from .dump import read_dumps
from .frame import DumpFrame, ImpossibleValues, ParticleFrame, impossible_values


class Progress:
    """Frames done, on one stderr line (a bar when the total is known), at most every ``interval`` s.

    The first line comes one interval after the start (a refusal in the first frames is then the
    only line); :meth:`abort` ends an open terminal line before a refusal is printed.
    """

    def __init__(self, total: int | None, stream=None, interval: float = 0.5):
        self.total = total
        self.stream = stream
        self.interval = interval
        self.tty = bool(stream is not None and getattr(stream, "isatty", lambda: False)())
        self.start = time.perf_counter()
        self.last = self.start
        self.printed = False
        self.open = False

    def abort(self) -> None:
        if self.open:
            self.stream.write("\n")
            self.stream.flush()
            self.open = False

    def update(self, frames: int, particles: int, step: int, final: bool = False) -> None:
        if self.stream is None:
            return
        now = time.perf_counter()
        if not final and now - self.last < (self.interval if self.tty else 30.0):
            return
        self.last = now
        rate = particles / max(now - self.start, 1e-9)
        if self.total:
            done = min(frames / self.total, 1.0)
            bar = "#" * int(30 * done) + "-" * (30 - int(30 * done))
            text = f"cg [{bar}] {frames}/{self.total} frames"
        else:
            text = f"cg {frames} frames"
        text += f", step {step}, {rate / 1e6:.2f} M particle-frames/s"
        if self.tty:
            self.stream.write("\r" + text + ("\n" if final else ""))
            self.open = not final
        else:
            self.stream.write(text + "\n")
        self.stream.flush()
        self.printed = True


def sha256(path: str | os.PathLike) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for chunk in iter(lambda: fh.read(1 << 22), b""):
            h.update(chunk)
    return h.hexdigest()


def first_frames(paths: Sequence[str], select: Callable[[int], bool], limit: int = 64) -> tuple[DumpFrame, DumpFrame | None]:
    """The first selected frame and the first selected one holding atoms (None if not within ``limit``)."""
    first = None
    for k, frame in enumerate(read_dumps(paths, select=select)):
        first = first or frame
        if frame.natoms > 0:
            return first, frame
        if k >= limit:
            break
    if first is None:
        raise CGInputError(f"no frame of {', '.join(paths)} is selected by --frames")
    return first, None


def possible_radii(frame: DumpFrame) -> np.ndarray | None:
    """The frame's possible radii (finite and > 0: the others are refused or dropped as the frames are read)."""
    c = frame.columns
    if "radius" in c:
        radii = np.asarray(c["radius"], float)
    elif "diameter" in c:
        radii = 0.5 * np.asarray(c["diameter"], float)
    else:
        return None
    return radii[np.isfinite(radii) & (radii > 0)]


def _atom(frame: DumpFrame, row: int) -> str:
    """The atom in row ``row`` of the frame, by its id when the dump has one."""
    if "id" not in frame.columns:
        return f"atom {row + 1} of the frame (the dump has no id column)"
    atom_id = float(frame.columns["id"][row])
    if not math.isfinite(atom_id):
        return f"atom {row + 1} of the frame (id {atom_id:g})"
    return f"atom id {int(round(atom_id))}"


def _impossible_message(path: str, frame: DumpFrame, columns: dict[str, np.ndarray], allowed: str) -> str:
    row, column, count = ImpossibleValues.first(columns)
    value = float(frame.columns[column][row])
    others = f" ({count} atoms of this frame have such values)" if count > 1 else ""
    return (f"{path}: frame at step {frame.timestep}, {_atom(frame, row)}: column {column} = {value:g} "
            f"is not allowed: allowed {allowed}{others}")


def possible_atoms(path: str, frame: DumpFrame, drop_nonfinite: bool) -> tuple[DumpFrame, dict[str, int], int]:
    """The frame, refused if an atom has a value no particle can have (:func:`~postproc.frame.impossible_values`).

    A mass, radius or diameter :math:`\\le 0` is always refused; a NaN or an
    infinity (position, velocity, spin, mass, radius) is refused unless
    ``drop_nonfinite``, when those atoms are left out. Returns the frame (without
    them), the dropped atoms per offending column and the number of atoms dropped.
    """
    found = impossible_values(frame)
    if found is None:
        return frame, {}, 0
    if found.nonpositive:
        raise CGInputError(_impossible_message(path, frame, found.nonpositive, "a positive finite number"))
    if not drop_nonfinite:
        raise CGInputError(_impossible_message(path, frame, found.nonfinite, "a finite number")
                           + "; --drop-nonfinite leaves such atoms out and counts them")
    bad = found.nonfinite_rows
    keep = ~bad
    kept = DumpFrame(timestep=frame.timestep, box=frame.box, boundary=frame.boundary,
                     columns={k: v[keep] for k, v in frame.columns.items()}, time=frame.time, units=frame.units)
    return kept, {k: int(np.count_nonzero(v)) for k, v in found.nonfinite.items()}, int(np.count_nonzero(bad))


def paired(frames: Iterable[ParticleFrame], contacts: Iterator[ContactFrame] | None, select,
            strict_end: Callable[[], bool]):
    """Yield (frame, contacts) with contacts matched by timestep; refuse unmatched ones."""
    if contacts is None:
        for frame in frames:
            yield frame, None
        return
    def next_contact() -> ContactFrame | None:
        for c in contacts:
            if select(c.timestep):
                return c
        return None

    pending = next_contact()
    for frame in frames:
        if pending is not None and pending.timestep < frame.timestep:
            raise CGInputError(f"contact frame at step {pending.timestep} has no atom frame at that step "
                               f"(the next atom frame is at step {frame.timestep}); contacts and atoms "
                               f"must be dumped at the same steps")
        if pending is None or pending.timestep != frame.timestep:
            raise CGInputError(f"atom frame at step {frame.timestep} has no contact frame at that step"
                               + ("" if pending is None else f" (the next contact frame is at step {pending.timestep})"))
        yield frame, pending
        pending = next_contact()
    if pending is not None and strict_end():
        raise CGInputError(f"contact frame at step {pending.timestep} has no atom frame at that step "
                           f"(the atom frames end before it)")


def describe_dropped(dropped: dict, n_frames: int) -> str:
    """``dropped`` (``meta["frames"]["dropped_nonfinite"]``) in words."""
    if not dropped["atom_frames"]:
        return "no atom (none had a non-finite value)"
    columns = ", ".join(f"{k} {n}" for k, n in dropped["columns"].items())
    n = dropped["atom_frames"]
    return (f"{n} atom-frame{'s' if n != 1 else ''} with a NaN or infinite value, in {dropped['frames']} of "
            f"{n_frames} frames (the first at step {dropped['first_step']}; by column: {columns})")

