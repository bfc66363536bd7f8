"""Analysis of silo discharge, after Rubio-Largo, Maza & Hidalgo (2016).

Pure functions from the per-case inputs to the paper's observables:

* discharge rates from the thermo series (figure 2): the outflow
  :math:`W_f(t)` from the deleted mass and the independent estimate
  :math:`W_r(t)` from the falling free surface; the steady window and the
  steady rate with its standard error;
* the Beverloo law :math:`W = C\\rho_b\\sqrt g\\,(D - k d)^{5/2}` over orifice
  sizes (and its linearisation :math:`W^{2/5} \\propto D - kd`);
* the self-similar orifice profiles :math:`\\phi(r)/\\phi(0)`,
  :math:`v_z(r)/v_z(0)` against :math:`r/R` and the distance of the velocity
  profile from :math:`\\sqrt{1-(r/R)^2}` (figures 4, 5);
* profiles on the axis, the height :math:`h_c` of the kinetic-pressure maximum
  (the transition region, figures 8, 9), the cumulative and the partial
  kinetic pressures per size (figures 10-12);
* the rescaled flow rate :math:`W/(\\rho_p\\phi_c v_c\\pi R^2)` (figure 2b).

Inputs (contracts of the silo glue):

``thermo``
    DataFrame of the discharge stage, ``Time`` in s from the opening of the
    orifice, ``v_mdel`` cumulative deleted mass (kg), ``v_mins`` cumulative
    re-inserted mass (kg; absent or 0 without re-insertion), ``v_zs`` height
    of the free surface (m).
``fields``
    time-averaged axisymmetric field table, one row per (r, z) node of a
    regular grid (m), columns such as ``phi, u_z, pk, pc, pk_s1 ... pk_s7,
    phi_s1 ... phi_s7`` and their block standard errors ``<column>_se``.
    Species ids grow with size (1 smallest).  Stresses are compressive
    positive, so pressures are positive; :math:`u_z < 0` is downward.

Units are SI throughout.
"""
from __future__ import annotations

import re
from collections import deque

import numpy as np
import pandas as pd
from scipy.optimize import curve_fit

#: Fraction of the orifice radius over which the velocity profile is compared
#: with sqrt(1 - (r/R)^2) (see :func:`orifice_profiles`).
SQRT_PROFILE_RANGE = 0.9
#: Smallest partial volume fraction at which pk_s / phi_s is formed.
PHI_MIN_PARTIAL = 1e-3


# --------------------------------------------------------------------------- helpers
def _column(df: pd.DataFrame, name: str, default: float = np.nan) -> np.ndarray:
    """Column as floats; ``default`` everywhere when absent."""
    if name in df:
        return pd.to_numeric(df[name], errors="coerce").to_numpy(dtype=float)
    return np.full(len(df), default, dtype=float)


def linear_fit(x, y) -> tuple[float, float, float, float]:
    """Ordinary least-squares line :math:`y = a x + b` with the slope's standard error.

    .. math:: \\sigma_a^2 = \\frac{\\sum_i r_i^2/(n-2)}{\\sum_i (x_i - \\bar x)^2}

    Parameters
    ----------
    x, y : array_like
        Finite samples (non-finite pairs are dropped).

    Returns
    -------
    slope, intercept, slope_se, x_mean : float
        NaN when fewer than two points or no spread in ``x``; ``slope_se`` is
        NaN with two points.
    """
    x = np.asarray(x, dtype=float)
    y = np.asarray(y, dtype=float)
    ok = np.isfinite(x) & np.isfinite(y)
    x, y = x[ok], y[ok]
    n = len(x)
    if n < 2 or np.ptp(x) == 0:
        return np.nan, np.nan, np.nan, np.nan
    xm = x.mean()
    sxx = np.sum((x - xm) ** 2)
    slope = float(np.sum((x - xm) * (y - y.mean())) / sxx)
    intercept = float(y.mean() - slope * xm)
    if n < 3:
        return slope, intercept, np.nan, float(xm)
    resid = y - (slope * x + intercept)
    return slope, intercept, float(np.sqrt(np.sum(resid ** 2) / (n - 2) / sxx)), float(xm)


