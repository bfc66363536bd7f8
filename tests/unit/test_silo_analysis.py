"""Known-answer tests of the silo analysis (Rubio-Largo, Maza & Hidalgo 2016).

Every input is synthetic with a known answer: compound-Poisson deleted mass
(particles of random mass leaving at random times, like the real counter),
a linearly falling free surface, plateaus with ramps, Beverloo rates with
known C and k, the sqrt(1 - (r/R)^2) orifice profile, a Gaussian kinetic-
pressure bump.  SI units; seeded.
"""
from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from numpy.testing import assert_allclose

from granflow.scenes.silo import analysis as silo

RHO_P, PHI_B, G = 7520.0, 0.60, 10.0
R_B = 1.0 / 64
R_C = 20 * R_B
D_MEAN = 2 * R_B * np.mean(np.arange(10, 17) / 16)


# --------------------------------------------------------------------------- flow rates
def poisson_thermo(rng, rate_particles=400.0, T=4.0, dt=2e-3, m_range=(0.02, 0.06)) -> tuple[pd.DataFrame, float]:
    """Cumulative deleted mass of particles leaving as a Poisson process; returns (thermo, true rate kg/s)."""
    n = rng.poisson(rate_particles * T)
    times = np.sort(rng.uniform(0, T, n))
    masses = rng.uniform(*m_range, n)
    t = np.arange(0.0, T, dt)
    m_del = np.concatenate([[0.0], np.cumsum(masses)])[np.searchsorted(times, t, side="right")]
    return pd.DataFrame(dict(Time=t, v_mdel=m_del, v_mins=0.0, v_zs=1.0)), rate_particles * np.mean(m_range)


def test_flow_rate_of_a_counting_process_is_within_its_error():
    thermo, W_true = poisson_thermo(np.random.default_rng(11))
    flow = silo.flow_rates(thermo, RHO_P, PHI_B, R_C, window=0.2)
    assert len(flow) == 19  # samples span 3.998 s: the trailing partial window is dropped
    z = (flow["W_f"] - W_true) / flow["W_f_se"]
    # 19 windows: |z| < 4 fails with probability ~1e-3 if the errors are right
    assert np.all(np.abs(z) < 4)
    # and the errors are neither far too small nor far too large: the sample
    # std of 19 standard normals lies in [0.6, 1.45] with probability > 0.99
    assert 0.6 < np.std(z, ddof=1) < 1.45


def test_surface_rate_equals_bulk_flux():
    t = np.arange(0.0, 1.0, 1e-3)
    v = 0.03  # m/s, surface falling
    thermo = pd.DataFrame(dict(Time=t, v_mdel=0.0, v_zs=0.8 - v * t))
    flow = silo.flow_rates(thermo, RHO_P, PHI_B, R_C, window=0.1)
    # exact line: round-off only
    assert_allclose(flow["W_r"], RHO_P * PHI_B * np.pi * R_C ** 2 * v, rtol=1e-9)
    assert_allclose(flow["W_r_se"], 0.0, atol=1e-9)


def test_surface_rate_with_reinsertion_adds_the_insertion_rate():
    # full re-insertion: the surface holds still, the inserted mass grows at 2 kg/s
    t = np.arange(0.0, 1.0, 1e-3)
    thermo = pd.DataFrame(dict(Time=t, v_mdel=2.0 * t, v_mins=2.0 * t, v_zs=0.8))
    flow = silo.flow_rates(thermo, RHO_P, PHI_B, R_C, window=0.1)
    assert_allclose(flow["W_r"], 2.0, rtol=1e-9)
    assert_allclose(flow["W_f"], 2.0, rtol=1e-9)


def test_noisy_surface_rate_within_error():
    rng = np.random.default_rng(5)
    t = np.arange(0.0, 2.0, 2e-3)
    v = 0.02
    thermo = pd.DataFrame(dict(Time=t, v_mdel=0.0, v_zs=0.8 - v * t + 2e-3 * rng.standard_normal(t.size)))
    flow = silo.flow_rates(thermo, RHO_P, PHI_B, R_C, window=0.25)
    z = (flow["W_r"] - RHO_P * PHI_B * np.pi * R_C ** 2 * v) / flow["W_r_se"]
    assert np.all(np.abs(z) < 4)  # 8 windows of independent noise: a 4-sigma excursion is ~5e-4 likely


def plateau_series(rng, noise=0.02):
    """Windowed rates: zero until 0.2 s, ramp to W0 by 0.5 s, plateau to 3 s, decline to 0 by 3.5 s."""
    t = np.arange(0.05, 4.0, 0.1)
    W0 = 10.0
    w = W0 * np.clip((t - 0.2) / 0.3, 0, 1) * np.clip((3.5 - t) / 0.5, 0, 1)
    return t, w * (1 + noise * rng.standard_normal(t.size))


