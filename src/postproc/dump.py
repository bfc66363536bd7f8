"""Readers for LAMMPS custom dumps, binary (fast, memory-mapped) and text.

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
"""
from __future__ import annotations

import itertools
import mmap
import os
import struct
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Iterator, Sequence

import numpy as np

from postproc.frame import DumpFrame, ParticleFrame

__all__ = [
    "DumpError",
    "read_binary_dump",
    "read_text_dump",
    "read_dump",
    "count_frames",
]

_MAGICS = (b"DUMPCUSTOM", b"DUMPATOM")
_BOUNDARY_LETTERS = "pfsm"
_MAX_STRING = 1 << 20  # sanity limit for header strings (bytes)


class DumpError(Exception):
    """A dump file is truncated, corrupted or in an unsupported format.

    The message names the file, the 0-based frame index, the byte offset and
    what was wrong.
    """


def _boundary_string(codes: Sequence[int] | Sequence[str]) -> str:
    """Turn six lo/hi boundary letters into LAMMPS ``boundary`` style, e.g. ``"p p fs"``."""
    letters = [c if isinstance(c, str) else _BOUNDARY_LETTERS[c] for c in codes]
    dims = []
    for lo, hi in zip(letters[0::2], letters[1::2]):
        dims.append(lo if lo == hi else lo + hi)
    return " ".join(dims)


# --------------------------------------------------------------------------- binary


@dataclass(frozen=True)
class _BinaryHeader:
    """Parsed header of one binary frame (internal)."""

    offset: int  # byte offset of the frame start
    timestep: int
    natoms: int
    triclinic: int
    boundary: tuple[int, ...]
    box: tuple[float, ...]
    size_one: int
    columns: tuple[str, ...]
    chunks: tuple[tuple[int, int], ...]  # (byte offset of the doubles, count)
    end: int  # byte offset just past the frame


