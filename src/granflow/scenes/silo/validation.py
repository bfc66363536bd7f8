"""The silo's validation record: Rubio-Largo, Maza & Hidalgo (2016) against our cases.

:func:`validation` compares what the scene's analysis wrote for each finished case
(``analysis/scalars.json``, ``fields.csv``, ``contact.csv``, ``flow.csv``) and the rung's
``table.csv`` (the Beverloo fit over the orifices) with the paper; it recomputes no field.

Checks, in the paper's order: Beverloo's C and k over the sweep (the paper gives neither);
:math:`W_r/W_f` per case (its figure 2a, "excellent agreement"); the orifice velocity profile
against :math:`\\sqrt{1-(r/R)^2}` (figure 5b) and the exponent of :math:`v_z(0) \\propto R^a`
(:math:`a = 1/2`), read without a kernel from the particles crossing the orifice plane
(:mod:`granflow.scenes.silo.analysis.orifice`) and fitted both as a power law and as
:math:`A(R-R_0)^b`, beside the kernel node's reading; :math:`W_f/(\\rho_p\\phi_c v_c\\pi R^2)` over R
(figure 2b: one constant); the transition height :math:`h_c/R` per case and its trend over R (the
collapse of figure 8); :math:`\\phi_{bulk}` (section 3, 0.60 ± 0.02); the partial kinetic
pressure per unit volume fraction, smallest size over largest, at :math:`h_c` (figure 12); the
fall of the contact pressure to the outlet (figure 6).

Errors are one standard error of ours (stat) and, for the scalings and :math:`h_c/R`, a
systematic error (syst, :func:`granflow.validation.systematic`): the largest shift over the
measurement choices (slab width, profile form, fit range; kernel width and the peak's node
resolution for :math:`h_c`), each recomputed from the same analysis. The headline numbers (:math:`W_f`, the profile
deviation, :math:`h_c/R`) carry the correlation-aware error of
:func:`granflow.headline.measure_with_errors`, which re-analyses sub-windows of the steady
window from the dumps; without dumps the analysis's own block errors stand in (the note says
so). Fit parameters carry the fits' standard errors; field values the coarse-graining block
errors of the analysis.
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

import granflow.scenes.silo.analysis as sl
from .field_checks import steady_rate_check
from .profile_checks import profile_checks

#: the silo scene's headline keys (``SiloScene.headline``) and, per key, the analysis's own error
HEADLINE_FALLBACK = {"W_f": "W_f_se", "profile_deviation": None, "h_c_over_R": "h_c_over_R_se"}
#: the paper's particle count (section 2)
PAPER_N = 393_216
#: the paper's time step, s, :math:`t_c/50` of two small particles (appendix)
PAPER_DT = 6.3e-7
PAPER_DT_FRACTION = 1 / 50
#: the paper's Young's modulus, Pa (appendix)
PAPER_Y = 120e9
#: the paper's bulk volume fraction, 0.60 ± 0.02 (section 3)
PHI_BULK = (0.58, 0.62)
#: the contact pressure's fall is judged over 0 <= z <= CONTACT_SPAN R on the axis
CONTACT_SPAN = 2.0
#: the largest overlap a faithful run should keep, as a fraction of the smallest diameter
OVERLAP_LIMIT = 0.01
#: the scene's figures kept in the record
FIGURES = ("fig05_vz_orifice", "fig05d_orifice_plane", "fig08_kinetic_axis", "fig12_partial_over_phi",
           "fig13_beverloo")
#: the paper's orifices: 12 r_s, 12 r_m and 12 r_b with r_s = 0.5625 r_b (section 2), in r_b
PAPER_R_RANGE = (6.75, 12.0)
#: orifice profiles are kept up to this r/R
PROFILE_R_MAX = 2.0


# --------------------------------------------------------------------------- inputs
@dataclass
class SiloCase:
    """What the analysis wrote for one case, and the errors of its headline numbers."""

    name: str
    path: Path
    record: dict
    status: dict
    scalars: dict
    fields: pd.DataFrame
    contact: pd.DataFrame
    flow: pd.DataFrame
    plane: pd.DataFrame = field(default_factory=pd.DataFrame)
    errors: dict = field(default_factory=dict)
    error_note: str = ""

    def get(self, key: str) -> float:
        return finite(self.scalars.get(key))

    @property
    def steady(self) -> bool:
        return self.scalars.get("status") == "steady" and not self.fields.empty

    @property
    def why_not(self) -> str:
        """Why a case has no steady fields, for the notes of its checks."""
        if not self.scalars:
            return "not analysed (no analysis/scalars.json)"
        reason = self.scalars.get("status_reason") or self.status.get("reason") or ""
        return f"not measured: case {self.scalars.get('status', '?')}" + (f" ({reason})" if reason else "")

    @property
    def R_over_rb(self) -> float:
        return finite(self.record.get("R_over_rb"))


def load_case(name: str, path: Path) -> SiloCase:
    """The case's record, run status, analysis scalars and tables (empty where absent), and its errors."""
    path = Path(path)
    record, status, scalars, _ = read_case(path)
    case = SiloCase(name, path, record, status, scalars, *(read_table(path / "analysis" / f"{t}.csv")
                                                           for t in ("fields", "contact", "flow", "orifice_plane")))
    case.errors, case.error_note = headline_errors(case)
    return case


