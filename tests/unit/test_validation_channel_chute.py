"""The channel's and the chute's validation checks on tiny hand-made case directories.

Each case directory holds what the scene's analysis writes (params.json, run/status.json,
run/thermo.csv, analysis/scalars.json, analysis/profile.csv) with known numbers; the
time-average errors, which the record measures from the dumps, are replaced by known ones.
"""
from __future__ import annotations

import json
import math

import numpy as np
import pandas as pd
import pytest
from numpy.testing import assert_allclose

import granflow.scenes.channel.validation as chv
from granflow import headline
import granflow.scenes.chute.validation as cuv
from granflow.scenes.channel.analysis import JOP2015


def _write(case, record, status, scalars=None, profile=None, thermo=None):
    (case / "run").mkdir(parents=True)
    (case / "analysis").mkdir()
    (case / "params.json").write_text(json.dumps(record))
    (case / "run" / "status.json").write_text(json.dumps(status))
    if scalars is not None:
        (case / "analysis" / "scalars.json").write_text(json.dumps(scalars))
    if profile is not None:
        profile.to_csv(case / "analysis" / "profile.csv", index=False)
    if thermo is not None:
        thermo.to_csv(case / "run" / "thermo.csv", index=False)
    return case


def _fake_errors(values: dict):
    """A stand-in for measure_with_errors: known errors per headline key, and no dumps read."""
    def measure(scene, case_dir, record, t_average, n_blocks=4):
        assert (case_dir / "run" / "status.json").exists()
        out = {key: {"x": math.nan, "se": se, "se_method": "autocorrelation", "se_block": se, "g": 1.5,
                     "n_series": 16, "reliable": False, "n_blocks": n_blocks} for key, se in values.items()}
        out["window"] = [0.0, t_average]
        return out
    return measure


# =========================================================================== channel
W = 20.0
WEIGHT = 1000.0


def channel_profile() -> pd.DataFrame:
    """Symmetric profile, walls at 0 and W: the eq. 3.1 velocity (u_slip 1, u_max 1.4, delta 5), phi
    exactly 0.63 from 4 d_p into the plug, flat sigma_xx and the momentum-balance sigma_xy."""
    e = np.concatenate([[0.0], np.arange(1.5, W - 1.5 + 0.5, 1.0), [W]])
    x = 0.5 * (e[:-1] + e[1:])
    xw = np.minimum(x, W - x)
    u = 1.0 + 0.4 * (1.0 - np.exp(-3.0 * xw / 5.0))
    phi = np.where(xw >= 4.0, 0.63, 0.55 + 0.02 * xw)
    zero = np.zeros(len(x))
    df = pd.DataFrame(dict(x=x, x_lo=e[:-1], x_hi=e[1:], n=np.full(len(x), 100.0), phi=phi, rho=phi,
                           u_x=zero, u_y=-u, u_z=zero, T=1e-3 + zero, sigma_xx=50.0 + zero,
                           sigma_xy=-0.6 * (x - W / 2), sigma_yy=50.0 + zero))
    for col in [c for c in df.columns if c not in ("x", "x_lo", "x_hi")]:
        # u_y's error sets the plug (shear rate within 2 errors of zero): 1e-2 puts its edge at ~4 d_p
        df[f"{col}_se"] = 1e-2 if col == "u_y" else 1e-3
    return df


