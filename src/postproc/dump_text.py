"""Reader of LAMMPS text dumps, plain or gzipped (streamed), custom or local.

:func:`text_frames` walks the ``ITEM:`` blocks of any text dump (atoms here,
contact entries in :mod:`postproc.contacts`) as :class:`TextBlock` objects,
counting lines and bytes for the error messages (:class:`Lines`);
:func:`read_text_dump` yields one :class:`~postproc.frame.DumpFrame` per frame.
:mod:`postproc.dump` re-exports the public names.
"""
from __future__ import annotations

import gzip
import os
import zlib
from dataclasses import dataclass
from typing import Callable, Iterator, Sequence

import numpy as np

from .dump_common import Select, boundary_string, column_picks, columns_sorted, dump_format
from .frame import DumpError, DumpFrame

#: Longest line read, in bytes: a line of a LAMMPS dump holds one atom's (or one
#: header's) values, tens to a few thousand bytes; a longer one is refused as soon
#: as this much of it is read, so memory stays bounded whatever the file holds.
MAX_LINE_BYTES = 1 << 20
#: Largest expansion of a gzipped dump, decompressed bytes per compressed byte.
#: Text dumps expand 3 to 11 times (random to lattice positions) and frames
#: without atoms about 40 times; deflate's own ceiling is 1032, what a gzip bomb
#: (one repeated byte) reaches. Checked once :data:`GZIP_RATIO_FLOOR` bytes are out.
MAX_GZIP_RATIO = 200
#: Decompressed bytes read before :data:`MAX_GZIP_RATIO` applies.
GZIP_RATIO_FLOOR = 16 << 20


class StreamError(Exception):
    """The stream cannot be read on (internal): the gzip stream is ``truncated`` or corrupted, a line
    is too long, or the gzip stream expands too much (then ``line`` is where, and the message says so)."""

    def __init__(self, what: str, truncated: bool, line: int | None = None) -> None:
        super().__init__(what)
        self.truncated = truncated
        self.line = line


class Lines:
    """Binary line reader over a text or gzipped text dump that counts lines and bytes (internal).

    ``lineno`` is the number of lines read so far, ``pos`` the byte offset just
    past them (in the decompressed stream for gzip). Errors of the gzip stream,
    a line longer than :data:`MAX_LINE_BYTES` and a gzip stream expanding more
    than :data:`MAX_GZIP_RATIO` times become :class:`StreamError`.
    """

    def __init__(self, path: str, fmt: str) -> None:
        self.gz = fmt == "gzip"
        self.raw = open(path, "rb")
        self.fh = gzip.GzipFile(fileobj=self.raw, mode="rb") if self.gz else self.raw
        self.lineno = 0
        self.pos = 0
        self._next_ratio_check = GZIP_RATIO_FLOOR

    def __enter__(self) -> "Lines":
        return self

    def __exit__(self, *exc) -> None:
        self.fh.close()
        self.raw.close()

    def _guard(self, call):
        try:
            return call()
        except EOFError as exc:  # gzip stream without its end marker
            raise StreamError(f"the compressed stream ends early ({exc})", True) from None
        except (OSError, zlib.error) as exc:  # bad CRC, bad deflate data, BadGzipFile
            raise StreamError(f"the compressed stream is corrupted ({exc})", False) from None

    def readline(self) -> bytes:
        """The next line (with its end of line), or ``b""`` at the end of the stream.

        Returns
        -------
        bytes

        Raises
        ------
        StreamError
            When the gzip stream ends early or is corrupted.
        """
        line = self._guard(lambda: self.fh.readline(MAX_LINE_BYTES))
        self._count(line)
        return line

    def _count(self, line: bytes) -> None:
        """Count a line read; refuse one cut at :data:`MAX_LINE_BYTES`, or a gzip stream expanding too much."""
        if len(line) >= MAX_LINE_BYTES and not line.endswith(b"\n"):
            raise StreamError(f"line {self.lineno + 1} (from byte {self.pos}) is longer than {MAX_LINE_BYTES:,} "
                              f"bytes: a line of a LAMMPS dump holds one atom's values; this is not a dump",
                              False, line=self.lineno + 1)
        if line:
            self.lineno += 1
            self.pos += len(line)
        if self.gz and self.pos >= self._next_ratio_check:
            self._next_ratio_check = self.pos + GZIP_RATIO_FLOOR
            compressed = max(self.raw.tell(), 1)
            if self.pos > MAX_GZIP_RATIO * compressed:
                raise StreamError(f"its first {compressed:,} compressed bytes expand to {self.pos:,} (line "
                                  f"{self.lineno}), more than {MAX_GZIP_RATIO} times: a gzipped LAMMPS dump "
                                  f"expands 3 to 40 times; this is not a dump (a gzip bomb?)", False, line=self.lineno)

    def lines(self, n: int) -> list[bytes]:
        """The next ``n`` lines, fewer at the end of the stream.

        Parameters
        ----------
        n : int
            Lines wanted.

        Returns
        -------
        list of bytes

        Raises
        ------
        StreamError
            When the gzip stream ends early or is corrupted.
        """
        return self._guard(lambda: self._read_lines(n))

    def _read_lines(self, n: int) -> list[bytes]:
        readline, count, lines = self.fh.readline, self._count, []
        for _ in range(n):
            line = readline(MAX_LINE_BYTES)
            if not line:
                break
            count(line)
            lines.append(line)
        return lines