def headline_errors(case) -> tuple[dict, str]:
    """Standard error of each headline number and how it was obtained
    (:func:`granflow.validation.headline_errors`; the fallback is :data:`HEADLINE_FALLBACK`)."""
    fallback = {k: (case.get(v) if v else float("nan")) for k, v in HEADLINE_FALLBACK.items()}
    return validation_errors("silo", case.path, case.record, case.status, fallback, case.steady)


# --------------------------------------------------------------------------- sweep checks
def beverloo_checks(table: pd.DataFrame) -> list[Check]:
    """Beverloo's C and k from the rung's table (:meth:`SiloScene.table`, :func:`beverloo_fit`)."""
    row = table.iloc[0].to_dict() if len(table) else {}
    C, C_se, k, k_se = (finite(row.get(f"beverloo_{key}")) for key in ("C", "C_se", "k", "k_se"))
    if math.isfinite(C):
        note = (f"weighted fit of W = C ρ_b √g (2R − k d)^5/2 over {int(finite(row.get('beverloo_n')))} steady "
                f"orifices (χ²/ν = {finite(row.get('beverloo_chi2_dof')):.2g}; errors scaled by it when > 1); "
                "ρ_b = ρ_p φ_bulk averaged over the cases, d the number-mean diameter (k depends on that choice)")
    else:
        note = f"no fit: {row.get('beverloo_note') or 'no table.csv with a Beverloo fit'}"
    paper = "not stated (the paper cites Beverloo 1961 and Mankoc 2007, its refs 6-7, without values)"
    note += "; the paper gives no C or k, so there is nothing to compare with"
    source = "§1 (refs 6-7)"
    return [Check("Beverloo C", paper, source, C, C_se, note=note),
            Check("Beverloo k", paper, source, k, k_se, note=note)]


def _plane(case: SiloCase, key: str, slab: float | None = None) -> tuple[float, float]:
    """``(|value|, se)`` of a kernel-free orifice reading (``v_c_plane``, ``v_core_plane``) at a slab."""
    name = key if slab is None else f"{key}_h{slab:g}"
    return abs(case.get(name)), case.get(name + "_se")


def _in_paper_range(c: SiloCase) -> bool:
    return c.R_over_rb >= PAPER_R_RANGE[0] - 1e-9


def _plane_variants(ok: list[SiloCase]) -> dict[str, tuple[list, list]]:
    """v_c per case (value, se) for each measurement choice of the kernel-free reading."""
    head = ok[0].get("plane_slab_half") if ok else 0.5
    out = {"headline": [_plane(c, "v_c_plane") for c in ok]}
    for h in (0.25, 0.5, 1.0):
        if h != head:
            out[f"slab ±{h:g} r_b"] = [_plane(c, "v_c_plane", h) for c in ok]
    out["v_z averaged over r < R/4 (no shape fit)"] = [_plane(c, "v_core_plane") for c in ok]
    return out


