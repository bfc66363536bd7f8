"""The channel's validation record: its numbers against Debnath, Kesava Rao & Kumaran (2022).

:func:`validation` builds the scene's :class:`~granflow.validation.ValidationResult` from the
finished cases of a rung: what each case's analysis wrote (``analysis/scalars.json``,
``analysis/profile.csv``, ``run/thermo.csv``, ``run/status.json``) and the errors of the time
averages (:func:`granflow.headline.measure_with_errors`, which re-reads the dumps of the
averaging window in blocks). Per steady case it compares

* :math:`u_{max}/u_{slip}` with the paper's 1.37-1.40 (section 3.1, figure 5c);
* the exponent :math:`a` of :math:`(u-u_{slip})/(u_{max}-u_{slip}) = 1 - e^{-a x/\\delta_{0.95}}`
  with eq. (3.1)'s 3;
* :math:`\\delta_{0.95}/W` (the paper gives it only in figure 5d: no number is compared);
* :math:`\\phi` in the plug with the paper's 0.63 (section 3.2);
* :math:`\\mu(I)` with eq. (B3) in the dense shearing zone and :math:`\\phi(I)` with eq. (B4) in
  the loose shearing zone (the paper finds B3 off in shape, B4 good in the loose zone);
* the momentum balance: the wall shear force of both walls over the weight, exactly 1.

and, from :mod:`.more_checks` and :mod:`.kinetic_checks`, the paper's other results one W and two φ̄ can
test (eqs. B1-B2, Ω/ω, (du/dx)/√T, ln φ's shape, u_cm's fluctuation, l_c, the trends with φ̄ across the
cases, and fig. 13's collapse and divergence of the loose zone's p_φ and μ_φ), and from :mod:`.width_checks`
what two widths at one φ̄ can test (the speeds' rise with W, l_s ∝ W, σ_xx ∝ W, μ_wall and δ0.95/W against W).

A case that was not averaged in a steady state gets NaN and the reason in each note.
Units: :math:`d_p`, :math:`\\sqrt{d_p/g}`, :math:`\\rho_p = 1` (as the analysis writes them).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from granflow.registry import finite
from granflow.validation import (Check, ValidationResult, error_note, read_case, sci, systematic,
                                 time_average_errors)
from postproc.autocorr import mean_error

from .analysis import JOP2015, ChannelAnalysis, analyse_profile, plug_phi
from .collapse_checks import scaled_profile_checks
from .measurement import central_errors, headline_variants
from .kinetic_checks import kinetic_checks
from .more_checks import more_checks
from .width_checks import width_checks
from .zone_checks import zone_checks

NAN = float("nan")
#: the paper's u_max/u_slip, section 3.1 and figure 5(c) ("1.37-1.40 for all W and phi-bar")
U_RATIO = (1.37, 1.40)
#: the exponent of eq. (3.1)
EXPONENT = 3.0
#: volume fraction in the plug, section 3.2 and conclusion (v)
PLUG_PHI = 0.63
#: the paper's set-up (section 2, Appendix A)
PAPER_B, PAPER_H = 40.0, "60 d_p + ΔH"
PAPER_K_N, PAPER_DT, PAPER_T_AVERAGE, PAPER_T_STEADY = 1.0e6, 1.2e-4, 600.0, 2.0e3
#: largest contact overlap, fraction of the smallest diameter, above which the record says so
OVERLAP_LIMIT = 0.01
#: the figures of the rung kept in the record (names of ChannelScene.figures)
FIGURES = ["fig04_velocity", "fig05c_ratio", "fig11_rheology", "fig_steadiness_plug"]
#: analysis scalar -> headline key of :meth:`ChannelScene.observables` (the one with a time-average error)
HEADLINE_OF = {"ratio": "u_ratio", "fit_exponent": "eq31_exponent", "delta_095_over_W": "delta_over_W"}


# ------------------------------------------------------------------------- one case
@dataclass
class ChannelCase:
    """What the record reads of one finished case.

    ``why_not`` is empty for a case averaged in a steady state, else why it has no numbers;
    ``analysis`` is the channel analysis of ``analysis/profile.csv`` (None without one).
    """

    name: str
    path: Path
    record: dict
    status: dict
    scalars: dict
    why_not: str
    analysis: ChannelAnalysis | None = None
    #: the headlines measured other ways (:func:`.measurement.headline_variants`), once the record reads them
    variants: dict = field(default_factory=dict)


def load_case(name: str, path: Path) -> ChannelCase:
    """Read a case's record, status, scalars and profile; say why it cannot be compared, if so."""
    path = Path(path)
    record, status, scalars, why_not = read_case(path)
    analysis = None
    profile_path = path / "analysis" / "profile.csv"
    if not why_not and profile_path.exists():
        profile = pd.read_csv(profile_path)
        if len(profile) >= 2:
            analysis = analyse_profile(profile, float(record["parameters"]["W"]))
    return ChannelCase(name, path, record, status, scalars, why_not, analysis)






