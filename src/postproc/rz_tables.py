"""Tables of the azimuthal integral of the axisymmetric truncated Gaussian kernel (numpy only).

What the compiled deposit of :mod:`postproc.cg_compiled` interpolates, and how the
tables are computed. Their container, :class:`postproc.cg_compiled.RZTables`, and the
compiled interpolation live there, with all the compiled code: numba's on-disk cache of
a function does not notice a change in a compiled function it calls from another module.

The ``rz`` weight of :class:`postproc.kernels.Gaussian` (standard deviation
:math:`\\sigma`, cutoff :math:`c`) of a particle at :math:`(r_i, z_i)` on the
ring node :math:`(r_n, z_n)` is the azimuthal average of the truncated 3D
Gaussian (the same weight as the numpy quadrature ``Gaussian._assign_rz``),

.. math::

    w_{in} = \\frac{1}{\\pi Z}\\, e^{-p^2/2\\sigma^2} J(a, b), \\qquad
    J(a, b) = \\int_0^{\\theta_c} e^{-a(1-\\cos\\varphi)}\\,\\mathrm{d}\\varphi
            = \\int_0^{\\min(b, 2a)} \\frac{e^{-s}\\,\\mathrm{d}s}{\\sqrt{s(2a - s)}},

with :math:`p^2 = (r_n - r_i)^2 + (z_n - z_i)^2 < c^2`,
:math:`a = r_n r_i / \\sigma^2`, :math:`b = (c^2 - p^2) / 2\\sigma^2 \\in (0, C]`,
:math:`C = c^2 / 2\\sigma^2` and :math:`\\cos\\theta_c = 1 - b/a` (the arc of the
ring inside the truncation sphere). The Gaussian factor splits into
:math:`e^{-(r_n - r_i)^2/2\\sigma^2}\\, e^{-(z_n - z_i)^2/2\\sigma^2}`, one
exponential per grid row and one per grid column of a particle, so the pair loop
has no exponential, and :math:`J` comes from small tables, built once per kernel
(:class:`postproc.cg_compiled.RZTables`). Two regimes:

far from the axis, :math:`a \\ge a_s = \\max(C, 1)`
    with :math:`s = \\tau^2`, :math:`t = \\sqrt b` and :math:`\\epsilon = 1/a`,

    .. math::

        \\sqrt a\\, J = \\int_0^t
        \\frac{2 e^{-\\tau^2}\\, \\mathrm{d}\\tau}{\\sqrt{2 - \\epsilon \\tau^2}}
        = \\sqrt b\\, F(\\epsilon, b), \\qquad
        F(\\epsilon, b) = \\int_0^1 \\frac{2 e^{-b x^2}\\, \\mathrm{d}x}{\\sqrt{2 - \\epsilon b x^2}},

    with the :math:`a^{-1/2}` decay and the :math:`\\sqrt b` edge at the
    truncation sphere taken out. :math:`F` is analytic on
    :math:`[0, 1/a_s] \\times [0, C]` (where :math:`\\epsilon b x^2 \\le 1`) and
    so smooth in :math:`b` that one polynomial of degree 15 per row of
    :math:`\\epsilon` holds it on the whole of :math:`[0, C]`
    (:func:`_far_polynomials`; to 7e-15 relative for the usual
    :math:`C \\le 4.5`, 1.4e-11 at :math:`C = 8`, a Gaussian cut at
    :math:`4\\sigma`; a larger C is cut into equal pieces of at most 8). A node
    then needs no table lookup, only a square root and a polynomial, which the
    loop over a grid row's nodes evaluates 4 nodes at a time in vector
    registers. Linear in :math:`\\epsilon` (1025 rows, their coefficients mixed
    once per grid row); the rows cover every :math:`a \\ge a_s`,
    :math:`\\epsilon \\to 0` included, so they do not depend on the grid or on
    the largest radius.

near the axis, :math:`a < a_s`
    the truncation sphere can enclose the whole ring (:math:`b \\ge 2a`) and
    :math:`J(a, b)` has a square-root kink along :math:`b = 2a`, which no table
    on smooth axes resolves. With :math:`u = \\sin(\\theta_c/2) = \\sqrt{b/2a}`
    and :math:`v = \\cos(\\theta_c/2) = \\sqrt{1 - b/2a}`,

    .. math::

        J = \\begin{cases}
        U(a, u) = \\int_0^u \\frac{2 e^{-2a\\omega^2}}{\\sqrt{1-\\omega^2}}\\,\\mathrm{d}\\omega
            & u^2 \\le \\tfrac12 \\\\
        J_\\pi(a) - e^{-a}\\tilde V(a, v), \\quad
        \\tilde V = \\int_0^v \\frac{2 e^{-a(1 - 2\\omega^2)}}{\\sqrt{1-\\omega^2}}\\,\\mathrm{d}\\omega
            & v^2 < \\tfrac12 \\\\
        J_\\pi(a) = \\pi e^{-a} I_0(a) = U(a, 2^{-1/2}) + e^{-a}\\tilde V(a, 2^{-1/2})
            & b \\ge 2a ,
        \\end{cases}

    both analytic on :math:`[0, a_s] \\times [0, 2^{-1/2}]` with bounded
    :math:`a`-derivatives: cubic Lagrange in :math:`a` (four rows, weights once
    per grid row of a particle; row spacing at most 1/32), Hermite in
    :math:`u, v` (65 columns, cells stored as cubic coefficients).

Interpolation error, measured against 64-point Gauss-Legendre quadrature of
:math:`J` on 4e5 random :math:`(a, b)` in each regime for :math:`C` = 4 and 4.5:
far from the axis at most 2.0e-9 relative (the linear interpolation in
:math:`\\epsilon`, largest next to :math:`a_s`; as much for C = 0.5, 8, 12.5 and
20), near it at most 1.8e-8 absolute (3.5e-8 relative, :math:`J \\le \\pi`).
tests/unit/test_cg_rz.py and test_rz_tables.py check the tables and the whole
deposit against the numpy quadrature of ``Gaussian._assign_rz``.
"""
from __future__ import annotations

