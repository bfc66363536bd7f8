"""Known-answer tests of the bounded-heap analysis (Fan, Umbanhowar, Ottino & Lueptow 2013).

Every input is synthetic, with a known answer: exact sphere-cap volumes,
uniform random (overlapping) sphere packings, analytic velocity profiles,
noisy planes with known parameters. SI units and the lab/moving frames of
:mod:`granflow.scenes.heap.analysis`.
"""
from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from numpy.testing import assert_allclose
from scipy.integrate import quad
from scipy.optimize import brentq

from granflow.scenes.heap import analysis as hp

GEOMETRY = hp.HeapGeometry(W=0.46, T=0.013, theta_deg=24.0, x_feed=0.04)  # the paper's box
ALPHA, V_R, Z0_SURFACE = 25.7, 3.7e-3, 0.30  # degrees, m/s, m (paper: 25.69° at 33 g/s)


def surface_fit(alpha=ALPHA, v_r=V_R, z0=Z0_SURFACE) -> hp.SurfaceFit:
    return hp.SurfaceFit(alpha_deg=alpha, alpha_se=0.0, v_r=v_r, v_r_se=0.0, z0=z0)


# --------------------------------------------------------------------------- binning
def test_geometry_base_and_length():
    # z_base(W) is the end-wall height; the base climbs W tan(theta) to the feed wall.
    assert_allclose(GEOMETRY.z_base([0.0, GEOMETRY.W]), [0.46 * np.tan(np.radians(24.0)), 0.0], atol=1e-15)
    assert_allclose(GEOMETRY.L_lab, 0.42, rtol=1e-15)


def test_sphere_slab_fractions_are_exact():
    rng = np.random.default_rng(1)
    c, r = rng.uniform(-1.0, 1.0, 50), rng.uniform(0.1, 0.5, 50)
    edges = np.linspace(-2.0, 2.0, 17)  # slabs 0.25 thick cover every sphere
    f = hp.sphere_slab_fraction(c[:, None], r[:, None], edges[None, :-1], edges[None, 1:])
    assert np.all(f >= 0)
    assert_allclose(f.sum(axis=1), 1.0, rtol=0, atol=1e-12)  # telescoping sum: round-off only
    # half sphere
    assert_allclose(hp.sphere_slab_fraction(0.3, 0.2, 0.3, 5.0), 0.5, rtol=1e-15)
    # cap of height a = r/2: pi a^2 (3r - a)/3 over 4/3 pi r^3 = 5/32
    r0, a = 0.2, 0.1
    cap = np.pi * a**2 * (3 * r0 - a) / 3 / (4 / 3 * np.pi * r0**3)
    assert_allclose(cap, 5 / 32, rtol=1e-15)
    assert_allclose(hp.sphere_slab_fraction(0.3, r0, 0.3 + r0 - a, 1.0), cap, rtol=1e-13)
    # an arbitrary slab against the integral of disc areas pi (r^2 - s^2); quad is exact to ~1e-14
    lo, hi = -0.07, 0.13
    disc = quad(lambda s: np.pi * (r0**2 - s**2), lo, hi)[0] / (4 / 3 * np.pi * r0**3)
    assert_allclose(hp.sphere_slab_fraction(0.0, r0, lo, hi), disc, rtol=1e-12)
    # a slab missing the sphere holds nothing
    assert hp.sphere_slab_fraction(0.0, r0, 0.3, 0.4) == 0.0


def test_uniform_random_spheres_give_flat_phi_and_conserve_volume():
    rng = np.random.default_rng(2)
    geo = hp.HeapGeometry(W=0.1, T=0.01, theta_deg=24.0, x_feed=0.01)
    r, H, N = 2.5e-4, 0.05, 200_000
    pos = np.column_stack([rng.uniform(0, geo.W, N), rng.uniform(0, geo.T, N), rng.uniform(r, H - r, N)])
    phi, xe, ze = hp.volume_fraction_columns(pos, np.full(N, r), geo, dx=0.01, dz=0.005, z_lo=0.0, z_hi=H)
    v = 4 / 3 * np.pi * r**3
    v_bin = np.outer(np.diff(xe), np.diff(ze)) * geo.T
    assert phi.shape == (10, 10)
    # every sphere lies inside [0, H] and every centre inside [0, W]: binning conserves volume to round-off
    assert_allclose(np.sum(phi * v_bin), N * v, rtol=1e-12)
    # centres are uniform over H - 2r, so bins more than 2r from the ends hold phi = N v / (W T (H - 2r))
    expected = N * v / (geo.W * geo.T * (H - 2 * r))
    interior = (ze[:-1] >= 2 * r) & (ze[1:] <= H - 2 * r)
    # the volume in a bin has variance at most n_touch v^2, n_touch the mean number of spheres
    # touching it; 5 sigma per bin (80 bins) and 5 sigma/sqrt(80) for their mean
    n_touch = N * (np.diff(ze)[0] + 2 * r) / (H - 2 * r) * np.diff(xe)[0] / geo.W
    sigma = np.sqrt(n_touch) * v / v_bin[0, 0]
    assert_allclose(phi[:, interior], expected, rtol=0, atol=5 * sigma)
    assert_allclose(phi[:, interior].mean(), expected, rtol=0, atol=5 * sigma / np.sqrt(interior.sum() * 10))


