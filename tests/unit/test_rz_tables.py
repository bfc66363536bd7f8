"""The far-field polynomials of the compiled rz deposit (postproc.rz_tables, postproc.cg_compiled).

Far from the axis the azimuthal integral is :math:`J = \\sqrt{b/a}\\, F(\\epsilon, b)`, with
:math:`F` held by one polynomial in b per row of :math:`\\epsilon = 1/a` (pieces of b beyond
C = 8). Checked against direct quadrature: of F (the fit alone), of J (the fit and the
linear interpolation in epsilon), and of the whole deposit against the numpy path, for
the usual C (4: the paper's kernel; 4.5: a cut at 3 sigma) and for C cut into pieces.
"""
import numpy as np
import pytest
from numpy.polynomial import polynomial
from numpy.polynomial.legendre import leggauss
from numpy.testing import assert_allclose

from postproc import rz_tables
from postproc.cg_compiled import RZTables
from postproc.coordinates import RZCoordinates
from postproc.kernels import Gaussian


def azimuthal_integral(a, b, n=64):
    """J(a, b) = int_0^theta_c exp(-a (1 - cos phi)) dphi by 64-point Gauss-Legendre (exact here)."""
    cos_c = 1.0 - np.divide(b, a, out=np.full_like(a, np.inf), where=a > 0)
    theta = np.arccos(np.clip(cos_c, -1.0, 1.0))
    x, w = leggauss(n)
    phi = 0.5 * theta[:, None] * (x + 1.0)
    return 0.5 * theta * (w * np.exp(-a[:, None] * (1.0 - np.cos(phi)))).sum(axis=1)


@pytest.mark.parametrize("C, pieces, tolerance", [(4.0, 1, 1e-13), (4.5, 1, 1e-13), (8.0, 1, 1e-10),
                                                  (12.5, 2, 1e-11), (20.0, 3, 1e-11)])
def test_far_polynomials_hold_F_on_every_piece(C, pieces, tolerance):
    """Degree-15 Chebyshev interpolation of F, relative error measured 2e-15 (C = 4), 7e-15 (4.5),
    1.4e-11 (8: the widest piece), 5e-13 (12.5), 1.3e-12 (20); tolerances ~10x."""
    a_split = max(C, 1.0)
    far = rz_tables._far_polynomials(C, a_split)
    assert far.shape == (pieces, rz_tables.FAR_ROWS + 1, rz_tables.FAR_DEGREE + 1)
    width = C / pieces
    b = np.linspace(0.0, C, 801)
    piece = np.minimum((b / width).astype(int), pieces - 1)
    y = 2.0 * (b - piece * width) / width - 1.0
    for row in (0, 517, rz_tables.FAR_ROWS):  # epsilon = 0, mid-range, one row beyond 1 / a_s
        eps = np.array(row / (a_split * (rz_tables.FAR_ROWS - 1)))
        fitted = np.array([polynomial.polyval(yk, far[pk, row]) for yk, pk in zip(y, piece)])
        assert_allclose(fitted, rz_tables._far_F(eps, b), rtol=tolerance, atol=0)


@pytest.mark.parametrize("C", [0.5, 4.0, 4.5, 12.5, 20.0])
def test_interpolated_J_matches_the_quadrature_far_from_the_axis(C):
    """Linear in epsilon over 1025 rows: measured at most 2.0e-9 relative (next to a_s); tolerance 1e-8."""
    tables = RZTables.build(C)
    rng = np.random.default_rng(13)
    a = np.concatenate([rng.uniform(tables.a_split, 1.2 * tables.a_split, 3000),
                        rng.uniform(tables.a_split, 500.0, 3000), [tables.a_split, 1e6]])
    b = np.concatenate([rng.uniform(0.0, C, 6000), [C, C]])
    assert_allclose(tables.J(a, b), azimuthal_integral(a, b), rtol=1e-8, atol=0)


def test_compiled_deposit_equals_numpy_quadrature_for_a_cutoff_cut_into_pieces():
    """c = 5 sigma (C = 12.5, two pieces of b): the same weights as the numpy path, as for C = 4 and 4.5."""
    rz = RZCoordinates()
    rng = np.random.default_rng(14)
    kernel = Gaussian(0.4, 2.0, (np.arange(0.0, 5.01, 0.25), np.arange(-1.0, 5.01, 0.25)))
    assert kernel.rz_tables.far.shape[0] == 2
    n = 300
    points = np.column_stack([5.0 * np.sqrt(rng.uniform(size=n)), rng.uniform(-2.0, 6.0, n)])
    points[:10, 0] = rng.uniform(0.0, 0.3, 10)  # near the axis: the near tables
    values = rng.normal(size=(n, 3))
    compiled = kernel.deposit(points, values, rz, None, method="compiled")
    reference = kernel.deposit(points, values, rz, None, method="numpy")
    # as in test_cg_rz: the tables' interpolation error, ~1e-8 of the largest density; tolerance 1e-7
    assert_allclose(compiled, reference, rtol=0, atol=1e-7 * np.abs(reference).max())
