"""Known-answer tests of the heap across its gap (granflow.scenes.heap.analysis.gap; Fan et al. 2013, Appendix 1,
Fig. A.12): the slices' shares of a sphere, u_s of each slice of a flow whose speed depends on y alone, and the
deposit's c_s in the slices with known wall and centre concentrations."""
from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest
from numpy.testing import assert_allclose
from scipy.integrate import quad

from granflow.scenes.heap import analysis as hp
from postproc.frame import ParticleFrame

T = 0.013
GEOMETRY = hp.HeapGeometry(W=0.12, T=T, theta_deg=24.0, x_feed=0.02)
FIT = hp.SurfaceFit(alpha_deg=26.0, alpha_se=0.0, v_r=5e-3, v_r_se=0.0, z0=0.08)


def test_slices_are_the_papers_millimetres_and_split_spheres_exactly():
    iv = hp.slices(T)
    assert_allclose(iv["wall"], [(0.0, 0.004), (0.009, 0.013)], atol=1e-15)
    assert_allclose(iv["centre"], [(0.004, 0.0087)], atol=1e-15)
    r = 0.5e-3
    y = np.array([0.004, 0.002, 0.00435, 0.0125])       # on the wall slice's edge; inside; straddling; at the far wall
    wall, centre = (hp.slice_share(y, np.full(4, r), iv[k]) for k in ("wall", "centre"))
    assert_allclose(wall, [0.5, 1.0, hp.sphere_slab_fraction(0.00435, r, 0.0, 0.004), 1.0], atol=1e-12)
    assert_allclose(centre, [0.5, 0.0, 1 - wall[2], 0.0], atol=1e-12)
    by_centre = hp.slice_share(y, np.full(4, r), iv["wall"], exact=False)
    assert_allclose(by_centre, [0.0, 1.0, 0.0, 1.0])   # [lo, hi): y = 4 mm belongs to the centre


def flow_frames(n_frames, u_of_y, rng, n=40_000, r=0.4e-3):
    """Frames of particles in the layer 3 mm under the fitted surface (whole spheres), centres uniform in the gap
    (r ≤ y ≤ T − r), each moving downhill at u(y) and riding the rise (u = u(y), w = 0 in the moving frame)."""
    moving = hp.MovingFrame(FIT, GEOMETRY)
    a = math.radians(FIT.alpha_deg)
    frames = []
    for k in range(n_frames):
        t = 2.0 + 0.02 * k
        x = rng.uniform(0.0, moving.L, n)
        z = rng.uniform(-3e-3 + r, -r, n)
        y = rng.uniform(r, T - r, n)
        x_lab, z_lab = moving.to_lab(x, z, t)
        u = u_of_y(y)
        vel = np.column_stack([u * math.cos(a) + moving.v_r_normal * math.sin(a), np.zeros(n),
                               -u * math.sin(a) + moving.v_r_normal * math.cos(a)])
        frames.append(ParticleFrame(timestep=int(round(t / 1e-4)), box=np.zeros((3, 2)),
                                    position=np.column_stack([x_lab, y, z_lab]), velocity=vel,
                                    mass=np.ones(n), radius=np.full(n, r), type=np.ones(n, int)))
    return moving, frames


