"""Coarse-grain anyone's LAMMPS dumps: the Python API behind ``granflow cg``.

:func:`coarse_grain` streams the frames of one or more ``dump custom`` files
(text, gzipped text or binary, told apart by their content), optionally with the
contacts of ``dump local`` files, through a
:class:`~postproc.fields.FieldAccumulator` and returns time-averaged continuum
fields on a regular grid with standard errors over blocks of frames;
:func:`write_result` writes them as ``fields.csv``, ``meta.json`` and
``fields.vtr`` (a VTK rectilinear grid that ParaView opens).

Nothing here needs a granflow case directory: the inputs are the dump files and
the choices below, and every choice is written to ``meta.json``.

Choices
-------
coordinates
    ``x``, ``y``, ``z``, ``xy``, ``xz``, ``yz``, ``xyz`` resolve those Cartesian
    axes and integrate over the others (over the box); ``r`` resolves the distance
    from a vertical axis through :math:`(x_0, y_0)` and integrates over the
    azimuth and :math:`z`; ``rz`` resolves radius and height. Vectors and
    tensors are Cartesian, or in the cylindrical basis (``r t z``) for ``r`` and
    ``rz``.
kernel
    ``heaviside`` (bins of the grid spacing; volume fraction with the exact
    sphere-slab split as an option for one Cartesian axis), ``gaussian``
    (standard deviation ``width``, truncated at ``cutoff``, default
    :data:`GAUSSIAN_CUTOFF` widths) or ``lucy`` (Lucy's polynomial, ``width``
    is its range, where it falls to zero).
grid
    ``spacing`` and ``ranges`` per coordinate (one value for all, or one per
    coordinate in their order). Nodes are the centres of the cells of that
    spacing covering the range (the spacing is adjusted to a whole number of
    cells, and the adjusted value recorded). The default range is the box along
    a Cartesian axis and its height, and from the axis to the nearest side wall
    of the box for the radius.

Fields (columns of :attr:`CGResult.fields`): the node coordinates (named as the
coordinates), ``n`` (mean number of particles per node cell), ``phi`` (volume
fraction), ``rho`` (mass density), ``v_<c>`` (mass-weighted velocity
components), ``sigmak_<cc>`` and ``pk`` (kinetic stress and a third of its
trace), with contacts (or a per-atom ``c_stress[1..6]``) ``sigmac_<cc>``,
``pc``, ``sigma_<cc>``, ``p``; with angular velocities ``Omega_<c>`` and ``T``;
with species the partials ``rho_s<t>``, ``phi_s<t>``, ``sigmak_s<t>_<cc>``,
``pk_s<t>``; and ``<column>_se`` for each, the standard error over blocks of
consecutive frames (:mod:`postproc.fields` gives the definitions). Stresses are
compressive positive. Units are those of the dump.

Example
-------
.. code-block:: python

    from postproc.cg import coarse_grain, write_result

    result = coarse_grain(["dump.hopper.bin"], coords="rz", axis=(0.05, 0.05),
                          kernel="gaussian", width=0.002, spacing=0.002,
                          contacts=["dump.contacts"], frames="100000:200000")
    write_result(result, "cg_out")
    print(result.fields[["r", "z", "rho", "v_z"]])
"""
from __future__ import annotations

import math
import os
import time
import warnings as _warnings
from dataclasses import dataclass, field
from typing import Iterator, Sequence

import numpy as np
import pandas as pd

from .cg_frames import (  # noqa: F401 (describe_dropped re-exported: postproc.cg is the API)
    Progress,
    describe_dropped,
    first_frames,
    paired,
    possible_atoms,
    possible_radii,
    sha256,
)
from .cg_options import (  # noqa: F401 (the choices, re-exported: postproc.cg is the API)
    COORDINATES,
    DEFAULT_BLOCKS,
    DEFAULT_MAX_NODES,
    GAUSSIAN_CUTOFF,
    KERNELS,
    FrameSelection,
    Grid,
    make_coordinates,
    make_grid,
    make_kernel,
    parse_numbers,
    parse_ranges,
)
from .cg_output import (  # noqa: F401 (the writers, re-exported: postproc.cg is the API)
    OUTPUT_NAMES,
    CGInputError,
    check_outputs,
    write_result,
)
from .contacts import read_contact_dump
from .dump import DumpError, dump_format, missing_particle_columns, read_dump, read_dumps
from .fields import FieldAccumulator, SparseGridWarning
from .frame import ParticleFrame

