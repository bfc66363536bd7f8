"""One universal velocity profile (Debnath, Kesava Rao & Kumaran 2022, §3.1, eq. 3.1, fig. 4(b); conclusion (iii)).

"The shape of the scaled velocity profile is characterized quantitatively by a universal exponential function":
:math:`(u_y - u_{slip})/(u_{max} - u_{slip})` against :math:`x/\\delta_{0.95}` is one curve for every φ̄ and W.
Eq. 3.1's exponent is forced ≈ ln 20 by δ0.95's definition (the record keeps it as a consistency check), so what
can fail is the collapse: :func:`scaled_profile_checks` reads how far the cases' scaled profiles lie from one
curve beyond their errors (:func:`postproc.collapse.collapse_spread`: 0 on a collapse, else their rms distance
from one curve), on x/δ0.95 = 0.3-0.8 and 1.2-2.0. Left out: the wall bin (0 by the scaling) and 0.8-1.2,
where every profile passes 0.95 at 1 by δ0.95's definition (a spread forced to 0 there would pull s down).
The grid is a measurement choice: starting at 0.4, ending at 2.5 and points 0.05 apart are its variants
(:func:`granflow.validation.systematic`).

The scaled profile's error is each block's own scaling (:func:`postproc.channel_profile.scaled_velocity`, the
profile's ``u_scaled_se``): a change of speed of the whole channel leaves it unchanged, so the error is not the
bins' over the span (which holds that change and is 10-50 times wider). A case analysed before that column has
no error of its own and gives no number.
"""
from __future__ import annotations

import numpy as np

from granflow.validation import Check, systematic
from postproc.collapse import N_RESAMPLE, collapse_spread

from .analysis import downward_speed

Q_COLLAPSE = ("scaled velocity (u − u_slip)/(u_max − u_slip) against x/δ0.95 across the cases: rms spread beyond "
              "errors, x/δ0.95 = 0.3-0.8 and 1.2-2")
PAPER = "0 (one universal profile for all φ̄ and W, eq. 3.1)"
SOURCE = "§3.1, eq. 3.1, fig. 4(b); conclusion (iii)"
#: every quantity this module writes (paper_results.yaml's compared_by names them)
QUANTITIES = (Q_COLLAPSE,)
_STEP = 0.1
GRID = np.round(np.r_[np.arange(0.3, 0.8 + 1e-9, _STEP), np.arange(1.2, 2.0 + 1e-9, _STEP)], 10)
def _grid(lo: float, hi: float, step: float = _STEP) -> np.ndarray:
    return np.round(np.r_[np.arange(lo, 0.8 + 1e-9, step), np.arange(1.2, hi + 1e-9, step)], 10)


VARIANTS = {"from x/δ0.95 = 0.4": _grid(0.4, 2.0), "to 2.5": _grid(0.3, 2.5), "points 0.05 apart": _grid(0.3, 2.0, 0.05)}


def scaled_curve(case) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """``(x/δ0.95, scaled u, its error)`` of a :class:`.validation.ChannelCase` beyond its wall bin; None without
    an analysis, a δ0.95 or the profile's own ``u_scaled_se``."""
    a = getattr(case, "analysis", None)
    if a is None or case.why_not or "u_scaled_se" not in a.folded:
        return None
    s = a.scales
    if not (np.isfinite(s.delta_095) and s.delta_095 > 0 and s.u_max > s.u_slip):
        return None
    f = a.folded
    x = f["x"].to_numpy(float) / s.delta_095
    u = (downward_speed(f)[0] - s.u_slip) / (s.u_max - s.u_slip)
    se = f["u_scaled_se"].to_numpy(float)
    ok = np.isfinite(x) & np.isfinite(u) & np.isfinite(se) & (se > 0)
    ok[0] = False
    return x[ok], u[ok], se[ok]


def scaled_profile_checks(cases: list) -> list[Check]:
    """The collapse row over every case with a scaled profile (two at least), one row named ``sweep``; none
    for a single case."""
    if len(cases) < 2:
        return []
    curves = {c.name: scaled_curve(c) for c in cases}
    have = {name: cv for name, cv in curves.items() if cv is not None and cv[0].max() >= 3.0}
    if len(have) < 2:
        lacking = ", ".join(n for n, cv in curves.items() if cv is None) or "none"
        return [Check(Q_COLLAPSE, PAPER, SOURCE, float("nan"), float("nan"), "sweep", (0.0, 0.0),
                      note=f"needs two cases with a scaled profile and its own error (u_scaled_se); without: "
                           f"{lacking} (an analysis before the column: rerun analyse)")]
    f = collapse_spread(list(have.values()), GRID)
    var = {name: collapse_spread(list(have.values()), grid)["s"] for name, grid in VARIANTS.items()}
    syst, text = systematic(f["s"], var)
    # the scale the paper's figure reads the collapse at: each profile's rms distance from eq. 3.1's curve
    eq31 = np.mean([np.sqrt(np.mean((np.interp(GRID, x, u) - (1.0 - np.exp(-3.0 * GRID))) ** 2))
                    for x, u, _ in have.values()])
    note = (f"{len(have)} cases ({', '.join(have)}): the scaled profiles interpolated onto {GRID.size} points of "
            f"x/δ0.95, their weighted mean curve, the rms distance from it beyond the errors (error: {N_RESAMPLE} "
            f"seeded parametric resamples, points taken as independent); χ²/ν of one curve through all = "
            f"{f['chi2']:.2g}. Each case's scaling is its own u_slip (wall bin), u_max and δ0.95; the error is each "
            f"block's own scaling (a change of speed of the whole channel leaves it unchanged). For scale: the "
            f"profiles lie {eq31:.2g} (rms, mean over the cases) from eq. 3.1's curve, which the paper calls an "
            f"excellent fit; its fig. 4(b) shows the collapse by eye")
    return [Check(Q_COLLAPSE, PAPER, SOURCE, f["s"], f["s_se"], "sweep", (0.0, 0.0), syst=syst, variants=text,
                  note=note)]
