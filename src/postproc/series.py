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

from collections import deque
from dataclasses import dataclass
from typing import Iterable

import numpy as np
import pandas as pd

from .autocorr import combined_error, mean_error

#: Columns of :func:`rate_series`.
RATE_COLUMNS = ("t", "t_lo", "t_hi", "n", "rate", "rate_se")


# --------------------------------------------------------------------------- fits
def _finite_pairs(x, y) -> tuple[np.ndarray, np.ndarray]:
    """``x`` and ``y`` as float arrays, without the pairs where either is not finite."""
    x = np.asarray(x, dtype=float)
    y = np.asarray(y, dtype=float)
    ok = np.isfinite(x) & np.isfinite(y)
    return x[ok], y[ok]


def check_series(t, y, rel_tol: float, min_windows: int, name: str = "y") -> tuple[np.ndarray, np.ndarray]:
    """``t`` and ``y`` as equal-length 1-D float arrays, after checking them and the band settings.

    Raises
    ------
    ValueError
        Arrays of different shapes or not 1-D; ``rel_tol`` outside (0, 1); ``min_windows`` < 1.
    """
    t = np.asarray(t, dtype=float)
    y = np.asarray(y, dtype=float)
    if t.shape != y.shape or t.ndim != 1:
        raise ValueError(f"t and {name} must be 1-D arrays of equal length, got {t.shape} and {y.shape}")
    if not 0 < rel_tol < 1 or int(min_windows) < 1:
        raise ValueError("rel_tol must lie in (0, 1) and min_windows be at least 1")
    return t, y


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
    """Yield ``(lo, hi, mask)`` per window of :func:`window_edges` (last window closed on the right)."""
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
    """Least-squares slopes of ``m(t)`` in ``n`` equal sub-windows of ``[t_start, t_end]`` (closed; NaN where
    a sub-window holds fewer than two samples)."""
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
        Sample times and the cumulative series.
    t_start, t_end : float
        The window, e.g. from :func:`steady_window`.
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


# --------------------------------------------------------------------------- steady window
@dataclass(frozen=True)
class SteadyWindow:
    """Verdict of :func:`steady_window`.

    Attributes
    ----------
    t_start, t_end : float
        Bounds of the steady window (NaN when there is none).
    mean : float
        Mean of the raw values in the window (NaN when none).
    n_windows : int
        Number of samples (windows of a rate series) in it; 0 when none.
    startup_end : float
        End of the excluded start-up: nothing before it may be steady (NaN
        when the start-up never ended).
    rule : str
        One sentence: the start-up rule applied and its numbers.
    reason : str
        One sentence with the numbers behind the verdict (why this window, or
        why there is none).
    """

    t_start: float
    t_end: float
    mean: float
    n_windows: int
    startup_end: float
    rule: str
    reason: str

    @property
    def found(self) -> bool:
        """Whether a steady window was found."""
        return bool(np.isfinite(self.t_start) and np.isfinite(self.t_end))


def running_median(y, usable, width: int) -> np.ndarray:
    """Centred running median over ``width`` samples within each run of usable samples (NaN elsewhere).

    Near the ends of a run the window shrinks symmetrically (the end values
    stay as they are), so a monotone ramp at the start is not pulled inwards.
    """
    y = np.asarray(y, dtype=float)
    usable = np.asarray(usable, dtype=bool)
    out = np.full(len(y), np.nan)
    half = max(int(width), 1) // 2
    edges = np.flatnonzero(np.diff(np.r_[0, usable.astype(int), 0]))
    for a, b in zip(edges[::2], edges[1::2]):
        for k in range(a, b):
            h = min(half, k - a, b - 1 - k)
            out[k] = np.median(y[k - h:k + h + 1])
    return out


def longest_band_run(w, rel_tol: float) -> tuple[int, int]:
    """Longest run ``w[i:j+1]`` (finite, positive) whose values fit in a band of relative half-width ``rel_tol``.

    Values fit in :math:`[(1-\\epsilon)W^*, (1+\\epsilon)W^*]` for some level
    :math:`W^*` iff :math:`\\max/(1+\\epsilon) \\le \\min/(1-\\epsilon)`; the
    condition only fails more as a run grows, so two pointers with monotone
    queues of the running max and min find the longest run in O(n).  Among
    runs of equal length the one with the smallest max/min wins.  Returns
    ``(-1, -1)`` when no value is positive.
    """
    w = np.asarray(w, dtype=float)
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