__all__ = [
    "COORDINATES",
    "KERNELS",
    "CGInputError",
    "FrameSelection",
    "Grid",
    "CGResult",
    "coarse_grain",
    "write_result",
    "check_outputs",
    "OUTPUT_NAMES",
]

#: A grid holding fewer particle-frames than this fraction of those read is
#: reported as (mostly) empty.
SPARSE_FRACTION = 0.01


_FIELDS = ("n", "phi", "rho", "u", "Omega", "T", "sigmac", "sigmak", "sigma", "pk", "pc", "p")


# --------------------------------------------------------------------------- result


@dataclass
class CGResult:
    """Fields and the record of how they were made.

    Attributes
    ----------
    fields : pandas.DataFrame
        One row per node (C order over the coordinates, the last fastest).
    meta : dict
        Inputs, frames, choices, units and warnings (written as ``meta.json``).
    grid : Grid
    """

    fields: pd.DataFrame
    meta: dict
    grid: Grid
    warnings: list[str] = field(default_factory=list)


def coarse_grain(
    dumps: Sequence[str | os.PathLike],
    coords: str = "z",
    *,
    spacing,
    axis: tuple[float, float] | None = None,
    kernel: str = "gaussian",
    width: float | None = None,
    cutoff: float | None = None,
    ranges=None,
    contacts: Sequence[str | os.PathLike] = (),
    contact_roles: dict[str, str] | None = None,
    species=None,
    frames: str | FrameSelection | None = None,
    density: float | None = None,
    volume: str = "centre",
    n_blocks: int = DEFAULT_BLOCKS,
    max_nodes: int = DEFAULT_MAX_NODES,
    allow_truncated: bool = False,
    drop_nonfinite: bool = False,
    progress=None,
    method: str = "auto",
) -> CGResult:
    """Time-averaged coarse-grained fields of LAMMPS dumps on a regular grid.

    Every choice is checked, against the first selected frame, before the frames
    are read; the frames are then streamed (memory does not grow with their
    number).

    Parameters
    ----------
    dumps : sequence of path
        ``dump custom`` files in time order (text, gzipped text or binary, any
        column order); they need positions (``x y z``, ``xu yu zu`` or
        ``xs ys zs``), ``vx vy vz``, ``radius`` or ``diameter``, and ``mass``
        unless ``density`` is given. ``id`` is needed with contacts, ``type``
        with species, ``omegax omegay omegaz`` for spin and temperature.
    coords : str
        One of :data:`COORDINATES` (module docstring).
    spacing : float or sequence of float
        Node spacing, one for all coordinates or one per coordinate.
    axis : (float, float), optional
        :math:`(x_0, y_0)` of the vertical axis of ``r`` and ``rz``; default the
        centre of the box in :math:`x, y` (recorded in the meta and a warning).
    kernel : str
        One of :data:`KERNELS`.
    width : float
        Gaussian standard deviation, or Lucy's range; required for both, at least
        the smallest particle radius.
    cutoff : float, optional
        Gaussian truncation radius (default :data:`GAUSSIAN_CUTOFF` widths).
    ranges : (lo, hi) or sequence of (lo, hi), optional
        Grid range per coordinate (module docstring for the default).
    contacts : sequence of path
        ``dump local`` files of ``compute pair/local`` with ``property/local``
        ids, at the same steps as the atom frames; they give the contact stress.
    contact_roles : dict, optional
        Column name of each role (``id1 id2 dx dy dz fx fy fz`` ...), when the
        header does not say (:func:`postproc.contacts.read_contact_dump`).
    species : "auto" or sequence of int, optional
        Per-type partial fields; ``"auto"`` takes the types of the first frame
        holding atoms.
    frames : str or FrameSelection, optional
        ``START:STOP[:EVERY]`` in timesteps, STOP included.
    density : float, optional
        Particle material density, when the dump has no mass column.
    volume : {"centre", "exact"}
        Volume fraction from whole spheres at their centres, or (Heaviside bins
        along one Cartesian axis) from each sphere's exact split over the bins.
    n_blocks : int
        Blocks of consecutive frames for the standard errors.
    max_nodes : int
        Node budget; a larger grid is refused before reading.
    allow_truncated : bool
        On a truncated dump, keep the fields of the complete frames (with a
        warning) instead of refusing.
    drop_nonfinite : bool
        Leave out the atoms with a NaN or infinite position, velocity, spin,
        mass or radius (counted in ``meta["frames"]["dropped_nonfinite"]``:
        atom-frames, frames, the first step, per column) instead of refusing the
        input. A mass or radius :math:`\\le 0` is refused either way.
    progress : file-like, optional
        Stream for a progress line (e.g. ``sys.stderr``); None is silent.
    method : {"auto", "compiled", "numpy"}
        Deposit path (the compiled one is used for Gaussian ``rz`` by default).

    Returns
    -------
    CGResult

    Raises
    ------
    CGInputError
        For any refused choice or input, before reading when it can be known then;
        as the frames are read, an atom with a mass, radius or diameter
        :math:`\\le 0` or (unless ``drop_nonfinite``) a non-finite value, naming
        the file, the step, the atom id and the column.
    """
    t_start = time.perf_counter()
    paths = [os.fspath(p) for p in dumps]
    contact_paths = [os.fspath(p) for p in contacts or ()]
    if not paths:
        raise CGInputError("no dump file given")
    for p in paths + contact_paths:
        if not os.path.isfile(p):
            raise CGInputError(f"dump file {p} does not exist")
    if coords not in COORDINATES:
        raise CGInputError(f"--coords {coords!r} is not one of {', '.join(COORDINATES)}")
    if kernel not in KERNELS:
        raise CGInputError(f"--kernel {kernel!r} is not one of {', '.join(KERNELS)}")
    if kernel != "heaviside":
        if width is None:
            raise CGInputError(f"--width is required for the {kernel} kernel "
                               f"({'standard deviation' if kernel == 'gaussian' else 'range, where it falls to zero'})")
        if not (math.isfinite(width) and width > 0):
            raise CGInputError(f"--width {width} must be a positive finite length")
        if cutoff is not None and kernel == "gaussian" and not (math.isfinite(cutoff) and cutoff > 0):
            raise CGInputError(f"--cutoff {cutoff} must be a positive finite length")
    if volume not in ("centre", "exact"):
        raise CGInputError(f"volume {volume!r} is not 'centre' or 'exact'")
    if volume == "exact" and not (kernel == "heaviside" and coords in ("x", "y", "z")):
        raise CGInputError("--exact-volume needs --kernel heaviside and one Cartesian coordinate (x, y or z); "
                           f"got --kernel {kernel} --coords {coords}")
    if density is not None and not (math.isfinite(density) and density > 0):
        raise CGInputError(f"--density {density} must be a positive finite number")
    if int(n_blocks) < 2:
        raise CGInputError(f"--blocks {n_blocks} must be at least 2 for standard errors")
    select = frames if isinstance(frames, FrameSelection) else FrameSelection.parse(frames)

    try:
        formats = [dump_format(p) for p in paths]
        contact_formats = [dump_format(p) for p in contact_paths]
        first, populated = first_frames(paths, select)
    except DumpError as exc:
        raise CGInputError(str(exc)) from None
    names = list(first.columns)
    lacking = missing_particle_columns(names, density)
    if lacking:
        raise CGInputError(f"{paths[0]} lacks {'; '.join(lacking)}; the file has the columns {' '.join(names)}")
    if contact_paths and "id" not in first.columns:
        raise CGInputError(f"--contacts needs the atom ids: {paths[0]} has no 'id' column "
                           f"(columns: {' '.join(names)})")
    if species is not None and "type" not in first.columns:
        raise CGInputError(f"--species needs the atom types: {paths[0]} has no 'type' column "
                           f"(columns: {' '.join(names)})")
    box = np.asarray(first.box, dtype=float)
    warnings: list[str] = []
    axis_source = None
    if coords in ("r", "rz"):
        if axis is None:
            axis = (0.5 * (box[0, 0] + box[0, 1]), 0.5 * (box[1, 0] + box[1, 1]))
            axis_source = "box centre (no --axis given)"
            warnings.append(f"axis not given: using the centre of the box in x, y, ({axis[0]:g}, {axis[1]:g})")
        else:
            axis = (float(axis[0]), float(axis[1]))
            axis_source = "given"
            if not all(math.isfinite(a) for a in axis):
                raise CGInputError(f"--axis {axis} must be two finite numbers")
            if not (box[0, 0] <= axis[0] <= box[0, 1] and box[1, 0] <= axis[1] <= box[1, 1]):
                raise CGInputError(
                    f"--axis {axis[0]:g},{axis[1]:g} lies outside the box (x in [{box[0, 0]:g}, {box[0, 1]:g}], "
                    f"y in [{box[1, 0]:g}, {box[1, 1]:g}] at step {first.timestep})")
    elif axis is not None:
        raise CGInputError(f"--axis applies to --coords r and rz, not {coords}")
    coordinates = make_coordinates(coords, axis)
    grid, notes = make_grid(coordinates.names, spacing, ranges, box, axis, kernel)
    warnings += notes
    if grid.n_nodes > int(max_nodes):
        raise CGInputError(f"the grid has {grid.n_nodes} nodes ({grid.describe()}), over the budget of "
                           f"{int(max_nodes)}: use a coarser --spacing, a smaller --range or raise --max-nodes "
                           f"(memory grows as nodes x fields x {16 * int(n_blocks)} block sums)")
    radii = possible_radii(populated) if populated is not None else None
    if kernel != "heaviside" and radii is not None and radii.size and width < radii.min():
        raise CGInputError(
            f"--width {width:g} is below the smallest particle radius {radii.min():g} (frame at step "
            f"{populated.timestep}): a kernel narrower than a particle resolves single particles, not a "
            f"continuum; use a width of a radius or more (typically one to two diameters)")
    if species == "auto":
        if populated is None:
            raise CGInputError("--species without ids: the first frames hold no atoms to take the types from; "
                               "give them, e.g. --species 1,2")
        species = sorted({int(t) for t in np.rint(populated.columns["type"])})
    try:
        kernel_obj = make_kernel(kernel, grid, width, cutoff)
    except ValueError as exc:
        raise CGInputError(str(exc)) from None
    if kernel != "heaviside" and cutoff is None:
        cutoff = GAUSSIAN_CUTOFF * width if kernel == "gaussian" else width

    accumulator = FieldAccumulator(kernel_obj, coordinates, fields=_FIELDS, n_blocks=n_blocks,
                                   species=species, method=method, volume=volume)
    accumulator.prepare()

    total_frames = None
    if progress is not None and all(f == "binary" for f in formats):
        # count the selected frames from the headers alone (select says no to all)
        selected = []
        try:
            for _ in read_dumps(paths, select=lambda step: bool(selected.append(select(step)))):
                pass
            total_frames = sum(selected)
        except DumpError:
            total_frames = None
    bar = Progress(total_frames, progress)

    truncated = None
    n_frames = n_particles = n_inside = n_timed = 0
    dropped = {"atom_frames": 0, "frames": 0, "first_step": None, "columns": {}}
    steps: list[int] = []  # first and last only: nothing grows with the number of frames
    intervals: set[int] = set()
    times: list[float] = []
    units = first.units

    def particle_frames() -> Iterator[ParticleFrame]:
        nonlocal truncated
        try:
            for path in paths:
                for frame in read_dump(path, select=select):
                    frame, columns, n_dropped = possible_atoms(path, frame, drop_nonfinite)
                    if n_dropped:
                        dropped["atom_frames"] += n_dropped
                        dropped["frames"] += 1
                        if dropped["first_step"] is None:
                            dropped["first_step"] = int(frame.timestep)
                        for k, n in columns.items():
                            dropped["columns"][k] = dropped["columns"].get(k, 0) + n
                    yield ParticleFrame.from_dump(frame, density=density)
        except DumpError as exc:
            if getattr(exc, "truncated", False) and allow_truncated:
                truncated = str(exc)
                return
            hint = " (--allow-truncated keeps the fields of the complete frames)" if getattr(exc, "truncated", False) else ""
            raise CGInputError(f"{exc}{hint}") from None

    contact_stream = None
    if contact_paths:
        def contact_frames():
            try:
                for p in contact_paths:
                    yield from read_contact_dump(p, roles=contact_roles)
            except DumpError as exc:
                if getattr(exc, "truncated", False) and allow_truncated:
                    return
                raise CGInputError(str(exc)) from None
        contact_stream = contact_frames()

    try:
        for frame, contact in paired(particle_frames(), contact_stream, select, lambda: truncated is None):
            if contact is not None and contact.branch is None:
                contact = contact.with_branch(frame)
            try:
                accumulator.accumulate(frame, contact)
            except (ValueError, KeyError) as exc:
                raise CGInputError(f"frame at step {frame.timestep}: {exc}") from None
            n_frames += 1
            n_particles += len(frame.mass)
            if len(frame.mass):
                n_inside += int(grid.contains(coordinates.points(frame)).sum())
            if steps:
                if len(intervals) < 16:
                    intervals.add(int(frame.timestep) - steps[-1])
                steps[1:] = [int(frame.timestep)]
            else:
                steps.append(int(frame.timestep))
            if frame.time is not None:
                n_timed += 1
                times[min(len(times), 1):] = [float(frame.time)]
            bar.update(n_frames, n_particles, frame.timestep)
    except CGInputError:
        bar.abort()
        raise
    bar.update(n_frames, n_particles, steps[-1] if steps else 0, final=True)
    if n_frames == 0:
        raise CGInputError(f"no complete frame selected ({select.describe()}) in {', '.join(paths)}")
    with _warnings.catch_warnings():  # reported below, with the centre counts
        _warnings.simplefilter("ignore", SparseGridWarning)
        table = accumulator.conclude()
    fields_table = _tidy(table, coordinates.names)

    if truncated:
        warnings.append(f"truncated input: {truncated}; fields from the {n_frames} complete frames before it")
    if n_particles == 0:
        warnings.append(f"the {n_frames} selected frames hold no particles: every field is empty")
    elif n_inside < SPARSE_FRACTION * n_particles:
        warnings.append(
            f"the grid is (nearly) empty: {n_inside} of {n_particles} particle-frames "
            f"({100.0 * n_inside / n_particles:.2g} %) have their centre inside {grid.describe()}; "
            + ("check --axis and --range" if coords in ("r", "rz") else "check --range"))
    empty_nodes = int((fields_table["n"] <= 0).sum()) if "n" in fields_table else 0
    if n_particles and empty_nodes > 0.5 * grid.n_nodes:
        warnings.append(f"{empty_nodes} of {grid.n_nodes} nodes never held a particle's kernel weight")

    elapsed = time.perf_counter() - t_start
    inputs = [{"path": p, "role": "atoms", "format": f, "bytes": os.path.getsize(p), "sha256": sha256(p)}
              for p, f in zip(paths, formats)]
    inputs += [{"path": p, "role": "contacts", "format": f, "bytes": os.path.getsize(p), "sha256": sha256(p)}
               for p, f in zip(contact_paths, contact_formats)]
    meta = {
        "tool": "granflow cg (postproc.cg.coarse_grain)",
        "inputs": inputs,
        "frames": {
            "selection": select.describe(),
            "count": n_frames,
            "first_step": steps[0],
            "last_step": steps[-1],
            "step_intervals": sorted(intervals),
            "first_time": times[0] if n_timed == n_frames else None,
            "last_time": times[-1] if n_timed == n_frames else None,
            "truncated": truncated,
            "particle_frames": n_particles,
            "particle_frames_in_grid": n_inside,
            "dropped_nonfinite": dropped if drop_nonfinite else None,
        },
        "coordinates": {"choice": coords, "names": list(coordinates.names),
                        "components": list(getattr(coordinates, "components", ("x", "y", "z"))),
                        "axis": None if axis is None else list(axis), "axis_source": axis_source},
        "kernel": {"name": kernel, "width": width, "cutoff": cutoff,
                   "width_means": {"gaussian": "standard deviation", "lucy": "range (zero beyond)",
                                   "heaviside": "unused: bins are the grid cells"}[kernel]},
        "grid": {"names": list(grid.names), "ranges": [list(r) for r in grid.ranges],
                 "spacing": list(grid.spacing), "nodes": list(grid.counts), "n_nodes": grid.n_nodes},
        "volume_fraction": volume,
        "density": density,
        "species": None if species is None else list(species),
        "fields": [c for c in fields_table.columns if not c.endswith("_se")],
        "omitted_fields": accumulator.omitted_fields,
        "standard_errors": f"std over {min(n_blocks, n_frames)} blocks of consecutive frames / sqrt(blocks)",
        "stress_sign": "compressive positive",
        "units": (f"as the dump's: LAMMPS units {units}" if units else
                  "as the dump's (the dump does not name its units; dump_modify units yes would)"),
        "warnings": warnings,
        "elapsed_s": round(elapsed, 3),
        "particle_frames_per_s": round(n_particles / elapsed, 1) if elapsed > 0 else None,
    }
    return CGResult(fields=fields_table, meta=meta, grid=grid, warnings=warnings)


def _tidy(table: pd.DataFrame, names: Sequence[str]) -> pd.DataFrame:
    """Node coordinates first (named as the coordinates), velocity as ``v_<c>``, no bin bounds."""
    drop = [f"{n}_{s}" for n in names for s in ("lo", "hi")]
    table = table.drop(columns=[c for c in drop if c in table.columns])
    rename = {c: "v_" + c[2:] for c in table.columns if c.startswith("u_")}
    table = table.rename(columns=rename)
    ordered = list(names) + [c for c in table.columns if c not in names]
    return table[ordered].reset_index(drop=True)