def test_volume_fraction_splits_a_sphere_exactly_over_z_slabs():
    geo = hp.HeapGeometry(W=0.1, T=0.01, theta_deg=24.0, x_feed=0.01)
    r, dz = 1e-3, 5e-3
    # centre r/2 below the edge at z = 10 mm: a cap of height r/2 (5/32 of the sphere) lies above it
    phi, xe, ze = hp.volume_fraction_columns([[0.0349, 0.005, 0.01 - r / 2]], [r], geo, 0.01, dz, 0.0, 0.02)
    v_bin = 0.01 * 0.01 * dz
    v = 4 / 3 * np.pi * r**3
    expected = np.zeros_like(phi)
    expected[3, 1], expected[3, 2] = 27 / 32 * v / v_bin, 5 / 32 * v / v_bin  # x by centre: column 3
    assert_allclose(phi, expected, rtol=1e-12, atol=1e-15)


def test_free_surface_of_a_tanh_profile():
    dz = 5e-4
    z_edges = np.arange(0.0, 0.1 + dz / 2, dz)
    zc = 0.5 * (z_edges[1:] + z_edges[:-1])
    zm, w = np.array([0.0612, 0.04, 0.0833]), 2e-3
    phi = 0.3 * (1.0 - np.tanh((zc[None, :] - zm[:, None]) / w))  # 0.6 in the bed, 0 above
    phi[0, zc > 0.09] = 0.1  # bouncing particles above the surface stay below phi_c
    # 0.3 (1 - tanh s) = 0.35  <=>  tanh s = -1/6
    z_star = zm - w * np.arctanh(1.0 / 6.0)
    phi = np.vstack([phi, np.zeros(len(zc)), np.full(len(zc), 0.6)])  # empty column, column full to the top
    z_s = hp.free_surface(phi, z_edges, 0.35)
    # linear interpolation between centres errs by about dz^2/8 * |phi''/phi'| = dz^2/(24 w) ~ 5 um
    assert_allclose(z_s[:3], z_star, rtol=0, atol=dz / 10)
    assert np.isnan(z_s[3]) and np.isnan(z_s[4])


def test_bed_volume_fraction_ignores_the_layer_and_the_base():
    dz = 1e-3
    z_edges = np.arange(0.0, 0.2 + dz / 2, dz)
    zc = 0.5 * (z_edges[1:] + z_edges[:-1])
    z_s = np.array([0.15, 0.12, np.nan])
    z_base = np.array([0.0, 0.095, 0.0])  # the second column's base lies 25 mm below its surface
    phi = np.where(zc[None, :] < z_s[:, None] - 0.006, 0.62, 0.5)  # bed, then flowing/creeping layer
    phi = np.where(zc[None, :] < z_base[:, None], 0.0, phi)
    phi[1, (zc > z_base[1]) & (zc < z_base[1] + 0.002)] = 0.5  # looser packing against the base
    bed = hp.bed_volume_fraction(phi, z_edges, z_s, 0.010, 0.030, z_base=z_base, clearance=0.002)
    # window 10-30 mm below the surface lies in the 0.62 bed; base bins excluded; no surface -> NaN
    assert_allclose(bed[:2], 0.62, rtol=1e-12)
    assert np.isnan(bed[2])


# --------------------------------------------------------------------------- surface fit
def plane(t, x, alpha=ALPHA, v_r=V_R, z0=Z0_SURFACE):
    return z0 - x[None, :] * np.tan(np.radians(alpha)) + v_r * t[:, None]


def test_fit_surface_recovers_alpha_rise_velocity_and_z0():
    rng = np.random.default_rng(4)
    dx, sigma = 0.01, 5e-4
    t = np.linspace(10.0, 20.0, 41)
    x_lab = np.arange(dx / 2, GEOMETRY.W, dx)
    x_range = hp.surface_fit_range(GEOMETRY, dx)
    # noise-free: exact to round-off
    exact = hp.fit_surface(t, x_lab, plane(t, x_lab), x_range)
    assert_allclose([exact.alpha_deg, exact.v_r, exact.z0], [ALPHA, V_R, Z0_SURFACE], rtol=1e-9)
    assert_allclose(exact.z_surface(0.2, 15.0), plane(np.array([15.0]), np.array([0.2]))[0, 0], rtol=1e-9)

    z_s = plane(t, x_lab) + rng.normal(0.0, sigma, (len(t), len(x_lab)))
    z_s[:, x_lab < GEOMETRY.x_feed] = 0.45  # flat pile under the feed: must be excluded
    z_s[:, -1] += 0.01                      # surface bent up at the end wall: must be excluded
    z_s[rng.random(z_s.shape) < 0.05] = np.nan
    fit = hp.fit_surface(t, x_lab, z_s, x_range)
    # unbiased estimates: within 5 standard errors
    assert abs(fit.alpha_deg - ALPHA) < 5 * fit.alpha_se
    assert abs(fit.v_r - V_R) < 5 * fit.v_r_se
    assert abs(fit.z0 - Z0_SURFACE) < 5 * fit.z0_se
    # the standard errors are the least-squares ones: se(tan a) = sigma / sqrt(sum (x - mean x)^2)
    # over ~1600 points; sigma itself is estimated to ~2 %, holes change the sum by ~5 %: 20 %
    used = fit.rise_by_x["in_fit"].to_numpy()
    xs = x_lab[used]
    se_tan = sigma / np.sqrt(len(t) * 0.95 * np.sum((xs - xs.mean()) ** 2))
    assert_allclose(fit.alpha_se, np.degrees(se_tan / (1 + np.tan(np.radians(ALPHA)) ** 2)), rtol=0.2)
    assert_allclose(fit.residual_std, sigma, rtol=0.1)
    assert not used[x_lab < GEOMETRY.x_feed + dx / 2].any() and not used[-1]
    # per-frame angles and per-column rise velocities: each within 5 of its standard errors
    assert np.all(np.abs(fit.alpha_t["alpha_deg"] - ALPHA) < 5 * fit.alpha_t["alpha_se"])
    rise = fit.rise_by_x[used]
    assert np.all(np.abs(rise["v_r"] - V_R) < 5 * rise["v_r_se"])


