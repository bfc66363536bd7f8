"""The frames ``granflow cg`` (:mod:`postproc.cg`) reads: the input files, the first selected frames,
the atom and contact frames streamed (impossible boxes refused, steps in order, the atoms no particle
can have refused or dropped) and paired by step, what the frame loop counts, the progress line and the
inputs' SHA-256."""
from __future__ import annotations

import hashlib
import math
import os
import time
from dataclasses import dataclass, field
from typing import Callable, Iterable, Iterator, Mapping, Sequence

import numpy as np

from .cg_checks import StepOrder, check_box, check_input_files
from .cg_output import CGInputError
from .contacts import ContactFrame, read_contact_dump
from .dump import DumpError, read_dump, read_dumps
from .frame import DumpFrame, ImpossibleValues, ParticleFrame, impossible_values


def input_paths(dumps: Sequence[str | os.PathLike], contacts: Sequence[str | os.PathLike] | None = ()
                ) -> tuple[list[str], list[str]]:
    """The atom and contact dump paths as strings; refuses none given, one that is not a readable,
    non-empty regular file, and one given twice (:func:`~postproc.cg_checks.check_input_files`).

    Parameters
    ----------
    dumps : sequence of path
        The atom (``dump custom``) files.
    contacts : sequence of path, optional
        The contact (``dump local``) files; None is none.

    Returns
    -------
    paths, contact_paths : list of str

    Raises
    ------
    CGInputError
        When ``dumps`` is empty, a path is not a readable, non-empty regular file
        (the message says what it is), or a file is given twice.
    """
    paths = [os.fspath(p) for p in dumps]
    contact_paths = [os.fspath(p) for p in contacts or ()]
    if not paths:
        raise CGInputError("no dump file given")
    check_input_files(paths, contact_paths)
    return paths, contact_paths


def count_selected(paths: Sequence[str], select: Callable[[int], bool]) -> int | None:
    """The selected frames of binary dumps, from their headers alone; None if a dump cannot tell.

    Parameters
    ----------
    paths : sequence of str
        Dump files, in order.
    select : callable
        ``select(timestep) -> bool``, e.g. a :class:`~postproc.cg_options.FrameSelection`.

    Returns
    -------
    int or None
        The frames ``select`` accepts; None when a dump cannot be scanned without
        reading it (a text dump, or a :class:`~postproc.frame.DumpError`).
    """
    selected = []
    try:
        for _ in read_dumps(paths, select=lambda step: bool(selected.append(select(step)))):
            pass  # select says no to all
        return sum(selected)
    except DumpError:
        return None


@dataclass
class FrameTally:
    """What the frame loop counts as it goes; nothing grows with the number of frames."""

    n_frames: int = 0
    n_particles: int = 0
    n_inside: int = 0  # particle-frames with their centre inside the grid
    n_timed: int = 0  # frames with a time
    steps: list[int] = field(default_factory=list)  # the first and the last
    intervals: set[int] = field(default_factory=set)  # up to 16 distinct step intervals
    times: list[float] = field(default_factory=list)  # the first and the last
    dropped: dict = field(default_factory=lambda: {"atom_frames": 0, "frames": 0, "first_step": None,
                                                   "columns": {}})
    truncated: str | None = None  # the error that ended a truncated dump, when allowed

    def drop(self, timestep: int, columns: dict[str, int], n_dropped: int) -> None:
        """Count ``n_dropped`` atoms left out of the frame at ``timestep`` (per offending column).

        Parameters
        ----------
        timestep : int
            The frame's step.
        columns : dict of str to int
            Atoms with a non-finite value, per column.
        n_dropped : int
            Atoms left out of the frame.
        """
        self.dropped["atom_frames"] += n_dropped
        self.dropped["frames"] += 1
        if self.dropped["first_step"] is None:
            self.dropped["first_step"] = int(timestep)
        for k, n in columns.items():
            self.dropped["columns"][k] = self.dropped["columns"].get(k, 0) + n

    def add(self, frame: ParticleFrame, n_inside: int) -> None:
        """Count a frame deposited, ``n_inside`` of its particles inside the grid.

        Parameters
        ----------
        frame : ParticleFrame
            The frame deposited; its ``timestep`` and ``time`` are recorded.
        n_inside : int
            Its particles whose centre lies inside the grid's ranges.
        """
        self.n_frames += 1
        self.n_particles += len(frame.mass)
        self.n_inside += n_inside
        if self.steps:
            if len(self.intervals) < 16:
                self.intervals.add(int(frame.timestep) - self.steps[-1])
            self.steps[1:] = [int(frame.timestep)]
        else:
            self.steps.append(int(frame.timestep))
        if frame.time is not None:
            self.n_timed += 1
            self.times[min(len(self.times), 1):] = [float(frame.time)]


