"""The compiled primitives of the axisymmetric deposit (:mod:`postproc.cg_compiled`): the numba
options (:data:`JIT`), the atomic counter and the 4-wide add (LLVM intrinsics), and the
interpolation of the azimuthal integral :math:`J(a, b)` from the tables of :mod:`postproc.rz_tables`
(far polynomials evaluated by :func:`estrin`, near cells by cubic Lagrange rows; :func:`J_pairs`
evaluates it on pairs for :meth:`postproc.cg_compiled.RZTables.J`). Moved from cg_compiled.py
unchanged; compiled functions are cached on disk."""
from __future__ import annotations

import numpy as np
from llvmlite import ir
from numba import njit
from numba.core import cgutils, types
from numba.extending import intrinsic


JIT = dict(cache=True, error_model="numpy", fastmath=True)


@intrinsic
def fetch_add(typingctx, counter, delta):
    """``counter[0] += delta`` in one atomic step, returning the value before.

    The workers of :func:`postproc.cg_compiled.deposit_rz` take their next chunk of particles
    with it (an LLVM ``atomicrmw add``: numba has no atomics on the CPU).

    Parameters
    ----------
    typingctx : numba typing context
        Supplied by numba (an ``@intrinsic``; compiled callers pass only the two below).
    counter : ndarray of int64, shape (1,)
        The shared counter.
    delta : int
        What to add.
    """
    if not (isinstance(counter, types.Array) and counter.dtype == types.int64 and counter.ndim == 1
            and isinstance(delta, types.Integer)):
        return None

    def codegen(context, builder, sig, args):
        array = context.make_array(sig.args[0])(context, builder, args[0])
        return builder.atomic_rmw("add", array.data, args[1], "monotonic")

    return types.int64(counter, types.int64), codegen


_V4 = ir.VectorType(ir.DoubleType(), 4)


@intrinsic
def add_scaled4(typingctx, out, o, w, q, k):
    """``out[o:o + 4] += w * q[k:k + 4]`` as one 4-wide fused multiply-add (no bounds test).

    The deposit's innermost operation. Numba runs LLVM's loop vectoriser but
    not its SLP vectoriser, and a loop over K = 12 values is too short for the
    former (it would need 16): the packed operation is written out here.

    Parameters
    ----------
    typingctx : numba typing context
        Supplied by numba (an ``@intrinsic``; compiled callers pass only the five below).
    out : ndarray of float64, C-contiguous
        The node buffer added into.
    o : uint64
        Offset in ``out`` of the first of the 4 values.
    w : float
        The kernel weight of the particle at the node.
    q : ndarray of float64, C-contiguous
        The particle's quantities (padded to a multiple of 4).
    k : uint64
        Offset in ``q`` of the first of the 4 values.
    """
    if not all(isinstance(a, types.Array) and a.dtype == types.float64 and a.ndim == 1 and a.layout == "C"
               for a in (out, q)):
        return None  # contiguous float64 vectors only: the element offsets are taken as addresses

    def codegen(context, builder, sig, args):
        out_data = context.make_array(sig.args[0])(context, builder, args[0]).data
        q_data = context.make_array(sig.args[3])(context, builder, args[3]).data
        target = builder.bitcast(builder.gep(out_data, [args[1]]), _V4.as_pointer())
        source = builder.bitcast(builder.gep(q_data, [args[4]]), _V4.as_pointer())
        zeros = ir.Constant(ir.VectorType(ir.IntType(32), 4), [0, 0, 0, 0])
        w4 = builder.insert_element(ir.Constant(_V4, ir.Undefined), args[2], ir.Constant(ir.IntType(32), 0))
        w4 = builder.shuffle_vector(w4, ir.Constant(_V4, ir.Undefined), zeros)
        fma = cgutils.get_or_insert_function(builder.module, ir.FunctionType(_V4, [_V4] * 3), "llvm.fma.v4f64")
        total = builder.call(fma, [w4, builder.load(source, align=8), builder.load(target, align=8)])
        builder.store(total, target, align=8)
        return context.get_dummy_value()

    return types.void(out, types.uint64, types.float64, q, types.uint64), codegen


# Table and buffer indices are unsigned (np.uint64): numba then skips the negative-index
# wraparound test, which otherwise blocks vectorisation.
_U1, _U2, _U3 = np.uint64(1), np.uint64(2), np.uint64(3)
#: Coefficients that :func:`estrin` evaluates (a far polynomial of lower degree is padded with zeros).
FAR_TERMS = 16


@njit(inline="always", **JIT)
def cubic(cells, i, j, s):
    """The cubic of cell ``cells[i, j]`` at ``s`` (Estrin's scheme: a shorter dependency chain than Horner's).

    Parameters
    ----------
    cells : ndarray, shape (n_a, n_u, 4)
        Cubic coefficients of each table cell.
    i, j : uint64
        The cell's row (in a) and column (in u).
    s : float
        Position in the cell, in column units (0 to 1).
    """
    return (cells[i, j, 0] + s * cells[i, j, 1]) + (s * s) * (cells[i, j, 2] + s * cells[i, j, 3])