def test_surface_chain_from_particles_recovers_the_plane():
    """Random spheres below a known rising plane -> phi columns -> free surface -> fit."""
    rng = np.random.default_rng(5)
    r, depth, dx, dz = 1e-3, 0.03, 0.01, 5e-4
    v = 4 / 3 * np.pi * r**3
    n = int(0.6 * GEOMETRY.W * GEOMETRY.T * depth / v)  # phi = 0.6 below the surface
    times = np.linspace(10.0, 14.0, 5)
    rows = []
    for t in times:
        x = rng.uniform(0, GEOMETRY.W, n)
        z = surface_fit().z_surface(x, t) - depth * rng.random(n)
        pos = np.column_stack([x, rng.uniform(0, GEOMETRY.T, n), z])
        phi, xe, ze = hp.volume_fraction_columns(pos, np.full(n, r), GEOMETRY, dx, dz, 0.03, 0.36)
        rows.append(hp.free_surface(phi, ze))
    x_lab = 0.5 * (xe[1:] + xe[:-1])
    fit = hp.fit_surface(times, x_lab, np.array(rows), hp.surface_fit_range(GEOMETRY, dx))
    # with centres uniform below the plane, phi(z)/0.6 is the fraction of a sphere below a plane
    # at s r above its centre, s = (plane - z)/r: phi = 0.35 a constant s r below the plane
    s = brentq(lambda s: (1 + s) ** 2 * (2 - s) / 4 - 0.35 / 0.6, -1.0, 1.0)
    # bin noise (~9 spheres per bin) scatters z_s: alpha, v_r and z0 within 5 standard errors
    assert abs(fit.alpha_deg - ALPHA) < 5 * fit.alpha_se
    assert abs(fit.v_r - V_R) < 5 * fit.v_r_se
    assert abs(fit.z0 - (Z0_SURFACE - s * r)) < 5 * fit.z0_se


# --------------------------------------------------------------------------- moving frame
def test_moving_frame_origin_axes_and_velocities():
    fit = surface_fit()
    frame = hp.MovingFrame(fit, GEOMETRY)
    a = np.radians(ALPHA)
    assert_allclose(frame.v_r_normal, V_R * np.cos(a), rtol=1e-15)
    assert_allclose(frame.L, 0.42 / np.cos(a), rtol=1e-15)
    for t in (0.0, 7.5, 30.0):
        z_feed = fit.z_surface(GEOMETRY.x_feed, t)
        z_end = fit.z_surface(GEOMETRY.W, t)
        pos = np.array([[GEOMETRY.x_feed, 0.006, z_feed],          # origin
                        [GEOMETRY.W, 0.006, z_end],                # surface at the end wall
                        [GEOMETRY.x_feed + 0.01 * np.sin(a), 0.0, z_feed + 0.01 * np.cos(a)]])  # 1 cm along e_z
        v_n = frame.v_r_normal
        vel = np.array([[v_n * np.sin(a), 0.0, v_n * np.cos(a)],    # moving with the surface, normal to it
                        [0.0, 0.3, 0.0],                            # at rest (y velocity is ignored)
                        [0.2 * np.cos(a) + v_n * np.sin(a), 0.0, -0.2 * np.sin(a) + v_n * np.cos(a)]])  # 0.2 m/s downhill, riding the rise
        x, z, u, w = frame.transform(pos, vel, t)
        # lengths of order 0.5 m: round-off ~1e-16 * 0.5
        assert_allclose(x, [0.0, frame.L, 0.0], rtol=0, atol=1e-12)
        assert_allclose(z, [0.0, 0.0, 0.01], rtol=0, atol=1e-12)
        # relative to the surface the static bed is at rest along the flow and sinks at v_r'
        assert_allclose(u, [0.0, 0.0, 0.2], rtol=0, atol=1e-15)
        assert_allclose(w, [0.0, -frame.v_r_normal, 0.0], rtol=0, atol=1e-15)
        back = frame.to_lab(x, z, t)
        assert_allclose(np.column_stack(back), pos[:, [0, 2]], rtol=0, atol=1e-12)


