"""The heap's solids volume fraction in depth (Fan et al. 2013, §3.1, Fig. 4a).

Three readings of :math:`\\phi`, each from the frames of the averaging window:

* the static bed (:func:`static_bed_table`): the lab columns' :math:`\\phi` (bins
  :math:`\\Delta x \\times T \\times \\Delta z`, the paper's) between two depths under each frame's free
  surface, below the creeping region, at least :data:`BED_CLEARANCE` mean diameters above the base,
  in the columns downstream of the feed zone that do not touch the end wall; the paper finds
  :math:`f \\approx 0.65` there;
* :math:`\\phi(z)` through the heap (:func:`phi_profile_table`): the moving frame's volume-weighted
  :math:`\\phi` in bins as thin as the lab columns' (:func:`phi_profile_accumulator`), z normal to the
  surface and measured from each column's own free surface (:func:`.layer.local_surface`), with the
  base's highest position in the window; its fall in bands of depth (:func:`band_falls`) and above the
  surface (:func:`phi_above`);
* the free surface found with the cutoffs :math:`f_c` = 0.1 and 0.5 (:func:`surface_cutoff_table`):
  the paper's :math:`f_c = 0.35` moves the surface by at most one diameter over that range.

Lengths in m; :math:`\\delta` the flowing-layer thickness (0.1 :math:`u_s` cutoff, normal to the
surface), :math:`\\bar d` the mixture's number-mean diameter.
"""
from __future__ import annotations

import math

import numpy as np
import pandas as pd

from .kinematics import KinematicsAccumulator, MovingFrame
from .layer import local_surface, shift_to_surface
from postproc.overlap import slab_pairs

from .surface import PHI_C, HeapGeometry, bed_volume_fraction, centre_bins, free_surface, line_fit, uniform_edges

#: the cutoffs between which the paper's surface moves by at most one diameter (§3.1)
PHI_C_RANGE = (0.1, 0.5)
#: the static bed's top under the surface, in δ: below the creeping region, which the paper's Fig. 4a puts
#: 1-2 δ under the surface (x_lab = 0.1 m: flowing layer 0.185-0.2 m, creeping region 0.17-0.185 m)
BED_TOP = 2.0
#: its alternatives (the systematic error): the record's φ_bed of the mass balance (1.5 δ), and below the
#: creep row's −3 ≤ z/δ < −2 (3 δ)
BED_TOP_VARIANTS = (1.5, 3.0)
#: the bed's thickness under its top, d̄ (normal to the surface), and the clearance above the base, d̄
BED_THICKNESS = 20.0
BED_CLEARANCE = 2.0
#: the moving-frame φ profile's range, d̄ under and over the surface (3 δ ≈ 21 d̄ for δ ≈ 7 d̄)
PHI_PROFILE_RANGE = (-30.0, 15.0)
#: bands of depth, each end ``(a, b)`` at :math:`z = a\\delta + b\\bar d` from the column's surface:
#: the creeping region, the flowing layer under the top diameter, the top diameter (centred on the surface)
BANDS = {
    "creep": ((-2.0, 0.0), (-1.0, 0.0)),
    "layer": ((-1.0, 0.0), (0.0, -0.5)),
    "top": ((0.0, -0.5), (0.0, 0.5)),
}
#: fewest bins in a band for its line (the top diameter holds 3 bins of 0.33 d̄, 2 of 0.5 d̄)
MIN_BAND_BINS = 2
#: the range, d̄ about each frame's surface line, of the tilt-free columns (:func:`tilt_free_spans`)
TILT_FREE_RANGE = (-8.0, 8.0)


# --------------------------------------------------------------------------- the static bed
def bed_columns(x_edges, geometry: HeapGeometry) -> np.ndarray:
    """Lab columns of the static bed: centre more than one column downstream of the feed zone, not the last
    column (against the end wall). Boolean mask over the columns."""
    x_edges = np.asarray(x_edges, float)
    dx = x_edges[1:] - x_edges[:-1]
    keep = 0.5 * (x_edges[1:] + x_edges[:-1]) > geometry.x_feed + dx
    keep[-1] = False
    return keep