@dataclass
class TextBlock:
    """One frame of a LAMMPS text dump (custom or local), as :func:`text_frames` parsed it.

    Attributes
    ----------
    frame : int
        0-based frame index in the file.
    timestep : int
    box : ndarray, shape (3, 2)
    flags : list of str
        Box-bound flags, e.g. ``["pp", "pp", "ff"]``.
    names : list of str
        Column names.
    data : ndarray, shape (n, len(names))
        Per-atom (or per-entry) values in file order.
    time : float or None
        From ``ITEM: TIME``, when present.
    units : str or None
        From ``ITEM: UNITS`` (written in the first frame only; carried on).
    line, byte : int
        Line (1-based) and byte offset at which the frame starts.
    """

    frame: int
    timestep: int
    box: np.ndarray
    flags: list[str]
    names: list[str]
    data: np.ndarray
    time: float | None = None
    units: str | None = None
    line: int = 1
    byte: int = 0


def text_frames(path: str | os.PathLike, item: str, noun: str,
                check_names: Callable[[list[str]], str | None] | None = None, *,
                select: Select | None = None) -> Iterator[TextBlock]:
    """Walk the frames of a text dump whose blocks are ``ITEM: NUMBER OF <item>`` and ``ITEM: <item> ...``.

    Shared by :func:`read_text_dump` (``item = "ATOMS"``) and
    :func:`postproc.contacts.read_contact_dump` (``"ENTRIES"``). Plain and
    gzipped text are told apart by content (:func:`dump_format`); gzip is
    streamed. Optional ``ITEM: UNITS`` and ``ITEM: TIME`` sections are attached
    to the frame that follows (the units also to the later frames); each block
    is parsed at once by :func:`numpy.loadtxt`.

    Parameters
    ----------
    path : str or os.PathLike
    item : str
        ``"ATOMS"`` or ``"ENTRIES"``.
    noun : str
        Name of a data line in messages (``"atom"``, ``"entry"``).
    check_names : callable, optional
        May refuse the column names (its message becomes the error) before the
        block is read.
    select : callable, optional
        ``select(timestep) -> bool``; the data lines of the frames for which it
        is false are read past without being parsed, and those frames are not
        yielded.

    Yields
    ------
    TextBlock

    Raises
    ------
    DumpError
        Truncated or malformed frames, non-orthogonal boxes, a binary file; the
        message names the file, the 0-based frame, the line and the byte at
        which the frame starts (``noun`` names the data lines); so do the
        attributes ``frame``, ``byte``, ``line`` and ``truncated``.
    """
    spath = os.fspath(path)
    fmt = dump_format(spath)
    if fmt == "binary":
        raise DumpError(f"{spath} is a binary dump, not a text one (read it with read_dump or read_binary_dump)",
                        path=spath, frame=0, byte=0, truncated=False)
    where = " (byte offsets in the decompressed stream)" if fmt == "gzip" else ""
    with Lines(spath, fmt) as src:
        frame, units = -1, None
        start_line, start_byte = 1, 0

        def fail(what: str, truncated: bool, line: int | None = None, ends: bool = True) -> DumpError:
            at = src.lineno if line is None else line
            end = f"; the file ends at line {src.lineno}, byte {src.pos}" if truncated and ends else ""
            return DumpError(
                f"{spath}: frame {max(frame, 0)} at line {at} {what}{end}; "
                f"the frame starts at line {start_line}, byte {start_byte}{where}",
                path=spath, frame=max(frame, 0), byte=start_byte, truncated=truncated, line=at)

        def next_line(what: str) -> str:
            line = src.readline()
            if not line:
                raise fail(f"is truncated: file ends while expecting {what}", True)
            return line.decode("latin-1")

        try:
            while True:
                start_line, start_byte = src.lineno + 1, src.pos
                raw = src.readline()
                if not raw:
                    return
                line = raw.decode("latin-1")
                if not line.strip():
                    continue
                frame += 1
                time = None
                try:
                    while line.strip() in ("ITEM: UNITS", "ITEM: TIME"):
                        if line.strip() == "ITEM: UNITS":
                            units = next_line("the unit style").strip()
                        else:
                            time = float(next_line("the time"))
                        line = next_line("'ITEM: TIMESTEP'")
                    if not line.startswith("ITEM: TIMESTEP"):
                        raise fail(f"is corrupted: expected 'ITEM: TIMESTEP', got {line.strip()[:60]!r}", False)
                    timestep = int(next_line("the timestep"))
                    if not next_line(f"'ITEM: NUMBER OF {item}'").startswith(f"ITEM: NUMBER OF {item}"):
                        raise ValueError(f"missing 'ITEM: NUMBER OF {item}'")
                    n = int(next_line(f"the number of {item.lower()}"))
                    if n < 0:
                        raise ValueError(f"negative number of {item.lower()} {n}")
                    boxline = next_line("'ITEM: BOX BOUNDS'")
                    if not boxline.startswith("ITEM: BOX BOUNDS"):
                        raise ValueError("missing 'ITEM: BOX BOUNDS'")
                    flags = boxline.split()[3:]
                    if len(flags) != 3:
                        raise fail(f"has a non-orthogonal box: {boxline.strip()!r}", False)
                    box = np.array([[float(v) for v in next_line("box bounds").split()[:2]] for _ in range(3)])
                    if box.shape != (3, 2):
                        raise ValueError("box bounds need two numbers per line")
                    header = next_line(f"'ITEM: {item}'")
                    if not header.startswith(f"ITEM: {item}"):
                        raise ValueError(f"expected 'ITEM: {item} ...', got {header.strip()[:60]!r}")
                except ValueError as exc:
                    raise fail(f"is corrupted: {exc}", False) from None
                names = header.split()[2:]
                refusal = check_names(names) if check_names else None
                if refusal:
                    raise fail(f"cannot be used: {refusal}", False)
                first = src.lineno + 1
                lines = src.lines(n)
                if len(lines) < n:
                    raise fail(f"is truncated: expected {n} {noun} lines, file ends after {len(lines)}", True)
                if n and not lines[-1].endswith(b"\n"):
                    raise fail(f"is truncated: the file ends inside {noun} line {src.lineno} "
                               f"(no end of line)", True)
                if select is not None and not select(timestep):
                    continue
                try:
                    data = np.loadtxt(lines, dtype=np.float64, ndmin=2) if n else np.empty((0, len(names)))
                except ValueError as exc:
                    raise fail(f"is corrupted: {noun} lines {first}-{first + n - 1} do not parse: {exc}", False,
                               line=first) from None
                if data.shape != (n, len(names)):
                    raise fail(f"is corrupted: {noun} block has shape {data.shape}, expected ({n}, {len(names)})",
                               False, line=first)
                yield TextBlock(frame, timestep, box, flags, names, data, time=time, units=units,
                                line=start_line, byte=start_byte)
        except StreamError as exc:
            after = "" if exc.line else f" after line {src.lineno}, byte {src.pos}"
            raise fail(f"is {'truncated' if exc.truncated else 'corrupted'}: {exc}{after}", exc.truncated,
                       line=exc.line, ends=False) from None


