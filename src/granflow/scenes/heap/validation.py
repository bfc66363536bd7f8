"""The heap's validation record: Fan, Umbanhowar, Ottino & Lueptow (2013) against our cases.

:func:`validation` compares what the scene's analysis wrote for each finished case
(``analysis/scalars.json``, ``per_x.csv``, ``collapse.csv``, ``surface.csv``, ``deposit.csv``)
with the paper; it recomputes no field.

Checks per case: the dynamic angle of repose α (the paper states it for the 1/2 mm mixture at
33 g/s only, section 3.1); the rise velocity against mass conservation (exact: ratio 1); the
flowing-layer thickness in local mean diameters, δ/d̄ (6-7 d, section 3.2.2); the prefactor and
the exponent of the exponential tail u/u_s = 2.4 e^{3.3 z/δ} (figure 7b); the spread of the three
δ methods (they agree, figure 6d); for a mixture, the small particles' deposit upstream (figure 3);
φ in the static bed, the shape of φ(z) and the surface's cutoff (section 3.1, figure 4a:
:mod:`granflow.scenes.heap.phi_checks`); u_s and c_s across the gap (appendix 1, figure A.12:
:mod:`granflow.scenes.heap.gap_checks`).
Over the sweep: the exponent of δ/d̄ ∝ q*^a (a ≈ 0.22, figure 11). From the kept profiles,
:func:`granflow.scenes.heap.profile_checks.profile_checks` (figures 6-11 in the paper's form).

Errors are one standard error of ours. The headline numbers (α, δ/d̄, the tail exponent) carry the
correlation-aware error of :func:`granflow.headline.measure_with_errors`, which re-analyses
sub-windows of the averaging window from the dumps; without dumps the analysis's own errors
stand in (the note says so). Fit parameters carry the fits' standard errors.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from granflow.plotting import pm
from granflow.registry import finite
from granflow.validation import Check, ValidationResult, concat_profiles, read_case, read_table, systematic
from granflow.validation import headline_errors as validation_errors

import granflow.scenes.heap.analysis as hp
from .gap_checks import gap_checks
from .phi_checks import phi_checks
from .pipeline import mixture_mean_diameter
from .profile_checks import profile_checks
from .shear_checks import shear_checks
from .steadiness import alpha_change_case

#: the heap scene's headline keys (``HeapScene.headline``) and, per key, the analysis's own error
HEADLINE_FALLBACK = {"alpha": "alpha_se", "delta_over_d": None, "tail_exponent": "tail_k_se"}
#: the paper's α for the 1/2 mm mixture at 33 g/s and its variation in time, degrees (section 3.1)
PAPER_ALPHA = 25.69
PAPER_ALPHA_SE = 0.07
#: the case of that statement: diameters (m) and feed rate (kg/s)
PAPER_ALPHA_CASE = ((1.0e-3, 2.0e-3), 0.033)
#: the case of "δ ≈ 6d to 7d" (figure 6d): 1.5 mm monodisperse at 33 g/s
PAPER_DELTA_CASE = ((1.5e-3,), 0.033)
PAPER_DELTA_OVER_D = (6.0, 7.0)
#: u/u_s = 2.4 exp(3.3 z/δ) (figure 7b), each to the digits stated
PAPER_TAIL_A = (2.35, 2.45)
PAPER_TAIL_K = (3.25, 3.35)
#: δ/d̄ ∝ q*^a, a ≈ 0.22 (figure 11), to the digits stated
PAPER_Q_STAR_EXPONENT = (0.215, 0.225)
#: the paper's heap length W, gap T, feed height above the base, t_c, time step and averaging time (sections 2-3)
PAPER_W = 0.46
PAPER_T = 0.013
PAPER_FEED_DROP = 0.1
PAPER_T_C = 1.0e-3
PAPER_DT = 1.0e-5
PAPER_T_AVERAGE = 10.0
#: the largest overlap a faithful run should keep, as a fraction of the smallest diameter
OVERLAP_LIMIT = 0.01
#: the scene's figures kept in the record
FIGURES = ("fig04_surface", "fig04b_surface_shape", "fig06_streamwise", "fig07_collapse", "fig11_qstar")
#: the planar middle of the free surface (:data:`granflow.scenes.heap.analysis.ALPHA_PLANAR_MIDDLE`)
ALPHA_MIDDLE = hp.ALPHA_PLANAR_MIDDLE
#: its fit-range variants (the systematic error), the same fractions
ALPHA_MIDDLE_VARIANTS = ((0.2, 0.8), (0.3, 0.7))
#: fit-range variants of the exponential tail (z/δ), around the analysis's TAIL_RANGE
TAIL_RANGE_VARIANTS = ((-1.8, -0.6), (-1.4, -0.8))
#: collapsed profiles are kept down to this z/δ
COLLAPSE_ZT_MIN = -3.0
#: the analysis's tables of φ in depth and of the gap's slices (read by phi_checks and gap_checks)
DEPTH_AND_GAP_TABLES = ("static_bed", "phi_profile", "surface_cutoff", "gap_surface_velocity", "deposit_gap")


# --------------------------------------------------------------------------- inputs
@dataclass
class HeapCase:
    """What the analysis wrote for one case, and the errors of its headline numbers."""

    name: str
    path: Path
    record: dict
    status: dict
    scalars: dict
    tables: dict
    errors: dict = field(default_factory=dict)
    error_note: str = ""

    def get(self, key: str) -> float:
        return finite(self.scalars.get(key))

    @property
    def measured(self) -> bool:
        """The analysis ran and found usable streamwise bins."""
        return bool(self.scalars) and not self.tables["per_x"].empty

    @property
    def why_not(self) -> str:
        if not self.scalars:
            return "not analysed (no analysis/scalars.json)"
        reason = self.scalars.get("status_reason") or self.status.get("reason") or ""
        return f"not measured: case {self.scalars.get('status', '?')}" + (f" ({reason})" if reason else "")

    @property
    def status_note(self) -> str:
        """The case's status when it is not steady (its numbers are then to be read with care)."""
        s = self.scalars.get("status")
        return "" if s == "steady" else f"; case {s}: {self.scalars.get('status_reason')}"

    @property
    def diameters(self) -> tuple[float, ...]:
        return tuple(sorted(float(s["d"]) for s in self.record["species"]))

    @property
    def feed_rate(self) -> float:
        return float(self.record["case"]["feed_rate"])

    def is_case(self, diameters, feed_rate) -> bool:
        """Whether this is the paper's case of given mean diameters (m) and feed rate (kg/s)."""
        return (len(self.diameters) == len(diameters) and np.allclose(self.diameters, diameters, rtol=1e-6)
                and math.isclose(self.feed_rate, feed_rate, rel_tol=1e-6))


