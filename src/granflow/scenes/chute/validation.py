"""The chute's validation record: its numbers against Silbert et al. (2001), Phys. Rev. E 64, 051302.

The paper's text is not held; its facts are those of SPEC.md ("Scene 4: chute"). :func:`validation`
builds the scene's :class:`~granflow.validation.ValidationResult` from what each case's analysis
wrote (``analysis/scalars.json``, ``analysis/profile.csv``, ``run/status.json``) and the errors of
the time averages (:func:`granflow.headline.measure_with_errors`, which re-reads the dumps of the
averaging window in blocks). Per steady case it compares

* the bulk stress ratio :math:`-\\sigma_{xz}/\\sigma_{zz}` with :math:`\\tan\\theta` (exact in steady
  uniform flow), as the ratio over :math:`\\tan\\theta`;
* :math:`\\sigma_{zz}` with the weight of the material above, :math:`g\\cos\\theta\\int_z^h\\rho\\,dz'` (exact);
* the Bagnold profile :math:`u \\propto h^{3/2} - (h - z)^{3/2}` in the bulk (a shape: R² and the relative
  rms residual, no paper number);
* how far the profile departs from the bulk's Bagnold fit within the bulk margin of base and surface, over
  its scatter in the bulk (the paper: it departs there);
* the bulk volume fraction (nearly uniform in the bulk) and, over the sweep, whether it is lower at the
  larger angle;
* over the sweep's angles, where the regimes change: θ_stop between the largest arrested and the smallest
  flowing angle (≈ 20°), the top of steady flow between the largest steady and the smallest accelerating
  angle (≈ 24-26°);

and says for every angle whether its regime (arrested, steady, accelerating) is the paper's.
A case that was not averaged in a steady state gets NaN and the reason in each note.
Units: :math:`d`, :math:`m`, :math:`\\sqrt{d/g}`.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from granflow.registry import finite
from granflow.validation import (Check, ValidationResult, error_note, read_case, sci, systematic,
                                 time_average_errors)

from .analysis import bulk_mask

NAN = float("nan")
SOURCE = "Silbert 2001 (per SPEC.md)"
#: the paper's contact model and time step (SPEC.md): k_n in m g/d, gamma_n in sqrt(g/d), dt in sqrt(d/g)
PAPER_K_N, PAPER_GAMMA_N, PAPER_DT = 2.0e5, 50.0, 1.0e-4
#: the paper's pair contact time, pi / sqrt(k_n/m_eff - gamma_n^2/4) with m_eff = m/2 (LAMMPS gran/hooke damping)
PAPER_T_C = math.pi / math.sqrt(PAPER_K_N / 0.5 - PAPER_GAMMA_N**2 / 4.0)
#: the regimes (SPEC.md): the bed stops below theta_stop (~20 deg for H ~ 20-40 d), flows steadily up to ~24-26 deg
THETA_STOP, STEADY_TOP = 20.0, (24.0, 26.0)
#: largest contact overlap, fraction of the diameter, above which the record says so
OVERLAP_LIMIT = 0.01
Q_BAGNOLD_BASE = "Bagnold fit near the base: rms residual over the bulk's"
Q_BAGNOLD_SURFACE = "Bagnold fit near the surface: rms residual over the bulk's"
Q_STOP = "θ_stop: midway between the largest arrested and the smallest flowing angle"
Q_STEADY_TOP = "top of steady flow: midway between the largest steady and the smallest accelerating angle"
#: the paper's "≈ 20°" for θ_stop read as 20 ± 1 (SPEC.md gives no error)
THETA_STOP_ERROR = 1.0
#: the figures of the rung kept in the record (names of ChuteScene.figures)
FIGURES = ["fig_profiles", "fig_stress", "fig_regimes"]


# ------------------------------------------------------------------------- one case
@dataclass
class ChuteCase:
    """What the record reads of one finished case.

    ``why_not`` is empty for a case averaged in a steady state, else why it has no numbers;
    ``profile`` is ``analysis/profile.csv`` (None without one).
    """

    name: str
    path: Path
    record: dict
    status: dict
    scalars: dict
    why_not: str
    profile: pd.DataFrame | None = None

    @property
    def theta(self) -> float:
        return float(self.record["parameters"]["theta_deg"])

    def value(self, key: str) -> float:
        return finite(self.scalars.get(key))

    def bulk(self) -> np.ndarray:
        """The analysis' bulk bins of the profile (``bulk_margin`` from base and surface)."""
        return bulk_mask(self.profile, self.value("z_base"), self.value("z_surface"),
                         float(self.record["rung_knobs"]["bulk_margin"]))