@njit(inline="always", **JIT)
def estrin(c, y):
    """:math:`\\sum_{k < 16} c_k y^k` by Estrin's scheme (5 dependent steps where Horner's takes 15).

    Parameters
    ----------
    c : ndarray, shape (16,)
        The coefficients (a polynomial of lower degree padded with zeros).
    y : float
        Where to evaluate it (the piece's variable, in [-1, 1]).
    """
    y2 = y * y
    y4 = y2 * y2
    q0 = (c[0] + c[1] * y) + y2 * (c[2] + c[3] * y)
    q1 = (c[4] + c[5] * y) + y2 * (c[6] + c[7] * y)
    q2 = (c[8] + c[9] * y) + y2 * (c[10] + c[11] * y)
    q3 = (c[12] + c[13] * y) + y2 * (c[14] + c[15] * y)
    return (q0 + y4 * q1) + (y4 * y4) * (q2 + y4 * q3)


@njit(inline="always", **JIT)
def far_row(far, piece, ie, fe, row):
    """``row``: the far polynomial at epsilon, rows ie and ie + 1 of ``far[piece]`` mixed linearly (fraction fe).

    Parameters
    ----------
    far : ndarray, shape (pieces, rows, terms)
        The far tables (:func:`postproc.rz_tables.table_arrays`).
    piece : uint64
        The piece of b.
    ie : uint64
        The lower row of epsilon.
    fe : float
        The fraction of the way to row ``ie + 1``.
    row : ndarray, shape (FAR_TERMS,)
        Written: the mixed coefficients.
    """
    for k in range(np.uint64(min(far.shape[2], row.shape[0]))):  # never more terms than estrin takes
        c0 = far[piece, ie, k]
        row[k] = c0 + fe * (far[piece, ie + _U1, k] - c0)


@njit(inline="always", **JIT)
def far_weights(wz, row, piece, width, y_scale, b_row, w_row, dz2h, gz, j_lo, j_hi):
    """``wz[j] = w_row gz[j] sqrt(b) F(b)``, b = ``b_row - dz2h[j]``, j in [j_lo, j_hi): a vectorised loop.

    Piece 0 sets every node (b <= 0 gives 0), a further one overwrites the
    nodes with b in ``[piece width, (piece + 1) width)``.

    Parameters
    ----------
    wz : ndarray, shape (n_z,)
        Written: the weight of each node of the grid row.
    row : ndarray, shape (FAR_TERMS,)
        The piece's polynomial (:func:`far_row`).
    piece : int
        The piece of b.
    width : float
        The width of a piece in b (dimensionless, as b).
    y_scale : float
        2 / ``width``: maps b in a piece to [-1, 1].
    b_row : float
        b of the row before the node's axial term, dimensionless (in units of the kernel's 2σ²).
    w_row : float
        The row's factor (the radial Gaussian factor and normalisation).
    dz2h : ndarray, shape (n_z,)
        Each node's axial term of b.
    gz : ndarray, shape (n_z,)
        Each node's axial Gaussian factor.
    j_lo, j_hi : int
        The nodes of the row within the cutoff.
    """
    if piece == 0:
        for j in range(np.uint64(j_lo), np.uint64(j_hi)):
            b = max(b_row - dz2h[j], 0.0)
            wz[j] = w_row * gz[j] * np.sqrt(b) * estrin(row, b * y_scale - 1.0)
    else:
        b_0 = piece * width
        for j in range(np.uint64(j_lo), np.uint64(j_hi)):
            b = b_row - dz2h[j]
            if b >= b_0:
                wz[j] = w_row * gz[j] * np.sqrt(b) * estrin(row, (b - b_0) * y_scale - 1.0)


@njit(inline="always", **JIT)
def near_row(a, a_scale, n_a):
    """First of the four table rows around a and their cubic Lagrange weights.

    Parameters
    ----------
    a : float
        The near table's variable (dimensionless).
    a_scale : float
        Rows per unit of a (1 / the row step).
    n_a : int
        Rows of the table less the 3 of the stencil.

    Returns
    -------
    ia : uint64
        The first row (rows ia .. ia + 3 hold a = (ia - 1 .. ia + 2) h_a).
    l0, l1, l2, l3 : float
        The Lagrange weights of the four rows.
    """
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