def _value(case: ChannelCase, key: str) -> float:
    return finite(case.scalars.get(key))




def _bins(n: int) -> str:
    return f"{n} bin" if n == 1 else f"{n} bins"


# ------------------------------------------------------------------------- rheology
def rheology_points(a: ChannelAnalysis) -> pd.DataFrame:
    """Per folded bin: distance from the wall, zone, :math:`I`, :math:`\\mu`, :math:`\\phi` and eqs. B3/B4.

    ``mu = |sigma_xy|/sigma_xx`` and ``I = d_p |du/dx| / sqrt(sigma_xx/rho_p)`` as
    :func:`granflow.scenes.channel.analysis.rheology` computes them; ``zone`` from
    :func:`~granflow.scenes.channel.analysis.flow_zones` (wall, loose, dense, plug).
    """
    r, f = a.rheo, a.folded
    return pd.DataFrame({
        "x": f["x"].to_numpy(float), "zone": a.zones.labels, "I": r["I"], "I_se": r["I_se"],
        "mu": r["mu"], "mu_se": r["mu_se"], "mu_B3": r["mu_B3"],
        "phi": f["phi"].to_numpy(float), "phi_se": f["phi_se"].to_numpy(float) if "phi_se" in f else NAN,
        "phi_B4": r["phi_B4"],
    })


def b3_deviation(points: pd.DataFrame, zone: str = "dense") -> dict:
    """Relative deviation of :math:`\\mu` from eq. (B3) over the bins of ``zone`` with :math:`I > 0`.

    .. math:: r_k = \\frac{\\mu_k - \\mu_{B3}(I_k)}{\\mu_{B3}(I_k)}, \\qquad
        \\mathrm{rms} = \\sqrt{\\langle r_k^2 \\rangle}

    Returns ``rms``, ``mean`` (signed), ``n`` and the range ``I_min``, ``I_max`` (NaN without bins).
    """
    p = points[(points["zone"] == zone) & np.isfinite(points["mu"]) & (points["I"] > 0)]
    rel = ((p["mu"] - p["mu_B3"]) / p["mu_B3"]).to_numpy(float)
    return _summary(rel, p["I"].to_numpy(float))


def b4_deviation(points: pd.DataFrame, zone: str = "loose") -> dict:
    """Deviation of :math:`\\phi` from eq. (B4), :math:`\\phi_k - \\phi_{B4}(I_k)`, over the bins of ``zone``.

    Returns ``rms``, ``mean`` (signed), ``n`` and ``I_min``, ``I_max`` as :func:`b3_deviation`.
    """
    p = points[(points["zone"] == zone) & np.isfinite(points["phi"]) & (points["I"] > 0)]
    return _summary((p["phi"] - p["phi_B4"]).to_numpy(float), p["I"].to_numpy(float))


def _summary(dev: np.ndarray, I: np.ndarray) -> dict:
    if len(dev) == 0:
        return {"rms": NAN, "mean": NAN, "n": 0, "I_min": NAN, "I_max": NAN}
    return {"rms": float(np.sqrt(np.mean(dev**2))), "mean": float(np.mean(dev)), "n": int(len(dev)),
            "I_min": float(np.min(I)), "I_max": float(np.max(I))}


