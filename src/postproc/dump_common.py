"""What the LAMMPS dump readers share: the kind of a dump and the columns of a frame.

:func:`dump_format` tells a binary, text or gzipped text dump from the file's
first bytes; :data:`Select` is the per-frame filter type of every reader;
:func:`column_picks`, :func:`columns_sorted` and :func:`boundary_string` turn a
frame's values into the columns of a :class:`~postproc.frame.DumpFrame` for
both :mod:`postproc.dump_binary` and :mod:`postproc.dump_text`.
:mod:`postproc.dump` (formats, errors) re-exports the public names.
"""
from __future__ import annotations

import os
import struct
import zlib
from typing import Callable, Sequence

import numpy as np

from .frame import DumpError, MissingColumnsError

MAGICS = (b"DUMPCUSTOM", b"DUMPATOM")
_BOUNDARY_LETTERS = "pfsm"
_GZIP_MAGIC = b"\x1f\x8b"
_PEEK = 4096  # bytes read by dump_format

#: Optional per-frame filter on the timestep: ``select(timestep) -> bool``.
Select = Callable[[int], bool]


def boundary_string(codes: Sequence[int] | Sequence[str]) -> str:
    """Turn six lo/hi boundary letters into LAMMPS ``boundary`` style, e.g. ``"p p fs"``.

    Parameters
    ----------
    codes : sequence of int or sequence of str
        Six codes ``xlo xhi ylo yhi zlo zhi``: binary-dump integers (0 p, 1 f, 2 s,
        3 m) or letters.

    Returns
    -------
    str
        One word per dimension: its letter, or the two letters when lo and hi differ.
    """
    letters = [c if isinstance(c, str) else _BOUNDARY_LETTERS[c] for c in codes]
    dims = []
    for lo, hi in zip(letters[0::2], letters[1::2]):
        dims.append(lo if lo == hi else lo + hi)
    return " ".join(dims)


# --------------------------------------------------------------------------- format


def _binary_start(head: bytes) -> bool:
    """Whether ``head`` starts like a LAMMPS >= 2021 binary dump (or is a cut-short start of one)."""
    for order in ("<", ">"):
        for magic in MAGICS:
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


# --------------------------------------------------------------------------- columns


def column_picks(path: str, frame: int, names: Sequence[str], columns: Sequence[str] | None,
           byte: int | None = None) -> list[int]:
    """Indices of the requested columns, in the requested order.

    Parameters
    ----------
    path : str
        The dump, to name in the message.
    frame : int
        0-based frame index, to name in the message.
    names : sequence of str
        The frame's column names, in file order.
    columns : sequence of str or None
        The columns wanted; None for all, in file order.
    byte : int, optional
        Byte offset of the frame, for the error.

    Returns
    -------
    list of int

    Raises
    ------
    MissingColumnsError
        If a wanted column is not among ``names``.
    """
    if columns is None:
        return list(range(len(names)))
    index = {name: i for i, name in enumerate(names)}
    missing = [c for c in columns if c not in index]
    if missing:
        raise MissingColumnsError(f"{path}: frame {frame} has no columns {missing}; available: {list(names)}",
                                  missing=missing, available=list(names), path=path, frame=frame, byte=byte)
    return [index[c] for c in columns]


def columns_sorted(data: np.ndarray, names: Sequence[str], picks: Sequence[int]) -> dict[str, np.ndarray]:
    """Copy the picked columns of ``data`` into contiguous float64 arrays sorted by ``id``.

    Parameters
    ----------
    data : ndarray, shape (natoms, n_columns)
        The frame's values in file order.
    names : sequence of str
        Column names of ``data``.
    picks : sequence of int
        Indices of the columns to copy (:func:`column_picks`).

    Returns
    -------
    dict of str to ndarray
        One float64 array of length natoms per picked column, by name, with the
        atoms in order of ``id`` when that column exists (a stable sort, skipped
        when already increasing).
    """
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