def _fmt(x: float, unit: str) -> str:
    return f"{x:.4g}{(' ' + unit) if unit else ''}"


def scatter(y, usable=None) -> float:
    """Robust standard deviation of the sample-to-sample noise of a series.

    From the successive differences :math:`\\Delta_k = y_{k+1} - y_k` of
    neighbouring usable samples, whose slow part (a ramp, a drift) cancels:

    .. math:: \\hat\\sigma = \\frac{1.4826\\, \\mathrm{med}_k |\\Delta_k - \\mathrm{med}\\,\\Delta|}{\\sqrt 2}

    (the median absolute deviation, scaled to a standard deviation for
    Gaussian noise; isolated outliers do not inflate it).  NaN with fewer than
    two differences.
    """
    y = np.asarray(y, dtype=float)
    usable = np.isfinite(y) if usable is None else np.asarray(usable, dtype=bool) & np.isfinite(y)
    pair = usable[1:] & usable[:-1]
    d = np.diff(y)[pair]
    if len(d) < 2:
        return float("nan")
    return float(1.4826 * np.median(np.abs(d - np.median(d))) / np.sqrt(2))


#: The band must be at least this many standard deviations of the smoothed
#: series wide (half-width), or :func:`steady_window` coarsens the series.
BAND_OVER_SCATTER = 2.5


def block_size(sigma: float, level: float, rel_tol: float, smooth: int) -> int:
    """Samples per block mean for which the smoothed series resolves the band.

    A running median over :math:`w` block means of :math:`b` samples each has
    the scatter :math:`\\sigma_s \\approx 1.2533\\,\\hat\\sigma/\\sqrt{b w}`
    (:math:`\\hat\\sigma/\\sqrt b` without smoothing, :math:`w < 3`); the band
    :math:`\\pm\\epsilon |Y|` is resolved when
    :math:`\\epsilon|Y| \\ge` :data:`BAND_OVER_SCATTER` :math:`\\sigma_s`, so

    .. math:: b = \\left\\lceil \\frac{1}{w}
        \\left(\\frac{2.5 \\cdot 1.2533\\,\\hat\\sigma}{\\epsilon |Y|}\\right)^2 \\right\\rceil \\ge 1 .
    """
    if not (np.isfinite(sigma) and np.isfinite(level) and level != 0):
        return 1
    w = int(smooth) if int(smooth) >= 3 else 1
    c = 1.2533 if w >= 3 else 1.0
    need = (BAND_OVER_SCATTER * c * sigma / (rel_tol * abs(level))) ** 2 / w
    return max(1, int(np.ceil(need - 1e-9)))