def static_bed_table(phis, z_s, x_edges, z_edges, geometry: HeapGeometry, *, delta: float, d_bar: float,
                     alpha_deg: float, tops=(BED_TOP, *BED_TOP_VARIANTS), thickness: float = BED_THICKNESS,
                     clearance: float = BED_CLEARANCE) -> pd.DataFrame:
    """:math:`\\phi` of the static bed per lab column, time-averaged, for each top of the bed.

    For each top :math:`k` (in δ) the bed of a frame's column is its bins lying between
    :math:`z_s - (k\\delta + t\\bar d)/\\cos\\alpha` and :math:`z_s - k\\delta/\\cos\\alpha` (depths normal to
    the surface, made vertical) and at least ``clearance`` :math:`\\bar d` above the base
    (:func:`.surface.bed_volume_fraction`, :math:`t` = ``thickness``); its :math:`\\phi` is averaged over
    the frames where the column has such bins.

    Parameters
    ----------
    phis : sequence of ndarray, each (n_x, n_z)
        Lab columns' φ per frame (:func:`.surface.volume_fraction_columns`).
    z_s : ndarray, shape (n_t, n_x)
        Each frame's free surface per column, m.
    x_edges, z_edges : ndarray
        The columns' edges, m.
    geometry : HeapGeometry
    delta, d_bar : float
        Flowing-layer thickness and mean diameter, m.
    alpha_deg : float
        Dynamic angle of repose, degrees.

    Returns
    -------
    DataFrame
        ``top_over_delta, depth_lo, depth_hi`` (vertical, m), ``x_lab, phi, n_frames``, one row per top
        and column of :func:`bed_columns`; ``phi`` NaN where no frame had bed bins.
    """
    x_edges = np.asarray(x_edges, float)
    keep = bed_columns(x_edges, geometry)
    xc = 0.5 * (x_edges[1:] + x_edges[:-1])
    cos_a = math.cos(math.radians(alpha_deg))
    z_base = geometry.z_base(x_edges[:-1])
    parts = []
    for k in tops:
        lo = k * delta / cos_a
        hi = lo + thickness * d_bar / cos_a
        total, count = np.zeros(len(xc)), np.zeros(len(xc))
        for phi, zs in zip(phis, z_s):
            bed = bed_volume_fraction(phi, z_edges, zs, lo, hi, z_base=z_base, clearance=clearance * d_bar)
            ok = np.isfinite(bed)
            total[ok] += bed[ok]
            count[ok] += 1
        mean = np.divide(total, count, out=np.full(len(xc), np.nan), where=count > 0)
        parts.append(pd.DataFrame({"top_over_delta": float(k), "depth_lo": lo, "depth_hi": hi, "x_lab": xc[keep],
                                   "phi": mean[keep], "n_frames": count[keep].astype(int)}))
    return pd.concat(parts, ignore_index=True)


def static_bed_phi(table: pd.DataFrame, top: float = BED_TOP) -> tuple[float, float, int]:
    """``(φ, standard error, columns)`` of the static bed with its top ``top`` δ under the surface: the mean over
    the columns of :func:`static_bed_table`, its error the columns' scatter :math:`s/\\sqrt n` (columns taken as
    independent); NaN without a column (the error without two)."""
    if table.empty or "top_over_delta" not in table:
        return float("nan"), float("nan"), 0
    v = table.loc[np.isclose(table["top_over_delta"], top), "phi"].to_numpy(float)
    v = v[np.isfinite(v)]
    if not len(v):
        return float("nan"), float("nan"), 0
    se = float(np.std(v, ddof=1) / math.sqrt(len(v))) if len(v) > 1 else float("nan")
    return float(v.mean()), se, int(len(v))


