"""Invariants of kernels, coordinates and time-averaged fields (postproc.fields)."""
import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy.special import erf

from postproc.coordinates import RZCoordinates, XCoordinates
from postproc.channel_profile import profile_from_frames
from postproc.fields import FIELDS, FieldAccumulator, field_columns
from postproc.frame import ParticleFrame
from postproc.kernels import Gaussian, HeavisideBins, channel_bin_edges

TENSOR = ("xx", "yy", "zz", "xy", "xz", "yz")


def box_of(W, Ly, Lz):
    return np.array([[0.0, W], [0.0, Ly], [0.0, Lz]])


def make_frame(rng, n, W, Ly=4.0, Lz=3.0, radius=None, velocity=None, omega=None, stress=None, x=None):
    """Particles uniform in the box; optional per-particle or shared kinematics."""
    position = rng.uniform([0, 0, 0], [W, Ly, Lz], size=(n, 3))
    if x is not None:
        position[:, 0] = x
    radius = rng.uniform(0.4, 0.6, n) if radius is None else np.full(n, float(radius))
    mass = rng.uniform(0.5, 2.0, n)
    v = rng.normal(size=(n, 3)) if velocity is None else np.broadcast_to(velocity, (n, 3)).copy()
    w = None if omega is None else np.broadcast_to(omega, (n, 3)).copy()
    return ParticleFrame(0, box_of(W, Ly, Lz), position, v, mass, radius, w, stress)


def bin_volumes(edges, Ly=4.0, Lz=3.0):
    return np.diff(edges) * Ly * Lz


def test_channel_bin_edges_wall_bins_and_even_remainder():
    edges = channel_bin_edges((0.0, 40.0))
    assert len(edges) - 1 == 39
    assert_allclose(np.diff(edges)[[0, -1]], 1.5)
    assert_allclose(np.diff(edges)[1:-1], 1.0)
    # 40.5 - 3 = 37.5 = 37 bins of 37.5/37: the remainder spread evenly
    edges = channel_bin_edges((0.0, 40.5))
    assert_allclose(np.diff(edges)[1:-1], 37.5 / 37)
    assert_allclose(edges[[0, -1]], [0.0, 40.5])


def test_binning_conserves_mass():
    rng = np.random.default_rng(1)
    W = 10.3
    frame = make_frame(rng, 500, W, omega=np.zeros(3))
    table = profile_from_frames([frame], W)
    V = bin_volumes(channel_bin_edges((0.0, W)))
    # sums of 500 O(1) numbers: round-off ~ 1e-14 relative, 1e-12 is safe
    assert_allclose(np.sum(table["rho"] * V), frame.mass.sum(), rtol=1e-12)
    assert_allclose(table["n"].sum(), 500, rtol=1e-12)


def test_uniform_packing_gives_flat_volume_fraction():
    rng = np.random.default_rng(2)
    W, Ly, Lz, n, n_frames, r = 20.0, 10.0, 10.0, 4000, 8, 0.25
    frames = [make_frame(rng, n, W, Ly, Lz, radius=r) for _ in range(n_frames)]
    table = profile_from_frames(frames, W)
    V = bin_volumes(channel_bin_edges((0.0, W)), Ly, Lz)
    v_p = 4 / 3 * np.pi * r**3
    phi_mean = n * v_p / (W * Ly * Lz)
    # count per bin is binomial(n, p) per frame: expected scatter of the time mean
    p = V / (W * Ly * Lz)
    sigma = v_p * np.sqrt(n * p * (1 - p) / n_frames) / V
    # 4 sigma: with 19 bins a false alarm has probability ~1e-3 (and the seed is fixed)
    assert np.all(np.abs(table["phi"] - phi_mean) < 4 * sigma)
    # block standard errors estimate the same scatter; with 7 degrees of freedom
    # each is uncertain by ~27 %, their median by much less
    assert 0.6 < np.median(table["phi_se"] / sigma) < 1.5


