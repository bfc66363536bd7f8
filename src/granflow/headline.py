"""Headline observables of a finished case, with block-average standard errors.

The error-versus-cost study (``granflow.cost``, ``workflows/rules/cost.smk``)
compares a few numbers per scene across fidelity settings:

* channel: u_max/u_slip, delta_0.95/W, sigma_xx/W, the eq. 3.1 exponent;
* heap: alpha, delta/d-bar, the exponent of the exponential velocity tail;
* silo: the steady discharge rate W_f, the deviation of the orifice velocity
  profile from sqrt(1 - (r/R)^2), h_c/R.

:func:`measure_with_errors` analyses the averaging window once for the values,
then each of ``n_blocks`` consecutive blocks of it on its own; the standard error
of an observable is the standard deviation of its block values over
sqrt(n_valid blocks). The same scene analyses as the campaign do the work
(the scenes' pipeline modules), so the study measures what the campaign reports.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

#: scene -> [(observable key, label)] in the order of the figures and tables
HEADLINE = {
    "channel": [("u_ratio", "u_max/u_slip"), ("delta_over_W", "δ0.95/W"),
                ("sigma_xx_over_W", "σxx/W"), ("eq31_exponent", "eq. 3.1 exponent")],
    "heap": [("alpha", "α (deg)"), ("delta_over_d", "δ/d̄"), ("tail_exponent", "tail exponent")],
    "silo": [("W_f", "steady W_f (kg/s)"), ("profile_deviation", "orifice profile vs √(1−(r/R)²)"),
             ("h_c_over_R", "h_c/R")],
}


def _nan_observables(scene: str) -> dict:
    return {key: float("nan") for key, _ in HEADLINE[scene]}


def _finite(value) -> float:
    try:
        value = float(value)
    except (TypeError, ValueError):
        return float("nan")
    return value if math.isfinite(value) else float("nan")


def block_errors(blocks: list[dict], keys) -> dict:
    """Standard error of each key from its block values: std (ddof 1) / sqrt(n finite blocks)."""
    out = {}
    for key in keys:
        vals = np.array([b[key] for b in blocks], dtype=float)
        vals = vals[np.isfinite(vals)]
        se = float(np.std(vals, ddof=1) / np.sqrt(len(vals))) if len(vals) >= 2 else float("nan")
        out[key] = {"se": se, "n_blocks": int(len(vals))}
    return out


def measure_with_errors(scene: str, case_dir: str | Path, record: dict, t_average: float,
                        n_blocks: int = 4) -> dict:
    """Headline observables of one case over ``t_average`` of its averaging window, with block errors.

    For the channel and the heap the window is the first ``t_average`` of the
    averaging stage (times from its first dumped frame). For the silo it is the
    discharge up to ``t_average`` after the opening, whose steady part the analysis
    finds; the blocks split that steady part.

    Returns ``{key: {"x", "se", "n_blocks", "label"}, "window": [lo, hi]}``.
    """
    keys = [k for k, _ in HEADLINE[scene]]
    labels = dict(HEADLINE[scene])
    if scene == "silo":
        from .scenes.silo.pipeline import silo_observables

        full, (t0, t1) = silo_observables(case_dir, record, t_max=t_average)
        blocks = []
        if math.isfinite(t0) and math.isfinite(t1) and t1 > t0:
            edges = np.linspace(t0, t1, n_blocks + 1)
            blocks = [silo_observables(case_dir, record, t_max=t_average, steady=(a, b))[0]
                      for a, b in zip(edges[:-1], edges[1:])]
        window = [t0, t1]
    else:
        from .scenes.channel.pipeline import channel_observables
        from .scenes.heap.pipeline import heap_observables

        fn = channel_observables if scene == "channel" else heap_observables
        full = fn(case_dir, record, t_window=(0.0, t_average))
        edges = np.linspace(0.0, t_average, n_blocks + 1)
        blocks = [fn(case_dir, record, t_window=(a, b)) for a, b in zip(edges[:-1], edges[1:])]
        window = [0.0, t_average]
    errs = block_errors(blocks, keys) if blocks else {k: {"se": float("nan"), "n_blocks": 0} for k in keys}
    out = {key: {"x": full[key], "se": errs[key]["se"], "n_blocks": errs[key]["n_blocks"], "label": labels[key]}
           for key in keys}
    out["window"] = window
    return out