class _BinaryScanner:
    """Walks the frames of a binary dump held in a buffer (internal).

    Parameters
    ----------
    path : str
        File name, for error messages only.
    buf : buffer
        The whole file (usually an ``mmap``).
    """

    def __init__(self, path: str, buf) -> None:
        self.path = path
        self.buf = buf
        self.size = len(buf)
        self.magic: bytes | None = None
        self.order = "<"

    # -- low-level helpers -------------------------------------------------
    def _fail(self, frame: int, start: int, what: str) -> DumpError:
        return DumpError(f"{self.path}: frame {frame} at byte {start} {what}")

    def _unpack(self, fmt: str, pos: int, frame: int, start: int, field: str):
        n = struct.calcsize(self.order + fmt)
        if pos + n > self.size:
            raise self._fail(
                frame,
                start,
                f"is truncated: header field '{field}' at byte {pos} needs {n} bytes, "
                f"file ends after {self.size - pos}",
            )
        return struct.unpack_from(self.order + fmt, self.buf, pos), pos + n

    def _string(self, pos: int, length: int, frame: int, start: int, field: str) -> tuple[str, int]:
        if length < 0 or length > _MAX_STRING:
            raise self._fail(frame, start, f"is corrupted: {field} length {length} at byte {pos - 4}")
        if pos + length > self.size:
            raise self._fail(
                frame,
                start,
                f"is truncated: {field} at byte {pos} needs {length} bytes, "
                f"file ends after {self.size - pos}",
            )
        raw = bytes(self.buf[pos : pos + length])
        try:
            return raw.decode("ascii"), pos + length
        except UnicodeDecodeError:
            raise self._fail(frame, start, f"is corrupted: {field} at byte {pos} is not ASCII: {raw[:40]!r}") from None

    def _detect_order(self) -> None:
        """Fix the byte order from the first frame's magic-length field."""
        if self.size < 8:
            raise self._fail(0, 0, f"is truncated: file has {self.size} bytes, not even a magic-string length")
        for order in ("<", ">"):
            (n,) = struct.unpack_from(order + "q", self.buf, 0)
            if -64 <= n < 0:
                self.order = order
                return
        raise self._fail(
            0,
            0,
            "is not a LAMMPS >= 2021 binary dump: first int64 is "
            f"{struct.unpack_from('<q', self.buf, 0)[0]}, expected -len(magic string) "
            "(pre-2021 binary dumps without magic string are not supported)",
        )

    # -- frames --------------------------------------------------------------
    def header(self, pos: int, frame: int) -> _BinaryHeader:
        """Parse the frame starting at byte ``pos`` and check its chunks fit in the file."""
        start = pos
        if frame == 0:
            self._detect_order()
        (nmagic,), pos = self._unpack("q", pos, frame, start, "magic length")
        expected = self.magic
        if nmagic >= 0 or -nmagic > 64 or (expected is not None and -nmagic != len(expected)):
            want = f"-{len(expected)}" if expected is not None else "a small negative number"
            raise self._fail(frame, start, f"is corrupted: magic-string length field is {nmagic}, expected {want}")
        magic = bytes(self.buf[pos : pos - nmagic])
        if len(magic) < -nmagic:
            raise self._fail(
                frame, start, f"is truncated: magic string at byte {pos} needs {-nmagic} bytes, file ends after {len(magic)}"
            )
        if (expected is not None and magic != expected) or (expected is None and magic not in _MAGICS):
            want = expected if expected is not None else " or ".join(repr(m) for m in _MAGICS)
            raise self._fail(frame, start, f"is corrupted: bad magic string {magic!r} at byte {pos} (expected {want!s})")
        self.magic = magic
        pos -= nmagic
        (endian, revision), pos = self._unpack("ii", pos, frame, start, "endian/revision")
        if endian != 1:
            raise self._fail(frame, start, f"is corrupted: endian flag is {endian:#x} at byte {pos - 8}, expected 0x1")
        if revision != 2:
            raise self._fail(
                frame, start, f"has unsupported format revision {revision} at byte {pos - 4} (only revision 2 is supported)"
            )
        (timestep, natoms, triclinic), pos = self._unpack("qqi", pos, frame, start, "timestep/natoms/triclinic")
        if timestep < 0 or natoms < 0 or triclinic not in (0, 1, 2):
            raise self._fail(
                frame,
                start,
                f"is corrupted: implausible timestep {timestep}, natoms {natoms} or "
                f"triclinic flag {triclinic} at byte {pos - 20}",
            )
        boundary, pos = self._unpack("6i", pos, frame, start, "boundary")
        if any(b not in (0, 1, 2, 3) for b in boundary):
            raise self._fail(frame, start, f"is corrupted: boundary codes {boundary} at byte {pos - 24}")
        nbox = (6, 9, 12)[triclinic]
        box, pos = self._unpack(f"{nbox}d", pos, frame, start, "box")
        (size_one, nunit), pos = self._unpack("ii", pos, frame, start, "size_one/unit length")
        if size_one <= 0:
            raise self._fail(frame, start, f"is corrupted: size_one is {size_one} at byte {pos - 8}")
        _, pos = self._string(pos, nunit, frame, start, "unit style")
        (tflag,), pos = self._unpack("b", pos, frame, start, "time flag")
        if tflag not in (0, 1):
            raise self._fail(frame, start, f"is corrupted: time flag is {tflag} at byte {pos - 1}")
        if tflag:
            _, pos = self._unpack("d", pos, frame, start, "time")
        (ncolstr,), pos = self._unpack("i", pos, frame, start, "columns length")
        colstr, pos = self._string(pos, ncolstr, frame, start, "columns string")
        columns = tuple(colstr.split())
        if len(columns) != size_one:
            raise self._fail(
                frame,
                start,
                f"is corrupted: columns string names {len(columns)} columns but size_one is {size_one}: {colstr!r}",
            )
        (nchunk,), pos = self._unpack("i", pos, frame, start, "nchunk")
        if nchunk < 0 or (nchunk == 0 and natoms > 0):
            raise self._fail(frame, start, f"is corrupted: chunk count {nchunk} at byte {pos - 4}")
        chunks = []
        total = 0
        for ichunk in range(nchunk):
            (n,), pos = self._unpack("i", pos, frame, start, f"chunk {ichunk} length")
            if n < 0 or n % size_one or total + n > natoms * size_one:
                raise self._fail(
                    frame,
                    start,
                    f"is corrupted: chunk {ichunk} of {nchunk} at byte {pos - 4} claims {n} doubles "
                    f"(size_one {size_one}, {total} of {natoms * size_one} already read)",
                )
            avail = (self.size - pos) // 8
            if n > avail:
                raise self._fail(
                    frame,
                    start,
                    f"is truncated: chunk {ichunk} of {nchunk} at byte {pos} expects {n} doubles, "
                    f"file ends after {avail}",
                )
            chunks.append((pos, n))
            total += n
            pos += 8 * n
        if total != natoms * size_one:
            raise self._fail(
                frame, start, f"is corrupted: chunks hold {total} doubles, header says {natoms} atoms x {size_one} columns"
            )
        return _BinaryHeader(
            offset=start,
            timestep=timestep,
            natoms=natoms,
            triclinic=triclinic,
            boundary=tuple(boundary),
            box=tuple(box),
            size_one=size_one,
            columns=columns,
            chunks=tuple(chunks),
            end=pos,
        )

    def headers(self) -> Iterator[_BinaryHeader]:
        """Yield the headers of all frames in file order."""
        pos, frame = 0, 0
        while pos < self.size:
            h = self.header(pos, frame)
            yield h
            pos, frame = h.end, frame + 1

    def data(self, h: _BinaryHeader) -> np.ndarray:
        """The frame's per-atom values, shape ``(natoms, size_one)``, in file order.

        A view of the buffer when there is a single chunk, else a copy.
        """
        dtype = np.dtype(self.order + "f8")
        parts = [np.frombuffer(self.buf, dtype=dtype, count=n, offset=off) for off, n in h.chunks if n]
        if not parts:
            flat = np.empty(0, dtype=dtype)
        elif len(parts) == 1:
            flat = parts[0]
        else:
            flat = np.concatenate(parts)
        return flat.reshape(h.natoms, h.size_one)


