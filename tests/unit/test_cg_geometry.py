"""Coarse-graining in every coordinate choice (x, xz, xyz, r, rz) with every kernel (bins, Gaussian, Lucy).

Known answers: kernel normalisation on fine grids, Lucy's closed-form integrals,
brute-force weights, the r kernel as the rz kernel integrated over z, flat
volume fraction of a lattice, the exact sphere-slab split, rigid rotation in
the cylindrical basis.
"""
import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy.integrate import quad
from scipy.special import gammainc

from postproc.coordinates import CartesianCoordinates, RCoordinates, RZCoordinates, XCoordinates
from postproc.fields import FieldAccumulator, _kernel_width
from postproc.frame import ParticleFrame
from postproc.kernels import Gaussian, HeavisideBins, Lucy, RadialKernel
from postproc.overlap import slab_pairs, sphere_slab_fraction

BOX = np.array([[0.0, 10.0], [0.0, 4.0], [0.0, 3.0]])


def frame_of(position, radius, mass=None, velocity=None, box=BOX, type=None):
    n = len(position)
    mass = np.ones(n) if mass is None else mass
    velocity = np.zeros((n, 3)) if velocity is None else velocity
    return ParticleFrame(0, np.asarray(box, float), np.asarray(position, float), velocity, mass,
                         np.broadcast_to(np.asarray(radius, float), (n,)).copy(), type=type)


def run(acc, frames):
    acc.prepare()
    for f in frames:
        acc.accumulate(f)
    return acc.conclude()


# ----------------------------------------------------------------------------- coordinates


def test_cartesian_coordinates_map_volumes_and_area():
    c = CartesianCoordinates("zx")
    assert c.names == ("z", "x") and c.kind == "cartesian" and c.cartesian
    pos = np.array([[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]])
    assert_allclose(c.map(pos), [[3.0, 1.0], [6.0, 4.0]])
    assert c.transverse_area(BOX) == 4.0
    ez, ex = np.array([0.0, 1.0, 3.0]), np.array([0.0, 2.0, 5.0, 10.0])
    assert_allclose(c.cell_volumes((ez, ex), BOX), np.outer([1.0, 2.0], [2.0, 3.0, 5.0]) * 4.0)
    xyz = CartesianCoordinates("xyz")
    assert xyz.transverse_area(BOX) == 1.0 and xyz.transverse_area(None) == 1.0
    assert xyz.cell_volumes(([0, 1], [0, 2], [0, 3]), None).shape == (1, 1, 1)
    assert_allclose(CartesianCoordinates("y").cell_volumes(([0.0, 0.5],), BOX), [0.5 * 30.0])
    for bad in ("", "xx", "xr", "xyzx"):
        with pytest.raises(ValueError, match="subset"):
            CartesianCoordinates(bad)


def test_x_coordinates_are_one_axis_cartesian():
    c = XCoordinates((0.0, 6.0), axis="z")
    assert isinstance(c, CartesianCoordinates) and c.kind == "cartesian" and c.cartesian
    assert c.names == ("z",) and c.axis == 2 and c.walls == (0.0, 6.0)
    assert_allclose(c.cell_volumes(([0.0, 1.0, 3.0],), BOX), [40.0, 80.0])
    assert not RCoordinates().cartesian and not RZCoordinates().cartesian
    with pytest.raises(ValueError, match="increasing"):
        XCoordinates((1.0, 0.0))
    assert CartesianCoordinates("xz", walls=((0, 10), None)).walls == ((0.0, 10.0), None)


def test_r_coordinates_shells_and_cylindrical_basis():
    c = RCoordinates((2.0, -1.0))
    assert c.kind == "r" and c.names == ("r",) and c.components == ("r", "t", "z")
    pos = np.array([[5.0, 3.0, 7.0], [2.0, -1.0, 0.0]])
    assert_allclose(c.map(pos), [[5.0], [0.0]])
    edges = np.array([-0.5, 1.0, 2.0])  # edges below zero clipped to the axis
    assert_allclose(c.cell_volumes((edges,), BOX), np.pi * np.array([1.0, 3.0]) * 3.0)
    rz = RZCoordinates((2.0, -1.0))
    rng = np.random.default_rng(0)
    p, v, t = rng.normal(size=(20, 3)), rng.normal(size=(20, 3)), rng.normal(size=(20, 6))
    assert_allclose(c.local_vectors(p, v), rz.local_vectors(p, v), rtol=0, atol=0)
    assert_allclose(c.local_tensors(p, t), rz.local_tensors(p, t), rtol=0, atol=0)


