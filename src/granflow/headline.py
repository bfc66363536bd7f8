"""Headline observables of a finished case, with standard errors that allow for autocorrelation.

The error-versus-cost study (``granflow.cost``, ``workflows/rules/cost.smk``)
compares a few numbers per scene across fidelity settings; each scene names
them (``Scene.headline``) and measures them (``Scene.observables``) with the
same analysis the campaign runs, so the study measures what the campaign reports.

:func:`measure_with_errors` analyses the averaging window once for the values.
The standard error of each value comes from ``n_series`` consecutive equal
sub-windows of that window, each analysed on its own: the error of the mean of
the sub-window values, with their statistical inefficiency :math:`g`
(:func:`postproc.autocorr.mean_error`),

.. math:: \\mathrm{se} = \\sqrt{g}\\,\\frac{\\operatorname{std}_{ddof=1}(x_k)}{\\sqrt{n}} ,

so that fluctuations slower than a sub-window count too.  As a cross-check, the
block error (standard deviation of the values of ``n_blocks`` consecutive
blocks over sqrt(n valid blocks), the former error) is reported beside it as
``se_block``, from its own analysis of the blocks: a scene's observables (fits,
ratios, thresholds) are not means of frames, so the block values cannot be
rebuilt from the sub-window values.  With fewer than
:data:`postproc.autocorr.MIN_SAMPLES` finite sub-window values (sub-windows too
short for the scene's analysis) the block error is the error; while :math:`g` is not
reliable (:math:`n < 50 g`, always so with 16 sub-windows) the error is the larger of
the two (:func:`postproc.autocorr.combined_error`; ``se_method`` says which).

The window is analysed ``1 + n_blocks + n_series`` times, each time re-reading
the dumps for the frames inside the (sub-)window.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from postproc.autocorr import combined_error, mean_error

from . import registry


def block_errors(blocks: list[dict], keys) -> dict:
    """Standard error of each key from its block values: std (ddof 1) / sqrt(n finite blocks)."""
    out = {}
    for key in keys:
        vals = np.array([b[key] for b in blocks], dtype=float)
        vals = vals[np.isfinite(vals)]
        se = float(np.std(vals, ddof=1) / np.sqrt(len(vals))) if len(vals) >= 2 else float("nan")
        out[key] = {"se": se, "n_blocks": int(len(vals))}
    return out


def window_values(scene, case_dir: Path, record: dict, t_average: float, t0: float, t1: float,
                  n: int) -> list[dict]:
    """The scene's observables over each of ``n`` consecutive equal parts of ``[t0, t1]`` (none if no window)."""
    if not (math.isfinite(t0) and math.isfinite(t1) and t1 > t0) or n < 1:
        return []
    edges = np.linspace(t0, t1, n + 1)
    return [scene.observables(case_dir, record, t_average, block=(a, b))[0] for a, b in zip(edges[:-1], edges[1:])]


def series_errors(series: list[dict], keys) -> dict:
    """Per key, :func:`postproc.autocorr.mean_error` of its values over consecutive sub-windows."""
    return {key: mean_error(np.array([s[key] for s in series], dtype=float)) for key in keys}


def measure_with_errors(scene_name: str, case_dir: str | Path, record: dict, t_average: float,
                        n_blocks: int = 4, n_series: int = 16) -> dict:
    """Headline observables of one case over ``t_average`` of its averaging window, with their errors.

    The scene measures over the first ``t_average`` of its averaging stage and says
    which window it used (the silo: the steady part of the discharge up to
    ``t_average``); the errors split that window into ``n_series`` equal
    sub-windows (the error) and into ``n_blocks`` equal blocks (the cross-check).

    Returns
    -------
    dict
        ``{key: {"x", "se", "se_method", "se_block", "n_blocks", "g", "n_series",
        "reliable", "label"}, "window": [lo, hi]}``: ``se`` is the
        autocorrelation-aware error of the sub-window values (``se_method``
        ``"autocorrelation"``), or the block error ``se_block`` when fewer than
        4 sub-window values are finite (``"block"``); ``g`` is the statistical
        inefficiency of the sub-window values, in sub-windows, ``n_series``
        the number of finite ones and ``reliable`` whether
        :math:`n \\ge 50 g` (emcee's criterion; not met with 16 sub-windows, it
        says how far to trust :math:`g`); ``n_blocks`` counts the finite
        block values.
    """
    scene = registry.get(scene_name)
    case_dir = Path(case_dir)
    keys = [k for k, _ in scene.headline]
    labels = dict(scene.headline)
    full, (t0, t1) = scene.observables(case_dir, record, t_average)
    blocks = window_values(scene, case_dir, record, t_average, t0, t1, n_blocks)
    series = window_values(scene, case_dir, record, t_average, t0, t1, n_series)
    block = block_errors(blocks, keys) if blocks else {k: {"se": float("nan"), "n_blocks": 0} for k in keys}
    acf = series_errors(series, keys)
    out = {}
    for key in keys:
        e = acf[key]
        se, method = combined_error(e, block[key]["se"])
        out[key] = {"x": full[key], "se": se, "se_method": method, "se_block": block[key]["se"],
                    "n_blocks": block[key]["n_blocks"], "g": e.g, "n_series": e.n, "reliable": e.reliable,
                    "label": labels[key]}
    out["window"] = [t0, t1]
    return out
