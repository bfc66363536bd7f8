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

import gzip
import itertools
import mmap
import os
import struct
import zlib
from dataclasses import dataclass
from typing import Callable, Iterable, Iterator, Sequence

import numpy as np

from postproc.frame import DumpError, DumpFrame, MissingColumnsError, ParticleFrame, missing_particle_columns

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

_MAGICS = (b"DUMPCUSTOM", b"DUMPATOM")
_BOUNDARY_LETTERS = "pfsm"
_MAX_STRING = 1 << 20  # sanity limit for header strings (bytes)
_GZIP_MAGIC = b"\x1f\x8b"
_PEEK = 4096  # bytes read by dump_format

#: Optional per-frame filter on the timestep: ``select(timestep) -> bool``.
Select = Callable[[int], bool]


def _boundary_string(codes: Sequence[int] | Sequence[str]) -> str:
    """Turn six lo/hi boundary letters into LAMMPS ``boundary`` style, e.g. ``"p p fs"``."""
    letters = [c if isinstance(c, str) else _BOUNDARY_LETTERS[c] for c in codes]
    dims = []
    for lo, hi in zip(letters[0::2], letters[1::2]):
        dims.append(lo if lo == hi else lo + hi)
    return " ".join(dims)


# --------------------------------------------------------------------------- format


def _binary_start(head: bytes) -> bool:
    """Whether ``head`` starts like a LAMMPS >= 2021 binary dump (or is a cut-short start of one)."""
    for order in ("<", ">"):
        for magic in _MAGICS:
            start = struct.pack(order + "q", -len(magic)) + magic
            if head[: len(start)] == start[: len(head)]:
                return True
    return False


def _gzip_head(raw: bytes) -> bytes:
    """Whatever the first compressed bytes decompress to (no error for a cut-short stream)."""
    try:
        return zlib.decompressobj(wbits=31).decompress(raw, _PEEK)
    except zlib.error:
        return b""