def load_case(name: str, path: Path) -> HeapCase:
    """The case's record, run status, analysis scalars and tables (empty where absent), and its errors."""
    path = Path(path)
    record, status, scalars, _ = read_case(path)
    tables = {t: read_table(path / "analysis" / f"{t}.csv") for t in ("per_x", "collapse", "surface", "deposit", "deposit_variants",
                                                                     *DEPTH_AND_GAP_TABLES)}
    case = HeapCase(name, path, record, status, scalars, tables)
    case.errors, case.error_note = headline_errors(case)
    return case


def headline_errors(case) -> tuple[dict, str]:
    """Standard error of each headline number and how it was obtained
    (:func:`granflow.validation.headline_errors`; the fallback is :data:`HEADLINE_FALLBACK`)."""
    fallback = {k: (case.get(v) if v else float("nan")) for k, v in HEADLINE_FALLBACK.items()}
    return validation_errors("heap", case.path, case.record, case.status, fallback, case.measured)


def _with(note: str, case: HeapCase, errors: bool = False) -> str:
    return note + (f"; {case.error_note}" if errors and case.error_note else "") + case.status_note


def _not_measured(quantity: str, paper: str, source: str, case: HeapCase, **kw) -> Check:
    return Check(quantity, paper, source, float("nan"), case=case.name, note=case.why_not, **kw)


# --------------------------------------------------------------------------- per-case checks
def _surface_grid(case: HeapCase):
    """``(t, x_lab, z_s (n_t, n_x))`` of the case's free surface (``surface.csv``), or None."""
    return hp.surface_grid(case.tables["surface"])


def alpha_planar(case: HeapCase, middle=ALPHA_MIDDLE, frames: slice = slice(None)) -> tuple[float, float, float]:
    """``(α, stat error, residual)`` of the plane fitted to the planar middle of the surface, degrees.

    The plane :math:`z_s = z_0 - x \\tan\\alpha + v_r t` (:func:`~granflow.scenes.heap.analysis.fit_surface`)
    over the columns between ``middle`` fractions of the flowing length (feed zone's edge to end wall);
    its error is that of the mean of the per-frame angles, :math:`sd\\sqrt{g/n}` with their statistical
    inefficiency g (surges span frames), or the fit's when larger.
    """
    from postproc.autocorr import statistical_inefficiency

    grid = _surface_grid(case)
    if grid is None:
        return float("nan"), float("nan"), float("nan")
    t, x, Z = grid
    geometry = case.record["geometry"]
    L = geometry["W"] - geometry["x_feed"]
    fit = hp.fit_surface(t[frames], x, Z[frames], (geometry["x_feed"] + middle[0] * L, geometry["x_feed"] + middle[1] * L))
    a_t = fit.alpha_t["alpha_deg"].dropna().to_numpy()
    se = fit.alpha_se
    if len(a_t) >= 4:
        g = max(1.0, statistical_inefficiency(a_t))
        se = max(se, float(np.std(a_t, ddof=1) * math.sqrt(g / len(a_t))))
    return fit.alpha_deg, se, fit.residual_std


def alpha_change(case: HeapCase) -> Check:
    """α's change across the averaging window over the planar middle, the other fit ranges its syst."""
    return alpha_change_case(case, ALPHA_MIDDLE, ALPHA_MIDDLE_VARIANTS)