def velocity_exponent_checks(cases: list[SiloCase]) -> list[Check]:
    """Exponent of :math:`v_c = |v_z(0)| \\propto R^a` (paper: 1/2), read two ways and fitted two ways.

    1. the orifice plane without a kernel (:mod:`~granflow.scenes.silo.analysis.orifice`), power law,
       with its systematic error over the slab width, the profile form and the fit range;
    2. the same readings fitted as :math:`A (R - R_0)^b` (Beverloo's empty annulus), exponent b;
    3. the kernel node (r = 0, z = 0) at w = 2 r_b, power law, as before (biased: the deletion plane
       cuts the kernel's lower part).
    """
    ok = [c for c in cases if c.steady]
    R = np.array([c.get("R") for c in ok])
    paper, source = "1/2 (v_z ∝ √R)", "§3, Fig. 5"
    checks = []
    have_plane = bool(ok) and all(math.isfinite(c.get("v_c_plane")) for c in ok)
    if have_plane:
        variants = _plane_variants(ok)
        head_v, head_se = (np.array(x) for x in zip(*variants["headline"]))
        inside = np.array([_in_paper_range(c) for c in ok])

        def power(v, se, sel=slice(None)):
            return sl.scaling_exponent(R[sel], np.asarray(v)[sel], np.asarray(se)[sel])

        def shifted(v, se, sel=slice(None)):
            return sl.shifted_power_fit(R[sel] / ok[0].record["r_b"], np.asarray(v)[sel], np.asarray(se)[sel])

        for kind, fit_fn, key in (("power law", power, "exponent"), ("A (R − R0)^b", shifted, "exponent")):
            head = fit_fn(head_v, head_se)
            alt = {}
            for name, vals in variants.items():
                if name != "headline":
                    v, se = zip(*vals)
                    f = fit_fn(v, se)
                    alt[name] = (f[key], f[key + "_se"])
            f = fit_fn(head_v, head_se, inside)
            alt[f"R ≥ {PAPER_R_RANGE[0]:g} r_b only (the paper's orifices)"] = (f[key], f[key + "_se"])
            # each variant reads a subset or superset of the same particles: only its shift beyond its
            # own statistics counts (granflow.validation.systematic)
            syst, text = systematic(head[key], alt, central_se=head[key + "_se"])
            W_ratio = ", ".join(f"{c.get('W_plane') / c.get('W_f'):.3f}" for c in ok)
            if kind == "power law":
                q = "v_z(0) ∝ R^a: exponent a (orifice plane, no kernel)"
                note = (f"weighted fit of ln|v_c| against ln R over {head['n']} orifices (χ²/ν = {head['chi2_dof']:.2g}; "
                        "errors scaled by it when > 1); v_c from the particles within ±0.5 r_b of the orifice plane, "
                        "binned by r (r_b/2), fitted with v_c √(1−(r/R)²) over r < 0.9R; errors: 8 blocks of frames. "
                        "Mass through the plane / W_f per case (mass conservation, a check of the reading): "
                        f"{W_ratio}. The fit's χ² and the shifted fit below show the curvature Beverloo's "
                        "empty annulus gives at R of 3-6 large diameters")
            else:
                q = "v_c = A (R − R0)^b: exponent b (orifice plane, no kernel)"
                note = (f"weighted fit over {head['n']} orifices: R0 = {pm(head['x0'], head['x0_se'], '.3g')} r_b, "
                        f"χ²/ν = {head['chi2_dof']:.2g} (errors scaled by it when > 1); the paper fits no offset, "
                        "its √R is over three orifices of 6.75-12 r_b. A fit range of 4 orifices leaves one degree "
                        "of freedom")
            checks.append(Check(q, paper, source, head[key], head[key + "_se"], paper_range=(0.5, 0.5),
                                note=note, syst=syst, variants=text))
    fit = sl.scaling_exponent(R, [c.get("v_c") for c in ok], [c.get("v_c_se") for c in ok])
    note = (f"weighted fit of ln v_c against ln R over {fit['n']} orifices (v_c at the orifice-centre node of the "
            "w = 2 r_b fields; errors: coarse-graining errors (correlation-aware), scaled by χ²/ν when > 1). Biased: "
            "the deletion plane 1.05 r_b below the orifice leaves the kernel's lower part empty, more so at small R "
            "(a forward test with particles falling at exactly √(2gR) reads R^0.8-0.9); kept to compare with the "
            "earlier record, the plane reading above is the measurement")
    if fit["n"] < 2:
        note = f"fewer than 2 steady orifices ({fit['n']}): no exponent"
    checks.append(Check("v_z(0) ∝ R^a: exponent a (kernel node, w = 2 r_b)", paper, source, fit["exponent"],
                        fit["exponent_se"], paper_range=(0.5, 0.5), note=note))
    return checks


def flow_scale_check(cases: list[SiloCase]) -> Check:
    """:math:`\\tilde W = W_f/(\\rho_p \\phi_c v_c \\pi R^2)` over R (paper Fig. 2b: one constant), as
    the exponent c of :math:`\\tilde W \\propto R^c` (paper: 0), from the kernel-free reading."""
    q, paper, source = "W_f/(ρ_p φ_c v_c πR²) ∝ R^c: exponent c (orifice plane)", "0 (one constant)", "§3, Fig. 2b"
    ok = [c for c in cases if c.steady and math.isfinite(c.get("v_c_plane"))]
    if len(ok) < 2:
        return Check(q, paper, source, float("nan"), paper_range=(0.0, 0.0),
                     note=f"fewer than 2 steady orifices with the plane reading ({len(ok)})")
    rho = ok[0].get("density")

    def scaled(slab=None):
        vals, ses = [], []
        for c in ok:
            v, v_se = _plane(c, "v_c_plane", slab)
            phi = c.get("phi_c_plane" if slab is None else f"phi_c_plane_h{slab:g}")
            w = float(sl.scaled_flow_rate(c.get("W_f"), rho, phi, v, c.get("R")))
            vals.append(w)
            ses.append(w * math.hypot(c.errors.get("W_f", c.get("W_f_se")) / c.get("W_f"), v_se / v))
        return np.array(vals), np.array(ses)

    R = np.array([c.get("R") for c in ok])
    v, se = scaled()
    head = sl.scaling_exponent(R, v, se)
    alt = {}
    for h in (0.25, 1.0):
        if h != ok[0].get("plane_slab_half"):
            f = sl.scaling_exponent(R, *scaled(h))
            alt[f"slab ±{h:g} r_b"] = (f["exponent"], f["exponent_se"])
    syst, text = systematic(head["exponent"], alt, central_se=head["exponent_se"])
    kernel = [float(sl.scaled_flow_rate(c.get("W_f"), rho, c.get("phi_c"), c.get("v_c"), c.get("R"))) for c in ok]
    note = (f"W̃ per orifice (R = {', '.join(f'{c.R_over_rb:g}' for c in ok)} r_b): "
            f"{', '.join(f'{x:.3f}' for x in v)} from the orifice plane (φ_c and v_c over r < R/4 and the shape fit; "
            "2/3 for a flat φ and v ∝ √(1−(r/R)²)); from the kernel node (w = 2 r_b): "
            f"{', '.join(f'{x:.3f}' for x in kernel)}; errors: W_f and v_c (φ_c's not included)")
    return Check(q, paper, source, head["exponent"], head["exponent_se"], paper_range=(0.0, 0.0), note=note,
                 syst=syst, variants=text)