# ------------------------------------------------------------------------- momentum balance
def wall_force_ratio(case: ChannelCase) -> tuple[float, float, str]:
    """Mean wall force over the weight in the averaging window, its error and a note.

    Ours is the analysis' ``1 + momentum_steady_residual`` (:func:`~granflow.scenes.channel.pipeline.momentum_balance`:
    the time-averaged force of both walls along y over :math:`M g`); its error is the
    autocorrelation-aware standard error of the mean of the thermo rows' interval-averaged
    wall force (``f_fwavg``) in the averaging stage, over the weight.
    """
    ratio = 1.0 + _value(case, "momentum_steady_residual")
    weight = _value(case, "weight")
    thermo_path = case.path / "run" / "thermo.csv"
    se, note = NAN, "error: none (no thermo.csv)"
    if thermo_path.exists():
        th = pd.read_csv(thermo_path)
        th = th[th["stage"] == "average"].sort_values("Step") if "stage" in th else th.iloc[0:0]
        # the first row's interval ends where averaging starts: it belongs to the flow stage
        force = th["f_fwavg"].to_numpy(float)[1:] if "f_fwavg" in th else np.array([])
        if len(force) >= 4 and weight > 0:
            m = mean_error(force)
            se = m.se / weight
            note = (f"error: autocorrelation-aware standard error of the mean wall force over {m.n} thermo "
                    f"intervals (g = {m.g:.2g}{'' if m.reliable else ', fewer than 50 g: g may be underestimated'})")
    residual = _value(case, "momentum_residual")
    note += (f"; the impulse balance P(t1) - P(t0) = ∫F_wall dt - Mg (t1 - t0) closes to {residual:.1e} of the "
             f"weight impulse" if math.isfinite(residual) else "")
    return ratio, se, note