def dump_format(path: str | os.PathLike) -> str:
    """Kind of LAMMPS dump a file holds, from its content (the name plays no part).

    Parameters
    ----------
    path : str or os.PathLike

    Returns
    -------
    {"binary", "gzip", "text"}
        ``"gzip"``: gzip-compressed text dump (magic bytes ``1f 8b``);
        ``"binary"``: LAMMPS >= 2021 binary dump (first int64, little or big
        endian, in [-64, -1] followed by the magic string ``DUMPCUSTOM`` or
        ``DUMPATOM``); ``"text"``: first non-blank line starts with ``ITEM:``.
        An empty or blank file is ``"text"`` (a dump without frames).

    Raises
    ------
    DumpError
        If the file is none of these (the message shows its first bytes),
        including pre-2021 binary dumps and gzip-compressed files whose content
        is not a text dump.
    OSError
        If the file cannot be read.
    """
    spath = os.fspath(path)
    with open(spath, "rb") as fh:
        head = fh.read(_PEEK)
        if head[:2] == _GZIP_MAGIC:
            inner = _gzip_head(head + fh.read(16 * _PEEK))
            text = inner.lstrip()
            if text and not text.startswith(b"ITEM:"[: len(text)]):
                raise DumpError(
                    f"{spath} is gzip-compressed but not a LAMMPS text dump: its first decompressed "
                    f"bytes are {inner[:32]!r}, expected 'ITEM: ...' (gzipped binary dumps are not supported)",
                    path=spath, frame=0, byte=0, truncated=False)
            return "gzip"
        if _binary_start(head):
            return "binary"
        text = head.lstrip()
        while not text and len(head) == _PEEK:  # a long blank prefix
            head = fh.read(_PEEK)
            text = head.lstrip()
    if not text or text.startswith(b"ITEM:"[: len(text)]):
        return "text"
    first = struct.unpack_from("<q", head)[0] if len(head) >= 8 else None
    raise DumpError(
        f"{spath} is not a LAMMPS dump: it is not gzip-compressed (magic 1f 8b), not a LAMMPS >= 2021 "
        f"binary dump (first int64 {first}, expected -10 or -8 followed by 'DUMPCUSTOM' or 'DUMPATOM'; "
        f"pre-2021 binary dumps without that magic string are not supported), and its first non-blank line "
        f"does not start with 'ITEM:'; first bytes: {head[:32]!r}",
        path=spath, frame=0, byte=0, truncated=False)


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
    units: str | None = None  # unit style, in the first frame only
    time: float | None = None


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
    def _fail(self, frame: int, start: int, what: str, truncated: bool = False) -> DumpError:
        if truncated:
            what = f"is truncated: {what}; the file ends at byte {self.size}"
        return DumpError(f"{self.path}: frame {frame} at byte {start} {what}",
                         path=self.path, frame=frame, byte=start, truncated=truncated)

    def _unpack(self, fmt: str, pos: int, frame: int, start: int, field: str):
        n = struct.calcsize(self.order + fmt)
        if pos + n > self.size:
            raise self._fail(
                frame,
                start,
                f"header field '{field}' at byte {pos} needs {n} bytes, file ends after {self.size - pos}",
                truncated=True,
            )
        return struct.unpack_from(self.order + fmt, self.buf, pos), pos + n

    def _string(self, pos: int, length: int, frame: int, start: int, field: str) -> tuple[str, int]:
        if length < 0 or length > _MAX_STRING:
            raise self._fail(frame, start, f"is corrupted: {field} length {length} at byte {pos - 4}")
        if pos + length > self.size:
            raise self._fail(
                frame,
                start,
                f"{field} at byte {pos} needs {length} bytes, file ends after {self.size - pos}",
                truncated=True,
            )
        raw = bytes(self.buf[pos : pos + length])
        try:
            return raw.decode("ascii"), pos + length
        except UnicodeDecodeError:
            raise self._fail(frame, start, f"is corrupted: {field} at byte {pos} is not ASCII: {raw[:40]!r}") from None

    def _detect_order(self) -> None:
        """Fix the byte order from the first frame's magic-length field."""
        if self.size < 8:
            raise self._fail(0, 0, f"file has {self.size} bytes, not even a magic-string length", truncated=True)
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
            if any(m.startswith(magic) for m in ((expected,) if expected is not None else _MAGICS)):
                raise self._fail(
                    frame, start, f"magic string at byte {pos} needs {-nmagic} bytes, file ends after {len(magic)}",
                    truncated=True,
                )
            raise self._fail(frame, start, f"is corrupted: bad magic string {magic!r} at byte {pos}")
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
        units, pos = self._string(pos, nunit, frame, start, "unit style")
        (tflag,), pos = self._unpack("b", pos, frame, start, "time flag")
        if tflag not in (0, 1):
            raise self._fail(frame, start, f"is corrupted: time flag is {tflag} at byte {pos - 1}")
        time = None
        if tflag:
            (time,), pos = self._unpack("d", pos, frame, start, "time")
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
                    f"chunk {ichunk} of {nchunk} at byte {pos} expects {n} doubles, file ends after {avail}",
                    truncated=True,
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
            units=units or None,
            time=time,
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


def _picks(path: str, frame: int, names: Sequence[str], columns: Sequence[str] | None,
           byte: int | None = None) -> list[int]:
    """Indices of the requested columns, in the requested order."""
    if columns is None:
        return list(range(len(names)))
    index = {name: i for i, name in enumerate(names)}
    missing = [c for c in columns if c not in index]
    if missing:
        raise MissingColumnsError(f"{path}: frame {frame} has no columns {missing}; available: {list(names)}",
                                  missing=missing, available=list(names), path=path, frame=frame, byte=byte)
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
            "DumpFrame supports orthogonal boxes only",
            path=path, frame=frame, byte=h.offset, truncated=False,
        )
    return np.array(h.box, dtype=np.float64).reshape(3, 2)


