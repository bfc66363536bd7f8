"""Standard errors of time averages of correlated series.

Consecutive samples of a simulation (frames, thermo rows, block values) are
correlated, so the mean of :math:`n` of them varies more than
:math:`\\sigma^2/n`.  With the normalised autocorrelation function
:math:`\\rho_k` of the series, the variance of the mean is

.. math:: \\operatorname{var}(\\bar x) = \\frac{g\\,\\sigma^2}{n}, \\qquad
    g = 1 + 2 \\sum_{k \\ge 1} \\rho_k ,

where :math:`g` is the *statistical inefficiency* (the integrated
autocorrelation time in samples): the series holds :math:`n/g` independent
samples.  :math:`g` is estimated by ``emcee.autocorr.integrated_time``
(Foreman-Mackey et al. 2013): the autocorrelation function by FFT, summed up
to the smallest window :math:`M` with :math:`M \\ge c\\,\\hat g(M)` (Sokal's
automatic window).  The estimate is trusted when :math:`n \\ge 50\\,g`
(emcee's own criterion, its ``tol``).

* :func:`statistical_inefficiency`: :math:`g` of a 1-D series;
* :func:`mean_error`: the mean of a series and its standard error
  (:class:`MeanError`);
* :func:`weighted_mean_error`: the same for a series of sub-block sums with
  their frame counts (e.g. the sub-blocks of :mod:`postproc.blocks`).
"""
from __future__ import annotations

import logging
from contextlib import contextmanager
from dataclasses import dataclass

import numpy as np

#: Fewest finite values from which :math:`g` is estimated (NaN below).
MIN_SAMPLES = 4
#: The estimate of :math:`g` is reliable when the series holds this many times :math:`g` samples
#: (emcee's ``tol``).
RELIABLE_OVER_G = 50


class _DropAll(logging.Filter):
    def filter(self, record: logging.LogRecord) -> bool:
        """Drop every record (a :class:`logging.Filter` that lets nothing through).

        Parameters
        ----------
        record : logging.LogRecord

        Returns
        -------
        bool
            Always False.
        """
        return False


@contextmanager
def _quiet_emcee():
    """Silence emcee's "chain is shorter than 50 tau" warning (a ``logging`` record) while inside.

    :class:`MeanError` says the same thing in ``reliable``.
    """
    logger = logging.getLogger("emcee.autocorr")
    drop = _DropAll()
    logger.addFilter(drop)
    try:
        yield
    finally:
        logger.removeFilter(drop)


def _finite_1d(x, name: str = "x") -> np.ndarray:
    x = np.asarray(x, dtype=float)
    if x.ndim != 1:
        raise ValueError(f"{name} must be a 1-D series, got shape {x.shape}")
    return x[np.isfinite(x)]


def statistical_inefficiency(x, c: float = 5.0) -> float:
    """Statistical inefficiency :math:`g` (integrated autocorrelation time, in samples) of a 1-D series.

    .. math:: g = 1 + 2 \\sum_{k=1}^{M} \\hat\\rho_k , \\qquad
        M = \\min\\{m : m \\ge c\\, \\hat g(m)\\}

    by ``emcee.autocorr.integrated_time(x, c=c, quiet=True)``, clipped to
    :math:`g \\ge 1` (an anticorrelated estimate is not trusted to shrink an
    error).  Non-finite values are dropped first (the rest is treated as one
    consecutive series).

    Parameters
    ----------
    x : array_like, 1-D
        Equally spaced samples.
    c : float
        Window factor of the automatic window (emcee's default 5).

    Returns
    -------
    float
        :math:`g \\ge 1`; 1 for a constant series; NaN with fewer than
        :data:`MIN_SAMPLES` finite values.
    """
    x = _finite_1d(x)
    if len(x) < MIN_SAMPLES:
        return float("nan")
    if np.all(x == x[0]):
        return 1.0
    with _quiet_emcee():
        from emcee.autocorr import integrated_time  # emcee imports scipy.stats (~1 CPU-s): only when used

        g = float(integrated_time(x, c=c, tol=RELIABLE_OVER_G, quiet=True)[0])
    return max(g, 1.0) if np.isfinite(g) else float("nan")


@dataclass(frozen=True)
class MeanError:
    """Mean of a correlated series and its standard error (:func:`mean_error`).

    Attributes
    ----------
    mean : float
        Mean of the finite values (NaN when there are none).
    se : float
        Standard error of the mean with the statistical inefficiency,
        :math:`\\sqrt{g}\\,` ``se_naive`` (NaN when :math:`g` is).
    g : float
        Statistical inefficiency, in samples (:func:`statistical_inefficiency`).
    n : int
        Finite values used.
    n_eff : float
        Effective number of independent values, :math:`n/g`.
    reliable : bool
        :math:`n \\ge 50\\, g`: emcee's criterion for trusting its estimate of
        :math:`g` (its ``tol``).  Shorter series give a :math:`g` that is
        usually too small.
    se_naive : float
        The error if the values were independent, :math:`s/\\sqrt n`.
    """

    mean: float
    se: float
    g: float
    n: int
    n_eff: float
    reliable: bool
    se_naive: float