def channel_case(tmp_path, name, status="steady", ratio=1.38, exponent=2.95, overlap=0.004,
                 wall_force_mean=1002.0, ucm_change=0.0):
    record = {"rung": "validation", "dt": 1.5e-4,
              "parameters": {"W": W, "phi_mean": 0.6, "n_particles": 1200, "t_c_min": 0.0019},
              "rung_knobs": {"W": W, "B": 5.0, "H": 12.0, "k_n": 1.0e6, "t_average": 300.0, "t_flow_max": 1500.0},
              "protocol": {"steady_rel_tol": 0.02, "steady_fluct_tol": 0.05, "steady_window": 100.0}}
    steady = status == "steady"
    st = {"status": status, "reason": "flat u_cm" if steady else "drift 6.5 % over the last 100",
          "dumps": ["dump_001.bin"] if steady else [], "max_overlap": overlap,
          "steady": {"t_start": 500.0 if steady else math.nan, "rel_fluct": 0.01}}
    scalars = {"status": status, "ratio": ratio, "u_slip": 1.0, "u_max": 1.0 * ratio, "fit_exponent": exponent,
               "fit_r2": 0.99, "fit_r2_a3": 0.98, "delta_095": 5.0, "delta_095_over_W": 0.25,
               "momentum_steady_residual": wall_force_mean / WEIGHT - 1.0, "momentum_residual": 1e-7,
               "weight": WEIGHT}
    rng = np.random.default_rng(7)
    n = 201
    thermo = pd.DataFrame({"Step": np.arange(n) * 1000, "Time": np.arange(n) * 1.0,
                           "f_fwavg": wall_force_mean + 5.0 * rng.standard_normal(n), "stage": "average",
                           # u_cm about 30 √(g d_p), changing by ucm_change of it over the 200 of the window
                           "v_ucm": 30.0 * (1 + ucm_change * (np.arange(n) - 100) / 200)
                                    + 0.1 * rng.standard_normal(n)})
    return _write(tmp_path / name, record, st, scalars if steady else {"status": status},
                  channel_profile() if steady else pd.DataFrame(columns=["x", "x_lo", "x_hi"]), thermo)


@pytest.fixture
def channel_errors(monkeypatch):
    monkeypatch.setattr(headline, "measure_with_errors",
                        _fake_errors({"u_ratio": 0.01, "eq31_exponent": 0.05, "delta_over_W": 0.004,
                                      "sigma_xx_over_W": 0.01}))


def _by(checks, case, quantity_start):
    found = [c for c in checks if c.case == case and c.quantity.startswith(quantity_start)]
    assert len(found) == 1, (case, quantity_start, [c.quantity for c in checks])
    return found[0]


def test_channel_ratio_inside_and_outside_the_papers_range(tmp_path, channel_errors):
    cases = {"W~20/phi~0.6": channel_case(tmp_path, "a", ratio=1.38),
             "W~20/phi~0.61": channel_case(tmp_path, "b", ratio=1.21, overlap=0.012)}
    result = chv.validation(tmp_path, cases)
    inside = _by(result.checks, "W~20/phi~0.6", "u_max/u_slip")
    assert inside.paper_range == (1.37, 1.40) and inside.verdict == "within the paper's range"
    assert inside.error == 0.01 and "error: autocorrelation standard error" in inside.note
    outside = _by(result.checks, "W~20/phi~0.61", "u_max/u_slip")
    assert outside.difference == pytest.approx(1.21 / 1.37 - 1.0)     # -11.7 %
    assert outside.verdict.startswith("one sample: off by -11.7 %")  # one replicate: no "differs"
    # the exponent: 2.95 +- 0.05 against eq. 3.1's 3 is 1 sigma
    exponent = _by(result.checks, "W~20/phi~0.6", "eq. 3.1 exponent")
    assert exponent.paper_range == (3.0, 3.0) and exponent.verdict == "within error (1.0 σ)"
    # delta/W: the paper gives it only in a figure, so no number is compared
    delta = _by(result.checks, "W~20/phi~0.6", "δ0.95/W")
    assert delta.paper_range is None and delta.ours == 0.25 and "fig. 5(d)" in delta.note
    # the overlap above 1 % is said, with what it does
    assert any("phi~0.61: largest overlap 1.2 %" in d and "above the 1 % limit" in d for d in result.differences)
    assert any("B = 5 d_p (paper: 40)" in d for d in result.differences)


def test_channel_plug_and_momentum_balance(tmp_path, channel_errors):
    result = chv.validation(tmp_path, {"c": channel_case(tmp_path, "c", wall_force_mean=1002.0)})
    plug = _by(result.checks, "c", "φ in the plug")
    # phi is exactly 0.63 beyond 4 d_p and the plug starts beyond it: the paper's 0.63
    assert plug.ours == pytest.approx(0.63) and plug.verdict in ("equal", "within error (0.0 σ)")
    # folding averages mirrored bins: a 1e-3 error becomes 1e-3/sqrt(2), the centre bin (19 bins) keeps 1e-3;
    # the plug's error is the mean over its bins, so it lies between the two
    assert 1e-3 / math.sqrt(2) < plug.error < 1e-3
    balance = _by(result.checks, "c", "wall shear force / weight")
    assert balance.ours == pytest.approx(1.002) and balance.paper_range == (1.0, 1.0)
    # white noise of 5 over 200 intervals: se = 5/sqrt(200)/1000 (g >= 1 and close to 1)
    naive = 5.0 / math.sqrt(200) / WEIGHT
    assert naive * 0.8 < balance.error < naive * 2.0
    assert balance.verdict.startswith("one sample: off by +0.2 %")


