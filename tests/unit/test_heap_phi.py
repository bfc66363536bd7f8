"""Known-answer tests of the heap's φ in depth (granflow.scenes.heap.analysis.phi; Fan et al. 2013, §3.1, Fig. 4a):
the static bed of a layered heap, the fall of a piecewise-linear φ(z) in each band, φ above the surface, the
surface found with two cutoffs on a tanh profile, and the columns' tilt removed under a sloping packing."""
from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest
from numpy.testing import assert_allclose
from scipy.optimize import brentq

from granflow.scenes.heap import analysis as hp

GEOMETRY = hp.HeapGeometry(W=0.1, T=0.01, theta_deg=24.0, x_feed=0.02)


# --------------------------------------------------------------------------- the static bed
def layered_frames(alpha_deg, delta, n_frames=4, dz=1e-3):
    """Lab columns (dx = 10 mm, dz = 1 mm) under a surface a quarter bin above an edge, rising 1 mm a frame (no
    window's end and no region's edge falls on a bin's edge or centre: exact counts); φ = 0.5 in the
    flowing layer (< δ/cos α under the surface), 0.58 in the creeping region (δ to 2δ), the bed's φ below, which
    differs by column (0.64 + 0.002 (j − 5)); 0.45 within 1 mm of the base (inside the 2 d̄ clearance)."""
    cos_a = math.cos(math.radians(alpha_deg))
    x_edges = hp.uniform_edges(0.0, GEOMETRY.W, 0.01)
    z_edges = np.arange(0.0, 0.2 + dz / 2, dz)
    zc = 0.5 * (z_edges[1:] + z_edges[:-1])
    j = np.arange(len(x_edges) - 1)
    bed = 0.64 + 0.002 * (j - 5)
    z_base = GEOMETRY.z_base(x_edges[:-1])
    phis, surfaces = [], []
    for k in range(n_frames):
        zs = np.full(len(j), 0.15025 + k * dz)
        depth = zs[:, None] - zc[None, :]
        phi = np.where(depth < delta / cos_a, 0.5, np.where(depth < 2 * delta / cos_a, 0.58, bed[:, None]))
        phi = np.where(zc[None, :] < z_base[:, None] + 1e-3, 0.45, phi)
        phi = np.where(zc[None, :] < z_base[:, None], 0.0, phi)
        phis.append(np.where(depth < 0, 0.0, phi))
        surfaces.append(zs)
    return phis, np.array(surfaces), x_edges, z_edges, bed


def test_static_bed_reads_below_the_creeping_region_away_from_base_and_walls():
    # α = 60°: depths normal to the surface double vertically; δ = 2 mm, d̄ = 0.5 mm: the central bed lies 8 to
    # 28 mm under the surface (19 whole bins, all bed), the 1.5 δ variant 6 to 26 mm (2 of its 19 bins in the
    # creeping region's 0.58)
    delta, d_bar = 2e-3, 0.5e-3
    phis, zs, x_edges, z_edges, bed = layered_frames(60.0, delta)
    table = hp.static_bed_table(phis, zs, x_edges, z_edges, GEOMETRY, delta=delta, d_bar=d_bar, alpha_deg=60.0)
    keep = hp.bed_columns(x_edges, GEOMETRY)
    # columns: centres more than one column past the feed zone's edge, not the last (the end wall's)
    assert_allclose(table.loc[table["top_over_delta"] == 2.0, "x_lab"], [0.035, 0.045, 0.055, 0.065, 0.075, 0.085])
    assert not keep[-1] and keep.sum() == 6
    central = table[table["top_over_delta"] == 2.0]
    assert_allclose(central[["depth_lo", "depth_hi"]].iloc[0], [0.008, 0.028], rtol=1e-12)
    # each column's bed exactly its own φ
    assert_allclose(central["phi"], bed[keep], rtol=1e-12)
    assert (central["n_frames"] == 4).all()
    value, se, n = hp.static_bed_phi(table)
    assert n == 6 and value == pytest.approx(bed[keep].mean(), rel=1e-12)
    assert se == pytest.approx(np.std(bed[keep], ddof=1) / math.sqrt(6), rel=1e-12)
    shallow = table[table["top_over_delta"] == 1.5]
    assert_allclose(shallow["phi"], (2 * 0.58 + 17 * bed[keep]) / 19, rtol=1e-12)