def test_rigid_translation_and_rotation_has_no_temperature_or_kinetic_stress():
    rng = np.random.default_rng(3)
    W, v0, w0 = 8.0, np.array([0.3, -1.2, 0.7]), np.array([2.0, 0.5, -1.0])
    frames = [make_frame(rng, 400, W, velocity=v0, omega=w0) for _ in range(3)]
    table = profile_from_frames(frames, W)
    # Σ m v / Σ m with equal v: sequential sums of 400 terms, error << 1e-12 relative
    assert_allclose(table[["u_x", "u_y", "u_z"]].to_numpy(), np.tile(v0, (len(table), 1)), rtol=1e-12)
    assert_allclose(table[["Omega_x", "Omega_y", "Omega_z"]].to_numpy(), np.tile(w0, (len(table), 1)), rtol=1e-12)
    # T and sigma_k are differences of O(rho |v|^2) ~ O(1) terms: 1e-12 absolute is
    # ~1e4 machine epsilons
    assert_allclose(table["T"], 0.0, atol=1e-12)
    assert_allclose(table[[f"sigmak_{c}" for c in TENSOR]].to_numpy(), 0.0, atol=1e-12)


def test_bin_velocity_fluctuations_between_frames_count_as_kinetic_stress():
    """The documented 'average primitives first' convention."""
    rng = np.random.default_rng(4)
    W, v1, v2 = 8.0, np.array([1.0, 0.0, 0.0]), np.array([0.0, 2.0, 0.0])
    first = make_frame(rng, 300, W, velocity=v1, omega=np.zeros(3))
    second = ParticleFrame(1, first.box, first.position, np.tile(v2, (300, 1)), first.mass, first.radius, first.omega)
    table = profile_from_frames([first, second], W)
    dv = v1 - v2
    rho = table["rho"].to_numpy()[:, None]
    expected = rho * np.array([dv[a] * dv[b] for a, b in ((0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2))]) / 4
    # O(1) terms combined a few times: round-off ~1e-15
    assert_allclose(table[[f"sigmak_{c}" for c in TENSOR]].to_numpy(), expected, atol=1e-12)
    V = bin_volumes(channel_bin_edges((0.0, W)))
    assert_allclose(table["T"], table["rho"] * (dv @ dv) / 4 / (6 * table["n"] / V), rtol=1e-12)


def test_linear_shear_gives_mass_weighted_bin_velocity():
    rng = np.random.default_rng(5)
    W, gamma = 10.0, 0.7
    frame = make_frame(rng, 600, W, velocity=np.zeros(3), omega=np.zeros(3))
    x = frame.position[:, 0]
    frame.velocity[:, 1] = gamma * x
    table = profile_from_frames([frame], W)
    edges = channel_bin_edges((0.0, W))
    b = np.searchsorted(edges, x, side="right") - 1
    m = np.bincount(b, frame.mass)
    x_mean = np.bincount(b, frame.mass * x) / m
    # u_y = γ Σ m x / Σ m computed two ways: round-off only
    assert_allclose(table["u_y"], gamma * x_mean, rtol=1e-12)
    assert_allclose(table[["u_x", "u_z"]].to_numpy(), 0.0, atol=0.0)
    # the within-bin gradient is 'temperature': T = γ² Σ m (x - x̄)² / (6 N);
    # the derivation subtracts O(γ² x̄²) terms to get O(γ² d²) ones, losing
    # log10((W/d)^2) ~ 2 digits, so 1e-10 is ample
    spread = np.bincount(b, frame.mass * (x - x_mean[b]) ** 2)
    assert_allclose(table["T"], gamma**2 * spread / (6 * np.bincount(b)), rtol=1e-10)


def test_heaviside_weight_times_volume_is_one():
    coords = XCoordinates((0.0, 10.0))
    edges = channel_bin_edges((0.0, 10.0))
    kernel = HeavisideBins(edges)
    box = box_of(10.0, 4.0, 3.0)
    a = kernel.assign(np.array([[0.2], [5.3], [11.0]]), coords, box)
    assert list(a.particle) == [0, 1]  # the particle outside all bins is dropped
    # weight is exactly 1/V: product is one up to a single rounding
    assert_allclose(a.weight * kernel.node_volumes(coords, box)[a.node], 1.0, rtol=1e-15)