def test_channel_profiles_are_small_and_scaled(tmp_path, channel_errors):
    result = chv.validation(tmp_path, {"c": channel_case(tmp_path, "c")})
    vel = result.profiles["velocity_scaled"]
    assert_allclose(vel["u_scaled"].iloc[0], 0.0, atol=1e-12)   # the wall bin defines u_slip
    assert {"x_over_delta", "x_over_W", "eq31", "u_scaled_se"} <= set(vel.columns)
    rheo = result.profiles["rheology_points"]
    assert {"I", "mu", "mu_B3", "phi", "phi_B4", "zone", "case"} <= set(rheo.columns)
    for table in result.profiles.values():
        assert len(table.to_csv(index=False)) < 50_000
    assert result.figures == ["fig04_velocity", "fig05c_ratio", "fig11_rheology", "fig_steadiness_plug"]


def test_channel_case_without_a_steady_state_gives_nan_and_the_reason(tmp_path, monkeypatch):
    def no_dumps(*args, **kwargs):
        raise AssertionError("a case without a steady state must not be measured")

    monkeypatch.setattr(headline, "measure_with_errors", no_dumps)
    result = chv.validation(tmp_path, {"W~20/phi~0.6": channel_case(tmp_path, "d", status="no_steady_state")})
    assert len(result.checks) == 11   # the six headlines, drift, plug structure, plug order, u_cm change, wall force
    for check in result.checks:
        assert math.isnan(check.ours) and math.isnan(check.error)
        assert "no_steady_state" in check.note
        assert check.verdict in ("not measured", "shape compared (see note)")
    assert result.profiles == {}
    assert any("no_steady_state" in d for d in result.differences)


def test_b3_and_b4_deviations_are_taken_over_one_zone():
    I = np.array([1e-3, 1e-2, 1e-1, 0.3, 0.5])
    points = pd.DataFrame({"zone": ["plug", "dense", "dense", "loose", "wall"], "I": I,
                           "mu": 1.1 * JOP2015.mu(I), "mu_B3": JOP2015.mu(I),
                           "phi": JOP2015.phi(I) - 0.02, "phi_B4": JOP2015.phi(I)})
    mu = chv.b3_deviation(points, "dense")
    assert mu["n"] == 2 and mu["rms"] == pytest.approx(0.1) and mu["mean"] == pytest.approx(0.1)
    assert (mu["I_min"], mu["I_max"]) == (1e-2, 1e-1)
    phi = chv.b4_deviation(points, "loose")
    assert phi["n"] == 1 and phi["rms"] == pytest.approx(0.02) and phi["mean"] == pytest.approx(-0.02)
    assert chv.b4_deviation(points.iloc[:0], "loose")["n"] == 0


# =========================================================================== chute
Z_BASE, Z_SURFACE = 2.5, 32.5


def chute_profile(theta: float, phi_bulk: float, weight_factor: float = 1.01) -> pd.DataFrame:
    """Bins of 1 d from 0 to 36 d: a bed of uniform phi between the base top and the surface, the weight
    above it, sigma_zz = weight_factor x weight with a 2 % error, the exact shear stress and a Bagnold u."""
    z = np.arange(36) + 0.5
    phi = np.where((z > Z_BASE) & (z < Z_SURFACE), phi_bulk, 0.0)
    rho = phi * 6.0 / math.pi
    weight = math.cos(math.radians(theta)) * (np.cumsum(rho[::-1])[::-1] - 0.5 * rho)
    h = Z_SURFACE - Z_BASE
    u = np.where(phi > 0, 0.1 * (h**1.5 - np.clip(h - (z - Z_BASE), 0, None) ** 1.5), np.nan)
    return pd.DataFrame({"z": z, "z_lo": z - 0.5, "z_hi": z + 0.5, "phi": phi, "phi_se": 1e-3, "rho": rho,
                         "u_x": u, "u_x_se": 0.01, "sigma_zz": weight_factor * weight,
                         "sigma_zz_se": 0.02 * weight, "sigma_xz": -math.tan(math.radians(theta)) * weight,
                         "sigma_xz_se": 0.02 * weight, "weight_above": weight, "u_bagnold": u,
                         "stress_ratio": math.tan(math.radians(theta))})


