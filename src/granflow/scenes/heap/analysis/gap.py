"""Across the gap: the surface velocity and the deposit's concentration in slices of y (Fan et al. 2013,
Appendix 1, Fig. A.12).

The paper averages :math:`u_s` over "4 mm thick slices in the y-direction adjacent to both side walls" and
over "the central region of the heap (4 < y < 8.7 mm)" of its T = 13 mm gap, and compares them with the
gap's mean; it plots the deposit's :math:`c_s(x)` the same way. The slices here are those fractions of the
case's gap T (:data:`WALL_SLICE`, :data:`CENTRE_SLICE`), the paper's millimetres at T = 13 mm.

* :class:`GapKinematics` accumulates the moving frame's kinematics of the particles whose centres lie in
  each slice (the record's bins; each slice's φ over its own width);
* :func:`gap_surface_velocity` reads :math:`u_s` of each slice in each streamwise bin, z measured from the
  bin's free surface as the record's (:func:`.layer.shift_to_surface`);
* :func:`deposit_gap` gives the deposit's :math:`c_s` per column in each slice (:func:`.deposit.deposit_concentration`
  with each particle's volume fraction inside the slice) and :func:`gap_contrast` the wall slices' minus the
  centre's, upstream and downstream.
"""
from __future__ import annotations

import numpy as np
import pandas as pd

from postproc.frame import ParticleFrame
from postproc.overlap import sphere_slab_fraction

from .deposit import deposit_concentration
from .kinematics import KinematicsAccumulator, MovingFrame, surface_velocity
from .layer import shift_to_surface
from .surface import HeapGeometry, SurfaceFit

#: the paper's gap, m, and its slices as fractions of it: 4 mm at each side wall, the centre 4 < y < 8.7 mm
PAPER_GAP = 0.013
WALL_SLICE = 0.004 / PAPER_GAP
CENTRE_SLICE = (0.004 / PAPER_GAP, 0.0087 / PAPER_GAP)
#: where the paper's c_s changes its spanwise behaviour: x_lab/W = 0.6
CS_SPLIT = 0.6
#: the deposit's slabs (equal parts of the window) for the statistical error, as the record's deposit
GAP_SLABS = 4


def slices(T: float) -> dict[str, list[tuple[float, float]]]:
    """The y intervals, m, of the slices of a gap ``T``: ``wall`` (both side walls) and ``centre``."""
    w = WALL_SLICE * T
    return {"wall": [(0.0, w), (T - w, T)], "centre": [(CENTRE_SLICE[0] * T, CENTRE_SLICE[1] * T)]}


def slice_width(intervals) -> float:
    """Total width of a slice's intervals, m."""
    return float(sum(hi - lo for lo, hi in intervals))


def slice_share(y, radius, intervals, exact: bool = True) -> np.ndarray:
    """Each particle's share of its volume inside the slice: exactly (the spherical caps,
    :func:`postproc.overlap.sphere_slab_fraction`) or 1 when its centre lies inside (``exact=False``)."""
    y, radius = np.asarray(y, float).ravel(), np.asarray(radius, float).ravel()
    if exact:
        return sum(sphere_slab_fraction(y, radius, lo, hi) for lo, hi in intervals)
    return np.any([(y >= lo) & (y < hi) for lo, hi in intervals], axis=0).astype(float)


class GapKinematics:
    """The moving frame's kinematics of each slice of the gap (:func:`slices`), particles by their centres.

    One :class:`.kinematics.KinematicsAccumulator` per slice, with the record's bin edges and the slice's
    width as its T (so a slice's φ is its own; u is a ratio of volume sums and does not depend on it).
    Lifecycle: :meth:`prepare`, :meth:`accumulate` per frame, :meth:`conclude`.
    """

    def __init__(self, x_edges, z_edges, T: float, n_types: int = 1, n_blocks: int = 8):
        self.intervals = slices(T)
        self.accumulators = {name: KinematicsAccumulator(x_edges, z_edges, slice_width(iv), n_types=n_types,
                                                         n_blocks=n_blocks)
                             for name, iv in self.intervals.items()}

    def prepare(self) -> None:
        for acc in self.accumulators.values():
            acc.prepare()

    def accumulate(self, frame: ParticleFrame, moving: MovingFrame, dt: float) -> None:
        """One frame (time ``timestep * dt``): each slice gets the particles whose centres lie in it."""
        x, z, u, w = moving.transform(frame.position, frame.velocity, frame.timestep * dt)
        y = np.asarray(frame.position, float).reshape(-1, 3)[:, 1]
        kind = frame.type if frame.type is not None else np.ones(len(y), int)
        for name, acc in self.accumulators.items():
            inside = slice_share(y, frame.radius, self.intervals[name], exact=False) > 0
            acc.accumulate(x[inside], z[inside], u[inside], w[inside], np.asarray(frame.radius)[inside],
                           np.asarray(kind)[inside])

    def conclude(self) -> dict[str, pd.DataFrame]:
        """Each slice's profile (:meth:`.kinematics.KinematicsAccumulator.conclude`)."""
        return {name: acc.conclude() for name, acc in self.accumulators.items()}