def _select(path: str, frame: int, names: Sequence[str], columns: Sequence[str] | None) -> list[int]:
    """Indices of the requested columns, in the requested order."""
    if columns is None:
        return list(range(len(names)))
    index = {name: i for i, name in enumerate(names)}
    missing = [c for c in columns if c not in index]
    if missing:
        raise KeyError(f"{path}: frame {frame} has no columns {missing}; available: {list(names)}")
    return [index[c] for c in columns]


def _columns_sorted(data: np.ndarray, names: Sequence[str], picks: Sequence[int]) -> dict[str, np.ndarray]:
    """Copy the picked columns of ``data`` into contiguous float64 arrays sorted by ``id``."""
    natoms = data.shape[0]
    order = None
    if "id" in names:
        ids = data[:, list(names).index("id")]
        if natoms > 1 and not np.all(ids[1:] > ids[:-1]):
            order = np.argsort(ids, kind="stable")
    out = np.empty((len(picks), natoms), dtype=np.float64)
    for row, j in enumerate(picks):  # loop over columns, not atoms
        if order is None:
            out[row] = data[:, j]
        else:
            np.take(data[:, j], order, out=out[row])
    return {names[j]: out[row] for row, j in enumerate(picks)}


def _frame_box(path: str, h: _BinaryHeader, frame: int) -> np.ndarray:
    if h.triclinic:
        raise DumpError(
            f"{path}: frame {frame} at byte {h.offset} has a triclinic box (flag {h.triclinic}); "
            "DumpFrame supports orthogonal boxes only"
        )
    return np.array(h.box, dtype=np.float64).reshape(3, 2)