# --------------------------------------------------------------------------- kinematics
def test_rigid_downhill_translation_gives_uniform_velocity_and_no_fluctuation():
    rng = np.random.default_rng(6)
    x_edges, z_edges = np.linspace(0.0, 0.4, 11), np.arange(-0.020, 0.0005, 0.001)
    N, U, n_frames = 3000, 0.12, 12
    kind = rng.integers(1, 3, N)
    radius = np.where(kind == 1, 0.75e-3, 1.0e-3)
    x0 = rng.uniform(0.0, 0.4, N)
    z = rng.uniform(-0.019, -0.001, N)  # whole spheres inside the z range
    acc = hp.KinematicsAccumulator(x_edges, z_edges, T=0.013, n_types=2, n_blocks=4)
    with pytest.raises(RuntimeError, match=r"accumulate\(\) called before prepare\(\)"):
        acc.accumulate(x0, z, np.full(N, U), np.zeros(N), radius, kind)
    acc.prepare()
    with pytest.raises(RuntimeError, match=r"result read before conclude\(\)"):
        acc.result
    with pytest.raises(RuntimeError, match=r"conclude\(\) called before any frame was accumulated"):
        acc.conclude()
    for k in range(n_frames):
        x = (x0 + U * k * 0.01) % 0.4  # rigid translation downhill, re-entering upstream
        acc.accumulate(x, z, np.full(N, U), np.zeros(N), radius, kind)
    res = acc.conclude()
    assert res is acc.result and acc.n_frames == n_frames
    assert len(res) == 10 * 20
    occ = res["phi"] > 0
    assert occ.sum() > 150
    # every particle has u = U and w = 0: the volume-weighted means are exact to round-off
    assert_allclose(res.loc[occ, "u"], U, rtol=1e-12)
    assert_allclose(res.loc[occ, "w"], 0.0, atol=1e-15)
    # <u^2> - <u>^2 cancels catastrophically: its square root is at most sqrt(eps) U ~ 2e-9 m/s
    assert_allclose(res.loc[occ, "u_std"], 0.0, atol=1e-7 * U)
    assert_allclose(res.loc[occ, "u_se"], 0.0, atol=1e-12 * U)  # every block gives U
    # binning conserves volume (all centres inside in x, whole spheres inside in z)
    v_bin = (res["x_hi"] - res["x_lo"]) * (res["z_hi"] - res["z_lo"]) * 0.013
    volume = 4 / 3 * np.pi * radius**3
    assert_allclose(np.sum(res["phi"] * v_bin), volume.sum(), rtol=1e-12)
    assert_allclose(res["phi_1"] + res["phi_2"], res["phi"], rtol=1e-12, atol=1e-15)
    assert_allclose(np.sum(res["phi_1"] * v_bin), volume[kind == 1].sum(), rtol=1e-12)
    # every centre is in a bin in every frame: mean counts sum to N, number-mean diameter is the global one
    assert_allclose(res["n"].sum(), N, rtol=1e-12)
    d = res["d_mean"].to_numpy()
    ok = res["n"].to_numpy() > 0
    assert_allclose(np.sum(res["n"][ok] * d[ok]) / N, np.mean(2 * radius), rtol=1e-12)
    assert np.all((d[ok] >= 1.5e-3 - 1e-15) & (d[ok] <= 2.0e-3 + 1e-15))


def test_kinematics_weights_a_particle_by_its_volume_in_each_bin():
    acc = hp.KinematicsAccumulator([0.0, 0.04, 0.08], [-0.006, -0.004, -0.002, 0.0], T=0.01, n_types=2)
    acc.prepare()
    # particle 1 (type 1, column 0) straddles z = -4 mm with a cap of height r/2 (5/32) below it;
    # particle 2 (type 2, column 1) lies inside the lowest bin
    r, r2 = 1e-3, 0.4e-3
    acc.accumulate([0.01, 0.05], [-0.004 + r / 2, -0.005], [1.0, 3.0], [-0.5, 0.0], [r, r2], [1, 2])
    res = acc.conclude()
    v1, v2 = 4 / 3 * np.pi * r**3, 4 / 3 * np.pi * r2**3
    v_bin = 0.04 * 0.002 * 0.01
    assert_allclose(res["phi"], np.array([5 / 32 * v1, 27 / 32 * v1, 0, v2, 0, 0]) / v_bin, rtol=1e-12, atol=1e-15)
    assert_allclose(res["phi_2"], np.array([0, 0, 0, v2, 0, 0]) / v_bin, rtol=1e-12, atol=1e-15)
    occupied = res["phi"].to_numpy() > 0
    assert_allclose(res["u"][occupied], [1.0, 1.0, 3.0], rtol=1e-12)
    assert_allclose(res["w"][occupied], [-0.5, -0.5, 0.0], rtol=1e-12)
    assert res["u"][~occupied].isna().all()
    # counts and diameters go by centre: particle 1's centre is in the middle bin of column 0
    assert_allclose(res["n"], [0, 1, 0, 1, 0, 0])
    assert_allclose(res["d_mean"].to_numpy()[[1, 3]], [2 * r, 2 * r2], rtol=1e-12)
    acc.prepare()
    with pytest.raises(ValueError, match=r"particle types \[3\] outside 1\.\.2"):
        acc.accumulate([0.01], [-0.002], [1.0], [0.0], [r], [3])  # type outside 1..n_types