def _resolved_widths(c: SiloCase, widths) -> list[str]:
    """The scan's kernel widths (as written in the keys) other than the main fields' that the nodes
    resolve: a kernel narrower than the node spacing cannot place a peak between nodes, so it is no
    measurement variant (the paper's w = r_b/2 needs nodes r_b/4 apart)."""
    cg = c.record["cg"]
    return [w for w in sorted(widths, key=float)
            if float(w) != cg["w_fields"] and float(w) >= cg["node_spacing"] - 1e-12]


def _slope_error(R, y, sigma) -> float:
    """The error of the exponent of :math:`y R \\propto R^\\beta` from per-point errors ``sigma`` of y alone
    (no :math:`\\chi^2` scaling): :math:`1/\\sqrt{\\sum_i w_i (x_i - \\bar x_w)^2}`, x = ln R,
    :math:`w_i = (y_i/\\sigma_i)^2`."""
    x, w = np.log(R), (np.asarray(y) / np.asarray(sigma)) ** 2
    return float(1.0 / np.sqrt(np.sum(w * (x - np.sum(w * x) / np.sum(w)) ** 2)))


def _node_sigma(c: SiloCase) -> float:
    """The refined peak's resolution error in units of R: anywhere within a third of the node spacing
    (how far a skewed peak's refined position may be off), uniform, so sigma = (spacing/3)/sqrt(3)."""
    return c.record["cg"]["node_spacing"] / 3.0 / math.sqrt(3.0) / c.R_over_rb


def collapse_check(cases: list[SiloCase]) -> Check:
    """Exponent of :math:`h_c \\propto R^\\beta` over the steady cases: 1 when the axis profiles collapse on
    z/R; systematic error over the kernel width, the fit range and the peak's node resolution."""
    ok = [c for c in cases if c.steady and math.isfinite(c.get("h_c_over_R"))]
    R = np.array([c.get("R") for c in ok])
    y = np.array([c.get("h_c_over_R") for c in ok])
    se = np.array([c.errors.get("h_c_over_R", np.nan) for c in ok])
    fit = sl.scaling_exponent(R, y * R, se * R)
    syst, text = float("nan"), ""
    if len(ok) >= 2:
        w = 1 / se ** 2 if np.all(np.isfinite(se) & (se > 0)) else np.ones(len(y))
        mean = np.sum(w * y) / np.sum(w)
        mean_se = np.sqrt(1 / np.sum(w)) if np.all(np.isfinite(se)) else np.nan
        alt = {}
        for wk in _resolved_widths(ok[0], {k.rsplit("_w", 1)[1] for c in ok for k in c.scalars
                                           if k.startswith("h_c_over_R_w") and not k.endswith("_se")}):
            yw = np.array([c.get(f"h_c_over_R_w{wk}") for c in ok])
            sw = np.array([c.get(f"h_c_over_R_w{wk}_se") for c in ok])
            alt[f"kernel w = {wk} r_b"] = sl.scaling_exponent(R, yw * R, sw * R)["exponent"]
        inside = np.array([_in_paper_range(c) for c in ok])
        if inside.sum() >= 2:
            f = sl.scaling_exponent(R[inside], (y * R)[inside], (se * R)[inside])
            alt[f"R ≥ {PAPER_R_RANGE[0]:g} r_b only"] = (f["exponent"], f["exponent_se"])
        syst, text = systematic(fit["exponent"], alt, central_se=fit["exponent_se"])
        # the refined peak anywhere within a third of a node: uniform, sigma = third/sqrt(3) per case,
        # independent; its share of the exponent's error joins the syst in quadrature
        node = np.array([_node_sigma(c) for c in ok])
        node_se = _slope_error(R, y, node)
        text += f"; node resolution (a third of a node, uniform): ±{node_se:.3g}"
        syst = math.hypot(syst if math.isfinite(syst) else 0.0, node_se)
        lin = sl.weighted_line_fit(R / ok[0].record["r_b"], y * R / ok[0].record["r_b"], se * R / ok[0].record["r_b"])
        R0 = -lin["intercept"] / lin["slope"] if lin["slope"] else float("nan")
        h = ok[0].record["cg"]["node_spacing"]
        note = (f"weighted fit of ln h_c against ln R over {len(ok)} orifices (w = 2 r_b, nodes {h:g} r_b apart); weighted "
                f"mean h_c/R = {pm(mean, mean_se)}, spread (std/mean) {np.std(y, ddof=1) / np.mean(y):.1%}; as a line "
                f"h_c = β'(R − R0): β' = {pm(lin['slope'], lin['slope_se'])}, R0 = {R0:.2g} r_b (0 when the profiles "
                "collapse); the paper gives no value of h_c/R, only the collapse. p^k is from time-averaged fields "
                "(the spread of the mean flow inside the kernel counts as kinetic pressure; the paper's eq. 7 takes "
                "fluctuations about the instantaneous local mean): not varied here; kernel widths below the node "
                f"spacing ({h:g} r_b) are no variant (they cannot place a peak between nodes)")
    else:
        note = f"fewer than 2 steady orifices with h_c ({len(ok)}): no exponent"
    return Check("h_c ∝ R^β: exponent β", "1 (the axis profiles collapse on z/R)", "§3, Fig. 8",
                 fit["exponent"], fit["exponent_se"], paper_range=(1.0, 1.0), note=note, syst=syst, variants=text)