def test_steady_window_finds_the_plateau():
    t, w = plateau_series(np.random.default_rng(3))
    t0, t1, reason = silo.steady_window(t, w, rel_tol=0.1, window=0.1)
    # the ramps pass within 10 % of the plateau over 0.1 x (0.3 or 0.5 s) = 0.03-0.05 s,
    # less than one window; the bounds are window edges: one window of slack
    assert abs(t0 - 0.5) <= 0.1 + 1e-9
    assert abs(t1 - 3.0) <= 0.1 + 1e-9
    assert "median" in reason


def test_steady_window_stops_where_the_silo_runs_low():
    t, w = plateau_series(np.random.default_rng(3))
    fill = 1.0 - 0.3 * t  # m; below 0.4 m after t = 2 s
    t0, t1, reason = silo.steady_window(t, w, rel_tol=0.1, window=0.1, fill_height=fill, min_fill_height=0.4)
    assert abs(t1 - 2.0) <= 0.1 + 1e-9
    assert "fill height" in reason


def test_steady_window_ignores_isolated_outliers():
    # a long plateau with two single-window spikes (a burst, a hiccup): the
    # running median removes them, so the plateau is not split
    t = np.arange(0.05, 20.0, 0.1)
    w = np.where(t < 1.0, 10 * t, 10.0) * (1 + 0.02 * np.random.default_rng(8).standard_normal(t.size))
    w[60], w[120] = 15.0, 4.0
    t0, t1, reason = silo.steady_window(t, w, rel_tol=0.1, window=0.1)
    # the band admits rates down to (1 - 0.1)/(1 + 0.1) = 0.82 of the plateau,
    # which the ramp 10 t reaches in the window centred at 0.85 s (edge 0.8 s);
    # noise moves this by at most one window
    assert abs(t0 - 0.8) <= 0.1 + 1e-9 and abs(t1 - 20.0) <= 0.1 + 1e-9
    # without smoothing the spikes split the plateau; the longest clean stretch
    # is the one after the second spike (79 windows, against 59 between them)
    t0, t1, _ = silo.steady_window(t, w, rel_tol=0.1, window=0.1, smooth=1)
    assert abs(t0 - 12.1) < 1e-9 and abs(t1 - 20.0) < 1e-9


@pytest.mark.parametrize("w, words", [(1.3 ** np.arange(20), "common level"),  # runaway, no plateau
                                      (np.zeros(20), "no outflow"),
                                      (np.array([1.0, 1.0]), "usable windows")])
def test_steady_window_refuses(w, words):
    t0, t1, reason = silo.steady_window(0.1 * np.arange(len(w)), w, rel_tol=0.1)
    assert np.isnan(t0) and np.isnan(t1)
    assert words in reason


def test_steady_flow_rate_recovers_the_rate():
    thermo, W_true = poisson_thermo(np.random.default_rng(17), T=6.0)
    W, W_se = silo.steady_flow_rate(thermo, 1.0, 5.0, n_blocks=8)
    # block error with 7 degrees of freedom: |t| < 5.4 with probability 0.999
    assert abs(W - W_true) < 5.4 * W_se
    # the error is of the size the counting statistics give: se^2 ~ E[m^2] rate / T
    expected = np.sqrt(400.0 * np.mean(np.random.default_rng(0).uniform(0.02, 0.06, 100000) ** 2) / 4.0)
    assert 0.3 * expected < W_se < 3 * expected
    with pytest.raises(ValueError, match="no steady window"):
        silo.steady_flow_rate(thermo, np.nan, np.nan)


# --------------------------------------------------------------------------- Beverloo
C_TRUE, K_TRUE = 0.58, 1.5


def beverloo_data(rng, n_R=(6, 8, 10, 12, 14, 16), rel_noise=0.01):
    D = 2 * R_B * np.asarray(n_R, dtype=float)
    W = silo.beverloo_law(D, C_TRUE, K_TRUE, RHO_P * PHI_B, G, D_MEAN)
    W_se = rel_noise * W
    return D, W + W_se * rng.standard_normal(D.size), W_se


def test_beverloo_fit_recovers_C_and_k():
    D, W, W_se = beverloo_data(np.random.default_rng(1961))
    fit = silo.beverloo_fit(D, W, W_se, RHO_P * PHI_B, G, D_MEAN)
    # 3 standard errors: a two-parameter fit with Gaussian errors misses by more ~0.3 % of the time
    assert abs(fit["C"] - C_TRUE) < 3 * fit["C_se"]
    assert abs(fit["k"] - K_TRUE) < 3 * fit["k_se"]
    assert fit["n"] == 6 and fit["dof"] == 4
    assert 0.0 < fit["chi2_dof"] < 5.0  # chi2 with 4 dof / 4 exceeds 5 with probability 5e-4
    # the linearisation is a straight line through D = k d
    assert fit["linear"]["r2"] > 0.999
    assert abs(fit["linear"]["D0"] - K_TRUE * D_MEAN) < 5 * fit["k_se"] * D_MEAN


