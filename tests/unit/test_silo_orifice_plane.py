"""The kernel-free orifice reading (silo): synthetic particles with a known v_z(r) and phi."""
from types import SimpleNamespace

import numpy as np
import pytest

from granflow.scenes.silo.analysis.orifice import CORE_FRACTION, PlaneCrossing, bin_shape, shape_fit, sqrt_shape

R_B = 0.015625


def _frames(R, v_c, n_frames=60, n=6000, seed=3, radius=0.8 * R_B, z_half=2 * R_B, r_out=None):
    """Particles uniform in the cylinder r < r_out, |z| < z_half, falling at v_c sqrt(1 - (r/R)^2)."""
    rng = np.random.default_rng(seed)
    r_out = 1.5 * R if r_out is None else r_out
    mass = 7520 * 4 / 3 * np.pi * radius**3
    for step in range(n_frames):
        r = r_out * np.sqrt(rng.random(n))
        th = 2 * np.pi * rng.random(n)
        pos = np.column_stack([r * np.cos(th), r * np.sin(th), rng.uniform(-z_half, z_half, n)])
        vel = np.zeros((n, 3))
        vel[:, 2] = -v_c * sqrt_shape(r, R) * (1 + 0.05 * rng.standard_normal(n))
        yield SimpleNamespace(timestep=step, position=pos, velocity=vel, mass=np.full(n, mass),
                              volume=np.full(n, 4 / 3 * np.pi * radius**3))


@pytest.mark.parametrize("R_over_rb", [6.0, 12.0])
def test_a_prescribed_profile_is_recovered_at_every_slab(R_over_rb):
    R, v_c = R_over_rb * R_B, 1.3
    plane = PlaneCrossing(R, R_B, slab_halves=(0.5, 0.25, 1.0), n_blocks=6)
    for f in _frames(R, v_c):
        plane.accumulate(f)
    table, s = plane.conclude()
    for h in (0.5, 0.25, 1.0):
        # the shape fit gives v_c (downwards) within 3 of its errors and 1 %
        assert s[f"v_c_plane_h{h:g}"] == pytest.approx(-v_c, rel=0.01)
        assert abs(s[f"v_c_plane_h{h:g}"] + v_c) < 4 * s[f"v_c_plane_h{h:g}_se"] + 1e-3
        # the disc mean over r < R/4 of that shape is (2/3)(1 - (1 - a^2)^1.5)/a^2 of v_c
        a = CORE_FRACTION
        assert s[f"v_core_plane_h{h:g}"] == pytest.approx(-v_c * (2 / 3) * (1 - (1 - a * a) ** 1.5) / a**2, rel=0.02)
    assert s["v_c_plane"] == s["v_c_plane_h0.5"] and s["plane_slab_half"] == 0.5
    # the mass flux through the plane: rho phi times the integral of the profile over the orifice
    rho_phi = 7520 * 6000 * 4 / 3 * np.pi * (0.8 * R_B) ** 3 / (np.pi * (1.5 * R) ** 2 * 4 * R_B)
    W_true = rho_phi * v_c * 2 / 3 * np.pi * R**2
    for h in (0.5, 0.25, 1.0):
        assert s[f"W_plane_h{h:g}"] == pytest.approx(W_true, rel=0.03)
    # phi: the uniform cylinder's volume fraction, in every bin (particles counted where their centre is)
    n, radius = 6000, 0.8 * R_B
    phi_true = n * 4 / 3 * np.pi * radius**3 / (np.pi * (1.5 * R) ** 2 * 4 * R_B)
    assert s["phi_c_plane"] == pytest.approx(phi_true, rel=0.05)
    inner = table[(table["slab_half"] == 1.0) & (table["r_hi"] <= 1.4 * R)]
    assert np.average(inner["phi"], weights=inner["r_mid"]) == pytest.approx(phi_true, rel=0.03)
    # the profile itself: v_z(r)/v_c on the curve, bin by bin, within 4 errors (+1 % of v_c)
    row = table[(table["slab_half"] == 0.5) & (table["r_over_R"] < 0.9)]
    expect = -v_c * bin_shape(row["r_lo"], row["r_hi"], R)
    assert np.all(np.abs(row["vz"] - expect) < 4 * row["vz_se"] + 0.01 * v_c)


def test_nothing_beyond_the_slab_or_the_bins_counts():
    R = 6 * R_B
    plane = PlaneCrossing(R, R_B, slab_halves=(0.5,), n_blocks=2)
    for f in _frames(R, 1.0, n_frames=4, n=500, z_half=4 * R_B):
        f.position[:, 2] += 10 * R_B     # all of them far above the plane
        plane.accumulate(f)
    table, s = plane.conclude()
    assert table["n"].sum() == 0 and np.isnan(s["v_c_plane"]) and s["plane_frames"] == 4
    assert PlaneCrossing(R, R_B).conclude()[1] == {"plane_frames": 0}


def test_the_bin_average_of_the_shape_is_its_area_average():
    R, lo, hi = 1.0, 0.55, 0.97
    r = np.linspace(lo, hi, 200001)
    numeric = np.trapezoid(sqrt_shape(r, R) * r, r) / np.trapezoid(r, r)
    assert bin_shape(lo, hi, R) == pytest.approx(numeric, rel=1e-6)
    assert bin_shape(0.0, 1.0, R) == pytest.approx(2 / 3)      # the disc average of the shape
    assert bin_shape(1.2, 1.5, R) == 0.0                        # beyond the orifice
    assert bin_shape(0.3, 0.3, R) == pytest.approx(sqrt_shape(0.3, R))


def test_the_shape_fit_is_exact_on_exact_data_and_weights_by_the_errors():
    R = 1.0
    edges = np.linspace(0.0, 1.2, 21)
    lo, hi = edges[:-1], edges[1:]
    v = -2.0 * bin_shape(lo, hi, R)
    assert shape_fit(lo, hi, v, np.full(20, 0.1), R)[0] == pytest.approx(-2.0)
    # a bad bin with a huge error barely moves the fit
    v_bad = v.copy()
    v_bad[0] += 5.0
    se = np.full(20, 0.01)
    se[0] = 100.0
    assert shape_fit(lo, hi, v_bad, se, R)[0] == pytest.approx(-2.0, abs=1e-4)
    assert np.isnan(shape_fit(lo, hi, v, se, R, fit_range=0.0)[0])


def test_the_offset_power_fit_recovers_a_beverloo_like_law_and_needs_four_points():
    from granflow.scenes.silo.analysis import scaling_exponent, shifted_power_fit

    R = np.array([6.0, 7.5, 9.0, 10.5, 12.0])
    v = 2.0 * (R - 4.5) ** 0.5
    fit = shifted_power_fit(R, v, 0.01 * v)
    assert [fit["prefactor"], fit["x0"], fit["exponent"]] == pytest.approx([2.0, 4.5, 0.5], rel=1e-6)
    # the pure power law over the same points reads the curvature as a larger exponent, and fits badly
    pure = scaling_exponent(R, v, 0.01 * v)
    assert pure["exponent"] > 1.0 and pure["chi2_dof"] > 10
    # seeded noise at 1 %: b within three of its errors
    rng = np.random.default_rng(7)
    noisy = shifted_power_fit(R, v * (1 + 0.01 * rng.standard_normal(5)), 0.01 * v)
    assert abs(noisy["exponent"] - 0.5) < 3 * noisy["exponent_se"]
    assert np.isnan(shifted_power_fit(R[:3], v[:3], 0.01 * v[:3])["exponent"])