def test_rigid_rotation_about_an_off_origin_axis():
    """v = Omega e_z x (x - x_0): v_r = 0 and v_t = Omega r, per particle and as a field."""
    rng = np.random.default_rng(1)
    centre, omega, n = np.array([3.0, -2.0]), 0.7, 400
    rad, theta = 2.0 * np.sqrt(rng.uniform(size=n)), rng.uniform(0, 2 * np.pi, n)
    pos = np.column_stack([centre[0] + rad * np.cos(theta), centre[1] + rad * np.sin(theta),
                           rng.uniform(0, 3, n)])
    rel = pos[:, :2] - centre
    vel = np.column_stack([-omega * rel[:, 1], omega * rel[:, 0], rng.normal(size=n)])
    coords = RCoordinates(tuple(centre))
    local = coords.local_vectors(pos, vel)
    assert_allclose(local[:, 0], 0.0, atol=1e-14)
    assert_allclose(local[:, 1], omega * rad, rtol=1e-13)
    assert_allclose(local[:, 2], vel[:, 2], rtol=0, atol=0)
    box = np.array([[0.0, 6.0], [-5.0, 1.0], [0.0, 3.0]])
    mass = rng.uniform(0.5, 2.0, n)
    edges = np.linspace(0, 2.0, 5)
    acc = FieldAccumulator(HeavisideBins(edges), coords, fields=("rho", "u"), n_blocks=2)
    table = run(acc, [frame_of(pos, 0.05, mass, vel, box)])
    b = np.searchsorted(edges, rad, side="right") - 1
    mean_r = np.bincount(b, mass * rad) / np.bincount(b, mass)
    assert_allclose(table["u_r"], 0.0, atol=1e-14)
    assert_allclose(table["u_t"], omega * mean_r, rtol=1e-13)
    assert_allclose(table["rho"] * acc.kernel.node_volumes(coords, box), np.bincount(b, mass), rtol=1e-13)


# ----------------------------------------------------------------------------- normalisation

W = 0.5  # kernel width of the normalisation tests


def _axis(centre, h):
    """Nodes of spacing h around ``centre`` reaching past 4 W, off the particle by a fraction of h."""
    return centre + np.arange(-4 * W, 4 * W + h / 2, h) + 0.123 * h


def _grids(h):
    r = np.arange(h / 2, 2.0 + 4 * W, h)
    return {
        "x": (CartesianCoordinates("x"), _axis(5.0, h), [5.0]),
        "xz": (CartesianCoordinates("xz"), (_axis(5.0, h), _axis(1.5, h)), [5.0, 1.5]),
        "xyz": (CartesianCoordinates("xyz"), (_axis(5.0, h), _axis(2.0, h), _axis(1.5, h)), [5.0, 2.0, 1.5]),
        "r": (RCoordinates(), r, [2.0]),
        "rz": (RZCoordinates(), (r, _axis(1.5, h)), [2.0, 1.5]),
    }


def _total(kernel, coords, point):
    a = kernel.assign(np.array([point]), coords, BOX)
    return np.sum(a.weight * kernel.node_volumes(coords, BOX)[a.node])