import numpy as np
from numpy.polynomial import chebyshev
from numpy.polynomial.legendre import leggauss

#: Far polynomials: rows over epsilon = 1/a in [0, 1/a_s]; the degree in b (at most 15: the compiled
#: evaluation, ``postproc.cg_jit.estrin``, takes 16 coefficients).
FAR_ROWS, FAR_DEGREE = 1025, 15
#: Widest piece of [0, C] in b that one far polynomial spans (a larger C is cut into equal pieces).
FAR_PIECE = 8.0
#: Near tables: row spacing in a at most this, columns over u or v in [0, 2^-1/2].
NEAR_ROW_SPACING, NEAR_COLUMNS = 1.0 / 32.0, 65

_GL_X, _GL_W = leggauss(4)  # per table interval: analytic integrands, round-off already with 4
_GL_F = leggauss(64)  # F(epsilon, b) over x in [0, 1]: round-off for b up to ~100


def _cumulative(integrand, rows: np.ndarray, columns: np.ndarray) -> np.ndarray:
    """Table of value and derivative ``(len(rows), len(columns), 2)`` of a cumulative integral."""
    h = columns[1] - columns[0]
    tau = columns[:-1, None] + 0.5 * h * (_GL_X + 1.0)
    f = integrand(rows[:, None, None], tau[None])
    table = np.zeros((len(rows), len(columns), 2))
    table[:, 1:, 0] = np.cumsum(0.5 * h * (f * _GL_W).sum(axis=-1), axis=1)
    table[:, :, 1] = integrand(rows[:, None], columns[None, :]) * h  # derivative per column step
    return table


def _hermite_cells(table: np.ndarray) -> np.ndarray:
    """Coefficients ``(f0, d0, c2, c3)`` of the cubic on each cell between adjacent columns.

    From a table of values :math:`f` and derivatives :math:`d` (per column step),
    the Hermite cubic of the cell from column k to k + 1,

    .. math::

        p(s) = f_0 + s\\,(d_0 + s\\,(c_2 + s\\,c_3)), \\quad s \\in [0, 1], \\qquad
        c_2 = 3(f_1 - f_0) - 2 d_0 - d_1, \\quad c_3 = 2(f_0 - f_1) + d_0 + d_1 ,

    matches value and derivative at both ends. Shape ``(..., columns - 1, 4)``.
    """
    f0, d0, f1, d1 = table[..., :-1, 0], table[..., :-1, 1], table[..., 1:, 0], table[..., 1:, 1]
    return np.ascontiguousarray(np.stack([f0, d0, 3.0 * (f1 - f0) - 2.0 * d0 - d1,
                                          2.0 * (f0 - f1) + d0 + d1], axis=-1))


