"""What ``granflow cg`` writes: ``fields.csv``, ``meta.json`` and ``fields.vtr`` of a :class:`postproc.cg.CGResult`,
and the check that none of them would replace an input or go through a link (moved out of :mod:`postproc.cg`,
which re-exports them). The three files are written under temporary names and moved into place together
(:mod:`postproc.safe_write`): an earlier result stays whole until the new one is complete."""
from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Iterable

import numpy as np

from .safe_write import output_refusal, staged_files

#: The files :func:`write_result` writes into its directory.
OUTPUT_NAMES = ("fields.csv", "meta.json", "fields.vtr")


class CGInputError(ValueError):
    """Input that :func:`coarse_grain` refuses; the message names the option, the value and what is allowed."""


def _same_file(a: Path, b: Path) -> bool:
    """Whether paths ``a`` and ``b`` name one file (after links; hard links too when both exist)."""
    if os.path.realpath(a) == os.path.realpath(b):
        return True
    try:
        return os.path.samefile(a, b)
    except OSError:
        return False


def check_outputs(out_dir: str | os.PathLike, inputs: Iterable[str | os.PathLike]) -> None:
    """Refuse an output directory whose writing would replace an input.

    Raises :class:`CGInputError` naming the input when ``out_dir`` is an input
    file, when one of the files :func:`write_result` writes there
    (:data:`OUTPUT_NAMES`) is an input (by name, through a symbolic link or as a
    hard link), or when ``out_dir`` exists and is not a directory; and naming
    the file when one of those names holds a symbolic link (dangling or not: an
    output never goes through one, nor replaces one) or anything but a regular
    file.

    Parameters
    ----------
    out_dir : str or os.PathLike
        The output directory (it need not exist).
    inputs : iterable of path
        The input files (atom and contact dumps).

    Raises
    ------
    CGInputError
        In the cases above.
    """
    out = Path(out_dir)
    for given in inputs:
        source = Path(given)
        if _same_file(out, source):
            raise CGInputError(f"--out {out} is the input {given}: granflow cg never writes over its input; "
                               f"choose a directory for the fields")
        for name in OUTPUT_NAMES:
            if _same_file(out / name, source):
                raise CGInputError(f"--out {out} would write {out / name} over the input {given}: granflow cg "
                                   f"never writes over its input; choose another --out")
    if out.exists() and not out.is_dir():
        raise CGInputError(f"--out {out} exists and is not a directory: choose a directory for the fields")
    for name in OUTPUT_NAMES:
        why = output_refusal(out / name)
        if why:
            raise CGInputError(f"--out {out}: {why}: granflow cg never writes through a link or over anything "
                               f"but its own regular files; remove it or choose another --out")


def write_result(result, out_dir: str | os.PathLike) -> dict[str, Path]:
    """Write ``fields.csv``, ``meta.json`` and ``fields.vtr`` of a :class:`postproc.cg.CGResult` into ``out_dir``.

    ``fields.vtr`` is a VTK rectilinear grid (written by ``pyevtk``) with one
    point array per column of the table; resolved coordinates map to the VTK
    axes x, y, z by name (``r`` to x), unresolved ones are a single layer at
    zero. Raises :class:`CGInputError` (:func:`check_outputs`), writing
    nothing, when that would replace one of the result's inputs or go through a
    link. The files are written under temporary names and moved into place
    only when all three are complete, so earlier ones stay as they were until then.

    Parameters
    ----------
    result : postproc.cg.CGResult
        Its ``meta["inputs"]`` names the inputs that must not be replaced.
    out_dir : str or os.PathLike
        Created (with its parents) if absent.

    Returns
    -------
    dict of str to pathlib.Path
        The paths written, by ``fields``, ``meta`` and ``vtk``.

    Raises
    ------
    CGInputError
        When writing would replace an input or go through a link (nothing is written).
    postproc.safe_write.OutputWriteError
        When a file cannot be written (a full disk, ...): it names the file, and
        the earlier files in ``out_dir`` are unchanged.
    """
    out = Path(out_dir)
    check_outputs(out, [entry["path"] for entry in result.meta.get("inputs", ())])
    paths = {"fields": out / "fields.csv", "meta": out / "meta.json", "vtk": out / "fields.vtr"}
    meta = dict(result.meta)
    meta["outputs"] = {k: p.name for k, p in paths.items()}
    text = json.dumps(meta, indent=2, default=_json_default) + "\n"
    with staged_files(out) as files:
        files.write("fields.csv", lambda tmp: result.fields.to_csv(tmp, index=False))
        files.write("fields.vtr", lambda tmp: _write_vtk(result, tmp.with_suffix("")))
        files.write("meta.json", lambda tmp: tmp.write_text(text, encoding="utf-8"))
    return paths


def _json_default(value):
    if isinstance(value, (np.integer,)):
        return int(value)
    if isinstance(value, (np.floating,)):
        return float(value)
    if isinstance(value, np.ndarray):
        return value.tolist()
    raise TypeError(f"cannot write {type(value).__name__} to JSON")


def _write_vtk(result, stem: Path) -> Path:
    from pyevtk.hl import gridToVTK

    grid = result.grid
    nodes = grid.nodes()
    vtk_axes = {"x": 0, "y": 1, "z": 2, "r": 0}
    axes = [np.zeros(1), np.zeros(1), np.zeros(1)]
    placement = []
    for name, node in zip(grid.names, nodes):
        k = vtk_axes[name]
        axes[k] = np.ascontiguousarray(node, dtype=float)
        placement.append(k)
    shape3 = [len(a) for a in axes]
    data = {}
    for column in result.fields.columns:
        if column in grid.names:
            continue
        values = result.fields[column].to_numpy(dtype=float).reshape(grid.shape)
        # move the resolved axes to their VTK positions, singleton elsewhere
        full = np.moveaxis(values.reshape(grid.shape + (1,) * (3 - len(grid.shape))),
                           list(range(len(grid.shape))), placement)
        data[column] = np.asfortranarray(full.reshape(shape3))
    return Path(gridToVTK(str(stem), *axes, pointData=data))
