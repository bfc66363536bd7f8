"""The heap's solids volume fraction against Fan et al. (2013), §3.1 and Fig. 4(a), per case.

:func:`phi_checks` reads what the analysis wrote (:mod:`granflow.scenes.heap.analysis.phi`:
``analysis/static_bed.csv``, ``phi_profile.csv``, ``surface_cutoff.csv``, with ``per_x.csv`` and the
scalars) and compares, each in the form the paper states it:

* "f ≈ 0.65 in the static portion of the heap": the static bed's φ in the paper's bins
  (:math:`\\Delta x \\times T \\times \\Delta z`, the whole gap) from :math:`2\\delta` to
  :math:`2\\delta + 20\\bar d` under each frame's surface, 2 :math:`\\bar d` clear of the base, in the
  columns downstream of the feed zone that do not touch the end wall; against 0.65 to the digits stated;
* the shape of f(z): it "decreases slightly in the creeping region", "continues to decrease slowly
  through the flowing layer", "then decreases rapidly to zero close to the free surface": the fall
  :math:`F = -d\\phi/d(z/\\delta)` of a line through φ in the creeping region
  (:math:`-2 \\le z/\\delta \\le -1`, the paper's Fig. 4a at x_lab = 0.1 m) and through the flowing
  layer (:math:`-\\delta \\le z \\le -\\bar d/2`), each > 0, and the fall over the top diameter
  (:math:`|z| \\le \\bar d/2`) over the layer's, > 1;
* "in the upstream region ... a non-zero solids volume fraction above the free surface, corresponding to
  the bouncing of some particles": φ between :math:`d_l` and :math:`d_l + 10\\bar d` above the surface
  over the first quarter of the flowing length minus over :math:`0.5 \\le x/L \\le 0.9` (> 0: the bouncing
  is upstream's), and the upstream value itself as a reading (any bouncing particle makes it > 0);
* "the measured free surface only varies by one particle diameter when :math:`f_c` is changed between
  0.1 and 0.5": the largest, over the columns of the record's surface fit, of the time-mean
  :math:`|z_s(0.1) - z_s(0.5)|` over :math:`\\bar d`, heights from each frame's own surface line
  (:func:`cutoff_check` says why), against one diameter read as the largest, :math:`d_l/\\bar d`.

Errors: the streamwise columns' scatter (columns taken as independent: neighbours share particles, an
underestimate); the largest offset carries its column's correlation-aware error. Syst: the x/L range,
the bands' edges, the bed's depth, the regions and heights above the surface, the column range of the
cutoff's reading and its per-column statistic (:func:`granflow.validation.systematic`).
"""
from __future__ import annotations

import math

import numpy as np
import pandas as pd

from granflow.validation import Check, systematic

import granflow.scenes.heap.analysis as hp
from .profile_checks import BINS_INDEPENDENT, X_RANGE, X_VARIANTS, mean_se, within

NAN = float("nan")
INF = float("inf")
#: "f ≈ 0.65" (§3.1), to the digits stated
PAPER_BED_PHI = (0.645, 0.655)
#: the bands' alternatives (the systematic error): the creeping region from 2.5 δ, the layer to a full d̄
#: under the surface, the top diameter as the one under the surface
BAND_VARIANTS = {"creep": ((-2.5, 0.0), (-1.0, 0.0)), "layer": ((-1.0, 0.0), (0.0, -1.0)),
                 "top": ((0.0, -1.0), (0.0, 0.0))}
#: upstream and downstream for φ above the surface, x/L; their alternatives
ABOVE_UP, ABOVE_DOWN = (0.0, 0.25), (0.5, 0.9)
ABOVE_REGION_VARIANTS = (((0.0, 1 / 3), (2 / 3, 0.9)),)
#: the band above the surface: from d_l, ABOVE_HEIGHT d̄ tall; alternatives from 2 d_l and 5 d̄ tall
ABOVE_HEIGHT = 10.0
ABOVE_HEIGHT_VARIANT = 5.0