def alpha_check(case: HeapCase) -> Check:
    q = "dynamic angle of repose α (planar middle of the surface)"
    if case.is_case(*PAPER_ALPHA_CASE):
        paper, source = f"{PAPER_ALPHA} ± {PAPER_ALPHA_SE}", "§3.1, Fig. 4b inset (1/2 mm, 33 g/s)"
        kw = dict(paper_range=(PAPER_ALPHA, PAPER_ALPHA), paper_error=PAPER_ALPHA_SE)
    else:
        paper = f"not stated for this case (only for 1/2 mm at 33 g/s: {PAPER_ALPHA} ± {PAPER_ALPHA_SE})"
        if case.is_case(PAPER_ALPHA_CASE[0], case.feed_rate):
            paper += "; its 1/2 mm runs are at 10, 33 and 120 g/s"
        source, kw = "§3.1; Table 1", {}
    if not case.measured or _surface_grid(case) is None:
        return _not_measured(q, paper, source, case, unit="deg", **kw)
    theta = float(case.record["geometry"]["theta_deg"])
    alpha, se, _ = alpha_planar(case)
    n_t = len(_surface_grid(case)[0])
    # every variant reads a subset or superset of the same surface: only its shift beyond its own
    # statistics counts (granflow.validation.systematic)
    alt = {f"x over {lo:g}-{hi:g} of the flowing length": alpha_planar(case, (lo, hi))[:2]
           for lo, hi in ALPHA_MIDDLE_VARIANTS}
    # the paper fits "the entire free surface" (§3.1, fig. 4b): on our S-shaped short heap that reading is a choice
    alt["the whole flowing length (the paper's fit of the entire free surface)"] = alpha_planar(case, (0.0, 1.0))[:2]
    alt["first half of the window"] = alpha_planar(case, frames=slice(0, n_t // 2))[:2]
    alt["second half of the window"] = alpha_planar(case, frames=slice(n_t // 2, None))[:2]
    syst, text = systematic(alpha, alt, central_se=se)
    lo, hi = ALPHA_MIDDLE
    note = (f"plane z_s = z_0 − x tan α + v_r t fitted to the free surface (φ = 0.35) of every frame of the averaging "
            f"window, over the planar middle: {lo:g}-{hi:g} of the flowing length from the feed zone's edge to the end "
            "wall. The surface is S-shaped (figure fig04b_surface_shape): a flat patch where the fed particles land "
            "and bounce and a flat pool against the end wall; the paper's heap (0.46 m) is long enough to have a "
            f"planar middle. Over the whole surface (the earlier reading): {case.get('alpha_deg'):.2f}°. Error: "
            f"the per-frame angles' correlation-aware error; the paper's base θ = {theta:g}° is 'slightly less "
            "than the dynamic angle of repose' (§2.1)")
    return Check(q, paper, source, alpha, se, case=case.name, unit="deg", note=_with(note, case), syst=syst,
                 variants=text, **kw)


def rise_check(case: HeapCase) -> Check:
    q = "v_r / (ṁ/(ρ φ_bed T W)): rise velocity over mass conservation"
    paper, source = "1 (mass conservation: v_r = q/W)", "§1, §3.1"
    if not case.measured:
        return _not_measured(q, paper, source, case, paper_range=(1.0, 1.0))
    v_r, v_pred = case.get("v_r"), case.get("v_r_predicted")
    geometry = hp.HeapGeometry(**case.record["geometry"])
    dx = case.record["rung_knobs"]["bin_dx"] * case.get("d_bar")
    g = hp.rise_inefficiency(case.tables["surface"], hp.surface_fit_range(geometry, dx)) \
        if not case.tables["surface"].empty else float("nan")
    v_se = case.get("v_r_se") * (math.sqrt(g) if math.isfinite(g) else 1.0)
    rate, rate_se = case.get("feed_rate_measured"), case.get("feed_rate_measured_se")
    ratio = v_r / v_pred
    se = abs(ratio) * math.hypot(v_se / v_r, rate_se / rate if math.isfinite(rate_se) else 0.0)
    note = (f"v_r = {pm(v_r * 1e3, v_se * 1e3, '.4g', 'mm/s')} from the fitted plane (least-squares error × √g, "
            f"g = {g:.3g} frames for correlated residuals); predicted {v_pred * 1e3:.4g} mm/s from the delivered "
            f"ṁ = {rate * 1e3:.4g} g/s, φ_bed = {case.get('phi_bed'):.3f} (static bed 1.5δ to 1.5δ + 20 d̄ below the "
            f"surface), T = {geometry.T * 1e3:g} mm, W = {geometry.W:g} m; φ_bed's own error is not included")
    return Check(q, paper, source, ratio, se, case=case.name, paper_range=(1.0, 1.0), note=_with(note, case))


#: where z = 0 is, in words (granflow.scenes.heap.analysis.analyse_heap's ``origin``)
_ORIGIN_WORDS = {"local": "each column's own free surface (φ = 0.35 of its time-averaged profile)",
                 "plane": "the plane fitted to the whole surface (the paper's origin, §2)"}


def _other_origin(case: HeapCase) -> str:
    """The origin the analysis did not use for its headlines (the measurement variant)."""
    return "plane" if case.scalars.get("origin", "plane") == "local" else "local"


def _offset_note(case: HeapCase) -> str:
    off = case.get("surface_offset_max_over_d")
    if not math.isfinite(off):
        return ""
    return (f"; the local surface lies up to {off:.2g} d̄ (rms {case.get('surface_offset_rms') * 1e3:.2g} mm) from "
            f"the fitted plane over 0.2 ≤ x/L ≤ 0.9 (the paper's plane: within 1 d, §3.1)")


def delta_check(case: HeapCase) -> Check:
    q = "δ/d̄ (flowing-layer thickness, local mean diameter)"
    paper, source = "6d to 7d (1.5 mm, 33 g/s)", "§3.2.2, Fig. 6d"
    if not case.measured:
        return _not_measured(q, paper, source, case, paper_range=PAPER_DELTA_OVER_D)
    value, n = hp.delta_over_local_d(case.tables["per_x"])
    global_ratio = case.get("delta_over_d")
    rel = case.errors.get("delta_over_d", np.nan) / global_ratio
    note = (f"mean over {n} usable bins with 0.2 ≤ x/L ≤ 0.9 of δ (0.1 u_s cutoff) over the number-mean diameter "
            f"in the layer (the paper's local d̄, §3.3); over the mixture's mean d̄ = {case.get('d_bar') * 1e3:.3g} mm "
            f"it is {pm(global_ratio, case.errors.get('delta_over_d', np.nan))}, whose relative error is used"
            + (f" ({case.error_note})" if case.error_note else ""))
    if not case.is_case(*PAPER_DELTA_CASE):
        note += ("; the paper states 6-7 d for 1.5 mm at 33 g/s only; its Fig. 10(d) shows δ/d̄ of every case "
                 "(the 1/2 mm mixture included) with no clear trend: the band is its nearest statement, not a value "
                 "for this case")
    alt = {}
    for name, key in (("exponential fit × 2.3", "delta_exp"), ("linear extrapolation", "delta_lin")):
        if key in case.tables["per_x"]:
            alt[f"δ by {name}"] = hp.delta_over_local_d(case.tables["per_x"].assign(delta=case.tables["per_x"][key]))[0]
    other = _other_origin(case)
    if math.isfinite(case.get("delta_over_d_other_origin")) and math.isfinite(global_ratio) and global_ratio > 0:
        # the other origin's δ over the mixture's d̄, put on the local-d̄ footing of ours
        alt[f"origin: {other}"] = value * case.get("delta_over_d_other_origin") / global_ratio
    syst, text = systematic(value, alt)
    note += "; syst: the paper's other two δ methods (§3.2.2), each over the same bins"
    if f"origin: {other}" in alt:
        note += f", and z measured from {_ORIGIN_WORDS[other]}" + _offset_note(case)
    return Check(q, paper, source, value, value * rel, case=case.name, paper_range=PAPER_DELTA_OVER_D,
                 note=_with(note, case), syst=syst, variants=text)


def tail_checks(case: HeapCase) -> list[Check]:
    source = "Fig. 7b (1.5 mm, 33 g/s); Fig. 9: every case on the same curve"
    qa, qk = "tail u/u_s = A e^{k z/δ}: prefactor A", "tail u/u_s = A e^{k z/δ}: exponent k"
    if not case.measured:
        return [_not_measured(qa, "2.4", source, case, paper_range=PAPER_TAIL_A),
                _not_measured(qk, "3.3", source, case, paper_range=PAPER_TAIL_K)]
    note = ("least squares of ln(u/u_s) on z/δ over −1.6 < z/δ < −0.7, the collapsed profiles of all usable "
            "streamwise bins pooled")
    # A comes from the same fit as k, whose fit error ignores the same correlations: scale A's by k's ratio
    k_fit, k_se = case.get("tail_k_se"), case.errors.get("tail_exponent", np.nan)
    inflation = max(1.0, k_se / k_fit) if math.isfinite(k_se) and k_fit > 0 else 1.0
    a_note = (f"; error: the fit's (points taken as independent) × {inflation:.2g}, the ratio of k's error to its "
              "fit error" if inflation > 1 else "; error: the fit's, points taken as independent")
    syst_a = syst_k = float("nan")
    text_a = text_k = ""
    col = case.tables["collapse"]
    if not col.empty and {"zt", "ut"} <= set(col):
        fits = {f"z/δ over {lo:g} to {hi:g}": hp.fit_exponential_tail(col["zt"], col["ut"], lo, hi)
                for lo, hi in TAIL_RANGE_VARIANTS}
        alt_a = {k: (f.A, f.A_se) for k, f in fits.items()}
        alt_k = {k: (f.k, f.k_se) for k, f in fits.items()}
        other = _other_origin(case)
        if math.isfinite(case.get("tail_k_other_origin")):
            alt_a[f"origin: {other}"] = case.get("tail_A_other_origin")
            alt_k[f"origin: {other}"] = case.get("tail_k_other_origin")
        syst_a, text_a = systematic(case.get("tail_A"), alt_a, central_se=case.get("tail_A_se"))
        syst_k, text_k = systematic(case.get("tail_k"), alt_k, central_se=case.get("tail_k_se"))
        note += "; syst: the fit range" + (f" and z measured from {_ORIGIN_WORDS[other]}" if f"origin: {other}"
                                            in alt_k else "")
    return [Check(qa, "2.4", source, case.get("tail_A"), case.get("tail_A_se") * inflation, case=case.name,
                  paper_range=PAPER_TAIL_A, note=_with(note + a_note, case), syst=syst_a, variants=text_a),
            Check(qk, "3.3", source, case.get("tail_k"), case.errors.get("tail_exponent"), case=case.name,
                  paper_range=PAPER_TAIL_K, note=_with(note, case, errors=True), syst=syst_k, variants=text_k)]


def methods_check(case: HeapCase) -> Check:
    q = "three δ methods: spread (max − min)/mean"
    paper, source = "'similar' (no number)", "§3.2.2, Fig. 6d; §4"
    if not case.measured:
        return _not_measured(q, paper, source, case)
    values = {name: case.get(f"delta_{key}_mean") for name, key in
              (("exponential fit × 2.3", "exp"), ("linear extrapolation", "lin"), ("0.1 u_s cutoff", "cut"))}
    v = np.array(list(values.values()))
    spread = float(np.ptp(v) / np.mean(v)) if np.all(np.isfinite(v)) else float("nan")
    note = ("means over 0.2 ≤ x/L ≤ 0.9: " + ", ".join(f"{k} {x * 1e3:.3g} mm" for k, x in values.items())
            + "; the paper's three agree by eye in its Fig. 6d")
    return Check(q, paper, source, spread, case=case.name, note=_with(note, case))


def deposit_check(case: HeapCase) -> Check:
    q = "c_s upstream − downstream half of the deposit"
    paper, source = "> 0: small particles deposit upstream, large downstream", "§2.2, Fig. 3c"
    if len(case.record["species"]) < 2:
        return Check(q, paper, source, float("nan"), case=case.name, paper_range=(0.0, math.inf),
                     note="monodisperse case: no small-particle concentration (a mixture-only check)")
    if not case.measured or case.tables["deposit"].empty:
        return _not_measured(q, paper, source, case, paper_range=(0.0, math.inf))
    if not (case.tables["deposit"]["n"] > 0).any():   # a slow rise lays nothing below the layer in a short window
        dt = case.get("t_end") - case.get("t_start")
        rise = case.get("v_r_normal") * dt
        return Check(q, paper, source, float("nan"), case=case.name, paper_range=(0.0, math.inf), note=_with(
            f"nothing laid down below the flowing layer in the window: the surface rose {rise * 1e3:.2g} mm (normal "
            f"to itself) in its {dt:.3g} s, less than δ = {case.get('delta_mean') * 1e3:.2g} mm", case))
    geometry = case.record["geometry"]
    dep = case.tables["deposit"]
    x0, W = geometry["x_feed"], geometry["W"]
    by_volume = "volume" in dep
    weight = "volume" if by_volume else "n"
    d = hp.deposit_contrast(dep, x0, W, weight)
    d_n = hp.deposit_contrast(dep, x0, W, "n")
    # the end-wall pool reported apart: the deposit beyond the planar middle's end
    x_pool = x0 + ALPHA_MIDDLE[1] * (W - x0)
    d_nopool = hp.deposit_contrast(dep, x0, x_pool, weight)
    pool = dep[(dep["x_lab"] > x_pool) & (dep["n"] > 0)]
    w = pool[weight] if weight in pool else pool["n"]
    c_pool = float(np.sum(pool["c_s"] * w) / np.sum(w)) if len(pool) and np.sum(w) > 0 else float("nan")
    se, syst, text, stat_note = _deposit_errors(case, d["contrast"], x0, W, weight)
    note = (f"volume concentration of the small species in the material laid down in the averaging window below "
            f"the flowing layer, x_lab from the feed zone's edge to the end wall, halves weighted by "
            f"{'volume (the paper: by volume)' if by_volume else 'the particles counted (no volumes in this analysis)'}: "
            f"upstream {d['upstream']:.3f}, downstream {d['downstream']:.3f} ({d['n']} particles); weighted by "
            f"number {d_n['contrast']:+.3f}. The pool at the end wall (x_lab > {x_pool * 1e3:.0f} mm, beyond the "
            f"surface's planar middle) has c_s = {c_pool:.3f}; without it the contrast is "
            f"{d_nopool['contrast']:+.3f}. {stat_note}" + _flux_note(case))
    return Check(q, paper, source, d["contrast"], se, case=case.name, paper_range=(0.0, math.inf),
                 note=_with(note, case), syst=syst, variants=text)


def _deposit_errors(case: HeapCase, central: float, x0: float, W: float, weight: str):
    """``(stat, syst, variants' text, note)`` of the deposit's contrast from analysis/deposit_variants.csv.

    Stat: the spread of the contrasts of the deposit's slabs (the material of successive parts of the
    window, :func:`~granflow.scenes.heap.analysis.layer.deposit_contrast_error`). Syst: the deposit's top
    at 1.5 δ and 0.5 δ and the front-wall slice (subsets or supersets of the same particles: only their
    shift beyond their own statistics counts) and the column width (the same particles binned again).
    """
    var = case.tables.get("deposit_variants", pd.DataFrame())
    nan = float("nan")
    if var.empty or "variant" not in var:
        return nan, nan, "", "No statistical error (an analysis older than the deposit's slabs: re-analyse)"
    c, se, per = hp.deposit_contrast_error(var, hp.DEPOSIT_CENTRAL, x0, W, weight)
    alt = {}
    for name in dict.fromkeys(var["variant"]):
        if name == hp.DEPOSIT_CENTRAL:
            continue
        v, v_se, _ = hp.deposit_contrast_error(var, name, x0, W, weight)
        alt[name] = v if name.startswith("columns") else (v, v_se)
    syst, text = systematic(central, alt, se)
    note = (f"Error: the spread of the contrasts of the deposit laid in {len(per)} equal parts of the window "
            f"(oldest first: {', '.join(f'{x:+.3f}' for x in per)})")
    return se, syst, text, note


def _flux_note(case: HeapCase) -> str:
    """The measured mechanism: each species' share of its downstream flux carried above the surface, and
    where its particles fed in the window came to rest after how much flight over the heap."""
    small, large = (case.get(f"flux_above_surface_{k}") for k in (1, 2))
    if not (math.isfinite(small) and math.isfinite(large)):
        return ""
    return _flux_share_note(case, small, large) + _travel_note(case)


def _travel_note(case: HeapCase) -> str:
    rest, flight, share = ([case.get(f"travel_{key}_{k}") for k in (1, 2)]
                           for key in ("rest_x_over_L", "flight", "flight_share"))
    if not all(math.isfinite(v) for v in rest + flight):
        return ""
    n = [int(case.get(f"travel_n_{k}")) for k in (1, 2)]
    d_l = max(float(sp["d"]) for sp in case.record["species"])
    return (f". Particles fed in the window's first half (followed by id, {n[0]} small, {n[1]} large) came to rest "
            f"at mean x/L = {rest[0]:.2f} (small) and {rest[1]:.2f} (large); they flew {1e3 * flight[0]:.0f} and "
            f"{1e3 * flight[1]:.0f} mm more than {1e3 * d_l:g} mm above the surface ({share[0]:.0%} and {share[1]:.0%} "
            f"of their streamwise travel; scenes/heap/analysis/travel.py)")


def _flux_share_note(case: HeapCase, small: float, large: float) -> str:
    small_d, large_d = (case.get(f"flux_above_d_max_{k}") for k in (1, 2))
    return (f". Mechanism measured: the small species carries {small:.0%} of its downstream flux above the "
            f"surface, the large {large:.0%} ({small_d:.0%} and {large_d:.0%} more than a large diameter above "
            f"it; the mixture's velocity of each bin stands in for each species', scenes/heap/analysis/flux.py): flux "
            f"carried over the surface skips the flowing layer where small particles percolate and stop "
            f"upstream (the paper's Fig. 3c)")


# --------------------------------------------------------------------------- sweep check
def q_star_check(cases: list[HeapCase]) -> Check:
    """δ/d̄ ∝ q*^a over the usable bins with x/L ≥ 0.2 of every case, pooled (paper figure 11)."""
    q, paper, source = "δ/d̄ ∝ q*^a: exponent a", "≈ 0.22", "§3.3, Fig. 11"
    qs, ds, per_case = [], [], []
    for c in cases:
        if not c.measured:
            continue
        px = c.tables["per_x"]
        usable = px["usable"].astype(bool).to_numpy() if "usable" in px else np.ones(len(px), bool)
        sel = usable & (px["x_over_L"].to_numpy(float) >= hp.Q_STAR_MIN_X_OVER_L)
        qs.append(px["q_star"].to_numpy(float)[sel])
        ds.append((px["delta"] / px["d_bar"]).to_numpy(float)[sel])
        per_case.append(f"{c.name}: {pm(c.get('q_star_exponent'), c.get('q_star_exponent_se'), '.2f')}")
    if not qs:
        return Check(q, paper, source, float("nan"), paper_range=PAPER_Q_STAR_EXPONENT, note="no measured case")
    fit = hp.fit_power_law(np.concatenate(qs), np.concatenate(ds))
    rates = sorted({f"{1e3 * c.feed_rate:g}" for c in cases if c.measured})
    note = (f"least squares of ln(δ/d̄) on ln q*, q* = q/(d̄√(g d̄)), over the usable bins with x/L ≥ 0.2 of "
            f"{len(qs)} case(s) at {', '.join(rates)} g/s (per case: {'; '.join(per_case)}); error: the fit's, bins "
            "taken as independent (neighbours share particles: an underestimate). ")
    note += ("A weak test: with " + (f"{len(rates)} feed rates" if len(rates) > 1 else "one feed rate")
             + " the q* range comes mostly from the fall of q along each heap, where δ also thins towards the "
             "end wall, not from the feed rate as in the paper's 11 runs")
    return Check(q, paper, source, fit.exponent, fit.exponent_se, paper_range=PAPER_Q_STAR_EXPONENT, note=note)


# --------------------------------------------------------------------------- profiles
def profiles(cases: list[HeapCase]) -> dict[str, pd.DataFrame]:
    """Small tables behind the kept figures: kinematics along the heap, the collapse, the surface, the deposit."""
    streamwise, collapsed, surface, deposit = [], [], [], []
    for c in cases:
        if not c.measured:
            continue
        head = {"case": c.name}
        px = c.tables["per_x"]
        keep = [k for k in ("x", "x_over_L", "q", "u_s", "gamma_bar", "delta", "delta_exp", "delta_lin",
                            "delta_cut", "delta_eq31", "d_bar", "q_star", "usable", "c_s") if k in px]
        streamwise.append(px[keep].assign(**head)[["case", *keep]])
        col = c.tables["collapse"]
        if not col.empty:
            col = col[col["zt"] >= COLLAPSE_ZT_MIN]
            collapsed.append(col[["x", "zt", "ut", "wt"]].assign(**head)[["case", "x", "zt", "ut", "wt"]])
        s = c.tables["surface"]
        if not s.empty:
            # the surface of every frame brought back to the start of the window by the fitted rise
            t0, v_r = c.get("t_start"), c.get("v_r")
            back = s.assign(z_s=s["z_s"] - v_r * (s["t"] - t0)).groupby("x_lab")["z_s"]
            fit = c.get("surface_z0") - back.mean().index.to_numpy(float) * math.tan(math.radians(c.get("alpha_deg")))
            lo, hi = hp.surface_fit_range(hp.HeapGeometry(**c.record["geometry"]),
                                          c.record["rung_knobs"]["bin_dx"] * c.get("d_bar"))
            x = back.mean().index.to_numpy(float)
            surface.append(pd.DataFrame({**head, "x_lab": x, "z_s_mean": back.mean().to_numpy(),
                                         "z_s_std": back.std().to_numpy(), "z_s_fit": fit + v_r * t0,
                                         "in_fit": (x > lo) & (x < hi)}))
        if not c.tables["deposit"].empty:
            deposit.append(c.tables["deposit"].assign(**head)[["case", "x_lab", "c_s", "n"]])
    return concat_profiles((("streamwise", streamwise), ("collapse", collapsed), ("surface_at_window_start", surface),
                        ("deposit", deposit)))


# --------------------------------------------------------------------------- set-up
def law_difference(rec: dict, d_ref: float, knobs: dict, lightest: dict) -> str:
    """The contact law against the paper's (every pair and wall contact t_c and e): each contact's e and t_c."""
    es = [c["e_n"] for c in rec.get("contacts", []) if "e_n" in c] or [float("nan")]
    law = rec.get("contact_law", {}).get("law", "hooke/history")
    walls = "granular wall syntax" if "contact_law" in rec else "classic wall/gran hooke/history walls"
    if law == "hooke/pair_time":
        return (f"The paper's law per type pair (hooke/pair_time; {walls}): e = {min(es):.3g} for every contact; "
                f"t_c from {lightest['t_c'] * 1e3:.3g} ms to {max(c['t_c'] for c in rec['contacts']) * 1e3:.3g} ms "
                "inside the species' size spread (the paper: t_c for every contact)."
                + ("" if math.isclose(knobs["t_c"], PAPER_T_C) else
                   f" Our t_c is {knobs['t_c'] * 1e3:g} ms against the paper's {PAPER_T_C * 1e3:g} ms (which the paper "
                   "found alike to 0.1 ms): at 1 ms the 1 mm particles' soft wall contacts let particles through the "
                   "walls at our feed (docs/contact-laws.md)."))
    return (f"One normal stiffness for every pair and wall (LAMMPS gran/hooke/history; {walls}), set so that the "
            f"reference pair (mean diameter {d_ref * 1e3:g} mm) has t_c = {knobs['t_c'] * 1e3:g} ms "
            f"(the paper's: {PAPER_T_C * 1e3:g} ms) and "
            f"e; lighter pairs collide faster (the lightest, {lightest['name']}: t_c = {lightest['t_c'] * 1e3:.3g} ms) "
            f"and every contact has its own restitution: e from {min(es):.2f} to {max(es):.2f} over the listed "
            f"pairs and walls. The paper gives every pair and wall t_c = {PAPER_T_C * 1e3:g} ms and e = 0.8 "
            "(k_n ∝ m_eff): that law (hooke/pair_time) at 1 ms loses 1 mm particles through the walls at this feed "
            "(docs/contact-laws.md).")


def differences(cases: list[HeapCase]) -> list[str]:
    """What differs from the paper's set-up, from the cases' records; one line per case for the overlap."""
    if not cases:
        return []
    rec = cases[0].record
    k, prm = rec["rung_knobs"], rec["parameters"]
    d_ref = prm.get("d_ref", max(s["d"] for s in rec["species"]))
    d_bar = mixture_mean_diameter(rec["species"]) if all("mean_volume" in s for s in rec["species"]) else d_ref
    lightest = min(rec["contacts"], key=lambda c: c["t_c"])
    same = [name for name, ours, paper in (("Gap T", k["T"], PAPER_T), ("feed height", k.get("feed_drop"),
                                                                     PAPER_FEED_DROP))
            if ours is not None and math.isclose(ours, paper, rel_tol=1e-6)]
    out = [
        f"Heap W = {k['W']:g} m long instead of the paper's {PAPER_W:g} m (its flow reaches q = 0 at x = 0.42 m), "
        f"feed zone {k['feed_width'] * 1e3:g} mm wide: what 2 cores afford; the flowing layer is about "
        f"{PAPER_W / k['W']:.1f}x shorter, so fewer streamwise bins lie away from the feed and the end wall "
        "(0.2 ≤ x/L ≤ 0.9)." + (f" {' and '.join(same)} as the paper's." if same else ""),
        law_difference(rec, d_ref, k, lightest),
        f"Time step dt = {k['dt_fraction']:g} × the shortest pair's t_c = t_c/{1 / k['dt_fraction']:.0f} = "
        f"{rec['dt']:.3g} s (the paper: t_c/100 = {PAPER_DT:g} s).",
        f"Averaging over {k['t_average']:g} s of steady filling (the paper: δt = {PAPER_T_AVERAGE:g} s).",
        f"Bins in units of the mixture's number-mean diameter d̄ = {d_bar * 1e3:.3g} mm: Δx = {k['bin_dx']:g} d̄ = "
        f"{k['bin_dx'] * d_bar * 1e3:.3g} mm, Δz = {k['bin_dz_phi']:g} d̄ = {k['bin_dz_phi'] * d_bar * 1e3:.2g} mm "
        f"for φ and {k['bin_dz_u']:g} d̄ = {k['bin_dz_u'] * d_bar * 1e3:.2g} mm for u (the paper: 10, 0.5 and 1 mm).",
        f"The paper's t_c = {PAPER_T_C * 1e3:g} ms is soft (ours {k['t_c'] * 1e3:g} ms: the softest type pair's "
        f"k_n = {prm['k_n']:.3g} N/m). Fed particles hit the heap at "
        "~1-2 m/s after falling ~0.1 m and overlap by tens of % of a diameter for one contact time; the static "
        "bed, a few % under its own weight. Overlap scales as t_c: keeping the largest at 1 % would need t_c shorter "
        "by the factor f below, i.e. f² stiffer contacts and f× smaller time steps (~100x and ~10x at f = 10). The "
        "paper checked its kinematics against t_c = 0.1 ms (§2.1).",
    ]
    for c in cases:
        ov = finite(c.status.get("max_overlap"))
        if math.isfinite(ov):
            f = ov / OVERLAP_LIMIT
            out.append(f"{c.name}: largest overlap {ov:.1%} of the smallest diameter, {f:.0f}x the 1 % limit "
                       f"(f = {f:.0f}: {f * f:.0f}x stiffer, {f:.0f}x smaller steps to meet it).")
        else:
            out.append(f"{c.name}: largest overlap not recorded (run status {c.status.get('status')}).")
    return out


# --------------------------------------------------------------------------- the record
def validation(scene_dir: Path, cases: dict[str, Path]) -> ValidationResult:
    """The heap's checks against Fan et al. (2013), its profiles, figures and set-up differences.

    Parameters
    ----------
    scene_dir : Path
        ``results/heap/<rung>``, holding ``table.csv`` and ``figures/``.
    cases : dict of str to Path
        Case directory name (e.g. ``mix~bi1-2/mdot~33``) to its analysed case directory.
    """
    loaded = sorted((load_case(name, path) for name, path in cases.items()),
                    key=lambda c: (c.record["case"]["mixture"], c.feed_rate, c.name))
    checks = []
    for make in (alpha_check, alpha_change, rise_check, delta_check, tail_checks, methods_check, deposit_check, phi_checks, gap_checks):
        for c in loaded:
            made = make(c)
            checks += made if isinstance(made, list) else [made]
    checks.append(q_star_check(loaded))
    kept = profiles(loaded)
    # the checks made from the profiles the record keeps (HeapScene.profile_checks: the same code judges a
    # committed record): kinematics along the heap, the collapse, w, the surface, across feed rates, q*, γ̇(z)
    checks += profile_checks(kept) + shear_checks(kept)
    return ValidationResult(checks=checks, profiles=kept, figures=list(FIGURES), differences=differences(loaded))
