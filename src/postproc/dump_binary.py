"""Reader of LAMMPS binary custom dumps (LAMMPS >= 2021, format revision 2).

The file is memory-mapped; :class:`BinaryScanner` walks and checks the frame
headers (the layout is documented in :mod:`postproc.dump`) and
:func:`read_binary_dump` yields one :class:`~postproc.frame.DumpFrame` per
frame. :mod:`postproc.dump` re-exports :func:`read_binary_dump`.
"""
from __future__ import annotations

import mmap
import os
import struct
from dataclasses import dataclass
from typing import Iterator, Sequence

import numpy as np

from .dump_common import MAGICS, Select, boundary_string, column_picks, columns_sorted
from .frame import DumpError, DumpFrame

_MAX_STRING = 1 << 20  # sanity limit for header strings (bytes)


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


class BinaryScanner:
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
        """Parse the frame starting at byte ``pos`` and check its chunks fit in the file.

        Parameters
        ----------
        pos : int
            Byte offset of the frame's start.
        frame : int
            0-based index of the frame (the byte order is detected at frame 0).

        Returns
        -------
        _BinaryHeader

        Raises
        ------
        DumpError
            If the header is truncated or corrupted, or its chunks run past the
            end of the file.
        """
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
            if any(m.startswith(magic) for m in ((expected,) if expected is not None else MAGICS)):
                raise self._fail(
                    frame, start, f"magic string at byte {pos} needs {-nmagic} bytes, file ends after {len(magic)}",
                    truncated=True,
                )
            raise self._fail(frame, start, f"is corrupted: bad magic string {magic!r} at byte {pos}")
        if (expected is not None and magic != expected) or (expected is None and magic not in MAGICS):
            want = expected if expected is not None else " or ".join(repr(m) for m in MAGICS)
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

        Parameters
        ----------
        h : _BinaryHeader
            A header of this buffer (:meth:`header`).

        Returns
        -------
        ndarray of float64, shape (natoms, size_one)
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
        scanner = BinaryScanner(spath, mm)
        units = None
        for frame, h in enumerate(scanner.headers()):
            units = h.units or units
            if select is not None and not select(h.timestep):
                continue
            box = _frame_box(spath, h, frame)
            picks = column_picks(spath, frame, h.columns, columns, h.offset)
            cols = columns_sorted(scanner.data(h), h.columns, picks)
            yield DumpFrame(timestep=h.timestep, box=box, boundary=boundary_string(h.boundary), columns=cols,
                            time=h.time, units=units)
    finally:
        try:
            mm.close()
        except BufferError:  # a view still alive in a traceback; the GC closes it
            pass
