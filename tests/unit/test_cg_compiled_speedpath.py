"""The compiled rz deposit's fast path: visiting order, padded blocks, threads taking chunks.

:mod:`postproc.cg_compiled` visits the particles in a sorted order, adds the K
values of a particle 4 at a time (K padded to a multiple of 4, three blocks per
step up to K = 12, then one), and lets its threads take chunks of particles from
a shared counter, each into its own buffer. None of this may change the result
beyond round-off: these tests compare with the numpy reference (the 24-point
quadrature of ``Gaussian._assign_rz``) and with the one-thread deposit, on seeded
particles, with more particles than a chunk so that the threads share the work.
"""
import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

from postproc import cg_compiled, rz_tables
from postproc.coordinates import RZCoordinates
from postproc.kernels import Gaussian

RZ = RZCoordinates()


def kernel_and_particles(n, seed=7):
    """The paper's kernel (w = 0.5) on a grid of spacing 0.25, particles in and around it, some on the axis."""
    rng = np.random.default_rng(seed)
    kernel = Gaussian.paper(0.5, (np.arange(0.0, 4.01, 0.25), np.arange(-1.0, 3.01, 0.25)))
    points = np.column_stack([4.5 * np.sqrt(rng.uniform(size=n)), rng.uniform(-2.0, 4.0, n)])
    points[:10, 0] = 0.0  # on the axis
    points[10:30, 0] = rng.uniform(0.0, 0.3, 20)  # near it: the near-axis tables
    return kernel, points, rng


def test_visiting_order_is_a_stable_sort_by_group_then_r_node_then_z_node():
    kernel, points, rng = kernel_and_particles(3 * cg_compiled.CHUNK)
    groups = rng.integers(0, 3, len(points))
    (r0, hr, n_r), (z0, hz, n_z) = (cg_compiled.uniform_axis(a) for a in kernel.nodes)
    order = cg_compiled._visiting_order(points[:, 0], points[:, 1], groups, 3, r0, hr, n_r, z0, hz, n_z)
    assert_array_equal(np.sort(order), np.arange(len(points)))  # a permutation
    m = np.clip(np.rint((points[:, 0] - r0) / hr), 0, n_r - 1).astype(int)
    j = np.clip(np.rint((points[:, 1] - z0) / hz), 0, n_z - 1).astype(int)
    key = (groups * n_r + m) * n_z + j
    assert_array_equal(order, np.argsort(key, kind="stable"))


@pytest.mark.parametrize("n_k", [1, 4, 6, 11, 12, 13, 16, 25])
def test_compiled_equals_numpy_for_any_number_of_values(n_k):
    """K below, at and above 12 (the blocks of three), padded or not."""
    kernel, points, rng = kernel_and_particles(2 * cg_compiled.CHUNK + 17, seed=n_k)
    values = rng.normal(size=(len(points), n_k))
    groups = rng.integers(0, 2, len(points))
    compiled = kernel.deposit(points, values, RZ, None, groups, 2, method="compiled")
    reference = kernel.deposit(points, values, RZ, None, groups, 2, method="numpy")
    assert compiled.shape == reference.shape == (2, kernel.n_nodes, n_k)
    assert compiled.flags.c_contiguous
    # the tables' interpolation error: measured 5e-9 of the largest density (all K here)
    assert_allclose(compiled, reference, rtol=0, atol=1e-7 * np.abs(reference).max())


@pytest.mark.parametrize("n_threads", [2, 3, 5])
def test_threads_taking_chunks_give_the_one_thread_result(n_threads):
    """More workers than numba threads is allowed too; only the summation order differs.

    Measured: 4e-16 of the largest density when the work is shared (with few
    particles one worker may take every chunk before the others start).
    """
    kernel, points, rng = kernel_and_particles(100 * cg_compiled.CHUNK + 5)
    values = rng.normal(size=(len(points), 11))
    one = kernel.deposit(points, values, RZ, None, method="compiled", n_threads=1)
    many = kernel.deposit(points, values, RZ, None, method="compiled", n_threads=n_threads)
    assert_allclose(many, one, rtol=1e-12, atol=1e-13 * np.abs(one).max())