def test_gaussian_x_weight_times_volume_is_one():
    w, c, h, xp = 0.8, 2.4, 0.01, 5.0
    # nodes at xp + k h with the cutoff midway between nodes: the node sum is the
    # midpoint rule on [-c, c], error h²/24 |g'(c) - g'(-c)| (tolerance: 10×)
    k = np.arange(-400, 401)
    c = (240 + 0.5) * h
    kernel = Gaussian(w, c, xp + k * h)
    coords, box = XCoordinates(), box_of(10.0, 4.0, 3.0)
    a = kernel.assign(np.array([[xp]]), coords, box)
    total = np.sum(a.weight * kernel.node_volumes(coords, box)[a.node])
    g_edge = np.exp(-0.5 * (c / w) ** 2) / (np.sqrt(2 * np.pi) * w * erf(c / np.sqrt(2) / w))
    tolerance = 10 * h**2 / 24 * 2 * (c / w**2) * g_edge
    assert abs(total - 1.0) < tolerance
    assert tolerance < 1e-5  # the check is tight


@pytest.mark.parametrize("r_p, tolerance", [(2.0, 1e-4), (0.0, 1e-3)])
def test_gaussian_rz_integrates_to_one(r_p, tolerance):
    """Σ w × 2π r dr dz over a midpoint (r, z) grid of spacing h = w/20.

    The kernel is continuous except across the truncation sphere (jump e^{-4.5}
    of the peak for c = 3w). Off the axis the azimuthal average smooths that
    jump and the midpoint rule converges as ~h² (measured 8e-7 here); on the axis
    it stays a jump and converges as ~h^1.5 (measured 3e-4).
    """
    w, c = 0.5, 1.5
    h = w / 20
    r = np.arange(h / 2, r_p + c + h, h)
    z = np.arange(-c - h / 2, c + h, h)
    kernel, coords = Gaussian(w, c, (r, z)), RZCoordinates()
    a = kernel.assign(np.array([[r_p, 0.013]]), coords, None)
    dV = 2 * np.pi * np.repeat(r, len(z)) * h * h
    assert_allclose(kernel.node_volumes(coords, None), dV, rtol=1e-12)
    assert abs(np.sum(a.weight * dV[a.node]) - 1.0) < tolerance


def test_gaussian_rz_accumulator_conserves_mass():
    rng = np.random.default_rng(6)
    n, R, H = 300, 3.0, 4.0
    rad, theta = R * np.sqrt(rng.uniform(size=n)), rng.uniform(0, 2 * np.pi, n)
    frame = make_frame(rng, n, 1.0, omega=np.zeros(3))
    frame.position[:] = np.column_stack([5 + rad * np.cos(theta), 5 + rad * np.sin(theta), rng.uniform(0, H, n)])
    w, c, h = 0.5, 1.5, 0.1
    kernel = Gaussian(w, c, (np.arange(h / 2, R + c, h), np.arange(-c, H + c, h)))
    acc = FieldAccumulator(kernel, RZCoordinates((5.0, 5.0)), n_blocks=2)
    acc.prepare()
    acc.accumulate(frame)
    table = acc.conclude()
    assert {"r", "z"} <= set(table.columns)
    # grid quadrature error per particle at h = w/5: ~3e-5 off the axis, ~2e-3 on
    # it (scaling the measurements of the test above); few particles sit near the axis
    total = np.sum(table["rho"] * kernel.node_volumes(acc.coordinates, frame.box))
    assert_allclose(total, frame.mass.sum(), rtol=1e-3)


def test_contact_stress_is_sum_over_bin_volume():
    rng = np.random.default_rng(7)
    W = 6.0
    stress = rng.normal(size=(50, 6))
    frame = make_frame(rng, 50, W, omega=np.zeros(3), stress=stress)
    table = profile_from_frames([frame], W)
    edges = channel_bin_edges((0.0, W))
    b = np.searchsorted(edges, frame.position[:, 0], side="right") - 1
    expected = np.column_stack([np.bincount(b, stress[:, k], minlength=len(edges) - 1) for k in range(6)])
    expected /= bin_volumes(edges)[:, None]
    # sums of ~10 O(1) numbers: round-off only
    assert_allclose(table[[f"sigmac_{c}" for c in TENSOR]].to_numpy(), expected, rtol=1e-12, atol=1e-15)
    total = table[[f"sigmac_{c}" for c in TENSOR]].to_numpy() + table[[f"sigmak_{c}" for c in TENSOR]].to_numpy()
    assert_allclose(table[[f"sigma_{c}" for c in TENSOR]].to_numpy(), total, rtol=1e-14)