@pytest.mark.parametrize("geometry", ["x", "xz", "xyz", "r", "rz"])
@pytest.mark.parametrize("name", ["heaviside", "gaussian", "lucy"])
def test_weight_times_volume_sums_to_one(name, geometry):
    """Σ_n w_in V_n = 1 for a particle well inside a grid of spacing h = w/10.

    Bins: exactly (one weight 1/V). Gaussian: the jump at the truncation sphere
    leaves a grid error ~1e-5 (measured 3e-5 at most, on r); Lucy vanishes with
    two continuous derivatives at its cutoff and reaches ~1e-7.
    """
    h = W / 10
    coords, nodes, point = _grids(h)[geometry]
    if name == "heaviside":
        axes = (nodes,) if isinstance(nodes, np.ndarray) else nodes
        kernel = HeavisideBins(tuple(np.append(a - h / 2, a[-1] + h / 2) for a in axes))
        tolerance = 1e-13
    elif name == "gaussian":
        kernel, tolerance = Gaussian(W, 3 * W, nodes), 1e-4
    else:
        kernel, tolerance = Lucy(3 * W, nodes), 1e-6
    assert abs(_total(kernel, coords, point) - 1.0) < tolerance


def test_heaviside_bins_in_several_dimensions_match_a_histogram():
    rng = np.random.default_rng(2)
    pos = rng.uniform(BOX[:, 0], BOX[:, 1], size=(500, 3))
    coords = CartesianCoordinates("zx")
    edges = (np.linspace(0, 3, 4), np.array([0.0, 1.0, 2.5, 7.0, 10.0]))
    kernel = HeavisideBins(edges)
    dens = kernel.deposit(coords.map(pos), np.ones(len(pos)), coords, BOX)[0, :, 0]
    counts, _ = np.histogramdd(pos[:, [2, 0]], bins=edges)
    volumes = np.outer(np.diff(edges[0]), np.diff(edges[1])) * 4.0
    assert_allclose(dens * kernel.node_volumes(coords, BOX), counts.ravel(), rtol=1e-13)
    assert_allclose(kernel.node_volumes(coords, BOX), volumes.ravel())
    cols = kernel.node_columns(coords)
    assert_allclose(cols["z"], np.repeat([0.5, 1.5, 2.5], 4))
    assert_allclose(cols["x_hi"], np.tile(edges[1][1:], 3))


def test_gaussian_normalisation_is_the_incomplete_gamma_function():
    w, c = 0.7, 2.3
    k = Gaussian(w, c, [0.0, 1.0])
    for d in (1, 2, 3):
        assert_allclose(k.normalisation_in(d), (2 * np.pi * w**2) ** (d / 2) * gammainc(d / 2, c**2 / (2 * w**2)),
                        rtol=1e-14)
    assert k.normalisation == k.normalisation_in(3)


def test_lucy_normalisation_and_width():
    """Closed-form Z_D (5/4c, 5/pi c^2, 105/16 pi c^3) against quadrature, and w^2 = c^2/12."""
    c = 1.7
    k = Lucy(c, [0.0, 1.0])

    def f(d):
        return float(k.profile(d * d))

    z1 = 2 * quad(f, 0, c, epsabs=0, epsrel=1e-13)[0]
    z2 = 2 * np.pi * quad(lambda r: f(r) * r, 0, c, epsabs=0, epsrel=1e-13)[0]
    z3 = 4 * np.pi * quad(lambda r: f(r) * r * r, 0, c, epsabs=0, epsrel=1e-13)[0]
    assert_allclose([z1, z2, z3], [k.normalisation_in(d) for d in (1, 2, 3)], rtol=1e-12)
    assert_allclose(1 / np.array([z1, z2, z3]), [5 / (4 * c), 5 / (np.pi * c**2), 105 / (16 * np.pi * c**3)],
                    rtol=1e-12)
    second = 4 * np.pi * quad(lambda r: f(r) * r**4, 0, c, epsabs=0, epsrel=1e-13)[0] / z3  # <d^2>
    assert_allclose(k.width**2, second / 3, rtol=1e-12)
    assert_allclose(k.width, c / (2 * np.sqrt(3)), rtol=1e-15)
    assert k.profile(np.array([c * c, 4 * c * c])).tolist() == [0.0, 0.0]
    assert isinstance(k, RadialKernel) and _kernel_width(k) == k.width
    with pytest.raises(ValueError, match="compiled"):
        k.deposit(np.zeros((1, 2)), np.ones(1), RZCoordinates(), None, method="compiled")