def read_binary_dump(path: str | os.PathLike, columns: Sequence[str] | None = None, *,
                     select: Select | None = None) -> Iterator[DumpFrame]:
    """Read a LAMMPS binary custom dump frame by frame.

    The file is memory-mapped; each frame's chunks are viewed with
    :func:`numpy.frombuffer`, concatenated, reshaped to ``(natoms, size_one)``
    and copied column-wise (sorted by ``id`` when that column exists).

    Parameters
    ----------
    path : str or os.PathLike
        Binary dump written by ``dump ... custom N file.bin ...`` (LAMMPS >= 2021,
        format revision 2), whatever its name.
    columns : sequence of str, optional
        Column names to return, in this order. Default: all columns. The ``id``
        column is used for sorting even if not selected.
    select : callable, optional
        ``select(timestep) -> bool``; frames for which it is false are skipped
        after their header is checked, without touching their per-atom data.

    Yields
    ------
    DumpFrame
        One per frame, in file order. All columns are float64 (binary dumps
        store every value as a double), each a contiguous array of length natoms.
        ``time`` and ``units`` are filled when the dump has them.

    Raises
    ------
    DumpError
        If a frame is truncated or its header is corrupted; the message names
        the file, the frame index and the byte offset (also attributes, with
        ``truncated``). Frames before the bad one are yielded first. Also for
        triclinic boxes, which :class:`~postproc.frame.DumpFrame` cannot represent.
    MissingColumnsError
        (a :class:`KeyError`) if a requested column is absent from a frame.
    """
    spath = os.fspath(path)
    with open(spath, "rb") as fh:
        if os.fstat(fh.fileno()).st_size == 0:
            return
        mm = mmap.mmap(fh.fileno(), 0, access=mmap.ACCESS_READ)
    try:
        scanner = _BinaryScanner(spath, mm)
        units = None
        for frame, h in enumerate(scanner.headers()):
            units = h.units or units
            if select is not None and not select(h.timestep):
                continue
            box = _frame_box(spath, h, frame)
            picks = _picks(spath, frame, h.columns, columns, h.offset)
            cols = _columns_sorted(scanner.data(h), h.columns, picks)
            yield DumpFrame(timestep=h.timestep, box=box, boundary=_boundary_string(h.boundary), columns=cols,
                            time=h.time, units=units)
    finally:
        try:
            mm.close()
        except BufferError:  # a view still alive in a traceback; the GC closes it
            pass


# --------------------------------------------------------------------------- text


class _StreamError(Exception):
    """The gzip stream broke while reading (internal): ``truncated`` or corrupted."""

    def __init__(self, what: str, truncated: bool) -> None:
        super().__init__(what)
        self.truncated = truncated


class _Lines:
    """Binary line reader over a text or gzipped text dump that counts lines and bytes (internal).

    ``lineno`` is the number of lines read so far, ``pos`` the byte offset just
    past them (in the decompressed stream for gzip). Errors of the gzip stream
    become :class:`_StreamError`.
    """

    def __init__(self, path: str, fmt: str) -> None:
        self.gz = fmt == "gzip"
        self.fh = gzip.open(path, "rb") if self.gz else open(path, "rb")
        self.lineno = 0
        self.pos = 0

    def __enter__(self) -> "_Lines":
        return self

    def __exit__(self, *exc) -> None:
        self.fh.close()

    def _guard(self, call):
        try:
            return call()
        except EOFError as exc:  # gzip stream without its end marker
            raise _StreamError(f"the compressed stream ends early ({exc})", True) from None
        except (OSError, zlib.error) as exc:  # bad CRC, bad deflate data, BadGzipFile
            raise _StreamError(f"the compressed stream is corrupted ({exc})", False) from None

    def readline(self) -> bytes:
        line = self._guard(self.fh.readline)
        if line:
            self.lineno += 1
            self.pos += len(line)
        return line

    def lines(self, n: int) -> list[bytes]:
        lines = self._guard(lambda: list(itertools.islice(self.fh, n)))
        self.lineno += len(lines)
        self.pos += sum(map(len, lines))
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
    with _Lines(spath, fmt) as src:
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
        except _StreamError as exc:
            raise fail(f"is {'truncated' if exc.truncated else 'corrupted'}: {exc} after line {src.lineno}, "
                       f"byte {src.pos}", exc.truncated, ends=False) from None


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
        picks = _picks(spath, block.frame, block.names, columns, block.byte)
        yield DumpFrame(
            timestep=block.timestep,
            box=block.box,
            boundary=_boundary_string([c for pair in block.flags for c in pair]),
            columns=_columns_sorted(block.data, block.names, picks),
            time=block.time,
            units=block.units,
        )


# --------------------------------------------------------------------------- dispatch


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
        with _Lines(spath, fmt) as src:
            try:
                while line := src.readline():
                    if line.startswith(b"ITEM: TIMESTEP"):  # the frame starts at its UNITS/TIME items, if any
                        count, start, pending = count + 1, src.pos - len(line) if pending is None else pending, None
                    elif pending is None and line.startswith((b"ITEM: UNITS", b"ITEM: TIME")):
                        pending = src.pos - len(line)
            except _StreamError as exc:
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
            return sum(1 for _ in _BinaryScanner(spath, mm).headers())


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
        Time step.
    t_window : (float, float), optional
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
