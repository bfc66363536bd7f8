"""The heap's deposit: the small species' volume concentration of what the window laid down, read each
way a measurement could choose, and the upstream − downstream contrast (paper, figure 3)."""
from __future__ import annotations

import numpy as np
import pandas as pd

from .kinematics import MovingFrame
from .layer import column
from .surface import HeapGeometry, SurfaceFit, centre_bins, uniform_edges


def deposit_concentration(position, radius, type, fit: SurfaceFit, geometry: HeapGeometry,
                          t_start: float, t_end: float, delta: float, dx: float, *,
                          y_range=None, slab=None, weight=None) -> pd.DataFrame:
    """Small-particle volume concentration of the material deposited in a time window (paper, figure 3).

    The deposit of the window lies between the fitted surface at ``t_start``
    and the fitted surface at ``t_end`` lowered by the flowing-layer
    thickness :math:`\\delta` (measured normal to the surface, as everywhere
    in the paper; vertically :math:`\\delta/\\cos\\alpha`), which excludes the
    flowing layer. In the moving frame at ``t_end`` that is
    :math:`-v_r'(t_{end} - t_{start}) \\le z < -\\delta`. Per :math:`\\Delta x`
    column in :math:`x_{lab}` (from 0 to :math:`W`, particles by centre),

    .. math:: c_s = \\frac{\\sum_{type\\,1} V_j}{\\sum V_j} .

    Positions should come from a frame at or after ``t_end`` (the deposit is
    static by then). ``y_range=(y_lo, y_hi)`` restricts to a slice of the gap
    (the paper compares particles within :math:`2 d_l` of the front wall with
    experiments). ``slab=(k, n)`` keeps the k-th (from 0, oldest first) of n
    equal slabs of the deposit's depth, the material laid down in the k-th of n
    equal parts of the window: the deposit's statistical error
    (:func:`deposit_variants`). ``weight`` (one per particle, in [0, 1]) counts that
    share of each particle's volume, e.g. its fraction inside slices of the gap
    (:func:`.gap.deposit_gap`); a particle with weight 0 is not counted.

    Returns
    -------
    DataFrame
        ``x_lab`` (column centre), ``c_s`` (NaN in empty columns), ``n``
        (particles counted), ``volume`` (their volume, m^3).
    """
    position = np.asarray(position, dtype=float).reshape(-1, 3)
    radius = np.asarray(radius, dtype=float).ravel()
    kind = np.ones(len(radius), dtype=int) if type is None else np.asarray(type).astype(int).ravel()
    moving = MovingFrame(fit, geometry)
    _, z, _, _ = moving.transform(position, np.zeros_like(position), t_end)
    thickness = moving.v_r_normal * (t_end - t_start)
    lo, hi = -thickness, -delta
    if slab is not None:
        k, n = slab
        if not 0 <= k < n:
            raise ValueError(f"slab {k} of {n}: k must lie in [0, n)")
        lo, hi = lo + k * (hi - lo) / n, lo + (k + 1) * (hi - lo) / n
    inside = (z >= lo) & (z < hi)
    if y_range is not None:
        inside &= (position[:, 1] >= y_range[0]) & (position[:, 1] <= y_range[1])
    edges = uniform_edges(0.0, geometry.W, dx)
    col = centre_bins(position[:, 0], edges)
    inside &= col >= 0
    vol = 4.0 / 3.0 * np.pi * radius**3
    if weight is not None:
        weight = np.asarray(weight, dtype=float).ravel()
        vol = vol * weight
        inside &= weight > 0
    n_cols = len(edges) - 1
    total = np.bincount(col[inside], weights=vol[inside], minlength=n_cols)
    small = np.bincount(col[inside], weights=(vol * (kind == 1))[inside], minlength=n_cols)
    count = np.bincount(col[inside], minlength=n_cols)
    return pd.DataFrame({
        "x_lab": 0.5 * (edges[1:] + edges[:-1]),
        "c_s": np.divide(small, total, out=np.full(n_cols, np.nan), where=total > 0),
        "n": count,
        "volume": total,
    })


#: the deposit's slabs (equal parts of the averaging window) for its statistical error
DEPOSIT_SLABS = 4
#: the central reading's name in :func:`deposit_variants`
DEPOSIT_CENTRAL = "central"