def read_binary_dump(path: str | os.PathLike, columns: Sequence[str] | None = None) -> Iterator[DumpFrame]:
    """Read a LAMMPS binary custom dump frame by frame.

    The file is memory-mapped; each frame's chunks are viewed with
    :func:`numpy.frombuffer`, concatenated, reshaped to ``(natoms, size_one)``
    and copied column-wise (sorted by ``id`` when that column exists).

    Parameters
    ----------
    path : str or os.PathLike
        Binary dump written by ``dump ... custom N file.bin ...`` (LAMMPS >= 2021,
        format revision 2).
    columns : sequence of str, optional
        Column names to return, in this order. Default: all columns. The ``id``
        column is used for sorting even if not selected.

    Yields
    ------
    DumpFrame
        One per frame, in file order. All columns are float64 (binary dumps
        store every value as a double), each a contiguous array of length natoms.

    Raises
    ------
    DumpError
        If a frame is truncated or its header is corrupted; the message names
        the file, the frame index and the byte offset. Frames before the bad
        one are yielded first. Also for triclinic boxes, which
        :class:`~postproc.frame.DumpFrame` cannot represent.
    KeyError
        If a requested column is absent from a frame.
    """
    spath = os.fspath(path)
    with open(spath, "rb") as fh:
        if os.fstat(fh.fileno()).st_size == 0:
            return
        mm = mmap.mmap(fh.fileno(), 0, access=mmap.ACCESS_READ)
    try:
        scanner = _BinaryScanner(spath, mm)
        for frame, h in enumerate(scanner.headers()):
            box = _frame_box(spath, h, frame)
            picks = _select(spath, frame, h.columns, columns)
            cols = _columns_sorted(scanner.data(h), h.columns, picks)
            yield DumpFrame(timestep=h.timestep, box=box, boundary=_boundary_string(h.boundary), columns=cols)
    finally:
        try:
            mm.close()
        except BufferError:  # a view still alive in a traceback; the GC closes it
            pass


# --------------------------------------------------------------------------- text


def read_text_dump(path: str | os.PathLike, columns: Sequence[str] | None = None) -> Iterator[DumpFrame]:
    """Read a LAMMPS text custom dump frame by frame (reference reader).

    Meant for tests and small files: each frame's atom lines are parsed with
    :func:`numpy.loadtxt`. Optional ``ITEM: UNITS`` and ``ITEM: TIME`` sections
    are skipped. All values must be numeric.

    Parameters
    ----------
    path : str or os.PathLike
        Text dump written by ``dump ... custom N file ...``.
    columns : sequence of str, optional
        Column names to return, in this order. Default: all columns.

    Yields
    ------
    DumpFrame
        One per frame, in file order; float64 columns sorted by ``id`` when it exists.

    Raises
    ------
    DumpError
        If a frame is truncated or malformed, or has a triclinic box.
    KeyError
        If a requested column is absent from a frame.
    """
    spath = os.fspath(path)
    for block in text_frames(spath, "ATOMS", "atom"):
        picks = _select(spath, block.frame, block.names, columns)
        yield DumpFrame(
            timestep=block.timestep,
            box=block.box,
            boundary=_boundary_string([c for pair in block.flags for c in pair]),
            columns=_columns_sorted(block.data, block.names, picks),
        )


@dataclass
class TextBlock:
    """One frame of a LAMMPS text dump (custom or local), as :func:`text_frames` parsed it."""

    frame: int
    timestep: int
    box: np.ndarray
    flags: list[str]
    names: list[str]
    data: np.ndarray


