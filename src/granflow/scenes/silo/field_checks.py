"""The silo's checks of two results of Rubio-Largo, Maza & Hidalgo (2016) that the record did not test:

* "the system quickly evolves to a steady state characterized by a constant flow rate" (§3, Fig. 2a):
  :func:`steady_rate_check` fits a line to the windowed :math:`W_f(t)` across the steady window and
  reports its relative change over the window (0 for a constant rate);
* "both coarse-grained magnitudes display monotonic behavior with the height. When approaching the
  orifice, the velocity :math:`v_z` increases, while the solid fraction decreases" (§3, Fig. 3):
  :func:`monotonic_checks`, on the axis profiles the record keeps (``kinetic_axis``: φ and
  :math:`v_z` beside :math:`p^k`), in the form of the contact pressure's check (Fig. 6): the rank
  correlation over :math:`0 \\le z \\le 2R`, no nearer the free surface's lowest height in the window than three
  kernel widths (a silo that empties while averaging has its surface pass through the large orifices' span: the
  nodes there read the surface, not the flow), 1 for a monotonic approach whatever its shape, with
  the largest reversal against the trend and its error in the note; its systematic error reads the same
  correlation two and four kernel widths below the surface and over 0-1.5 R.
"""
from __future__ import annotations

import math

import numpy as np
import pandas as pd

from granflow.validation import Check
from granflow.verdicts import systematic

#: the heights of the axis checks, in R (as the contact pressure's: the span every orifice's axis profile covers)
SPAN = 2.0
#: ... and no higher than this far below the free surface's lowest height in the window, r_b: three of the paper's
#: kernel widths w = 2 r_b (a node within reach of the surface averages frames above and below it; in a silo that
#: empties while averaging, the large orifices' surface reaches 1.8 R)
SURFACE_MARGIN = 6.0
#: the measurement choices of the axis checks, each read as a variant for the systematic error: the margin below the
#: surface at two and four kernel widths, and a span of 1.5 R (the larger orifices' axis above 1.5 R is often cut by
#: the surface margin already)
MARGIN_VARIANTS = (4.0, 8.0)
SPAN_VARIANTS = (1.5,)
STEADY_SOURCE = "§3, Fig. 2a"
MONOTONIC_SOURCE = "§3, Fig. 3"


def rate_drift(t, W, W_se, t_start: float, t_end: float) -> dict:
    """The relative change of a rate across a window, from a weighted straight line through it.

    .. math:: d = \\frac{b\\,(t_1 - t_0)}{\\bar W}

    with :math:`b` the slope of the weighted least-squares line through the samples with
    :math:`t_0 \\le t \\le t_1` (weights :math:`1/\\sigma_i^2`; its error scaled by
    :math:`\\sqrt{\\chi^2/\\nu}` when that exceeds 1, for scatter the errors do not hold) and
    :math:`\\bar W` their weighted mean. 0 for a constant rate.

    Returns
    -------
    dict
        ``drift, drift_se, n, chi2`` (χ²/ν of the line); NaN with fewer than 3 samples.
    """
    t, W, se = (np.asarray(a, dtype=float) for a in (t, W, W_se))
    sel = np.isfinite(t) & np.isfinite(W) & np.isfinite(se) & (se > 0) & (t >= t_start) & (t <= t_end)
    out = dict(drift=float("nan"), drift_se=float("nan"), n=int(sel.sum()), chi2=float("nan"))
    if sel.sum() < 3 or not t_end > t_start:
        return out
    t, W, se = t[sel], W[sel], se[sel]
    coef, cov = np.polyfit(t - t.mean(), W, 1, w=1 / se, cov="unscaled")
    nu = len(t) - 2
    chi2 = float(np.sum(((W - np.polyval(coef, t - t.mean())) / se) ** 2) / nu) if nu > 0 else float("nan")
    mean = float(np.sum(W / se ** 2) / np.sum(1 / se ** 2))
    scale = math.sqrt(max(1.0, chi2)) if math.isfinite(chi2) else 1.0
    out.update(drift=float(coef[0] * (t_end - t_start) / mean),
               drift_se=float(math.sqrt(cov[0, 0]) * scale * (t_end - t_start) / abs(mean)), chi2=chi2)
    return out


def steady_rate_check(case) -> Check:
    """W_f(t) constant across the steady window (paper: "a constant flow rate"); ``case`` a
    :class:`~granflow.scenes.silo.validation.SiloCase`."""
    q = "W_f(t) across the steady window: relative change (slope × duration / mean)"
    paper = "0 (\"quickly evolves to a steady state characterized by a constant flow rate\")"
    if not case.steady:
        return Check(q, paper, STEADY_SOURCE, float("nan"), case=case.name, paper_range=(0.0, 0.0), note=case.why_not)
    t0, t1 = case.get("t_start"), case.get("t_end")
    flow = case.flow
    d = rate_drift(flow["t"], flow["W_f"], flow["W_f_se"], t0, t1)
    g = case.record.get("gravity")
    t_d = f"{t0 / math.sqrt(2 * case.record['r_b'] / g):.0f}-{t1 / math.sqrt(2 * case.record['r_b'] / g):.0f} t_d; " if g else ""
    after = flow["t"] > 0
    hi, lo = flow.get("t_hi", flow["t"]), flow.get("t_lo", flow["t"])
    span = float(hi[after].max() - lo[after].min()) if after.any() else float("nan")
    note = (f"weighted line through {d['n']} windows of {case.get('window'):g} s from t = {t0:.3g} to {t1:.3g} s "
            f"after the opening ({t_d}the steady window covers "
            f"{(t1 - t0) / span:.0%} of the discharge the run records), χ²/ν = {d['chi2']:.2g} (its error scaled by "
            "√(χ²/ν) when > 1); the window is the longest run of the smoothed rate within ±10 % of one level and "
            "above the fill height where the silo runs low, so a change beyond ~20 % could not be in it: smaller "
            "ones can, and this row reads them")
    return Check(q, paper, STEADY_SOURCE, d["drift"], d["drift_se"], case=case.name, paper_range=(0.0, 0.0),
                 note=note)