def load_case(name: str, path: Path) -> ChuteCase:
    """Read a case's record, status, scalars and profile; say why it cannot be compared, if so."""
    path = Path(path)
    record, status, scalars, why_not = read_case(path)
    profile = None
    profile_path = path / "analysis" / "profile.csv"
    if not why_not and profile_path.exists():
        profile = pd.read_csv(profile_path)
        if profile.empty:
            profile = None
    if not why_not and profile is None:
        why_not = "not measured: no analysis/profile.csv"
    return ChuteCase(name, path, record, status, scalars, why_not, profile)






# ------------------------------------------------------------------------- measures on the profile
def weight_deviation(case: ChuteCase) -> tuple[float, float, int]:
    """Mean over the bulk bins of :math:`(\\sigma_{zz} - W)/W`, :math:`W` the weight above (the
    analysis' ``weight_above``), its error and the number of bins.

    The error is the mean of the bins' :math:`\\mathrm{se}(\\sigma_{zz})/W` (the profile's correlation-aware
    errors, bins taken as fully correlated: an upper bound).
    """
    p, bulk = case.profile, case.bulk()
    szz, weight = p["sigma_zz"].to_numpy(float)[bulk], p["weight_above"].to_numpy(float)[bulk]
    ok = np.isfinite(szz) & (weight > 0)
    if not ok.any():
        return NAN, NAN, 0
    se = p["sigma_zz_se"].to_numpy(float)[bulk][ok] / weight[ok] if "sigma_zz_se" in p else np.full(ok.sum(), NAN)
    return float(np.mean((szz[ok] - weight[ok]) / weight[ok])), float(np.mean(se)), int(ok.sum())


def bulk_phi_spread(case: ChuteCase) -> dict:
    """Standard deviation, minimum and maximum of :math:`\\phi` over the bulk bins."""
    phi = case.profile["phi"].to_numpy(float)[case.bulk()]
    phi = phi[np.isfinite(phi)]
    if len(phi) < 2:
        return {"std": NAN, "min": NAN, "max": NAN, "n": int(len(phi))}
    return {"std": float(np.std(phi, ddof=1)), "min": float(phi.min()), "max": float(phi.max()), "n": int(len(phi))}


def bagnold_departure(case: ChuteCase, where: str, width: float | None = None) -> dict:
    """rms of :math:`u_x - u_{Bagnold}` (the bulk fit, extrapolated) over the bins within ``width`` (default: the
    bulk margin) of the base (``where="base"``) or of the surface, over the same rms in the bulk: ``ratio``, its
    error (each rms's from the bins' correlation-aware errors, first order), ``n`` bins near the edge."""
    p = case.profile
    if "u_bagnold" not in p:
        return {"ratio": NAN, "se": NAN, "n": 0}
    z, r = p["z"].to_numpy(float), (p["u_x"] - p["u_bagnold"]).to_numpy(float)
    se = p["u_x_se"].to_numpy(float) if "u_x_se" in p else np.full(len(z), NAN)
    z0, zs = case.value("z_base"), case.value("z_surface")
    w = float(case.record["rung_knobs"]["bulk_margin"]) if width is None else width
    near = (z >= z0) & (z < z0 + w) if where == "base" else (z > zs - w) & (z <= zs)

    def rms(mask):
        mask = mask & np.isfinite(r)
        if not mask.any():
            return NAN, NAN
        value = float(np.sqrt(np.mean(r[mask] ** 2)))
        return value, float(np.sqrt(np.nansum((r[mask] * se[mask]) ** 2)) / (mask.sum() * value)) if value else NAN

    (edge, edge_se), (bulk, bulk_se) = rms(near), rms(case.bulk())
    ratio = edge / bulk if bulk else NAN
    return {"ratio": ratio, "se": ratio * math.hypot(edge_se / edge, bulk_se / bulk) if edge and bulk else NAN,
            "n": int(near.sum()), "edge": edge, "bulk": bulk}


