"""Readers for LAMMPS dumps: binary (fast, memory-mapped), text and gzipped text.

Format detection
----------------
:func:`dump_format` decides from the file's first bytes, never from its name:
the gzip magic ``1f 8b`` means a gzipped text dump (``dump custom/gz``, or
``gzip dump.txt``; read by streaming, never decompressed to disk); a first
int64 in [-64, -1] (little or big endian) followed by ``DUMPCUSTOM`` or
``DUMPATOM`` means a binary dump; a first non-blank line starting with
``ITEM:`` means a text dump. Anything else is refused with :class:`DumpError`.
An empty file is a dump without frames.

Binary layout
-------------
Verified against ``dump custom ... file.bin`` written by LAMMPS 22 Jul 2025
(single rank and ``mpirun -np 2``). Every frame is self-contained and starts
with the full header, magic string included; all values in native (little)
endian::

    int64    -len(magic)             -10 for "DUMPCUSTOM" (-8 for "DUMPATOM")
    char[]   magic                   b"DUMPCUSTOM"
    int32    endian flag             0x0001
    int32    format revision         0x0002
    int64    ntimestep
    int64    natoms                  atoms in this frame
    int32    triclinic               0 orthogonal, 1 restricted, 2 general
    int32[6] boundary codes          xlo xhi ylo yhi zlo zhi; 0 p, 1 f, 2 s, 3 m
    double   box                     triclinic 0: xlo xhi ylo yhi zlo zhi
                                     triclinic 1: the 6 above + xy xz yz
                                     triclinic 2: avec bvec cvec boxlo (12)
    int32    size_one                columns per atom
    int32    unit-style length       > 0 only in the first frame written with
    char[]   unit style                ``dump_modify units yes``, else 0
    char     time flag               1 with ``dump_modify time yes``, then
    double   time                      the simulation time
    int32    columns length
    char[]   columns                 space-separated column names
    int32    nchunk                  one chunk per MPI rank (or file cluster)
    nchunk x ( int32 n; double[n] )  n = size_one * atoms of that rank

Chunks are concatenated and reshaped to ``(natoms, size_one)``; atoms are then
sorted by the ``id`` column when present. Revision 1 files (no column names)
and pre-2021 files (no magic string) are rejected with :class:`DumpError`.
The unit style, written in the first frame only, is carried to the later
frames (:attr:`DumpFrame.units`); the time goes to :attr:`DumpFrame.time`.

Text layout
-----------
Each frame is ``ITEM: TIMESTEP``, ``ITEM: NUMBER OF ATOMS``, ``ITEM: BOX BOUNDS``
(three lines) and ``ITEM: ATOMS <names>`` followed by one line per atom,
optionally preceded by ``ITEM: UNITS`` (first frame only) and ``ITEM: TIME``,
which are attached to the frame that follows. Atoms may come in any order and
their number may change from frame to frame; columns are found by name.

Errors
------
:class:`DumpError` (attributes ``path``, ``frame``, ``byte``, ``truncated``)
names the file, the 0-based frame, the byte offset at which that frame starts
and, for text dumps, the line; offsets in gzipped dumps count the decompressed
stream. All frames before the bad one are yielded first.
"""
from __future__ import annotations

import mmap
import os
from typing import Iterable, Iterator, Sequence

from postproc.frame import DumpError, DumpFrame, MissingColumnsError, ParticleFrame, missing_particle_columns

from .dump_binary import BinaryScanner, read_binary_dump
from .dump_common import Select, dump_format
from .dump_text import Lines, StreamError, TextBlock, read_text_dump, text_frames  # noqa: F401 (re-exported)

__all__ = [
    "DumpError",
    "MissingColumnsError",
    "dump_format",
    "read_binary_dump",
    "read_text_dump",
    "read_dump",
    "read_dumps",
    "peek_dump",
    "count_frames",
    "missing_particle_columns",
    "particle_frames",
]


def read_dump(path: str | os.PathLike, columns: Sequence[str] | None = None, *,
              select: Select | None = None) -> Iterator[DumpFrame]:
    """Read a LAMMPS custom dump of any kind (binary, text or gzipped text) frame by frame.

    The kind is found from the content by :func:`dump_format`, not from the name.

    Parameters
    ----------
    path : str or os.PathLike
        Dump file.
    columns : sequence of str, optional
        Column names to return. Default: all.
    select : callable, optional
        ``select(timestep) -> bool``, applied to each frame before its per-atom
        data are copied (binary) or parsed (text); frames for which it is false
        are skipped.

    Yields
    ------
    DumpFrame
        See :func:`read_binary_dump` and :func:`read_text_dump`. An empty file
        yields nothing.

    Raises
    ------
    DumpError
        If the file is not a LAMMPS dump, or a frame is truncated or corrupted
        (after the frames before it are yielded).
    MissingColumnsError
        If a requested column is absent.
    """
    if dump_format(path) == "binary":
        yield from read_binary_dump(path, columns, select=select)
    else:
        yield from read_text_dump(path, columns, select=select)


