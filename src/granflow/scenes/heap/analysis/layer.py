"""The flowing layer of the heap: thickness by three methods, fits, scalings along the heap (the deposit: deposit.py)."""
from __future__ import annotations

from typing import NamedTuple

import numpy as np
import pandas as pd
from scipy.optimize import curve_fit

from .kinematics import MovingFrame, finite_profile, surface_tolerance, surface_velocity
from .surface import (
    PHI_C,
    CUTOFF_FRACTION,
    DELTA_MEAN_RANGE,
    EXPONENTIAL_DEPTH_FACTOR,
    EXPONENTIAL_FIT_MIN_FRACTION,
    K_EXPONENTIAL,
    LINEAR_RANGE,
    MIN_LAYER_POINTS,
    Q_STAR_MIN_X_OVER_L,
    SCALAR_KEYS,
    TAIL_RANGE,
    HeapGeometry,
    SurfaceFit,
    line_fit,
    free_surface,
)


class ExponentialDepth(NamedTuple):
    """Result of :func:`delta_exponential`."""

    delta: float
    z0: float


def delta_exponential(z, u, u_s) -> ExponentialDepth:
    """Flowing-layer thickness from an exponential fit, :math:`\\delta = 2.3 z_0`.

    Fits :math:`u = u_0 e^{z/z_0}` (:func:`scipy.optimize.curve_fit`,
    unweighted, started from a log-linear fit) to the points with
    :math:`z \\le 0` and :math:`u > 0.01 u_s` (paper, section 3.2.2, after
    Komatsu et al. 2001).

    Returns
    -------
    ExponentialDepth
        ``(delta, z0)``, m; NaN with fewer than three points or a failed fit.
    """
    nan = ExponentialDepth(float("nan"), float("nan"))
    z, u = finite_profile(z, u, surface_tolerance(z))
    keep = u > EXPONENTIAL_FIT_MIN_FRACTION * u_s
    z, u = z[keep], u[keep]
    if not (np.isfinite(u_s) and u_s > 0) or len(z) < 3:
        return nan
    a, b, _, _ = line_fit(z, np.log(u))
    if not (np.isfinite(b) and b > 0):
        return nan
    try:
        popt, _ = curve_fit(lambda zz, u0, z0: u0 * np.exp(zz / z0), z, u, p0=(np.exp(a), 1.0 / b),
                            maxfev=2000)
    except (RuntimeError, ValueError):
        return nan
    z0 = float(popt[1])
    if not (np.isfinite(z0) and z0 > 0):
        return nan
    return ExponentialDepth(EXPONENTIAL_DEPTH_FACTOR * z0, z0)


def delta_linear(z, u, u_s) -> float:
    """Flowing-layer thickness by extrapolating the linear part of the profile to zero.

    A least-squares line :math:`u = a + b z` through the points with
    :math:`z \\le 0` and :math:`0.2 u_s \\le u \\le 0.8 u_s` (after GDR MiDi
    2004) meets :math:`u = 0` at :math:`z_{bottom} = -a/b`;
    :math:`\\delta = -z_{bottom}`, m. NaN with fewer than two points or a
    non-positive slope.
    """
    z, u = finite_profile(z, u, surface_tolerance(z))
    if not (np.isfinite(u_s) and u_s > 0):
        return float("nan")
    keep = (u >= LINEAR_RANGE[0] * u_s) & (u <= LINEAR_RANGE[1] * u_s)
    if keep.sum() < 2:
        return float("nan")
    a, b, _, _ = line_fit(z[keep], u[keep])
    return float(a / b) if np.isfinite(b) and b > 0 else float("nan")