def cumulative_rate(t, m) -> tuple[float, float]:
    """Rate of a cumulative counter (deleted or inserted mass) and its standard error.

    The rate is the least-squares slope :math:`\\hat W = \\sum_i c_i m_i`,
    :math:`c_i = (t_i - \\bar t)/\\sum_j (t_j - \\bar t)^2`.  A cumulative
    counter is a random walk with drift, not a line plus independent noise:
    its increments :math:`\\epsilon_j = m_j - m_{j-1}` are independent with
    variance :math:`D\\,\\Delta t_j`, so

    .. math:: \\sigma_{\\hat W}^2 = \\hat D \\sum_j \\Delta t_j \\Big(\\sum_{i \\ge j} c_i\\Big)^2,
        \\qquad \\hat D = \\frac{n-1}{n-2}\\,\\frac{\\sum_j (\\epsilon_j - \\hat W \\Delta t_j)^2}{\\sum_j \\Delta t_j}

    (about :math:`\\tfrac65 D/T` for a window of length T).  The ordinary
    residual-based error would be far too small for such a series.

    Returns
    -------
    W, W_se : float
        NaN with fewer than three finite samples.
    """
    t = np.asarray(t, dtype=float)
    m = np.asarray(m, dtype=float)
    ok = np.isfinite(t) & np.isfinite(m)
    t, m = t[ok], m[ok]
    n = len(t)
    if n < 3 or np.ptp(t) == 0:
        return np.nan, np.nan
    c = (t - t.mean()) / np.sum((t - t.mean()) ** 2)
    W = float(np.sum(c * m))
    dt, eps = np.diff(t), np.diff(m)
    D = np.sum((eps - W * dt) ** 2) / np.sum(dt) * (n - 1) / (n - 2)
    tail = np.cumsum(c[::-1])[::-1][1:]  # sum over i >= j of c_i, for j = 1 .. n-1
    return W, float(np.sqrt(D * np.sum(dt * tail ** 2)))


def species_ids(fields: pd.DataFrame, prefix: str = "pk") -> list[int]:
    """Species ids ``s`` with a column ``<prefix>_s<s>`` in ``fields``, ascending (smallest size first)."""
    pattern = re.compile(rf"^{re.escape(prefix)}_s(\d+)$")
    return sorted(int(m.group(1)) for m in map(pattern.match, map(str, fields.columns)) if m)