# ------------------------------------------------------------------------- the checks
def case_checks(case: ChannelCase, errors: dict, variants: dict | None = None) -> list[Check]:
    """The per-case checks (NaN, with the reason in the note, for a case without a steady average).

    ``variants`` holds, per analysis scalar, the same headline measured other ways
    (:func:`.measurement.headline_variants`); each check then carries its systematic error.
    """
    name = case.name
    why = case.why_not or errors.get("why", "")
    steady = not case.why_not
    variants = variants or {}
    footing = central_errors(case.analysis) if case.analysis is not None and variants else {}

    def syst(key: str, value: float) -> dict:
        if key not in variants:
            return {}
        error, text = systematic(value, variants[key], central_se=footing.get(key, NAN))
        return {"syst": error, "variants": text}

    def headline(key: str) -> tuple[float, float, str]:
        entry = errors.get(HEADLINE_OF[key])
        value = _value(case, key) if steady else NAN
        se = entry["se"] if entry and steady else NAN
        return value, se, error_note(entry, why) if steady else why

    checks = []
    ratio, se, enote = headline("ratio")
    detail = (f"u_slip = {_value(case, 'u_slip'):.4g} (speed of the 1.5 d_p wall bin, as the paper), u_max = "
              f"{_value(case, 'u_max'):.4g} √(g d_p) (the centre of the folded profile); " if steady else "")
    checks.append(Check("u_max/u_slip", "1.37–1.40 for all W and φ̄",
                        "§3.1, fig. 5(c) (conclusion ii: 1.38–1.4)",
                        ratio, se, name, U_RATIO, note=detail + enote, **syst("ratio", ratio)))

    a, se, enote = headline("fit_exponent")
    detail = (f"free least-squares fit of (u - u_slip)/(u_max - u_slip) = 1 - exp(-a x/δ0.95) over the folded bins "
              f"beyond the wall bin: R² = {_value(case, 'fit_r2'):.4f}; with a = 3 fixed R² = "
              f"{_value(case, 'fit_r2_a3'):.4f}; " if steady else "")
    checks.append(Check("eq. 3.1 exponent a", "3", "eq. (3.1), fig. 4(b)", a, se, name, (EXPONENT, EXPONENT),
                        note=detail + enote, **syst("fit_exponent", a)))

    d, se, enote = headline("delta_095_over_W")
    W = float(case.record["parameters"]["W"])
    detail = (f"δ0.95 = {_value(case, 'delta_095'):.3g} d_p at W = {W:g} d_p. The paper gives δ0.95/W only as "
              f"points of fig. 5(d), which the paper text we hold does not carry: no number is compared. Its text: "
              f"δ0.95/W is independent of W for W ≥ 100 d_p but not at W = 60 d_p, and δ0.95 falls as φ̄ rises; "
              if steady else "")
    checks.append(Check("δ0.95/W", "fig. 5(d) only; W-independent for W ≥ 100 d_p, not at W = 60",
                        "§3.1, fig. 5(d); conclusions iii-iv", d, se, name, None, note=detail + enote,
                        **syst("delta_095_over_W", d)))

    profile_why = "" if case.analysis is not None else (case.why_not or "not measured: no analysis/profile.csv")
    if case.analysis is not None:
        phi_plug, phi_se = plug_phi(case.analysis)
        zones = case.analysis.zones
        detail = (f"mean φ of the folded bins from the plug edge x = {zones.x_dense_plug:.3g} d_p (from there to the "
                  f"centre |du/dx| ≤ max(2 se, 3 × the rms du/dx of x ≥ 0.35 W, the plug's frozen scatter)) to the "
                  f"centre; error: the mean of those bins' errors of φ (correlation-aware field errors; bins taken as "
                  f"fully correlated, an upper bound)")
        points = rheology_points(case.analysis)
        mu = b3_deviation(points, "dense")
        loose, dense = b4_deviation(points, "loose"), b4_deviation(points, "dense")
    else:
        phi_plug, phi_se = NAN, NAN
        detail = profile_why
        mu = loose = dense = _summary(np.array([]), np.array([]))
    checks.append(Check("φ in the plug", "≈ 0.63", "§3.2, fig. 8(a); conclusion (v)", phi_plug, phi_se, name,
                        (PLUG_PHI, PLUG_PHI), note=detail, **syst("plug_phi", phi_plug)))
    checks += steadiness_and_plug_checks(case)

    base = (f"μ = |σ_xy|/σ_xx and I = d_p|du/dx|/√(σ_xx/ρ_p) per folded bin; B3 with μ_s = {JOP2015.mu_s}, "
            f"μ_∞ = {JOP2015.mu_inf}, I_0 = {JOP2015.I_0}")
    if mu["n"]:
        note = (f"ours: rms of (μ - μ_B3(I))/μ_B3(I) over {_bins(mu['n'])} of the dense shearing zone "
                f"(φ ≥ φ_ad = 0.587, sheared), I = {mu['I_min']:.2g}–{mu['I_max']:.2g}; mean signed deviation "
                f"{mu['mean']:+.1%}. {base}. No statistical error")
    else:
        note = profile_why or "no dense-shearing-zone bin with a finite μ and I > 0"
    checks.append(Check("μ(I) vs eq. B3, dense shearing zone (rms relative deviation)",
                        "differs from B3 in value and shape: μ falls about logarithmically with I down to the "
                        "lowest I of the dense zone, where B3 tends to μ_s", "§3.2, fig. 11(a); conclusion (x)",
                        mu["rms"], NAN, name, None, note=note))

    if loose["n"]:
        note = (f"ours: rms of φ - φ_B4(I) over {_bins(loose['n'])} of the loose shearing zone (between the wall "
                f"layer, 2 d_p, and φ = φ_ad = 0.587), I = {loose['I_min']:.2g}–{loose['I_max']:.2g}; mean "
                f"{loose['mean']:+.3f}. B4 with φ_max = {JOP2015.phi_max}, φ_min = {JOP2015.phi_min}. In the dense "
                f"zone ({_bins(dense['n'])}) the mean is {dense['mean']:+.3f} (paper: φ rises to 0.63 at low I, "
                f"B4 stays at 0.6). No statistical error")
    else:
        note = profile_why or (f"no loose-shearing-zone bin (φ reaches φ_ad inside the wall layer or never falls "
                               f"below it); dense zone ({_bins(dense['n'])}): mean φ - φ_B4 = {dense['mean']:+.3f}")
    checks.append(Check("φ(I) vs eq. B4, loose shearing zone (rms deviation)",
                        "B4 predicts φ quite well in the loose shearing zone, not in the dense zone",
                        "§3.2, fig. 11(b); conclusion (x)", loose["rms"], NAN, name, None, note=note))

    if steady:
        ratio, se, note = wall_force_ratio(case)
        note = ("time-averaged force of both walls along the flow over the total weight Mg (wall shear stress × "
                f"wall area = weight); {note}")
    else:
        ratio, se, note = NAN, NAN, case.why_not
    checks.append(Check("wall shear force / weight", "1 (exact in steady flow)", "§3.1 (fig. 7 discussion), eq. (B2)",
                        ratio, se, name, (1.0, 1.0), note=note))
    return checks