def particle_frames(paths: Sequence[str], select: Callable[[int], bool], tally: FrameTally, *,
                    density: float | None, drop_nonfinite: bool, allow_truncated: bool,
                    order: StepOrder | None = None) -> Iterator[ParticleFrame]:
    """The selected frames of the dumps in turn, as particle frames (:func:`possible_atoms` first).

    Each frame's box is checked (:func:`~postproc.cg_checks.check_box`) and its step
    (``order``). Dropped atoms and, with ``allow_truncated``, the end of a truncated
    dump are recorded in ``tally``.

    Parameters
    ----------
    paths : sequence of str
        The atom dumps, in time order.
    select : callable
        ``select(timestep) -> bool``.
    tally : FrameTally
        Updated with the dropped atoms and a truncation.
    density : float, optional
        Particle material density, mass per volume in the dump's units, for
        dumps without a mass column (:meth:`ParticleFrame.from_dump`).
    drop_nonfinite : bool
        Leave out atoms with a non-finite value instead of refusing the frame.
    allow_truncated : bool
        End quietly at a truncated dump instead of refusing it.
    order : StepOrder, optional
        Refuses (or drops and counts) a frame whose step is not after the last one's.

    Yields
    ------
    ParticleFrame

    Raises
    ------
    CGInputError
        For a dump that does not read (:class:`~postproc.frame.DumpError`; a
        truncated one unless ``allow_truncated``), an impossible box, a step out
        of order, or an atom no particle can be (:func:`possible_atoms`).
    """
    try:
        for path in paths:
            for frame in read_dump(path, select=select):
                check_box(path, frame.box, frame.timestep)
                if order is not None and not order.admit(path, frame.timestep):
                    continue
                frame, columns, n_dropped = possible_atoms(path, frame, drop_nonfinite)
                if n_dropped:
                    tally.drop(frame.timestep, columns, n_dropped)
                yield ParticleFrame.from_dump(frame, density=density)
    except DumpError as exc:
        if getattr(exc, "truncated", False) and allow_truncated:
            tally.truncated = str(exc)
            return
        truncated = getattr(exc, "truncated", False)
        hint = " (--allow-truncated keeps the fields of the complete frames)" if truncated else ""
        raise CGInputError(f"{exc}{hint}") from None


def contact_frames(paths: Sequence[str], roles: Mapping[str, str] | None, allow_truncated: bool,
                   order: StepOrder | None = None) -> Iterator[ContactFrame]:
    """The frames of the contact dumps in turn; a truncated one ends them when ``allow_truncated``.

    Each frame's box is checked (:func:`~postproc.cg_checks.check_box`) and its step
    (``order``); the reader refuses a non-finite id, force or branch value, or a
    branch longer than the box (:func:`~postproc.contacts.read_contact_dump`).

    Parameters
    ----------
    paths : sequence of str
        The contact dumps, in time order.
    roles : mapping of str to str, optional
        Column of each role (:func:`postproc.contacts.read_contact_dump`).
    allow_truncated : bool
        End quietly at a truncated dump instead of refusing it.
    order : StepOrder, optional
        Refuses (or drops and counts) a frame whose step is not after the last one's.

    Yields
    ------
    ContactFrame

    Raises
    ------
    CGInputError
        For a dump that does not read (a truncated one unless ``allow_truncated``),
        an impossible box or a step out of order.
    """
    try:
        for p in paths:
            for frame in read_contact_dump(p, roles=roles):
                check_box(p, frame.box, frame.timestep, "contact frame")
                if order is None or order.admit(p, frame.timestep):
                    yield frame
    except DumpError as exc:
        if getattr(exc, "truncated", False) and allow_truncated:
            return
        raise CGInputError(str(exc)) from None


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
        """End an open terminal line (a newline), so that what is printed next starts a line of its own."""
        if self.open:
            self.stream.write("\n")
            self.stream.flush()
            self.open = False

    def update(self, frames: int, particles: int, step: int, final: bool = False) -> None:
        """Print the progress line, at most every ``interval`` s on a terminal (30 s on another stream).

        Parameters
        ----------
        frames : int
            Frames done.
        particles : int
            Particle-frames done (for the rate, in particle-frames per second).
        step : int
            The last frame's timestep.
        final : bool
            Print whatever the time since the last line, and end the line.
        """
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
    """The SHA-256 digest of the file at ``path``, read in chunks of 4 MiB.

    Parameters
    ----------
    path : str or os.PathLike

    Returns
    -------
    str
        64 hexadecimal digits.
    """
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for chunk in iter(lambda: fh.read(1 << 22), b""):
            h.update(chunk)
    return h.hexdigest()