def test_beverloo_exact_data_unweighted():
    D, _, _ = beverloo_data(np.random.default_rng(0))
    W = silo.beverloo_law(D, C_TRUE, K_TRUE, RHO_P * PHI_B, G, D_MEAN)
    fit = silo.beverloo_fit(D, W, None, RHO_P * PHI_B, G, D_MEAN)
    assert_allclose([fit["C"], fit["k"]], [C_TRUE, K_TRUE], rtol=1e-6)  # optimiser tolerance
    lin = silo.beverloo_linearised(D, W)
    assert_allclose(lin["D0"], K_TRUE * D_MEAN, rtol=1e-10)  # exact straight line


@pytest.mark.parametrize("D", [[0.2, 0.3], [0.2, 0.2, 0.3, 0.3]])
def test_beverloo_refuses_fewer_than_three_sizes(D):
    W = silo.beverloo_law(np.asarray(D), C_TRUE, K_TRUE, RHO_P * PHI_B, G, D_MEAN)
    with pytest.raises(ValueError, match="at least 3 orifice sizes"):
        silo.beverloo_fit(D, W, 0.01 * W, RHO_P * PHI_B, G, D_MEAN)


# --------------------------------------------------------------------------- orifice profiles
def orifice_table(R: float, v0: float, phi0: float, r_nodes=None) -> pd.DataFrame:
    r = np.arange(0, 2 * R, R / 12) if r_nodes is None else r_nodes
    z = np.array([-0.004, 0.001, 0.006, 0.011])
    rr, zz = (a.ravel() for a in np.meshgrid(r, z, indexing="ij"))
    x = rr / R
    u_z = np.where(x < 1, -v0 * np.sqrt(np.clip(1 - x ** 2, 0, None)), 0.0) * (1 + 5 * np.abs(zz - 0.001))
    phi = phi0 * (1 - 0.2 * np.clip(x, 0, 1) ** 2) * (1 + 3 * np.abs(zz - 0.001))
    return pd.DataFrame(dict(r=rr, z=zz, phi=phi, phi_se=0.01, u_z=u_z, u_z_se=0.02))


def test_orifice_profiles_of_the_sqrt_profile():
    R, v0, phi0 = 12 * R_B, 1.2, 0.52
    o = silo.orifice_profiles(orifice_table(R, v0, phi0), R)
    assert o["z_row"] == 0.001                      # the row nearest z = 0
    assert o["sqrt_profile_deviation"] < 1e-12      # exact profile: round-off only
    assert o["n_deviation"] == 11                   # nodes r = 0 .. 10 R/12 < 0.9 R
    assert_allclose([o["phi_c"], o["v_c"]], [phi0, v0], rtol=1e-12)
    p = o["profile"]
    assert_allclose(p["phi_norm"], 1 - 0.2 * np.clip(p["r_over_R"], 0, 1) ** 2, rtol=1e-12)


def test_orifice_profiles_detects_a_flat_profile():
    R = 12 * R_B
    table = orifice_table(R, 1.0, 0.5)
    table["u_z"] = -1.0  # plug flow
    o = silo.orifice_profiles(table, R)
    x = np.arange(0, 0.9, 1 / 12)
    assert_allclose(o["sqrt_profile_deviation"], np.sqrt(np.mean((1 - np.sqrt(1 - x ** 2)) ** 2)), rtol=1e-12)


def test_scaled_flow_rate_of_the_self_similar_profile_is_two_thirds():
    # W = rho_p phi v0 int_0^R sqrt(1-(r/R)^2) 2 pi r dr = rho_p phi v0 pi R^2 * 2/3
    R, v0, phi = 0.2, 1.1, 0.55
    W = RHO_P * phi * v0 * np.pi * R ** 2 * 2 / 3
    assert_allclose(silo.scaled_flow_rate(W, RHO_P, phi, v0, R), 2 / 3, rtol=1e-14)


def test_velocity_scaling_fit():
    R = np.array([6, 8, 12, 16]) * R_B
    fit = silo.velocity_scaling_fit(R, 2.5 * np.sqrt(R), 0.01 * np.ones(4))
    assert_allclose(fit["a"], 2.5, rtol=1e-12)


