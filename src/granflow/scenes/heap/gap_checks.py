"""The side walls' effect across the gap against Fan et al. (2013), Appendix 1 and Fig. A.12, per case.

:func:`gap_checks` reads what the analysis wrote (:mod:`granflow.scenes.heap.analysis.gap`:
``analysis/gap_surface_velocity.csv`` and ``deposit_gap.csv``) and compares, in the paper's form:

* Fig. A.12(a): "surface velocities close to the wall (data averaged over 4 mm thick slices in the
  y-direction adjacent to both side walls) are roughly 10 % smaller than mean surface velocities, while
  those in the central region of the heap (4 < y < 8.7 mm) are 10 % larger": :math:`u_s` of each slice over
  the gap's, per usable streamwise bin, averaged along the heap; the paper's "roughly 10 %" to the digit
  stated, 5-15 %;
* Fig. A.12(b): "c_s decreases from the side walls to the center in the upstream region of the heap
  (x_lab/W < 0.6)" and "does not vary in the spanwise direction in the downstream region": the deposit's
  c_s in the wall slices minus in the centre, pooled by volume upstream (> 0) and downstream (0).

Errors: the streamwise bins' scatter (bins taken as independent: an underestimate) for :math:`u_s`; for
c_s the spread of the contrasts of the deposit laid in successive parts of the window (as the record's
c_s row). Syst: the x/L range and the mean of the ratios against the ratio of the means; the split
x_lab/W, the deposit's top and the slices' y assignment (exact caps, or whole particles by centre).
"""
from __future__ import annotations

import pandas as pd

from granflow.validation import Check, systematic

import granflow.scenes.heap.analysis as hp
from .phi_checks import missing, with_status
from .profile_checks import BINS_INDEPENDENT, X_RANGE, X_VARIANTS, mean_se, within

NAN = float("nan")
INF = float("inf")
#: "roughly 10 %" smaller and larger, to the digit stated
PAPER_WALL_RATIO = (0.85, 0.95)
PAPER_CENTRE_RATIO = (1.05, 1.15)
#: the split's alternatives, x_lab/W
SPLIT_VARIANTS = (0.5, 0.7)

Q_US_WALL = "u_s in the 4 mm slices at the side walls over the gap's u_s"
Q_US_CENTRE = "u_s in the centre of the gap (4 < y < 8.7 mm) over the gap's u_s"
Q_CS_UP = "deposit c_s at the side walls minus at the centre of the gap, upstream (x_lab/W < 0.6)"
Q_CS_DOWN = "deposit c_s at the side walls minus at the centre of the gap, downstream (x_lab/W ≥ 0.6)"
#: every quantity this module writes (paper_results_pending.yaml lists them)
QUANTITIES = (Q_US_WALL, Q_US_CENTRE, Q_CS_UP, Q_CS_DOWN)
SOURCE_U, SOURCE_C = "Appendix 1, Fig. A.12a", "Appendix 1, Fig. A.12b"


def _slice_words(case) -> str:
    T = float(case.record["geometry"]["T"])
    iv = hp.slices(T)
    (a, b), = iv["centre"]
    return (f"slices of the gap T = {T * 1e3:g} mm: 0-{iv['wall'][0][1] * 1e3:.3g} mm and "
            f"{iv['wall'][1][0] * 1e3:.3g}-{T * 1e3:g} mm at the side walls, {a * 1e3:.3g}-{b * 1e3:.3g} mm in the "
            "centre (the paper's millimetres at its T = 13 mm, fractions of T otherwise)")