Q_BED = "φ of the static bed, 2δ to 2δ + 20 d̄ under the surface"
Q_CREEP = "φ(z): fall −dφ/d(z/δ) in the creeping region, −2 ≤ z/δ ≤ −1"
Q_LAYER = "φ(z): fall −dφ/d(z/δ) through the flowing layer, −δ ≤ z ≤ −d̄/2"
Q_TOP = "φ(z): fall over the top diameter (|z| ≤ d̄/2) over that through the flowing layer"
Q_ABOVE = "φ above the surface (d_l to d_l + 10 d̄): upstream minus downstream"
Q_ABOVE_UP = "φ above the surface (d_l to d_l + 10 d̄), upstream x/L ≤ 0.25"
Q_CUTOFF = "free surface with f_c = 0.1 and 0.5: largest |Δz_s| over d̄"
#: every quantity this module writes (paper_results_pending.yaml lists them)
QUANTITIES = (Q_BED, Q_CREEP, Q_LAYER, Q_TOP, Q_ABOVE, Q_ABOVE_UP, Q_CUTOFF)
SOURCE = "§3.1, Fig. 4a"


def _table(case, name: str) -> pd.DataFrame:
    return case.tables.get(name, pd.DataFrame())


def missing(case, name: str) -> str:
    """Why a case has no rows from ``analysis/<name>.csv``."""
    if not case.measured:
        return case.why_not
    return f"no analysis/{name}.csv (an analysis older than this row: re-analyse)"


def with_status(text: str, case) -> str:
    """``text`` with the case's status when it is not steady (its numbers then to be read with care)."""
    return text + getattr(case, "status_note", "")


def _d_large(case) -> float:
    return max(float(s["d"]) for s in case.record["species"])


# --------------------------------------------------------------------------- the static bed
def bed_check(case) -> Check:
    table = _table(case, "static_bed")
    kw = dict(case=case.name, paper_range=PAPER_BED_PHI)
    if not case.measured or table.empty:
        return Check(Q_BED, "≈ 0.65", SOURCE, NAN, note=missing(case, "static_bed"), **kw)
    value, se, n = hp.static_bed_phi(table, hp.BED_TOP)
    alt = {f"top at {k:g}δ" + (" (the mass balance's φ_bed window)" if k == 1.5 else ""): hp.static_bed_phi(table, k)[0]
           for k in hp.BED_TOP_VARIANTS}
    syst, text = systematic(value, alt)
    rows = table[np.isclose(table["top_over_delta"], hp.BED_TOP) & np.isfinite(table["phi"])]
    d_bar, knobs = case.get("d_bar"), case.record["rung_knobs"]
    lo, hi = (float(rows[c].iloc[0]) if len(rows) else NAN for c in ("depth_lo", "depth_hi"))
    x = rows["x_lab"].to_numpy(float) if len(rows) else np.array([NAN])
    note = (f"the lab columns' φ in the paper's bins (Δx = {knobs['bin_dx'] * d_bar * 1e3:.3g} mm × the whole gap T × "
            f"Δz = {knobs['bin_dz_phi'] * d_bar * 1e3:.2g} mm; the side walls' looser layers included, as the "
            f"paper's) lying, in each frame, between {lo * 1e3:.3g} and {hi * 1e3:.3g} mm under its free surface "
            f"(2δ and 2δ + {hp.BED_THICKNESS:g} d̄ normal to the surface, δ = {case.get('delta_mean') * 1e3:.3g} mm; "
            f"the paper's Fig. 4a puts the creeping region 1-2δ under it) and at least {hp.BED_CLEARANCE:g} d̄ above "
            f"the base; averaged over the frames in each of {n} columns from x_lab = {np.nanmin(x) * 1e3:.0f} to "
            f"{np.nanmax(x) * 1e3:.0f} mm (downstream of the feed zone, not the column at the end wall), then over the "
            f"columns (their spread {np.nanstd(rows['phi']) if len(rows) else NAN:.3f}); the mass balance's φ_bed "
            f"(1.5δ to 1.5δ + 20 d̄ vertically, every downstream column) is {case.get('phi_bed'):.3f}; error: the "
            f"columns' scatter, columns taken as independent; syst: the bed's top")
    return Check(Q_BED, "≈ 0.65", SOURCE, value, se, syst=syst, variants=text, note=with_status(note, case), **kw)


# --------------------------------------------------------------------------- the shape of φ(z)
def _over_x(frame: pd.DataFrame, measure, extra=None):
    """``(value, se, syst, variants' text, n)`` of ``measure(rows) -> (value, se)`` over :data:`X_RANGE`,
    its variants and ``extra`` (other measurements, already made)."""
    sub = within(frame, X_RANGE)
    value, se = measure(sub) if len(sub) else (NAN, NAN)
    alt = {f"x/L over {lo:g}-{hi:g}": measure(within(frame, (lo, hi)))[0] for lo, hi in X_VARIANTS}
    alt.update(extra or {})
    syst, text = systematic(value, alt)
    return value, se, syst, text, len(sub)


