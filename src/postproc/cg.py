"""Coarse-grain anyone's LAMMPS dumps: the Python API behind ``granflow cg``.

:func:`coarse_grain` streams the frames of one or more ``dump custom`` files
(text, gzipped text or binary, told apart by their content), optionally with the
contacts of ``dump local`` files, through a
:class:`~postproc.fields.FieldAccumulator` and returns time-averaged continuum
fields on a regular grid with standard errors over blocks of frames;
:func:`write_result` writes them as ``fields.csv``, ``meta.json`` and
``fields.vtr`` (a VTK rectilinear grid that ParaView opens).

The same as an object, in the manner of freud's computes and MDAnalysis'
analyses: :class:`CoarseGraining` holds the choices (a :class:`CGOptions`,
checked once, when made) and coarse-grains any dumps on
:meth:`CoarseGraining.compute`, frame by frame; :func:`coarse_grain` makes one
and calls it.

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

    from postproc.cg import CGOptions, CoarseGraining

    cg = CoarseGraining(CGOptions(coords="rz", axis=(0.05, 0.05), width=0.002, spacing=0.002))
    early, late = cg.compute(["dump.hopper.bin"], progress=sys.stderr), cg.compute(["dump.late.bin"])
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

from .cg_checks import StepOrder
from .cg_frames import (FrameTally, Progress, contact_frames, count_selected, first_frames, input_paths, paired,
                        particle_frames, possible_radii, sha256)
# the choices and the writers, re-exported: postproc.cg is the API (and describe_dropped, for the command)
from .cg_frames import describe_dropped  # noqa: F401
from .cg_options import (COORDINATES, DEFAULT_BLOCKS, DEFAULT_MAX_NODES, GAUSSIAN_CUTOFF, KERNELS,  # noqa: F401
                         CGOptions, FrameSelection, Grid, make_coordinates, make_grid, make_kernel, parse_numbers,
                         parse_ranges)
from .cg_output import OUTPUT_NAMES, CGInputError, check_outputs, write_result  # noqa: F401
from .contacts import ContactFrame
from .dump import DumpError, dump_format, missing_particle_columns
from .fields import FieldAccumulator, SparseGridWarning
from .frame import ParticleFrame

__all__ = [
    "COORDINATES",
    "KERNELS",
    "CGInputError",
    "FrameSelection",
    "Grid",
    "CGOptions",
    "CGResult",
    "CoarseGraining",
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


class CoarseGraining:
    """A coarse-graining: its choices held (:class:`CGOptions`), dumps taken by :meth:`compute`.

    The shape of freud's computes and of MDAnalysis' ``AnalysisBase``: the choices are
    given, and checked, once (``CoarseGraining(CGOptions(...))`` or
    ``CoarseGraining(coords=..., spacing=..., ...)``); :meth:`compute` then reads
    the frames through :meth:`_prepare` (the first selected frames: columns, box,
    axis, grid, kernel, the accumulator), :meth:`_single_frame` (one frame and its
    contacts) and :meth:`_conclude` (the fields, the warnings, the meta), and
    returns the :class:`CGResult`, also kept as :attr:`result` (None until a
    compute succeeds). One object may compute any number of times, on any dumps.
    """

    def __init__(self, options: CGOptions | None = None, /, **choices):
        if options is not None and choices:
            raise TypeError("give CoarseGraining either a CGOptions or the choices, not both")
        self.options = options if options is not None else CGOptions(**choices)
        self.result: CGResult | None = None

    def compute(self, dumps: Sequence[str | os.PathLike], contacts: Sequence[str | os.PathLike] = (), *,
                progress=None) -> CGResult:
        """Time-averaged coarse-grained fields of the ``dump custom`` files ``dumps`` (in time order).

        :func:`coarse_grain` says what the dumps need, what is refused and when.
        The result is also kept as :attr:`result` (None after a refused compute).

        Parameters
        ----------
        dumps : sequence of path
            ``dump custom`` files in time order (text, gzipped text or binary).
        contacts : sequence of path
            ``dump local`` files of ``compute pair/local`` with ``property/local``
            ids at the same steps as the atom frames (they give the contact stress).
        progress : file-like, optional
            A stream for a progress line (e.g. ``sys.stderr``), or None.

        Returns
        -------
        CGResult
            Fields in the units of the dump (:func:`coarse_grain`).

        Raises
        ------
        CGInputError
            For a missing file, a choice the first selected frames refuse, or an
            impossible value or unmatched contact frame as the frames are read.
        """
        start = time.perf_counter()
        self.result = None  # a refused compute leaves none
        self._prepare(*input_paths(dumps, contacts))
        total = count_selected(self._paths, self.options.frames) if (
            progress is not None and all(f == "binary" for f in self._formats)) else None
        bar = Progress(total, progress)
        tally = self._tally
        try:
            for frame, contact in self._frames():
                self._single_frame(frame, contact)
                bar.update(tally.n_frames, tally.n_particles, frame.timestep)
        except CGInputError:
            bar.abort()
            raise
        bar.update(tally.n_frames, tally.n_particles, tally.steps[-1] if tally.steps else 0, final=True)
        self.result = self._conclude(start)
        return self.result

    def _prepare(self, paths: list[str], contact_paths: list[str]) -> None:
        """Check the choices against the first selected frames; set up the grid, the kernel and the accumulator."""
        o = self.options
        self._paths, self._contact_paths = paths, contact_paths
        try:
            self._formats = [dump_format(p) for p in paths]
            self._contact_formats = [dump_format(p) for p in contact_paths]
            first, populated = first_frames(paths, o.frames)
        except DumpError as exc:
            raise CGInputError(str(exc)) from None
        names = list(first.columns)
        lacking = missing_particle_columns(names, o.density)
        if lacking:
            raise CGInputError(f"{paths[0]} lacks {'; '.join(lacking)}; the file has the columns {' '.join(names)}")
        if contact_paths and "id" not in first.columns:
            raise CGInputError(f"--contacts needs the atom ids: {paths[0]} has no 'id' column "
                               f"(columns: {' '.join(names)})")
        if o.species is not None and "type" not in first.columns:
            raise CGInputError(f"--species needs the atom types: {paths[0]} has no 'type' column "
                               f"(columns: {' '.join(names)})")
        box = np.asarray(first.box, dtype=float)
        self._units = first.units
        self._warnings: list[str] = []
        self._axis, self._axis_source = self._resolve_axis(box, first.timestep)
        self._coordinates = make_coordinates(o.coords, self._axis)
        self._grid, notes = make_grid(self._coordinates.names, o.spacing, o.ranges, box, self._axis, o.kernel)
        self._warnings += notes
        if self._grid.n_nodes > int(o.max_nodes):
            raise CGInputError(f"the grid has {self._grid.n_nodes} nodes ({self._grid.describe()}), over the budget "
                               f"of {int(o.max_nodes)}: use a coarser --spacing, a smaller --range or raise "
                               f"--max-nodes (memory grows as nodes x fields x {16 * int(o.n_blocks)} block sums)")
        radii = possible_radii(populated) if populated is not None else None
        if o.kernel != "heaviside" and radii is not None and radii.size and o.width < radii.min():
            raise CGInputError(
                f"--width {o.width:g} is below the smallest particle radius {radii.min():g} (frame at step "
                f"{populated.timestep}): a kernel narrower than a particle resolves single particles, not a "
                f"continuum; use a width of a radius or more (typically one to two diameters)")
        self._species = o.species
        if o.species == "auto":
            if populated is None:
                raise CGInputError("--species without ids: the first frames hold no atoms to take the types from; "
                                   "give them, e.g. --species 1,2")
            self._species = sorted({int(t) for t in np.rint(populated.columns["type"])})
        try:
            kernel = make_kernel(o.kernel, self._grid, o.width, o.cutoff)
        except ValueError as exc:
            raise CGInputError(str(exc)) from None
        self._accumulator = FieldAccumulator(kernel, self._coordinates, fields=_FIELDS, n_blocks=o.n_blocks,
                                             species=self._species, method=o.method, volume=o.volume)
        self._accumulator.prepare()
        self._tally = FrameTally()

    def _resolve_axis(self, box: np.ndarray, timestep: int) -> tuple[tuple[float, float] | None, str | None]:
        """The axis of ``r`` and ``rz`` (given, inside the box, or the box centre, with a warning) and its source."""
        coords, axis = self.options.coords, self.options.axis
        if coords not in ("r", "rz"):
            if axis is not None:
                raise CGInputError(f"--axis applies to --coords r and rz, not {coords}")
            return None, None
        if axis is None:
            axis = (0.5 * (box[0, 0] + box[0, 1]), 0.5 * (box[1, 0] + box[1, 1]))
            self._warnings.append(f"axis not given: using the centre of the box in x, y, ({axis[0]:g}, {axis[1]:g})")
            return axis, "box centre (no --axis given)"
        axis = (float(axis[0]), float(axis[1]))
        if not all(math.isfinite(a) for a in axis):
            raise CGInputError(f"--axis {axis} must be two finite numbers")
        if not (box[0, 0] <= axis[0] <= box[0, 1] and box[1, 0] <= axis[1] <= box[1, 1]):
            raise CGInputError(
                f"--axis {axis[0]:g},{axis[1]:g} lies outside the box (x in [{box[0, 0]:g}, {box[0, 1]:g}], "
                f"y in [{box[1, 0]:g}, {box[1, 1]:g}] at step {timestep})")
        return axis, "given"

    def _frames(self) -> Iterator[tuple[ParticleFrame, ContactFrame | None]]:
        """The selected atom frames, each with its contact frame (None without contact dumps)."""
        o, tally = self.options, self._tally
        self._order = (StepOrder(o.drop_repeated_steps), StepOrder(o.drop_repeated_steps, "contact frame"))
        particles = particle_frames(self._paths, o.frames, tally, density=o.density, drop_nonfinite=o.drop_nonfinite,
                                    allow_truncated=o.allow_truncated, order=self._order[0])
        contacts = (contact_frames(self._contact_paths, o.contact_roles, o.allow_truncated, self._order[1])
                    if self._contact_paths else None)
        return paired(particles, contacts, o.frames, lambda: tally.truncated is None)

    def _single_frame(self, frame: ParticleFrame, contact: ContactFrame | None) -> None:
        """Deposit one frame (and its contacts) and count it."""
        if contact is not None and contact.branch is None:
            contact = contact.with_branch(frame)
        try:
            self._accumulator.accumulate(frame, contact)
        except (ValueError, KeyError) as exc:
            raise CGInputError(f"frame at step {frame.timestep}: {exc}") from None
        n_inside = int(self._grid.contains(self._coordinates.points(frame)).sum()) if len(frame.mass) else 0
        self._tally.add(frame, n_inside)

    def _conclude(self, start: float) -> CGResult:
        """The fields of the frames read, the warnings on what they cover, the meta; ``start`` for the timing."""
        tally, grid = self._tally, self._grid
        if tally.n_frames == 0:
            raise CGInputError(f"no complete frame selected ({self.options.frames.describe()}) in "
                               f"{', '.join(self._paths)}")
        with _warnings.catch_warnings():  # reported below, with the centre counts
            _warnings.simplefilter("ignore", SparseGridWarning)
            table = self._accumulator.conclude()
        fields_table = _tidy(table, self._coordinates.names)
        warnings = self._warnings
        if tally.truncated:
            warnings.append(f"truncated input: {tally.truncated}; fields from the {tally.n_frames} complete "
                            f"frames before it")
        if tally.n_particles == 0:
            warnings.append(f"the {tally.n_frames} selected frames hold no particles: every field is empty")
        elif tally.n_inside < SPARSE_FRACTION * tally.n_particles:
            warnings.append(
                f"the grid is (nearly) empty: {tally.n_inside} of {tally.n_particles} particle-frames "
                f"({100.0 * tally.n_inside / tally.n_particles:.2g} %) have their centre inside {grid.describe()}; "
                + ("check --axis and --range" if self.options.coords in ("r", "rz") else "check --range"))
        empty_nodes = int((fields_table["n"] <= 0).sum()) if "n" in fields_table else 0
        if tally.n_particles and empty_nodes > 0.5 * grid.n_nodes:
            warnings.append(f"{empty_nodes} of {grid.n_nodes} nodes never held a particle's kernel weight")
        meta = self._meta(fields_table, time.perf_counter() - start)
        return CGResult(fields=fields_table, meta=meta, grid=grid, warnings=warnings)

    def _meta(self, fields_table: pd.DataFrame, elapsed: float) -> dict:
        """Inputs, frames, choices, units and warnings of the fields (``meta.json``)."""
        o, tally, grid, coordinates = self.options, self._tally, self._grid, self._coordinates
        inputs = [{"path": p, "role": "atoms", "format": f, "bytes": os.path.getsize(p), "sha256": sha256(p)}
                  for p, f in zip(self._paths, self._formats)]
        inputs += [{"path": p, "role": "contacts", "format": f, "bytes": os.path.getsize(p), "sha256": sha256(p)}
                   for p, f in zip(self._contact_paths, self._contact_formats)]
        timed = tally.n_timed == tally.n_frames
        return {
            "tool": "granflow cg (postproc.cg.coarse_grain)",
            "inputs": inputs,
            "frames": {
                "selection": o.frames.describe(),
                "count": tally.n_frames,
                "first_step": tally.steps[0],
                "last_step": tally.steps[-1],
                "step_intervals": sorted(tally.intervals),
                "first_time": tally.times[0] if timed else None,
                "last_time": tally.times[-1] if timed else None,
                "truncated": tally.truncated,
                "particle_frames": tally.n_particles,
                "particle_frames_in_grid": tally.n_inside,
                "dropped_nonfinite": tally.dropped if o.drop_nonfinite else None,
                "dropped_repeated_steps": ({"atom_frames": self._order[0].record(),
                                            "contact_frames": self._order[1].record()}
                                           if o.drop_repeated_steps else None),
            },
            "coordinates": {"choice": o.coords, "names": list(coordinates.names),
                            "components": list(getattr(coordinates, "components", ("x", "y", "z"))),
                            "axis": None if self._axis is None else list(self._axis),
                            "axis_source": self._axis_source},
            "kernel": {"name": o.kernel, "width": o.width, "cutoff": o.kernel_cutoff,
                       "width_means": {"gaussian": "standard deviation", "lucy": "range (zero beyond)",
                                       "heaviside": "unused: bins are the grid cells"}[o.kernel]},
            "grid": {"names": list(grid.names), "ranges": [list(r) for r in grid.ranges],
                     "spacing": list(grid.spacing), "nodes": list(grid.counts), "n_nodes": grid.n_nodes},
            "volume_fraction": o.volume,
            "density": o.density,
            "species": None if self._species is None else list(self._species),
            "fields": [c for c in fields_table.columns if not c.endswith("_se")],
            "omitted_fields": self._accumulator.omitted_fields,
            "standard_errors": (f"std over {min(o.n_blocks, tally.n_frames)} blocks of consecutive frames "
                                "/ sqrt(blocks)"),
            "stress_sign": "compressive positive",
            "units": (f"as the dump's: LAMMPS units {self._units}" if self._units else
                      "as the dump's (the dump does not name its units; dump_modify units yes would)"),
            "warnings": self._warnings,
            "elapsed_s": round(elapsed, 3),
            "particle_frames_per_s": round(tally.n_particles / elapsed, 1) if elapsed > 0 else None,
        }


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
    drop_repeated_steps: bool = False,
    progress=None,
    method: str = "auto",
) -> CGResult:
    """Time-averaged coarse-grained fields of LAMMPS dumps on a regular grid.

    ``CoarseGraining(CGOptions(coords=coords, spacing=spacing, ...)).compute(dumps,
    contacts, progress=progress)``, with the files checked first. Every choice is
    checked, against the first selected frame, before the frames are read; the
    frames are then streamed (memory does not grow with their number).

    Parameters
    ----------
    dumps : sequence of path
        ``dump custom`` files in time order (text, gzipped text or binary, any
        column order); they need positions (``x y z``, ``xu yu zu`` or
        ``xs ys zs``), ``vx vy vz``, ``radius`` or ``diameter``, and ``mass``
        unless ``density`` is given. ``id`` is needed with contacts, ``type``
        with species, ``omegax omegay omegaz`` for spin and temperature.
    contacts : sequence of path
        ``dump local`` files of ``compute pair/local`` with ``property/local``
        ids, at the same steps as the atom frames; they give the contact stress.
    progress : file-like, optional
        Stream for a progress line (e.g. ``sys.stderr``); None is silent.

    Other Parameters
    ----------------
    coords, spacing, axis, kernel, width, cutoff, ranges, contact_roles, species, frames, density, volume,
    n_blocks, max_nodes, allow_truncated, drop_nonfinite, drop_repeated_steps, method
        The choices, as :class:`~postproc.cg_options.CGOptions` documents them.

    Returns
    -------
    CGResult

    Raises
    ------
    CGInputError
        For any refused choice or input, before reading when it can be known then
        (an input that is not a readable, non-empty regular file, or one given
        twice, first, then the choices, then against the first frames); as the
        frames are read, a box bound that is not finite or a low bound not below
        its high one, a timestep not after the previous frame's (unless
        ``drop_repeated_steps``), a contact with a non-finite id, force or branch
        value or a branch longer than the box, an atom with a mass, radius or
        diameter :math:`\\le 0` or (unless ``drop_nonfinite``) a non-finite value,
        naming the file, the step, the atom ids and the column.
    """
    paths, contact_paths = input_paths(dumps, contacts)
    options = CGOptions(coords=coords, spacing=spacing, axis=axis, kernel=kernel, width=width, cutoff=cutoff,
                        ranges=ranges, contact_roles=contact_roles, species=species, frames=frames,
                        density=density, volume=volume, n_blocks=n_blocks, max_nodes=max_nodes,
                        allow_truncated=allow_truncated, drop_nonfinite=drop_nonfinite,
                        drop_repeated_steps=drop_repeated_steps, method=method)
    return CoarseGraining(options).compute(paths, contact_paths, progress=progress)


def _tidy(table: pd.DataFrame, names: Sequence[str]) -> pd.DataFrame:
    """Node coordinates first (named as the coordinates), velocity as ``v_<c>``, no bin bounds."""
    drop = [f"{n}_{s}" for n in names for s in ("lo", "hi")]
    table = table.drop(columns=[c for c in drop if c in table.columns])
    rename = {c: "v_" + c[2:] for c in table.columns if c.startswith("u_")}
    table = table.rename(columns=rename)
    ordered = list(names) + [c for c in table.columns if c not in names]
    return table[ordered].reset_index(drop=True)