# --------------------------------------------------------------------------- thickness
def test_thickness_of_an_exponential_profile():
    z0, u_s = 2e-3, 0.3
    z = -(np.arange(300) + 0.5) * z0 / 20  # bin centres down to 15 z0
    u = u_s * np.exp(z / z0)
    fit = hp.delta_exponential(z, u, u_s)
    assert_allclose(fit.z0, z0, rtol=1e-6)  # noise-free: the fit converges to round-off
    assert_allclose(fit.delta, 2.3 * z0, rtol=1e-6)
    # linear interpolation of exp over spacing h errs by ~h^2/(8 z0): 1.4e-4 relative to z0 ln 10
    assert_allclose(hp.delta_cutoff(z, u, u_s), z0 * np.log(10.0), rtol=5e-4)


def test_thickness_of_a_linear_profile():
    delta, u_s = 5e-3, 0.3
    z = (np.arange(-60, 5) + 0.5) * delta / 20  # centres from -3 delta to above the surface
    u = u_s * np.clip(1.0 + z / delta, 0.0, None)
    below = z <= 0
    # the 0.2-0.8 points and the 0.1 crossing lie on the straight part: exact to round-off
    assert_allclose(hp.delta_linear(z[below], u[below], u_s), delta, rtol=1e-10)
    assert_allclose(hp.delta_cutoff(z[below], u[below], u_s), 0.9 * delta, rtol=1e-10)
    assert_allclose(hp.surface_velocity(z, u), u_s, rtol=1e-12)         # interpolated across z = 0
    assert_allclose(hp.surface_velocity(z[below], u[below]), u_s, rtol=1e-12)  # extrapolated
    # no shear, no thickness
    assert np.isnan(hp.delta_cutoff(z[below], np.full(below.sum(), u_s), u_s))


def test_normal_velocity_profiles_eq_35_36():
    for f in (hp.normal_velocity_linear, hp.normal_velocity_exponential):
        assert_allclose(f(0.0), 0.0, atol=1e-15)   # w = 0 at the surface
        assert_allclose(f(-1.0), -1.0, rtol=1e-14)  # w = -v_r' at the bottom of the layer
    # both follow from eq. (3.4), w = -(1/L) int_z^0 u(0, s) ds with q0 = v_r' L (units delta = v_r' = L = 1)
    k = 2.3
    for shape, eq in ((lambda s: 2.0 * (1.0 + s), hp.normal_velocity_linear),
                      (lambda s: k / (1.0 - np.exp(-k)) * np.exp(k * s), hp.normal_velocity_exponential)):
        for zt in (-0.8, -0.5, -0.1):
            assert_allclose(-quad(shape, zt, 0.0)[0], eq(zt), rtol=1e-12)


def test_tail_and_power_law_fits_recover_known_parameters():
    rng = np.random.default_rng(9)
    zt = rng.uniform(-2.5, 0.0, 600)
    ut = np.where(zt > -0.7, 1.0 + zt, 2.4 * np.exp(3.3 * zt) * np.exp(rng.normal(0, 0.05, zt.size)))
    tail = hp.fit_exponential_tail(zt, ut)
    # unbiased least squares on the logarithm: within 5 standard errors
    assert abs(tail.k - 3.3) < 5 * tail.k_se and tail.k_se < 0.1
    assert abs(tail.A - 2.4) < 5 * tail.A_se
    q = np.logspace(1, 3, 50)
    y = 3.1 * q**0.22 * np.exp(rng.normal(0, 0.03, q.size))
    power = hp.fit_power_law(np.append(q, [-1.0, np.nan]), np.append(y, [2.0, 1.0]))  # junk is skipped
    assert abs(power.exponent - 0.22) < 5 * power.exponent_se and power.exponent_se < 0.01
    # the prefactor's log has se ~ 0.03/sqrt(50) * ~3.5 (extrapolation to ln q = 0): 5 % is > 5 sigma
    assert_allclose(power.prefactor, 3.1, rtol=0.05)


