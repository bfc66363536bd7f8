"""Compiled (numba) deposit of the axisymmetric truncated Gaussian kernel.

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
(:class:`RZTables`) and interpolated with cubic Hermite polynomials along the
fast axis (the tables hold the analytic derivative). Two regimes:

far from the axis, :math:`a \\ge a_s = \\max(C, 1)`
    with :math:`s = \\tau^2`, :math:`t = \\sqrt b` and :math:`\\epsilon = 1/a`,

    .. math::

        \\sqrt a\\, J = K(\\epsilon, t) = \\int_0^t
        \\frac{2 e^{-\\tau^2}\\, \\mathrm{d}\\tau}{\\sqrt{2 - \\epsilon \\tau^2}},

    analytic on :math:`[0, 1/a_s] \\times [0, \\sqrt C]` (where
    :math:`\\epsilon\\tau^2 \\le 1`): the :math:`a^{-1/2}` decay and the
    :math:`\\sqrt b` edge at the truncation sphere are taken out. Linear in
    :math:`\\epsilon` (257 rows), Hermite in :math:`t` (129 columns). The table
    covers every :math:`a \\ge a_s`, :math:`\\epsilon \\to 0` included, so it
    does not depend on the grid or on the largest radius.

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
    :math:`u, v` (65 columns).

Interpolation error, measured against 64-point Gauss-Legendre quadrature of
:math:`J` on 4e5 random :math:`(a, b)` for :math:`C` = 4 and 4.5: below 3e-8
relative (2e-8 absolute, :math:`J \\le \\pi`); tests/unit/test_cg_rz.py checks the
tables and the whole deposit against the numpy quadrature of
``Gaussian._assign_rz``.

The Gaussian factors of successive nodes follow by recurrence (two
exponentials per particle and axis), the node range of each grid row is
computed, not searched (the compiled path needs equally spaced nodes), and
each particle's values are added to a row of nodes by one vectorised loop.
:func:`deposit_rz` runs in parallel over contiguous chunks of particles, one per
numba thread, each accumulating into its own buffer; the buffers are summed at
the end (so it also runs with ``NUMBA_NUM_THREADS=1``; the summation order, and
so the last bits, depend on the thread count). Compiled functions are cached on
disk (``cache=True``).
"""
from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np
from numba import njit, prange
from numpy.polynomial.legendre import leggauss

#: Far table: rows over epsilon = 1/a in [0, 1/a_s], columns over t = sqrt(b) in [0, sqrt(C)].
FAR_ROWS, FAR_COLUMNS = 257, 129
#: Near tables: row spacing in a at most this, columns over u or v in [0, 2^-1/2].
NEAR_ROW_SPACING, NEAR_COLUMNS = 1.0 / 32.0, 65

_GL_X, _GL_W = leggauss(8)  # per table interval: the integrands are analytic there


def _cumulative(integrand, rows: np.ndarray, columns: np.ndarray) -> np.ndarray:
    """Table of value and derivative ``(len(rows), len(columns), 2)`` of a cumulative integral."""
    h = columns[1] - columns[0]
    tau = columns[:-1, None] + 0.5 * h * (_GL_X + 1.0)
    f = integrand(rows[:, None, None], tau[None])
    table = np.zeros((len(rows), len(columns), 2))
    table[:, 1:, 0] = np.cumsum(0.5 * h * (f * _GL_W).sum(axis=-1), axis=1)
    table[:, :, 1] = integrand(rows[:, None], columns[None, :]) * h  # derivative per column step
    return table


def _far_integrand(eps, tau):
    return 2.0 * np.exp(-(tau**2)) / np.sqrt(2.0 - eps * tau**2)


def _u_integrand(a, w):
    return 2.0 * np.exp(-2.0 * a * w**2) / np.sqrt(1.0 - w**2)


def _v_integrand(a, w):
    return 2.0 * np.exp(-a * (1.0 - 2.0 * w**2)) / np.sqrt(1.0 - w**2)