def first_frames(paths: Sequence[str], select: Callable[[int], bool], limit: int = 64) -> tuple[DumpFrame, DumpFrame | None]:
    """The first selected frame and the first selected one holding atoms (None if not within ``limit``).

    Parameters
    ----------
    paths : sequence of str
        The atom dumps, in time order.
    select : callable
        ``select(timestep) -> bool``.
    limit : int
        Selected frames after the first to look through for atoms.

    Returns
    -------
    first : DumpFrame
    populated : DumpFrame or None

    Raises
    ------
    CGInputError
        When no frame is selected, or a frame's box is impossible.
    DumpError
        For a dump that does not read.
    """
    first = None
    frames = ((path, frame) for path in paths for frame in read_dump(path, select=select))
    for k, (path, frame) in enumerate(frames):
        check_box(path, frame.box, frame.timestep)
        first = first or frame
        if frame.natoms > 0:
            return first, frame
        if k >= limit:
            break
    if first is None:
        every = getattr(select, "describe", lambda: "")() == "all frames"
        raise CGInputError(f"{', '.join(paths)} hold{'s' if len(paths) == 1 else ''} no frame" if every else
                           f"no frame of {', '.join(paths)} is selected by --frames")
    return first, None


def possible_radii(frame: DumpFrame) -> np.ndarray | None:
    """The frame's possible radii (finite and > 0: the others are refused or dropped as the frames are read).

    Parameters
    ----------
    frame : DumpFrame

    Returns
    -------
    ndarray or None
        The radii (``radius``, else ``diameter / 2``), in the dump's length unit;
        None when the frame has neither column.
    """
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

    Parameters
    ----------
    path : str
        The dump, to name in the message.
    frame : DumpFrame
    drop_nonfinite : bool

    Returns
    -------
    frame : DumpFrame
    columns : dict of str to int
    n_dropped : int

    Raises
    ------
    CGInputError
        For an impossible value that is not dropped, naming the file, the step,
        the atom and the column.
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
    """Yield (frame, contacts) with contacts matched by timestep; refuse unmatched ones.

    Parameters
    ----------
    frames : iterable of ParticleFrame
        The selected atom frames, in time order.
    contacts : iterator of ContactFrame or None
        The contact frames, in time order; None: every frame comes with None.
    select : callable
        ``select(timestep) -> bool``, applied to the contact frames.
    strict_end : callable
        ``strict_end() -> bool``: whether a contact frame left after the last atom
        frame is refused (false after a truncated atom dump).

    Yields
    ------
    tuple of (ParticleFrame, ContactFrame or None)

    Raises
    ------
    CGInputError
        For an atom frame without a contact frame at its step, or the reverse.
    """
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
    """``dropped`` (``meta["frames"]["dropped_nonfinite"]``) in words.

    Parameters
    ----------
    dropped : dict
        ``atom_frames``, ``frames``, ``first_step`` and ``columns`` (count per column).
    n_frames : int
        Frames read.

    Returns
    -------
    str
    """
    if not dropped["atom_frames"]:
        return "no atom (none had a non-finite value)"
    columns = ", ".join(f"{k} {n}" for k, n in dropped["columns"].items())
    n = dropped["atom_frames"]
    return (f"{n} atom-frame{'s' if n != 1 else ''} with a NaN or infinite value, in {dropped['frames']} of "
            f"{n_frames} frames (the first at step {dropped['first_step']}; by column: {columns})")