def largest_reversal(z, v, se) -> dict:
    """The largest step against a rise with height: :math:`\\max_{z_i < z_j} (v_i - v_j)` (0 for a
    non-decreasing profile), at the pair that gives it, and that pair's error (independent nodes)."""
    z, v, se = (np.asarray(a, dtype=float) for a in (z, v, se))
    order = np.argsort(z)
    v, se = v[order], se[order]
    best, best_se = 0.0, float("nan")
    peak = 0
    for j in range(1, len(v)):
        if v[j - 1] > v[peak]:
            peak = j - 1
        if v[peak] - v[j] > best:
            best, best_se = float(v[peak] - v[j]), float(math.hypot(se[peak], se[j]))
    return dict(reversal=best, reversal_se=best_se)


def _monotonic(kinetic: pd.DataFrame | None, column: str, sign: float, q: str, paper: str) -> list[Check]:
    from scipy.stats import spearmanr

    if kinetic is None or kinetic.empty or column not in kinetic:
        return [Check(q, paper, MONOTONIC_SOURCE, float("nan"), note=f"the record's kinetic_axis has no {column}")]
    out = []
    for case, g in kinetic.groupby("case", sort=False):
        z = g["z_over_R"].to_numpy(float)
        v = sign * g[column].to_numpy(float)
        se = g[column + "_se"].to_numpy(float) if column + "_se" in g else np.full(len(g), np.nan)
        surface = float(g["z_surface_over_R"].iloc[0]) if "z_surface_over_R" in g else float("nan")
        r_over_rb = float(g["R_over_rb"].iloc[0])

        def nodes(span: float = SPAN, margin: float = SURFACE_MARGIN) -> tuple[float, np.ndarray]:
            """(the span's top in R, the nodes in it): 0 ≤ z ≤ span, ``margin`` r_b below the free surface."""
            top = min(span, surface - margin / r_over_rb) if np.isfinite(surface) else span
            return top, np.isfinite(z) & np.isfinite(v) & (z >= -1e-12) & (z <= top + 1e-12)

        def rho_of(sel: np.ndarray) -> float:
            # a flat profile has no rank order (Spearman's ρ undefined): NaN; so have fewer than 3 nodes
            return float(spearmanr(z[sel], v[sel]).statistic) if sel.sum() >= 3 and np.ptp(v[sel]) > 0 else float("nan")

        top, sel = nodes()
        if sel.sum() < 3:
            out.append(Check(q, paper, MONOTONIC_SOURCE, float("nan"), case=case,
                             note=f"fewer than 3 axis nodes in 0 ≤ z ≤ {top:.3g}R"))
            continue
        rho = rho_of(sel)
        choices = {f"{m:g} r_b below the surface": rho_of(nodes(margin=m)[1]) for m in MARGIN_VARIANTS}
        choices.update({f"span 0-{sp:g}R": rho_of(nodes(span=sp)[1]) for sp in SPAN_VARIANTS})
        syst, variants = systematic(rho, choices)
        rev = largest_reversal(z[sel], v[sel], se[sel])
        rise = float(np.nanmax(v[sel]) - np.nanmin(v[sel]))
        sigmas = rev["reversal"] / rev["reversal_se"] if rev["reversal_se"] > 0 else float("nan")
        reach = (f"up to {top:.3g}R, {SURFACE_MARGIN:g} r_b below the free surface's lowest in the window "
                 f"({surface:.3g}R); " if top < SPAN else "")
        note = (f"Spearman ρ over {int(sel.sum())} axis nodes, {reach}(1: monotonic towards the orifice, whatever the shape; "
                f"w = 2 r_b as the paper's Fig. 3); the largest step against the trend is "
                f"{rev['reversal']:.3g}" + (f" ± {rev['reversal_se']:.2g} ({sigmas:.1f} σ)" if rev["reversal"] > 0 else "")
                + f", of a change of {rise:.3g} across the span")
        out.append(Check(q, paper, MONOTONIC_SOURCE, rho, case=case, note=note, syst=syst, variants=variants))
    return out


def monotonic_checks(kinetic: pd.DataFrame | None) -> list[Check]:
    """φ and |v_z| on the axis, each monotonic towards the orifice (Fig. 3): one row per case and field."""
    span = f"0 ≤ z ≤ {SPAN:g}R below the free surface"
    return (_monotonic(kinetic, "phi", 1.0, f"φ on the axis: rank correlation of φ with z, {span}",
                       "falls monotonically towards the orifice (ρ = 1)")
            + _monotonic(kinetic, "u_z", 1.0, f"v_z on the axis: rank correlation of v_z (< 0, downwards) with z, {span}",
                         "|v_z| grows monotonically towards the orifice (ρ = 1)"))