# --------------------------------------------------------------------------- axis and kinetic pressure
def kinetic_table(z0=0.123, s=0.04, dz=R_B / 2, species=7, rng=None) -> pd.DataFrame:
    r = np.arange(0, 6) * dz
    z = np.arange(-2, 40) * dz
    rr, zz = (a.ravel() for a in np.meshgrid(r, z, indexing="ij"))
    pk = 30 * np.exp(-(zz - z0) ** 2 / (2 * s ** 2)) * np.exp(-rr ** 2 / (4 * dz) ** 2) + 0.5
    out = dict(r=rr, z=zz, pk=pk, pk_se=0.01 * pk)
    rng = rng or np.random.default_rng(0)
    frac = rng.dirichlet(np.ones(species), size=len(rr))
    for k in range(species):
        out[f"pk_s{k + 1}"] = pk * frac[:, k]
        out[f"pk_s{k + 1}_se"] = 0.01 * pk * frac[:, k]
        out[f"phi_s{k + 1}"] = 0.6 / species * (1 + 0.1 * k)
    return pd.DataFrame(out)


def test_axis_profile_nearest_and_area_weighted():
    table = kinetic_table()
    ax = silo.axis_profile(table, "pk")
    on_axis = table[table["r"] == 0].sort_values("z")
    assert_allclose(ax["value"], on_axis["pk"], rtol=1e-15)
    table["flat"] = 3.0 + table["z"]  # independent of r: any weighted mean returns it
    assert_allclose(silo.axis_profile(table, "flat", r_max=0.02)["value"], 3.0 + ax["z"], rtol=1e-14)
    assert silo.axis_profile(table, "missing")["value"].isna().all()


def test_transition_height_of_a_gaussian_bump():
    dz = R_B / 2
    z0 = 0.123  # not on a node
    ax = silo.axis_profile(kinetic_table(z0=z0, dz=dz), "pk")
    h, h_se = silo.transition_height(ax["z"], ax["value"])
    # the 0.5 Pa floor spoils the exact log-parabola only slightly (measured
    # 3e-5 dz); a twentieth of the node spacing is the claim
    assert abs(h - z0) < 0.05 * dz
    assert h_se < 0.05 * dz  # five-point parabola through a nearly Gaussian peak: tiny residuals


@pytest.mark.parametrize("width", [2.0, 3.0, 5.0])
def test_transition_height_of_a_lorentzian_peak(width):
    # not a Gaussian: the log-parabola is only a local approximation; over
    # peak positions across a node interval the error stays below 0.021 dz
    # (measured, width 2 dz); 0.05 dz is the claim
    z = np.arange(40.0)
    for z0 in np.linspace(15, 16, 11):
        h, _ = silo.transition_height(z, 1 / (1 + ((z - z0) / width) ** 2))
        assert abs(h - z0) < 0.05


def test_transition_height_with_noise_and_its_error():
    dz = R_B / 2
    z = np.arange(0, 40) * dz
    z0, s = 0.2, 0.05
    rng = np.random.default_rng(42)
    pk = 20 * np.exp(-(z - z0) ** 2 / (2 * s ** 2))
    se = 0.03 * pk + 0.01
    h, h_se = silo.transition_height(z, pk + se * rng.standard_normal(z.size), se, seed=1)
    assert 0 < h_se < dz
    assert abs(h - z0) < 4 * h_se + 0.05 * dz  # resampling error plus the interpolation bias
    # resampling is seeded: the same call gives the same error
    assert silo.transition_height(z, pk, se, seed=1)[1] == silo.transition_height(z, pk, se, seed=1)[1]


def test_transition_height_at_the_edge_is_not_resolved():
    z = np.linspace(0.01, 0.3, 20)
    h, h_se = silo.transition_height(z, np.exp(-z / 0.05))
    assert h == z[0] and np.isnan(h_se)
    # nodes at or below the orifice plane do not count
    h, _ = silo.transition_height(np.r_[-0.02, z], np.r_[1e3, np.exp(-(z - 0.1) ** 2 / 0.001)])
    assert abs(h - 0.1) < 0.2 * (z[1] - z[0])


def test_cumulative_kinetic_pressure_ends_at_the_total():
    table = kinetic_table()
    cum = silo.cumulative_kinetic_pressure(table)
    assert_allclose(cum["pk_cum_s1"], table["pk"], rtol=1e-12)         # sum of the partials
    assert_allclose(cum["pk_cum_s7"], table["pk_s7"], rtol=0)           # largest size alone
    steps = np.diff(cum[[f"pk_cum_s{s}" for s in range(1, 8)]].to_numpy(), axis=1)
    assert np.all(steps <= 1e-12)                                       # fewer sizes, less pressure


def test_partial_over_fraction():
    table = kinetic_table()
    table.loc[:5, "phi_s3"] = 1e-5  # no particles of size 3 there
    out = silo.partial_over_fraction(table)
    assert_allclose(out["pk_over_phi_s1"], table["pk_s1"] / table["phi_s1"], rtol=1e-15)
    assert out.loc[:5, "pk_over_phi_s3"].isna().all()
    assert out.loc[6:, "pk_over_phi_s3"].notna().all()