def test_static_bed_leaves_out_the_base_and_a_column_without_bed():
    # a heap 15 mm deep over a flat base at 135 mm: the bins within 2 d̄ (1 mm) of the base, looser, are not read
    delta, d_bar = 2e-3, 0.5e-3
    geometry = hp.HeapGeometry(W=0.1, T=0.01, theta_deg=0.0, x_feed=0.02, z_base_end=0.135)
    phis, zs, x_edges, z_edges, bed = layered_frames(60.0, delta, n_frames=1)
    z_base = geometry.z_base(x_edges[:-1])
    zc = 0.5 * (z_edges[1:] + z_edges[:-1])
    phi = phis[0]
    phi[:, zc < z_base[0] + 1e-3] = 0.45      # looser packing within 1 mm of the base
    phi[:, zc < z_base[0]] = 0.0
    table = hp.static_bed_table([phi], zs, x_edges, z_edges, geometry, delta=delta, d_bar=d_bar, alpha_deg=60.0,
                                tops=(2.0, 3.0))
    keep = hp.bed_columns(x_edges, geometry)
    assert_allclose(table.loc[table["top_over_delta"] == 2.0, "phi"], bed[keep], rtol=1e-12)  # 136-142 mm read
    # 3δ: 12 to 32 mm under the surface at 150.25 mm is 118.25-138.25 mm; the clearance ends at 136 mm: the two
    # bins 136-138 mm are read, the bed's
    assert_allclose(table.loc[table["top_over_delta"] == 3.0, "phi"], bed[keep], rtol=1e-12)
    deeper = hp.static_bed_table([phi], zs - 0.004, x_edges, z_edges, geometry, delta=delta, d_bar=d_bar,
                                 alpha_deg=60.0, tops=(3.0,))
    assert deeper["phi"].isna().all() and (deeper["n_frames"] == 0).all()   # window wholly in the clearance
    assert math.isnan(hp.static_bed_phi(deeper, 3.0)[0])


# --------------------------------------------------------------------------- the surface's cutoff
def tanh_frames(widths, n_frames=6, dz=1e-4, seed=0):
    """φ = 0.3 (1 − tanh((z − z_m)/w)) per column (w by column), z_m wandering from frame to frame."""
    rng = np.random.default_rng(seed)
    z_edges = np.arange(0.0, 0.06 + dz / 2, dz)
    zc = 0.5 * (z_edges[1:] + z_edges[:-1])
    x_edges = hp.uniform_edges(0.0, GEOMETRY.W, 0.01)
    w = np.asarray(widths)[:, None]
    phis = [0.3 * (1 - np.tanh((zc[None, :] - rng.uniform(0.02, 0.04, (len(widths), 1))) / w))
            for _ in range(n_frames)]
    return phis, x_edges, z_edges


def test_surface_cutoffs_on_a_tanh_profile():
    # 0.3 (1 − tanh s) = c  <=>  s = artanh(1 − c/0.3): the cutoffs 0.1 and 0.5 lie w (artanh(2/3) + artanh(2/3))
    # apart whatever the surface's height
    widths = np.linspace(0.5e-3, 1.4e-3, 10)
    phis, x_edges, z_edges = tanh_frames(widths)
    table = hp.surface_cutoff_table(phis, x_edges, z_edges)
    expected = 2 * widths * np.arctanh(2 / 3)
    # linear interpolation between centres errs by ~dz² |φ''/φ'|/8 at a crossing, 2 dz² tanh(s)/(8 w) ≤ 4 µm
    # here (w ≥ 0.5 mm, dz = 0.1 mm): 10 µm
    assert_allclose(table["span_mean"], expected, rtol=0, atol=1e-5)
    assert_allclose(table["span_median"], expected, rtol=0, atol=1e-5)
    assert (table["n_frames"] == 6).all() and table.attrs["cutoffs"] == hp.PHI_C_RANGE
    assert (table["span_se"] < 1e-5).all()          # the span does not wander with the surface
    assert table["span_tilt_free_mean"].isna().all()
    d = 1e-3
    got = hp.surface_cutoff_max(table, (0.0, GEOMETRY.W), d)
    assert got["value"] == pytest.approx(expected[-1] / d, abs=0.03) and got["x_lab"] == pytest.approx(0.095)
    inner = hp.surface_cutoff_max(table, (0.0, 0.05), d)          # the largest of the first five columns
    assert inner["value"] == pytest.approx(expected[4] / d, abs=0.03) and inner["n"] == 5
    assert hp.surface_cutoff_max(table, (0.2, 0.3), d)["n"] == 0