def read_text_dump(path: str | os.PathLike, columns: Sequence[str] | None = None, *,
                   select: Select | None = None) -> Iterator[DumpFrame]:
    """Read a LAMMPS text custom dump, plain or gzipped, frame by frame (reference reader).

    Meant for tests and small files: each frame's atom lines are parsed with
    :func:`numpy.loadtxt`. Gzip is recognised by content and streamed.
    ``ITEM: UNITS`` and ``ITEM: TIME`` give :attr:`DumpFrame.units` and
    :attr:`DumpFrame.time`. All values must be numeric.

    Parameters
    ----------
    path : str or os.PathLike
        Text dump written by ``dump ... custom N file ...`` (or ``custom/gz``),
        whatever its name.
    columns : sequence of str, optional
        Column names to return, in this order. Default: all columns.
    select : callable, optional
        ``select(timestep) -> bool``; the atom lines of frames for which it is
        false are not parsed, and those frames are not yielded.

    Yields
    ------
    DumpFrame
        One per frame, in file order; float64 columns sorted by ``id`` when it exists.

    Raises
    ------
    DumpError
        If a frame is truncated or malformed, has a triclinic box, or the file
        is binary; the message names the frame, the line and the byte offset.
    MissingColumnsError
        (a :class:`KeyError`) if a requested column is absent from a frame.
    """
    spath = os.fspath(path)
    for block in text_frames(spath, "ATOMS", "atom", select=select):
        picks = column_picks(spath, block.frame, block.names, columns, block.byte)
        yield DumpFrame(
            timestep=block.timestep,
            box=block.box,
            boundary=boundary_string([c for pair in block.flags for c in pair]),
            columns=columns_sorted(block.data, block.names, picks),
            time=block.time,
            units=block.units,
        )