def collapse_eq7_check(cases: list[SiloCase]) -> Check:
    """Exponent of :math:`h_c \\propto R^\\beta` the paper's way: the kinetic pressure of eq. 7 (fluctuations
    about each frame's local mean) at w = r_b/2 on nodes r_b/4 apart (``h_c_over_R_eq7`` of the analysis);
    systematic error over the fit range and the node resolution."""
    from .pipeline import EQ7_SPACING, EQ7_W

    q = f"h_c ∝ R^β: exponent β (eq. 7, w = r_b/{1 / EQ7_W:g}, nodes r_b/{1 / EQ7_SPACING:g}: the paper's way)"
    paper, source = "1 (the axis profiles collapse on z/R)", "§3, Fig. 8, eq. 7"
    ok = [c for c in cases if c.steady and math.isfinite(c.get("h_c_over_R_eq7"))]
    if len(ok) < 2:
        return Check(q, paper, source, float("nan"), paper_range=(1.0, 1.0),
                     note=f"fewer than 2 steady orifices with the eq.-7 reading ({len(ok)}): no exponent "
                          "(cases analysed before it existed)")
    R = np.array([c.get("R") for c in ok])
    y = np.array([c.get("h_c_over_R_eq7") for c in ok])
    se = np.array([c.get("h_c_over_R_eq7_se") for c in ok])
    fit = sl.scaling_exponent(R, y * R, se * R)
    alt = {}
    inside = np.array([_in_paper_range(c) for c in ok])
    if inside.sum() >= 2:
        f = sl.scaling_exponent(R[inside], (y * R)[inside], (se * R)[inside])
        alt[f"R ≥ {PAPER_R_RANGE[0]:g} r_b only"] = (f["exponent"], f["exponent_se"])
    syst, text = systematic(fit["exponent"], alt, central_se=fit["exponent_se"])
    node = np.array([EQ7_SPACING / 3.0 / math.sqrt(3.0) / c.R_over_rb for c in ok])
    node_se = _slope_error(R, y, node)
    text += ("; " if text else "") + f"node resolution (a third of a node, uniform): ±{node_se:.3g}"
    syst = math.hypot(syst if math.isfinite(syst) else 0.0, node_se)
    per = ", ".join(f"{c.R_over_rb:g}: {pm(c.get('h_c_over_R_eq7'), c.get('h_c_over_R_eq7_se'), '.2f')}" for c in ok)
    avg = ", ".join(f"{c.get('h_c_over_R_fine'):.2f}" for c in ok)
    ratio = ", ".join(f"{c.get('pk_max_fine') / c.get('pk_max_eq7'):.1f}" for c in ok)
    note = (f"weighted fit of ln h_c against ln R over {len(ok)} orifices; h_c/R per R/r_b: {per} (the refined "
            "maximum of p^k on the axis; errors: 8 blocks of frames); the time-averaged form on the same nodes gives "
            f"{avg}, its peak p^k {ratio} times eq. 7's (it counts the mean flow's spread inside the kernel and "
            "the frame-to-frame changes as kinetic pressure)")
    return Check(q, paper, source, fit["exponent"], fit["exponent_se"], paper_range=(1.0, 1.0), note=note,
                 syst=syst, variants=text)


# --------------------------------------------------------------------------- per-case checks
def _not_measured(quantity: str, paper: str, source: str, case: SiloCase, **kw) -> Check:
    return Check(quantity, paper, source, float("nan"), case=case.name, note=case.why_not, **kw)


def surface_rate_check(case: SiloCase) -> Check:
    q, paper, source = "W_r/W_f (surface rate over outflow)", "1 (\"excellent agreement\")", "§3, Fig. 2a"
    if not case.steady:
        return _not_measured(q, paper, source, case, paper_range=(1.0, 1.0))
    W_f_se = case.errors.get("W_f", case.get("W_f_se"))
    r = sl.surface_rate_ratio(case.flow, case.get("W_f"), W_f_se, case.get("t_start"), case.get("t_end"))
    note = (f"W_r = ρ_p φ_bulk π R_c² × fall speed of the highest particle, mean of {r['n']} windows of "
            f"{case.get('window'):g} s in the steady window (error: {r['W_r_se_method']}) = "
            f"{pm(r['W_r'], r['W_r_se'], '.4g')} kg/s; W_f = {pm(case.get('W_f'), W_f_se, '.4g')} kg/s; "
            "φ_bulk measured at half the fill height (the paper: a slab at the top surface)")
    return Check(q, paper, source, r["ratio"], r["ratio_se"], case=case.name, paper_range=(1.0, 1.0), note=note)