def chute_case(tmp_path, name, theta, status="steady", phi_bulk=0.57, ratio_over_tan=0.99, overlap=0.008):
    tan = math.tan(math.radians(theta))
    record = {"rung": "validation", "dt": 4e-4,
              "parameters": {"theta_deg": theta, "n_particles": 3600, "t_c_min": 0.005, "xi_n": 50.0, "xi_t": 0.0,
                             "friction": 0.5, "base_height": Z_BASE},
              "rung_knobs": {"Lx": 10.0, "Ly": 10.0, "H": 30.0, "k_n": 2.0e5, "t_average": 150.0,
                             "t_flow_max": 600.0, "bulk_margin": 4.0},
              "protocol": {"steady_rel_tol": 0.03, "steady_fluct_tol": 0.05, "steady_window": 50.0}}
    steady = status == "steady"
    st = {"status": status, "reason": "flat u_cm" if steady else "u_cm still rising",
          "dumps": ["dump_001.bin"] if steady else [], "max_overlap": overlap}
    scalars = {"status": status, "theta": theta, "tan_theta": tan, "z_base": Z_BASE, "z_surface": Z_SURFACE,
               "bulk_lo": Z_BASE + 4, "bulk_hi": Z_SURFACE - 4, "n_bulk_bins": 22, "phi_bulk": phi_bulk,
               "stress_ratio": ratio_over_tan * tan, "stress_ratio_se": 0.004, "weight_residual": 0.0101,
               "bagnold_A": 0.1, "bagnold_r2": 0.998, "bagnold_rel_rms": 0.012, "bagnold_H": Z_SURFACE - Z_BASE}
    return _write(tmp_path / name, record, st, scalars if steady else {"status": status},
                  chute_profile(theta, phi_bulk) if steady else None)


@pytest.fixture
def chute_errors(monkeypatch):
    monkeypatch.setattr(headline, "measure_with_errors",
                        _fake_errors({"stress_ratio_over_tan": 0.004, "bagnold_A": 0.001, "phi_bulk": 0.002}))


def test_chute_momentum_balance_checks(tmp_path, chute_errors):
    result = cuv.validation(tmp_path, {"theta~22": chute_case(tmp_path, "a", 22.0, ratio_over_tan=0.99)})
    ratio = _by(result.checks, "theta~22", "bulk -σ_xz/σ_zz / tan θ")
    assert ratio.ours == pytest.approx(0.99) and ratio.error == 0.004
    assert ratio.verdict.startswith("one sample: off by -1.0 %")            # 0.01 off is 2.5 sigma
    weight = _by(result.checks, "theta~22", "σ_zz / weight above")
    # sigma_zz is 1.01 x the weight in every bulk bin, each with a 2 % error
    assert weight.ours == pytest.approx(0.01) and weight.error == pytest.approx(0.02)
    assert weight.verdict == "within error (0.5 σ)"
    bagnold = _by(result.checks, "theta~22", "Bagnold profile")
    assert bagnold.ours == 0.998 and bagnold.paper_range is None and "1.20%" in bagnold.note
    phi = _by(result.checks, "theta~22", "bulk φ")
    assert phi.ours == 0.57 and phi.error == 0.002 and "spread by 0.000" in phi.note
    heights = result.profiles["height_profiles"]
    # bin centres from 4 d above the base top (6.5) to 4 d below the surface (28.5)
    assert heights["in_bulk"].sum() == 23 and {"u_x", "phi", "stress_ratio", "tan_theta"} <= set(heights.columns)
    assert len(heights.to_csv(index=False)) < 50_000
    assert result.figures == ["fig_profiles", "fig_stress", "fig_regimes"]


