"""Rates and steady windows of time series, with no case directory and no column names.

Four steps take any cumulative quantity to a steady rate:

* :func:`mass_in_region` reads a cumulative series off particle frames (the
  mass inside a box; minus it is the discharged mass);
* :func:`rate_series` turns a cumulative series :math:`m(t)` into rates
  :math:`\\dot m` over consecutive windows, with the standard errors of a
  counting process;
* :func:`steady_window` finds the steady part of *any* series (a rate, a
  velocity, ...) after a start-up excluded by an explicit rule that the
  result states in words (:attr:`SteadyWindow.rule`);
* :func:`steady_rate` is the rate of the cumulative series over that window,
  with an error that allows for autocorrelation (:func:`steady_rate_errors`,
  :mod:`postproc.autocorr`).

Scenes keep their own names (thermo columns, units) in thin wrappers; every
function here takes arrays.
"""
from __future__ import annotations

import math
from typing import Iterable

import numpy as np
import pandas as pd

from .autocorr import combined_error, mean_error, statistical_inefficiency
from .series_steady import (BAND_OVER_SCATTER, SteadyWindow, block_size,  # noqa: F401 (re-exported)
                            check_series, longest_band_run, running_median, scatter, steady_window)

#: Columns of :func:`rate_series`.
RATE_COLUMNS = ("t", "t_lo", "t_hi", "n", "rate", "rate_se")


# --------------------------------------------------------------------------- fits
def _finite_pairs(x, y) -> tuple[np.ndarray, np.ndarray]:
    """``x`` and ``y`` as float arrays, without the pairs where either is not finite."""
    x = np.asarray(x, dtype=float)
    y = np.asarray(y, dtype=float)
    ok = np.isfinite(x) & np.isfinite(y)
    return x[ok], y[ok]


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
    x, y = _finite_pairs(x, y)
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


def change_across(t, y, min_points: int = 3, correlated: bool = False) -> tuple[float, float, int]:
    """Change of ``y`` across the span of ``t`` from the least-squares line, its error and the points used.

    .. math:: \\Delta = a\\,(t_{last} - t_{first}), \\qquad a = \\text{the slope of } y = a t + b

    Parameters
    ----------
    t, y : array_like
        Samples in time order (non-finite pairs are dropped).
    min_points : int, optional
        Fewest finite points that give a change.
    correlated : bool, optional
        Samples of one run whose surges span several (frames): the error is widened by
        :math:`\\sqrt g`, g the statistical inefficiency of the residuals (at least 1). Blocks that
        are independent leave it False.

    Returns
    -------
    change, error, n : float, float, int
        The slope times the span and the slope's error (:func:`linear_fit`) times the span, NaN with
        fewer than ``min_points`` points; the points used.
    """
    t, y = _finite_pairs(t, y)
    if len(t) < min_points:
        return float("nan"), float("nan"), len(t)
    slope, intercept, se, _ = linear_fit(t, y)
    g = max(1.0, statistical_inefficiency(y - (slope * t + intercept))) if correlated else 1.0
    span = float(t[-1] - t[0])
    return slope * span, se * math.sqrt(g) * span, len(t)


def cumulative_rate(t, m) -> tuple[float, float]:
    """Rate of a cumulative counter (deleted, inserted or discharged mass) and its standard error.

    The rate is the least-squares slope :math:`\\hat W = \\sum_i c_i m_i`,
    :math:`c_i = (t_i - \\bar t)/\\sum_j (t_j - \\bar t)^2`.  A cumulative
    counter is a random walk with drift, not a line plus independent noise:
    its increments :math:`\\epsilon_j = m_j - m_{j-1}` are independent with
    variance :math:`D\\,\\Delta t_j`, so

    .. math:: \\sigma_{\\hat W}^2 = \\hat D \\sum_j \\Delta t_j \\Big(\\sum_{i \\ge j} c_i\\Big)^2,
        \\qquad \\hat D = \\frac{n-1}{n-2}\\,\\frac{\\sum_j (\\epsilon_j - \\hat W \\Delta t_j)^2}{\\sum_j \\Delta t_j}

    (about :math:`\\tfrac65 D/T` for a window of length T).  The ordinary
    residual-based error would be far too small for such a series.

    Parameters
    ----------
    t : array_like, 1-D
        Sample times, any time unit (non-finite pairs are dropped).
    m : array_like, 1-D
        The cumulative counter at ``t``, any unit (``W`` is in its unit per unit of ``t``).

    Returns
    -------
    W, W_se : float
        NaN with fewer than three finite samples.
    """
    t, m = _finite_pairs(t, m)
    n = len(t)
    if n < 3 or np.ptp(t) == 0:
        return np.nan, np.nan
    c = (t - t.mean()) / np.sum((t - t.mean()) ** 2)
    W = float(np.sum(c * m))
    dt, eps = np.diff(t), np.diff(m)
    D = np.sum((eps - W * dt) ** 2) / np.sum(dt) * (n - 1) / (n - 2)
    tail = np.cumsum(c[::-1])[::-1][1:]  # sum over i >= j of c_i, for j = 1 .. n-1
    return W, float(np.sqrt(D * np.sum(dt * tail ** 2)))


