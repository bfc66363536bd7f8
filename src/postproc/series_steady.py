"""The steady window of any time series: where it fits a band about a common level, after a stated start-up.

:func:`steady_window` measures the series' scatter, coarsens and smooths it
(:func:`scatter`, :func:`block_size`, :func:`running_median`), excludes the
start-up by an explicit rule and finds the longest run within the band
(:func:`longest_band_run`); its verdict is a :class:`SteadyWindow` stating the
rule and the numbers in words. :func:`check_series` checks a series and the
band settings. :mod:`postproc.series` (rates of cumulative series) re-exports
the public names.
"""
from __future__ import annotations

from collections import deque
from dataclasses import dataclass

import numpy as np


def check_series(t, y, rel_tol: float, min_windows: int, name: str = "y") -> tuple[np.ndarray, np.ndarray]:
    """``t`` and ``y`` as equal-length 1-D float arrays, after checking them and the band settings.

    Parameters
    ----------
    t, y : array_like
        Sample times and values.
    rel_tol : float
        Relative half-width of the band.
    min_windows : int
        Shortest acceptable steady run.
    name : str
        The name of ``y`` in the message.

    Returns
    -------
    t, y : ndarray of float, 1-D

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

    Parameters
    ----------
    y : array_like, 1-D
        Values, any unit.
    usable : array_like of bool, shape (len(y),)
        Which samples count; a False one ends a run.
    width : int
        Samples in the window (an even width acts as the next odd one).

    Returns
    -------
    ndarray, shape (len(y),)
        The unit of ``y``; NaN where not usable.
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

    Parameters
    ----------
    w : array_like, 1-D
        Values, any unit; a non-finite or non-positive one ends a run.
    rel_tol : float
        :math:`\\epsilon`, relative half-width of the band.

    Returns
    -------
    i, j : int
        First and last index of the run (inclusive).
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

    Parameters
    ----------
    y : array_like, 1-D
        Values, any unit.
    usable : array_like of bool, optional
        Which samples count (default: the finite ones); a difference needs both
        its samples usable.

    Returns
    -------
    float
        In the unit of ``y``.
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

    Parameters
    ----------
    sigma : float
        :math:`\\hat\\sigma`, the sample-to-sample noise (:func:`scatter`).
    level : float
        :math:`Y`, the level of the series (its median), in the unit of ``sigma``.
    rel_tol : float
        :math:`\\epsilon`, relative half-width of the band.
    smooth : int
        :math:`w`, width of the running median (below 3: none).

    Returns
    -------
    int
        1 when ``sigma`` or ``level`` is not finite or ``level`` is 0.
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