def _from_parts(mean: float, se_naive: float, g: float, n: int) -> MeanError:
    se = se_naive * np.sqrt(g) if np.isfinite(g) else float("nan")
    n_eff = n / g if np.isfinite(g) else float("nan")
    reliable = bool(np.isfinite(g) and n >= RELIABLE_OVER_G * g)
    return MeanError(float(mean), float(se), float(g), int(n), float(n_eff), reliable, float(se_naive))


def mean_error(x, c: float = 5.0) -> MeanError:
    """Mean of a 1-D series and its standard error, allowing for autocorrelation.

    .. math:: \\operatorname{var}(\\bar x) = \\frac{g\\, s^2}{n}, \\qquad
        \\mathrm{se} = \\frac{s}{\\sqrt n}\\sqrt g , \\qquad n_{eff} = \\frac{n}{g}

    with :math:`s` the sample standard deviation (ddof 1) and :math:`g` the
    statistical inefficiency (:func:`statistical_inefficiency`).  The result
    is ``reliable`` when :math:`n \\ge 50\\,g`, emcee's own criterion.

    Parameters
    ----------
    x : array_like, 1-D
        Equally spaced samples; non-finite values are dropped.
    c : float
        Window factor of the automatic window.

    Returns
    -------
    MeanError
        ``se`` and ``g`` are NaN with fewer than :data:`MIN_SAMPLES` finite
        values (``se_naive`` needs 2); a constant series has ``g = 1`` and
        ``se = 0``.
    """
    x = _finite_1d(x)
    n = len(x)
    mean = float(np.mean(x)) if n else float("nan")
    se_naive = float(np.std(x, ddof=1) / np.sqrt(n)) if n >= 2 else float("nan")
    return _from_parts(mean, se_naive, statistical_inefficiency(x, c), n)


def weighted_mean_error(sums, counts, c: float = 5.0) -> MeanError:
    """Mean over all frames of a series of sub-block sums, and its standard error.

    Sub-block :math:`i` holds :math:`c_i` frames whose values sum to
    :math:`S_i`; its mean is :math:`y_i = S_i/c_i`.  The mean over all frames
    is the count-weighted mean of the sub-block means, and its variance the
    ratio-estimator variance times the statistical inefficiency :math:`g` of
    the series :math:`y_i`:

    .. math:: \\bar y = \\frac{\\sum_i S_i}{\\sum_i c_i}, \\qquad
        \\operatorname{var}(\\bar y) = g\\,\\frac{n}{n-1}\\,
        \\frac{\\sum_i c_i^2 (y_i - \\bar y)^2}{(\\sum_i c_i)^2}

    which for equal counts is :math:`g\\, s_y^2/n` as in :func:`mean_error`.

    Parameters
    ----------
    sums, counts : array_like, 1-D
        Sub-block sums and their frame counts, in time order.  Sub-blocks with
        no frame or a non-finite sum are dropped.
    c : float
        Window factor of the automatic window.

    Returns
    -------
    MeanError
        With ``n`` the number of sub-blocks used and ``g`` in sub-blocks.
    """
    sums = np.asarray(sums, dtype=float)
    counts = np.asarray(counts, dtype=float)
    if sums.ndim != 1 or sums.shape != counts.shape:
        raise ValueError(f"sums and counts must be 1-D arrays of equal length, got {sums.shape} and {counts.shape}")
    ok = np.isfinite(sums) & np.isfinite(counts) & (counts > 0)
    sums, counts = sums[ok], counts[ok]
    n = len(sums)
    if n == 0:
        return _from_parts(float("nan"), float("nan"), float("nan"), 0)
    means = sums / counts
    mean = float(sums.sum() / counts.sum())
    w = counts / counts.sum()
    se_naive = float(np.sqrt(n / (n - 1) * np.sum(w ** 2 * (means - mean) ** 2))) if n >= 2 else float("nan")
    return _from_parts(mean, se_naive, statistical_inefficiency(means, c), n)



def combined_error(e: MeanError, se_block: float) -> tuple[float, str]:
    """The error to report, and how it was chosen, from the autocorrelation analysis and the blocks.

    The blocks imply an inefficiency of their own, :math:`g_b = (se_{block} / se_{naive})^2`.
    :math:`g` counts as resolved only when the series is long enough for both,
    :math:`n \\ge 50 \\max(g, g_b)`: a short series underestimates :math:`g` (emcee's
    estimate of a true g of 10 from 100 values had a median of 4.7 and a 5th percentile of 1.9),
    so a small :math:`g` alone does not prove the series resolved its correlation.

    - ``"autocorrelation"``: resolved: ``e.se``.
    - ``"max(autocorrelation, block)"``: not resolved: the larger of ``e.se`` and the block
      error, so a correlation the series is too short to resolve is not hidden. In 1000 AR(1)
      windows of 8-30 correlation times, 16 sub-windows alone covered the true mean at 2 se in
      75-90 % of the windows, 4 blocks in 81-85 %.
    - ``"block"``: fewer than :data:`MIN_SAMPLES` finite values: the block error.

    Parameters
    ----------
    e : MeanError
        The autocorrelation analysis of the series (:func:`mean_error` or
        :func:`weighted_mean_error`).
    se_block : float
        The block error of the same mean, in the unit of the series (NaN when
        there is none).

    Returns
    -------
    se : float
        The error to report, in the unit of the series.
    method : str
        ``"autocorrelation"``, ``"max(autocorrelation, block)"`` or ``"block"``.
    """
    if e.n < MIN_SAMPLES or not np.isfinite(e.se):
        return float(se_block), "block"
    if not np.isfinite(se_block):
        return float(e.se), "autocorrelation"
    g_block = (se_block / e.se_naive) ** 2 if e.se_naive > 0 else (np.inf if se_block > 0 else 1.0)
    if e.reliable and e.n >= RELIABLE_OVER_G * max(e.g, g_block):
        return float(e.se), "autocorrelation"
    return float(max(e.se, se_block)), "max(autocorrelation, block)"


