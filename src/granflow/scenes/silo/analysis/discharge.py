"""Analysis of silo discharge, after Rubio-Largo, Maza & Hidalgo (2016).

Pure functions from the per-case inputs to the paper's observables:

* discharge rates from the thermo series (figure 2): the outflow
  :math:`W_f(t)` from the deleted mass and the independent estimate
  :math:`W_r(t)` from the falling free surface; the steady window and the
  steady rate with its standard error (thin wrappers that name the thermo
  columns around :mod:`postproc.series`, which works on any series);
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

import numpy as np
import pandas as pd
from scipy.optimize import curve_fit

from postproc.series import (SteadyWindow, check_series, cumulative_rate, linear_fit,  # noqa: F401
                             steady_rate, window_masks)
from postproc.series import steady_window as series_steady_window

#: Fraction of the orifice radius over which the velocity profile is compared
#: with sqrt(1 - (r/R)^2) (see :func:`orifice_profiles`).
SQRT_PROFILE_RANGE = 0.9
#: Smallest partial volume fraction at which pk_s / phi_s is formed.
PHI_MIN_PARTIAL = 1e-3


# --------------------------------------------------------------------------- helpers
def numeric_column(df: pd.DataFrame, name: str, default: float = np.nan) -> np.ndarray:
    """Column as floats; ``default`` everywhere when absent."""
    if name in df:
        return pd.to_numeric(df[name], errors="coerce").to_numpy(dtype=float)
    return np.full(len(df), default, dtype=float)


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
    r = np.unique(numeric_column(fields, "r"))
    z = np.unique(numeric_column(fields, "z"))
    r, z = r[np.isfinite(r)], z[np.isfinite(z)]
    values = np.full((len(r), len(z)), np.nan)
    if column in fields and len(r) and len(z):
        rr, zz, v = numeric_column(fields, "r"), numeric_column(fields, "z"), numeric_column(fields, column)
        ok = np.isfinite(rr) & np.isfinite(zz)
        values[np.searchsorted(r, rr[ok]), np.searchsorted(z, zz[ok])] = v[ok]
    return r, z, values


# --------------------------------------------------------------------------- flow rates
def flow_rates(thermo: pd.DataFrame, rho_p: float, phi_b: float, R_c: float, window: float,
               phi_b_se: float = 0.0) -> pd.DataFrame:
    """Discharge rates :math:`W_f(t)` and :math:`W_r(t)` over consecutive time windows.

    The thermo series is cut into non-overlapping windows of length ``window``
    from its first sample (:func:`postproc.series.window_edges`: a trailing
    partial window is dropped; a series shorter than one window gives one
    short window), as :func:`postproc.series.rate_series` does for any
    cumulative series.  In each window the rates are least-squares slopes
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
    t = numeric_column(thermo, "Time")
    order = np.argsort(t, kind="stable")
    t = t[order]
    m_del = numeric_column(thermo, "v_mdel")[order]
    m_ins = numeric_column(thermo, "v_mins", 0.0)[order]
    z_s = numeric_column(thermo, "v_zs")[order]
    if np.isfinite(t).sum() < 3:
        return pd.DataFrame(columns=columns)
    area_mass = rho_p * phi_b * np.pi * R_c ** 2
    rows = []
    for lo, hi, sel in window_masks(t, window):
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


def discharge_steady_window(t, W_f, rel_tol: float = 0.1, min_windows: int = 3, window: float | None = None,
                            fill_height=None, min_fill_height: float | None = None, smooth: int = 5,
                            startup: str | float | None = "auto", coarsen: bool = False) -> SteadyWindow:
    """The discharge window in which the flow rate is steady, as a :class:`postproc.series.SteadyWindow`.

    :func:`postproc.series.steady_window` on the windowed rates (rows of
    :func:`flow_rates`), with the silo's own exclusions: windows whose fill
    height is below ``min_fill_height`` (when both are given) cannot be
    steady (the silo runs low), and a median rate :math:`\\le 0` is no outflow
    (a clog).  In short: a running median over ``smooth`` windows, the
    start-up rule ``startup`` (default ``"auto"``: nothing before the
    smoothed rate first comes within ``rel_tol`` of the median of the later
    rates), then the longest run of smoothed rates within a band of relative
    half-width :math:`\\epsilon` about a common level,

    .. math:: \\frac{\\max_k \\tilde W_k}{1+\\epsilon} \\le \\frac{\\min_k \\tilde W_k}{1-\\epsilon},

    which excludes the end of the discharge too.  The start-up rule applied
    is stated in ``rule``; ``reason`` quotes the median of the raw rates in
    the run and their largest relative deviation from it.

    ``coarsen`` is off by default to keep the silo's historic windows on its
    thermo rates; switch it on for noisy rates (from frames, or short
    windows), whose scatter would otherwise make the run a random stretch.

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
    startup : "auto", float or None
        Start-up rule of :func:`postproc.series.steady_window` (a float is a
        time in s before which no window may start; None excludes nothing).
    coarsen : bool
        Average blocks of windows when their scatter is too large for the band.
    """
    t, w = check_series(t, W_f, rel_tol, min_windows, name="W_f")
    usable = np.isfinite(t) & np.isfinite(w)
    note = ""
    if fill_height is not None and min_fill_height is not None:
        low = np.asarray(fill_height, dtype=float) < min_fill_height
        if (usable & low).any():
            note = f"; {int((usable & low).sum())} windows excluded by fill height < {min_fill_height:.4g} m"
        usable &= ~low
    nan = float("nan")
    if usable.sum() < int(min_windows):
        return SteadyWindow(nan, nan, nan, 0, nan, "start-up not assessed",
                            f"only {int(usable.sum())} usable windows, fewer than {int(min_windows)}{note}")
    if np.median(w[usable]) <= 0:
        return SteadyWindow(nan, nan, nan, 0, nan, "start-up not assessed",
                            f"no outflow: median W_f = {np.median(w[usable]):.3g} kg/s (clogged?){note}")
    sw = series_steady_window(t, np.where(usable, w, np.nan), rel_tol=rel_tol, min_windows=min_windows,
                              window=window, startup=startup, smooth=smooth, coarsen=coarsen, label="W_f",
                              unit="kg/s", time_unit="s", noun="windows")
    return SteadyWindow(sw.t_start, sw.t_end, sw.mean, sw.n_windows, sw.startup_end, sw.rule, sw.reason + note)