def test_surface_velocity_of_each_slice_from_a_speed_that_depends_on_y():
    """u = U (1 − a s²), s = (2y − T)/T: each slice's u is the mean over its centres (uniform in y), the gap's the
    mean over the gap's; the record's whole-gap accumulator gives the latter as per_x's u_s."""
    rng = np.random.default_rng(11)
    U, a, r = 0.2, 0.3, 0.4e-3
    u_of_y = lambda y: U * (1 - a * ((2 * y - T) / T) ** 2)  # noqa: E731
    moving, frames = flow_frames(4, u_of_y, rng, r=r)
    x_edges, z_edges = hp.uniform_edges(0.0, moving.L, 0.02), np.arange(-4e-3, 2.01e-3, 1e-3)
    gap = hp.GapKinematics(x_edges, z_edges, T, n_blocks=2)
    whole = hp.KinematicsAccumulator(x_edges, z_edges, T, n_blocks=2)
    gap.prepare()
    whole.prepare()
    for f in frames:
        gap.accumulate(f, moving, 1e-4)
        hp.accumulate_frame(whole, f, moving, 1e-4)
    profiles = gap.conclude()
    full = whole.conclude()
    per_x = pd.DataFrame([{"x": x, "x_over_L": x / moving.L, "usable": True,
                           "u_s": hp.surface_velocity(g["z"], g["u"])} for x, g in full.groupby("x")])
    table = hp.gap_surface_velocity(profiles, per_x)

    def mean_u(lo, hi):  # the mean of u over centres uniform on [max(lo, r), min(hi, T − r)]
        lo, hi = max(lo, r), min(hi, T - r)
        return quad(u_of_y, lo, hi)[0] / (hi - lo)
    w = hp.WALL_SLICE * T
    expected = {"wall": mean_u(0.0, w), "centre": mean_u(hp.CENTRE_SLICE[0] * T, hp.CENTRE_SLICE[1] * T),
                "gap": mean_u(0.0, T)}
    # u is the same at every depth: u_s is each slice's mean speed; ~4 frames × 40k particles in 6 streamwise
    # bins, the speeds' spread ~0.02 m/s: ~3e-4 m/s per bin and slice; 2e-3 is > 5σ
    assert_allclose(table["u_s_wall"], expected["wall"], atol=2e-3)
    assert_allclose(table["u_s_centre"], expected["centre"], atol=2e-3)
    assert_allclose(table["u_s"], expected["gap"], atol=2e-3)
    ratio_wall = (table["u_s_wall"] / table["u_s"]).mean()
    assert ratio_wall == pytest.approx(expected["wall"] / expected["gap"], abs=0.01)
    assert ratio_wall < 0.95 and (table["u_s_centre"] / table["u_s"]).mean() > 1.02
    # the slices' φ over their own widths, particles by centre: in the bin −2 < z < −1 mm, which every sphere
    # covers as uniformly as its centres (uniform over the 2.2 mm between −3 mm + r and −r), the wall slices'
    # share (w − r)/(T/2 − r) of the particles in L × 2.2 mm × 2w; ~1000 particles a bin-frame: 5 %
    v = 4 / 3 * np.pi * r**3
    inside = profiles["wall"][np.isclose(profiles["wall"]["z"], -1.5e-3)]
    n_wall = 40_000 * 2 * (w - r) / (T - 2 * r)
    phi_wall = n_wall * v / (moving.L * (3e-3 - 2 * r) * 2 * w)
    assert inside["phi"].mean() == pytest.approx(phi_wall, rel=0.05)


def deposit_particles(c_wall_up, c_centre_up, c_down, slab_noise=(0.0, 0.0, 0.0, 0.0)):
    """The record's deposit (normal depth δ to v_r' Δt under the final surface), four slabs, in every column: 20
    particles in the wall slices (y = 1 and 12 mm) and 20 in the centre (y = 6 mm), equal sizes; upstream of
    0.6 W the walls' small fraction c_wall_up + the slab's noise and the centre's c_centre_up, downstream c_down."""
    t_start, t_end, delta, dx = 10.0, 20.0, 5e-3, 0.01
    cos_a = math.cos(FIT.alpha)
    lo, hi = -FIT.v_r * cos_a * (t_end - t_start), -delta
    xc = 0.5 * (hp.uniform_edges(0.0, GEOMETRY.W, dx)[1:] + hp.uniform_edges(0.0, GEOMETRY.W, dx)[:-1])
    rows = []
    for x in xc:
        top = FIT.z_surface(x, t_end)
        for k in range(4):
            z = top + (lo + (k + 0.5) * (hi - lo) / 4) / cos_a
            up = x < 0.6 * GEOMETRY.W
            for ys, c in (((0.001, 0.012), (c_wall_up + slab_noise[k]) if up else c_down),
                          ((0.006,), c_centre_up if up else c_down)):
                n_small = int(round(c * 20))
                rows += [(x, ys[j % len(ys)], z, 1 if j < n_small else 2) for j in range(20)]
    x, y, z, kind = (np.array(v) for v in zip(*rows))
    return np.column_stack([x, y, z]), np.full(len(x), 0.3e-3), kind, (t_start, t_end, delta, dx)