# ------------------------------------------------------------------------- the checks
def case_checks(case: ChuteCase, errors: dict) -> list[Check]:
    """The per-case checks (NaN, with the reason in the note, for a case without a steady average)."""
    name, steady = case.name, not case.why_not
    why = case.why_not or errors.get("why", "")

    def se_of(key: str) -> tuple[float, str]:
        entry = errors.get(key) if steady else None
        return (entry["se"] if entry else NAN), (error_note(entry, why) if steady else why)

    tan = math.tan(math.radians(case.theta))
    bulk_text = (f"bulk: {int(case.value('n_bulk_bins'))} bins with centres z = {case.value('bulk_lo'):.3g}-"
                 f"{case.value('bulk_hi'):.3g} d ({case.record['rung_knobs']['bulk_margin']:g} d from the base top "
                 f"z0 = {case.value('z_base'):g} and from the surface, where φ = φ_bulk/2)" if steady else "")
    checks = []

    ratio = case.value("stress_ratio") / tan if steady else NAN
    se, enote = se_of("stress_ratio_over_tan")
    note = (f"mean of -σ_xz/σ_zz (total stress: contact + kinetic) over the {bulk_text}: "
            f"{case.value('stress_ratio'):.4f} against tan θ = {tan:.4f}; the analysis' own error (bins' "
            f"errors or their scatter, the larger) {case.value('stress_ratio_se') / tan:.2g}; {enote}"
            if steady else why)
    checks.append(Check("bulk -σ_xz/σ_zz / tan θ", "1 (exact in steady uniform flow)",
                        f"{SOURCE}: momentum balance", ratio, se, name, (1.0, 1.0), note=note))
    checks += acceleration_checks(case, ratio, se, tan, why)

    if steady:
        dev, dev_se, n = weight_deviation(case)
        note = (f"mean over the {bulk_text} of (σ_zz - W)/W, W = g cos θ ∫_z ρ dz' (the analysis' weight_above); "
                f"rms of the same over the bulk (the analysis' weight_residual) {case.value('weight_residual'):.2%}; "
                f"error: the mean of the bins' correlation-aware errors of σ_zz over W (bins taken as "
                f"fully correlated, an upper bound)")
    else:
        dev, dev_se, note = NAN, NAN, why
    checks.append(Check("σ_zz / weight above - 1 (bulk mean)", "0 (exact in steady uniform flow)",
                        f"{SOURCE}: momentum balance", dev, dev_se, name, (0.0, 0.0), note=note))

    if steady:
        se_A, enote = se_of("bagnold_A")
        note = (f"fit of u_x = A[h^(3/2) - (h - z)^(3/2)] over the {bulk_text}, "
                f"h = {case.value('bagnold_H'):.3g} d the "
                f"surface height above z0: relative rms residual {case.value('bagnold_rel_rms'):.2%}, A = "
                f"{case.value('bagnold_A'):.4g} ± {se_A:.2g} √(g/d)/d^(3/2) ({enote}). The paper gives the shape (with "
                f"deviations within a few d of base and surface), not a goodness of fit: no number is compared; "
                f"R² has no statistical error")
    else:
        note = why
    checks.append(Check("Bagnold profile: R² of the bulk fit",
                        "u ∝ h^(3/2) - (h - z)^(3/2) in the bulk",
                        f"{SOURCE}: Bagnold velocity profile", case.value("bagnold_r2") if steady else NAN, NAN,
                        name, None, note=note))

    margin = float(case.record["rung_knobs"]["bulk_margin"])
    for q, where, words in ((Q_BAGNOLD_BASE, "base", "above the base"), (Q_BAGNOLD_SURFACE, "surface", "below the surface")):
        if steady:
            d = bagnold_departure(case, where)
            narrow = bagnold_departure(case, where, margin - 1.0)["ratio"]
            syst, variants = systematic(d["ratio"], {f"the {margin - 1:g} d {words}": narrow})
            note = (f"rms of u_x − the bulk's Bagnold fit over the {d['n']} bins within {margin:g} d {words} "
                    f"({d['edge']:.3g} √(gd)) over its rms in the bulk ({d['bulk']:.3g}); > 1: the profile departs "
                    f"from Bagnold's there beyond its scatter in the bulk. Error: each rms's, first order, from the "
                    f"bins' correlation-aware errors")
        else:
            d, syst, variants, note = {"ratio": NAN, "se": NAN}, NAN, "", why
        checks.append(Check(q, "> 1: the profile departs from Bagnold's within a few d of base and surface",
                            f"{SOURCE}: Bagnold velocity profile", d["ratio"], d["se"], name, (1.0, math.inf),
                            syst=syst, variants=variants, note=note))

    se, enote = se_of("phi_bulk")
    if steady:
        spread = bulk_phi_spread(case)
        note = (f"mean φ over the {bulk_text}; the bins' φ spread by {spread['std']:.3f} (std, "
                f"{spread['std'] / case.value('phi_bulk'):.1%} of the mean), from {spread['min']:.3f} to "
                f"{spread['max']:.3f}; {enote}")
    else:
        note = why
    checks.append(Check("bulk φ", "nearly uniform in the bulk", f"{SOURCE}: packing profile",
                        case.value("phi_bulk") if steady else NAN, se, name, None, note=note))
    return checks