# --------------------------------------------------------------------------- along the heap
def synthetic_profile(frame: hp.MovingFrame, z0: float, dx: float, dz: float, d: float) -> pd.DataFrame:
    """u = u_s(x) exp(z/z0) with u_s = v_r'(L - x)/z0, so q = v_r'(L - x) (mass conservation),
    and w = -v_r'(1 - exp(z/z0)) from eq. (3.4); plus two empty/motionless bins beyond L."""
    L, v_rn = frame.L, frame.v_r_normal
    x_edges = np.append(hp.uniform_edges(0.0, L, dx), L + np.array([dx, 2 * dx]))
    z_edges = np.arange(-300, 6) * dz  # 15 z0 deep, 5 bins above the surface; 0 is an edge
    xc, zc = 0.5 * (x_edges[1:] + x_edges[:-1]), 0.5 * (z_edges[1:] + z_edges[:-1])
    X, Z = (g.ravel() for g in np.meshgrid(xc, zc, indexing="ij"))
    XL, ZL = (g.ravel() for g in np.meshgrid(x_edges[:-1], z_edges[:-1], indexing="ij"))
    XH, ZH = (g.ravel() for g in np.meshgrid(x_edges[1:], z_edges[1:], indexing="ij"))
    u = v_rn * (L - X) / z0 * np.exp(Z / z0)
    w = -v_rn * (1.0 - np.exp(Z / z0))
    u[X > L + dx], w[X > L + dx] = np.nan, np.nan  # an empty bin
    u[(X > L) & (X < L + dx)] = 0.0                # a bin that does not flow
    n = len(X)
    return pd.DataFrame(dict(x=X, z=Z, x_lo=XL, x_hi=XH, z_lo=ZL, z_hi=ZH, phi=np.full(n, 0.6), u=u, w=w,
                             u_std=np.zeros(n), u_se=np.zeros(n), w_se=np.zeros(n), n=np.full(n, 10.0),
                             d_mean=np.full(n, d), phi_1=np.full(n, 0.6)))


def test_analyse_heap_on_an_exponential_profile():
    z0, dx, dz, d = 2e-3, 0.02, 1e-4, 1.5e-3
    fit = surface_fit()
    frame = hp.MovingFrame(fit, GEOMETRY)
    L, v_rn = frame.L, frame.v_r_normal
    profile = synthetic_profile(frame, z0, dx, dz, d)
    density, phi_bed = 2500.0, 0.62
    feed = V_R * density * phi_bed * GEOMETRY.T * GEOMETRY.W  # consistent with mass conservation
    per_x, s = hp.analyse_heap(profile, fit, GEOMETRY, density=density, feed_rate=feed, phi_bed=phi_bed,
                               d_ref=d)
    ok = per_x["usable"].to_numpy()
    assert ok.sum() == len(per_x) - 2 and not ok[-2:].any()  # the empty and the still bin are skipped
    assert (per_x["n_profile"].to_numpy()[-2:] == 0).all() and per_x["delta"].iloc[-2:].isna().all()
    good = per_x[ok]
    x = good["x"].to_numpy()
    u_true = v_rn * (L - x) / z0
    # u_s interpolated between z = -dz/2 and +dz/2 overestimates by cosh(dz/2z0) - 1 = 3e-4
    assert_allclose(good["u_s"], u_true, rtol=5e-4)
    # q by the midpoint rule: relative error (dz/z0)^2/24 = 1e-4, truncation at 15 z0: 3e-7
    assert_allclose(good["q"], u_true * z0, rtol=5e-4)
    assert_allclose(good["q"], v_rn * (L - x), rtol=5e-4)
    assert_allclose(good["delta_exp"], 2.3 * z0, rtol=1e-6)  # exact exponential data
    # cutoff: interpolation (1.4e-4) and the u_s bias (ln cosh / ln 10 = 1.4e-4)
    assert_allclose(good["delta_cut"], z0 * np.log(10), rtol=5e-4)
    assert_allclose(good["delta"], good["delta_cut"], rtol=0)
    # mean gradient over the layer: (u_s - 0.1 u_s)/delta
    assert_allclose(good["gamma_bar"], 0.9 * good["u_s"] / good["delta"], rtol=1e-9)
    # eq. (3.1) with u_s = v_r'(L - x)/z0: sqrt(delta_L^2 + 2 z0 delta / 0.9), same 5e-4 budget
    delta = z0 * np.log(10)
    assert_allclose(good["delta_eq31"], np.sqrt(delta**2 + 2 * z0 * delta / 0.9), rtol=1e-3)
    assert_allclose(good["d_bar"], d, rtol=1e-12)
    assert_allclose(good["q_star"], good["q"] / (d * np.sqrt(9.81 * d)), rtol=1e-12)
    assert_allclose(good["x_over_L"], x / L, rtol=1e-12)

    assert_allclose(s["v_r_predicted"], V_R, rtol=1e-12)
    assert_allclose(s["mass_balance_residual"], 0.0, atol=1e-12)
    assert_allclose(s["L"], 0.42 / np.cos(np.radians(ALPHA)), rtol=1e-12)
    assert_allclose(s["q0_rise"], v_rn * L, rtol=1e-12)
    assert_allclose(s["q0"], v_rn * (L - x[0]), rtol=5e-4)  # at the first bin centre
    assert_allclose([s["delta_mean"], s["delta_cut_mean"]], delta, rtol=5e-4)
    assert_allclose(s["delta_exp_mean"], 2.3 * z0, rtol=1e-6)
    assert_allclose(s["delta_over_d"], delta / d, rtol=5e-4)
    # collapsed u/u_s = exp(z/z0)/cosh(dz/2z0) = A exp(k z/delta), k = delta/z0 = ln 10, A = 1 (3e-4 bias)
    assert_allclose([s["tail_A"], s["tail_k"]], [1.0, np.log(10)], rtol=1e-3)
    # delta is constant along x: delta/d does not depend on q* (scatter of delta ~1e-4)
    assert_allclose(s["q_star_exponent"], 0.0, atol=1e-3)
    assert s["n_usable"] == ok.sum() and "unusable" in s["notes"]

    col = hp.collapse(profile, per_x)
    assert set(col["x"]) == set(x)
    assert_allclose(col["wt"], np.exp(col["z"] / z0) - 1.0, rtol=0, atol=1e-12)  # w/v_r' by construction
    assert_allclose(col["zt"], col["z"] / delta, rtol=5e-4)