@dataclass(frozen=True)
class RZTables:
    """Interpolation tables of the azimuthal integral :math:`J(a, b)` for one :math:`C`.

    Attributes
    ----------
    C : float
        :math:`c^2 / 2\\sigma^2`.
    a_split : float
        :math:`a_s = \\max(C, 1)`.
    far : ndarray, shape (FAR_ROWS + 1, FAR_COLUMNS + 1, 2)
        :math:`K(\\epsilon, t)` and :math:`h_t \\partial_t K` (one row and column
        beyond the range).
    near_u, near_v : ndarray, shape (n_a + 3, NEAR_COLUMNS, 2)
        :math:`U(a, u)`, :math:`\\tilde V(a, v)` and their column derivatives times
        the column step, rows at :math:`a = (k - 1) h_a`.
    near_step : float
        :math:`h_a`.
    """

    C: float
    a_split: float
    far: np.ndarray
    near_u: np.ndarray
    near_v: np.ndarray
    near_step: float

    @classmethod
    def build(cls, C: float) -> "RZTables":
        a_split = max(float(C), 1.0)
        # one row and one column beyond the range: interpolation never needs a bounds test
        eps = np.arange(FAR_ROWS + 1) / (a_split * (FAR_ROWS - 1))
        t = np.arange(FAR_COLUMNS + 1) * (np.sqrt(C) / (FAR_COLUMNS - 1))
        n_a = int(np.ceil(a_split / NEAR_ROW_SPACING))
        step = a_split / n_a
        a = (np.arange(n_a + 3) - 1.0) * step  # one ghost row below 0, two above a_s
        u = np.linspace(0.0, np.sqrt(0.5), NEAR_COLUMNS)
        return cls(
            C=float(C),
            a_split=a_split,
            far=_cumulative(_far_integrand, eps, t),
            near_u=_cumulative(_u_integrand, a, u),
            near_v=_cumulative(_v_integrand, a, u),
            near_step=step,
        )

    def J(self, a, b) -> np.ndarray:
        """:math:`J(a, b)` for arrays of pairs, with the compiled interpolation (for tests)."""
        a, b = np.broadcast_arrays(np.asarray(a, float), np.asarray(b, float))
        out = np.empty(a.shape)
        _J_pairs(a.ravel(), b.ravel(), *self._args(), out.reshape(-1))
        return out

    def _args(self):
        t_scale = (FAR_COLUMNS - 1) / np.sqrt(self.C)
        u_scale = (NEAR_COLUMNS - 1) / np.sqrt(0.5)
        return (self.C, self.a_split, self.far, (FAR_ROWS - 1) * self.a_split, t_scale,
                self.near_u, self.near_v, 1.0 / self.near_step, u_scale)


_JIT = dict(cache=True, error_model="numpy", fastmath=True)


@njit(inline="always", **_JIT)
def _hermite(f0, d0, f1, d1, s):
    c2 = 3.0 * (f1 - f0) - 2.0 * d0 - d1
    c3 = 2.0 * (f0 - f1) + d0 + d1
    return f0 + s * (d0 + s * (c2 + s * c3))


# Table indices are unsigned (np.uint64) throughout: numba then skips the
# negative-index wraparound test, which otherwise blocks vectorisation.
_U1, _U2, _U3 = np.uint64(1), np.uint64(2), np.uint64(3)


@njit(inline="always", **_JIT)
def _far_row(fe):
    """Row index and fraction of epsilon = 1/a, given in row units ``fe`` (at most FAR_ROWS - 1)."""
    ie = np.uint64(fe)
    return ie, fe - ie