def acceleration_checks(case: ChuteCase, ratio: float, se: float, tan: float, why: str) -> list[Check]:
    r"""The momentum balance with the bed's acceleration over the window, and that acceleration.

    A bed still creeping at :math:`a` (:func:`postproc.series.window_acceleration`,
    in g) balances :math:`-\sigma_{xz}/\sigma_{zz} = \tan\theta - a/\cos\theta`: the comparison
    is the stress ratio over that, its error the ratio's and the acceleration's in quadrature. The
    acceleration over :math:`g\sin\theta` (how much it lowers the plain ratio over tan θ) is a diagnostic.
    """
    steady = not case.why_not
    a, a_se = case.value("accel_cm"), case.value("accel_cm_se")
    cos = math.cos(math.radians(case.theta))
    if steady and math.isfinite(a) and math.isfinite(ratio):
        expected = tan - a / cos
        ours = ratio * tan / expected
        err = ours * math.hypot(se / ratio if math.isfinite(se) else 0.0, (a_se / cos) / expected)
        note = (f"the ratio over tan θ ({ratio:.4f}) times tan θ / (tan θ − a/cos θ): a = {a:.3g} ± {a_se:.2g} g, "
                f"the slope of u_cm over the averaging window ({int(case.value('accel_rows'))} thermo rows, mean "
                f"u_cm {case.value('u_cm_window'):.4g} √(gd); error scaled by the residuals' statistical "
                f"inefficiency); the layers above any height carry their weight's share g sin θ − a of the shear, "
                f"a taken uniform (the bed's mean)")
        frac = a / math.sin(math.radians(case.theta))
        a_note = (f"a/(g sin θ) = {frac:+.2%}: the plain ratio over tan θ is lower than the balance by this much; "
                  f"the steadiness test passed on u_cm's drift per window, this is what remains of it over the "
                  f"averaging window")
        frac_se = a_se / math.sin(math.radians(case.theta))
    else:
        ours = err = frac = frac_se = NAN
        note = a_note = why or "no acceleration: no averaging stage in thermo.csv"
    return [Check("bulk -σ_xz/σ_zz / (tan θ − a/(g cos θ)), a the bed's acceleration",
                  "1 (exact in uniform flow: the momentum balance)", f"{SOURCE}: momentum balance", ours, err,
                  case.name, (1.0, 1.0), note=note),
            Check("u_cm acceleration over the averaging window / (g sin θ)", "0 (steady)",
                  f"{SOURCE}: steady flow", frac, frac_se, case.name, (0.0, 0.0), note=a_note)]


def sweep_checks(loaded: list[ChuteCase], errors: dict[str, dict]) -> list[Check]:
    """Bulk φ at the largest minus the smallest steady angle (paper: lower at larger θ)."""
    steady = sorted((c for c in loaded if not c.why_not and math.isfinite(c.value("phi_bulk"))), key=lambda c: c.theta)
    paper, source = "lower at larger θ", f"{SOURCE}: packing profile"
    if len(steady) < 2 or steady[0].theta == steady[-1].theta:
        return [Check("bulk φ(θ_max) - φ(θ_min)", paper, source, NAN, NAN, "sweep", None,
                      note=f"needs two steady angles; steady: {', '.join(c.name for c in steady) or 'none'}")]
    lo, hi = steady[0], steady[-1]
    se_lo = (errors[lo.name].get("phi_bulk") or {}).get("se", NAN)
    se_hi = (errors[hi.name].get("phi_bulk") or {}).get("se", NAN)
    diff, se = hi.value("phi_bulk") - lo.value("phi_bulk"), math.hypot(se_lo, se_hi)
    if diff < 0:
        words = "ours is lower at the larger angle, as the paper"
    else:
        words = "ours is not lower at the larger angle, unlike the paper"
    sig = f" ({abs(diff) / se:.1f} σ)" if math.isfinite(se) and se > 0 else ""
    note = (f"φ_bulk = {lo.value('phi_bulk'):.4f} ± {se_lo:.2g} at {lo.theta:g}°, {hi.value('phi_bulk'):.4f} ± "
            f"{se_hi:.2g} at {hi.theta:g}°: {words}{sig}; error: the two autocorrelation-aware errors combined")
    return [Check("bulk φ(θ_max) - φ(θ_min)", paper, source, diff, se, "sweep", None, note=note)]