def test_analyse_heap_on_an_unusable_profile_reports_nan():
    frame = hp.MovingFrame(surface_fit(), GEOMETRY)
    profile = synthetic_profile(frame, 2e-3, 0.1, 5e-4, 1.5e-3)
    profile["u"] = np.nan
    per_x, s = hp.analyse_heap(profile, surface_fit(), GEOMETRY, density=2500.0, feed_rate=0.033,
                               phi_bed=0.6, d_ref=1.5e-3, n_types=2)
    assert not per_x["usable"].any() and (per_x["n_profile"] == 0).all()
    assert per_x[["q", "u_s", "delta", "c_s"]].isna().all().all()
    assert np.isnan(s["delta_mean"]) and np.isnan(s["tail_k"]) and np.isnan(s["q0"])
    assert set(s) == set(hp.SCALAR_KEYS)
    per_x, s = hp.analyse_heap(profile.iloc[:0], surface_fit(), GEOMETRY, density=2500.0, feed_rate=0.033,
                               phi_bed=0.6, d_ref=1.5e-3, n_types=2)
    assert per_x.empty and "c_s" in per_x and s["n_usable"] == 0 and s["notes"] == "empty profile"


# --------------------------------------------------------------------------- deposit
def test_deposit_concentration_counts_only_the_window_below_the_layer():
    fit, dx, delta = surface_fit(), 0.02, 5e-3
    t_start, t_end = 10.0, 20.0
    cos_a = np.cos(np.radians(ALPHA))
    thickness = V_R * cos_a * (t_end - t_start)  # normal distance between the two surfaces
    x_edges = hp.uniform_edges(0.0, GEOMETRY.W, dx)
    xc = 0.5 * (x_edges[1:] + x_edges[:-1])
    rows = []
    for i, x in enumerate(xc):
        n_small = 4 if x < GEOMETRY.W / 2 else 2
        top = fit.z_surface(x, t_end)
        for j, depth in enumerate(np.linspace(delta + 1e-3, thickness - 1e-3, 6)):  # normal depth in the deposit
            rows.append((x, top - depth / cos_a, 1 if j < n_small else 2))
        rows.append((x, top - 0.5 * delta / cos_a, 1))                # flowing layer: excluded
        rows.append((x, top - (thickness + 3e-3) / cos_a, 1))         # older bed: excluded
    x, z, kind = (np.array(c) for c in zip(*rows))
    pos = np.column_stack([x, np.full(len(x), 0.006), z])
    radius = np.where(kind == 1, 0.5e-3, 1.0e-3)
    dep = hp.deposit_concentration(pos, radius, kind, fit, GEOMETRY, t_start, t_end, delta, dx)
    assert_allclose(dep["x_lab"], xc, rtol=1e-12)
    assert (dep["n"] == 6).all()
    # volume concentration: 4 small (r/2) + 2 large -> 4/8 / (4/8 + 2) = 0.2; 2 + 4 -> 2/8 / (2/8 + 4)
    expected = np.where(xc < GEOMETRY.W / 2, 0.5 / 2.5, 0.25 / 4.25)
    assert_allclose(dep["c_s"], expected, rtol=1e-12)