def surface_velocity_checks(case) -> list[Check]:
    """u_s of the wall slices and of the centre over the gap's (Fig. A.12a)."""
    table = case.tables.get("gap_surface_velocity", pd.DataFrame())
    rows = ((Q_US_WALL, "≈ 0.9: 'roughly 10% smaller than mean surface velocities'", PAPER_WALL_RATIO, "wall"),
            (Q_US_CENTRE, "≈ 1.1: '10% larger'", PAPER_CENTRE_RATIO, "centre"))
    if not case.measured or table.empty:
        return [Check(q, p, SOURCE_U, NAN, case=case.name, paper_range=r, note=missing(case, "gap_surface_velocity"))
                for q, p, r, _ in rows]
    bins = table[table["usable"].astype(str).str.lower().isin(("true", "1", "1.0"))]
    checks = []
    for q, paper, rng, name in rows:
        col = f"u_s_{name}"
        per_bin = bins.assign(ratio=bins[col] / bins["u_s"])
        measure = lambda d: mean_se(d["ratio"])  # noqa: E731
        inside = within(per_bin, X_RANGE)
        v, se = measure(inside) if len(inside) else (NAN, NAN)
        alt = {f"x/L over {lo:g}-{hi:g}": measure(within(per_bin, (lo, hi)))[0] for lo, hi in X_VARIANTS}
        alt["the ratio of the means along the heap"] = (inside[col].mean() / inside["u_s"].mean()
                                                        if len(inside) else NAN)
        syst, text = systematic(v, alt)
        note = (f"u_s = u(z = 0) of the particles whose centres lie in the slice ({_slice_words(case)}), z from each "
                f"streamwise bin's own free surface as the record's (the gap's), over the gap's u_s (the record's), in "
                f"each of the {len(inside)} usable bins at {X_RANGE[0]:g} ≤ x/L ≤ {X_RANGE[1]:g}, averaged; "
                f"{int((inside['ratio'] < 1).sum())} of them below 1; error: the bins' scatter, {BINS_INDEPENDENT}; "
                "syst: the x/L range, the ratio of the means")
        checks.append(Check(q, paper, SOURCE_U, v, se, case=case.name, paper_range=rng, syst=syst, variants=text,
                            note=with_status(note, case)))
    return checks


def segregation_checks(case) -> list[Check]:
    """The deposit's c_s at the side walls minus at the centre, upstream and downstream (Fig. A.12b)."""
    table = case.tables.get("deposit_gap", pd.DataFrame())
    rows = ((Q_CS_UP, "> 0: 'c_s decreases from the side walls to the center in the upstream region'", (0.0, INF),
             "upstream"),
            (Q_CS_DOWN, "0: 'c_s does not vary in the spanwise direction in the downstream region'", (0.0, 0.0),
             "downstream"))
    if len(case.record["species"]) < 2:
        return [Check(q, p, SOURCE_C, NAN, case=case.name, paper_range=r,
                      note="monodisperse case: no small-particle concentration (a mixture-only check)")
                for q, p, r, _ in rows]
    if not case.measured or table.empty:
        return [Check(q, p, SOURCE_C, NAN, case=case.name, paper_range=r, note=missing(case, "deposit_gap"))
                for q, p, r, _ in rows]
    geometry = case.record["geometry"]
    x0, W = float(geometry["x_feed"]), float(geometry["W"])
    central = hp.gap_contrast(table, "central", x0, hp.CS_SPLIT * W, W)
    alts = {f"split at x_lab/W = {s:g}": hp.gap_contrast(table, "central", x0, s * W, W) for s in SPLIT_VARIANTS}
    for variant in dict.fromkeys(table["variant"]):
        if variant != "central":
            alts[variant] = hp.gap_contrast(table, variant, x0, hp.CS_SPLIT * W, W)
    checks = []
    for q, paper, rng, region in rows:
        c = central[region]
        # the deposit's other tops hold more or less of the same material: only their shift beyond their own
        # statistics counts; the split and the y assignment read the same particles again
        alt = {name: ((a[region]["contrast"], a[region]["se"]) if name.startswith("from") else a[region]["contrast"])
               for name, a in alts.items()}
        syst, text = systematic(c["contrast"], alt, c["se"])
        span = (f"x_lab from {x0 * 1e3:.0f} mm (the feed zone's edge) to {hp.CS_SPLIT:g} W" if region == "upstream"
                else f"x_lab from {hp.CS_SPLIT:g} W to the end wall")
        note = (f"the small species' volume concentration of the material laid down in the averaging window below the "
                f"flowing layer (the record's deposit), {span}, pooled by volume in each slice ({_slice_words(case)}; "
                f"each particle's volume split exactly over the slices): walls {c['wall']:.3f}, centre "
                f"{c['centre']:.3f}; the paper's Fig. A.12b compares c_s(x) profiles of the slices. Error: the spread "
                f"of the contrasts of the deposit laid in {len(c['per_slab'])} equal parts of the window (oldest "
                f"first: {', '.join(f'{x:+.3f}' for x in c['per_slab'])}); syst: the split, the deposit's top, the "
                "y assignment")
        checks.append(Check(q, paper, SOURCE_C, c["contrast"], c["se"], case=case.name, paper_range=rng, syst=syst,
                            variants=text, note=with_status(note, case)))
    return checks


def gap_checks(case) -> list[Check]:
    """Every row of this module for one case (module docstring)."""
    return [*surface_velocity_checks(case), *segregation_checks(case)]