# --------------------------------------------------------------------------- the surface's cutoff
def tilt_free_spans(position, radius, z_s, x_edges, T: float, alpha_deg: float, dz: float, d_bar: float,
                    cutoffs=PHI_C_RANGE) -> np.ndarray:
    """One frame's :math:`\\Delta z_s = z_s(f_{c,lo}) - z_s(f_{c,hi})` per lab column, without the column's tilt.

    A column :math:`\\Delta x` wide under a surface sloping at :math:`\\alpha` spans :math:`\\Delta x\\tan\\alpha`
    of surface height, which a vertical profile of the column spreads its fall to 0 over. Here each particle's
    height is taken from the frame's own surface line (``z_s`` of the columns, linear between their centres),
    :math:`h = z - z_{line}(x)`, and φ is binned in (x, h): the shear keeps areas, and a sphere of radius r is
    spread over h as a sphere of radius :math:`r/\\cos\\alpha` (its extent normal to the line, made vertical),
    so each is split exactly over the h-slabs (:func:`postproc.overlap.slab_pairs`). The surface is found with
    each cutoff on these columns (:func:`.surface.free_surface`).

    Returns
    -------
    ndarray, shape (n_x,)
        :math:`\\Delta z_s`, m; NaN where either cutoff finds no surface or the frame has fewer than two.
    """
    position = np.asarray(position, float).reshape(-1, 3)
    radius = np.asarray(radius, float).ravel()
    x_edges = np.asarray(x_edges, float)
    xc = 0.5 * (x_edges[1:] + x_edges[:-1])
    z_s = np.asarray(z_s, float)
    ok = np.isfinite(z_s)
    if ok.sum() < 2:
        return np.full(len(xc), np.nan)
    h = position[:, 2] - np.interp(position[:, 0], xc[ok], z_s[ok])
    h_edges = uniform_edges(TILT_FREE_RANGE[0] * d_bar, TILT_FREE_RANGE[1] * d_bar, dz)
    p, ih, f = slab_pairs(h, radius / math.cos(math.radians(alpha_deg)), h_edges)
    ix = centre_bins(position[p, 0], x_edges)
    inside = ix >= 0
    n_h = len(h_edges) - 1
    vol = 4.0 / 3.0 * np.pi * radius[p] ** 3 * f
    total = np.bincount(ix[inside] * n_h + ih[inside], weights=vol[inside], minlength=len(xc) * n_h)
    phi = total.reshape(len(xc), n_h) / (np.outer(np.diff(x_edges), np.diff(h_edges)) * T)
    return free_surface(phi, h_edges, cutoffs[0]) - free_surface(phi, h_edges, cutoffs[1])


def surface_cutoff_table(phis, x_edges, z_edges, cutoffs=PHI_C_RANGE, tilt_free=None) -> pd.DataFrame:
    """The free surface of every frame and column found with the two ``cutoffs`` (:func:`.surface.free_surface`),
    and per column the statistics of their difference :math:`\\Delta z_s = z_s(f_{c,lo}) - z_s(f_{c,hi})`
    (positive: the lower cutoff finds the surface higher); with ``tilt_free`` (:func:`tilt_free_spans` of every
    frame, shape (n_t, n_x)) the same statistics of those.

    Returns
    -------
    DataFrame
        Per column: ``x_lab``, ``z_s_lo`` and ``z_s_hi`` (time means, m), ``span_mean`` and ``span_median``
        of :math:`\\Delta z_s` over the frames where both are found, ``span_se`` (the mean's error,
        :math:`s\\sqrt{g/n}` with the series' statistical inefficiency g; NaN with fewer than four frames),
        ``n_frames``, and ``span_tilt_free_mean``, ``span_tilt_free_median``, ``span_tilt_free_se``;
        ``attrs["cutoffs"]``.
    """
    lo_c, hi_c = cutoffs
    z_lo = np.vstack([free_surface(p, z_edges, lo_c) for p in phis])
    z_hi = np.vstack([free_surface(p, z_edges, hi_c) for p in phis])
    span = z_lo - z_hi
    tilt = np.full_like(span, np.nan) if tilt_free is None else np.asarray(tilt_free, float).reshape(span.shape)
    rows = []
    for j, x in enumerate(0.5 * (np.asarray(x_edges[1:], float) + np.asarray(x_edges[:-1], float))):
        row = {"x_lab": float(x), "z_s_lo": _mean(z_lo[:, j]), "z_s_hi": _mean(z_hi[:, j])}
        for prefix, series in (("span", span[:, j]), ("span_tilt_free", tilt[:, j])):
            row.update({f"{prefix}_{k}": v for k, v in _series_stats(series).items()})
        row["n_frames"] = int(np.isfinite(span[:, j]).sum())
        rows.append(row)
    out = pd.DataFrame(rows)
    out.attrs["cutoffs"] = (lo_c, hi_c)
    return out