@njit(inline="always", **JIT)
def near_value(cells, ia, l0, l1, l2, l3, u):
    """U or V-tilde at (a, u): cubic Lagrange in a (weights l), the cell's cubic in u (column units).

    Parameters
    ----------
    cells : ndarray, shape (n_a, n_u, 4)
        The table (U or V-tilde).
    ia : uint64
        The first of the four rows (:func:`near_row`).
    l0, l1, l2, l3 : float
        Their Lagrange weights.
    u : float
        The column coordinate (column units).
    """
    iu = np.uint64(u)
    cap = np.uint64(cells.shape[1] - 1)
    if iu > cap:
        iu = cap
    s = u - iu
    return (l0 * cubic(cells, ia, iu, s) + l1 * cubic(cells, ia + _U1, iu, s)
            + l2 * cubic(cells, ia + _U2, iu, s) + l3 * cubic(cells, ia + _U3, iu, s))


@njit(inline="always", **JIT)
def near_full(near_end, ia, l0, l1, l2, l3, e_a):
    """J_pi(a) = U(a, 2^-1/2) + e^-a V-tilde(a, 2^-1/2).

    Parameters
    ----------
    near_end : ndarray, shape (n_a, 2)
        U and V-tilde at u = 2^-1/2 per row.
    ia : uint64
        The first of the four rows (:func:`near_row`).
    l0, l1, l2, l3 : float
        Their Lagrange weights.
    e_a : float
        :math:`e^{-a}`.
    """
    a1, a2, a3 = ia + _U1, ia + _U2, ia + _U3
    return (l0 * (near_end[ia, 0] + e_a * near_end[ia, 1]) + l1 * (near_end[a1, 0] + e_a * near_end[a1, 1])
            + l2 * (near_end[a2, 0] + e_a * near_end[a2, 1]) + l3 * (near_end[a3, 0] + e_a * near_end[a3, 1]))


@njit(inline="always", **JIT)
def near_J(b, a, inv_2a, full, e_a, near_u, near_v, ia, l0, l1, l2, l3, u_scale):
    """J(a, b) from the near tables: the whole integral where b >= 2a, else U or J_pi - e^-a V-tilde.

    Parameters
    ----------
    b, a : float
        The integral's variables (dimensionless).
    inv_2a : float
        1 / (2a) (0 at a = 0).
    full : float
        J_pi(a) (:func:`near_full`).
    e_a : float
        :math:`e^{-a}`.
    near_u, near_v : ndarray, shape (n_a, n_u, 4)
        The U and V-tilde tables.
    ia : uint64
        The first of the four rows (:func:`near_row`).
    l0, l1, l2, l3 : float
        Their Lagrange weights.
    u_scale : float
        Columns per unit of u.
    """
    if b >= 2.0 * a:
        return full
    x = b * inv_2a
    if x <= 0.5:
        return near_value(near_u, ia, l0, l1, l2, l3, np.sqrt(x) * u_scale)
    return full - e_a * near_value(near_v, ia, l0, l1, l2, l3, np.sqrt(1.0 - x) * u_scale)


@njit(**JIT)
def J_pairs(a_arr, b_arr, C, a_split, far, eps_scale, y_scale, near_u, near_v, near_end, a_scale, u_scale, out):
    """J(a, b) pair by pair (test hook of the interpolation used in the deposit).

    Parameters
    ----------
    a_arr, b_arr : ndarray, shape (n,)
        The pairs (dimensionless).
    C : float
        The cutoff of b.
    a_split : float
        Where the far tables take over from the near ones.
    far : ndarray, shape (pieces, rows, terms)
        The far tables.
    eps_scale : float
        Rows of epsilon per unit of 1/a.
    y_scale : float
        2 / the width of a piece in b.
    near_u, near_v : ndarray, shape (n_a, n_u, 4)
        The near tables.
    near_end : ndarray, shape (n_a, 2)
        U and V-tilde at u = 2^-1/2.
    a_scale, u_scale : float
        Rows per unit of a, columns per unit of u.
    out : ndarray, shape (n,)
        Written: J of each pair.
    """
    n_a = near_u.shape[0] - 3
    width = 2.0 / y_scale
    row = np.zeros(FAR_TERMS)
    for p in range(a_arr.shape[0]):
        a, b = a_arr[p], b_arr[p]
        if b <= 0.0:
            out[p] = 0.0
        elif a >= a_split:
            b = min(b, C)
            fe = eps_scale / a
            ie = np.uint64(fe)
            piece = min(np.uint64(b / width), np.uint64(far.shape[0] - 1))
            far_row(far, piece, ie, fe - ie, row)
            out[p] = np.sqrt(b) * estrin(row, (b - piece * width) * y_scale - 1.0) / np.sqrt(a)
        else:
            ia, l0, l1, l2, l3 = near_row(a, a_scale, n_a)
            e_a = np.exp(-a)
            full = near_full(near_end, ia, l0, l1, l2, l3, e_a)
            inv_2a = 0.5 / a if a > 0.0 else 0.0
            out[p] = near_J(b, a, inv_2a, full, e_a, near_u, near_v, ia, l0, l1, l2, l3, u_scale)