#: the plug's rms non-affine displacement over the window below which it is one frozen configuration,
#: and above which it has rearranged (diameters)
FROZEN_BELOW, REARRANGED_ABOVE = 0.3, 1.0


def steadiness_and_plug_checks(case: ChannelCase) -> list[Check]:
    """u_max/u_slip's drift over the averaging window (0 in a steady flow) and the plug's structure."""
    name, sc = case.name, case.scalars
    if case.why_not or "ratio_drift" not in sc:
        why = case.why_not or "not measured: the analysis predates the per-block ratio (rerun analyse)"
        return [Check("drift of u_max/u_slip over the averaging window", "0 (steady)", "§2, §3.1", NAN, NAN, name,
                      (0.0, 0.0), note=why),
                Check("plug: rms non-affine displacement over the window", "no number (a sheared plug at φ ≈ 0.63)",
                      "§3.2", NAN, NAN, name, None, note=why), plug_order_check(case), ucm_change_check(case)]
    window = float(case.record["rung_knobs"]["t_average"])
    drift, drift_se = _value(case, "ratio_drift"), _value(case, "ratio_drift_se")
    note = (f"change of a straight line through u_max/u_slip of {int(sc.get('n_blocks', 0))} consecutive blocks of "
            f"the {window:g} √(d_p/g) window (blocks scatter by {_value(case, 'ratio_block_sd'):.3g}); error: "
            f"the slope's, from the blocks' scatter about the line. A steady flow has none")
    checks = [Check("drift of u_max/u_slip over the averaging window", "0 (steady)", "§2, §3.1", drift, drift_se,
                    name, (0.0, 0.0), note=note), ucm_change_check(case)]
    rms = _value(case, "plug_nonaffine_rms")
    state = ("one frozen configuration" if rms < FROZEN_BELOW else
             "rearranged" if rms >= REARRANGED_ABOVE else "partly rearranged")
    note = (f"particles that start in the plug (distance from the wall ≥ {_value(case, 'x_dense_plug'):.3g} d_p): "
            f"each one's displacement less what the mean flow (the time-averaged velocity at its x) carried it, "
            f"over {window:g} √(d_p/g): {rms:.3g} d_p, i.e. "
            f"{state} (< {FROZEN_BELOW:g} d_p frozen: it moves with the mean flow as one configuration; ≥ {REARRANGED_ABOVE:g} rearranged). Bond order: q6 = "
            f"{_value(case, 'plug_q6'):.3f} in the plug, {_value(case, 'shear_q6'):.3f} in the shear zone (fcc 0.5745, "
            f"dense random packing 0.35-0.45); crystal-like particles (ten Wolde et al. 1996) "
            f"{_value(case, 'plug_crystal_fraction'):.1%} of the plug, {_value(case, 'shear_crystal_fraction'):.1%} "
            f"of the shear zone; layering along the periodic depth |<exp(2πi n z/B)>| = "
            f"{_value(case, 'plug_layering'):.3f} (no order: {_value(case, 'plug_layering_random'):.3f}). A frozen "
            f"plug samples one configuration, so its bins scatter by more than their time-average errors")
    checks.append(Check("plug: rms non-affine displacement over the window", "no number (a sheared plug at φ ≈ 0.63)",
                        "§3.2", rms, NAN, name, None, unit="d_p", note=note))
    return checks + [plug_order_check(case)]


#: u_cm "varies by less than 1 %" in the paper's steady flows (§3.1, fig. 3)
UCM_CHANGE_BOUND = 0.01
Q_UCM_CHANGE = "u_cm's change across the averaging window (its acceleration × the window / its mean)"