def _series_stats(series) -> dict:
    """``mean, median, se`` of a frame series' finite values (se :math:`s\\sqrt{g/n}`, NaN under four)."""
    from postproc.autocorr import statistical_inefficiency

    s = np.asarray(series, float)
    s = s[np.isfinite(s)]
    nan = float("nan")
    se = nan
    if len(s) >= 4:
        g = statistical_inefficiency(s)
        se = float(np.std(s, ddof=1) * math.sqrt(max(1.0, g) / len(s))) if np.isfinite(g) else nan
    return {"mean": float(s.mean()) if len(s) else nan, "median": float(np.median(s)) if len(s) else nan, "se": se}


def _mean(v) -> float:
    v = np.asarray(v, float)
    v = v[np.isfinite(v)]
    return float(v.mean()) if len(v) else float("nan")


def surface_cutoff_max(table: pd.DataFrame, x_range, d: float, column: str = "span_mean") -> dict:
    """The largest :math:`|\\Delta z_s|/d` over the columns with centres inside ``x_range`` (open interval).

    Returns
    -------
    dict
        ``value`` (largest |column| over d), ``se`` (that column's ``span_se`` over d), ``x_lab`` (where),
        ``mean`` (the mean |column| over d), ``n`` (columns); NaN and 0 without a column.
    """
    nan = float("nan")
    out = {"value": nan, "se": nan, "x_lab": nan, "mean": nan, "n": 0}
    if table.empty or column not in table:
        return out
    sel = table[(table["x_lab"] > x_range[0]) & (table["x_lab"] < x_range[1]) & np.isfinite(table[column])]
    if sel.empty:
        return out
    a = sel[column].abs().to_numpy(float)
    i = int(np.argmax(a))
    se_column = column.rsplit("_", 1)[0] + "_se"
    return {"value": float(a[i] / d), "se": float(sel[se_column].iloc[i] / d) if se_column in sel else nan,
            "x_lab": float(sel["x_lab"].iloc[i]),
            "mean": float(a.mean() / d), "n": int(len(sel))}


# --------------------------------------------------------------------------- φ(z) through the heap
def phi_profile_accumulator(L: float, dx: float, dz: float, d_bar: float, T: float,
                            n_types: int = 1) -> KinematicsAccumulator:
    """A :class:`.kinematics.KinematicsAccumulator` for φ alone: the kinematics' streamwise bins (``dx`` from 0
    to L), z from :data:`PHI_PROFILE_RANGE` d̄ in bins ``dz`` thick (the lab columns' :math:`\\Delta z`); prepared."""
    acc = KinematicsAccumulator(uniform_edges(0.0, L, dx),
                                uniform_edges(PHI_PROFILE_RANGE[0] * d_bar, PHI_PROFILE_RANGE[1] * d_bar, dz),
                                T, n_types=n_types, n_blocks=2)
    acc.prepare()
    return acc


def base_height(moving: MovingFrame, geometry: HeapGeometry, t: float, x_edges, n: int = 4001) -> np.ndarray:
    """The base's highest z (normal to the surface, from the fitted plane) over each streamwise bin of the moving
    frame at time ``t``, m; NaN over a bin the base does not reach (beyond the end wall). The plane rises through
    the window, so the base is highest in the frame at the window's first time."""
    x_lab = np.linspace(0.0, geometry.W, n)
    points = np.column_stack([x_lab, np.zeros(n), geometry.z_base(x_lab)])
    x, z, _, _ = moving.transform(points, np.zeros_like(points), t)
    x_edges = np.asarray(x_edges, float)
    i = np.searchsorted(x_edges, x, side="right") - 1
    out = np.full(len(x_edges) - 1, np.nan)
    for k in range(len(out)):
        if np.any(i == k):
            out[k] = float(np.max(z[i == k]))
    return out


def phi_profile_table(profile: pd.DataFrame, base: np.ndarray, phi_c: float = PHI_C) -> pd.DataFrame:
    """φ(z) of every streamwise bin, z from the bin's own free surface (where its time-averaged φ falls through
    ``phi_c``, :func:`.layer.local_surface`), with the base's highest position on the same scale.

    Parameters
    ----------
    profile : DataFrame
        The φ accumulator's profile (:func:`phi_profile_accumulator`): ``x, z, z_lo, z_hi, phi``.
    base : ndarray
        :func:`base_height` of each streamwise bin, in the order of the profile's sorted ``x``.

    Returns
    -------
    DataFrame
        ``x, z, z_lo, z_hi, phi, z_surface`` (the local surface above the fitted plane), ``z_base`` (the base
        under the local surface, m; NaN where unknown).
    """
    offsets = local_surface(profile, phi_c)
    out = shift_to_surface(profile, offsets)[["x", "z", "z_lo", "z_hi", "phi"]].copy()
    xs = np.sort(profile["x"].unique())
    base_by_x = dict(zip(xs, np.asarray(base, float)))
    out["z_surface"] = out["x"].map(offsets).astype(float)
    out["z_base"] = out["x"].map(base_by_x).astype(float) - out["z_surface"]
    return out.sort_values(["x", "z"]).reset_index(drop=True)