def test_deposit_concentration_in_the_slices_and_its_contrast():
    pos, radius, kind, (t0, t1, delta, dx) = deposit_particles(0.6, 0.4, 0.5, slab_noise=(-0.1, 0.1, -0.1, 0.1))
    table = hp.deposit_gap(pos, radius, kind, FIT, GEOMETRY, t0, t1, delta, dx)
    assert set(table["variant"]) == {"central", "y by centre", "from 1.5 δ below the surface",
                                     "from 0.5 δ below the surface"}
    got = hp.gap_contrast(table, "central", GEOMETRY.x_feed, 0.6 * GEOMETRY.W, GEOMETRY.W)
    # equal sizes: volume fractions are number fractions; the slabs' contrasts 0.1, 0.3, 0.1, 0.3
    assert got["upstream"]["contrast"] == pytest.approx(0.2, abs=1e-12)
    assert got["upstream"]["wall"] == pytest.approx(0.6) and got["upstream"]["centre"] == pytest.approx(0.4)
    assert got["upstream"]["per_slab"] == pytest.approx([0.1, 0.3, 0.1, 0.3])
    assert got["upstream"]["se"] == pytest.approx(np.std([0.1, 0.3, 0.1, 0.3], ddof=1) / 2)
    assert got["downstream"]["contrast"] == pytest.approx(0.0, abs=1e-12)
    assert got["downstream"]["se"] == pytest.approx(0.0, abs=1e-12)
    # the spheres lie wholly inside their slices: by centre gives the same
    same = hp.gap_contrast(table, "y by centre", GEOMETRY.x_feed, 0.6 * GEOMETRY.W, GEOMETRY.W)
    assert same["upstream"]["contrast"] == pytest.approx(0.2, abs=1e-12)
    # a split further downstream moves downstream columns (contrast 0) into the upstream region
    later = hp.gap_contrast(table, "central", GEOMETRY.x_feed, 0.7 * GEOMETRY.W, GEOMETRY.W)
    n_up, n_mid = np.sum((np.arange(0.005, 0.12, 0.01) >= 0.02) & (np.arange(0.005, 0.12, 0.01) < 0.072)), 1
    assert later["upstream"]["contrast"] == pytest.approx(0.2 * n_up / (n_up + n_mid), abs=1e-12)


def test_deposit_slices_split_a_straddling_sphere():
    # one small sphere centred on the wall slice's edge (y = 4 mm) among large ones wholly in the centre: split
    # exactly, half its volume is the wall's (the wall's c_s is 1, the centre's below 1); by centre, all the centre's
    pos, radius, kind, (t0, t1, delta, dx) = deposit_particles(0.5, 0.5, 0.5)
    col = np.abs(pos[:, 0] - 0.035) < 1e-9
    keep = ~col | (np.abs(pos[:, 1] - 0.006) < 1e-9)     # in the column at 35 mm only the centre's particles
    pos, radius, kind = pos[keep], radius[keep], kind[keep]
    kind[np.abs(pos[:, 0] - 0.035) < 1e-9] = 2
    z = FIT.z_surface(0.035, t1) - 8e-3 / math.cos(FIT.alpha)
    pos = np.vstack([pos, [0.035, 0.004, z]])
    radius, kind = np.append(radius, 0.3e-3), np.append(kind, 1)
    table = hp.deposit_gap(pos, radius, kind, FIT, GEOMETRY, t0, t1, delta, dx)
    row = lambda variant, s: table[(table["variant"] == variant) & (table["slice"] == s) & (table["slab"] == 0)  # noqa: E731
                                   & (np.abs(table["x_lab"] - 0.035) < 1e-9)].iloc[0]
    assert row("central", "wall")["c_s"] == pytest.approx(1.0)
    assert row("central", "wall")["volume"] == pytest.approx(0.5 * 4 / 3 * np.pi * 0.3e-3 ** 3)
    assert row("central", "centre")["c_s"] == pytest.approx(0.5 / 80.5)   # 20 large a slab, four slabs
    assert np.isnan(row("y by centre", "wall")["c_s"])
    assert row("y by centre", "centre")["c_s"] == pytest.approx(1 / 81)