def test_cartesian_2d_gaussian_and_lucy_weights_match_brute_force():
    rng = np.random.default_rng(3)
    x, z = np.linspace(0, 10, 41), np.linspace(0, 3, 13)
    pts = rng.uniform([0, 0], [10, 3], size=(30, 2))
    coords = CartesianCoordinates("xz")
    dx = x[None, :, None] - pts[:, 0, None, None]
    dz = z[None, None, :] - pts[:, 1, None, None]
    d2 = (dx**2 + dz**2).reshape(len(pts), -1)
    w, c = 0.6, 1.8
    for kernel, expected in (
        (Gaussian(w, c, (x, z)),
         np.exp(-d2 / (2 * w**2)) / (2 * np.pi * w**2 * (1 - np.exp(-(c**2) / (2 * w**2))) * 4.0)),
        (Lucy(c, (x, z)),
         5 / (np.pi * c**2) * (1 + 3 * np.sqrt(d2) / c) * (1 - np.sqrt(d2) / c) ** 3 / 4.0),
    ):
        expected = np.where(d2 < c * c, expected, 0.0)
        a = kernel.assign(pts, coords, BOX)
        dense = np.zeros_like(d2)
        dense[a.particle, a.node] = a.weight
        assert_allclose(dense, expected, rtol=1e-13, atol=1e-15)
        assert_allclose(kernel.node_columns(coords)["x"], np.repeat(x, len(z)))


def test_one_axis_gaussian_keeps_its_formula():
    """The 1D weights are those of before the D-dimensional generalisation (erf normalisation)."""
    from scipy.special import erf

    w, c, x = 0.8, 2.4, np.linspace(0, 10, 101)
    pts = np.random.default_rng(4).uniform(0, 10, (200, 1))
    a = Gaussian(w, c, x).assign(pts, XCoordinates(), BOX)
    dx = x[a.node] - pts[a.particle, 0]
    expected = np.exp(-0.5 * (dx / w) ** 2) / (np.sqrt(2 * np.pi) * w * erf(c / (np.sqrt(2) * w)) * 12.0)
    assert np.all(np.abs(dx) < c)
    assert_allclose(a.weight, expected, rtol=1e-14)
    assert len(a.node) == np.sum(np.abs(x[None, :] - pts) < c)


def test_r_kernel_is_the_rz_kernel_integrated_over_z():
    """For a cutoff far out (8w, truncation ~e^-32) the azimuthally averaged 3D Gaussian
    integrated over z is the azimuthally averaged 2D one: w_r L_z = ∫ w_rz dz.

    The z integral is the trapezoid rule on a grid of w/20 over ±c, exact to round-off
    for a Gaussian (spectral convergence).
    """
    w, c = 0.4, 3.2
    r = np.linspace(0.0, 3.0, 31)
    hz = w / 20
    z = np.arange(-c - hz, c + 2 * hz, hz)
    pts = np.array([[0.0], [0.05], [1.3], [2.2]])
    k_r, k_rz = Gaussian(w, c, r), Gaussian(w, c, (r, z))
    a = k_r.assign(pts, RCoordinates(), BOX)
    w_r = np.zeros((len(pts), len(r)))
    w_r[a.particle, a.node] = a.weight * 3.0  # times L_z
    b = k_rz.assign(np.column_stack([pts[:, 0], np.full(len(pts), 0.01)]), RZCoordinates(), None)
    w_rz = np.zeros((len(pts), len(r) * len(z)))
    w_rz[b.particle, b.node] = b.weight
    integral = w_rz.reshape(len(pts), len(r), len(z)).sum(axis=2) * hz
    assert w_r.max() > 0.1
    with pytest.raises(ValueError, match="compiled deposit needs rz"):
        k_r.deposit(pts, np.ones(len(pts)), RCoordinates(), BOX, method="compiled")
    assert_allclose(integral, w_r, rtol=1e-9, atol=1e-12 * w_r.max())


# ----------------------------------------------------------------------------- fields


def _lattice(a, n, radius):
    """Simple cubic lattice of n[0] x n[1] x n[2] spheres at (i + 1/2) a, in its box."""
    grid = np.meshgrid(*[(np.arange(k) + 0.5) * a for k in n], indexing="ij")
    pos = np.column_stack([g.ravel() for g in grid])
    box = np.array([[0.0, n[0] * a], [0.0, n[1] * a], [0.0, n[2] * a]])
    return frame_of(pos, radius, box=box)


