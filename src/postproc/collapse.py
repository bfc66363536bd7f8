"""How far curves lie from one curve beyond their errors: the test of a collapse (curves that a
scaling should make one, e.g. profiles against a scaled coordinate).

:func:`collapse_spread` is the one entry; the silo's orifice profiles against r/R and the channel's
scaled velocity against x/δ0.95 use it.
"""
from __future__ import annotations

import math

import numpy as np

#: resamples of the parametric bootstrap of a spread (seeded)
N_RESAMPLE = 400


def collapse_spread(curves: list[tuple], grid: np.ndarray, seed: int = 0) -> dict:
    """The rms spread between curves beyond their errors, on a common grid.

    Each curve ``(x, y, se)`` is interpolated linearly onto ``grid`` (its error too). At each grid
    point the weighted mean :math:`\\bar y_j` of the curves; under a collapse
    :math:`\\langle (y_{ij}-\\bar y_j)^2\\rangle = \\sigma_{ij}^2 - 1/\\sum_i \\sigma_{ij}^{-2}`, so

    .. math:: s = \\sqrt{\\max\\left(0, \\overline{(y_{ij}-\\bar y_j)^2 - \\sigma_{ij}^2 + 1/W_j}\\right)}

    is 0 on a collapse and the curves' rms distance from one curve otherwise. Its error is the
    standard deviation of s over a seeded parametric bootstrap (each point redrawn from
    :math:`N(y, \\sigma)`; points taken as independent). Also returns :math:`\\chi^2/\\nu` of one
    curve through all, :math:`\\nu = n_{grid}(n_{curves}-1)`.

    Parameters
    ----------
    curves : list of (x, y, se)
        Each curve's abscissae (ascending), values and standard errors.
    grid : ndarray
        The common abscissae, inside every curve's range.
    seed : int
        Seed of the bootstrap.

    Returns
    -------
    dict
        ``s, s_se, chi2`` (χ²/ν), ``n`` (curves); NaN with fewer than two curves or a non-finite point.
    """
    y = np.array([np.interp(grid, x, v) for x, v, _ in curves])
    se = np.array([np.interp(grid, x, e) for x, _, e in curves])
    if len(curves) < 2 or not (np.isfinite(y).all() and (se > 0).all()):
        return {"s": float("nan"), "s_se": float("nan"), "chi2": float("nan"), "n": len(curves)}

    def spread(yy):
        w = 1.0 / se ** 2
        mean = (w * yy).sum(axis=0) / w.sum(axis=0)
        excess = np.mean((yy - mean) ** 2 - se ** 2 + 1.0 / w.sum(axis=0))
        return math.sqrt(max(0.0, excess)), float(np.sum(w * (yy - mean) ** 2))

    s, chi2 = spread(y)
    rng = np.random.default_rng(seed)
    boot = [spread(y + se * rng.standard_normal(y.shape))[0] for _ in range(N_RESAMPLE)]
    return {"s": s, "s_se": float(np.std(boot, ddof=1)), "chi2": chi2 / (grid.size * (len(curves) - 1)),
            "n": len(curves)}