def statistical_inefficiencies(y, c: float = 5.0) -> np.ndarray:
    """:func:`statistical_inefficiency` of every column of a finite (n, m) array.

    emcee's estimator, applied to all columns at once: ``emcee.autocorr.function_1d`` (FFT of
    the centred series, zero-padded to twice the next power of two) and ``auto_window``
    (the first lag :math:`M \\ge c\\,\\hat g(M)`), vectorised over columns. One emcee call
    per column would loop in Python: 2.95 CPU-s for 30,000 columns of 128 values against
    0.55 s here (a coarse-grained silo grid has ~10^5 node-columns per analysis);
    ``tests/unit/test_field_errors.py`` checks that each column equals emcee's own
    :func:`statistical_inefficiency` to round-off. Clipped to :math:`g \\ge 1`; 1 for a
    constant column; NaN with fewer than :data:`MIN_SAMPLES` rows.

    Parameters
    ----------
    y : array_like, shape (n, m)
        ``m`` series of ``n`` equally spaced samples each, one per column; finite
        (a NaN makes its column's :math:`g` NaN).
    c : float
        Window factor of the automatic window (emcee's default 5).

    Returns
    -------
    ndarray, shape (m,)
        :math:`g` of each column, in samples.

    Raises
    ------
    ValueError
        If ``y`` is not two-dimensional.
    """
    y = np.asarray(y, dtype=float)
    n, m = y.shape
    if n < MIN_SAMPLES:
        return np.full(m, np.nan)
    constant = np.all(y == y[:1], axis=0)
    size = 2 * (1 << max(n - 1, 0).bit_length())
    f = np.fft.rfft(y - y.mean(axis=0), n=size, axis=0)
    acf = np.fft.irfft(f.real ** 2 + f.imag ** 2, n=size, axis=0)[:n]
    with np.errstate(invalid="ignore", divide="ignore"):
        acf = acf / acf[:1]
    taus = 2.0 * np.cumsum(acf, axis=0) - 1.0
    inside = np.arange(n)[:, None] < c * taus
    window = np.where(inside.any(axis=0), np.argmin(inside, axis=0), n - 1)
    g = taus[window, np.arange(m)]
    g = np.where(np.isfinite(g), np.maximum(g, 1.0), np.nan)
    return np.where(constant, 1.0, g)


def combined_errors(se, se_naive, g, n, se_block) -> np.ndarray:
    """:func:`combined_error` of many series at once (arrays of ``MeanError`` fields, ``n`` values each).

    Element-wise, the same choice as :func:`combined_error`: the autocorrelation
    error where :math:`n \\ge 50 \\max(g, g_b)` (or there is no finite block
    error), else the larger of the two, and the block error where the
    autocorrelation error is not finite or :math:`n <` :data:`MIN_SAMPLES`.

    Parameters
    ----------
    se, se_naive, g : array_like, shape (m,)
        The ``se``, ``se_naive`` and ``g`` (in samples) of :class:`MeanError` for
        each series; errors in the unit of its values.
    n : int or array_like of int, shape (m,)
        Finite values of each series.
    se_block : array_like, shape (m,)
        The block error of each series, same unit (NaN when there is none).

    Returns
    -------
    ndarray, shape (m,)
        The error to report for each series.
    """
    se, se_naive, g, se_block = (np.asarray(a, dtype=float) for a in (se, se_naive, g, se_block))
    with np.errstate(invalid="ignore", divide="ignore"):
        g_block = np.where(se_naive > 0, (se_block / se_naive) ** 2, np.where(se_block > 0, np.inf, 1.0))
    resolved = n >= RELIABLE_OVER_G * np.fmax(g, g_block)
    out = np.where(resolved | ~np.isfinite(se_block), se, np.fmax(se, se_block))
    return np.where(np.isfinite(se) & (n >= MIN_SAMPLES), out, se_block)


__all__ = ["MIN_SAMPLES", "RELIABLE_OVER_G", "MeanError", "combined_error", "combined_errors",
           "statistical_inefficiencies", "mean_error", "statistical_inefficiency",
           "weighted_mean_error"]