def _ratio(a: tuple, b: tuple) -> tuple[float, float]:
    (x, sx), (y, sy) = a, b
    if not (math.isfinite(x) and math.isfinite(y) and y != 0):
        return NAN, NAN
    r = x / y
    return r, abs(r) * math.hypot(sx / x if x else NAN, sy / y)


def _band_words(band) -> str:
    def end(a, b):
        parts = [f"{a:g}δ" if a else "", f"{b:+g} d̄" if b else ""]
        return " ".join(p for p in parts if p) or "0"
    (a0, b0), (a1, b1) = band
    return f"z from {end(a0, b0)} to {end(a1, b1)}"


def shape_checks(case) -> list[Check]:
    """The falls of φ through the creeping region and the flowing layer, and the top diameter's over the
    layer's (the module docstring)."""
    prof, px = _table(case, "phi_profile"), case.tables["per_x"]
    rows = ((Q_CREEP, "> 0: f 'decreases slightly in the creeping region'", (0.0, INF)),
            (Q_LAYER, "> 0: f 'continues to decrease slowly moving upward through the flowing layer'", (0.0, INF)),
            (Q_TOP, "> 1: 'slowly' through the flowing layer, then 'rapidly to zero close to the free surface'",
             (1.0, INF)))
    if not case.measured or prof.empty:
        return [Check(q, p, SOURCE, NAN, case=case.name, paper_range=r, note=missing(case, "phi_profile"))
                for q, p, r in rows]
    d_bar = case.get("d_bar")
    falls = hp.band_falls(prof, px, d_bar)
    checks = []
    for (q, paper, rng), band in zip(rows[:2], ("creep", "layer")):
        other = hp.band_falls(prof, px, d_bar, {band: BAND_VARIANTS[band]})
        extra = {_band_words(BAND_VARIANTS[band]): mean_se(within(other, X_RANGE)[band])[0]}
        v, se, syst, text, n = _over_x(falls, lambda d, b=band: mean_se(d[b]), extra)
        values = within(falls, X_RANGE)[band]
        checks.append(Check(q, paper, SOURCE, v, se, case=case.name, paper_range=rng, syst=syst, variants=text,
                            note=with_status(_shape_note(band, n, values, case), case)))
    top_over_layer = lambda d: _ratio(mean_se(d["top"]), mean_se(d["layer"]))  # noqa: E731
    extra = {}
    for band in ("top", "layer"):
        other = falls.drop(columns=band).merge(hp.band_falls(prof, px, d_bar, {band: BAND_VARIANTS[band]})[["x", band]],
                                               on="x")
        extra[f"{band}: {_band_words(BAND_VARIANTS[band])}"] = top_over_layer(within(other, X_RANGE))[0]
    v, se, syst, text, n = _over_x(falls, top_over_layer, extra)
    inside = within(falls, X_RANGE)
    note = (f"the mean over the {n} usable streamwise bins at {X_RANGE[0]:g} ≤ x/L ≤ {X_RANGE[1]:g} of the fall over "
            f"the top diameter (|z| ≤ d̄/2 around the bin's own surface: mean {inside['top'].mean():.3g}) over the "
            f"mean fall through the flowing layer ({inside['layer'].mean():.3g}); "
            + _profile_words(case) + f"; error: propagated from the bins' scatter, {BINS_INDEPENDENT}; syst: the "
            "x/L range and each band's edges")
    checks.append(Check(rows[2][0], rows[2][1], SOURCE, v, se, case=case.name, paper_range=rows[2][2], syst=syst,
                        variants=text, note=with_status(note, case)))
    return checks


def _profile_words(case) -> str:
    d_bar = case.get("d_bar")
    dz = case.record["rung_knobs"]["bin_dz_phi"] * d_bar
    return (f"F = −dφ/d(z/δ) of a least-squares line through φ in each band, φ the moving frame's volume-weighted "
            f"time average in bins {dz * 1e3:.2g} mm thick (the lab columns' Δz), z normal to the surface from each "
            f"bin's own free surface (φ = {hp.PHI_C:g} of its time average), bins nearer the base than "
            f"{hp.BED_CLEARANCE:g} d̄ left out; δ each bin's (0.1 u_s cutoff), d̄ = {d_bar * 1e3:.3g} mm. Averaging in "
            "time at fixed depth smears the surface's steep fall over the frames' wander about their mean")


