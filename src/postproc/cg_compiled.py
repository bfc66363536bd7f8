"""Compiled (numba) deposit of the axisymmetric truncated Gaussian kernel.

The ``rz`` weight of :class:`postproc.kernels.Gaussian` of a particle on a ring
node is the azimuthal average of the truncated 3D Gaussian, the same weight as
the numpy quadrature ``Gaussian._assign_rz``; :mod:`postproc.rz_tables` gives
its form and the tables of the azimuthal integral :math:`J(a, b)` that the
deposit interpolates (:class:`RZTables`, built once per kernel).

How the deposit is organised (whatever does not depend on the node is computed
once per particle or once per grid row):

* the Gaussian factor splits, :math:`e^{-p^2/2\\sigma^2} = g_r(r_n)\\, g_z(z_n)`:
  the factors of successive nodes follow by recurrence (two exponentials per
  particle and axis, none per node), and the node range of each grid row is
  computed, not searched (the compiled path needs equally spaced nodes);
* per grid row, :math:`a`, the far polynomial (mixed from two rows of
  :math:`\\epsilon`) and its weight, and :math:`a^{-1/2}` (from
  :math:`r_n^{-1/2}`, tabulated once per call) are computed once; per node
  only :math:`J` remains, a square root and a polynomial (:func:`postproc.cg_jit.estrin`), in
  a straight loop over the row's nodes that LLVM vectorises, 4 nodes at a time;
* all K quantities of a particle are added to a node in one pass, 4 at a time
  (:func:`postproc.cg_jit.add_scaled4`: K is padded to a multiple of 4, a node's values are
  contiguous), into the block of the particle's group;
* particles are visited in order of group, then nearest node in r, then in z (a
  counting sort, O(N)), so that successive particles add into the same nodes,
  in cache, and read the same rows of the far polynomials (:math:`\\epsilon`
  depends on :math:`r_i`);
* :func:`deposit_rz` runs on the calling thread and ``n_threads - 1`` helper
  threads (compiled code without the GIL), each adding into its own buffer;
  they take chunks of :data:`CHUNK` particles from a shared atomic counter as
  they go, so that a thread slowed down by another process on a shared machine
  holds up no one, and a helper that has not started by the time the work is
  done is cancelled rather than waited for (a fork-join of numba's threading
  layer waits for every thread to get a core, which on a busy machine costs a
  scheduler time slice per call). The buffers are summed once at the end. With
  one thread the result is deterministic; with several, the summation order,
  and so the last bits (~1e-16 relative), change from call to call. Compiled
  functions are cached on disk (``cache=True``).
"""
from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import numba
import numpy as np
from numba import njit

from .cg_jit import FAR_TERMS, JIT, J_pairs, add_scaled4, far_row, far_weights, fetch_add, near_J, near_full, near_row
from .rz_tables import FAR_ROWS, NEAR_COLUMNS, table_arrays

#: Particles a thread of :func:`deposit_rz` takes at a time.
CHUNK = 64


