"""Tables of the azimuthal integral of the axisymmetric truncated Gaussian kernel (numpy only).

What the compiled deposit of :mod:`postproc.cg_compiled` interpolates, and how the
tables are computed (the container, :class:`postproc.cg_compiled.RZTables`, and the
compiled interpolation live there).

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
(:class:`postproc.cg_compiled.RZTables`) and interpolated with cubic Hermite polynomials along the
fast axis (the tables hold the analytic derivative). Two regimes:

far from the axis, :math:`a \\ge a_s = \\max(C, 1)`
    with :math:`s = \\tau^2`, :math:`t = \\sqrt b` and :math:`\\epsilon = 1/a`,

    .. math::

        \\sqrt a\\, J = K(\\epsilon, t) = \\int_0^t
        \\frac{2 e^{-\\tau^2}\\, \\mathrm{d}\\tau}{\\sqrt{2 - \\epsilon \\tau^2}},

    analytic on :math:`[0, 1/a_s] \\times [0, \\sqrt C]` (where
    :math:`\\epsilon\\tau^2 \\le 1`): the :math:`a^{-1/2}` decay and the
    :math:`\\sqrt b` edge at the truncation sphere are taken out. Linear in
    :math:`\\epsilon` (257 rows), Hermite in :math:`t` (129 columns), each cell
    stored as the coefficients of its cubic (a lookup reads 2 x 4 adjacent
    numbers). The table covers every :math:`a \\ge a_s`, :math:`\\epsilon \\to 0`
    included, so it does not depend on the grid or on the largest radius.

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
:math:`J` on 4e5 random :math:`(a, b)` for :math:`C` = 4 and 4.5: at most 3.3e-8
relative (1.9e-8 absolute, :math:`J \\le \\pi`); tests/unit/test_cg_rz.py checks the
tables and the whole deposit against the numpy quadrature of
``Gaussian._assign_rz``.
"""
from __future__ import annotations

import numpy as np
from numpy.polynomial.legendre import leggauss

#: Far table: rows over epsilon = 1/a in [0, 1/a_s], columns over t = sqrt(b) in [0, sqrt(C)].
FAR_ROWS, FAR_COLUMNS = 257, 129
#: Near tables: row spacing in a at most this, columns over u or v in [0, 2^-1/2].
NEAR_ROW_SPACING, NEAR_COLUMNS = 1.0 / 32.0, 65

_GL_X, _GL_W = leggauss(4)  # per table interval: analytic integrands, round-off already with 4


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


def _far_integrand(eps, tau):
    return 2.0 * np.exp(-(tau**2)) / np.sqrt(2.0 - eps * tau**2)


def _u_integrand(a, w):
    return 2.0 * np.exp(-2.0 * a * w**2) / np.sqrt(1.0 - w**2)


def _v_integrand(a, w):
    return 2.0 * np.exp(-a * (1.0 - 2.0 * w**2)) / np.sqrt(1.0 - w**2)