def test_chute_sweep_regimes_and_an_accelerating_case(tmp_path, chute_errors):
    cases = {"theta~22": chute_case(tmp_path, "a", 22.0, phi_bulk=0.58),
             "theta~25": chute_case(tmp_path, "b", 25.0, phi_bulk=0.56, overlap=0.02),
             "theta~30": chute_case(tmp_path, "c", 30.0, status="accelerating")}
    result = cuv.validation(tmp_path, cases)
    sweep = _by(result.checks, "sweep", "bulk φ(θ_max) - φ(θ_min)")
    assert sweep.ours == pytest.approx(-0.02) and sweep.error == pytest.approx(math.hypot(0.002, 0.002))
    assert "lower at the larger angle, as the paper" in sweep.note
    for check in (c for c in result.checks if c.case == "theta~30"):
        assert math.isnan(check.ours) and "accelerating" in check.note
    assert any(d.startswith("theta~30: regime accelerating") and d.endswith("as the paper") for d in result.differences)
    assert any(d.startswith("theta~22: regime steady") and d.endswith("as the paper") for d in result.differences)
    assert any("theta~25: largest overlap 2 %" in d and "above the 1 % limit" in d for d in result.differences)
    assert any("10 x 10 d periodic" in d for d in result.differences)


def test_chute_expected_regimes():
    assert [cuv.expected_regime(t) for t in (18, 22, 25, 30)] == \
        ["arrested", "steady", "steady or accelerating", "accelerating"]


def test_chute_sweep_needs_two_steady_angles(tmp_path, chute_errors):
    result = cuv.validation(tmp_path, {"theta~25": chute_case(tmp_path, "b", 25.0)})
    sweep = _by(result.checks, "sweep", "bulk φ")
    assert math.isnan(sweep.ours) and "needs two steady angles" in sweep.note


def test_chute_profile_departing_from_bagnold_near_base_and_surface(tmp_path, chute_errors):
    # the bulk scatters about the Bagnold fit by ±0.01; the 4 d above the base sit 0.1 below it, the 4 d below
    # the surface 0.05 above: the ratios are 10 and 5
    path = chute_case(tmp_path, "a", 22.0)
    profile = pd.read_csv(path / "analysis" / "profile.csv")
    z = profile["z"].to_numpy()
    wiggle = np.where(np.arange(len(z)) % 2 == 0, 0.01, -0.01)
    shift = np.where((z >= Z_BASE) & (z < Z_BASE + 4), -0.1, np.where((z > Z_SURFACE - 4) & (z <= Z_SURFACE), 0.05, wiggle))
    profile["u_x"] = profile["u_bagnold"] + shift
    profile.to_csv(path / "analysis" / "profile.csv", index=False)
    result = cuv.validation(tmp_path, {"theta~22": path})
    base, surface = _by(result.checks, "theta~22", cuv.Q_BAGNOLD_BASE), _by(result.checks, "theta~22", cuv.Q_BAGNOLD_SURFACE)
    assert base.ours == pytest.approx(10.0) and surface.ours == pytest.approx(5.0)
    assert base.verdict == surface.verdict == "within the paper's range"
    assert "3 d above the base: 10" in base.variants                          # the narrower zone, same shift
    # a profile that is Bagnold's up to the edges, closer to it there than in the bulk, does not depart: fails
    edges = (z < Z_BASE + 4) | (z > Z_SURFACE - 4)
    profile["u_x"] = profile["u_bagnold"] + np.where(edges, 2.5, 5.0) * wiggle           # ±0.025 and ±0.05, se 0.01
    profile.to_csv(path / "analysis" / "profile.csv", index=False)
    flat = _by(cuv.validation(tmp_path, {"theta~22": path}).checks, "theta~22", cuv.Q_BAGNOLD_BASE)
    assert flat.ours == pytest.approx(0.5) and flat.verdict.startswith("one sample: off")