def deposit_variants(position, radius, type, fit: SurfaceFit, geometry: HeapGeometry,
                     t_start: float, t_end: float, delta: float, dx: float, *, d_large: float,
                     slabs: int = DEPOSIT_SLABS) -> pd.DataFrame:
    """The deposit (:func:`deposit_concentration`) read each way a measurement could choose, each also by slab.

    Variants: ``central`` (the deposit from :math:`\\delta` below the surface, all of the gap, columns
    ``dx``); the deposit from :math:`1.5\\delta` and from :math:`0.5\\delta` below the surface (where
    the flowing layer ends is a choice: :math:`\\delta` is the 0.1 :math:`u_s` depth); the slice
    within :math:`2 d_l` of the front wall (the paper compares that slice with its experiments,
    §2.2); columns ``dx/2`` and ``2 dx``. Each variant whole (``slab`` 0) and in ``slabs`` equal
    slabs of its depth, oldest first (``slab`` 1 … n): the material of each part of the window,
    from whose spread :func:`deposit_contrast_error` takes the statistical error.

    Returns
    -------
    DataFrame
        ``variant, slab, x_lab, c_s, n, volume``.
    """
    if not (np.isfinite(delta) and delta > 0 and dx > 0 and d_large > 0 and slabs >= 2):
        raise ValueError(f"deposit variants need δ > 0, dx > 0, d_l > 0 and ≥ 2 slabs, got "
                         f"δ = {delta}, dx = {dx}, d_l = {d_large}, slabs = {slabs}")
    specs = {DEPOSIT_CENTRAL: {},
             "from 1.5 δ below the surface": {"delta": 1.5 * delta},
             "from 0.5 δ below the surface": {"delta": 0.5 * delta},
             "front-wall slice y < 2 d_l (the paper's comparison)": {"y_range": (0.0, 2.0 * d_large)},
             "columns dx/2": {"dx": 0.5 * dx},
             "columns 2 dx": {"dx": 2.0 * dx}}
    parts = []
    for name, spec in specs.items():
        kw = {"delta": delta, "dx": dx, **spec}
        for k in range(slabs + 1):
            dep = deposit_concentration(position, radius, type, fit, geometry, t_start, t_end, kw["delta"], kw["dx"],
                                        y_range=kw.get("y_range"), slab=None if k == 0 else (k - 1, slabs))
            parts.append(dep.assign(variant=name, slab=k))
    return pd.concat(parts, ignore_index=True)[["variant", "slab", "x_lab", "c_s", "n", "volume"]]


def deposit_contrast_error(variants: pd.DataFrame, variant: str, x_lo: float, x_hi: float,
                           weight: str = "volume") -> tuple[float, float, list]:
    """``(contrast, standard error, per-slab contrasts)`` of one variant of :func:`deposit_variants`.

    The contrast (:func:`deposit_contrast`) of the whole deposit; its error from the slabs' contrasts
    :math:`\\Delta_k` (the material of successive parts of the window),
    :math:`s(\\Delta_k)/\\sqrt{n}` over the n slabs with a finite contrast (NaN with fewer than 2).
    """
    rows = variants[variants["variant"] == variant]
    whole = deposit_contrast(rows[rows["slab"] == 0], x_lo, x_hi, weight)["contrast"]
    per = [deposit_contrast(rows[rows["slab"] == k], x_lo, x_hi, weight)["contrast"]
           for k in sorted(set(rows["slab"]) - {0})]
    ok = np.array([v for v in per if np.isfinite(v)])
    se = float(np.std(ok, ddof=1) / np.sqrt(len(ok))) if len(ok) >= 2 else float("nan")
    return float(whole), se, per


def deposit_contrast(deposit: pd.DataFrame, x_lo: float, x_hi: float, weight: str = "n") -> dict:
    """Small-particle concentration of the upstream half of the deposit minus the downstream half's.

    .. math:: \\Delta c_s = \\bar c_s(x_{lo} \\le x_{lab} < x_m) - \\bar c_s(x_m \\le x_{lab} \\le x_{hi}),
        \\qquad x_m = (x_{lo} + x_{hi})/2

    each half's :math:`\\bar c_s` weighted per column by ``weight``: ``n``, the particles
    counted, or ``volume``, their volume (the paper's concentration is by volume, so a half's
    :math:`\\bar c_s` is then its small particles' volume over its particles' volume;
    :func:`deposit_concentration`); positive when the small particles deposit upstream (paper,
    figure 3).

    Returns
    -------
    dict
        ``contrast, upstream, downstream, n`` (particles); NaN without particles in a half.
    """
    x, c, n, w = (column(deposit, k) for k in ("x_lab", "c_s", "n", weight))
    ok = (np.isfinite(x) & np.isfinite(c) & np.isfinite(n) & (n > 0) & np.isfinite(w) & (w > 0)
          & (x >= x_lo) & (x <= x_hi))
    mid = 0.5 * (x_lo + x_hi)
    halves = [ok & (x < mid), ok & (x >= mid)]
    up, down = (float(np.sum(c[h] * w[h]) / np.sum(w[h])) if h.any() else float("nan") for h in halves)
    return dict(contrast=up - down, upstream=up, downstream=down, n=int(np.sum(n[ok])) if ok.any() else 0)