def bracket(low: list[float], high: list[float]) -> tuple[float, float, str]:
    """Midway between the largest angle of ``low`` and the smallest of ``high`` (when it lies above), with the
    standard deviation of a uniform spread over that gap, and the gap in words; NaN without both."""
    if not low or not high or max(low) >= min(high):
        return NAN, NAN, ""
    a, b = max(low), min(high)
    return 0.5 * (a + b), (b - a) / (2.0 * math.sqrt(3.0)), f"between {a:g}° and {b:g}°"


def regime_checks(loaded: list[ChuteCase]) -> list[Check]:
    """Where the regimes change across the sweep's angles (the runs' statuses): θ_stop between the largest
    arrested and the smallest flowing angle (paper ≈ 20° for H ≈ 20-40 d), the top of steady flow between the
    largest steady and the smallest accelerating angle (paper ≈ 24-26°)."""
    by = {s: sorted(c.theta for c in loaded if c.status.get("status") == s) for s in ("arrested", "steady", "accelerating")}
    flowing = sorted(by["steady"] + by["accelerating"])
    has = ", ".join(f"{s} at {', '.join(f'{t:g}°' for t in v)}" for s, v in by.items() if v) or "no judged angle"
    out = []
    for q, low, high, paper, rng, err, need in (
            (Q_STOP, by["arrested"], flowing, "≈ 20° for H ≈ 20-40 d (read as 20 ± 1°)", (THETA_STOP, THETA_STOP),
             THETA_STOP_ERROR, "an arrested angle below a flowing one"),
            (Q_STEADY_TOP, by["steady"], by["accelerating"], "≈ 24-26°: steady up to it, accelerating above",
             STEADY_TOP, 0.0, "a steady angle below an accelerating one")):
        mid, spread, gap = bracket(low, high)
        note = (f"the runs' regimes (status of each case: {has}): the change lies {gap}; ours is the middle. The "
                f"sweep's spacing is the resolution: a uniform spread over the gap (gap/√12) is the systematic "
                f"error (each seed brackets alike, so replicates do not narrow it). H = 30 d nominal" if gap else
                f"needs {need}; the sweep has {has}")
        variants = f"the change anywhere {gap}" if gap else ""
        out.append(Check(q, paper, f"{SOURCE}: regimes", mid, NAN, "sweep", rng, paper_error=err, unit="deg",
                         syst=spread, variants=variants, note=note))
    return out


# ------------------------------------------------------------------------- profiles
def height_profile(case: ChuteCase) -> pd.DataFrame:
    """Height profile of one case: :math:`u_x`, :math:`\\phi`, the stress ratio and the weight check."""
    p = case.profile
    cols = ["z", "phi", "phi_se", "u_x", "u_x_se", "u_bagnold", "stress_ratio", "sigma_xz", "sigma_xz_se",
            "sigma_zz", "sigma_zz_se", "weight_above"]
    out = p[[c for c in cols if c in p]].copy()
    out.insert(0, "case", case.name)
    out.insert(1, "theta", case.theta)
    out.insert(3, "z_above_base", p["z"] - case.value("z_base"))
    out.insert(4, "in_bulk", case.bulk())
    out["tan_theta"] = math.tan(math.radians(case.theta))
    return out


# ------------------------------------------------------------------------- set-up differences


def expected_regime(theta: float) -> str:
    """The paper's regime at ``theta`` for H ~ 20-40 d (SPEC.md)."""
    if theta < THETA_STOP:
        return "arrested"
    if theta <= STEADY_TOP[0]:
        return "steady"
    if theta <= STEADY_TOP[1]:
        return "steady or accelerating"
    return "accelerating"


def regime_line(case: ChuteCase) -> str:
    """The regime of one angle against the paper's."""
    status, expected = case.status.get("status"), expected_regime(case.theta)
    if status in ("unstable", "no_steady_state") or status is None:
        verdict = "regime not judged"
    elif status in expected.split(" or "):
        verdict = "as the paper"
    else:
        verdict = "differs from the paper"
    return (f"{case.name}: regime {status} ({case.status.get('reason')}); paper at θ = {case.theta:g}°: {expected} "
            f"(stops below θ_stop ≈ {THETA_STOP:g}° for H ≈ 20-40 d, higher for thinner beds; steady up to ≈ "
            f"{STEADY_TOP[0]:g}-{STEADY_TOP[1]:g}°; accelerates above): {verdict}")