@njit(inline="always", **_JIT)
def _far_K(far, ie, fe, t):
    """K(epsilon, t): linear between rows ie, ie + 1, Hermite in t (t in column units, <= FAR_COLUMNS - 1)."""
    it = np.uint64(t)
    s = t - it
    ge = 1.0 - fe
    ie1, it1 = ie + _U1, it + _U1
    f0 = ge * far[ie, it, 0] + fe * far[ie1, it, 0]
    d0 = ge * far[ie, it, 1] + fe * far[ie1, it, 1]
    f1 = ge * far[ie, it1, 0] + fe * far[ie1, it1, 0]
    d1 = ge * far[ie, it1, 1] + fe * far[ie1, it1, 1]
    return _hermite(f0, d0, f1, d1, s)


@njit(inline="always", **_JIT)
def _near_row(a, a_scale, n_a):
    """First of the four table rows around a and their cubic Lagrange weights."""
    xa = a * a_scale
    ia = np.uint64(xa)
    cap = np.uint64(n_a - 1)
    if ia > cap:
        ia = cap
    x = xa - ia
    l0 = -x * (x - 1.0) * (x - 2.0) / 6.0
    l1 = (x + 1.0) * (x - 1.0) * (x - 2.0) / 2.0
    l2 = -(x + 1.0) * x * (x - 2.0) / 2.0
    l3 = (x + 1.0) * x * (x - 1.0) / 6.0
    return ia, l0, l1, l2, l3  # rows ia .. ia + 3 hold a = (ia - 1 .. ia + 2) h_a


@njit(inline="always", **_JIT)
def _near_value(table, ia, l0, l1, l2, l3, u):
    """U or V-tilde at (a, u): cubic in a (weights l), Hermite in u (column units)."""
    iu = np.uint64(u)
    cap = np.uint64(table.shape[1] - 2)
    if iu > cap:
        iu = cap
    s = u - iu
    a1, a2, a3 = ia + _U1, ia + _U2, ia + _U3
    f0 = l0 * table[ia, iu, 0] + l1 * table[a1, iu, 0] + l2 * table[a2, iu, 0] + l3 * table[a3, iu, 0]
    d0 = l0 * table[ia, iu, 1] + l1 * table[a1, iu, 1] + l2 * table[a2, iu, 1] + l3 * table[a3, iu, 1]
    j = iu + _U1
    f1 = l0 * table[ia, j, 0] + l1 * table[a1, j, 0] + l2 * table[a2, j, 0] + l3 * table[a3, j, 0]
    d1 = l0 * table[ia, j, 1] + l1 * table[a1, j, 1] + l2 * table[a2, j, 1] + l3 * table[a3, j, 1]
    return _hermite(f0, d0, f1, d1, s)


@njit(inline="always", **_JIT)
def _near_full(near_u, near_v, ia, l0, l1, l2, l3, e_a):
    """J_pi(a) = U(a, 2^-1/2) + e^-a V-tilde(a, 2^-1/2)."""
    last = np.uint64(near_u.shape[1] - 1)
    a1, a2, a3 = ia + _U1, ia + _U2, ia + _U3
    return (l0 * (near_u[ia, last, 0] + e_a * near_v[ia, last, 0])
            + l1 * (near_u[a1, last, 0] + e_a * near_v[a1, last, 0])
            + l2 * (near_u[a2, last, 0] + e_a * near_v[a2, last, 0])
            + l3 * (near_u[a3, last, 0] + e_a * near_v[a3, last, 0]))


@njit(inline="always", **_JIT)
def _near_J(b, a, inv_2a, full, e_a, near_u, near_v, ia, l0, l1, l2, l3, u_scale):
    if b >= 2.0 * a:
        return full
    x = b * inv_2a
    if x <= 0.5:
        return _near_value(near_u, ia, l0, l1, l2, l3, np.sqrt(x) * u_scale)
    return full - e_a * _near_value(near_v, ia, l0, l1, l2, l3, np.sqrt(1.0 - x) * u_scale)