def steady_window(t, y, *, rel_tol: float = 0.1, min_windows: int = 3, window: float | None = None,
                  startup: str | float | None = "auto", smooth: int = 5, coarsen: bool = True,
                  label: str = "y", unit: str = "", time_unit: str = "s", noun: str = "samples") -> SteadyWindow:
    """The steady part of a time series, after an explicit start-up rule.

    Works on any series: windowed rates (:func:`rate_series`), a velocity, a
    kinetic energy ...; NaN samples are unusable and break a steady run (a
    caller excludes samples by setting them to NaN).  A negative series (a
    downward velocity) is handled through its magnitude; samples of the other
    sign never fit a band.

    1. **Scatter.** The sample-to-sample noise :math:`\\hat\\sigma` is
       measured from successive differences (:func:`scatter`).  If the band
       cannot resolve it after smoothing, i.e. if :math:`\\epsilon|Y| <`
       :data:`BAND_OVER_SCATTER` :math:`\\sigma_s` with :math:`Y` the median of
       the series, consecutive samples are averaged in blocks of :math:`b`
       (:func:`block_size`; with ``coarsen``) and every later step works on
       the block means (for a rate series: rates over :math:`b` times longer
       windows).  Without it the longest run below is a random short stretch
       of the noise, anywhere, start-up included.
    2. **Smoothing.** A centred running median over ``smooth`` values
       (:func:`running_median`) removes isolated outliers but keeps step
       edges sharp: :math:`\\tilde y_k`.
    3. **Start-up.** Values before the end of the start-up never count as steady:

       * ``startup="auto"``: the start-up lasts until the smoothed series first
         comes within the band around the median of the rest, i.e. it ends at
         the first :math:`k` (with at least ``min_windows`` usable values from
         :math:`k` on) such that

         .. math:: |\\tilde y_k - \\mathrm{med}_{l \\ge k}\\, y_l| \\le \\epsilon\\,\\mathrm{med}_{l \\ge k}\\, y_l ;

         this excludes a rise from rest as well as an overshoot, whatever its
         length, and nothing when the series starts steady;
       * a number :math:`t_s`: values whose window starts before :math:`t_s`
         are excluded (0 excludes nothing of a series starting at 0);
       * ``None``: nothing is excluded.
    4. **Steady run.** The steady window is the longest run of consecutive
       smoothed values after the start-up that fit within a band of relative
       half-width :math:`\\epsilon` about a common level,

       .. math:: (1-\\epsilon) Y^* \\le \\tilde y_k \\le (1+\\epsilon) Y^* \\quad \\forall k
           \\iff \\frac{\\max_k \\tilde y_k}{1+\\epsilon} \\le \\frac{\\min_k \\tilde y_k}{1-\\epsilon}

       (:func:`longest_band_run`; among runs of equal length the flattest
       wins), which also excludes a run-out at the end.

    The start-up rule and its numbers are stated in :attr:`SteadyWindow.rule`,
    the rest (coarsening included) in :attr:`SteadyWindow.reason`.  With
    ``startup=None, coarsen=False`` this is the former silo rule.

    Parameters
    ----------
    t : array_like
        Sample times (window centres for a rate series).
    y : array_like
        Values.
    rel_tol : float
        :math:`\\epsilon`, relative half-width of the band (0 < ε < 1).
    min_windows : int
        Shortest acceptable steady run, in values (samples, or blocks when
        coarsened).
    window : float, optional
        Length of the windows the values were measured over; when given, a
        sample covers :math:`t \\pm` ``window``/2, so the bounds are widened by
        half a window each side and a numeric ``startup`` applies to the
        window starts.
    startup : "auto", float or None
        The start-up rule (see above).
    smooth : int
        Width of the running median, values (1: no smoothing).
    coarsen : bool
        Average blocks of samples when the noise is too large for the band.
        Blocks are aligned on the first sample; a trailing partial block is
        kept if it holds at least half a block.
    label, unit, time_unit, noun : str
        Names used in the sentences (e.g. ``"W_f"``, ``"kg/s"``, ``"s"``,
        ``"windows"``).

    Returns
    -------
    SteadyWindow
        With NaN bounds and ``n_windows = 0`` when there is no steady window
        (never an exception for a valid series).
    """
    t, y = check_series(t, y, rel_tol, min_windows)
    if not (startup is None or (isinstance(startup, str) and startup == "auto")
            or (isinstance(startup, (int, float, np.integer, np.floating)) and np.isfinite(startup))):
        raise ValueError(f"startup must be 'auto', a finite time or None, got {startup!r}")
    min_windows = int(min_windows)
    order = np.argsort(t, kind="stable")
    t, y = t[order], y[order]
    usable = np.isfinite(t) & np.isfinite(y)
    half = 0.5 * window if window else 0.0
    nan = float("nan")
    tol = f"±{rel_tol:.0%}"
    tu = f" {time_unit}" if time_unit else ""

    def none(reason, rule, startup_end=nan):
        return SteadyWindow(nan, nan, nan, 0, startup_end, rule, reason)

    n_usable = int(usable.sum())
    if n_usable < min_windows:
        return none(f"no steady window: only {n_usable} usable {noun}, fewer than {min_windows}",
                    "start-up not assessed (too few values)")
    level = float(np.median(y[usable]))
    if level == 0:
        return none(f"no steady window: the median {label} is 0, so no relative band can be drawn",
                    "start-up not assessed (median 0)")
    sign = 1.0 if level > 0 else -1.0
    ys = sign * y

    # ---- scatter and coarsening: the values the rule works on ("units")
    sigma = scatter(ys, usable)
    b = block_size(sigma, level, rel_tol, smooth) if coarsen else 1
    if b == 1:
        u_y, u_ok, u_lo, u_hi = ys, usable, t - half, t + half
        member = np.arange(len(t))
        unit_noun, coarse = noun, ""
    else:
        starts = np.arange(0, len(t), b)
        if len(t) - starts[-1] < -(-b // 2):  # a trailing block of fewer than b/2 samples is dropped
            starts = starts[:-1]
        ends = np.minimum(starts + b, len(t))
        member = np.full(len(t), -1)
        for k, (a, e) in enumerate(zip(starts, ends)):
            member[a:e] = k
        u_ok = np.array([usable[a:e].all() for a, e in zip(starts, ends)], dtype=bool)
        u_y = np.array([ys[a:e].mean() if ok else np.nan for a, e, ok in zip(starts, ends, u_ok)])
        u_lo = np.array([np.min(t[a:e] - half) for a, e in zip(starts, ends)])
        u_hi = np.array([np.max(t[a:e] + half) for a, e in zip(starts, ends)])
        unit_noun = f"blocks of {b} {noun}"
        coarse = (f"; on means of {b} consecutive {noun}, because their scatter (±{sigma / abs(level):.0%} of the "
                  f"median {_fmt(level, unit)}, from successive differences) is too large for a {tol} band")
    smoothing = f" (running median over {smooth})" if smooth > 1 else ""
    n_units = int(u_ok.sum())
    if n_units < min_windows:
        return none(f"no steady window: only {n_units} usable {unit_noun}, fewer than {min_windows}{coarse}",
                    "start-up not assessed (too few values)")

    # ---- start-up
    idx = np.flatnonzero(u_ok)
    if startup == "auto":
        smoothed = running_median(u_y, u_ok, smooth)
        k_end = None
        for pos, k in enumerate(idx[:len(idx) - min_windows + 1]):
            med = float(np.median(u_y[idx[pos:]]))
            if med > 0 and abs(smoothed[k] - med) <= rel_tol * med:
                k_end, ref = pos, med
                break
        if k_end is None:
            rule = (f"start-up never ended: the series{smoothing} never came within {tol} of the median of the "
                    f"rest (with at least {min_windows} {unit_noun} left) (startup='auto')")
            return none(f"no steady window: the series never settled, so no {min_windows} consecutive {unit_noun} "
                        f"fit within {tol} of a common level after a start-up ({label} from "
                        f"{_fmt(np.min(y[usable]), unit)} to {_fmt(np.max(y[usable]), unit)}){coarse}", rule)
        startup_end = float(u_lo[idx[k_end]])
        if k_end == 0:
            rule = (f"no start-up to exclude: the series{smoothing} lies within {tol} of the median of the rest "
                    f"({_fmt(sign * ref, unit)}) from its start at t = {startup_end:.4g}{tu} (startup='auto')")
        else:
            rule = (f"start-up excluded: the first {k_end} {unit_noun}, until the series{smoothing} first came "
                    f"within {tol} of the median of the rest ({_fmt(sign * ref, unit)}) at t = "
                    f"{startup_end:.4g}{tu} (startup='auto')")
        after = np.zeros_like(u_ok)
        after[idx[k_end:]] = True
    elif startup is None:
        startup_end = float(u_lo[idx[0]])
        rule = "no start-up excluded (startup=None)"
        after = u_ok.copy()
    else:
        startup_end = float(startup)
        after = u_ok & (u_lo >= startup_end - 1e-9 * max(abs(startup_end), half, 1e-300))
        rule = (f"start-up excluded: the first {int(u_ok.sum() - after.sum())} {unit_noun}, those starting "
                f"before t = {startup_end:.4g}{tu} (startup={startup_end:g} set by the caller)")
    n_after = int(after.sum())
    if n_after < min_windows:
        return none(f"no steady window: only {n_after} usable {unit_noun} after the start-up, fewer than "
                    f"{min_windows}{coarse}", rule, startup_end)

    # ---- steady run
    smoothed = running_median(u_y, after, smooth)
    i, j = longest_band_run(smoothed, rel_tol)
    if i < 0 or j - i + 1 < min_windows:
        return none(f"no steady window: no {min_windows} consecutive {unit_noun} fit within {tol} of a common "
                    f"level{smoothing} after the start-up ({label} from {_fmt(np.min(sign * u_y[after]), unit)} "
                    f"to {_fmt(np.max(sign * u_y[after]), unit)}){coarse}", rule, startup_end)
    t_start, t_end = float(u_lo[i]), float(u_hi[j])
    inside = usable & (member >= i) & (member <= j)
    values = y[inside]
    med = float(np.median(sign * u_y[i:j + 1]))
    dev = float(np.max(np.abs(sign * u_y[i:j + 1] - med)) / abs(med))
    reason = (f"{j - i + 1} consecutive {unit_noun} from t = {t_start:.4g}{tu} to {t_end:.4g}{tu} fit within {tol} "
              f"of a common level{smoothing}; median {label} = {_fmt(med, unit)}, "
              f"{'block means' if b > 1 else 'raw values'} within ±{dev:.1%} of it{coarse}")
    return SteadyWindow(t_start, t_end, float(np.mean(values)), int(len(values)), startup_end, rule, reason)