def _far_F(eps, b):
    """:math:`F(\\epsilon, b)` by Gauss-Legendre quadrature, for broadcast arrays of epsilon and b."""
    x, w = 0.5 * (_GL_F[0] + 1.0), 0.5 * _GL_F[1]
    bx2 = b[..., None] * x**2
    return np.sum(w * 2.0 * np.exp(-bx2) / np.sqrt(2.0 - eps[..., None] * bx2), axis=-1)


def _far_polynomials(C: float, a_split: float) -> np.ndarray:
    """Coefficients of F in powers of y, per piece of [0, C] and row of epsilon: ``(pieces, FAR_ROWS + 1, 16)``.

    On the piece :math:`[b_0, b_0 + \\Delta]` (:math:`\\Delta = C / \\text{pieces}
    \\le` :data:`FAR_PIECE`), :math:`F \\approx \\sum_{k \\le 15} f_k y^k` with
    :math:`y = 2 (b - b_0) / \\Delta - 1 \\in [-1, 1]`: the interpolating
    polynomial at the 16 Chebyshev points (within a factor ~2 of the best
    polynomial), in powers of y (coefficients of order one: no round-off to
    speak of). Rows at :math:`\\epsilon = k / (a_s (\\text{FAR\\_ROWS} - 1))`,
    one beyond the range.
    """
    n_pieces = max(1, int(np.ceil(C / FAR_PIECE)))
    width = C / n_pieces
    n = FAR_DEGREE + 1
    eps = np.arange(FAR_ROWS + 1) / (a_split * (FAR_ROWS - 1))
    y = np.cos(np.pi * (np.arange(n) + 0.5) / n)
    to_powers = np.zeros((n, n))  # column k: the Chebyshev polynomial T_k in powers of y
    for k in range(n):
        to_powers[: k + 1, k] = chebyshev.cheb2poly(np.eye(n)[k])
    out = np.empty((n_pieces, len(eps), n))
    for piece in range(n_pieces):
        b = width * (piece + 0.5 * (y + 1.0))
        values = _far_F(eps[:, None], b[None, :])  # (rows, points)
        out[piece] = (to_powers @ chebyshev.chebfit(y, values.T, FAR_DEGREE)).T
    return out


def _u_integrand(a, w):
    return 2.0 * np.exp(-2.0 * a * w**2) / np.sqrt(1.0 - w**2)


def _v_integrand(a, w):
    return 2.0 * np.exp(-a * (1.0 - 2.0 * w**2)) / np.sqrt(1.0 - w**2)


def table_arrays(C: float) -> dict:
    """The arrays of :class:`postproc.cg_compiled.RZTables` for :math:`C` (its attributes but C).

    Parameters
    ----------
    C : float
        :math:`c^2 / 2\\sigma^2` of the kernel (dimensionless, > 0).

    Returns
    -------
    dict
        ``a_split``, ``far``, ``near_u``, ``near_v``, ``near_end`` and
        ``near_step``, as :class:`postproc.cg_compiled.RZTables` documents them.
    """
    a_split = max(float(C), 1.0)
    n_a = int(np.ceil(a_split / NEAR_ROW_SPACING))
    step = a_split / n_a
    a = (np.arange(n_a + 3) - 1.0) * step  # one ghost row below 0, two above a_s
    u = np.linspace(0.0, np.sqrt(0.5), NEAR_COLUMNS)
    near_u, near_v = _cumulative(_u_integrand, a, u), _cumulative(_v_integrand, a, u)
    return dict(
        a_split=a_split,
        far=np.ascontiguousarray(_far_polynomials(float(C), a_split)),
        near_u=_hermite_cells(near_u),
        near_v=_hermite_cells(near_v),
        near_end=np.ascontiguousarray(np.column_stack([near_u[:, -1, 0], near_v[:, -1, 0]])),
        near_step=step,
    )