def steady_window(t, W_f, rel_tol: float = 0.1, min_windows: int = 3, window: float | None = None,
                  fill_height=None, min_fill_height: float | None = None, smooth: int = 5,
                  startup: str | float | None = "auto", coarsen: bool = False) -> tuple[float, float, str]:
    """The steady discharge window as ``(t_start, t_end, reason)``.

    :func:`discharge_steady_window` (same parameters) with the start-up rule
    appended to the reason, so that whatever records the reason records the
    rule too: ``"<verdict>; <start-up rule>"``.

    Returns
    -------
    t_start, t_end : float
        Bounds of the steady window, s; NaN when there is none.
    reason : str
        The verdict with its numbers, then the start-up rule applied.
    """
    sw = discharge_steady_window(t, W_f, rel_tol=rel_tol, min_windows=min_windows, window=window,
                                 fill_height=fill_height, min_fill_height=min_fill_height, smooth=smooth,
                                 startup=startup, coarsen=coarsen)
    return sw.t_start, sw.t_end, f"{sw.reason}; {sw.rule}"


def steady_flow_rate(thermo: pd.DataFrame, t_start: float, t_end: float, n_blocks: int = 4) -> tuple[float, float]:
    """Steady discharge rate from the deleted mass over the steady window.

    :func:`postproc.series.steady_rate` of ``v_mdel`` against ``Time``: the
    least-squares slope over :math:`t_{start} \\le t \\le t_{end}` and the
    block standard error of the slopes in ``n_blocks`` equal sub-windows,

    .. math:: W = \\frac{d m_{del}}{dt}, \\qquad
        \\mathrm{se}(W) = \\frac{\\operatorname{std}_{ddof=1}(W_b)}{\\sqrt{n_b}} .

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

    Raises
    ------
    ValueError
        Without a steady window ("no steady window") or with fewer than 3
        thermo samples in it.
    """
    return steady_rate(numeric_column(thermo, "Time"), numeric_column(thermo, "v_mdel"), t_start, t_end,
                       n_blocks=n_blocks)


def surface_rate_ratio(flow: pd.DataFrame, W_f: float, W_f_se: float, t_start: float, t_end: float,
                       n_blocks: int = 4) -> dict:
    """The rate read from the falling free surface over the outflow, in the steady window (paper figure 2a).

    .. math:: \\frac{\\langle W_r \\rangle}{W_f}, \\qquad
        \\frac{\\sigma}{\\langle W_r\\rangle/W_f} = \\sqrt{\\Big(\\frac{\\sigma_{W_r}}{W_r}\\Big)^2
        + \\Big(\\frac{\\sigma_{W_f}}{W_f}\\Big)^2}

    :math:`\\langle W_r \\rangle` is the mean of the windowed rates of
    :func:`flow_rates` whose centres lie in ``[t_start, t_end]``, with the
    standard error of a correlated series (:func:`postproc.autocorr.mean_error`),
    or the block error of ``n_blocks`` consecutive blocks of windows when larger
    and the autocorrelation estimate is not reliable
    (:func:`postproc.autocorr.combined_error`); ``W_f`` and its error are the
    steady outflow.  Mass conservation makes the ratio 1 when the bulk below
    the surface has the volume fraction used for :math:`W_r`.

    Returns
    -------
    dict
        ``ratio, ratio_se, W_r, W_r_se, W_r_se_method, n`` (windows); NaN without windows or outflow.
    """
    from postproc.autocorr import combined_error, mean_error

    t = numeric_column(flow, "t")
    sel = np.isfinite(t) & (t >= t_start - 1e-12) & (t <= t_end + 1e-12)
    w_r = numeric_column(flow, "W_r")[sel]
    w_r = w_r[np.isfinite(w_r)]
    m = mean_error(w_r)
    blocks = [b.mean() for b in np.array_split(w_r, n_blocks) if len(b)] if len(w_r) >= n_blocks else []
    se_block = float(np.std(blocks, ddof=1) / np.sqrt(len(blocks))) if len(blocks) >= 2 else np.nan
    se, method = combined_error(m, se_block)
    out = dict(ratio=np.nan, ratio_se=np.nan, W_r=m.mean, W_r_se=se, W_r_se_method=method, n=m.n)
    if np.isfinite(W_f) and W_f > 0 and np.isfinite(m.mean):
        ratio = m.mean / W_f
        se_f = W_f_se / W_f if np.isfinite(W_f_se) else 0.0
        out.update(ratio=float(ratio), ratio_se=float(abs(ratio) * np.hypot(se / m.mean, se_f)))
    return out


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