@njit(**_JIT)
def _J_pairs(a_arr, b_arr, C, a_split, far, eps_scale, t_scale, near_u, near_v, a_scale, u_scale, out):
    """J(a, b) pair by pair (test hook of the interpolation used in the deposit)."""
    n_a = near_u.shape[0] - 3
    for p in range(a_arr.shape[0]):
        a, b = a_arr[p], b_arr[p]
        if b <= 0.0:
            out[p] = 0.0
        elif a >= a_split:
            ie, fe = _far_row(eps_scale / a)
            out[p] = _far_K(far, ie, fe, np.sqrt(min(b, C)) * t_scale) / np.sqrt(a)
        else:
            ia, l0, l1, l2, l3 = _near_row(a, a_scale, n_a)
            e_a = np.exp(-a)
            full = _near_full(near_u, near_v, ia, l0, l1, l2, l3, e_a)
            inv_2a = 0.5 / a if a > 0.0 else 0.0
            out[p] = _near_J(b, a, inv_2a, full, e_a, near_u, near_v, ia, l0, l1, l2, l3, u_scale)


#: Values are padded with zeros to a multiple of this many columns, so that the
#: vectorised loop over them has no remainder.
_BLOCK = 4


@njit(inline="always", **_JIT)
def _deposit_row(out, o, step, wz, j_lo, j_hi, q, n_pad):
    """out[o + (j - j_lo) step + k] += wz[j] q[k] for j in [j_lo, j_hi), k < n_pad."""
    n = np.uint64(n_pad)
    for j in range(j_lo, j_hi):
        w = wz[j]
        for k in range(n):  # unsigned, contiguous: the loop vectoriser packs it
            out[o + k] += w * q[k]
        o += step