@dataclass(frozen=True)
class RZTables:
    """Interpolation tables of the azimuthal integral :math:`J(a, b)` for one :math:`C`.

    Attributes
    ----------
    C : float
        :math:`c^2 / 2\\sigma^2`.
    a_split : float
        :math:`a_s = \\max(C, 1)`.
    far : ndarray, shape (pieces, FAR_ROWS + 1, 16)
        Coefficients of :math:`F(\\epsilon, b)` in powers of
        :math:`y \\in [-1, 1]` on each piece of :math:`[0, C]` in b, per row of
        :math:`\\epsilon` (:func:`postproc.rz_tables._far_polynomials`; one row
        beyond the range: interpolation never needs a bounds test).
    near_u, near_v : ndarray, shape (n_a + 3, NEAR_COLUMNS - 1, 4)
        Cubic coefficients of :math:`U(a, u)` and :math:`\\tilde V(a, v)` on the
        cells of u or v, rows at :math:`a = (k - 1) h_a`.
    near_end : ndarray, shape (n_a + 3, 2)
        :math:`U(a, 2^{-1/2})` and :math:`\\tilde V(a, 2^{-1/2})` on those rows.
    near_step : float
        :math:`h_a`.
    """

    C: float
    a_split: float
    far: np.ndarray
    near_u: np.ndarray
    near_v: np.ndarray
    near_end: np.ndarray
    near_step: float

    @classmethod
    def build(cls, C: float) -> "RZTables":
        """The tables for :math:`C` (:func:`postproc.rz_tables.table_arrays`).

        Parameters
        ----------
        C : float
            :math:`c^2 / 2\\sigma^2` of the kernel (dimensionless, > 0).

        Returns
        -------
        RZTables
        """
        return cls(C=float(C), **table_arrays(float(C)))

    def J(self, a, b) -> np.ndarray:
        """:math:`J(a, b)` for arrays of pairs, with the compiled interpolation (for tests).

        Parameters
        ----------
        a, b : array_like
            :math:`a = r_n r_i / \\sigma^2 \\ge 0` and :math:`b = (c^2 - p^2) / 2\\sigma^2`
            (dimensionless), broadcast together; :math:`b` is clipped to :math:`C` far
            from the axis and :math:`J = 0` for :math:`b \\le 0`.

        Returns
        -------
        ndarray
            :math:`J(a, b)` (dimensionless, at most :math:`\\pi`), the broadcast shape.
        """
        a, b = np.broadcast_arrays(np.asarray(a, float), np.asarray(b, float))
        out = np.empty(a.shape)
        J_pairs(np.ascontiguousarray(a).reshape(-1), np.ascontiguousarray(b).reshape(-1), *self._args(),
                 out.reshape(-1))
        return out

    def _args(self):
        """The tables and their scales, in the order the compiled functions take them."""
        y_scale = 2.0 * self.far.shape[0] / self.C  # 2 / the width of a piece in b
        u_scale = (NEAR_COLUMNS - 1) / np.sqrt(0.5)
        return (self.C, self.a_split, self.far, (FAR_ROWS - 1) * self.a_split, y_scale,
                self.near_u, self.near_v, self.near_end, 1.0 / self.near_step, u_scale)


#: Values are padded with zeros to a multiple of this many columns, added 4 at a time.
_BLOCK = 4


@njit(inline="always", **JIT)
def _deposit_row(out, o, wz, j_lo, j_hi, q):
    """out[o + (j - j_lo) K + k] += wz[j] q[k] for j in [j_lo, j_hi), k < K = len(q), a multiple of 4."""
    n_pad = np.uint64(q.shape[0])
    u4, u8, u12 = np.uint64(4), np.uint64(8), np.uint64(12)
    for j in range(j_lo, j_hi):
        w = wz[j]
        k = np.uint64(0)
        while k + u12 <= n_pad:  # three blocks at a time: no loop overhead up to K = 12
            add_scaled4(out, o + k, w, q, k)
            add_scaled4(out, o + k + u4, w, q, k + u4)
            add_scaled4(out, o + k + u8, w, q, k + u8)
            k += u12
        while k < n_pad:
            add_scaled4(out, o + k, w, q, k)
            k += u4
        o += n_pad


@njit(**JIT)
def _visiting_order(r, z, groups, n_groups, r0, hr, n_r, z0, hz, n_z):
    """Particle indices by group, then nearest node in r, then in z (a stable counting sort)."""
    n = r.shape[0]
    n_cells = n_r * n_z
    key = np.empty(n, dtype=np.int64)
    start = np.zeros(n_groups * n_cells + 1, dtype=np.int64)
    inv_hr, inv_hz = 1.0 / hr, 1.0 / hz
    for i in range(n):
        x, y = (r[i] - r0) * inv_hr, (z[i] - z0) * inv_hz
        m = 0 if x <= 0.0 else (n_r - 1 if x >= n_r - 1 else int(x + 0.5))  # positions are finite
        j = 0 if y <= 0.0 else (n_z - 1 if y >= n_z - 1 else int(y + 0.5))
        key[i] = groups[i] * n_cells + m * n_z + j
        start[key[i] + 1] += 1
    for c in range(1, start.shape[0]):
        start[c] += start[c - 1]
    order = np.empty(n, dtype=np.int64)
    for i in range(n):
        order[start[key[i]]] = i
        start[key[i]] += 1
    return order


