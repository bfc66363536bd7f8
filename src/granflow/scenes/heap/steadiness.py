"""Whether the heap's averaging window is steady: the change of the dynamic angle of repose across it.

Fan et al. (2013, §3.1, Fig. 4b inset) find α = 25.69 ± 0.07° "nearly constant" once the heap fills steadily:
in the frame that rises with the heap nothing should change. Each frame's α comes from the plane fitted to that
frame's free surface (:func:`granflow.scenes.heap.analysis.fit_surface`, its ``alpha_t``); the change across the
window is the least-squares straight line through them, slope times the window's length,

.. math:: \\Delta\\alpha = \\frac{\\sum_k (t_k - \\bar t)(\\alpha_k - \\bar\\alpha)}{\\sum_k (t_k - \\bar t)^2}\\,(t_n - t_1),

its error the line's own widened by the statistical inefficiency g of the residuals (surges span frames). The
paper's ± 0.07° is its angle's variation over a 10 s window; it is the paper's error of the row, whose value is 0.
"""
from __future__ import annotations

import pandas as pd

from postproc import series

import granflow.scenes.heap.analysis as hp
from granflow.validation import Check, systematic

QUANTITY = "change of α across the averaging window (steady filling: α nearly constant)"
#: the paper's α is steady to within its variation in time (§3.1), degrees
PAPER_VARIATION = 0.07


def change_across(alpha_t: pd.DataFrame) -> tuple[float, float, int]:
    """``(Δα, its error, frames)`` of one surface fit's per-frame angles (``t``, ``alpha_deg``); NaN with fewer
    than 4 frames."""
    d = alpha_t[["t", "alpha_deg"]].astype(float)
    return series.change_across(d["t"].to_numpy(), d["alpha_deg"].to_numpy(), min_points=4, correlated=True)


def alpha_change_check(case: str, nominal: pd.DataFrame | None, variants: dict[str, pd.DataFrame],
                       middle: tuple[float, float], why_not: str = "") -> Check:
    """The row of Δα for one case: ``nominal`` the per-frame angles over the planar middle (fractions ``middle``
    of the flowing length), ``variants`` those over other fit ranges (the systematic error); not measured, with
    ``why_not``, without frames."""
    paper = f"0: nearly constant in the steady state (the paper's α varies by ± {PAPER_VARIATION}° in time)"
    source = "§3.1, Fig. 4b inset"
    if nominal is None:
        return Check(QUANTITY, paper, source, float("nan"), case=case, paper_range=(0.0, 0.0),
                     paper_error=PAPER_VARIATION, unit="deg", note=why_not)
    change, se, n = change_across(nominal)
    syst, text = systematic(change, {name: change_across(v)[:2] for name, v in variants.items()}, central_se=se)
    note = (f"straight line through the {n} frames' α (each frame's plane over {middle[0]:g}-{middle[1]:g} of the "
            f"flowing length), its slope times the window's length; error: the line's, widened by the residuals' "
            f"statistical inefficiency; syst: the fit range. The paper's window is 10 s, ours the rung's t_average: "
            f"a drift within the paper's ± {PAPER_VARIATION}° is steady by its measure")
    return Check(QUANTITY, paper, source, change, se, case=case, paper_range=(0.0, 0.0), paper_error=PAPER_VARIATION,
                 unit="deg", syst=syst, variants=text, note=note)


def alpha_change_case(case, middle: tuple[float, float], other_ranges) -> Check:
    """The row for one heap case (its ``surface`` table of each frame's free surface): each frame's α over the
    planar ``middle`` of the flowing length, and over ``other_ranges`` and the whole length for the syst."""
    grid = hp.surface_grid(case.tables["surface"]) if case.measured else None
    if grid is None:
        return alpha_change_check(case.name, None, {}, middle, case.why_not if not case.measured else "no surface")
    t, x, Z = grid
    geometry = case.record["geometry"]
    x_feed, length = geometry["x_feed"], geometry["W"] - geometry["x_feed"]
    per_frame = {tuple(r): hp.fit_surface(t, x, Z, (x_feed + r[0] * length, x_feed + r[1] * length)).alpha_t
                 for r in (middle, *other_ranges, (0.0, 1.0))}
    nominal = per_frame.pop(tuple(middle))
    return alpha_change_check(case.name, nominal, {f"x over {lo:g}-{hi:g} of the flowing length": a
                                                   for (lo, hi), a in per_frame.items()}, middle)