def ucm_change_check(case: ChannelCase) -> Check:
    """How far u_cm moves across the averaging window: a straight line through the averaging stage's
    u_cm (:func:`postproc.series.window_acceleration`; error scaled by the residuals' statistical
    inefficiency), its slope times the window over the mean, against the paper's "< 1 %" (fig. 3, its flows
    steady after 2×10³ √(d_p/g)). The note sets the drift per steadiness window beside half the tolerance
    the runner's steadiness test allowed."""
    from postproc.series import window_acceleration

    paper = "within ± 1 % (u_cm varies by less than 1 % at 0.59 ≤ φ̄ ≤ 0.61, after 2×10³ √(d_p/g))"
    source = "§2; §3.1, fig. 3"
    path = case.path / "run" / "thermo.csv"
    th = pd.read_csv(path) if path.exists() and not case.why_not else None
    if th is None or "v_ucm" not in th:
        return Check(Q_UCM_CHANGE, paper, source, NAN, NAN, case.name, (-UCM_CHANGE_BOUND, UCM_CHANGE_BOUND),
                     note=case.why_not or "no u_cm in run/thermo.csv")
    acc = window_acceleration(th)
    t = th.loc[th["stage"] == "average", "Time"] if "stage" in th else th["Time"].iloc[:0]
    span = float(t.max() - t.min()) if len(t) > 1 else NAN
    u = acc.get("u_cm_window", NAN)
    change, change_se = acc["accel_cm"] * span / u, acc["accel_cm_se"] * span / abs(u)
    proto = case.record.get("protocol", {})
    window, tol = float(proto.get("steady_window", NAN)), float(proto.get("steady_rel_tol", NAN))
    per_window = change * window / span
    start = float(t.min()) if len(t) else NAN
    note = (f"u_cm from {start:.0f} to {start + span:.0f} √(d_p/g) ({acc['accel_rows']} thermo rows, mean "
            f"{u:.4g} √(g d_p)): a = {acc['accel_cm']:.3g} ± {acc['accel_cm_se']:.2g} g; per {window:g} √(d_p/g), "
            f"the steadiness test's window, {per_window:+.2%} against its tolerance {tol:.0%} ("
            + ("more than half of it: the window still drifts" if abs(per_window) > 0.5 * tol else "within half of it")
            + "). The paper averages from 2×10³ √(d_p/g); the ladder's rung t_paper runs its protocol")
    return Check(Q_UCM_CHANGE, paper, source, change, change_se, case.name, (-UCM_CHANGE_BOUND, UCM_CHANGE_BOUND),
                 note=note)


#: the paper's bound on the plug's order parameter: "no crystallization; the Q_6 order parameter
#: (Kumaran 2009c,d) in this region is below 0.4"
Q6_BOUND = 0.4


def plug_order_check(case: ChannelCase) -> Check:
    """The plug's global bond order :math:`Q_6` (Steinhardt et al. 1983, over every bond of the plug's
    particles; :meth:`postproc.structure.BondOrder.global_q`), the frames' mean, against the paper's < 0.4.
    Syst: the bond cutoff (1.2 and 1.4 d_p against 1.3) and the plug's edge 1 d_p further in."""
    quantity, paper, source = "plug: global bond order Q_6", f"< {Q6_BOUND:g} (no crystallization)", "§3.2"
    value = _value(case, "plug_Q6")
    if case.why_not or not math.isfinite(value):
        why = case.why_not or "not measured: the analysis predates the plug's global Q_6 (rerun analyse)"
        return Check(quantity, paper, source, NAN, NAN, case.name, (0.0, Q6_BOUND), note=why)
    variants = {f"bond cutoff {c:g} d_p": _value(case, f"plug_Q6_cut{c:g}") for c in (1.2, 1.4)}
    variants["plug edge 1 d_p further in"] = _value(case, "plug_Q6_inner")
    se = _value(case, "plug_Q6_se")
    syst, text = systematic(value, variants, central_se=se)
    note = (f"Q_6 = [4π/13 Σ_m |⟨Y_6m⟩|²]^½ with ⟨Y_6m⟩ the mean over every bond (centres closer than 1.3 d_p) of the "
            f"particles at ≥ {_value(case, 'x_dense_plug'):.3g} d_p from the wall, per frame, the frames' mean: 0.5745 "
            f"for fcc, ~1/√(bonds) without common orientation (Steinhardt et al. 1983; the paper cites Kumaran 2009c,d "
            f"for it). The local q6 averaged per particle is {_value(case, 'plug_q6'):.3f} (in the non-affine row's "
            f"note: a random packing reads 0.35-0.45 there). Error: the frames' scatter over √frames (frames taken "
            f"as independent); syst: the bond cutoff, the plug's edge")
    return Check(quantity, paper, source, value, se, case.name, (0.0, Q6_BOUND), syst=syst, variants=text, note=note)