def gap_surface_velocity(profiles: dict[str, pd.DataFrame], per_x: pd.DataFrame,
                         offsets: pd.Series | None = None) -> pd.DataFrame:
    """:math:`u_s` of each slice per streamwise bin, beside the gap's (``per_x``'s ``u_s``).

    Each slice's profile is measured from the same origin as the record's (``offsets``: the local surface
    above the fitted plane by ``x``, :func:`.layer.local_surface`; None for the plane) and its
    :math:`u_s = u(z = 0)` read as the gap's (:func:`.kinematics.surface_velocity`).

    Returns
    -------
    DataFrame
        ``x, x_over_L, usable, u_s`` (the gap's) and ``u_s_<slice>`` for each slice.
    """
    out = per_x[["x", "x_over_L", "usable", "u_s"]].copy().reset_index(drop=True)
    keys = np.round(out["x"].to_numpy(float), 9)
    for name, prof in profiles.items():
        shifted = shift_to_surface(prof, offsets) if offsets is not None else prof
        us = {round(float(x), 9): surface_velocity(g["z"], g["u"]) for x, g in shifted.groupby("x")}
        out[f"u_s_{name}"] = [us.get(k, np.nan) for k in keys]
    return out


def deposit_gap(position, radius, type, fit: SurfaceFit, geometry: HeapGeometry, t_start: float, t_end: float,
                delta: float, dx: float, *, slabs: int = GAP_SLABS) -> pd.DataFrame:
    """The deposit's small-particle concentration per column in each slice of the gap, read each way a
    measurement could choose, each whole and by slab (as :func:`.deposit.deposit_variants`).

    Variants: ``central`` (the deposit from δ below the surface, each particle's volume split exactly over
    the slices), ``y by centre`` (a particle counted whole in the slice holding its centre), the deposit from
    1.5 δ and from 0.5 δ below the surface.

    Returns
    -------
    DataFrame
        ``variant, slice, slab, x_lab, c_s, n, volume``.
    """
    position = np.asarray(position, float).reshape(-1, 3)
    specs = {"central": (1.0, True), "y by centre": (1.0, False),
             "from 1.5 δ below the surface": (1.5, True), "from 0.5 δ below the surface": (0.5, True)}
    parts = []
    for variant, (depth, exact) in specs.items():
        for name, intervals in slices(geometry.T).items():
            share = slice_share(position[:, 1], radius, intervals, exact)
            for k in range(slabs + 1):
                dep = deposit_concentration(position, radius, type, fit, geometry, t_start, t_end, depth * delta, dx,
                                            slab=None if k == 0 else (k - 1, slabs), weight=share)
                parts.append(dep.assign(variant=variant, slice=name, slab=k))
    return pd.concat(parts, ignore_index=True)[["variant", "slice", "slab", "x_lab", "c_s", "n", "volume"]]


def _pooled(rows: pd.DataFrame) -> float:
    """The volume-weighted c_s of columns (their small particles' volume over their volume)."""
    ok = np.isfinite(rows["c_s"]) & (rows["volume"] > 0)
    w = rows.loc[ok, "volume"].to_numpy(float)
    return float(np.sum(rows.loc[ok, "c_s"].to_numpy(float) * w) / np.sum(w)) if w.sum() > 0 else float("nan")


def gap_contrast(table: pd.DataFrame, variant: str, x_lo: float, x_split: float, x_hi: float) -> dict:
    """The wall slices' c_s minus the centre's, upstream (``x_lo <= x_lab < x_split``) and downstream
    (``x_split <= x_lab <= x_hi``), each pooled by volume over the region's columns.

    .. math:: \\Delta c_s = \\bar c_{s,wall} - \\bar c_{s,centre}

    Returns
    -------
    dict
        ``{"upstream": {...}, "downstream": {...}}``, each ``contrast``, ``se`` (the slabs' contrasts'
        :math:`s/\\sqrt n`, NaN with fewer than two), ``per_slab``, ``wall``, ``centre``.
    """
    rows = table[table["variant"] == variant]
    regions = {"upstream": (rows["x_lab"] >= x_lo) & (rows["x_lab"] < x_split),
               "downstream": (rows["x_lab"] >= x_split) & (rows["x_lab"] <= x_hi)}
    out = {}
    for region, inside in regions.items():
        part = rows[inside]

        def contrast(k):
            c = {s: _pooled(part[(part["slice"] == s) & (part["slab"] == k)]) for s in ("wall", "centre")}
            return c["wall"] - c["centre"], c

        whole, c = contrast(0)
        per = [contrast(k)[0] for k in sorted(set(part["slab"]) - {0})]
        ok = np.array([v for v in per if np.isfinite(v)])
        se = float(np.std(ok, ddof=1) / np.sqrt(len(ok))) if len(ok) >= 2 else float("nan")
        out[region] = {"contrast": whole, "se": se, "per_slab": per, "wall": c["wall"], "centre": c["centre"]}
    return out