def test_one_thread_is_deterministic():
    kernel, points, rng = kernel_and_particles(3 * cg_compiled.CHUNK)
    values = rng.normal(size=(len(points), 5))
    first = kernel.deposit(points, values, RZ, None, method="compiled", n_threads=1)
    again = kernel.deposit(points, values, RZ, None, method="compiled", n_threads=1)
    assert_array_equal(first, again)


def test_mass_is_conserved_inside_the_grid():
    """Particles at least a cutoff inside the grid keep their whole mass: sum_n rho_n V_n = sum_i m_i.

    The node sum is a midpoint rule of the axisymmetric kernel (error ~h^2, and
    ~h^1.5 within a few widths of the axis, see test_cg_rz); on this grid, with
    particles spread over r, the measured error is 1.0e-4; tolerance 1e-3.
    """
    rng = np.random.default_rng(11)
    kernel = Gaussian.paper(0.5, (np.arange(0.0, 6.01, 0.125), np.arange(0.0, 6.01, 0.125)))
    n = 2 * cg_compiled.CHUNK
    points = np.column_stack([4.0 * np.sqrt(rng.uniform(size=n)), rng.uniform(2.0, 4.0, n)])
    mass = rng.uniform(0.5, 2.0, (n, 1))
    density = kernel.deposit(points, mass, RZ, None, method="compiled", n_threads=2)
    total = np.sum(density[0, :, 0] * kernel.node_volumes(RZ, None))
    assert abs(total / mass.sum() - 1.0) < 1e-3


def test_no_particles_and_particles_off_the_grid_deposit_nothing():
    kernel, _, _ = kernel_and_particles(30)
    empty = kernel.deposit(np.zeros((0, 2)), np.zeros((0, 3)), RZ, None, method="compiled")
    assert empty.shape == (1, kernel.n_nodes, 3) and not empty.any()
    far = np.array([[20.0, 1.0], [1.0, 40.0], [1.0, -40.0]])
    assert not kernel.deposit(far, np.ones((3, 2)), RZ, None, method="compiled").any()


def test_hermite_cells_match_values_and_derivatives_at_both_ends():
    x = np.linspace(0.0, 1.0, 9)
    table = np.stack([np.sin(x), np.cos(x) * (x[1] - x[0])], axis=-1)  # derivative per column step
    cells = rz_tables._hermite_cells(table)
    for s, end in ((0.0, slice(None, -1)), (1.0, slice(1, None))):
        value = cells[:, 0] + s * (cells[:, 1] + s * (cells[:, 2] + s * cells[:, 3]))
        slope = cells[:, 1] + s * (2.0 * cells[:, 2] + 3.0 * s * cells[:, 3])
        assert_allclose(value, table[end, 0], rtol=0, atol=1e-15)
        assert_allclose(slope, table[end, 1], rtol=0, atol=1e-15)


def test_particles_without_a_position_deposit_nothing_as_in_numpy():
    kernel, points, rng = kernel_and_particles(100)
    points[5] = [np.nan, 1.0]
    points[6] = [1.0, np.inf]
    values = rng.normal(size=(len(points), 3))
    compiled = kernel.deposit(points, values, RZ, None, method="compiled")
    reference = kernel.deposit(points, values, RZ, None, method="numpy")
    assert np.isfinite(compiled).all()
    assert_allclose(compiled, reference, rtol=0, atol=1e-7 * np.abs(reference).max())
    kept = np.isfinite(points).all(axis=1)
    assert_allclose(compiled, kernel.deposit(points[kept], values[kept], RZ, None, method="compiled"),
                    rtol=1e-12, atol=0)