def field_map(fields: pd.DataFrame, column: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A field column as a 2-D array on the (r, z) grid.

    Returns
    -------
    r : ndarray, shape (n_r,)
        Radial nodes, m, ascending.
    z : ndarray, shape (n_z,)
        Vertical nodes, m, ascending.
    values : ndarray, shape (n_r, n_z)
        ``values[i, j]`` at ``(r[i], z[j])``; NaN where a node or the column is missing.
    """
    r = np.unique(_column(fields, "r"))
    z = np.unique(_column(fields, "z"))
    r, z = r[np.isfinite(r)], z[np.isfinite(z)]
    values = np.full((len(r), len(z)), np.nan)
    if column in fields and len(r) and len(z):
        rr, zz, v = _column(fields, "r"), _column(fields, "z"), _column(fields, column)
        ok = np.isfinite(rr) & np.isfinite(zz)
        values[np.searchsorted(r, rr[ok]), np.searchsorted(z, zz[ok])] = v[ok]
    return r, z, values


# --------------------------------------------------------------------------- flow rates
def flow_rates(thermo: pd.DataFrame, rho_p: float, phi_b: float, R_c: float, window: float,
               phi_b_se: float = 0.0) -> pd.DataFrame:
    """Discharge rates :math:`W_f(t)` and :math:`W_r(t)` over consecutive time windows.

    The thermo series is cut into non-overlapping windows of length ``window``
    from its first sample (a trailing partial window is dropped; a series
    shorter than one window gives one short window).  In each window the rates are least-squares slopes
    (:func:`linear_fit`):

    .. math:: W_f = \\frac{d m_{del}}{dt}

    is the mass leaving through the orifice (paper's :math:`W_f`), and

    .. math:: W_r = \\rho_p \\phi_b \\pi R_c^2 \\left(-\\frac{dz_s}{dt}\\right) + \\frac{d m_{ins}}{dt}

    the outflow read from the falling free surface (paper's :math:`W_r`).  The
    reasoning: below the surface the bulk has the volume fraction
    :math:`\\phi_b` over the full cross-section, and in steady flow the shape of
    the region that is not bulk (the funnel above the orifice) does not change,
    so the mass inside is :math:`M = \\rho_p\\phi_b\\pi R_c^2 z_s + \\mathrm{const}`.
    Mass balance :math:`dM/dt = -W_f + dm_{ins}/dt` then gives the formula;
    without re-insertion the second term is zero.  With re-insertion the
    surface barely moves and :math:`W_r` is mostly the re-insertion rate,
    which is :math:`W_f` delayed by the fall of the re-inserted particles:
    agreement then tests mass conservation and the stillness of the surface,
    not the outflow independently.

    Standard errors: the cumulative masses are random walks with drift (they
    grow in particle-sized steps), so their rates carry the increment-based
    error of :func:`cumulative_rate`; the surface height is a noisy marker of
    a line, so its slope carries the ordinary residual-based error of
    :func:`linear_fit` (a lower bound if the surface noise is correlated over
    a good part of a window).  Errors are propagated linearly; a relative
    uncertainty ``phi_b_se/phi_b`` of the bulk fraction is added in
    quadrature to the surface term.

    Parameters
    ----------
    thermo : DataFrame
        ``Time`` (s), ``v_mdel`` (kg), optional ``v_mins`` (kg), optional ``v_zs`` (m).
    rho_p : float
        Particle material density, kg/m^3.
    phi_b : float
        Bulk volume fraction below the free surface.
    R_c : float
        Container radius, m.
    window : float
        Window length, s; each window needs at least 3 samples.
    phi_b_se : float
        Standard error of ``phi_b``.

    Returns
    -------
    DataFrame
        One row per window: ``t`` (window centre, s), ``t_lo, t_hi`` (s),
        ``n`` (samples), ``W_f, W_f_se, W_r, W_r_se, W_ins`` (kg/s), ``z_s``
        (mean surface height in the window, m).
    """
    if not window > 0:
        raise ValueError(f"window must be positive, got {window}")
    columns = ["t", "t_lo", "t_hi", "n", "W_f", "W_f_se", "W_r", "W_r_se", "W_ins", "z_s"]
    t = _column(thermo, "Time")
    order = np.argsort(t, kind="stable")
    t = t[order]
    m_del = _column(thermo, "v_mdel")[order]
    m_ins = _column(thermo, "v_mins", 0.0)[order]
    z_s = _column(thermo, "v_zs")[order]
    ok = np.isfinite(t)
    if ok.sum() < 3:
        return pd.DataFrame(columns=columns)
    t0, t1 = t[ok][0], t[ok][-1]
    n_win = int(np.floor((t1 - t0) / window * (1 + 1e-12))) or 1
    area_mass = rho_p * phi_b * np.pi * R_c ** 2
    rows = []
    for k in range(n_win):
        lo, hi = t0 + k * window, t0 + (k + 1) * window
        sel = ok & (t >= lo) & ((t < hi) if k < n_win - 1 else (t <= hi))
        if sel.sum() < 3:
            continue
        w_f, w_f_se = cumulative_rate(t[sel], m_del[sel])
        w_ins, w_ins_se = cumulative_rate(t[sel], m_ins[sel])
        dz, _, dz_se, _ = linear_fit(t[sel], z_s[sel])
        w_surface = -area_mass * dz
        se_surface = np.hypot(area_mass * dz_se, w_surface * phi_b_se / phi_b)
        rows.append(dict(t=0.5 * (lo + hi), t_lo=lo, t_hi=hi, n=int(sel.sum()), W_f=w_f, W_f_se=w_f_se,
                         W_r=w_surface + w_ins, W_r_se=float(np.hypot(se_surface, w_ins_se)), W_ins=w_ins,
                         z_s=float(np.nanmean(z_s[sel])) if np.isfinite(z_s[sel]).any() else np.nan))
    return pd.DataFrame(rows, columns=columns)


def _running_median(w: np.ndarray, usable: np.ndarray, width: int) -> np.ndarray:
    """Centred running median over ``width`` windows within each run of usable windows (NaN elsewhere).

    Near the ends of a run the window shrinks symmetrically (the end values
    stay as they are), so a monotone ramp at the start is not pulled inwards.
    """
    out = np.full(len(w), np.nan)
    half = max(int(width), 1) // 2
    edges = np.flatnonzero(np.diff(np.r_[0, usable.astype(int), 0]))
    for a, b in zip(edges[::2], edges[1::2]):
        for k in range(a, b):
            h = min(half, k - a, b - 1 - k)
            out[k] = np.median(w[k - h:k + h + 1])
    return out


def _longest_band_run(w: np.ndarray, rel_tol: float) -> tuple[int, int]:
    """Longest run ``w[i:j+1]`` (finite) whose values fit in a band of relative half-width ``rel_tol``.

    Values fit in :math:`[(1-\\epsilon)W^*, (1+\\epsilon)W^*]` for some level
    :math:`W^*` iff :math:`\\max/(1+\\epsilon) \\le \\min/(1-\\epsilon)`; the
    condition only fails more as a run grows, so two pointers with monotone
    queues of the running max and min find the longest run in O(n).  Among
    runs of equal length the one with the smallest max/min wins.  Returns
    ``(-1, -1)`` when no value is positive.
    """
    best, best_key = (-1, -1), None
    hi, lo = deque(), deque()
    i = 0
    for j, v in enumerate(w):
        if not (np.isfinite(v) and v > 0):
            hi.clear()
            lo.clear()
            i = j + 1
            continue
        while hi and w[hi[-1]] <= v:
            hi.pop()
        hi.append(j)
        while lo and w[lo[-1]] >= v:
            lo.pop()
        lo.append(j)
        while w[hi[0]] * (1 - rel_tol) > w[lo[0]] * (1 + rel_tol):
            i += 1
            if hi[0] < i:
                hi.popleft()
            if lo[0] < i:
                lo.popleft()
        key = (j - i + 1, -w[hi[0]] / w[lo[0]])
        if best_key is None or key > best_key:
            best, best_key = (i, j), key
    return best


def steady_window(t, W_f, rel_tol: float = 0.1, min_windows: int = 3, window: float | None = None,
                  fill_height=None, min_fill_height: float | None = None,
                  smooth: int = 5) -> tuple[float, float, str]:
    """The discharge window in which the flow rate is steady.

    The windowed rates (rows of :func:`flow_rates`) are first smoothed by a
    running median over ``smooth`` windows, which removes isolated outliers
    (over thousands of windows a few single rates always stray out of any
    band) but keeps the step edges of the start-up and the run-out sharp.
    The steady window is then the longest run of consecutive smoothed rates
    that fit within a band of relative half-width :math:`\\epsilon` about a
    common level,

    .. math:: (1-\\epsilon) W^* \\le \\tilde W_k \\le (1+\\epsilon) W^* \\quad \\forall k
        \\iff \\frac{\\max_k \\tilde W_k}{1+\\epsilon} \\le \\frac{\\min_k \\tilde W_k}{1-\\epsilon},

    which excludes the start-up transient (rates still rising) and the end of
    the discharge (rates falling as the silo runs low).  Windows whose fill
    height is below ``min_fill_height`` (when both are given) cannot belong to
    the run.  Among runs of equal length the flattest wins.  The reason
    quotes the median of the raw rates in the run and their largest relative
    deviation from it.

    Parameters
    ----------
    t : array_like
        Window centres, s.
    W_f : array_like
        Windowed flow rates, kg/s.
    rel_tol : float
        :math:`\\epsilon`, relative half-width of the band (0 < ε < 1).
    min_windows : int
        Shortest acceptable run.
    window : float, optional
        Length of the windows the rates were measured over, s; when given the
        interval is widened by half a window each side so that it spans the
        samples behind the accepted rates.
    fill_height : array_like, optional
        Fill height (e.g. the mean free-surface height ``z_s``) per window, m;
        NaN (unknown) does not exclude a window.
    min_fill_height : float, optional
        Fill height below which the silo counts as running low, m.
    smooth : int
        Width of the running median, windows (1: no smoothing).

    Returns
    -------
    t_start, t_end : float
        Bounds of the steady window, s; NaN when there is none.
    reason : str
        One sentence with the numbers behind the verdict.
    """
    t = np.asarray(t, dtype=float)
    w = np.asarray(W_f, dtype=float)
    if t.shape != w.shape or t.ndim != 1:
        raise ValueError(f"t and W_f must be 1-D arrays of equal length, got {t.shape} and {w.shape}")
    if not 0 < rel_tol < 1 or int(min_windows) < 1:
        raise ValueError("rel_tol must lie in (0, 1) and min_windows be at least 1")
    min_windows = int(min_windows)
    usable = np.isfinite(t) & np.isfinite(w)
    note = ""
    if fill_height is not None and min_fill_height is not None:
        low = np.asarray(fill_height, dtype=float) < min_fill_height
        if (usable & low).any():
            note = f"; {int((usable & low).sum())} windows excluded by fill height < {min_fill_height:.4g} m"
        usable &= ~low
    order = np.argsort(t, kind="stable")
    t, w, usable = t[order], w[order], usable[order]
    nan = float("nan")
    if usable.sum() < min_windows:
        return nan, nan, f"only {int(usable.sum())} usable windows, fewer than {min_windows}{note}"
    if np.median(w[usable]) <= 0:
        return nan, nan, f"no outflow: median W_f = {np.median(w[usable]):.3g} kg/s (clogged?){note}"
    smoothed = _running_median(w, usable, smooth)
    i, j = _longest_band_run(smoothed, rel_tol)
    smoothing = f", after a running median over {smooth} windows" if smooth > 1 else ""
    if i < 0 or j - i + 1 < min_windows:
        return nan, nan, (f"no {min_windows} consecutive windows fit within ±{rel_tol:.0%} of a common level"
                          f"{smoothing} (W_f from {np.min(w[usable]):.3g} to {np.max(w[usable]):.3g} kg/s){note}")
    med = float(np.median(w[i:j + 1]))
    dev = float(np.max(np.abs(w[i:j + 1] - med)) / med)
    half = 0.5 * window if window else 0.0
    t_start, t_end = float(t[i] - half), float(t[j] + half)
    return t_start, t_end, (f"{j - i + 1} consecutive windows from t = {t_start:.4g} s to {t_end:.4g} s fit within "
                            f"±{rel_tol:.0%} of a common level{smoothing}; median W_f = {med:.4g} kg/s, raw "
                            f"rates within ±{dev:.1%} of it{note}")


def steady_flow_rate(thermo: pd.DataFrame, t_start: float, t_end: float, n_blocks: int = 4) -> tuple[float, float]:
    """Steady discharge rate from the deleted mass over the steady window.

    The rate is the least-squares slope of :math:`m_{del}(t)` over
    :math:`t_{start} \\le t \\le t_{end}`; its standard error is the block
    standard error of the slopes in ``n_blocks`` equal sub-windows,

    .. math:: W = \\frac{d m_{del}}{dt}, \\qquad
        \\mathrm{se}(W) = \\frac{\\operatorname{std}_{ddof=1}(W_b)}{\\sqrt{n_b}},

    which is honest about correlated fluctuations longer than the sampling
    interval but shorter than a sub-window.

    Parameters
    ----------
    thermo : DataFrame
        ``Time`` (s) and ``v_mdel`` (kg).
    t_start, t_end : float
        Steady window, s.
    n_blocks : int
        Number of sub-windows (at least 2); reduced when there are fewer than
        3 samples per sub-window.

    Returns
    -------
    W, W_se : float
        kg/s.
    """
    if not (np.isfinite(t_start) and np.isfinite(t_end) and t_end > t_start):
        raise ValueError(f"no steady window: t_start = {t_start}, t_end = {t_end}")
    t, m = _column(thermo, "Time"), _column(thermo, "v_mdel")
    sel = np.isfinite(t) & np.isfinite(m) & (t >= t_start) & (t <= t_end)
    t, m = t[sel], m[sel]
    if len(t) < 3:
        raise ValueError(f"only {len(t)} thermo samples between t = {t_start:.4g} and {t_end:.4g} s")
    W = linear_fit(t, m)[0]
    n_blocks = min(int(n_blocks), len(t) // 3)
    if n_blocks < 2:
        return W, np.nan
    edges = np.linspace(t_start, t_end, n_blocks + 1)
    slopes = [linear_fit(t[(t >= a) & (t <= b)], m[(t >= a) & (t <= b)])[0] for a, b in zip(edges[:-1], edges[1:])]
    slopes = np.asarray(slopes)
    slopes = slopes[np.isfinite(slopes)]
    se = float(np.std(slopes, ddof=1) / np.sqrt(len(slopes))) if len(slopes) >= 2 else np.nan
    return W, se


# --------------------------------------------------------------------------- Beverloo
def beverloo_law(D, C: float, k: float, rho_b: float, g: float, d: float):
    """Beverloo's law for the discharge rate through a circular orifice.

    .. math:: W = C \\rho_b \\sqrt{g}\\, (D - k d)^{5/2}

    (0 when :math:`D \\le k d`).  D and d in m, :math:`\\rho_b` in kg/m^3, W in kg/s.
    """
    return C * rho_b * np.sqrt(g) * np.clip(np.asarray(D, dtype=float) - k * d, 0.0, None) ** 2.5


def beverloo_linearised(D, W, W_se=None) -> dict:
    """Straight-line check of Beverloo's law: :math:`W^{2/5}` against D.

    .. math:: W^{2/5} = (C\\rho_b\\sqrt g)^{2/5}\\,(D - k d) = a D + b,
        \\qquad k d = -b/a

    Weighted least squares when ``W_se`` is given (:math:`\\sigma(W^{2/5}) =
    \\tfrac25 W^{-3/5}\\sigma_W`).

    Returns
    -------
    dict
        ``slope`` (kg^{2/5} s^{-2/5} m^{-1}), ``intercept``, ``slope_se``,
        ``intercept_se``, ``D0 = -b/a`` (the D at which W vanishes, m, i.e.
        :math:`k d`), ``r2`` (coefficient of determination), ``n``.
    """
    D = np.asarray(D, dtype=float)
    W = np.asarray(W, dtype=float)
    ok = np.isfinite(D) & np.isfinite(W) & (W > 0)
    y = W[ok] ** 0.4
    sigma = None
    if W_se is not None:
        s = 0.4 * W[ok] ** -0.6 * np.asarray(W_se, dtype=float)[ok]
        sigma = s if np.all(np.isfinite(s) & (s > 0)) else None
    n = int(ok.sum())
    out = dict(slope=np.nan, intercept=np.nan, slope_se=np.nan, intercept_se=np.nan, D0=np.nan, r2=np.nan, n=n)
    if n < 2 or np.ptp(D[ok]) == 0:
        return out
    wts = np.ones(n) if sigma is None else 1.0 / sigma ** 2
    X = np.column_stack([D[ok], np.ones(n)])
    A = X.T @ (X * wts[:, None])
    coef = np.linalg.solve(A, X.T @ (wts * y))
    resid = y - X @ coef
    if n > 2:
        scale = np.sum(wts * resid ** 2) / (n - 2) if sigma is None else 1.0
        cov = np.linalg.inv(A) * scale
        out.update(slope_se=float(np.sqrt(cov[0, 0])), intercept_se=float(np.sqrt(cov[1, 1])))
    ss_tot = np.sum((y - y.mean()) ** 2)
    out.update(slope=float(coef[0]), intercept=float(coef[1]), D0=float(-coef[1] / coef[0]),
               r2=float(1 - np.sum(resid ** 2) / ss_tot) if ss_tot > 0 else np.nan)
    return out


def beverloo_fit(D, W, W_se, rho_b: float, g: float, d: float) -> dict:
    """Fit Beverloo's law :math:`W = C\\rho_b\\sqrt g\\,(D - kd)^{5/2}` over orifice sizes.

    Non-linear weighted least squares (:func:`scipy.optimize.curve_fit`,
    ``sigma = W_se``, absolute) started from the linearisation
    (:func:`beverloo_linearised`).  When :math:`\\chi^2/\\nu > 1` the
    covariance is scaled by :math:`\\chi^2/\\nu` (the scatter between sizes is
    larger than the quoted errors), so the standard errors are never smaller
    than the scatter implies.  Without ``W_se`` the fit is unweighted and the
    covariance comes from the residuals.

    Parameters
    ----------
    D : array_like
        Orifice diameters :math:`D = 2R`, m.
    W : array_like
        Steady discharge rates, kg/s.
    W_se : array_like or None
        Their standard errors, kg/s (all positive and finite, or None).
    rho_b : float
        Bulk density :math:`\\rho_p\\phi_b`, kg/m^3.
    g : float
        Gravity, m/s^2.
    d : float
        Mean particle diameter, m.

    Returns
    -------
    dict
        ``C, C_se, k, k_se, chi2_dof, dof, n`` (points used), ``n_sizes``
        (distinct D) and ``linear`` (the :func:`beverloo_linearised` dict).

    Raises
    ------
    ValueError
        With fewer than 3 distinct orifice sizes with a positive finite rate
        (two parameters need at least one degree of freedom to be tested),
        with invalid standard errors, or when the fit does not converge.
    """
    D = np.asarray(D, dtype=float).ravel()
    W = np.asarray(W, dtype=float).ravel()
    if D.shape != W.shape:
        raise ValueError(f"D and W differ in length: {D.size} and {W.size}")
    ok = np.isfinite(D) & np.isfinite(W) & (W > 0) & (D > 0)
    n_sizes = len(np.unique(D[ok]))
    if n_sizes < 3:
        raise ValueError(f"Beverloo fit needs at least 3 orifice sizes with a positive flow rate, got {n_sizes}")
    sigma = None
    if W_se is not None:
        sigma = np.asarray(W_se, dtype=float).ravel()[ok]
        if not np.all(np.isfinite(sigma) & (sigma > 0)):
            raise ValueError("W_se must be positive and finite for every orifice size (or None for an unweighted fit)")
    D, W = D[ok], W[ok]
    lin = beverloo_linearised(D, W, sigma)
    pref = rho_b * np.sqrt(g)
    if np.isfinite(lin["slope"]) and lin["slope"] > 0:
        p0 = (lin["slope"] ** 2.5 / pref, lin["D0"] / d)
    else:
        p0 = (0.5, 1.5)
    k_max = D.min() / d * (1 - 1e-9)
    p0 = (max(p0[0], 1e-6), min(p0[1], k_max - 1e-3 * abs(k_max) - 1e-9))

    def model(x, C, k):
        return beverloo_law(x, C, k, rho_b, g, d)

    try:
        popt, pcov = curve_fit(model, D, W, p0=p0, sigma=sigma, absolute_sigma=sigma is not None,
                               bounds=([0.0, -np.inf], [np.inf, k_max]), max_nfev=20000)
    except RuntimeError as err:
        raise ValueError(f"Beverloo fit did not converge: {err}") from err
    resid = (W - model(D, *popt)) / (sigma if sigma is not None else 1.0)
    dof = len(D) - 2
    chi2_dof = float(np.sum(resid ** 2) / dof) if dof > 0 else np.nan
    if sigma is not None and np.isfinite(chi2_dof) and chi2_dof > 1:
        pcov = pcov * chi2_dof
    se = np.sqrt(np.diag(pcov)) if np.all(np.isfinite(pcov)) else np.full(2, np.nan)
    return dict(C=float(popt[0]), C_se=float(se[0]), k=float(popt[1]), k_se=float(se[1]),
                chi2_dof=chi2_dof if sigma is not None else np.nan, dof=dof, n=len(D), n_sizes=n_sizes,
                linear=lin)