def overlap_line(case: ChuteCase) -> str:
    """The case's largest overlap against :data:`OVERLAP_LIMIT`, and what it means."""
    ov = case.status.get("max_overlap")
    if not isinstance(ov, (int, float)):
        return f"{case.name}: largest overlap not recorded"
    line = f"{case.name}: largest overlap {100 * ov:.4g} % of the diameter"
    if ov <= OVERLAP_LIMIT:
        return line + f" (within the {100 * OVERLAP_LIMIT:g} % limit)"
    k_n = float(case.record["rung_knobs"]["k_n"])
    if math.isclose(k_n, PAPER_K_N):
        why = ("at the paper's k_n = 2e5 the overlap is set by the load (the weight above a contact), so the paper's "
               "beds overlap alike at equal depth and more in its deeper ones")
    else:
        why = (f"k_n = {sci(k_n)} is {PAPER_K_N / k_n:.3g}x softer than the paper's 2e5, so contacts overlap that "
               f"much more than the paper's at equal depth")
    return line + f", above the {100 * OVERLAP_LIMIT:g} % limit: {why}"


def differences(loaded: list[ChuteCase]) -> list[str]:
    """What differs from the paper's set-up (from each case's parameter record), and why."""
    if not loaded:
        return []
    first = loaded[0]
    k, p, proto = first.record["rung_knobs"], first.record["parameters"], first.record["protocol"]
    dt, t_c = float(first.record["dt"]), float(p["t_c_min"])
    out = [
        f"box: {k['Lx']:g} x {k['Ly']:g} d periodic, bed H = {k['H']:g} d nominal, {p['n_particles']} particles "
        f"(paper: 20 x 10 d lateral, as config/scenes/chute.yaml's rung paper records, H = 10-100 d): the smaller "
        f"box affords the rung {first.record['rung']!r}; a narrower periodic cell fluctuates more",
        f"contacts: k_n = {sci(k['k_n'])} m g/d (paper {sci(PAPER_K_N)}), "
        f"γ_n = {p['xi_n']:.3g}, γ_t = {p['xi_t']:.3g}, "
        f"μ = {p['friction']:g} (paper: 50, 0, 0.5); dt = {dt:.3g} √(d/g) = t_c/{t_c / dt:.1f} (paper: "
        f"{sci(PAPER_DT)} = t_c/{PAPER_T_C / PAPER_DT:.1f} at its k_n): a longer step to afford the rung "
        f"(its choice is argued in config/scenes/chute.yaml)",
        f"rough base: the settled particles with centres below {p['base_height']:g} d frozen (paper: a layer taken "
        f"from a random packing)",
        f"averaging over {k['t_average']:g} √(d/g) once u_cm was steady by our criterion (drift < "
        f"{proto['steady_rel_tol']:.0%}, fluctuation < {proto['steady_fluct_tol']:.0%} over "
        f"{proto['steady_window']:g} √(d/g); flow at most {k['t_flow_max']:g})",
    ]
    for c in sorted(loaded, key=lambda c: c.theta):
        out.append(regime_line(c))
        out.append(overlap_line(c))
    return out


# ------------------------------------------------------------------------- the record
def validation(scene_dir: Path, cases: dict[str, Path]) -> ValidationResult:
    """The chute's checks, profiles, figures and set-up differences for the cases of a rung.

    Parameters
    ----------
    scene_dir : Path
        ``results/chute/<rung>`` (its ``figures/`` hold the rung's figures).
    cases : dict of str to Path
        Case directory name (``theta~22``) to its analysed directory.
    """
    loaded = sorted((load_case(name, path) for name, path in cases.items()), key=lambda c: c.theta)
    errors = {c.name: time_average_errors("chute", c.path, c.record, c.why_not) for c in loaded}
    checks = [check for c in loaded for check in case_checks(c, errors[c.name])]
    checks += sweep_checks(loaded, errors) + regime_checks(loaded)
    heights = [height_profile(c) for c in loaded if not c.why_not]
    profiles = {"height_profiles": pd.concat(heights, ignore_index=True)} if heights else {}
    return ValidationResult(checks=checks, profiles=profiles, figures=list(FIGURES),
                            differences=differences(loaded))