def sloping_packing(geometry, alpha_deg, phi0, r, rng, depth=0.006):
    """Overlapping spheres with centres uniform under the plane z = 0.06 − x tan α (a step surface)."""
    v = 4 / 3 * np.pi * r**3
    n = int(phi0 * geometry.W * geometry.T * depth / v)
    x = rng.uniform(0.0, geometry.W, n)
    z = 0.06 - x * math.tan(math.radians(alpha_deg)) - depth * rng.random(n)
    return np.column_stack([x, rng.uniform(0, geometry.T, n), z]), np.full(n, r)


def test_tilt_free_spans_remove_the_columns_slope():
    """Centres uniform under a plane sloping at 30°: normal to it, φ/φ0 is the fraction of a sphere below a
    plane s r above its centre, so heights measured from the surface line spread it as a sphere of radius
    r/cos α; the vertical columns (10 mm wide) add 0.4/φ0 of their 5.8 mm of surface height between the cutoffs."""
    rng = np.random.default_rng(3)
    geometry = hp.HeapGeometry(W=0.1, T=0.05, theta_deg=24.0, x_feed=0.02)   # a wide gap: many spheres per bin
    alpha, phi0, r, dz, n_frames = 30.0, 0.6, 0.5e-3, 1e-4, 10
    x_edges = hp.uniform_edges(0.0, geometry.W, 0.01)
    xc = 0.5 * (x_edges[1:] + x_edges[:-1])
    line = 0.06 - xc * math.tan(math.radians(alpha))
    z_edges = np.arange(0.0, 0.08, dz)
    tilt, vertical = [], []
    for _ in range(n_frames):
        pos, radius = sloping_packing(geometry, alpha, phi0, r, rng)
        tilt.append(hp.tilt_free_spans(pos, radius, line, x_edges, geometry.T, alpha, dz, 1e-3))
        phi, _, _ = hp.volume_fraction_columns(pos, radius, geometry, 0.01, dz, 0.0, 0.08)
        vertical.append(hp.free_surface(phi, z_edges, 0.1) - hp.free_surface(phi, z_edges, 0.5))
    below = lambda s, c: (1 + s) ** 2 * (2 - s) / 4 - c / phi0  # noqa: E731
    s_lo, s_hi = (brentq(below, -1.0, 1.0, args=(c,)) for c in hp.PHI_C_RANGE)
    expected = (s_hi - s_lo) * r / math.cos(math.radians(alpha))
    inner = slice(1, -1)                                # the line is flat beyond the first and last centres
    tilt = np.array(tilt)[:, inner]
    # φ of a bin scatters by ~3 % near the crossings (~600 spheres touch it), moving a crossing by ~50 µm in a
    # frame: each column's mean over the frames is within 5 of its errors, their mean within 5 of its own
    column_se = tilt.std(axis=0, ddof=1) / math.sqrt(n_frames)
    assert np.all(np.abs(tilt.mean(axis=0) - expected) < 5 * column_se)
    assert abs(tilt.mean() - expected) < 5 * tilt.mean(axis=0).std(ddof=1) / math.sqrt(tilt.shape[1])
    spread = 0.01 * math.tan(math.radians(alpha))
    assert np.mean(vertical, axis=0)[inner].mean() > expected + 0.5 * 0.4 / phi0 * spread
    assert np.isnan(hp.tilt_free_spans(pos, radius, np.full(len(xc), np.nan), x_edges, geometry.T, alpha, dz,
                                       1e-3)).all()


# --------------------------------------------------------------------------- φ(z) through the heap
DELTA, D_BAR, D_L = 6e-3, 1e-3, 2e-3


def piecewise_phi(z, upstream: bool):
    """0.64 in the bed, falling 0.04 per δ in the creeping region (−2δ..−δ), 0.05 over the layer (−δ..−d̄/2),
    0.4 over the top diameter (0.35 at z = 0), to 0 at d_l; 0.01 above d_l upstream (bouncing), 0 downstream."""
    z = np.asarray(z, float)
    top_lo, top_hi = -D_BAR / 2, D_BAR / 2
    phi = np.select(
        [z < -2 * DELTA, z < -DELTA, z < top_lo, z < top_hi, z < D_L],
        [0.64, 0.60 - 0.04 * (z + DELTA) / DELTA, 0.55 - 0.05 * (z - top_lo) / (DELTA + top_lo),
         0.35 - 0.4 * z / D_BAR, 0.15 * (D_L - z) / (D_L - top_hi)],
        0.01 if upstream else 0.0)
    return phi