def profile_check(case: SiloCase) -> Check:
    q = "orifice profile: rms of v_z(r)/v_z(0) − √(1−(r/R)²), r < 0.9R"
    paper, source = "on the curve √(1−(r/R)²) (no deviation stated)", "Fig. 5b"
    if not case.steady:
        return _not_measured(q, paper, source, case)
    w = case.record["cg"]["w_fields"]
    note = (f"over {case.scalars.get('n_deviation', '?')} nodes of the orifice row (w = {w:g} r_b, "
            f"{w / case.R_over_rb:.0%} of R). Shape, not a number: the rms is ≥ 0 by construction and biased "
            "upwards by the noise and by the kernel's smoothing of the profile's edge, neither of which our "
            "statistical error covers, so a paper range of 0 would only test that bias; read it as 'on average "
            "within this fraction of v_z(0) of the curve'" + (f"; {case.error_note}" if case.error_note else ""))
    return Check(q, paper, source, case.get("sqrt_profile_deviation"), case.errors.get("profile_deviation"),
                 case=case.name, note=note)


def transition_check(case: SiloCase) -> Check:
    q, paper, source = "h_c/R (kinetic-pressure maximum on the axis)", "collapses on z/R (no value stated)", "Fig. 8"
    if not case.steady:
        return _not_measured(q, paper, source, case)
    scan = ", ".join(f"{pm(case.get(k), case.get(k + '_se'), '.2f')} at w = {k.rsplit('_w', 1)[1]} r_b"
                     for k in sorted(case.scalars) if k.startswith("h_c_over_R_w") and not k.endswith("_se"))
    spacing = case.record["cg"]["node_spacing"] / case.R_over_rb
    widths = _resolved_widths(case, {k.rsplit("_w", 1)[1] for k in case.scalars
                                     if k.startswith("h_c_over_R_w") and not k.endswith("_se")})
    alt = {f"kernel w = {wk} r_b": case.get(f"h_c_over_R_w{wk}") for wk in widths}
    syst_w, text = systematic(case.get("h_c_over_R"), alt)
    node = _node_sigma(case)
    syst = math.hypot(syst_w if math.isfinite(syst_w) else 0.0, node)
    text = (text + "; " if text else "") + f"node resolution (a third of a node, uniform): ±{node:.3f}"
    note = ("main fields, w = 2 r_b" + (f"; kernel scan: {scan} (the paper: h_c does not move with w, Fig. 9)"
                                         if scan else "")
            + f"; nodes {spacing:.2f} R apart: a skewed peak's refined position can be off by a third of that; "
            "syst: the largest shift over the kernel widths the nodes resolve (w ≥ the node spacing) and that "
            "third (as a uniform error, /√3) in quadrature"
            + (f"; {case.error_note}" if case.error_note else ""))
    return Check(q, paper, source, case.get("h_c_over_R"), case.errors.get("h_c_over_R"), case=case.name, note=note,
                 syst=syst, variants=text)


def bulk_check(case: SiloCase) -> Check:
    q, paper, source = "φ_bulk", "0.60 ± 0.02", "§3"
    if not case.steady:
        return _not_measured(q, paper, source, case, paper_range=PHI_BULK)
    rec = case.record
    phi, se = sl.bulk_volume_fraction(case.fields, rec["fill_height"], rec["R_c"], rec["r_b"])
    note = ("mean φ over a slab of ±4 r_b at half the fill height, r < R_c − 3 r_b, over the steady window "
            "(the paper: a slab touching the top surface); error: the nodes' (correlation-aware) errors taken as fully "
            "correlated (an upper bound)")
    return Check(q, paper, source, phi, se, case=case.name, paper_range=PHI_BULK, note=note)


def partial_check(case: SiloCase) -> Check:
    q = "(p^k_s/φ_s)_smallest / (p^k_s/φ_s)_largest on the axis at h_c"
    paper = "> 1 (\"the small particles carry a higher fraction of kinetic stress respect to their concentration\")"
    source = "§3, Fig. 12"
    if not case.steady:
        return _not_measured(q, paper, source, case, paper_range=(1.0, math.inf))
    r = sl.partial_ratio(case.fields, case.get("h_c"))
    note = (f"species {r['small']} over {r['large']} at the axis node z = {r['z_node']:.3g} m nearest h_c, main "
            "fields w = 2 r_b (the paper's Figs. 11-12: w = r_b/2); p^k_largest/p^k_smallest = "
            f"{r['pk_large_over_small']:.3g} (the paper, Fig. 11: larger for bigger particles); errors: "
            "coarse-graining errors (correlation-aware)")
    if r["small"] is None or r["small"] == r["large"]:
        note = "fewer than two species with partial kinetic pressures and volume fractions"
    return Check(q, paper, source, r["ratio"], r["ratio_se"], case=case.name, paper_range=(1.0, math.inf), note=note)


