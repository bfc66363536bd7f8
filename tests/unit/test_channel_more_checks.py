"""The channel's further checks against Debnath et al. (2022) (granflow.scenes.channel.more_checks and
.kinetic_checks) on hand-made symmetric profiles with known fields: each check recovers the number it was
built with, and passes or fails against the paper as the built-in physics says it must."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import granflow.scenes.channel.kinetic_checks as kc
import granflow.scenes.channel.more_checks as mc
from granflow import coverage
from granflow.scenes.channel.analysis import analyse_profile
from granflow.scenes.channel.validation import ChannelCase

W = 30.0
EDGES = np.concatenate([[0.0], np.arange(1.5, W - 1.5 + 0.5, 1.0), [W]])
X = 0.5 * (EDGES[:-1] + EDGES[1:])
XW = np.minimum(X, W - X)            # distance from the nearer wall
HALF = XW <= W / 2                   # every bin; the mirror below uses the first half
#: per-field standard error of the synthetic time averages; u_y's 1e-2 puts the shear-rate plug edge at ~4 d_p
SE = 1e-3


def saturating_phi(xw, plateau=0.64, drop=0.09, length=5.0):
    """φ rising from the wall towards a plateau, reaching 0.63 at x = length ln 9: −ln φ is curved (the
    paper's fig. 12)."""
    return plateau - drop * np.exp(-xw / length)


def exponential_phi(xw):
    """φ exponential in x up to 0.63 (Barker et al. 2022's form): −ln φ exactly linear there."""
    return np.minimum(0.50 * np.exp(0.02 * xw), 0.63 + 0.0 * xw)


def build_profile(phi=saturating_phi, u_scale=1.0, delta=5.0, sxx=lambda xw: 50.0 + 0.0 * xw, sxy_factor=1.0,
                  spin=0.5, spin_wall=0.2, r_of_x=lambda xw: 1.0 + 0.5 * np.minimum(xw, 3.0), t_plug=None,
                  u_se=1e-2, t_loose=None):
    """An unfolded symmetric profile with known fields.

    u: eq. 3.1 (u_slip 1, u_max 1.4, times ``u_scale``; δ-like length ``delta``); φ from ``phi``; σ_xx from
    ``sxx``; σ_xy = ``sxy_factor`` × g∫_x^{W/2} φ dx (eq. B2, the bin rule of ``column_from_centre``);
    Ω_z = ``spin`` × ω_z (``spin_wall`` in the wall bins); T = (γ̇/r)² with d_p γ̇/√T = ``r_of_x`` in the
    shearing zone, ``t_plug`` (a number or a function of x, if given) in the plug, where φ ≥ 0.63,
    ``t_loose(phi, sigma_xx)`` (if given)
    where φ < 0.587; u_y's standard error ``u_se``.
    """
    u = u_scale * (1.0 + 0.4 * (1.0 - np.exp(-3.0 * XW / delta)))
    f = phi(XW)
    zero = np.zeros(len(X))
    df = pd.DataFrame(dict(x=X, x_lo=EDGES[:-1], x_hi=EDGES[1:], n=np.full(len(X), 100.0), phi=f, rho=f,
                           u_x=zero, u_y=-u, u_z=zero, sigma_xx=sxx(XW), sigma_yy=50.0 + zero))
    for col in [c for c in df.columns if c not in ("x", "x_lo", "x_hi")]:
        df[f"{col}_se"] = u_se if col == "u_y" else SE
    first = analyse_profile(df, W)            # the folded gradient and G, on the same bins
    n_half = len(first.folded)
    G = mc.column_from_centre(first)
    gd = first.rheo["gamma_dot"].to_numpy(float)
    ratio = np.full(n_half, spin)
    ratio[0] = spin_wall
    omega_half = ratio * (-gd)                 # Ω_z = ratio × ω_z, ω_z = du_y/dx = −γ̇ (raw frame)
    with np.errstate(divide="ignore"):
        T_half = (gd / r_of_x(first.folded["x"].to_numpy(float))) ** 2
    if t_plug is not None:
        plug_t = t_plug(first.folded["x"].to_numpy(float)) if callable(t_plug) else t_plug
        T_half = np.where(first.folded["phi"].to_numpy(float) >= 0.63, plug_t, T_half)
    if t_loose is not None:
        phi_half = first.folded["phi"].to_numpy(float)
        T_half = np.where(phi_half < 0.587, t_loose(phi_half, first.folded["sigma_xx"].to_numpy(float)), T_half)
    T_half = np.maximum(T_half, 1e-9)
    idx = np.where(np.arange(len(X)) < n_half, np.arange(len(X)), len(X) - 1 - np.arange(len(X)))
    odd = np.where(np.arange(len(X)) < n_half, 1.0, -1.0)
    if len(X) % 2 == 1:
        odd[n_half - 1] = 1.0
    df["sigma_xy"] = sxy_factor * G[idx] * odd
    df["Omega_z"] = omega_half[idx] * odd
    df["T"] = T_half[idx]
    for col in ("sigma_xy", "Omega_z"):
        df[f"{col}_se"] = SE
    df["T_se"] = 1e-3 * df["T"]                # 0.1 % relative error
    return df


def make_case(tmp_path: Path, name: str, profile: pd.DataFrame, phi_mean: float = 0.6, thermo=None) -> ChannelCase:
    path = tmp_path / name.replace("/", "_")
    (path / "run").mkdir(parents=True)
    if thermo is not None:
        thermo.to_csv(path / "run" / "thermo.csv", index=False)
    record = {"parameters": {"W": W, "phi_mean": phi_mean, "n_particles": 1200}}
    return ChannelCase(name, path, record, {}, {}, "", analyse_profile(profile, W))


def thermo_with(rel: float, n: int = 400, seed: int = 3) -> pd.DataFrame:
    rng = np.random.default_rng(seed)
    return pd.DataFrame({"Step": np.arange(n) * 100, "stage": "average",
                         "v_py": -1000.0 * (1.0 + rel * rng.standard_normal(n))})


def by(checks, quantity):
    found = [c for c in checks if c.quantity == quantity]
    assert len(found) == 1, (quantity, [c.quantity for c in checks])
    return found[0]


# ------------------------------------------------------------------------- per case
def conducting_plug(l_c):
    """T in the plug from eq. B13 with zero flux at the centre: T^{3/2} = 1e-9 cosh((W/2 − x)/l_c)."""
    return lambda x: (1e-9 * np.cosh((W / 2 - x) / l_c)) ** (2.0 / 3.0)


def test_a_case_built_on_the_papers_physics_passes_every_check(tmp_path, monkeypatch):
    monkeypatch.setattr(mc, "LC_MIN_WIDTH", W)   # l_c is a comparison from the paper's width on; here W = 30
    case = make_case(tmp_path, "W~30/phi~0.6", build_profile(t_plug=conducting_plug(11.5)), thermo=thermo_with(0.004))
    checks = {c.quantity: c for c in mc.case_more_checks(case)}
    assert set(checks) == {mc.Q_SXX, mc.Q_SXY, mc.Q_SPIN, mc.Q_SQRT_T, mc.Q_LOG_PHI, mc.Q_UCM, mc.Q_LC, mc.Q_T_ORDERS}
    checks.pop(mc.Q_T_ORDERS)                   # its own test: this profile's wall T is not the paper's
    # the plug's T built on eq. B13 with l_c = 11.5 d_p (from x = 11, where φ reaches 0.63, to the centre)
    assert checks[mc.Q_LC].ours == pytest.approx(11.5, rel=1e-4)
    # σ_xx flat: the line's change is 0 to rounding (errors 1e-3 of 50)
    assert checks[mc.Q_SXX].ours == pytest.approx(0.0, abs=1e-12)
    # σ_xy built as exactly g∫ρ dx: b = 1
    assert checks[mc.Q_SXY].ours == pytest.approx(1.0, rel=1e-9)
    # Ω_z/ω_z built 1/2 in every bin beyond the wall bin
    assert checks[mc.Q_SPIN].ours == pytest.approx(0.5, rel=1e-9)
    assert "The wall bin reads 0.2" in checks[mc.Q_SPIN].note
    assert "By bin (its centre's distance from the wall): 2 d_p: 0.50 ± " in checks[mc.Q_SPIN].note
    # d_p γ̇/√T built as 1 + 0.5 min(x, 3): from x = 0.75 to 2, a rise of 0.625
    assert checks[mc.Q_SQRT_T].ours == pytest.approx(0.625, rel=1e-6)
    # u_cm: white noise of 0.4 % around its mean (sampling error of a standard deviation over 400 samples ~4 %)
    assert checks[mc.Q_UCM].ours == pytest.approx(0.004, rel=0.15)
    # a saturating φ is curved in −ln φ: the largest p of the three exclusions is tiny
    assert checks[mc.Q_LOG_PHI].ours < mc.P_CURVED
    for c in checks.values():
        assert c.kind == "comparison"
        # (σ_xx's change is 0 to rounding, so its rounding-sized variants read "within the systematic error")
        assert c.verdict in ("equal", "within the paper's range") or c.verdict.startswith("within"), \
            (c.quantity, c.ours, c.verdict)


def test_the_conduction_length_is_a_diagnostic_below_the_papers_width(tmp_path):
    case = make_case(tmp_path, "W~30/phi~0.6", build_profile(t_plug=conducting_plug(11.5)))
    row = by(mc.case_more_checks(case), mc.Q_LC)
    assert W < mc.LC_MIN_WIDTH and row.kind == "diagnostic" and row.ours == pytest.approx(11.5, rel=1e-4)
    assert row.verdict.startswith("diagnostic") and "W ≥ 100 d_p" in row.note


def test_the_orders_of_magnitude_between_the_wall_and_the_centre_are_read_from_t(tmp_path):
    for ratio, inside in ((1e-5, True), (1e-2, False)):
        profile = build_profile(t_plug=conducting_plug(11.5))
        centre = (profile["x"] - W / 2).abs() <= mc.CENTRE_HALF_WIDTH + 0.6
        profile.loc[centre, "T"] = ratio * float(profile["T"].iloc[0])
        profile.loc[centre, "T_se"] = 1e-3 * profile.loc[centre, "T"]
        case = make_case(tmp_path, f"W~30/phi~0.6/{ratio:g}", profile)
        row = by(mc.case_more_checks(case), mc.Q_T_ORDERS)
        assert row.ours == pytest.approx(-math.log10(ratio), rel=1e-6)
        assert row.error == pytest.approx(math.sqrt(1e-6 + 1e-6 / centre.sum() * 2) / math.log(10), rel=0.5)
        assert (row.verdict == "within the paper's range") is inside, row.verdict
        assert "T in the second bin" in row.variants


def test_profiles_against_the_paper_fail(tmp_path, monkeypatch):
    monkeypatch.setattr(mc, "LC_MIN_WIDTH", W)
    # σ_xx rising 2 per d_p towards the centre, σ_xy 1.3 times the weight, particles spinning at 0.3 ω,
    # d_p γ̇/√T falling from 2 in the wall bin to 1 beyond, φ exponential (Barker et al.'s form), u_cm fluctuating by 3 %
    bad = build_profile(phi=exponential_phi, sxx=lambda xw: 50.0 + 2.0 * xw, sxy_factor=1.3, spin=0.3,
                        t_plug=conducting_plug(4.0),
                        r_of_x=lambda xw: np.where(xw < 1.0, 2.0, 1.0))
    case = make_case(tmp_path, "W~30/phi~0.6", bad, thermo=thermo_with(0.03))
    checks = {c.quantity: c for c in mc.case_more_checks(case)}
    # the line through 50 + 2x over the folded bins x = 2, 3, ..., 15 (the centre): change 26 over a mean of 67
    assert checks[mc.Q_SXX].ours == pytest.approx(2.0 * 13.0 / 67.0, rel=1e-6)
    assert checks[mc.Q_SXY].ours == pytest.approx(1.3, rel=1e-9)
    assert checks[mc.Q_SPIN].ours == pytest.approx(0.3, rel=1e-9)
    assert checks[mc.Q_SQRT_T].ours == pytest.approx(-1.0, rel=1e-6)
    # an exactly exponential φ leaves no curvature: p = 1
    assert checks[mc.Q_LOG_PHI].ours == pytest.approx(1.0)
    assert checks[mc.Q_LC].ours == pytest.approx(4.0, rel=1e-4)   # a plug conducting over 4 d_p, not 11.5
    for q in (mc.Q_SXX, mc.Q_SXY, mc.Q_SPIN, mc.Q_SQRT_T, mc.Q_LOG_PHI, mc.Q_UCM, mc.Q_LC):
        assert checks[q].verdict.startswith("one sample: off by"), (q, checks[q].ours, checks[q].verdict)


def test_the_free_choices_carry_a_systematic_error(tmp_path):
    # σ_xx bending near the wall only: where the line starts moves its change
    bent = build_profile(sxx=lambda xw: 50.0 - 4.0 * np.exp(-xw))
    checks = {c.quantity: c for c in mc.case_more_checks(make_case(tmp_path, "c", bent))}
    sxx = checks[mc.Q_SXX]
    assert sxx.syst > 0 and "from the wall layer (2 d_p)" in sxx.variants and "from 3 d_p" in sxx.variants
    assert "bins taken as independent" in sxx.note
    assert "to the shear-rate plug edge" in checks[mc.Q_LOG_PHI].variants


def test_weighted_fits_recover_known_lines_and_widen_with_scatter():
    x = np.arange(10.0)
    coef, cov, chi2, nu = mc.weighted_polyfit(x, 2.0 + 0.5 * x, np.full(10, 0.1), 1)
    np.testing.assert_allclose(coef, [2.0, 0.5], atol=1e-12)
    assert nu == 8 and chi2 == pytest.approx(0.0, abs=1e-20)
    # errors of 0.1 on 10 points: se of a mean 0.1/√10; scatter of ±1 about the line widens it by √(χ²/ν)
    _, cov0, _, _ = mc.weighted_polyfit(x, np.zeros(10), np.full(10, 0.1), 0)
    assert math.sqrt(cov0[0, 0]) == pytest.approx(0.1 / math.sqrt(10))
    y = np.where(np.arange(10) % 2, 1.0, -1.0)
    _, cov1, chi2, _ = mc.weighted_polyfit(x, y, np.full(10, 0.1), 0)
    assert chi2 == pytest.approx(100.0 * 10 / 9) and math.sqrt(cov1[0, 0]) == pytest.approx(math.sqrt(10 / 9 / 10))


def test_column_from_centre_is_the_weight_per_wall_area():
    a = analyse_profile(build_profile(phi=lambda xw: 0.6 + 0.0 * xw), W)
    G = mc.column_from_centre(a)
    # constant φ: g∫_x^{W/2} φ dx = 0.6 (W/2 − x), exact for the bin rule
    np.testing.assert_allclose(G, 0.6 * (W / 2 - a.folded["x"].to_numpy(float)), atol=1e-12)


# ------------------------------------------------------------------------- across φ̄
def pair(tmp_path, u_se=1e-2, **high):
    """φ̄ = 0.60 and 0.61 at W = 30: the higher φ̄ slower, thinner-layered, with a wider plug, higher σ_xx,
    colder shearing zones and the same plug T, unless ``high`` overrides the higher case's profile."""
    low = build_profile(phi=lambda xw: saturating_phi(xw, length=5.0), t_plug=1e-6, u_se=u_se)
    spec = dict(phi=lambda xw: saturating_phi(xw, length=3.0), u_scale=0.8, delta=4.0,
                sxx=lambda xw: 60.0 + 0.0 * xw, r_of_x=lambda xw: 1.3 + 0.5 * np.minimum(xw, 3.0), t_plug=1e-6,
                u_se=u_se)
    spec.update(high)
    return [make_case(tmp_path, "W~30/phi~0.6", low, 0.60), make_case(tmp_path, "W~30/phi~0.61", build_profile(**spec), 0.61)]


def test_the_trends_with_phi_bar_are_read_across_the_two_cases(tmp_path):
    cases = pair(tmp_path)
    checks = {c.quantity: c for c in mc.sweep_more_checks(cases)}
    assert set(checks) == {mc.Q_USLIP, mc.Q_UMAX, mc.Q_DELTA, mc.Q_PLUG, mc.Q_SXX_PHI, mc.Q_MU_WALL,
                           mc.Q_T_SHEAR, mc.Q_T_PLUG}
    assert {c.case for c in checks.values()} == {"W~30/phi~0.6 vs W~30/phi~0.61"}
    # speeds built 1/0.8 apart (u_slip also by the shorter layer: the wall bin's centre lies further into it)
    low, high = (c.analysis.scales for c in cases)
    assert checks[mc.Q_USLIP].ours == pytest.approx(low.u_slip / high.u_slip, rel=1e-12)
    assert 1.2 < checks[mc.Q_USLIP].ours < 1.25
    assert checks[mc.Q_UMAX].ours == pytest.approx(1.25, rel=1e-3)   # the centre bin: e^{-3·9.5/4} from 1.4
    # σ_xx 60 over 50
    assert checks[mc.Q_SXX_PHI].ours == pytest.approx(1.2, rel=1e-9)
    # μ_wall = τ_w/σ_xx: τ_w the column's weight per wall area, nearly equal, σ_xx 20 % higher
    assert checks[mc.Q_MU_WALL].ours < 0
    # the shear-zone T: (γ̇/r)², r 1.3 higher at the higher φ̄ and γ̇ slower (0.8, and a shorter layer)
    assert checks[mc.Q_T_SHEAR].ours < 1
    # the plug T built equal
    assert checks[mc.Q_T_PLUG].ours == pytest.approx(1.0, rel=1e-9)
    # φ reaches 0.63 at x = L ln 9: L = 5 and 3 put the edges at 11.0 and 6.6 d_p (read between bin centres,
    # linearly: within a tenth of a bin of the curve's), a plug 2 × 4.4 d_p wider at the higher φ̄
    assert checks[mc.Q_PLUG].ours == pytest.approx(2 * 2.0 * math.log(9.0), abs=0.2)
    assert checks[mc.Q_DELTA].ours < 1
    for c in checks.values():
        assert c.verdict in ("equal", "within the paper's range") or c.verdict.startswith(("within error",
                                                                                          "not resolved")), \
            (c.quantity, c.ours, c.verdict)


def test_reversed_trends_fail(tmp_path):
    # the higher φ̄ built faster, with a narrower plug, lower σ_xx, hotter shearing
    # zones and a plug ten times hotter
    cases = pair(tmp_path, u_scale=1.3, sxx=lambda xw: 40.0 + 0.0 * xw, delta=8.0,
                 phi=lambda xw: saturating_phi(xw, length=6.0),
                 r_of_x=lambda xw: 0.5 + 0.2 * np.minimum(xw, 3.0), t_plug=1e-5)
    checks = {c.quantity: c for c in mc.sweep_more_checks(cases)}
    for q in (mc.Q_USLIP, mc.Q_UMAX, mc.Q_SXX_PHI, mc.Q_MU_WALL, mc.Q_T_SHEAR, mc.Q_T_PLUG, mc.Q_PLUG):
        assert checks[q].verdict.startswith("one sample: off by"), (q, checks[q].ours, checks[q].verdict)
    # a longer φ length at the higher φ̄: its plug edge 6 ln 9 = 13.2 d_p against 11.0, a plug 4.4 d_p narrower
    assert checks[mc.Q_PLUG].ours == pytest.approx(-2 * 1.0 * math.log(9.0), abs=0.2)
    assert checks[mc.Q_T_PLUG].ours == pytest.approx(10.0, rel=1e-9)
    # a shear layer 8/5 times thicker at the higher φ̄, speeds known to 0.1 %: δ0.95 is read where the profile
    # is flat, so its error is wide (with the 1 % errors above such a difference is "not resolved")
    thick = {c.quantity: c for c in mc.sweep_more_checks(pair(tmp_path / "thick", delta=8.0, u_se=1e-3))}
    assert thick[mc.Q_DELTA].ours > 1.4 and thick[mc.Q_DELTA].verdict.startswith("one sample: off by"), \
        (thick[mc.Q_DELTA].ours, thick[mc.Q_DELTA].verdict)
    wide = {c.quantity: c for c in mc.sweep_more_checks(pair(tmp_path / "wide", delta=8.0))}[mc.Q_DELTA]
    assert wide.verdict.startswith("not resolved")


def test_a_case_without_an_analysis_adds_nothing(tmp_path):
    case = make_case(tmp_path, "c", build_profile())
    case.why_not = "no steady state"
    assert mc.case_more_checks(case) == [] and mc.sweep_more_checks([case]) == []
    assert mc.sweep_more_checks([make_case(tmp_path, "d", build_profile())]) == []   # one φ̄: no trend


def test_every_new_check_compares_a_result_of_the_paper():
    # the rows across φ̄ waited in paper_results_pending.yaml until the record held both φ̄ (2026-11-27, two seeds
    # each); now each check of more_checks and kinetic_checks is named by an entry of paper_results.yaml
    # (tests/unit/test_coverage.py requires every compared_by row to be in validation/channel/checks.csv); the
    # pending file holds only the rows across W (tests/unit/test_channel_width_checks.py)
    table = coverage.load(coverage.paper_results_path("channel"))["results"]
    compared = {(q if isinstance(q, str) else q["quantity"]) for e in table for q in e.get("compared_by", [])}
    assert set(mc.QUANTITIES) | set(kc.QUANTITIES) <= compared


def test_a_profile_without_stress_spin_or_temperature_gives_nan_rows(tmp_path):
    bare = build_profile().drop(columns=[c for c in build_profile().columns
                                         if c.split("_se")[0] in ("sigma_xx", "sigma_xy", "sigma_yy", "Omega_z", "T")])
    cases = [make_case(tmp_path, "a", bare, 0.60), make_case(tmp_path, "b", bare, 0.61)]
    checks = {c.quantity: c for c in mc.more_checks(cases)}
    for q in (mc.Q_SXX, mc.Q_SXY, mc.Q_SPIN, mc.Q_SQRT_T, mc.Q_SXX_PHI, mc.Q_MU_WALL, mc.Q_T_SHEAR, mc.Q_T_PLUG):
        assert math.isnan(checks[q].ours) and checks[q].verdict == "not measured", q
    assert math.isfinite(checks[mc.Q_UMAX].ours)   # the speeds need no more than u_y


def test_divergence_point_of_a_known_curve():
    phi = np.linspace(0.53, 0.585, 6)
    fit = kc.divergence_point(phi, 2.0 / (0.59 - phi), np.full(6, 0.01))
    assert fit["phi_ad"] == pytest.approx(0.59, abs=1e-12) and fit["n"] == 6
    # the error is the 1 % errors' (no residual scatter to widen it): 1/c known to 1 % near φ_ad, where it is
    # 0.0025, moves the crossing by ~1 % of its distance 0.005 from the last point: of order 5e-5
    assert 1e-5 < fit["se"] < 2e-4


def loose_pair(tmp_path, phi_ad, factor_high=1.0):
    """φ̄ = 0.60 and 0.61 with wide loose zones (φ = 0.64 − 0.15 e^{−x/L} reaches 0.587 at x = 6.2 and 4.1 d_p)
    and T making p_φ = σ_xx/T = 2/(φ_ad − φ) there (``factor_high`` times that at the higher φ̄)."""
    def t_loose(phi, sxx, factor=1.0):
        return sxx * (phi_ad - phi) / (2.0 * factor)
    low = build_profile(phi=lambda xw: saturating_phi(xw, drop=0.15, length=6.0), t_loose=t_loose)
    high = build_profile(phi=lambda xw: saturating_phi(xw, drop=0.15, length=4.0),
                         t_loose=lambda phi, sxx: t_loose(phi, sxx, factor_high), u_scale=0.8,
                         sxx=lambda xw: 60.0 + 0.0 * xw)
    return [make_case(tmp_path, "W~30/phi~0.6", low, 0.60), make_case(tmp_path, "W~30/phi~0.61", high, 0.61)]


def test_the_divergence_at_phi_ad(tmp_path):
    checks = {c.quantity: c for c in kc.kinetic_checks(loose_pair(tmp_path, 0.59))}
    assert set(checks) == set(kc.QUANTITIES)
    p = checks[kc.Q_PAD_P]
    assert p.ours == pytest.approx(0.59, abs=1e-9) and p.paper_error == 0.002
    assert p.verdict in ("equal",) or p.verdict.startswith("within"), p.verdict
    assert "of the 7 loose-zone bins" in p.note   # x = 2..6 at φ̄ = 0.60, x = 2..3 at 0.61
    # μ_φ follows from the same fields: its φ_ad is whatever they give, measured the same way
    lows = pd.concat([kc.loose_coefficients(c.analysis) for c in loose_pair(tmp_path / "again", 0.59)])
    fit = kc.divergence_point(lows["phi"], lows["mu_phi"], lows["mu_phi_rel"])
    assert checks[kc.Q_PAD_MU].ours == pytest.approx(fit["phi_ad"], rel=1e-12)
    # a divergence at 0.62 (beyond random close packing's reach in the paper) fails
    far = {c.quantity: c for c in kc.kinetic_checks(loose_pair(tmp_path / "far", 0.62))}[kc.Q_PAD_P]
    assert far.ours == pytest.approx(0.62, abs=1e-9) and far.verdict.startswith("one sample: off by +5.1 %"), far.verdict


def test_the_loose_zone_coefficients_collapse_on_phi(tmp_path):
    # both φ̄ built on one p_φ(φ) = 2/(0.59 − φ): at equal φ the ratio is 1 (1/p_φ is linear in φ, so the
    # interpolation is exact); the higher φ̄'s loose bins (x = 2, 3: φ = 0.562, 0.581) lie within the lower's
    same = {c.quantity: c for c in kc.kinetic_checks(loose_pair(tmp_path, 0.59))}[kc.Q_COLLAPSE_P]
    assert same.ours == pytest.approx(1.0, rel=1e-9)
    assert same.verdict == "equal" or same.verdict.startswith("within"), same.verdict
    assert "over the 2 loose-zone bins of the higher φ̄" in same.note
    # p_φ 1.5 times higher at the higher φ̄: not a function of φ alone
    apart = {c.quantity: c for c in kc.kinetic_checks(loose_pair(tmp_path / "apart", 0.59, 1.5))}[kc.Q_COLLAPSE_P]
    assert apart.ours == pytest.approx(1.5, rel=1e-9) and apart.verdict.startswith("one sample: off by +50.0 %")


def loose_bins(I, phi):
    """A stand-in analysis holding only loose-zone bins (x from 2 d_p) with I and φ (errors 1e-3)."""
    from types import SimpleNamespace

    n = len(I)
    folded = pd.DataFrame({"x": 2.0 + np.arange(n), "phi": phi, "phi_se": np.full(n, 1e-3)})
    return SimpleNamespace(folded=folded, rheo=pd.DataFrame({"I": I}),
                           zones=SimpleNamespace(labels=np.array(["loose"] * n, dtype=object)))


def test_phi_of_i_collapses_in_the_loose_zone():
    # 0.64 − φ = 0.1 √I at both φ̄ (a power law: straight on fig. 11(b)'s log-log axes, so the interpolation
    # in ln I is exact); the higher φ̄'s I = 0.4 and 0.15 lie within the lower's 0.1-0.5
    I_low, I_high = np.array([0.5, 0.3, 0.2, 0.1]), np.array([0.4, 0.15, 0.05])
    low = loose_bins(I_low, 0.64 - 0.1 * np.sqrt(I_low))
    same = kc.phi_of_i_ratio(loose_bins(I_high, 0.64 - 0.1 * np.sqrt(I_high)), low)
    assert same["ratio"] == pytest.approx(1.0, rel=1e-12) and same["n"] == 2   # I = 0.05 is outside: left out
    apart = kc.phi_of_i_ratio(loose_bins(I_high, 0.64 - 0.2 * np.sqrt(I_high)), low)
    assert apart["ratio"] == pytest.approx(2.0, rel=1e-12)
    # errors: φ's 1e-3 over 0.64 − φ ≈ 0.04-0.07, three bins' worth per point, two points
    assert 0.01 < same["se"] < 0.05
    from types import SimpleNamespace
    row = kc.phi_of_i_check(SimpleNamespace(analysis=low),
                            SimpleNamespace(analysis=loose_bins(I_high, 0.64 - 0.2 * np.sqrt(I_high))), "a vs b", "a, b")
    assert row.ours == pytest.approx(2.0) and row.verdict.startswith("one sample: off by +100.0 %"), row.verdict


def test_the_phi_of_i_row_is_judged(tmp_path):
    cases = loose_pair(tmp_path, 0.59)
    row = {c.quantity: c for c in kc.kinetic_checks(cases)}[kc.Q_PHI_I]
    low, high = (c.analysis for c in cases)
    assert row.ours == pytest.approx(kc.phi_of_i_ratio(high, low)["ratio"], rel=1e-12)
    assert row.paper_range == (1.0, 1.0) and row.kind == "comparison" and "equal I" in row.quantity


def test_the_sigma_xy_balance_takes_the_flows_acceleration(tmp_path):
    """σ_xy built as (1 − a/g) g∫ρ dx, the balance of a flow speeding up at a = 0.02 g, with u_cm rising at that
    rate over the window: b/(1 − a/g) = 1; without u_cm in thermo.csv, b alone (0.98)."""
    n = 301
    t = np.arange(n) * 1.0
    thermo = pd.DataFrame({"Step": np.arange(n) * 100, "Time": t, "stage": "average",
                           "v_ucm": 30.0 + 0.02 * t, "v_py": -1000.0 * (1.0 + 0.02 * t / 30.0)})
    profile = build_profile(sxy_factor=0.98)
    accelerating = {c.quantity: c for c in mc.case_more_checks(make_case(tmp_path, "a", profile, thermo=thermo))}
    assert accelerating[mc.Q_SXY].ours == pytest.approx(1.0, rel=1e-6)
    assert "a = 0.02 ± " in accelerating[mc.Q_SXY].note
    plain = {c.quantity: c for c in mc.case_more_checks(make_case(tmp_path, "b", profile,
                                                                  thermo=thermo.drop(columns=["v_ucm"])))}
    assert plain[mc.Q_SXY].ours == pytest.approx(0.98, rel=1e-6)


def test_u_cm_fluctuates_by_1_to_2_percent_at_the_papers_phi_max(tmp_path):
    """At φ̄ = 0.62 the paper sees u_cm fluctuate by 1–2 % (below 0.62 less than 1 %): the row's range follows φ̄,
    and above 0.62 (no flow in the paper) there is no row."""
    def row(name, fluctuation):
        case = make_case(tmp_path, name, build_profile(), phi_mean=float(name.split("~")[-1]),
                         thermo=thermo_with(fluctuation))
        found = [c for c in mc.case_more_checks(case) if c.quantity == mc.Q_UCM]
        return found[0] if found else None

    at_max = row("W~30/phi~0.62", 0.015)
    assert at_max.paper_range == mc.UCM_AT_PHI_MAX and at_max.verdict == "within the paper's range"
    assert row("W~30/phi~0.620", 0.004).verdict.startswith("one sample: off")   # too steady for 0.62
    assert row("W~30/phi~0.60", 0.004).paper_range == (0.0, mc.UCM_BOUND)
    assert row("W~30/phi~0.63", 0.004) is None