def text_frames(path: str | os.PathLike, item: str, noun: str,
                check_names: Callable[[list[str]], str | None] | None = None) -> Iterator[TextBlock]:
    """Walk the frames of a text dump whose blocks are ``ITEM: NUMBER OF <item>`` and ``ITEM: <item> ...``.

    Shared by :func:`read_text_dump` (``item = "ATOMS"``) and
    :func:`postproc.contacts.read_contact_dump` (``"ENTRIES"``). Optional
    ``ITEM: UNITS`` and ``ITEM: TIME`` sections are skipped; each block is parsed
    at once by :func:`numpy.loadtxt`. ``check_names`` may refuse the column names
    (its message becomes the error) before the block is read.

    Raises
    ------
    DumpError
        Truncated or malformed frames, non-orthogonal boxes; the message names
        the file, the 0-based frame and the line (``noun`` names the data lines).
    """
    spath = os.fspath(path)
    with open(spath, "r") as fh:
        frame, lineno = -1, 0

        def fail(what: str) -> DumpError:
            return DumpError(f"{spath}: frame {max(frame, 0)} at line {lineno} {what}")

        def next_line(what: str) -> str:
            nonlocal lineno
            line = fh.readline()
            if not line:
                raise fail(f"is truncated: file ends while expecting {what}")
            lineno += 1
            return line

        while True:
            line = fh.readline()
            if not line:
                return
            lineno += 1
            if not line.strip():
                continue
            if line.startswith("ITEM: UNITS") or (line.startswith("ITEM: TIME") and not line.startswith("ITEM: TIMESTEP")):
                next_line("the value of " + line.strip())
                continue
            frame += 1
            if not line.startswith("ITEM: TIMESTEP"):
                raise fail(f"is corrupted: expected 'ITEM: TIMESTEP', got {line.strip()[:60]!r}")
            try:
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
                    raise fail(f"has a non-orthogonal box: {boxline.strip()!r}")
                box = np.array([[float(v) for v in next_line("box bounds").split()[:2]] for _ in range(3)])
                if box.shape != (3, 2):
                    raise ValueError("box bounds need two numbers per line")
                header = next_line(f"'ITEM: {item}'")
                if not header.startswith(f"ITEM: {item}"):
                    raise ValueError(f"expected 'ITEM: {item} ...', got {header.strip()[:60]!r}")
            except ValueError as exc:
                raise fail(f"is corrupted: {exc}") from None
            names = header.split()[2:]
            refusal = check_names(names) if check_names else None
            if refusal:
                raise fail(f"is corrupted: {refusal}")
            first = lineno + 1
            lines = list(itertools.islice(fh, n))
            lineno += len(lines)
            if len(lines) < n:
                raise fail(f"is truncated: expected {n} {noun} lines, file ends after {len(lines)}")
            try:
                data = np.loadtxt(lines, dtype=np.float64, ndmin=2) if n else np.empty((0, len(names)))
            except ValueError as exc:
                lineno = first
                raise fail(f"is corrupted: {noun} lines {first}-{first + n - 1} do not parse: {exc}") from None
            if data.shape != (n, len(names)):
                lineno = first
                raise fail(f"is corrupted: {noun} block has shape {data.shape}, expected ({n}, {len(names)})")
            yield TextBlock(frame, timestep, box, flags, names, data)


# --------------------------------------------------------------------------- dispatch


def _is_binary(path: str | os.PathLike) -> bool:
    return Path(path).suffix == ".bin"


def read_dump(path: str | os.PathLike, columns: Sequence[str] | None = None) -> Iterator[DumpFrame]:
    """Read a LAMMPS custom dump, binary if the name ends in ``.bin``, else text.

    Parameters
    ----------
    path : str or os.PathLike
        Dump file.
    columns : sequence of str, optional
        Column names to return. Default: all.

    Returns
    -------
    iterator of DumpFrame
        See :func:`read_binary_dump` and :func:`read_text_dump`.
    """
    if _is_binary(path):
        return read_binary_dump(path, columns)
    return read_text_dump(path, columns)


def count_frames(path: str | os.PathLike) -> int:
    """Number of frames in a dump, scanning headers only.

    For binary dumps the headers are parsed and the per-atom data are skipped
    (their extent is checked against the file size); text dumps are scanned
    for ``ITEM: TIMESTEP`` lines.

    Parameters
    ----------
    path : str or os.PathLike
        Dump file; binary if its name ends in ``.bin``.

    Returns
    -------
    int
        Number of frames.

    Raises
    ------
    DumpError
        If a binary frame header is corrupted or a frame is truncated.
    """
    spath = os.fspath(path)
    if not _is_binary(spath):
        with open(spath, "rb") as fh:
            return sum(1 for line in fh if line.startswith(b"ITEM: TIMESTEP"))
    with open(spath, "rb") as fh:
        if os.fstat(fh.fileno()).st_size == 0:
            return 0
        with mmap.mmap(fh.fileno(), 0, access=mmap.ACCESS_READ) as mm:
            return sum(1 for _ in _BinaryScanner(spath, mm).headers())



def particle_frames(paths, dt: float | None = None, t_window: tuple[float, float] | None = None):
    """ParticleFrames from a sequence of dump files, in order.

    With ``t_window = (lo, hi)`` (and the time step ``dt``) only the frames with
    ``lo <= t - t_0 < hi`` are yielded, ``t_0`` being the time of the first frame:
    a block or a prefix of the averaging window.
    """
    t0 = None
    for path in paths:
        for frame in read_dump(path):
            if t_window is not None:
                t = frame.timestep * dt
                t0 = t if t0 is None else t0
                if not t_window[0] - 1e-9 * abs(t) <= t - t0 < t_window[1] - 1e-9 * abs(t):
                    continue
            yield ParticleFrame.from_dump(frame)