# ------------------------------------------------------------------------- profiles
def velocity_profile(case: ChannelCase) -> pd.DataFrame:
    """Scaled velocity of the folded profile against :math:`x/\\delta_{0.95}` and :math:`x/W`, with eq. (3.1)."""
    a = case.analysis
    f, s = a.folded, a.scales
    x = f["x"].to_numpy(float)
    u, u_se = f["u"].to_numpy(float), f["u_se"].to_numpy(float)
    span = s.u_max - s.u_slip
    xi = x / s.delta_095 if np.isfinite(s.delta_095) and s.delta_095 > 0 else np.full(len(x), NAN)
    return pd.DataFrame({
        "case": case.name, "W": a.W, "phi_mean": float(case.record["parameters"]["phi_mean"]),
        "x": x, "x_over_W": x / a.W, "x_over_delta": xi, "u": u, "u_se": u_se,
        "u_scaled": (u - s.u_slip) / span if span > 0 else NAN,
        # the block-wise scaling's own error where the profile has it (a change of speed of the whole channel
        # leaves the scaled profile alone), else the bins' over the span
        "u_scaled_se": f["u_scaled_se"].to_numpy(float) if "u_scaled_se" in f else (u_se / span if span > 0 else NAN),
        "eq31": 1.0 - np.exp(-EXPONENT * xi),
    })


# ------------------------------------------------------------------------- set-up differences
def overlap_line(case: ChannelCase) -> str:
    """The case's largest overlap against :data:`OVERLAP_LIMIT`, and what it does."""
    ov = case.status.get("max_overlap")
    if not isinstance(ov, (int, float)):
        return f"{case.name}: largest overlap not recorded"
    line = f"{case.name}: largest overlap {100 * ov:.4g} % of the smallest diameter"
    if ov <= OVERLAP_LIMIT:
        return line + f" (within the {100 * OVERLAP_LIMIT:g} % limit)"
    k_n = float(case.record["rung_knobs"]["k_n"])
    same = math.isclose(k_n, PAPER_K_N)
    return (line + f", above the {100 * OVERLAP_LIMIT:g} % limit: " +
            ("the paper uses the same k_n = 1e6, so its contacts overlap alike at equal W (σ_xx ∝ W, §3.1: more in "
             "its wider channels)" if same else
             f"k_n = {sci(k_n)} is softer than the paper's 1e6, so contacts overlap more than the paper's") +
            ". The paper (§3.2, fig. 10) finds φ and u_y independent of k_n ≥ 1e5 (but for φ at k_n = 1e5, "
            "φ̄ = 0.59), while du_y/dx and T in the dense shearing and plug zones depend on k_n")