def delta_cutoff(z, u, u_s, fraction: float = CUTOFF_FRACTION) -> float:
    """Flowing-layer thickness where :math:`u` first falls to ``fraction`` :math:`\\cdot u_s`.

    Going down from the surface (the point :math:`(0, u_s)` heads the
    profile), the first point with :math:`u \\le u_c = f u_s` and the one
    above it bracket the bottom of the layer, interpolated linearly;
    :math:`\\delta = -z_{bottom}`, m. NaN if :math:`u` never falls that low.
    """
    z, u = finite_profile(z, u, surface_tolerance(z))
    if not (np.isfinite(u_s) and u_s > 0) or len(z) == 0:
        return float("nan")
    z, u = z[::-1], u[::-1]  # from the surface down
    if z[0] < 0:
        z, u = np.concatenate([[0.0], z]), np.concatenate([[u_s], u])
    u_c = fraction * u_s
    below = np.flatnonzero(u <= u_c)
    if len(below) == 0 or below[0] == 0:
        return float("nan")
    k = int(below[0])
    z_bottom = z[k - 1] + (u_c - u[k - 1]) * (z[k] - z[k - 1]) / (u[k] - u[k - 1])
    return float(-z_bottom)


def delta_eq31(x, gamma_bar, v_r, L, delta_L):
    """Eq. (3.1) of Khakhar et al. (2001), flowing-layer thickness from mass conservation.

    .. math::

        \\delta(x) = \\left[\\delta_L^2 + \\frac{2 v_r (L - x)}{\\bar{\\dot\\gamma}}\\right]^{1/2}.
    """
    x, gamma_bar = np.asarray(x, dtype=float), np.asarray(gamma_bar, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.sqrt(delta_L**2 + 2.0 * v_r * (L - x) / gamma_bar)


def normal_velocity_linear(zt):
    """Eq. (3.5), scaled normal velocity for a linear streamwise profile, :math:`\\tilde w = 2\\tilde z + \\tilde z^2`."""
    zt = np.asarray(zt, dtype=float)
    return 2.0 * zt + zt**2


def normal_velocity_exponential(zt, k: float = K_EXPONENTIAL):
    """Eq. (3.6), scaled normal velocity for an exponential profile,

    .. math:: \\tilde w = \\frac{e^{k\\tilde z} - 1}{1 - e^{-k}}, \\qquad
              \\tilde z = z/\\delta, \\; \\tilde w = w/v_r'.
    """
    zt = np.asarray(zt, dtype=float)
    return (np.exp(k * zt) - 1.0) / (1.0 - np.exp(-k))


class TailFit(NamedTuple):
    """Result of :func:`fit_exponential_tail`: :math:`u/u_s = A e^{k z/\\delta}`."""

    A: float
    k: float
    A_se: float
    k_se: float


def fit_exponential_tail(zt, ut, lo: float = TAIL_RANGE[0], hi: float = TAIL_RANGE[1]) -> TailFit:
    """Exponential tail of the collapsed profile, :math:`u/u_s = A e^{k z/\\delta}` (paper, figure 7b).

    Least squares of :math:`\\ln(u/u_s) = \\ln A + k\\,z/\\delta` over
    :math:`lo < z/\\delta < hi` and positive :math:`u/u_s`;
    :math:`\\mathrm{se}(A) = A\\,\\mathrm{se}(\\ln A)`. NaN with fewer than two points
    (standard errors need three).
    """
    zt, ut = np.asarray(zt, dtype=float).ravel(), np.asarray(ut, dtype=float).ravel()
    ok = np.isfinite(zt) & np.isfinite(ut) & (zt > lo) & (zt < hi) & (ut > 0)
    if ok.sum() < 2:
        return TailFit(*(float("nan"),) * 4)
    a, k, a_se, k_se = line_fit(zt[ok], np.log(ut[ok]))
    A = float(np.exp(a))
    return TailFit(A, k, A * a_se, k_se)


class PowerLawFit(NamedTuple):
    """Result of :func:`fit_power_law`: :math:`y = c\\,x^a`."""

    prefactor: float
    exponent: float
    exponent_se: float


def fit_power_law(x, y) -> PowerLawFit:
    """Power law :math:`y = c\\,x^a` by least squares of :math:`\\ln y = \\ln c + a \\ln x`.

    Only points with positive finite :math:`x` and :math:`y`; NaN with fewer
    than two.
    """
    x, y = np.asarray(x, dtype=float).ravel(), np.asarray(y, dtype=float).ravel()
    ok = np.isfinite(x) & np.isfinite(y) & (x > 0) & (y > 0)
    if ok.sum() < 2:
        return PowerLawFit(*(float("nan"),) * 3)
    a, b, _, b_se = line_fit(np.log(x[ok]), np.log(y[ok]))
    return PowerLawFit(float(np.exp(a)), b, b_se)


# --------------------------------------------------------------------------- along the heap
def column(df: pd.DataFrame, name: str) -> np.ndarray:
    """A column of a table as floats; all NaN when the table has no such column.

    Parameters
    ----------
    df : pandas.DataFrame
        The table (e.g. the heap's per-x layer table).
    name : str
        The column's name.

    Returns
    -------
    ndarray of float, shape (len(df),)
        The column's values, in their unit.
    """
    return df[name].to_numpy(dtype=float) if name in df else np.full(len(df), np.nan)


def _widths_below_surface(group: pd.DataFrame) -> np.ndarray:
    """Length of each bin below :math:`z = 0` (bin edges from ``z_lo``/``z_hi`` or centre midpoints)."""
    z = group["z"].to_numpy(dtype=float)
    if "z_lo" in group and "z_hi" in group:
        lo, hi = group["z_lo"].to_numpy(dtype=float), group["z_hi"].to_numpy(dtype=float)
    elif len(z) >= 2:
        mid = 0.5 * (z[1:] + z[:-1])
        edges = np.concatenate([[z[0] - (mid[0] - z[0])], mid, [z[-1] + (z[-1] - mid[-1])]])
        lo, hi = edges[:-1], edges[1:]
    else:
        return np.zeros(len(z))
    return np.clip(np.minimum(hi, 0.0) - lo, 0.0, None)


def _nanmean(values) -> float:
    values = np.asarray(values, dtype=float)
    values = values[np.isfinite(values)]
    return float(values.mean()) if len(values) else float("nan")


def _column_kinematics(group: pd.DataFrame, n_types: int, d_ref: float) -> dict:
    """Everything :func:`analyse_heap` derives from one streamwise bin."""
    nan = float("nan")
    z, u = group["z"].to_numpy(dtype=float), group["u"].to_numpy(dtype=float)
    row = dict(q=nan, u_s=nan, gamma_bar=nan, delta_exp=nan, delta_lin=nan, delta_cut=nan,
               delta=nan, d_bar=nan, n_profile=0, usable=False)
    if n_types == 2:
        row["c_s"] = nan
    finite = np.isfinite(u)
    if finite.any():
        row["q"] = float(np.sum(np.where(finite, u, 0.0) * _widths_below_surface(group)))
    u_s = surface_velocity(z, u)
    row["u_s"] = u_s
    if not (np.isfinite(u_s) and u_s > 0):
        return row
    row["delta_exp"] = delta_exponential(z, u, u_s).delta
    row["delta_lin"] = delta_linear(z, u, u_s)
    row["delta_cut"] = delta = delta_cutoff(z, u, u_s)
    row["delta"] = delta
    if not np.isfinite(delta):
        return row
    layer = (z > -delta) & (z <= surface_tolerance(z))
    row["n_profile"] = int(np.sum(layer & finite))
    if row["n_profile"] < MIN_LAYER_POINTS:
        return row
    row["usable"] = True
    zp, up = finite_profile(z, u)
    row["gamma_bar"] = float((u_s - np.interp(-delta, zp, up)) / delta)
    if "d_mean" in group and "n" in group:
        n, d = column(group, "n")[layer], column(group, "d_mean")[layer]
        ok = np.isfinite(n) & np.isfinite(d) & (n > 0)
        row["d_bar"] = float(np.sum(n[ok] * d[ok]) / np.sum(n[ok])) if ok.any() else nan
    else:
        row["d_bar"] = float(d_ref)
    if n_types == 2 and "phi_1" in group and "phi_2" in group:
        f1, f2 = np.nansum(column(group, "phi_1")[layer]), np.nansum(column(group, "phi_2")[layer])
        row["c_s"] = float(f1 / (f1 + f2)) if f1 + f2 > 0 else nan
    return row


def local_surface(profile: pd.DataFrame, phi_c: float = PHI_C) -> pd.Series:
    """Height of the local free surface above the fitted plane, per streamwise bin of the moving frame, m.

    Where the column's time-averaged :math:`\\phi(z)` falls through :math:`\\phi_c` (:func:`free_surface`,
    the paper's cutoff, section 3.1), so :math:`z = 0` sits on the surface the column actually has, not on
    the plane fitted to the whole surface. The paper's plane stays within a diameter of its local surface
    (:math:`|\\Delta z_s/d_s| < 1`, section 3.1); a short heap's S-shaped surface need not. NaN where the
    column has no ``phi`` or never crosses :math:`\\phi_c`; indexed by ``x``.
    """
    out = {}
    for x, g in profile.sort_values(["x", "z"]).groupby("x", sort=True):
        if "phi" not in g or len(g) < 2:
            out[float(x)] = float("nan")
            continue
        z = g["z"].to_numpy(float)
        if "z_lo" in g and "z_hi" in g:
            edges = np.append(g["z_lo"].to_numpy(float), g["z_hi"].to_numpy(float)[-1])
        else:
            mid = 0.5 * (z[1:] + z[:-1])
            edges = np.concatenate([[2 * z[0] - mid[0]], mid, [2 * z[-1] - mid[-1]]])
        out[float(x)] = float(free_surface(g["phi"].to_numpy(float)[None, :], edges, phi_c)[0])
    return pd.Series(out, name="z_surface_local", dtype=float)


def shift_to_surface(profile: pd.DataFrame, offsets: pd.Series) -> pd.DataFrame:
    """The profile with each column's ``z`` (and ``z_lo``, ``z_hi``) measured from its local surface
    (``offsets`` by ``x``, from :func:`local_surface`; a column without one keeps the plane's origin)."""
    shift = profile["x"].map(offsets).fillna(0.0).to_numpy(float)
    out = profile.copy()
    for col in ("z", "z_lo", "z_hi"):
        if col in out:
            out[col] = out[col].to_numpy(float) - shift
    return out


def mass_balance(fit: SurfaceFit, geometry: HeapGeometry, *, density: float, feed_rate: float,
                 phi_bed: float) -> dict:
    """Rise velocity predicted by mass conservation, and the measured one's residual.

    .. math::

        v_{r,pred} = \\frac{\\dot m}{\\rho\\,\\phi_{bed}\\,T\\,W_h}, \\qquad W_h = W .
    """
    v_pred = feed_rate / (density * phi_bed * geometry.T * geometry.W)
    return {"v_r_predicted": float(v_pred), "mass_balance_residual": float(fit.v_r / v_pred - 1.0),
            "phi_bed": float(phi_bed)}


def analyse_heap(profile: pd.DataFrame, fit: SurfaceFit, geometry: HeapGeometry, *, density: float,
                 feed_rate: float, phi_bed: float, d_ref: float, g: float = 9.81, n_types: int = 1,
                 origin: str = "local"):
    """Streamwise kinematics and scalings of the bounded heap (paper, sections 3.2-3.3).

    Per streamwise bin (``per_x``):

    * :math:`q(x) = \\int_{z_{wall}}^0 u\\,dz`, the 2D flow rate, by the
      midpoint rule over the bins below the surface (NaN bins count as no
      flow). The static bed is at rest along the flow (:class:`MovingFrame`),
      so bins below the layer add nothing but noise;
    * :math:`u_s` (:func:`surface_velocity`);
    * :math:`\\delta` by the exponential fit (``delta_exp``), the linear
      extrapolation (``delta_lin``) and the :math:`0.1 u_s` cutoff
      (``delta_cut``); ``delta`` is ``delta_cut``;
    * :math:`\\bar{\\dot\\gamma} = \\frac1\\delta\\int_{-\\delta}^0 \\frac{\\partial u}{\\partial z} dz
      = [u_s - u(-\\delta)]/\\delta`, the mean shear rate over the layer
      (exact mean of the gradient, without differencing noisy bins);
    * ``delta_eq31``, eq. (3.1) with the local :math:`\\bar{\\dot\\gamma}`,
      :math:`\\delta_L` the thickness at the last usable bin and the normal
      rise speed :math:`v_r'`, the rate at which the layer loses material per
      unit length along the slope (:math:`dq/dx = -v_r'`);
    * :math:`\\bar d`, the number-mean diameter over :math:`-\\delta < z \\le 0`
      (``n``-weighted ``d_mean``; ``d_ref`` when the profile has no diameters),
      and :math:`q^* = q/(\\bar d\\sqrt{g\\bar d})`;
    * ``c_s`` (two species): :math:`\\phi_1/(\\phi_1 + \\phi_2)` summed over the layer;
    * ``n_profile``: bins with a velocity in the layer; a bin is ``usable``
      with a positive :math:`u_s`, a cutoff thickness and at least
      :data:`MIN_LAYER_POINTS` of them; other bins keep NaN in what they lack.

    Scalars: the surface fit; :math:`v_r' = v_r\\cos\\alpha`;
    :math:`L = (W - x_{feed})/\\cos\\alpha`; mass conservation
    :math:`v_{r,pred} = \\dot m/(\\rho\\,\\phi_{bed}\\,T\\,W_h)` with
    :math:`W_h = W` and ``mass_balance_residual`` :math:`= v_r/v_{r,pred} - 1`;
    means of the three thicknesses over :math:`0.2 \\le x/L \\le 0.9` and
    ``delta_over_d`` = ``delta_mean / d_ref``; the tail fit of the collapsed
    profiles (:func:`fit_exponential_tail`); the power law
    :math:`\\delta/\\bar d = c\\,(q^*)^a` over :math:`x/L \\ge 0.2`;
    ``q0`` = :math:`q` at the first usable bin and ``q0_rise`` =
    :math:`v_r' L = v_r (W - x_{feed})`, the flow rate at :math:`x = 0` that
    mass conservation requires (the paper writes :math:`q_0 = v_r L`, which
    omits the factor :math:`\\cos\\alpha`).

    Parameters
    ----------
    profile : DataFrame
        :meth:`KinematicsAccumulator.conclude` output (needs ``x, z, u``;
        uses ``w, n, d_mean, phi_1, phi_2, z_lo, z_hi`` when present).
    fit : SurfaceFit
    geometry : HeapGeometry
    density : float
        Particle material density :math:`\\rho`, kg/m³.
    feed_rate : float
        Mass feed rate :math:`\\dot m`, kg/s.
    phi_bed : float
        Volume fraction of the static bed (:func:`bed_volume_fraction`).
    d_ref : float
        Reference particle diameter, m.
    g : float
        Gravity, m/s².
    n_types : int
    origin : ``"local"`` or ``"plane"``
        Where each column's :math:`z = 0` is: its local free surface (:func:`local_surface`, the default) or
        the plane fitted to the whole surface (the paper's, exact for its planar surface). The scalars
        carry the other origin's δ/d and tail as ``*_other_origin`` (a measurement variant), and how far the
        local surface lies from the plane: ``surface_offset_rms`` and ``surface_offset_max_over_d``.

    Returns
    -------
    per_x : DataFrame
        ``x, x_over_L, q, u_s, gamma_bar, delta_exp, delta_lin, delta_cut,
        delta, delta_eq31, d_bar, q_star, n_profile, usable`` (+ ``c_s``);
        ``attrs`` holds ``v_r_normal``, ``L`` and ``delta_L``.
    scalars : dict
        Keys :data:`SCALAR_KEYS`.
    """
    if origin not in ("local", "plane"):
        raise ValueError(f"origin = {origin!r}: allowed 'local' or 'plane'")
    moving = MovingFrame(fit, geometry)
    L, v_rn = moving.L, moving.v_r_normal
    notes = []
    offsets = local_surface(profile) if not profile.empty else pd.Series(dtype=float)
    local = shift_to_surface(profile, offsets) if not profile.empty else profile
    used, other = (local, profile) if origin == "local" else (profile, local)
    per_x = _per_x(used, n_types, d_ref)
    if per_x.empty:
        notes.append("empty profile")
    per_x["z_surface_local"] = per_x["x"].map(offsets).astype(float) if len(per_x) else []
    per_x["usable"] = per_x["usable"].astype(bool)
    usable = per_x["usable"].to_numpy()
    x = per_x["x"].to_numpy(dtype=float)
    per_x["x_over_L"] = x / L
    delta = per_x["delta"].to_numpy(dtype=float)
    delta_L = float(delta[usable][-1]) if usable.any() else float("nan")
    per_x["delta_eq31"] = np.where(usable, delta_eq31(x, per_x["gamma_bar"].to_numpy(float), v_rn, L, delta_L),
                                   np.nan)
    d_bar = per_x["d_bar"].to_numpy(dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        per_x["q_star"] = np.where(usable, per_x["q"].to_numpy(float) / (d_bar * np.sqrt(g * d_bar)), np.nan)
    order = ["x", "x_over_L", "q", "u_s", "gamma_bar", "delta_exp", "delta_lin", "delta_cut", "delta",
             "delta_eq31", "d_bar", "q_star", "n_profile", "usable", "z_surface_local"] + \
        (["c_s"] if n_types == 2 else [])
    per_x = per_x[order]
    per_x.attrs.update(v_r_normal=float(v_rn), L=float(L), delta_L=delta_L)
    if not usable.all():
        notes.append(f"{int((~usable).sum())} of {len(per_x)} streamwise bins unusable "
                     f"(no surface velocity, no cutoff depth or fewer than {MIN_LAYER_POINTS} bins in the layer)")

    xl = x / L
    window = usable & (xl >= DELTA_MEAN_RANGE[0]) & (xl <= DELTA_MEAN_RANGE[1])
    delta_mean = _nanmean(delta[window])
    scaled = collapse(used, per_x)
    tail = fit_exponential_tail(scaled["zt"], scaled["ut"])
    # the same from the other origin: a measurement variant of δ and the tail
    alt = _per_x(other, n_types, d_ref)
    alt_window = alt["usable"].astype(bool).to_numpy() & (alt["x"].to_numpy(float) / L >= DELTA_MEAN_RANGE[0]) & \
        (alt["x"].to_numpy(float) / L <= DELTA_MEAN_RANGE[1]) if len(alt) else np.zeros(0, bool)
    alt_collapse = collapse(other, alt)
    alt_tail = fit_exponential_tail(alt_collapse["zt"], alt_collapse["ut"])
    offset = per_x["z_surface_local"].to_numpy(float)[window] if len(per_x) else np.zeros(0)
    offset = offset[np.isfinite(offset)]
    far = usable & (xl >= Q_STAR_MIN_X_OVER_L)
    with np.errstate(divide="ignore", invalid="ignore"):
        power = fit_power_law(per_x["q_star"].to_numpy(float)[far], delta[far] / d_bar[far])
    scalars = {
        "alpha_deg": fit.alpha_deg, "alpha_se": fit.alpha_se, "v_r": fit.v_r, "v_r_se": fit.v_r_se,
        "v_r_normal": float(v_rn), "surface_z0": fit.z0,
        **mass_balance(fit, geometry, density=density, feed_rate=feed_rate, phi_bed=phi_bed),
        "L": float(L),
        "delta_mean": delta_mean, "delta_over_d": delta_mean / d_ref,
        "delta_exp_mean": _nanmean(per_x["delta_exp"].to_numpy(float)[window]),
        "delta_lin_mean": _nanmean(per_x["delta_lin"].to_numpy(float)[window]),
        "delta_cut_mean": _nanmean(per_x["delta_cut"].to_numpy(float)[window]),
        "tail_A": tail.A, "tail_A_se": tail.A_se, "tail_k": tail.k, "tail_k_se": tail.k_se,
        "q_star_exponent": power.exponent, "q_star_exponent_se": power.exponent_se,
        "q_star_prefactor": power.prefactor,
        "q0": float(per_x["q"].to_numpy(float)[usable][0]) if usable.any() else float("nan"),
        "q0_rise": float(v_rn * L), "n_usable": int(usable.sum()), "notes": "; ".join(notes),
        "origin": origin,
        "delta_over_d_other_origin": _nanmean(alt["delta"].to_numpy(float)[alt_window]) / d_ref if len(alt)
        else float("nan"),
        "tail_A_other_origin": alt_tail.A, "tail_k_other_origin": alt_tail.k,
        "surface_offset_rms": float(np.sqrt(np.mean(offset**2))) if len(offset) else float("nan"),
        "surface_offset_max_over_d": float(np.max(np.abs(offset)) / d_ref) if len(offset) else float("nan"),
    }
    return per_x, {k: scalars[k] for k in SCALAR_KEYS}


def _per_x(profile: pd.DataFrame, n_types: int, d_ref: float) -> pd.DataFrame:
    """:func:`_column_kinematics` of every streamwise bin, one row each (empty columns for an empty profile)."""
    rows = [{"x": float(x), **_column_kinematics(group, n_types, d_ref)}
            for x, group in profile.sort_values(["x", "z"]).groupby("x", sort=True)]
    if not rows:
        return pd.DataFrame(columns=["x", *_column_kinematics(profile.iloc[:0], n_types, d_ref)])
    return pd.DataFrame(rows)


def collapse(profile: pd.DataFrame, per_x: pd.DataFrame, v_r_normal: float | None = None) -> pd.DataFrame:
    """Scaled profiles of every usable streamwise bin (paper, figures 7-9).

    Long table ``x, z, zt, ut, wt`` over the bins with :math:`z \\le 0`:
    :math:`\\tilde z = z/\\delta`, :math:`u/u_s` and :math:`\\tilde w = w/v_r'`,
    with :math:`\\delta`, :math:`u_s` from ``per_x`` and :math:`v_r'` from
    ``v_r_normal`` or else ``per_x.attrs["v_r_normal"]`` (``wt`` is NaN
    without either, or without a ``w`` column).
    """
    v_rn = v_r_normal if v_r_normal is not None else per_x.attrs.get("v_r_normal", float("nan"))
    columns = ["x", "z", "zt", "ut", "wt"]
    if per_x.empty or profile.empty:
        return pd.DataFrame(columns=columns)
    keep = per_x["usable"].astype(bool) if "usable" in per_x else np.isfinite(per_x["delta"])
    scales = per_x.loc[keep, ["x", "u_s", "delta"]]
    merged = profile.merge(scales, on="x", how="inner")
    merged = merged[merged["z"] <= surface_tolerance(merged["z"])]
    w = column(merged, "w")
    out = pd.DataFrame({
        "x": merged["x"].to_numpy(float), "z": merged["z"].to_numpy(float),
        "zt": (merged["z"] / merged["delta"]).to_numpy(float),
        "ut": (merged["u"] / merged["u_s"]).to_numpy(float),
        "wt": w / v_rn if np.isfinite(v_rn) and v_rn != 0 else np.full(len(merged), np.nan),
    })
    return out.sort_values(["x", "z"]).reset_index(drop=True)


# --------------------------------------------------------------------------- comparisons
def delta_over_local_d(per_x: pd.DataFrame, x_range=DELTA_MEAN_RANGE) -> tuple[float, int]:
    """Mean flowing-layer thickness in local mean diameters over :math:`x_{lo} \\le x/L \\le x_{hi}`.

    .. math:: \\langle \\delta/\\bar d \\rangle = \\frac1n \\sum_{x} \\frac{\\delta(x)}{\\bar d(x)}

    over the usable streamwise bins, :math:`\\bar d(x)` the number-mean
    diameter in the layer (paper section 3.3, figure 10d: the paper scales
    :math:`\\delta` by the *local* :math:`\\bar d`, which segregation changes along
    a bidisperse heap; ``delta_over_d`` of :func:`analyse_heap` divides by the
    mixture's mean instead).

    Returns
    -------
    mean, n : float, int
        NaN and 0 without a usable bin in the range.
    """
    xl, delta, d = (column(per_x, k) for k in ("x_over_L", "delta", "d_bar"))
    usable = per_x["usable"].astype(bool).to_numpy() if "usable" in per_x else np.isfinite(delta)
    sel = usable & (xl >= x_range[0]) & (xl <= x_range[1]) & np.isfinite(delta) & np.isfinite(d) & (d > 0)
    return (float(np.mean(delta[sel] / d[sel])), int(sel.sum())) if sel.any() else (float("nan"), 0)
