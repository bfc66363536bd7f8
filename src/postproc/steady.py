"""Steady-state detection from the centre-of-mass velocity time series.

The channel paper (Debnath, Kesava Rao & Kumaran 2022, section 3.1, figure 3)
calls a flow steady when the centre-of-mass velocity :math:`u_{cm}(t)` varies
by less than 1 % about its time average (1-2 % at :math:`\\bar\\phi = 0.62`);
denser packings jam (no flow) and looser ones oscillate and then accelerate
(no steady state).  :func:`detect_steady_state` turns that statement into a
test with three outcomes, and :func:`block_average` gives the mean of a
correlated series with an honest standard error.

Units: time in :math:`\\sqrt{d_p/g}`, speed in :math:`\\sqrt{g d_p}`.  The
speed passed in is the *downward* speed :math:`u = -u_y` (positive for a
draining channel).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

STEADY = "steady"
NO_STEADY_STATE = "no_steady_state"
JAMMED = "jammed"

#: Default speed below which the channel counts as jammed, in sqrt(g d_p).
DEFAULT_JAM_SPEED = 1e-3


@dataclass(frozen=True)
class SteadyState:
    """Verdict of :func:`detect_steady_state`.

    Attributes
    ----------
    status : str
        ``"steady"``, ``"no_steady_state"`` or ``"jammed"``.
    t_start : float
        Start of the steady interval (time units :math:`\\sqrt{d_p/g}`); NaN unless
        steady.
    mean : float
        Mean speed over the interval the verdict is based on (the steady
        interval when steady, otherwise the last ``window``).
    rel_fluct : float
        Relative fluctuation :math:`\\mathrm{std}(u)/|\\bar u|` over that interval.
    slope : float
        Least-squares slope :math:`du/dt` over that interval (speed per time unit).
    reason : str
        One sentence with the measured numbers behind the verdict.
    """

    status: str
    t_start: float
    mean: float
    rel_fluct: float
    slope: float
    reason: str


def _segment_statistics(t: np.ndarray, u: np.ndarray) -> tuple[float, float, float, float]:
    """Mean, relative fluctuation, slope and relative drift of one segment.

    The relative drift is the change of the least-squares line across the
    segment divided by the mean,

    .. math:: \\Delta_{rel} = |b|\\,(t_{end} - t_{start}) / |\\bar u| .
    """
    mean = float(np.mean(u))
    std = float(np.std(u, ddof=1)) if len(u) > 1 else 0.0
    slope = float(np.polyfit(t, u, 1)[0]) if len(u) > 1 and np.ptp(t) > 0 else 0.0
    if mean == 0.0:
        return mean, np.inf, slope, np.inf
    span = float(t[-1] - t[0])
    return mean, std / abs(mean), slope, abs(slope) * span / abs(mean)


def detect_steady_state(
    t,
    u,
    window: float,
    rel_tol: float = 0.01,
    jam_speed: float = DEFAULT_JAM_SPEED,
    grid_step: float | None = None,
    fluct_tol: float | None = None,
) -> SteadyState:
    """Decide whether a centre-of-mass velocity series reached a steady state.

    Candidate start times :math:`t_s` lie on a grid of spacing ``grid_step``
    from the first sample up to :math:`t_{end} - \\mathrm{window}`.  A candidate
    is accepted when the series from :math:`t_s` to the end satisfies both

    .. math::
        \\frac{\\mathrm{std}(u)}{|\\bar u|} < \\mathrm{rel\\_tol}, \\qquad
        \\frac{|b|\\,(t_{end}-t_s)}{|\\bar u|} < \\mathrm{rel\\_tol},

    with :math:`b` the least-squares slope :math:`du/dt` (no significant linear
    trend).  The earliest accepted candidate is the start of the steady state.

    Before that, the mean speed over the last ``window`` is compared with
    ``jam_speed``: below it the flow is ``"jammed"`` (the paper's
    :math:`\\bar\\phi > 0.62`).  If no candidate is accepted the verdict is
    ``"no_steady_state"`` with the drift and fluctuation measured over the
    last ``window`` (the most lenient candidate) in ``reason``.

    Parameters
    ----------
    t : array_like
        Sample times, :math:`\\sqrt{d_p/g}`; need not be uniform, sorted here.
    u : array_like
        Downward centre-of-mass speed :math:`u_{cm} = -u_{y,cm}`, :math:`\\sqrt{g d_p}`.
    window : float
        Minimum length of the steady interval (time units), e.g. the averaging
        time (the paper averages over 600).
    rel_tol : float
        Tolerance on both relative fluctuation and relative drift (paper: 0.01;
        0.02 admits the fluctuating :math:`\\bar\\phi = 0.62` flows).
    jam_speed : float
        Absolute speed below which the channel is jammed, :math:`\\sqrt{g d_p}`.
    grid_step : float, optional
        Spacing of candidate start times; default ``window / 10``.
    fluct_tol : float, optional
        Tolerance on the relative fluctuation alone; default ``rel_tol``.

    Returns
    -------
    SteadyState

    Raises
    ------
    ValueError
        If ``t`` and ``u`` are not 1-D arrays of equal length, or ``window``,
        ``rel_tol``, ``fluct_tol`` or ``grid_step`` is not positive.
    """
    t = np.asarray(t, dtype=float)
    u = np.asarray(u, dtype=float)
    if t.shape != u.shape or t.ndim != 1:
        raise ValueError(f"t and u must be 1-D arrays of equal length, got {t.shape} and {u.shape}")
    fluct_tol = rel_tol if fluct_tol is None else float(fluct_tol)
    if window <= 0 or rel_tol <= 0 or fluct_tol <= 0:
        raise ValueError("window, rel_tol and fluct_tol must be positive")
    good = np.isfinite(t) & np.isfinite(u)
    order = np.argsort(t[good], kind="stable")
    t, u = t[good][order], u[good][order]
    nan = float("nan")
    if len(t) < 3 or t[-1] - t[0] < window:
        span = float(t[-1] - t[0]) if len(t) else 0.0
        return SteadyState(NO_STEADY_STATE, nan, nan, nan, nan,
                           f"series spans {span:.4g} time units, shorter than window {window:.4g}")

    t_end = t[-1]
    last = t >= t_end - window
    mean_last, fluct_last, slope_last, drift_last = _segment_statistics(t[last], u[last])
    if abs(mean_last) < jam_speed:
        return SteadyState(JAMMED, nan, mean_last, fluct_last, slope_last,
                           f"mean speed {mean_last:.3g} over the last {window:.4g} time units "
                           f"is below jam_speed {jam_speed:.3g}")

    step = window / 10.0 if grid_step is None else float(grid_step)
    if step <= 0:
        raise ValueError("grid_step must be positive")
    for t_s in np.arange(t[0], t_end - window + 0.5 * step, step):
        t_s = min(t_s, t_end - window)
        seg = t >= t_s
        mean, fluct, slope, drift = _segment_statistics(t[seg], u[seg])
        if fluct < fluct_tol and drift < rel_tol:
            return SteadyState(STEADY, float(t[seg][0]), mean, fluct, slope,
                               f"from t = {t[seg][0]:.4g} to {t_end:.4g}: relative fluctuation "
                               f"{fluct:.2%} (< {fluct_tol:.2%}) and relative drift {drift:.2%} "
                               f"(< {rel_tol:.2%})")
    return SteadyState(NO_STEADY_STATE, nan, mean_last, fluct_last, slope_last,
                       f"over the last {window:.4g} time units the relative drift is {drift_last:.2%} "
                       f"(slope {slope_last:.3g} per time unit) and the relative fluctuation "
                       f"{fluct_last:.2%}; tolerances {rel_tol:.2%} (drift) and {fluct_tol:.2%} (fluctuation)")


def block_average(x, n_blocks: int) -> tuple[float, float]:
    """Mean and standard error of a correlated series by block averaging.

    The series is cut into ``n_blocks`` contiguous blocks of equal length
    (leading samples that do not fill a block are dropped, so the latest data
    are kept); the standard error is that of the block means,

    .. math:: \\mathrm{se} = \\sqrt{\\frac{\\sum_k (\\bar x_k - \\bar x)^2}{n_b (n_b - 1)}},

    which is unbiased when blocks are longer than the correlation time.

    Parameters
    ----------
    x : array_like
        Samples, e.g. :math:`u_{cm}(t)` over the steady interval.
    n_blocks : int
        Number of blocks, at least 2.

    Returns
    -------
    mean, se : float
        In the unit of ``x``.

    Raises
    ------
    ValueError
        If ``n_blocks`` is below 2 or above the number of samples.
    """
    x = np.asarray(x, dtype=float).ravel()
    n_blocks = int(n_blocks)
    if n_blocks < 2:
        raise ValueError("n_blocks must be at least 2")
    if len(x) < n_blocks:
        raise ValueError(f"{len(x)} samples cannot fill {n_blocks} blocks")
    length = len(x) // n_blocks
    blocks = x[len(x) - length * n_blocks:].reshape(n_blocks, length).mean(axis=1)
    return float(blocks.mean()), float(blocks.std(ddof=1) / np.sqrt(n_blocks))