def test_fields_needing_missing_data_are_omitted():
    rng = np.random.default_rng(8)
    acc = FieldAccumulator(HeavisideBins(channel_bin_edges((0.0, 6.0))), XCoordinates((0.0, 6.0)))
    acc.prepare()
    acc.accumulate(make_frame(rng, 40, 6.0))  # no omega, no contact stress
    table = acc.conclude()
    assert set(acc.omitted_fields) == {"Omega", "T", "sigmac", "sigma"}
    assert not any(col.startswith(("Omega", "T", "sigmac", "sigma_")) for col in table.columns)
    assert "sigmak_xy" in table.columns and "u_x" in table.columns


def test_standard_errors_shrink_with_frames_and_cover_every_field():
    rng = np.random.default_rng(9)
    W, n = 10.0, 1000
    template = make_frame(rng, n, W, omega=np.zeros(3), stress=np.zeros((n, 6)))
    template.mass[:] = 1.0

    def run(n_frames):
        frames = [
            ParticleFrame(i, template.box, template.position, rng.normal(size=(n, 3)), template.mass,
                          template.radius, rng.normal(size=(n, 3)), rng.normal(size=(n, 6)))
            for i in range(n_frames)
        ]
        return profile_from_frames(frames, W)

    short, long = run(16), run(256)
    # 16x the frames: se / 4. Each se has 7 degrees of freedom (±27 %); averaged
    # over 9 bins the ratio is known to ~±10 %, so [3, 5.3] is a loose check
    ratio = np.mean(short["u_x_se"]) / np.mean(long["u_x_se"])
    assert 3.0 < ratio < 5.3
    # and the size is right: se(u_x) ≈ 1 / sqrt(frames × particles in the bin)
    assert_allclose(np.mean(long["u_x_se"] * np.sqrt(256 * long["n"])), 1.0, rtol=0.15)
    value_columns = [c for f in FIELDS for c in field_columns(f)]
    for column in value_columns:
        assert f"{column}_se" in long.columns
        assert np.all(np.isfinite(long[f"{column}_se"]))
    # positions are fixed, so only velocity-, spin- and stress-derived fields fluctuate
    fluctuating = [c for f in ("u", "Omega", "T", "sigmac", "sigmak", "sigma") for c in field_columns(f)]
    assert np.all(long[[f"{c}_se" for c in fluctuating]].to_numpy() > 0)


def test_long_runs_average_exactly_over_all_frames():
    """Sub-block merging must not change the time average."""
    rng = np.random.default_rng(10)
    counts = rng.integers(20, 60, size=301)
    frames = [make_frame(rng, k, 6.0) for k in counts]
    table = profile_from_frames(frames, 6.0, n_blocks=4)
    # mean count summed over bins = mean particle number; round-off only
    assert_allclose(table["n"].sum(), counts.mean(), rtol=1e-12)
    assert np.all(np.isfinite(table["n_se"]))


def test_lifecycle_errors():
    rng = np.random.default_rng(11)
    acc = FieldAccumulator(HeavisideBins(channel_bin_edges((0.0, 6.0))), XCoordinates((0.0, 6.0)))
    with pytest.raises(RuntimeError, match="before conclude"):
        acc.result
    with pytest.raises(RuntimeError, match="before prepare"):
        acc.accumulate(make_frame(rng, 10, 6.0))
    acc.prepare()
    with pytest.raises(RuntimeError, match="first frame"):
        acc.fields
    with pytest.raises(RuntimeError, match="before any frame"):
        acc.conclude()
    acc.accumulate(make_frame(rng, 10, 6.0))
    assert acc.conclude() is acc.result
    with pytest.raises(RuntimeError, match="concluded"):
        acc.accumulate(make_frame(rng, 10, 6.0))
    with pytest.raises(ValueError, match="unknown fields"):
        FieldAccumulator(HeavisideBins([0.0, 1.0]), XCoordinates(), fields=("pressure",))