@njit(**JIT)
def _deposit_particles(order, start, stop, r, z, values, groups, grid, kernel, tables, inv_r, inv_sqrt_r, gz, dz2h,
                       wz, row, q, out):
    """Add particles ``order[start:stop]`` into ``out`` of shape (groups, n_r, n_z, K padded), flat.

    ``grid`` is ``(r0, hr, n_r, z0, hz, n_z)``: uniform node axes ``r0 + m hr``
    (m < n_r) and ``z0 + j hz`` (j < n_z). Node ranges are computed, not
    searched, and the Gaussian factors of successive nodes follow by recurrence,
    :math:`g_{j+1} = g_j \\rho_j`, :math:`\\rho_{j+1} = \\rho_j e^{-h^2/\\sigma^2}`
    (a relative round-off of ~1e-15 over a kernel's nodes). ``kernel`` is
    ``(1/2 sigma^2, C, 1/pi Z)``, ``tables`` is :meth:`RZTables._args` without
    C. ``inv_r`` and ``inv_sqrt_r`` hold :math:`1/r_n` and :math:`r_n^{-1/2}`
    (0 on the axis); ``gz``, ``dz2h`` and ``wz`` are scratch arrays of length
    n_z, ``row`` of :data:`FAR_TERMS` and ``q`` of the padded K.
    """
    r0, hr, n_r, z0, hz, n_z = grid
    half_inv_var, C, norm = kernel
    a_split, far, eps_scale, y_scale, near_u, near_v, near_end, a_scale, u_scale = tables
    width = 2.0 / y_scale  # of a piece of the far polynomials in b
    n_k = values.shape[1]
    n_pad = q.shape[0]
    n_a = near_u.shape[0] - 3
    two_var = 1.0 / half_inv_var
    inv_var = 2.0 * half_inv_var
    reach = np.sqrt(C * two_var)  # the cutoff c
    kappa_r = np.exp(-2.0 * hr * hr * half_inv_var)
    kappa_z = np.exp(-2.0 * hz * hz * half_inv_var)
    inv_hr, inv_hz = 1.0 / hr, 1.0 / hz
    sigma = np.sqrt(0.5 * two_var)
    for k in range(n_k, n_pad):
        q[k] = 0.0
    for p in range(start, stop):
        i = order[p]
        ri, zi = r[i], z[i]
        m_lo = max(0, int(np.ceil((ri - reach - r0) * inv_hr)))
        m_hi = min(n_r, int(np.floor((ri + reach - r0) * inv_hr)) + 1)
        j0 = max(0, int(np.ceil((zi - reach - z0) * inv_hz)))
        nz = min(n_z, int(np.floor((zi + reach - z0) * inv_hz)) + 1) - j0
        if m_lo >= m_hi or nz <= 0:
            continue
        # the z factors and squared distances of the particle's node columns, once
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
                fe = eps_i * inv_r[m]
                ie = np.int64(fe)
                fe -= ie
                w_row = g_row * inv_sqrt_r[m] * inv_sqrt_ri  # times 1 / sqrt(a)
                for piece in range(far.shape[0]):  # one piece unless C > FAR_PIECE
                    if piece * width >= b_row:
                        break
                    far_row(far, np.uint64(piece), np.uint64(ie), fe, row)
                    far_weights(wz, row, piece, width, y_scale, b_row, w_row, dz2h, gz, j_lo, j_hi)
            else:
                ia, l0, l1, l2, l3 = near_row(a, a_scale, n_a)
                e_a = np.exp(-a)
                full = near_full(near_end, ia, l0, l1, l2, l3, e_a)
                inv_2a = 0.5 / a if a > 0.0 else 0.0
                for j in range(j_lo, j_hi):
                    b = b_row - dz2h[j]
                    if b > 0.0:  # d < c strictly, as in the numpy path (on the axis J(a, 0+) = pi)
                        wz[j] = g_row * gz[j] * near_J(b, a, inv_2a, full, e_a, near_u, near_v,
                                                        ia, l0, l1, l2, l3, u_scale)
                    else:
                        wz[j] = 0.0
            _deposit_row(out, o, wz, j_lo, j_hi, q)