def _shape_note(band: str, n: int, values: pd.Series, case) -> str:
    where = {"creep": "the creeping region, −2 ≤ z/δ ≤ −1 (the paper's Fig. 4a at x_lab = 0.1 m: 0.17-0.185 m under "
                      "a layer at 0.185-0.2 m)",
             "layer": "the flowing layer from z = −δ to −d̄/2 (the top diameter is the next row's)"}[band]
    return (f"mean over the {n} usable streamwise bins at {X_RANGE[0]:g} ≤ x/L ≤ {X_RANGE[1]:g} of φ's fall through "
            f"{where}; {(values > 0).sum()} of {values.notna().sum()} bins fall; " + _profile_words(case)
            + f"; error: the bins' scatter, {BINS_INDEPENDENT}; syst: the x/L range and the band's edges")


# --------------------------------------------------------------------------- above the surface
def above_checks(case) -> list[Check]:
    """φ above the surface upstream, against downstream (a comparison) and alone (a reading)."""
    prof = _table(case, "phi_profile")
    paper = "> 0: 'a non-zero solids volume fraction above the free surface' in the upstream region (bouncing)"
    if not case.measured or prof.empty:
        why = missing(case, "phi_profile")
        return [Check(Q_ABOVE, paper, SOURCE, NAN, case=case.name, paper_range=(0.0, INF), note=why),
                Check(Q_ABOVE_UP, "> 0", SOURCE, NAN, case=case.name, kind="diagnostic", note=why)]
    d_l, d_bar, L = _d_large(case), case.get("d_bar"), case.get("L")

    def contrast(start: float, height: float, up=ABOVE_UP, down=ABOVE_DOWN):
        above = hp.phi_above(prof, start, start + height * d_bar, L)
        (u, su), (w, sw) = mean_se(within(above, up)["phi_above"]), mean_se(within(above, down)["phi_above"])
        return (u - w, math.hypot(su, sw) if math.isfinite(su) and math.isfinite(sw) else NAN), (u, su), (w, sw)

    (v, se), (u, su), (w, _) = contrast(d_l, ABOVE_HEIGHT)
    specs = {f"from {2 * d_l * 1e3:g} mm (2 d_l)": (2 * d_l, ABOVE_HEIGHT),
             f"{ABOVE_HEIGHT_VARIANT:g} d̄ tall": (d_l, ABOVE_HEIGHT_VARIANT)}
    specs.update({f"upstream x/L ≤ {up[1]:.2g}, downstream {down[0]:.2g}-{down[1]:.2g}": (d_l, ABOVE_HEIGHT, up, down)
                  for up, down in ABOVE_REGION_VARIANTS})
    got = {name: contrast(*spec) for name, spec in specs.items()}
    syst, text = systematic(v, {name: g[0][0] for name, g in got.items()})
    syst_up, text_up = systematic(u, {name.split(",")[0]: g[1][0] for name, g in got.items()})
    where = (f"φ of the moving frame's thin bins between {d_l * 1e3:g} mm (the large diameter d_l) and "
             f"{(d_l + ABOVE_HEIGHT * d_bar) * 1e3:.3g} mm ({ABOVE_HEIGHT:g} d̄ more) above each streamwise bin's own "
             f"surface, averaged over the bins at x/L ≤ {ABOVE_UP[1]:g} (upstream: the paper's x_lab = 0.1 m is just "
             "past its feed zone) ")
    note = (where + f"({u:.2g}) minus over those at {ABOVE_DOWN[0]:g} ≤ x/L ≤ {ABOVE_DOWN[1]:g} ({w:.2g}); the paper "
            "states the non-zero φ for the upstream region: read as φ there exceeding the downstream's (any bouncing "
            "particle makes the upstream value alone > 0, the next row). Fed particles still in flight over the heap "
            f"count as bouncing; error: the bins' scatter, {BINS_INDEPENDENT}; syst: the band's start and height, "
            "the regions")
    return [Check(Q_ABOVE, paper, SOURCE, v, se, case=case.name, paper_range=(0.0, INF), syst=syst, variants=text,
                  note=with_status(note, case)),
            Check(Q_ABOVE_UP, "> 0", SOURCE, u, su, case=case.name, kind="diagnostic", syst=syst_up, variants=text_up,
                  note=with_status(where + "(a reading: > 0 as soon as one particle passes through the band in the window; the "
                             "row above compares)", case))]