# --------------------------------------------------------------------------- series from frames
def mass_in_region(frames: Iterable, lo, hi, dt: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Mass of the particles whose centres lie in an axis-aligned box, frame by frame.

    .. math:: M(t_f) = \\sum_i m_i\\,[\\,lo \\le x_i < hi\\,], \\qquad t_f = \\mathrm{timestep}_f\\,\\Delta t

    Minus :math:`M` is a cumulative series (the mass that left the box since
    the first frame plus a constant), whose rate :func:`rate_series` measures:
    the discharge rate of a silo is the rate of :math:`-M` over its interior.

    Parameters
    ----------
    frames : iterable of :class:`postproc.frame.ParticleFrame`
        Any order; ``.timestep``, ``.position`` (N, 3) and ``.mass`` (N,) are used.
    lo, hi : sequence of 3 float
        Box corners, in the units of ``position``; ``None`` or ``±inf`` leaves
        a side open.
    dt : float, optional
        Time per step, so that :math:`t = \\mathrm{timestep}\\cdot dt` (1 gives steps).
        Without it each frame's own ``time`` is used (a ValueError if a frame
        has none).

    Returns
    -------
    t, mass : ndarray, shape (n_frames,)
        Sorted by time.
    """
    lo = np.array([-np.inf if v is None else v for v in lo], dtype=float)
    hi = np.array([np.inf if v is None else v for v in hi], dtype=float)
    if lo.shape != (3,) or hi.shape != (3,):
        raise ValueError("lo and hi must have 3 entries (x, y, z)")
    t, mass = [], []
    for frame in frames:
        x = np.asarray(frame.position, dtype=float)
        inside = np.all((x >= lo) & (x < hi), axis=1)
        if dt is not None:
            t.append(frame.timestep * dt)
        elif getattr(frame, "time", None) is not None:
            t.append(float(frame.time))
        else:
            raise ValueError(f"frame at step {frame.timestep} carries no time: pass dt")
        mass.append(float(np.sum(np.asarray(frame.mass, dtype=float)[inside])))
    t, mass = np.asarray(t, dtype=float), np.asarray(mass, dtype=float)
    order = np.argsort(t, kind="stable")
    return t[order], mass[order]


# --------------------------------------------------------------------------- rates
def window_edges(t, window: float) -> np.ndarray:
    """Edges of consecutive windows of length ``window`` from the first finite sample.

    A trailing partial window is dropped; a series shorter than one window
    gives one window ``[t_0, t_0 + window]`` holding all of it.  Returns an
    empty array with fewer than two finite samples.

    Parameters
    ----------
    t : array_like
        Sample times, any unit.
    window : float
        Window length, same unit.

    Returns
    -------
    ndarray
        ``n_windows + 1`` edges, same unit.

    Raises
    ------
    ValueError
        If ``window`` is not positive.
    """
    if not window > 0:
        raise ValueError(f"window must be positive, got {window}")
    t = np.asarray(t, dtype=float)
    t = t[np.isfinite(t)]
    if len(t) < 2:
        return np.empty(0)
    t0, t1 = t.min(), t.max()
    n_win = int(np.floor((t1 - t0) / window * (1 + 1e-12))) or 1
    return t0 + window * np.arange(n_win + 1)


def window_masks(t, window: float):
    """Yield ``(lo, hi, mask)`` per window of :func:`window_edges` (last window closed on the right).

    Parameters
    ----------
    t : array_like
        Sample times, any unit; non-finite ones fall in no window.
    window : float
        Window length, same unit.

    Yields
    ------
    lo, hi : float
        The window's edges.
    mask : ndarray of bool, shape (len(t),)
        The samples in ``[lo, hi)``, ``[lo, hi]`` for the last window.

    Raises
    ------
    ValueError
        If ``window`` is not positive.
    """
    t = np.asarray(t, dtype=float)
    edges = window_edges(t, window)
    n_win = len(edges) - 1
    for k in range(n_win):
        lo, hi = edges[k], edges[k + 1]
        yield lo, hi, np.isfinite(t) & (t >= lo) & ((t < hi) if k < n_win - 1 else (t <= hi))


def rate_series(t, m, window: float) -> pd.DataFrame:
    """Rate :math:`\\dot m(t)` of a cumulative series over consecutive windows.

    The series is cut into non-overlapping windows of length ``window`` from
    its first sample (:func:`window_edges`: a trailing partial window is
    dropped).  In each window with at least 3 samples the rate is the
    least-squares slope and its error that of a counting process
    (:func:`cumulative_rate`):

    .. math:: \\dot m_k = \\frac{\\sum_{i \\in k} (t_i - \\bar t_k)\\, m_i}{\\sum_{i \\in k} (t_i - \\bar t_k)^2}

    ``m`` is any cumulative quantity: the deleted mass of a thermo output, or
    minus the mass still in a region read off frames (:func:`mass_in_region`).
    With frames, a window must hold at least 3 frames.

    Parameters
    ----------
    t : array_like
        Sample times (any order; sorted here).
    m : array_like
        Cumulative series at ``t``.
    window : float
        Window length, in the units of ``t``.

    Returns
    -------
    DataFrame
        One row per window with 3 samples or more: ``t`` (window centre),
        ``t_lo``, ``t_hi``, ``n`` (samples), ``rate``, ``rate_se``.
    """
    if not window > 0:
        raise ValueError(f"window must be positive, got {window}")
    t = np.asarray(t, dtype=float)
    m = np.asarray(m, dtype=float)
    if t.shape != m.shape or t.ndim != 1:
        raise ValueError(f"t and m must be 1-D arrays of equal length, got {t.shape} and {m.shape}")
    order = np.argsort(t, kind="stable")
    t, m = t[order], m[order]
    ok = np.isfinite(t) & np.isfinite(m)
    rows = []
    if ok.sum() >= 3:
        for lo, hi, sel in window_masks(np.where(ok, t, np.nan), window):
            if sel.sum() < 3:
                continue
            rate, rate_se = cumulative_rate(t[sel], m[sel])
            rows.append((0.5 * (lo + hi), lo, hi, int(sel.sum()), rate, rate_se))
    return pd.DataFrame(rows, columns=list(RATE_COLUMNS))


def subwindow_slopes(t, m, t_start: float, t_end: float, n: int) -> np.ndarray:
    """Least-squares slopes of ``m(t)`` in ``n`` equal sub-windows of ``[t_start, t_end]``.

    The sub-windows are closed; NaN where a sub-window holds fewer than two samples.

    Parameters
    ----------
    t, m : array_like, 1-D
        Sample times (any unit) and the series at them (any unit).
    t_start, t_end : float
        The window, in the unit of ``t``.
    n : int
        Number of sub-windows.

    Returns
    -------
    ndarray, shape (n,)
        Slopes, the unit of ``m`` per unit of ``t``.
    """
    t = np.asarray(t, dtype=float)
    m = np.asarray(m, dtype=float)
    edges = np.linspace(t_start, t_end, int(n) + 1)
    return np.asarray([linear_fit(t[(t >= a) & (t <= b)], m[(t >= a) & (t <= b)])[0]
                       for a, b in zip(edges[:-1], edges[1:])], dtype=float)


def steady_rate_errors(t, m, t_start: float, t_end: float, n_blocks: int = 4, n_series: int = 16) -> dict:
    """Rate of a cumulative series over a (steady) window, with an error that allows for autocorrelation.

    The rate :math:`\\dot m` is the least-squares slope of :math:`m(t)` over
    :math:`t_{start} \\le t \\le t_{end}`.  Its standard error comes from the
    slopes :math:`\\dot m_k` of ``n_series`` equal sub-windows and their
    statistical inefficiency :math:`g` (:func:`postproc.autocorr.mean_error`),

    .. math:: \\mathrm{se} = \\sqrt{g}\\,\\frac{\\operatorname{std}_{ddof=1}(\\dot m_k)}{\\sqrt{n}} ,

    so fluctuations of the rate shorter than a sub-window enter through the
    scatter of the slopes and longer ones through :math:`g`.  For a
    cumulative counter (noise in the increments, as for deleted mass) the mean
    of the sub-window slopes has the variance of the full-window slope; noise
    added to :math:`m` itself would make this error too large.  The block
    error of ``n_blocks`` sub-windows (the former error) is kept as a
    cross-check,

    .. math:: \\mathrm{se}_{block} = \\frac{\\operatorname{std}_{ddof=1}(\\dot m_b)}{\\sqrt{n_b}} ,

    and is the error when fewer than 4 sub-window slopes are finite.

    Parameters
    ----------
    t, m : array_like
        Sample times and the cumulative series (any units: the rate is in the
        unit of ``m`` per unit of ``t``).
    t_start, t_end : float
        The window, e.g. from :func:`steady_window`, in the unit of ``t``.
    n_blocks : int
        Number of blocks of the cross-check (at least 2); reduced when there
        are fewer than 3 samples per block.
    n_series : int
        Number of sub-windows of the error; reduced when there are fewer than
        3 samples per sub-window.  Fewer than 4 (e.g. 0) gives the block
        error alone, as before the autocorrelation analysis.

    Returns
    -------
    dict
        ``rate``; ``se`` and ``se_method`` (``"autocorrelation"``,
        ``"max(autocorrelation, block)"`` while :math:`g` is not reliable, or
        ``"block"``: :func:`postproc.autocorr.combined_error`); ``se_block`` and ``n_blocks`` (finite block slopes);
        ``g`` (in sub-windows), ``n`` (finite sub-window slopes), ``reliable``
        (:math:`n \\ge 50 g`, emcee's criterion) and ``se_naive`` (the error
        of the sub-window slopes as if independent).

    Raises
    ------
    ValueError
        When the window is empty or not finite ("no steady window"), or holds
        fewer than 3 samples.
    """
    if not (np.isfinite(t_start) and np.isfinite(t_end) and t_end > t_start):
        raise ValueError(f"no steady window: t_start = {t_start}, t_end = {t_end}")
    t = np.asarray(t, dtype=float)
    m = np.asarray(m, dtype=float)
    sel = np.isfinite(t) & np.isfinite(m) & (t >= t_start) & (t <= t_end)
    t, m = t[sel], m[sel]
    if len(t) < 3:
        raise ValueError(f"only {len(t)} samples between t = {t_start:.4g} and {t_end:.4g}")
    rate = linear_fit(t, m)[0]
    n_blocks = min(int(n_blocks), len(t) // 3)
    blocks = subwindow_slopes(t, m, t_start, t_end, n_blocks) if n_blocks >= 2 else np.empty(0)
    blocks = blocks[np.isfinite(blocks)]
    se_block = float(np.std(blocks, ddof=1) / np.sqrt(len(blocks))) if len(blocks) >= 2 else np.nan
    n_series = min(int(n_series), len(t) // 3)
    e = mean_error(subwindow_slopes(t, m, t_start, t_end, n_series) if n_series >= 1 else np.empty(0))
    se, method = combined_error(e, se_block)
    return {"rate": rate, "se": se, "se_method": method,
            "se_block": se_block, "n_blocks": int(len(blocks)), "g": e.g, "n": e.n, "reliable": e.reliable,
            "se_naive": e.se_naive}


def steady_rate(t, m, t_start: float, t_end: float, n_blocks: int = 4, n_series: int = 16) -> tuple[float, float]:
    """Rate of a cumulative series over a (steady) window and its standard error.

    ``(rate, se)`` of :func:`steady_rate_errors`: the least-squares slope
    over :math:`t_{start} \\le t \\le t_{end}` and the error of the slopes of
    ``n_series`` sub-windows with their statistical inefficiency,

    .. math:: \\mathrm{se} = \\sqrt{g}\\,\\frac{\\operatorname{std}_{ddof=1}(\\dot m_k)}{\\sqrt{n}}

    (the block error of ``n_blocks`` sub-windows when fewer than 4
    sub-window slopes are finite, or with ``n_series=0``: the former
    error).  :func:`steady_rate_errors` also returns the block error,
    :math:`g` and the counts.

    Parameters
    ----------
    t, m : array_like
        Sample times (any unit) and the cumulative series (any unit).
    t_start, t_end : float
        The window, in the unit of ``t``.
    n_blocks, n_series : int
        As for :func:`steady_rate_errors`.

    Returns
    -------
    rate, rate_se : float

    Raises
    ------
    ValueError
        When the window is empty or not finite ("no steady window"), or holds
        fewer than 3 samples.
    """
    out = steady_rate_errors(t, m, t_start, t_end, n_blocks=n_blocks, n_series=n_series)
    return out["rate"], out["se"]


def window_acceleration(thermo: pd.DataFrame) -> dict:
    r"""The bed's mean acceleration over the averaging window, :math:`a = du_{cm}/dt` in g.

    A straight line through the averaging stage's thermo rows (``stage == "average"``) of
    :math:`u_{cm}` against time (√(gd) per √(d/g)); its standard error is the fit's, times
    :math:`\sqrt{g}`, the residuals' statistical inefficiency (they are correlated in time). A
    still-creeping bed (:math:`a > 0`) lowers the stress ratio: the momentum balance of the layers
    above z reads :math:`-\sigma_{xz}/\sigma_{zz} = \tan\theta - a/(g\cos\theta)`. NaN without an
    averaging stage or with fewer than 4 rows.

    Parameters
    ----------
    thermo : DataFrame
        ``Time``, ``v_ucm`` and ``stage`` (the averaging stage's rows are ``"average"``).

    Returns
    -------
    dict
        ``accel_cm`` and ``accel_cm_se`` (g), ``accel_rows``, ``u_cm_window`` (the window's mean u_cm).
    """
    from postproc.autocorr import statistical_inefficiency

    avg = thermo[thermo["stage"] == "average"] if "stage" in thermo else thermo.iloc[:0]
    t, u = avg["Time"].to_numpy(float), avg["v_ucm"].to_numpy(float)
    if len(t) < 4 or not np.ptp(t) > 0:
        return {"accel_cm": float("nan"), "accel_cm_se": float("nan"), "accel_rows": int(len(t))}
    (slope, intercept), cov = np.polyfit(t, u, 1, cov=True)
    resid = u - (slope * t + intercept)
    g = statistical_inefficiency(resid) if np.std(resid) > 0 else 1.0
    return {"accel_cm": float(slope), "accel_cm_se": float(np.sqrt(cov[0, 0] * max(g, 1.0))),
            "accel_rows": int(len(t)), "u_cm_window": float(np.mean(u))}


def ucm_fluctuation(thermo: pd.DataFrame, detrend: bool = False) -> tuple[float, float]:
    """Relative standard deviation of :math:`u_{cm}` (∝ the total momentum ``v_py``) over the thermo
    rows of the averaging stage, and its error :math:`s_r\\sqrt{g/(2n)}` (g the series' statistical
    inefficiency); with ``detrend`` about a straight line in time.

    Parameters
    ----------
    thermo : DataFrame
        ``Step``, ``v_py`` and ``stage`` (the averaging stage's rows are ``"average"``).
    detrend : bool
        Deviations about a straight line in time instead of about the mean.

    Returns
    -------
    rel, rel_se : float
        NaN without ``v_py`` or with fewer than 8 averaging rows.
    """
    th = thermo[thermo["stage"] == "average"] if "stage" in thermo else thermo.iloc[0:0]
    if "v_py" not in th or len(th) < 8:
        return float("nan"), float("nan")
    p = th.sort_values("Step")["v_py"].to_numpy(float)
    dev = p - np.polyval(np.polyfit(np.arange(len(p)), p, 1), np.arange(len(p))) if detrend else p - p.mean()
    rel = float(np.std(dev, ddof=1) / abs(p.mean()))
    g = mean_error(dev).g
    return rel, rel * math.sqrt((g if math.isfinite(g) else 1.0) / (2.0 * len(p)))