def test_deposit_slabs_give_the_contrast_its_statistical_error():
    """Four slabs of deposit (the material of four parts of the window) with known contrasts 0.1, 0.3,
    0.1, 0.3: the whole deposit's contrast is 0.2, its error the slabs' s/√4; the slabs partition the
    deposit; the front-wall slice counts only y < 2 d_l and, being as mixed as the rest, gives 0.2."""
    fit, dx, delta, d_l = surface_fit(), 0.02, 5e-3, 2e-3
    t_start, t_end = 10.0, 20.0
    cos_a = np.cos(np.radians(ALPHA))
    lo, hi = -V_R * cos_a * (t_end - t_start), -delta          # the deposit's normal coordinate range
    x_edges = hp.uniform_edges(0.0, GEOMETRY.W, dx)
    xc = 0.5 * (x_edges[1:] + x_edges[:-1])
    mid = 0.5 * (GEOMETRY.x_feed + GEOMETRY.W)
    small_up, small_down = [6, 8, 6, 8], [5, 5, 5, 5]          # small particles of 10 per half-gap
    rows = []
    for x in xc:
        top = fit.z_surface(x, t_end)
        for k in range(4):
            z = lo + (k + 0.5) * (hi - lo) / 4
            n_small = (small_up if x < mid else small_down)[k]
            for y in (0.002, 0.008):                           # front slice and the rest of the gap
                rows += [(x, y, top + z / cos_a, 1 if j < n_small else 2) for j in range(10)]
    n_deposit = len(rows)
    rows += [(x, 0.006, fit.z_surface(x, t_end) - 0.75 * delta / cos_a, 1) for x in xc]  # flowing layer's foot
    x, y, z, kind = (np.array(c) for c in zip(*rows))
    pos = np.column_stack([x, y, z])
    radius = np.full(len(x), 0.75e-3)                          # equal sizes: volume fractions = number fractions
    var = hp.deposit_variants(pos, radius, kind, fit, GEOMETRY, t_start, t_end, delta, dx, d_large=d_l)
    central = var[var["variant"] == hp.DEPOSIT_CENTRAL]
    whole = central[central["slab"] == 0]
    assert whole["n"].sum() == n_deposit
    for k in range(1, 5):                                      # each slab holds its own 20 per column
        assert (central[central["slab"] == k]["n"] == 20).all()
    c, se, per = hp.deposit_contrast_error(var, hp.DEPOSIT_CENTRAL, GEOMETRY.x_feed, GEOMETRY.W)
    assert c == pytest.approx(0.2) and per == pytest.approx([0.1, 0.3, 0.1, 0.3])
    assert se == pytest.approx(np.std([0.1, 0.3, 0.1, 0.3], ddof=1) / 2)
    front = var[(var["variant"].str.startswith("front")) & (var["slab"] == 0)]
    assert front["n"].sum() == n_deposit // 2
    assert hp.deposit_contrast_error(var, front["variant"].iloc[0], GEOMETRY.x_feed, GEOMETRY.W)[0] == pytest.approx(0.2)
    higher = var[(var["variant"] == "from 0.5 δ below the surface") & (var["slab"] == 0)]
    assert higher["n"].sum() == n_deposit + len(xc)            # takes in the foot of the flowing layer
    with pytest.raises(ValueError, match="slab"):
        hp.deposit_concentration(pos, radius, kind, fit, GEOMETRY, t_start, t_end, delta, dx, slab=(4, 4))


def test_the_origin_is_each_columns_own_free_surface():
    """Columns whose surface lies h(x) above or below the fitted plane (an S-shaped heap): measured from the
    local surface, u_s and the collapsed profile are those of the flat heap; from the plane, u_s is off by
    exp(h/z0) and the offset is reported."""
    z0, dx, dz, d = 2e-3, 0.02, 1e-4, 1.5e-3
    fit = surface_fit()
    frame = hp.MovingFrame(fit, GEOMETRY)
    L, v_rn = frame.L, frame.v_r_normal
    flat = synthetic_profile(frame, z0, dx, dz, d)
    xs = np.sort(flat["x"].unique())
    h = dict(zip(xs, np.round(3e-4 * np.sin(2 * np.pi * xs / L) / dz) * dz))  # on bin edges, within the profile's top
    bent = flat.copy()
    shift = bent["x"].map(h).to_numpy()
    moved = bent["z"] - shift
    bent["u"] = np.where(np.isfinite(flat["u"]), v_rn * (L - bent["x"]) / z0 * np.exp(moved / z0), np.nan)
    bent.loc[bent["x"] > L, "u"] = flat.loc[flat["x"] > L, "u"]
    bent["phi"] = np.where(moved < 0, 0.6, 0.0)
    per_x, s = hp.analyse_heap(bent, fit, GEOMETRY, density=2500.0, feed_rate=0.03, phi_bed=0.62, d_ref=d)
    ok = per_x["usable"].to_numpy()
    good = per_x[ok]
    # the crossing of phi_c = 0.35 between bin centres lies 0.083 dz below the step
    assert_allclose(good["z_surface_local"], good["x"].map(h) - dz * (1 - 0.25 / 0.6 - 0.5), atol=1e-9)
    assert_allclose(good["u_s"], v_rn * (L - good["x"]) / z0, rtol=5e-3)
    assert_allclose([s["tail_A"], s["tail_k"]], [1.0, np.log(10)], rtol=5e-3)
    assert s["origin"] == "local"
    assert_allclose(s["surface_offset_max_over_d"], 3e-4 / d, rtol=0.1)
    # from the fitted plane: u_s is read h above or below the column's surface
    per_plane, s_plane = hp.analyse_heap(bent, fit, GEOMETRY, density=2500.0, feed_rate=0.03, phi_bed=0.62,
                                         d_ref=d, origin="plane")
    ratio = per_plane["u_s"].to_numpy()[ok] / (v_rn * (L - good["x"].to_numpy()) / z0)
    hx = good["x"].map(h).to_numpy()
    far = np.abs(hx) > 1.5e-4
    assert far.sum() >= 4
    assert_allclose(np.log(ratio[far]), -hx[far] / z0 + np.log(ratio[~far]).mean(), atol=0.01)
    assert s_plane["origin"] == "plane" and s["tail_A_other_origin"] == pytest.approx(s_plane["tail_A"])
    with pytest.raises(ValueError, match="origin = 'middle'"):
        hp.analyse_heap(bent, fit, GEOMETRY, density=2500.0, feed_rate=0.03, phi_bed=0.62, d_ref=d, origin="middle")
