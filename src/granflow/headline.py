"""Headline observables of a finished case, with block-average standard errors.

The error-versus-cost study (``granflow.cost``, ``workflows/rules/cost.smk``)
compares a few numbers per scene across fidelity settings; each scene names
them (``Scene.headline``) and measures them (``Scene.observables``) with the
same analysis the campaign runs, so the study measures what the campaign reports.

:func:`measure_with_errors` analyses the averaging window once for the values,
then each of ``n_blocks`` consecutive blocks of it on its own; the standard error
of an observable is the standard deviation of its block values over
sqrt(n_valid blocks).
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

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


def measure_with_errors(scene_name: str, case_dir: str | Path, record: dict, t_average: float,
                        n_blocks: int = 4) -> dict:
    """Headline observables of one case over ``t_average`` of its averaging window, with block errors.

    The scene measures over the first ``t_average`` of its averaging stage and says
    which window it used (the silo: the steady part of the discharge up to
    ``t_average``); the blocks split that window into ``n_blocks`` equal parts.

    Returns ``{key: {"x", "se", "n_blocks", "label"}, "window": [lo, hi]}``.
    """
    scene = registry.get(scene_name)
    keys = [k for k, _ in scene.headline]
    labels = dict(scene.headline)
    full, (t0, t1) = scene.observables(Path(case_dir), record, t_average)
    blocks = []
    if math.isfinite(t0) and math.isfinite(t1) and t1 > t0:
        edges = np.linspace(t0, t1, n_blocks + 1)
        blocks = [scene.observables(Path(case_dir), record, t_average, block=(a, b))[0]
                  for a, b in zip(edges[:-1], edges[1:])]
    errs = block_errors(blocks, keys) if blocks else {k: {"se": float("nan"), "n_blocks": 0} for k in keys}
    out = {key: {"x": full[key], "se": errs[key]["se"], "n_blocks": errs[key]["n_blocks"], "label": labels[key]}
           for key in keys}
    out["window"] = [t0, t1]
    return out