@pytest.mark.parametrize("axes", ["x", "xz", "zy"])
def test_lattice_gives_flat_volume_fraction_in_bins(axes):
    a, r = 1.0, 0.4
    frame = _lattice(a, (8, 6, 4), r)
    phi_lattice = 4 / 3 * np.pi * r**3 / a**3
    coords = CartesianCoordinates(axes)
    lengths = frame.box[:, 1] - frame.box[:, 0]
    edges = tuple(np.arange(0.0, lengths[k] + 0.5, 2 * a) for k in coords.indices)
    table = run(FieldAccumulator(HeavisideBins(edges), coords, fields=("phi", "n"), n_blocks=2), [frame])
    assert_allclose(table["phi"], phi_lattice, rtol=1e-13)
    assert_allclose(table["n"].sum(), len(frame.mass), rtol=1e-13)


@pytest.mark.parametrize("coords, nodes", [
    (CartesianCoordinates("xz"), (np.arange(-1.5, 9.6, 0.1), np.arange(-1.5, 5.6, 0.1))),
    (RCoordinates((4.0, 3.0)), np.arange(0.05, 6.0, 0.1)),
    (RZCoordinates((4.0, 3.0)), (np.arange(0.05, 6.0, 0.1), np.arange(-1.5, 5.6, 0.1))),
])
def test_lucy_accumulator_conserves_mass(coords, nodes):
    """A lattice whose kernels (c = 1) all lie inside the grid (h = 0.1): Σ rho V = total mass
    up to the grid's quadrature error (~1e-5 measured; c/10 spacing)."""
    frame = _lattice(1.0, (8, 6, 4), 0.3)
    frame.mass[:] = np.random.default_rng(6).uniform(0.5, 2.0, len(frame.mass))
    kernel = Lucy(1.0, nodes)
    table = run(FieldAccumulator(kernel, coords, fields=("rho", "u"), n_blocks=2), [frame])
    mass = np.sum(table["rho"] * kernel.node_volumes(coords, frame.box))
    assert_allclose(mass, frame.mass.sum(), rtol=1e-4)


# ----------------------------------------------------------------------------- exact volume


def test_sphere_straddling_two_slabs_is_split_by_the_cap_formula():
    c, r = 0.3, 0.5
    frame = frame_of([[c, 2.0, 1.5]], r)
    edges = np.array([-1.0, 0.0, 1.0])
    h = 0.0 - c  # plane at x = 0, signed distance from the centre
    below = np.pi / 3 * (r + h) ** 2 * (2 * r - h)
    volume = 4 / 3 * np.pi * r**3
    exact = run(FieldAccumulator(HeavisideBins(edges), XCoordinates(), fields=("phi",), n_blocks=2,
                                 volume="exact"), [frame])
    assert_allclose(exact["phi"] * 12.0, [below, volume - below], rtol=1e-14)
    centre = run(FieldAccumulator(HeavisideBins(edges), XCoordinates(), fields=("phi",), n_blocks=2), [frame])
    assert_allclose(centre["phi"] * 12.0, [0.0, volume], rtol=1e-14)
    assert_allclose(sphere_slab_fraction(c, r, -1.0, 0.0), below / volume, rtol=1e-14)