@njit(**_JIT)
def _deposit_chunk(start, stop, r, z, values, groups, r0, hr, n_r, z0, hz, n_z, half_inv_var, inv_var, C,
                   norm, a_split, far, eps_scale, t_scale, near_u, near_v, a_scale, u_scale, gz, dz2h, wz, q,
                   out):
    """Add particles start .. stop - 1 into ``out`` of shape (groups, n_r, n_z, K padded), flat.

    Uniform node axes ``r0 + m hr`` (m < n_r) and ``z0 + j hz`` (j < n_z): node
    ranges are computed, not searched, and the Gaussian factors of successive
    nodes follow by recurrence, :math:`g_{j+1} = g_j \\rho_j`,
    :math:`\\rho_{j+1} = \\rho_j e^{-h^2/\\sigma^2}` (a relative round-off of
    ~1e-15 over a kernel's nodes). ``gz``, ``dz2h`` and ``wz`` are scratch arrays
    of length n_z, ``q`` of the padded K.
    """
    n_k = values.shape[1]
    n_pad = q.shape[0]
    n_a = near_u.shape[0] - 3
    reach = np.sqrt(C / half_inv_var)  # the cutoff c
    two_var = 1.0 / half_inv_var
    kappa_r = np.exp(-2.0 * hr * hr * half_inv_var)
    kappa_z = np.exp(-2.0 * hz * hz * half_inv_var)
    inv_hr, inv_hz = 1.0 / hr, 1.0 / hz
    sigma = np.sqrt(1.0 / inv_var)
    step = np.uint64(n_pad)
    inv_r = np.empty(n_r)
    inv_sqrt_r = np.empty(n_r)
    for m in range(n_r):
        rn = r0 + m * hr
        inv_r[m] = 1.0 / rn if rn > 0.0 else 0.0  # only rows with a >= a_split > 0 use them
        inv_sqrt_r[m] = np.sqrt(inv_r[m])
    for k in range(n_k, n_pad):
        q[k] = 0.0
    for i in range(start, stop):
        ri, zi = r[i], z[i]
        m_lo = max(0, int(np.ceil((ri - reach - r0) * inv_hr)))
        m_hi = min(n_r, int(np.floor((ri + reach - r0) * inv_hr)) + 1)
        j0 = max(0, int(np.ceil((zi - reach - z0) * inv_hz)))
        nz = min(n_z, int(np.floor((zi + reach - z0) * inv_hz)) + 1) - j0
        if m_lo >= m_hi or nz <= 0:
            continue
        d = z0 + j0 * hz - zi
        g = np.exp(-d * d * half_inv_var)
        rho = np.exp(-(2.0 * d * hz + hz * hz) * half_inv_var)
        for j in range(nz):
            dj = d + j * hz
            dz2h[j] = dj * dj * half_inv_var
            gz[j] = g
            g *= rho
            rho *= kappa_z
        for k in range(n_k):
            q[k] = values[i, k]
        group_row = groups[i] * n_r
        # per particle, so that a row needs no division: 1/a = (sigma^2 / r_i) / r_n
        eps_i = eps_scale / (ri * inv_var) if ri > 0.0 else 0.0
        inv_sqrt_ri = sigma / np.sqrt(ri) if ri > 0.0 else 0.0
        d = r0 + m_lo * hr - ri
        g_row_next = norm * np.exp(-d * d * half_inv_var)
        rho = np.exp(-(2.0 * d * hr + hr * hr) * half_inv_var)
        for m in range(m_lo, m_hi):
            g_row = g_row_next
            g_row_next *= rho
            rho *= kappa_r
            rn = r0 + m * hr
            d = rn - ri
            b_row = C - d * d * half_inv_var
            if b_row <= 0.0:
                continue
            # nodes of this row inside the cutoff: |z_n - z_i| < sqrt(b_row) * sqrt(2) sigma
            half = np.sqrt(b_row * two_var)
            j_lo = max(0, int(np.ceil((zi - half - z0) * inv_hz)) - j0)
            j_hi = min(nz, int(np.floor((zi + half - z0) * inv_hz)) + 1 - j0)
            if j_lo >= j_hi:
                continue
            a = rn * ri * inv_var
            o = np.uint64(((group_row + m) * n_z + j0 + j_lo) * n_pad)
            if a >= a_split:
                ie, fe = _far_row(eps_i * inv_r[m])
                g_row *= inv_sqrt_r[m] * inv_sqrt_ri  # 1 / sqrt(a)
                # two passes: t with vectorised square roots, then the table lookups, whose
                # long dependency chains overlap once nothing else waits on them
                for j in range(np.uint64(j_lo), np.uint64(j_hi)):
                    wz[j] = np.sqrt(max(b_row - dz2h[j], 0.0)) * t_scale
                for j in range(np.uint64(j_lo), np.uint64(j_hi)):
                    wz[j] = g_row * gz[j] * _far_K(far, ie, fe, wz[j])
            else:
                ia, l0, l1, l2, l3 = _near_row(a, a_scale, n_a)
                e_a = np.exp(-a)
                full = _near_full(near_u, near_v, ia, l0, l1, l2, l3, e_a)
                inv_2a = 0.5 / a if a > 0.0 else 0.0
                for j in range(j_lo, j_hi):
                    b = b_row - dz2h[j]
                    if b > 0.0:  # d < c strictly, as in the numpy path (on the axis J(a, 0+) = pi)
                        wz[j] = g_row * gz[j] * _near_J(b, a, inv_2a, full, e_a, near_u, near_v,
                                                        ia, l0, l1, l2, l3, u_scale)
                    else:
                        wz[j] = 0.0
            _deposit_row(out, o, step, wz, j_lo, j_hi, q, n_pad)