def test_chute_regime_changes_are_bracketed_by_the_sweeps_angles(tmp_path, chute_errors):
    cases = {"theta~19": chute_case(tmp_path, "a", 19.0, status="arrested"),
             "theta~22": chute_case(tmp_path, "b", 22.0), "theta~25": chute_case(tmp_path, "c", 25.0),
             "theta~28": chute_case(tmp_path, "d", 28.0, status="accelerating")}
    result = cuv.validation(tmp_path, cases)
    stop, top = _by(result.checks, "sweep", cuv.Q_STOP), _by(result.checks, "sweep", cuv.Q_STEADY_TOP)
    gap = 3.0 / (2.0 * math.sqrt(3.0))                                        # a uniform spread over 3°
    # the sweep's spacing is a resolution, not noise: the gap's spread is the syst, which replicates do not narrow
    assert stop.ours == 20.5 and math.isnan(stop.error) and stop.syst == pytest.approx(gap)
    assert stop.paper_error == cuv.THETA_STOP_ERROR and top.ours == 26.5 and top.syst == pytest.approx(gap)
    assert stop.verdict.startswith("within the systematic error") and top.verdict.startswith("within")
    assert "between 19° and 22°" in stop.note and "between 25° and 28°" in top.note
    # a bed that stops at 23° where 25° flows: θ_stop 24 ± 0.58 against 20 ± 1 is off
    late = cuv.validation(tmp_path, {"theta~23": chute_case(tmp_path, "e", 23.0, status="arrested"),
                                     "theta~25": cases["theta~25"]})
    assert _by(late.checks, "sweep", cuv.Q_STOP).verdict.startswith("one sample: off")
    # without both regimes, or with them the wrong way round, nothing is bracketed
    alone = cuv.validation(tmp_path, {"theta~22": cases["theta~22"], "theta~25": cases["theta~25"]})
    assert math.isnan(_by(alone.checks, "sweep", cuv.Q_STOP).ours)
    assert "needs an arrested angle below a flowing one" in _by(alone.checks, "sweep", cuv.Q_STOP).note
    assert math.isnan(cuv.bracket([25.0], [22.0])[0]) and cuv.bracket([25.0], [22.0])[2] == ""


def test_the_plugs_q6_row_reads_the_paper_bound_with_its_variants_as_syst(tmp_path):
    def case(q6, inner, cut12, cut14, why=""):
        sc = {"plug_Q6": q6, "plug_Q6_se": 0.002, "plug_Q6_inner": inner, "plug_Q6_cut1.2": cut12,
              "plug_Q6_cut1.4": cut14, "plug_q6": 0.40, "x_dense_plug": 20.0}
        return chv.ChannelCase("W~60/phi~0.61", tmp_path, {}, {}, sc, why)

    random = chv.plug_order_check(case(0.04, 0.05, 0.045, 0.03))
    assert random.verdict == "within the paper's range" and random.paper_range == (0.0, 0.4)
    assert random.syst == pytest.approx(0.01, abs=2e-3)                  # the largest variant's shift, beyond stat
    crystal = chv.plug_order_check(case(0.55, 0.56, 0.55, 0.54))
    assert "off by" in crystal.verdict
    old = chv.plug_order_check(case(float("nan"), 0, 0, 0))
    assert math.isnan(old.ours) and "rerun analyse" in old.note
    assert "no_steady" in chv.plug_order_check(case(0.04, 0, 0, 0, why="no_steady_state")).note


def test_channel_ucm_change_across_the_window_against_the_papers_one_percent(tmp_path, channel_errors):
    """u_cm flat (noise 0.3 %) reads no change; rising 5 % across the window reads 5 %, beyond ± 1 %, and says it
    drifts more than half the steadiness tolerance per window (2.5 % per 100 against 2 %)."""
    result = chv.validation(tmp_path, {"flat": channel_case(tmp_path, "flat"),
                                       "rising": channel_case(tmp_path, "rising", ucm_change=0.05)})
    flat = _by(result.checks, "flat", "u_cm's change across the averaging window")
    assert abs(flat.ours) < 0.002 and flat.verdict == "within the paper's range"
    rising = _by(result.checks, "rising", "u_cm's change across the averaging window")
    assert rising.ours == pytest.approx(0.05, abs=0.002) and rising.paper_range == (-0.01, 0.01)
    assert rising.verdict.startswith("one sample: off by")
    assert "% against its tolerance 2%" in rising.note and "more than half of it" in rising.note