def read_dumps(paths: Iterable[str | os.PathLike], columns: Sequence[str] | None = None, *,
               select: Select | None = None) -> Iterator[DumpFrame]:
    """Read several dumps one after the other, as one sequence of frames.

    Parameters
    ----------
    paths : iterable of str or os.PathLike
        Dump files, in the order their frames are wanted; each may be of any kind.
    columns, select
        As for :func:`read_dump`.

    Yields
    ------
    DumpFrame
        The frames of the first file, then of the second, and so on.
    """
    for path in paths:
        yield from read_dump(path, columns, select=select)


def peek_dump(path: str | os.PathLike) -> DumpFrame:
    """The first frame of a dump, reading nothing past it.

    Useful to check the columns (:func:`missing_particle_columns`), the box or
    the units before reading a long file.

    Parameters
    ----------
    path : str or os.PathLike
        Dump file of any kind.

    Returns
    -------
    DumpFrame

    Raises
    ------
    DumpError
        If the file has no frame, is not a dump, or its first frame is truncated
        or corrupted.
    """
    frames = read_dump(path)
    try:
        for frame in frames:
            return frame
    finally:
        frames.close()
    spath = os.fspath(path)
    raise DumpError(f"{spath} holds no frame", path=spath)


def count_frames(path: str | os.PathLike) -> int:
    """Number of frames in a dump, scanning headers only.

    For binary dumps the headers are parsed and the per-atom data are skipped
    (their extent is checked against the file size); text dumps, plain or
    gzipped, are scanned for ``ITEM: TIMESTEP`` lines (their frames are not
    checked for completeness: read them for that).

    Parameters
    ----------
    path : str or os.PathLike
        Dump file of any kind (found by :func:`dump_format`).

    Returns
    -------
    int
        Number of frames (0 for an empty file).

    Raises
    ------
    DumpError
        If the file is not a dump, a binary frame header is corrupted or a
        binary frame is truncated, or a gzip stream is cut short or corrupted.
    """
    spath = os.fspath(path)
    fmt = dump_format(spath)
    if fmt == "text":
        with open(spath, "rb") as fh:
            return sum(1 for line in fh if line.startswith(b"ITEM: TIMESTEP"))
    if fmt == "gzip":
        count, start, pending = 0, 0, None
        with Lines(spath, fmt) as src:
            try:
                while line := src.readline():
                    if line.startswith(b"ITEM: TIMESTEP"):  # the frame starts at its UNITS/TIME items, if any
                        count, start, pending = count + 1, src.pos - len(line) if pending is None else pending, None
                    elif pending is None and line.startswith((b"ITEM: UNITS", b"ITEM: TIME")):
                        pending = src.pos - len(line)
            except StreamError as exc:
                frame = max(count - 1, 0)
                raise DumpError(
                    f"{spath}: frame {frame} at line {src.lineno} is "
                    f"{'truncated' if exc.truncated else 'corrupted'}: {exc} after line {src.lineno}, byte "
                    f"{src.pos}; the frame starts at byte {start} "
                    "(byte offsets in the decompressed stream)",
                    path=spath, frame=frame, byte=start, truncated=exc.truncated, line=src.lineno) from None
        return count
    with open(spath, "rb") as fh:
        if os.fstat(fh.fileno()).st_size == 0:
            return 0
        with mmap.mmap(fh.fileno(), 0, access=mmap.ACCESS_READ) as mm:
            return sum(1 for _ in BinaryScanner(spath, mm).headers())


def particle_frames(paths: Iterable[str | os.PathLike], dt: float | None = None,
                    t_window: tuple[float, float] | None = None, **from_dump) -> Iterator[ParticleFrame]:
    """ParticleFrames from a sequence of dump files, in order.

    With ``t_window = (lo, hi)`` only the frames with ``lo <= t - t_0 < hi`` are
    yielded, ``t_0`` being the time of the first frame: a block or a prefix of
    the averaging window. The time is ``timestep * dt`` when ``dt`` is given
    (then the frames outside the window are skipped unread), else the dump's
    own time (``dump_modify time yes``).

    Parameters
    ----------
    paths : iterable of str or os.PathLike
        Dumps of any kind.
    dt : float, optional
        Time step: simulation time per timestep, in the dump's time unit.
    t_window : (float, float), optional
        ``(lo, hi)``, simulation time from the first frame, same unit.
    **from_dump
        Passed to :meth:`ParticleFrame.from_dump` (``stress_compute``, ``density``).

    Yields
    ------
    ParticleFrame

    Raises
    ------
    ValueError
        With ``t_window`` but neither ``dt`` nor times in the dump.
    """
    t0 = None

    def inside(t: float) -> bool:
        nonlocal t0
        t0 = t if t0 is None else t0
        return t_window[0] - 1e-9 * abs(t) <= t - t0 < t_window[1] - 1e-9 * abs(t)

    if t_window is not None and dt is not None:
        for frame in read_dumps(paths, select=lambda step: inside(step * dt)):
            yield ParticleFrame.from_dump(frame, **from_dump)
        return
    for frame in read_dumps(paths):
        if t_window is not None:
            if frame.time is None:
                raise ValueError(f"frame at step {frame.timestep} has no time: give dt to select a time window")
            if not inside(frame.time):
                continue
        yield ParticleFrame.from_dump(frame, **from_dump)