def contact_check(case: SiloCase) -> Check:
    q = f"contact pressure on the axis: rank correlation of p^c with z, 0 ≤ z ≤ {CONTACT_SPAN:g}R"
    paper, source = "falls monotonically to zero at the outlet", "§3, Fig. 6"
    if not case.steady:
        return _not_measured(q, paper, source, case)
    if case.contact.empty:
        return Check(q, paper, source, float("nan"), case=case.name, note="no contact-stress table")
    f = sl.contact_fall(case.contact, case.get("R"), CONTACT_SPAN)
    note = (f"Spearman ρ over {f['n']} axis nodes (1: a monotonic fall towards the outlet; w = r_b/2 as the "
            f"paper); p^c(z = 0)/p^c(z = {CONTACT_SPAN:g}R) = {pm(f['ratio'], f['ratio_se'], '.2g')} (0 when it "
            "vanishes at the outlet; the kernel reaches 2 r_b above the orifice plane)")
    return Check(q, paper, source, f["rho_s"], case=case.name, note=note)


# --------------------------------------------------------------------------- profiles
def profiles(cases: list[SiloCase]) -> dict[str, pd.DataFrame]:
    """Small tables behind the kept figures: orifice profiles, the axis pressures, the sweep."""
    orifice, kinetic, partial, contact, sweep, plane = [], [], [], [], [], []
    for c in cases:
        head = {"case": c.name, "R_over_rb": c.R_over_rb}
        W_r = sl.surface_rate_ratio(c.flow, c.get("W_f"), c.get("W_f_se"), c.get("t_start"), c.get("t_end"))
        sweep.append({**head, "status": c.scalars.get("status"), "D": 2 * c.get("R"), "W_f": c.get("W_f"),
                      "W_f_se": c.errors.get("W_f", np.nan), "W_r": W_r["W_r"], "W_r_se": W_r["W_r_se"],
                      "phi_c": c.get("phi_c"), "v_c": c.get("v_c"), "v_c_se": c.get("v_c_se"),
                      "v_c_plane": abs(c.get("v_c_plane")), "v_c_plane_se": c.get("v_c_plane_se"),
                      "v_core_plane": abs(c.get("v_core_plane")), "phi_c_plane": c.get("phi_c_plane"),
                      "W_plane": c.get("W_plane"), "W_plane_se": c.get("W_plane_se"),
                      "h_c_over_R_eq7": c.get("h_c_over_R_eq7"), "h_c_over_R_eq7_se": c.get("h_c_over_R_eq7_se"),
                      "h_c_over_R_fine": c.get("h_c_over_R_fine"),
                      "h_c_over_R": c.get("h_c_over_R"), "h_c_over_R_se": c.errors.get("h_c_over_R", np.nan),
                      "phi_bulk": c.get("phi_bulk")})
        if not c.steady:
            continue
        R = c.get("R")
        o = sl.orifice_profiles(c.fields, R)
        p = o["profile"][o["profile"]["r_over_R"] <= PROFILE_R_MAX]
        orifice.append(pd.DataFrame({**head, "r_over_R": p["r_over_R"], "phi_norm": p["phi_norm"],
                                     "phi_norm_se": p["phi_se"] / o["phi_c"], "vz_norm": p["vz_norm"],
                                     "vz_norm_se": p["u_z_se"] / o["v_c"]}))
        if not c.plane.empty:
            pl = c.plane[c.plane["r_over_R"] <= 1.5]
            plane.append(pd.DataFrame({**head, **{k: pl[k] for k in ("slab_half", "r_over_R", "vz", "vz_se", "phi",
                                                                    "phi_se", "n")}}))
        ax = sl.axis_profile(c.fields, "pk")
        in_window = c.flow[(c.flow["t"] >= c.get("t_start")) & (c.flow["t"] <= c.get("t_end"))] if "z_s" in c.flow else []
        surface = float(in_window["z_s"].min()) / R if len(in_window) else np.nan   # the free surface's lowest
        kinetic.append(pd.DataFrame({**head, "z_over_R": ax["z"] / R, "pk": ax["value"], "pk_se": ax["value_se"],
                                     "z_surface_over_R": surface,
                                     **{f"{f}{e}": sl.axis_profile(c.fields, f)[col].to_numpy()
                                        for f in ("phi", "u_z") for e, col in (("", "value"), ("_se", "value_se"))}}))
        part = {**head, "z": ax["z"], "z_over_R": ax["z"] / R}
        for s in sl.species_ids(c.fields, "pk"):
            pk_s = sl.axis_profile(c.fields, f"pk_s{s}")
            part.update({f"pk_s{s}": pk_s["value"], f"pk_s{s}_se": pk_s["value_se"],
                         f"phi_s{s}": sl.axis_profile(c.fields, f"phi_s{s}")["value"]})
        partial.append(pd.DataFrame(part))
        if not c.contact.empty:
            pc = sl.axis_profile(c.contact, "pc")
            contact.append(pd.DataFrame({**head, "z_over_R": pc["z"] / R, "pc": pc["value"], "pc_se": pc["value_se"]}))
    return {"sweep": pd.DataFrame(sweep), **concat_profiles((("orifice_profiles", orifice), ("orifice_plane", plane), ("kinetic_axis", kinetic), ("partial_kinetic_axis", partial),
                        ("contact_axis", contact)))}