def test_exact_slab_volume_fraction_of_a_dilute_slab():
    """A dilute layer of random spheres cut by the slab planes: with ``volume="exact"`` φ per
    slab is the volume of the spheres inside it (∫ π (r² - (x - c)²) dx per sphere, by
    quadrature) over the slab volume; the centre assignment differs."""
    rng = np.random.default_rng(5)
    box = np.array([[0.0, 6.0], [0.0, 20.0], [0.0, 20.0]])
    n = 60
    pos = rng.uniform([0.5, 1, 1], [5.5, 19, 19], size=(n, 3))  # inside the outer edges
    radius = rng.uniform(0.2, 0.5, n)
    edges = np.array([0.0, 0.7, 1.9, 2.0, 3.4, 6.0])  # one slab thinner than any sphere
    frame = frame_of(pos, radius, box=box, type=np.where(np.arange(n) % 3 == 0, 1, 2))
    expected = np.zeros(len(edges) - 1)
    for (x, r) in zip(pos[:, 0], radius):
        for k in range(len(edges) - 1):
            lo, hi = max(edges[k], x - r), min(edges[k + 1], x + r)
            if hi > lo:
                expected[k] += quad(lambda s: np.pi * (r * r - (s - x) ** 2), lo, hi, epsabs=0, epsrel=1e-13)[0]
    expected /= np.diff(edges) * 400.0
    kernel = HeavisideBins(edges)
    acc = FieldAccumulator(kernel, XCoordinates((0.0, 6.0)), fields=("phi", "rho"), n_blocks=2,
                           species=(1, 2), volume="exact")
    table = run(acc, [frame])
    assert_allclose(table["phi"], expected, rtol=1e-12)
    assert_allclose(table["phi_s1"] + table["phi_s2"], table["phi"], rtol=1e-13)
    assert_allclose(np.sum(table["phi"] * np.diff(edges) * 400.0), frame.volume.sum(), rtol=1e-13)
    centre = run(FieldAccumulator(kernel, XCoordinates((0.0, 6.0)), fields=("phi", "rho"), n_blocks=2),
                 [frame])
    assert np.max(np.abs(centre["phi"] - expected)) > 0.1 * expected.max()
    assert_allclose(centre["rho"], table["rho"], rtol=0, atol=0)  # only the volume changes
    p, slab, f = slab_pairs(pos[:, 0], radius, edges)
    assert_allclose(np.bincount(p, f), 1.0, rtol=1e-14)


@pytest.mark.parametrize("kernel, coords", [
    (Gaussian(0.5, 1.5, np.linspace(0, 10, 11)), XCoordinates()),
    (Lucy(1.5, np.linspace(0, 10, 11)), XCoordinates()),
    (HeavisideBins((np.linspace(0, 10, 3), np.linspace(0, 3, 3))), CartesianCoordinates("xz")),
    (HeavisideBins(np.linspace(0, 5, 3)), RCoordinates()),
    (HeavisideBins((np.linspace(0, 5, 3), np.linspace(0, 3, 3))), RZCoordinates()),
])
def test_exact_volume_needs_one_axis_cartesian_bins(kernel, coords):
    with pytest.raises(ValueError, match="HeavisideBins on a one-axis Cartesian"):
        FieldAccumulator(kernel, coords, volume="exact")
    with pytest.raises(ValueError, match="'centre' or 'exact'"):
        FieldAccumulator(kernel, coords, volume="whole")


def test_a_grid_off_the_material_warns_with_counts():
    """RZ coordinates about the default axis (0, 0) of a bed centred at (30, 30): nothing on the grid."""
    import warnings as _w

    from postproc.fields import FieldAccumulator, SparseGridWarning

    rng = np.random.default_rng(0)
    n = 200
    pos = np.column_stack([30 + rng.uniform(-5, 5, n), 30 + rng.uniform(-5, 5, n), rng.uniform(0, 10, n)])
    frame = ParticleFrame(timestep=0, box=np.array([[20.0, 40], [20, 40], [0, 10]]), position=pos,
                          velocity=np.zeros((n, 3)), mass=np.ones(n), radius=np.full(n, 0.3))
    acc = FieldAccumulator(HeavisideBins((np.linspace(0, 10, 11), np.linspace(0, 10, 6))), RZCoordinates(),
                           fields=("n", "rho"))
    acc.prepare()
    acc.accumulate(frame)
    with pytest.warns(SparseGridWarning, match="holds 0 of the 200 particles"):
        acc.conclude()
    assert acc.coverage == 0.0
    centred = FieldAccumulator(HeavisideBins((np.linspace(0, 10, 11), np.linspace(0, 10, 6))),
                               RZCoordinates((30, 30)), fields=("n", "rho"))
    centred.prepare()
    centred.accumulate(frame)
    with _w.catch_warnings():
        _w.simplefilter("error", SparseGridWarning)
        centred.conclude()
    assert centred.coverage == pytest.approx(1.0)