# --------------------------------------------------------------------------- the surface's cutoff
def cutoff_check(case) -> Check:
    """The largest move of the free surface between the cutoffs 0.1 and 0.5, in d̄ (§3.1).

    Each frame's lab columns, the paper's bins, with every height taken from the frame's own surface line
    (:func:`.analysis.phi.tilt_free_spans`): a vertical column Δx wide under the slope spreads the fall of φ over
    Δx tan α of surface height, and between the cutoffs a step surface then moves by (0.5 − 0.1)/φ_bed of it,
    a length fixed by the bins' width and the slope, not by where the surface is (the paper's 10 mm columns at
    α = 25.7° would move it by ~3 mm, two to three diameters, against its bound of one). That reading is reported
    in the note, not varied.
    """
    table = _table(case, "surface_cutoff")
    d_bar = case.get("d_bar")
    d_l = _d_large(case)
    bound = d_l / d_bar if math.isfinite(d_bar) else NAN
    paper = (f"≤ one particle diameter: the surface 'only varies by one particle diameter' when f_c goes from 0.1 "
             f"to 0.5; in a mixture read as the largest, d_l = {bound:.3g} d̄")
    kw = dict(case=case.name, paper_range=(0.0, bound) if math.isfinite(bound) else (0.0, 1.0))
    if not case.measured or table.empty or "span_tilt_free_mean" not in table:
        return Check(Q_CUTOFF, paper, "§3.1", NAN, note=missing(case, "surface_cutoff"), **kw)
    geometry = hp.HeapGeometry(**case.record["geometry"])
    dx = case.record["rung_knobs"]["bin_dx"] * d_bar
    fit_range = hp.surface_fit_range(geometry, dx)
    mid = tuple(geometry.x_feed + f * geometry.L_lab for f in hp.ALPHA_PLANAR_MIDDLE)
    central = "span_tilt_free_mean"
    got = hp.surface_cutoff_max(table, fit_range, d_bar, central)
    alt = {f"columns of the surface's planar middle ({hp.ALPHA_PLANAR_MIDDLE[0]:g}-{hp.ALPHA_PLANAR_MIDDLE[1]:g} of "
           "its length)": hp.surface_cutoff_max(table, mid, d_bar, central)["value"],
           "each column's median over the frames":
               hp.surface_cutoff_max(table, fit_range, d_bar, "span_tilt_free_median")["value"]}
    syst, text = systematic(got["value"], alt)
    vertical = hp.surface_cutoff_max(table, fit_range, d_bar, "span_mean")
    tilt = dx * math.tan(math.radians(case.get("alpha_deg"))) / d_bar
    phi_bed = case.get("phi_bed")
    note = (f"the free surface of every frame and lab column (Δx = {dx * 1e3:.3g} mm, the record's) found where φ falls "
            f"through 0.1 and through 0.5 (the paper's cutoff: {hp.PHI_C:g}), every height taken from the frame's own "
            f"surface line (φ = {hp.PHI_C:g}, linear between the columns), their difference averaged over the frames "
            f"in each column, the largest over the {got['n']} columns of the record's surface fit (x_lab "
            f"{fit_range[0] * 1e3:.0f}-{fit_range[1] * 1e3:.0f} mm), at x_lab = {got['x_lab'] * 1e3:.0f} mm; the mean "
            f"over them {got['mean']:.2g} d̄; d̄ = {d_bar * 1e3:.3g} mm. From the vertical columns the largest is "
            f"{vertical['value']:.2g} d̄: a column spans {tilt:.2g} d̄ of the sloping surface's height, which moves a "
            f"step surface by (0.5 − 0.1)/φ_bed × {tilt:.2g} = {0.4 / phi_bed * tilt:.2g} d̄ between the cutoffs "
            f"whatever the surface (the bins' width, not the surface; not varied). The paper's unit, 'one particle "
            f"diameter', is 1 or 2 mm in its 1/2 mm mixture: the bound is read as the largest diameter (the most "
            f"lenient; over d_s the value is {got['value'] * d_bar / min(float(s['d']) for s in case.record['species']):.2g}, "
            f"over d_l {got['value'] * d_bar / d_l:.2g}). Error: that column's mean over correlated frames; syst: the "
            "columns read, the per-column statistic")
    return Check(Q_CUTOFF, paper, "§3.1", got["value"], got["se"], syst=syst, variants=text, note=with_status(note, case),
                 **kw)


def phi_checks(case) -> list[Check]:
    """Every row of this module for one case (module docstring)."""
    return [bed_check(case), *shape_checks(case), *above_checks(case), cutoff_check(case)]