def padded(n_k: int) -> int:
    """Columns of the deposit buffers: K rounded up to a multiple of the block.

    Parameters
    ----------
    n_k : int
        Number of per-particle quantities K.

    Returns
    -------
    int
    """
    return -(-n_k // _BLOCK) * _BLOCK


@njit(**JIT)
def _prepare(r, z, groups, n_groups, grid):
    """The visiting order, and :math:`1/r_n`, :math:`r_n^{-1/2}` per grid row (0 on the axis)."""
    r0, hr, n_r, z0, hz, n_z = grid
    order = _visiting_order(r, z, groups, n_groups, r0, hr, n_r, z0, hz, n_z)
    inv_r = np.zeros(n_r)
    inv_sqrt_r = np.zeros(n_r)
    for m in range(n_r):
        rn = r0 + m * hr
        if rn > 0.0:  # only rows with a >= a_split > 0 use them
            inv_r[m] = 1.0 / rn
            inv_sqrt_r[m] = 1.0 / np.sqrt(rn)
    return order, inv_r, inv_sqrt_r


@njit(nogil=True, **JIT)
def _deposit_worker(worker, counters, order, r, z, values, groups, grid, kernel, tables, inv_r, inv_sqrt_r,
                    scratch, buffer):
    """One worker: chunks of :data:`CHUNK` particles of the visiting order, added into ``buffer``.

    The order is cut into one stretch per worker; ``counters[8 s]`` is the next
    particle of stretch ``s`` (a cache line per counter). A worker takes chunks
    from its own stretch, in order (so that successive chunks share nodes and
    table rows), then from the others' until none is left. Runs without the
    GIL, on any thread.
    """
    n_z = grid[5]
    n_pad = -(-values.shape[1] // _BLOCK) * _BLOCK
    q, row = scratch[:n_pad], scratch[-FAR_TERMS:]  # row: zeros beyond the far polynomials' terms
    gz, dz2h, wz = scratch[n_pad:][:n_z], scratch[n_pad + n_z:][:n_z], scratch[n_pad + 2 * n_z:][:n_z]
    n, n_workers = r.shape[0], counters.shape[0] // 8
    for i in range(n_workers):
        stretch = (worker + i) % n_workers
        stop = (n * (stretch + 1)) // n_workers
        start = fetch_add(counters[8 * stretch:], CHUNK)
        while start < stop:
            _deposit_particles(order, start, min(start + CHUNK, stop), r, z, values, groups, grid, kernel, tables,
                               inv_r, inv_sqrt_r, gz, dz2h, wz, row, q, buffer)
            start = fetch_add(counters[8 * stretch:], CHUNK)


@njit(**JIT)
def _unpadded_sum(buffers, workers, n_k):
    """Sum of the buffers of ``workers``, without the padding: shape (nodes of all groups, K)."""
    n_pad = -(-n_k // _BLOCK) * _BLOCK
    n_nodes = buffers.shape[1] // n_pad
    total = np.zeros((n_nodes, n_k))
    for w in workers:
        buffer = buffers[w]
        for node in range(n_nodes):
            for k in range(n_k):
                total[node, k] += buffer[node * n_pad + k]
    return total


def _aligned_zeros(rows: int, length: int, line: int = 64) -> np.ndarray:
    """Zeros of shape (rows, length), each row starting on a cache line, rows a whole number of lines apart."""
    per_line = line // 8
    stride = -(-length // per_line) * per_line
    raw = np.zeros(rows * stride + per_line)
    shift = (-raw.ctypes.data % line) // 8
    return raw[shift:shift + rows * stride].reshape(rows, stride)[:, :length]


def _deposit_threads(r, z, values, groups, n_groups, grid, kernel, tables, n_workers: int) -> np.ndarray:
    """Run :func:`_deposit_worker` on this thread and ``n_workers - 1`` helper threads; the summed buffers.

    The helpers share the work only if they get a core in time: a helper that
    has not started when this thread finds no chunk left is cancelled (so a
    busy machine costs no waiting for a core), one that has started is waited
    for (it is adding its last chunk).
    """
    order, inv_r, inv_sqrt_r = _prepare(r, z, groups, n_groups, grid)
    n_pad = padded(values.shape[1])
    n_z = grid[5]
    size = n_groups * grid[2] * n_z * n_pad
    # rows on cache lines of their own: 4-wide additions never straddle two lines, and no line
    # is shared between workers (it would bounce between the cores)
    buffers = _aligned_zeros(n_workers, size)
    scratch = _aligned_zeros(n_workers, n_pad + FAR_TERMS + 3 * n_z)
    # the next particle of each worker's stretch of the order, a cache line per counter
    counters = _aligned_zeros(1, 8 * n_workers)[0].view(np.int64)
    counters[::8] = (len(r) * np.arange(n_workers)) // n_workers
    shared = (counters, order, r, z, values, groups, grid, kernel, tables, inv_r, inv_sqrt_r)
    workers = [0]
    if n_workers == 1:
        _deposit_worker(0, *shared, scratch[0], buffers[0])
    else:
        pool = ThreadPoolExecutor(n_workers - 1, thread_name_prefix="deposit_rz")
        try:
            helpers = [pool.submit(_deposit_worker, w, *shared, scratch[w], buffers[w]) for w in range(1, n_workers)]
            _deposit_worker(0, *shared, scratch[0], buffers[0])
            for w, helper in enumerate(helpers, start=1):
                if not helper.cancel():
                    helper.result()
                    workers.append(w)
        finally:
            pool.shutdown(wait=False)
    return _unpadded_sum(buffers, np.array(workers, dtype=np.int64), values.shape[1])


def uniform_axis(nodes, rtol: float = 1e-9) -> tuple[float, float, int] | None:
    """``(first, spacing, count)`` of an equally spaced axis, or None.

    Parameters
    ----------
    nodes : array_like, 1-D
        Node coordinates, any length unit.
    rtol : float
        Largest departure from the equally spaced axis, relative to the larger
        of the spacing and the largest absolute node coordinate.

    Returns
    -------
    tuple of (float, float, int) or None
        ``(first, spacing, count)`` in the unit of ``nodes``; None with fewer than
        two nodes or unequal spacing.
    """
    nodes = np.asarray(nodes, dtype=float)
    if nodes.size < 2:
        return None
    h = (nodes[-1] - nodes[0]) / (nodes.size - 1)
    expected = nodes[0] + h * np.arange(nodes.size)
    if np.max(np.abs(nodes - expected)) > rtol * max(abs(h), np.max(np.abs(nodes))):
        return None
    return float(nodes[0]), float(h), int(nodes.size)


def deposit_rz(points, values, groups, n_groups, r_axis, z_axis, width, cutoff, norm, tables: RZTables,
               n_threads: int | None = None) -> np.ndarray:
    """Kernel-weighted densities of ``values`` on the ``(r, z)`` grid, per group.

    Lengths are in any one unit (the dump's), and the weights :math:`w_{in}`
    in its inverse cube: a density of :math:`q` per unit volume. Particles
    without a finite position are left out.

    Parameters
    ----------
    points : ndarray, shape (N, 2)
        Particle :math:`(r_i, z_i)`, length units.
    values : ndarray, shape (N, K)
        Per-particle quantities :math:`q_{ik}` (any units; shape (N,) is one column).
    groups : ndarray of int, shape (N,)
        Group of each particle, in ``[0, n_groups)``.
    n_groups : int
    r_axis, z_axis : tuple (first, spacing, count)
        The equally spaced node axes (:func:`uniform_axis`), length units.
    width, cutoff : float
        :math:`\\sigma` and :math:`c`, length units.
    norm : float
        :math:`1 / \\pi Z` of the truncated kernel (:math:`Z` in volume units).
    tables : RZTables
        Built for :math:`C = c^2 / 2\\sigma^2`.
    n_threads : int, optional
        Number of threads (this one and helpers, each adding into its own
        buffer); default :func:`numba.get_num_threads`.

    Returns
    -------
    ndarray, shape (n_groups, n_r * n_z, K)
        :math:`\\sum_{i \\in g} w_{in} q_{ik}`, nodes in C order (z fastest), contiguous.

    Raises
    ------
    ValueError
        If ``tables`` were built for another :math:`C` than ``width`` and ``cutoff`` give.
    """
    points = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    values = np.asarray(values, dtype=np.float64)
    values = values[:, None] if values.ndim == 1 else values
    groups = np.asarray(groups, dtype=np.int64)
    finite = np.isfinite(points).all(axis=1)
    if not finite.all():  # as in the numpy path, a particle without a position has no node
        points, values, groups = points[finite], values[finite], groups[finite]
    values, groups = np.ascontiguousarray(values), np.ascontiguousarray(groups)
    (r0, hr, n_r), (z0, hz, n_z) = r_axis, z_axis
    n_groups, n_k = int(n_groups), values.shape[1]
    n_threads = max(1, int(n_threads or numba.get_num_threads()))
    C = cutoff**2 / (2.0 * width**2)
    if abs(C - tables.C) > 1e-12 * C:
        raise ValueError(f"tables were built for C = {tables.C}, kernel has C = {C}")
    grid = (float(r0), float(hr), int(n_r), float(z0), float(hz), int(n_z))
    total = _deposit_threads(np.ascontiguousarray(points[:, 0]), np.ascontiguousarray(points[:, 1]), values,
                             groups, n_groups, grid, (0.5 / width**2, C, float(norm)), tables._args()[1:],
                             n_threads)
    return total.reshape(n_groups, n_r * n_z, n_k)