def test_z_profile_equals_x_profile_of_the_rotated_frame():
    """XCoordinates(axis="z") resolves height: permuting x and z of every vector and tensor
    leaves each field unchanged (the same bins, the same particles)."""
    rng = np.random.default_rng(11)
    W = 8.0
    stress = rng.normal(size=(300, 6))
    frame = make_frame(rng, 300, W, omega=rng.normal(size=3), stress=stress)
    perm = [2, 1, 0]
    # tensor order xx yy zz xy xz yz -> under x<->z: zz yy xx zy zx yx = (2, 1, 0, 5, 4, 3)
    rotated = ParticleFrame(0, frame.box[perm], frame.position[:, perm], frame.velocity[:, perm], frame.mass,
                            frame.radius, frame.omega[:, perm], stress[:, [2, 1, 0, 5, 4, 3]])
    edges = np.linspace(0.0, W, 9)
    fields = ("n", "phi", "rho", "u", "sigmac")
    by_x = FieldAccumulator(HeavisideBins(edges), XCoordinates(), fields=fields)
    by_z = FieldAccumulator(HeavisideBins(edges), XCoordinates(axis="z"), fields=fields)
    for acc, fr in ((by_x, frame), (by_z, rotated)):
        acc.prepare()
        acc.accumulate(fr)
    tx, tz = by_x.conclude(), by_z.conclude()
    assert_allclose(tz["z"], tx["x"])
    # identical sums in another order: round-off only
    for a, b in (("rho", "rho"), ("phi", "phi"), ("u_z", "u_x"), ("u_x", "u_z"), ("sigmac_xz", "sigmac_xz"),
                 ("sigmac_zz", "sigmac_xx")):
        assert_allclose(tz[a], tx[b], rtol=1e-12, atol=1e-12)
    with pytest.raises(ValueError, match="axis"):
        XCoordinates(axis="r")


def test_frame_fluctuations_leave_out_a_change_of_the_whole_bins_speed():
    """fluctuation="frame": a bin whose particles all change speed together between frames has no T and
    no kinetic stress; scatter about each frame's own mean is kept, and equals the window's reading when
    the mean does not move."""
    rng = np.random.default_rng(11)
    W, n = 8.0, 400
    base = make_frame(rng, n, W, velocity=np.zeros(3), omega=np.zeros(3))
    noise = [rng.normal(0, 0.1, (n, 3)) for _ in range(6)]
    spins = [rng.normal(0, 0.2, (n, 3)) for _ in range(6)]

    def frames(shift):
        return [ParticleFrame(k, base.box, base.position, noise[k] + shift * k * np.array([0, 1.0, 0]),
                              base.mass, base.radius, spins[k]) for k in range(6)]

    still_w = profile_from_frames(frames(0.0), W)
    still_f = profile_from_frames(frames(0.0), W, fluctuation="frame")
    moving_w = profile_from_frames(frames(0.5), W)
    moving_f = profile_from_frames(frames(0.5), W, fluctuation="frame")
    # the whole bin's speed steps by 0.5 per frame: the window's T gains the steps' variance, the frame's does not
    assert_allclose(moving_f["T"], still_f["T"], rtol=1e-10)
    assert (moving_w["T"] > 10 * still_w["T"]).all()
    # without a moving mean the two readings differ only by the frames' bin means' scatter about the window's
    assert_allclose(still_f["T"], still_w["T"], rtol=0.1)
    # the frame's T is the scatter of each particle about its bin's mean at that instant, spin included
    b = np.digitize(base.position[:, 0], channel_bin_edges((0.0, W))) - 1
    expected = []
    for j in range(len(moving_f)):
        num = den = 0.0
        for k in range(6):
            pick = b == j
            m, v, w = base.mass[pick], noise[k][pick], spins[k][pick]
            vbar = (m[:, None] * v).sum(axis=0) / m.sum()
            I = base.moment_of_inertia[pick]
            wbar = (I[:, None] * w).sum(axis=0) / I.sum()
            num += (m * ((v - vbar) ** 2).sum(axis=1)).sum() + (I * ((w - wbar) ** 2).sum(axis=1)).sum()
            den += 6 * pick.sum()
        expected.append(num / den)
    assert_allclose(moving_f["T"], expected, rtol=1e-10)
    assert_allclose(moving_f[[f"sigmak_{c}" for c in TENSOR]].to_numpy(),
                    still_f[[f"sigmak_{c}" for c in TENSOR]].to_numpy(), rtol=1e-8, atol=1e-12)
    with pytest.raises(ValueError, match="fluctuation"):
        FieldAccumulator(HeavisideBins(channel_bin_edges((0.0, W))), XCoordinates(walls=(0.0, W)), fluctuation="bin")