def padded(n_k: int) -> int:
    """Columns of the deposit buffers: K rounded up to a multiple of the block."""
    return -(-n_k // _BLOCK) * _BLOCK


@njit(parallel=True, **_JIT)
def _deposit_parallel(r, z, values, groups, n_groups, r0, hr, n_r, z0, hz, n_z, half_inv_var, inv_var, C,
                      norm, a_split, far, eps_scale, t_scale, near_u, near_v, a_scale, u_scale, n_pad,
                      n_chunks):
    """One contiguous chunk of particles per thread, each adding into its own buffer; then the sum."""
    n = r.shape[0]
    size = n_groups * n_r * n_z * n_pad
    buffers = np.zeros((n_chunks, size))
    for c in prange(n_chunks):
        gz = np.empty(n_z)
        dz2h = np.empty(n_z)
        wz = np.empty(n_z)
        q = np.empty(n_pad)
        _deposit_chunk((n * c) // n_chunks, (n * (c + 1)) // n_chunks, r, z, values, groups, r0, hr, n_r,
                       z0, hz, n_z, half_inv_var, inv_var, C, norm, a_split, far, eps_scale, t_scale,
                       near_u, near_v, a_scale, u_scale, gz, dz2h, wz, q, buffers[c])
    total = buffers[0]
    for c in range(1, n_chunks):
        total += buffers[c]
    return total


def uniform_axis(nodes, rtol: float = 1e-9) -> tuple[float, float, int] | None:
    """``(first, spacing, count)`` of an equally spaced axis, or None."""
    nodes = np.asarray(nodes, dtype=float)
    if nodes.size < 2:
        return None
    h = (nodes[-1] - nodes[0]) / (nodes.size - 1)
    expected = nodes[0] + h * np.arange(nodes.size)
    if np.max(np.abs(nodes - expected)) > rtol * max(abs(h), np.max(np.abs(nodes))):
        return None
    return float(nodes[0]), float(h), int(nodes.size)


def deposit_rz(points, values, groups, n_groups, r_nodes, z_nodes, width, cutoff, norm, tables: RZTables,
               n_threads: int | None = None) -> np.ndarray:
    """Kernel-weighted densities of ``values`` on the ``(r, z)`` grid, per group.

    Parameters
    ----------
    points : ndarray, shape (N, 2)
        Particle :math:`(r_i, z_i)`.
    values : ndarray, shape (N, K)
        Per-particle quantities :math:`q_{ik}`.
    groups : ndarray of int, shape (N,)
        Group of each particle, in ``[0, n_groups)``.
    n_groups : int
    r_nodes, z_nodes : ndarray
        Equally spaced, increasing node axes.
    width, cutoff : float
        :math:`\\sigma` and :math:`c`.
    norm : float
        :math:`1 / \\pi Z` of the truncated kernel.
    tables : RZTables
        Built for :math:`C = c^2 / 2\\sigma^2`.
    n_threads : int, optional
        Number of chunks, run in parallel by up to that many numba threads;
        default :func:`numba.get_num_threads`.

    Returns
    -------
    ndarray, shape (n_groups, n_r * n_z, K)
        :math:`\\sum_{i \\in g} w_{in} q_{ik}`, nodes in C order (z fastest); a view
        into the padded buffer (not contiguous when K is not a multiple of 4).
    """
    points = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    values = np.ascontiguousarray(values, dtype=np.float64).reshape(len(points), -1)
    groups = np.ascontiguousarray(groups, dtype=np.int64)
    r_axis, z_axis = uniform_axis(r_nodes), uniform_axis(z_nodes)
    if r_axis is None or z_axis is None:
        raise ValueError("the compiled rz deposit needs equally spaced r and z nodes")
    n_groups, n_k = int(n_groups), values.shape[1]
    n_threads = max(1, int(n_threads or numba.get_num_threads()))
    C = cutoff**2 / (2.0 * width**2)
    if abs(C - tables.C) > 1e-12 * C:
        raise ValueError(f"tables were built for C = {tables.C}, kernel has C = {C}")
    total = _deposit_parallel(
        np.ascontiguousarray(points[:, 0]), np.ascontiguousarray(points[:, 1]), values, groups, n_groups,
        *r_axis, *z_axis, 0.5 / width**2, 1.0 / width**2, C, float(norm), *tables._args()[1:],
        padded(n_k), n_threads,
    )
    return total.reshape(n_groups, r_axis[2] * z_axis[2], padded(n_k))[:, :, :n_k]