def _key(x) -> np.ndarray:
    """Streamwise bin centres as merge keys (to 1 nm: a CSV's round trip changes the last digit)."""
    return np.round(np.asarray(x, float), 9)


def band_falls(phi_profile: pd.DataFrame, per_x: pd.DataFrame, d_bar: float, bands=None,
               clearance: float = BED_CLEARANCE) -> pd.DataFrame:
    """The fall of φ through each band of depth, per usable streamwise bin.

    In each bin with a usable flowing layer (``per_x``: ``x, x_over_L, delta, usable``), the least-squares
    line of φ on :math:`z/\\delta` over the profile's bins whose centres lie in the band (:data:`BANDS`: ends at
    :math:`a\\delta + b\\bar d`) and that lie at least ``clearance`` :math:`\\bar d` above the base gives

    .. math:: F = -\\frac{d\\phi}{d(z/\\delta)} ,

    positive where φ falls towards the surface. NaN with fewer than :data:`MIN_BAND_BINS` bins in the band.

    Returns
    -------
    DataFrame
        ``x, x_over_L, delta`` and one column per band.
    """
    bands = BANDS if bands is None else bands
    cols = ["x", "x_over_L", "delta", *bands]
    if phi_profile.empty or per_x.empty:
        return pd.DataFrame(columns=cols)
    px = per_x[per_x["usable"].astype(str).str.lower().isin(("true", "1", "1.0"))] if "usable" in per_x else per_x
    scale = dict(zip(_key(px["x"]), zip(px["x_over_L"].astype(float), px["delta"].astype(float))))
    rows = []
    for x, g in phi_profile.groupby(_key(phi_profile["x"])):
        if x not in scale:
            continue
        x_over_l, delta = scale[x]
        if not (np.isfinite(delta) and delta > 0):
            continue
        z, phi = g["z"].to_numpy(float), g["phi"].to_numpy(float)
        floor = g["z_base"].to_numpy(float) + clearance * d_bar if "z_base" in g else np.full(len(g), -np.inf)
        ok = np.isfinite(phi) & ~(g["z_lo"].to_numpy(float) < floor)
        row = {"x": float(g["x"].iloc[0]), "x_over_L": x_over_l, "delta": delta}
        for name, ((a0, b0), (a1, b1)) in bands.items():
            lo, hi = a0 * delta + b0 * d_bar, a1 * delta + b1 * d_bar
            sel = ok & (z >= lo) & (z <= hi)
            slope = line_fit(z[sel] / delta, phi[sel])[1] if sel.sum() >= MIN_BAND_BINS else float("nan")
            row[name] = -slope
        rows.append(row)
    return pd.DataFrame(rows, columns=cols)


def phi_above(phi_profile: pd.DataFrame, lo: float, hi: float, L: float) -> pd.DataFrame:
    """Mean φ over the bins with centres between ``lo`` and ``hi`` above each streamwise bin's own surface.

    Returns
    -------
    DataFrame
        ``x, x_over_L`` (``x/L``), ``phi_above``, one row per bin with a local surface.
    """
    if phi_profile.empty:
        return pd.DataFrame(columns=["x", "x_over_L", "phi_above"])
    rows = []
    for _, g in phi_profile.groupby(_key(phi_profile["x"])):
        if not np.isfinite(g["z_surface"].iloc[0]):
            continue
        sel = (g["z"] >= lo) & (g["z"] <= hi) & np.isfinite(g["phi"])
        x = float(g["x"].iloc[0])
        rows.append({"x": x, "x_over_L": x / L, "phi_above": float(g.loc[sel, "phi"].mean()) if sel.any() else np.nan})
    return pd.DataFrame(rows, columns=["x", "x_over_L", "phi_above"])