def differences(loaded: list[ChannelCase]) -> list[str]:
    """What differs from the paper's set-up (from each case's parameter record), and why."""
    if not loaded:
        return []
    first = loaded[0]
    k, p = first.record["rung_knobs"], first.record["parameters"]
    rung = first.record["rung"]
    widths = ", ".join(sorted({f"{c.record['parameters']['W']:g}" for c in loaded}, key=float))
    counts = ", ".join(str(c.record["parameters"]["n_particles"]) for c in loaded)
    dt, t_c = float(first.record["dt"]), float(p["t_c_min"])
    paper_dt = f"{sci(PAPER_DT, 2)} √(d_p/g) at k_n = 1e6"
    if math.isclose(float(k["k_n"]), PAPER_K_N):
        paper_dt += f", t_c/{t_c / PAPER_DT:.1f}"
    out = [
        f"box: W = {widths} d_p (paper: 60-150 d_p), B = {k['B']:g} d_p (paper: {PAPER_B:g}), H = {k['H']:g} d_p "
        f"(paper: {PAPER_H}); {counts} particles (paper: 1.7e5 at W = 60 d_p), §2. B and H are periodic and "
        f"thinned to afford the rung {rung!r} (config/scenes/channel.yaml); fewer particles make u_cm fluctuate "
        f"more (paper: < 1 % for 0.59 <= φ̄ <= 0.61, §3.1)",
        f"averaging over {k['t_average']:g} √(d_p/g) (paper: {PAPER_T_AVERAGE:g}); the flow ran until our steady "
        f"criterion held (drift < {first.record['protocol']['steady_rel_tol']:.0%}, fluctuation < "
        f"{first.record['protocol']['steady_fluct_tol']:.0%} over {first.record['protocol']['steady_window']:g} "
        f"√(d_p/g); at most {k['t_flow_max']:g}) instead of the paper's {PAPER_T_STEADY:g} (§2)",
        f"k_n = {sci(k['k_n'])} (paper default {sci(PAPER_K_N)}, App. A); "
        f"dt = {dt:.3g} √(d_p/g) = t_c/{t_c / dt:.1f} "
        f"of the shortest pair contact (paper: {paper_dt}, App. A)",
    ]
    for c in loaded:
        st = c.status.get("steady") or {}
        if c.why_not:
            out.append(f"{c.name}: {c.why_not} (paper, §2 and §3.1: steady flow between φ̄_cr, 0.59 at W = "
                       f"100-150 d_p, and 0.62, for W = 60-150 d_p)")
        elif isinstance(st.get("t_start"), (int, float)) and math.isfinite(st["t_start"]):
            out.append(f"{c.name}: steady from t = {st['t_start']:.0f} √(d_p/g), u_cm fluctuating by "
                       f"{st.get('rel_fluct', NAN):.1%}")
        out.append(overlap_line(c))
    return out


# ------------------------------------------------------------------------- the record
def validation(scene_dir: Path, cases: dict[str, Path]) -> ValidationResult:
    """The channel's checks, profiles, figures and set-up differences for the cases of a rung.

    Parameters
    ----------
    scene_dir : Path
        ``results/channel/<rung>`` (its ``figures/`` hold the rung's figures).
    cases : dict of str to Path
        Case directory name (``W~60/phi~0.6``) to its analysed directory.
    """
    loaded = [load_case(name, path) for name, path in cases.items()]
    checks, velocity, rheology, blocks = [], [], [], []
    for case in loaded:
        variants = {}
        if case.analysis is not None and all((case.path / "run" / d).exists() for d in case.status["dumps"]):
            variants = headline_variants(case.path, case.record, case.analysis)
            case.variants = variants
        checks += case_checks(case, time_average_errors("channel", case.path, case.record, case.why_not), variants)
        if case.analysis is not None:
            velocity.append(velocity_profile(case))
            rheology.append(rheology_points(case.analysis).assign(case=case.name))
        if (case.path / "analysis" / "blocks.csv").exists():
            blocks.append(pd.read_csv(case.path / "analysis" / "blocks.csv").assign(case=case.name))
    checks += more_checks(loaded) + kinetic_checks(loaded)  # the paper's other results one W and two φ̄ can test
    checks += zone_checks(loaded)  # the shear rate's curvature in the dense and loose zones
    checks += width_checks(loaded)  # and those two W at one φ̄ can
    checks += scaled_profile_checks(loaded)  # one universal scaled profile across every case
    profiles = {}
    if velocity:
        profiles["velocity_scaled"] = pd.concat(velocity, ignore_index=True)
        profiles["rheology_points"] = pd.concat(rheology, ignore_index=True)
    if blocks:
        profiles["ratio_blocks"] = pd.concat(blocks, ignore_index=True)
    return ValidationResult(checks=checks, profiles=profiles, figures=list(FIGURES),
                            differences=differences(loaded))