def phi_profile_frame(offsets, dz=D_BAR / 4, L=0.1):
    """A φ accumulator's profile: 10 streamwise bins, z from the fitted plane; each bin's surface ``offsets`` above it."""
    x_edges = hp.uniform_edges(0.0, L, L / 10)
    z_edges = np.arange(-120, 60) * dz       # −30 to +15 d̄; the band ends fall on bin edges
    rows = []
    for i, off in enumerate(offsets):
        zc = 0.5 * (z_edges[1:] + z_edges[:-1])
        rows.append(pd.DataFrame({"x": 0.5 * (x_edges[i] + x_edges[i + 1]), "z": zc + off, "z_lo": z_edges[:-1] + off,
                                  "z_hi": z_edges[1:] + off, "phi": piecewise_phi(zc, upstream=i < 3)}))
    return pd.concat(rows, ignore_index=True), x_edges


def test_band_falls_and_phi_above_of_a_piecewise_profile():
    offsets = 2.5e-4 * np.arange(10) - 1e-3
    prof, x_edges = phi_profile_frame(offsets)
    base = np.full(10, -1.0)
    base[5] = offsets[5] - 1.5 * DELTA - 2 * D_BAR    # the base 1.5δ + clearance under the surface: half the creep band
    table = hp.phi_profile_table(prof, base)
    # the local surface (φ = 0.35, inside the top's straight piece) is each bin's offset
    per_bin = table.groupby("x").first()
    assert_allclose(per_bin["z_surface"], offsets, atol=1e-12)
    assert_allclose(per_bin["z_base"].iloc[5], -1.5 * DELTA - 2 * D_BAR, atol=1e-12)
    assert_allclose(table.groupby("x")["z"].apply(lambda z: z.iloc[0]), -30 * D_BAR + D_BAR / 8, atol=1e-12)
    xc = 0.5 * (x_edges[1:] + x_edges[:-1])
    per_x = pd.DataFrame({"x": xc, "x_over_L": xc / 0.1, "delta": DELTA, "usable": [True] * 9 + [False]})
    falls = hp.band_falls(table, per_x, D_BAR)
    assert len(falls) == 9                                        # the unusable bin has no δ
    # each band's bins lie on one straight piece: the falls are exact (the base's column keeps 2 creep bins)
    assert_allclose(falls["creep"], 0.04, rtol=1e-9)
    assert_allclose(falls["layer"], 0.05 / (1 - D_BAR / (2 * DELTA)), rtol=1e-9)
    assert_allclose(falls["top"], 0.4 * DELTA / D_BAR, rtol=1e-9)
    # a base nearer than the clearance everywhere: no creep band left
    assert hp.band_falls(table.assign(z_base=-1.2 * DELTA), per_x, D_BAR)["creep"].isna().all()
    above = hp.phi_above(table, D_L, D_L + 10 * D_BAR, 0.1)
    assert_allclose(above["phi_above"], [0.01] * 3 + [0.0] * 7, atol=1e-12)
    assert_allclose(above["x_over_L"], xc / 0.1)


def test_base_height_in_the_moving_frame():
    fit = hp.SurfaceFit(alpha_deg=26.0, alpha_se=0.0, v_r=5e-3, v_r_se=0.0, z0=0.08)
    geometry = hp.HeapGeometry(W=0.12, T=0.013, theta_deg=24.0, x_feed=0.02)
    moving = hp.MovingFrame(fit, geometry)
    x_edges = hp.uniform_edges(0.0, moving.L, 0.01)
    t = 2.0
    base = hp.base_height(moving, geometry, t, x_edges)
    # along the base the moving z is linear in the moving x: the highest point of a bin is at one of its ends
    a, th = math.radians(26.0), math.radians(24.0)
    x0, z0 = moving.origin(t)

    def z_at(x):  # the base point with moving coordinate x: solve (x_lab − x0) cos a − (z_b − z0) sin a = x
        x_lab = brentq(lambda xl: (xl - x0) * math.cos(a) - (geometry.z_base(xl) - z0) * math.sin(a) - x, -1, 1)
        return (x_lab - x0) * math.sin(a) + (geometry.z_base(x_lab) - z0) * math.cos(a), x_lab
    for k in range(len(base)):
        ends = [z_at(x) for x in x_edges[k:k + 2]]
        inside = [z for z, xl in ends if 0 <= xl <= geometry.W]
        if inside:
            # sampled every W/4000 along the base: within one sample's rise (tan(α − θ) · 30 µm)
            assert base[k] == pytest.approx(max(inside), abs=3e-5 * math.tan(a - th) + 1e-9)
    assert base[0] < -0.02                   # the base lies well under the surface there