# --------------------------------------------------------------------------- set-up
def law_difference(rec: dict) -> str:
    """The contact law against the paper's eq. 10 per pair: each contact's e_n."""
    es = [c["e_n"] for c in rec.get("contacts", []) if "e_n" in c] or [float("nan")]
    law = rec.get("contact_law", {}).get("law", "hooke/history")
    walls = "granular wall syntax" if "contact_law" in rec else "classic wall/gran hooke/history walls"
    if law == "hooke/pair_eq10":
        return (f"The paper's law (hooke/pair_eq10; {walls}): eq. 10 per pair of the seven sizes, e_n = {min(es):.3g} "
                "for every contact; a wall contact is R_eff = r_i, m_eff = m_i (not stated in the paper).")
    return ("One normal stiffness for every pair (LAMMPS gran/hooke/history; " + walls + ": eq. 10 for two r_b "
            f"spheres, k_n = {rec['k_n']:.4g} N/m); the paper evaluates eq. 10 for each pair's R_eff and m_eff. "
            f"Every contact then has its own restitution: e_n from {min(es):.2f} to {max(es):.2f} (the paper: 0.88).")


def differences(cases: list[SiloCase]) -> list[str]:
    """What differs from the paper's set-up, from the cases' records; one line per case for the overlap."""
    if not cases:
        return []
    rec = cases[0].record
    k = rec["rung_knobs"]
    prm = rec["parameters"]
    r_b = rec["r_b"]
    radii = sorted(s["radius"] / r_b for s in rec["species"])
    n = sorted({int(c.record["n_particles"]) for c in cases})
    t_c = prm["t_c_min"]
    out = [
        f"Silo radius R_c = {k['R_c']:g} r_b filled to {k['fill_height']:g} r_b: {n[0]:,}"
        + (f"-{n[-1]:,}" if n[-1] != n[0] else "") + f" particles, the paper's N = {PAPER_N:,} "
        "(R_c not stated; the scene's paper rung: 50 r_b), which 2 cores cannot run; the discharge "
        f"lasts {k['t_discharge']:g} s without re-insertion, so the steady window ends where the fill runs low.",
        f"Young's modulus softened to Y = {k['Y_factor']:g} × {PAPER_Y / 1e9:g} GPa = {rec['Y'] / 1e9:.3g} GPa: "
        f"shortest contact time t_c = {t_c:.3g} s (the paper's {PAPER_DT / PAPER_DT_FRACTION:.3g} s), so the run "
        "needs far fewer steps; stiffness scales as Y^(4/5) through eq. 10.",
        f"Time step dt = t_c/{1 / k['dt_fraction']:.0f} = {rec['dt']:.3g} s (the paper: t_c/50 = {PAPER_DT:.2g} s).",
        law_difference(rec),
        f"Seven radii from {radii[0]:.4g} to {radii[-1]:g} r_b in equal steps of {np.diff(radii).mean():.4g} r_b, "
        "equal numbers; the paper's text gives r_s = r_b/2 + r_b/16 and a step of r_b/16, which would make 8 sizes.",
        "φ_bulk is measured in a slab at half the fill height, the paper's in a slab touching the top surface; the "
        "partial kinetic pressures are compared at w = 2 r_b (the paper's Figs. 10-12: w = r_b/2).",
    ]
    for c in cases:
        ov = finite(c.status.get("max_overlap"))
        if math.isfinite(ov):
            verdict = "within" if ov <= OVERLAP_LIMIT else f"{ov / OVERLAP_LIMIT:.1f}× over"
            out.append(f"{c.name}: largest overlap {ov:.2%} of the smallest diameter ({verdict} the 1 % limit).")
        else:
            out.append(f"{c.name}: largest overlap not recorded (run status {c.status.get('status')}).")
    return out


# --------------------------------------------------------------------------- the record
def validation(scene_dir: Path, cases: dict[str, Path]) -> ValidationResult:
    """The silo's checks against Rubio-Largo et al. (2016), its profiles, figures and set-up differences.

    Parameters
    ----------
    scene_dir : Path
        ``results/silo/<rung>``, holding ``table.csv`` (with the Beverloo fit) and ``figures/``.
    cases : dict of str to Path
        Case directory name (e.g. ``R~6``) to its analysed case directory.
    """
    loaded = sorted((load_case(name, path) for name, path in cases.items()),
                    key=lambda c: (np.nan_to_num(c.R_over_rb, nan=np.inf), c.name))
    table = read_table(Path(scene_dir) / "table.csv")
    checks = (beverloo_checks(table) + velocity_exponent_checks(loaded)
              + [flow_scale_check(loaded), collapse_eq7_check(loaded), collapse_check(loaded)])
    for make in (surface_rate_check, steady_rate_check, profile_check, transition_check, bulk_check, partial_check, contact_check):
        checks += [make(c) for c in loaded]
    kept = profiles(loaded)
    # the checks made from the profiles the record keeps, by the code that judges a committed record again
    r_b = loaded[0].record["r_b"] if loaded else float("nan")
    checks += profile_checks(kept, [s["radius"] / r_b for s in loaded[0].record["species"]] if loaded else None)
    return ValidationResult(checks=checks, profiles=kept, figures=list(FIGURES), differences=differences(loaded))