def test_a_whole_channels_change_of_speed_leaves_the_shear_rates_error_alone():
    """The channel profile's du_y/dx (postproc.channel_profile.shear_rate) takes its error from each block's
    own gradient (FieldAccumulator.errors_of): particles in a fixed linear shear whose whole channel changes
    speed from frame to frame give the shear exactly, with an error far below the bins' errors propagated as
    independent (which count the common change of speed twice per gradient)."""
    from postproc.channel_profile import SHEAR, shear_rate

    rng = np.random.default_rng(13)
    W, n, gamma = 12.0, 800, 0.3
    base = make_frame(rng, n, W, velocity=np.zeros(3), omega=np.zeros(3))
    x = base.position[:, 0]
    frames = []
    for k in range(64):
        v = np.zeros((n, 3))
        v[:, 1] = gamma * x + rng.normal(0.0, 2.0) + rng.normal(0.0, 0.01, n)   # a common jump of ~2 per frame
        frames.append(ParticleFrame(k, base.box, base.position, v, base.mass, base.radius, np.zeros((n, 3))))
    table = profile_from_frames(frames, W)
    # the bins' mass-weighted mean x differs from their centres: the exact gradient of the binned u_y
    edges = channel_bin_edges((0.0, W))
    b = np.searchsorted(edges, x, side="right") - 1
    x_mean = np.bincount(b, base.mass * x) / np.bincount(b, base.mass)
    assert_allclose(table[SHEAR], shear_rate(table["x"].to_numpy(), gamma * x_mean), atol=0.01)
    se = table[f"{SHEAR}_se"].to_numpy()
    propagated = np.sqrt(2) * table["u_y_se"].to_numpy() / 2          # two bins 2 apart, errors independent
    assert np.all(se[1:-1] < 0.05 * propagated[1:-1])
    assert list(table.columns).index(SHEAR) < list(table.columns).index("n_se")   # a field among the fields


def test_a_whole_channels_change_of_speed_leaves_the_scaled_velocitys_error_alone():
    """The channel profile's (u − u_slip)/(u_max − u_slip) (postproc.channel_profile.scaled_velocity) takes its
    error from each block's own scaling: a profile of the paper's shape whose whole channel jumps speed from
    frame to frame gives the scaled profile of its mean, with an error far below the bins' own over the span."""
    from postproc.channel_profile import SCALED, scaled_velocity

    rng = np.random.default_rng(17)
    W, n = 12.0, 1600
    base = make_frame(rng, n, W, velocity=np.zeros(3), omega=np.zeros(3))
    x = base.position[:, 0]
    xw = np.minimum(x, W - x)
    shape = 10.0 + 5.0 * (1.0 - np.exp(-xw))
    frames = []
    for k in range(64):
        v = np.zeros((n, 3))
        v[:, 1] = -(shape + rng.normal(0.0, 2.0)) + rng.normal(0.0, 0.01, n)   # downward; a common jump of ~2
        frames.append(ParticleFrame(k, base.box, base.position, v, base.mass, base.radius, np.zeros((n, 3))))
    table = profile_from_frames(frames, W)
    assert_allclose(table[SCALED], scaled_velocity(table["u_y"].to_numpy()), atol=1e-9)
    # the mean profile's scaling is the bins' own shape's: 0 at the walls' mean, 1 at the fastest bin
    assert abs(0.5 * (table[SCALED].iloc[0] + table[SCALED].iloc[-1])) < 1e-9 and table[SCALED].max() == 1.0
    span = float(np.abs(table["u_y"]).max() - np.abs(table["u_y"]).iloc[[0, -1]].mean())
    se = table[f"{SCALED}_se"].to_numpy()
    assert np.all(se < 0.05 * table["u_y_se"].to_numpy() / span)
