"""Coarse-graining kernels: how one particle spreads onto the nodes of a grid.

A kernel is one of three independent choices of a coarse-graining (with the
coordinates, :mod:`postproc.coordinates`, and the fields, :mod:`postproc.fields`).
Given the particles' coordinates in the space of a coordinate system, a kernel
returns a sparse :class:`Assignment` of particles to nodes with weights
:math:`w_{in}` of units 1/volume, normalised so that a particle whose kernel lies
entirely inside the domain contributes one particle in total,

.. math::

    \\int w_i(\\mathbf{r})\\, \\mathrm{d}V = 1 ,

and a coarse-grained density of any per-particle quantity :math:`q_i` at node
:math:`n` is :math:`\\sum_i w_{in} q_i`.

Every kernel offers

``n_nodes``
    number of nodes;
``node_columns(coordinates)``
    dict of node-coordinate columns (length ``n_nodes``) for result tables;
``node_volumes(coordinates, box)``
    volume attributed to each node, shape ``(n_nodes,)``;
``assign(points, coordinates, box)``
    the :class:`Assignment` for points of shape ``(N, ndim)``;
``deposit(points, values, coordinates, box, groups=None, n_groups=1)``
    the kernel-weighted densities :math:`\\sum_{i \\in g} w_{in} q_{ik}` per group
    ``g``, shape ``(n_groups, n_nodes, K)``. The reference implementation is
    :func:`deposit_by_assignment` (``assign`` then one ``numpy.bincount`` per
    column); :class:`Gaussian` on ``rz`` coordinates has a compiled path
    (:mod:`postproc.cg_compiled`).

Multi-dimensional nodes are numbered in C order (last coordinate fastest).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np
from scipy.special import erf

#: Gauss-Legendre points for the azimuthal integral of the ``rz`` Gaussian. Over
#: the truncated arc the exponent varies by at most ``cutoff**2 / (2 width**2)``,
#: a smooth (entire) integrand, for which 24 points reach round-off.
AZIMUTHAL_QUADRATURE_POINTS = 24


@dataclass(frozen=True)
class Assignment:
    """Sparse particle-to-node assignment of a kernel.

    Attributes
    ----------
    particle : ndarray of int, shape (M,)
        Particle index of each pair.
    node : ndarray of int, shape (M,)
        Flat node index of each pair.
    weight : ndarray of float, shape (M,)
        Kernel weight :math:`w_{in}`, units 1/volume.
    """

    particle: np.ndarray
    node: np.ndarray
    weight: np.ndarray


def channel_bin_edges(
    walls: tuple[float, float], bin_width: float = 1.0, wall_bin_width: float = 1.5
) -> np.ndarray:
    """Bin edges across a channel with wider bins at the two walls.

    One bin of width ``wall_bin_width`` touches each wall; the interior
    :math:`L = W - 2 w_\\mathrm{wall}` is cut into
    :math:`n = \\max(1, \\lfloor L / d \\rfloor)` equal bins. When :math:`L` is not
    a multiple of the bin width :math:`d`, the remainder is spread evenly over
    the interior bins, whose width is then :math:`L / n` (slightly above
    :math:`d`).

    Parameters
    ----------
    walls : (float, float)
        Wall positions :math:`(x_0, x_0 + W)`, length units.
    bin_width : float
        Target interior bin width :math:`d`.
    wall_bin_width : float
        Width of each wall bin.

    Returns
    -------
    ndarray, shape (n + 3,)
        Increasing edges from ``walls[0]`` to ``walls[1]``.
    """
    lo, hi = (float(w) for w in walls)
    interior = (hi - lo) - 2.0 * wall_bin_width
    if bin_width <= 0 or wall_bin_width <= 0:
        raise ValueError("bin widths must be positive")
    if interior <= 0:
        raise ValueError(
            f"channel of width {hi - lo} has no room between two wall bins of {wall_bin_width}"
        )
    n = max(1, int(np.floor(interior / bin_width + 1e-9)))
    inner = np.linspace(lo + wall_bin_width, hi - wall_bin_width, n + 1)
    return np.concatenate([[lo], inner, [hi]])


def _as_axes(edges_or_nodes) -> tuple[np.ndarray, ...]:
    """Normalise one array or a sequence of arrays into a tuple of strictly increasing 1D axes."""
    if isinstance(edges_or_nodes, np.ndarray) or np.isscalar(edges_or_nodes[0]):
        axes = (edges_or_nodes,)
    else:
        axes = tuple(edges_or_nodes)
    axes = tuple(np.asarray(a, dtype=float) for a in axes)
    for a in axes:
        if a.ndim != 1 or a.size < 2 or np.any(np.diff(a) <= 0):
            raise ValueError("each axis needs at least two strictly increasing values")
    return axes


def _check_dimension(coordinates, ndim: int) -> None:
    if len(coordinates.names) != ndim:
        raise ValueError(
            f"kernel has {ndim} axes but coordinates {coordinates.kind!r} have "
            f"{len(coordinates.names)}"
        )


def _grid_columns(names: Sequence[str], axes: Sequence[np.ndarray]) -> list[np.ndarray]:
    """Flattened C-ordered meshgrid of the axes."""
    return [g.ravel() for g in np.meshgrid(*axes, indexing="ij")]


class HeavisideBins:
    """Top-hat bins on the particle centres (MercuryCG's Heaviside function).

    A particle belongs to the bin containing its centre, with weight

    .. math::

        w_{in} = \\frac{1}{V_n}\\, \\Theta(\\mathbf{x}_i \\in \\text{bin } n),

    so :math:`\\sum_n w_{in} V_n = 1` exactly. Bins are half-open
    :math:`[e_k, e_{k+1})`, except that the last edge is included; particles
    outside all bins are dropped.

    Parameters
    ----------
    edges : array_like or sequence of array_like
        Bin edges, one increasing array per coordinate (a single array for 1D).
    """

    def __init__(self, edges):
        self.edges = _as_axes(edges)
        self.shape = tuple(len(e) - 1 for e in self.edges)

    @property
    def n_nodes(self) -> int:
        return int(np.prod(self.shape))

    def node_columns(self, coordinates) -> dict[str, np.ndarray]:
        """Bin centre ``<c>`` and bounds ``<c>_lo``, ``<c>_hi`` for each coordinate ``c``."""
        _check_dimension(coordinates, len(self.edges))
        centres = _grid_columns(coordinates.names, [0.5 * (e[1:] + e[:-1]) for e in self.edges])
        lows = _grid_columns(coordinates.names, [e[:-1] for e in self.edges])
        highs = _grid_columns(coordinates.names, [e[1:] for e in self.edges])
        columns = {}
        for name, c, lo, hi in zip(coordinates.names, centres, lows, highs):
            columns.update({name: c, f"{name}_lo": lo, f"{name}_hi": hi})
        return columns

    def node_volumes(self, coordinates, box) -> np.ndarray:
        """Bin volumes :math:`V_n` from the coordinate system's cell measure."""
        _check_dimension(coordinates, len(self.edges))
        return np.asarray(coordinates.cell_volumes(self.edges, box), dtype=float).ravel()

    def assign(self, points, coordinates, box) -> Assignment:
        """Assign each particle centre to its bin with weight :math:`1/V_n`."""
        points = np.asarray(points, dtype=float).reshape(len(points), -1)
        _check_dimension(coordinates, len(self.edges))
        inside = np.ones(len(points), dtype=bool)
        index = []
        for k, e in enumerate(self.edges):
            i = np.searchsorted(e, points[:, k], side="right") - 1
            i[points[:, k] == e[-1]] = len(e) - 2
            inside &= (i >= 0) & (i < len(e) - 1)
            index.append(i)
        particle = np.flatnonzero(inside)
        node = np.ravel_multi_index(tuple(i[inside] for i in index), self.shape)
        weight = 1.0 / self.node_volumes(coordinates, box)[node]
        return Assignment(particle=particle, node=node, weight=weight)

    def deposit(self, points, values, coordinates, box, groups=None, n_groups: int = 1,
                method: str = "auto") -> np.ndarray:
        """Bin sums over the bin volume per group, shape (n_groups, n_nodes, K).

        Always :func:`deposit_by_assignment` (``method`` is accepted for symmetry
        with :meth:`Gaussian.deposit`; ``"compiled"`` is refused).
        """
        if method == "compiled":
            raise ValueError("Heaviside bins have no compiled deposit")
        return deposit_by_assignment(self, points, values, coordinates, box, groups, n_groups)


#: Particles per chunk of the numpy deposit: bounds the memory of the pair arrays
#: (~300 pairs per particle for a 3D Gaussian on an (r, z) grid).
DEPOSIT_CHUNK = 16384


def deposit_by_assignment(kernel, points, values, coordinates, box, groups=None, n_groups: int = 1) -> np.ndarray:
    """Kernel-weighted densities per group, the straightforward numpy way.

    ``kernel.assign`` gives the pairs (particle, node, weight); each column of
    ``values`` is then summed per (group, node) with :func:`numpy.bincount`.
    Particles are processed in chunks of :data:`DEPOSIT_CHUNK`.

    .. math::

        D_{gnk} = \\sum_{i:\\, g_i = g} w_{in}\\, q_{ik}

    Parameters
    ----------
    kernel : HeavisideBins or Gaussian
    points : array_like, shape (N, ndim)
        Particle coordinates in the space of ``coordinates``.
    values : array_like, shape (N, K) or (N,)
        Per-particle quantities :math:`q_{ik}`.
    coordinates : XCoordinates or RZCoordinates
    box : array_like, shape (3, 2)
    groups : array_like of int, shape (N,), optional
        Group of each particle in ``[0, n_groups)``, e.g. its species index;
        None puts every particle in group 0.
    n_groups : int

    Returns
    -------
    ndarray, shape (n_groups, n_nodes, K)
    """
    points = np.asarray(points, dtype=float).reshape(len(points), -1)
    values = np.asarray(values, dtype=float).reshape(len(points), -1)
    groups = _check_groups(groups, len(points), n_groups)
    n_nodes, n_k = kernel.n_nodes, values.shape[1]
    out = np.zeros((n_groups * n_nodes, n_k))
    for start in range(0, len(points), DEPOSIT_CHUNK):
        chunk = slice(start, start + DEPOSIT_CHUNK)
        a = kernel.assign(points[chunk], coordinates, box)
        index = a.node if groups is None else groups[chunk][a.particle] * n_nodes + a.node
        for k in range(n_k):
            out[:, k] += np.bincount(index, weights=a.weight * values[chunk][a.particle, k],
                                     minlength=n_groups * n_nodes)
    return out.reshape(n_groups, n_nodes, n_k)


def _check_groups(groups, n: int, n_groups: int):
    if int(n_groups) < 1:
        raise ValueError(f"n_groups must be at least 1, not {n_groups}")
    if groups is None:
        return None
    groups = np.asarray(groups)
    if groups.shape != (n,) or not np.issubdtype(groups.dtype, np.integer):
        raise ValueError(f"groups must be {n} integers, got shape {groups.shape} of {groups.dtype}")
    if n and (groups.min() < 0 or groups.max() >= n_groups):
        raise ValueError(f"groups must lie in [0, {n_groups}), found [{groups.min()}, {groups.max()}]")
    return groups.astype(np.int64)


def _candidate_pairs(points: np.ndarray, axes: Sequence[np.ndarray], reach: float):
    """All (particle, node) pairs with every node coordinate within ``reach`` of the particle.

    Returns the particle indices and a tuple of per-axis node indices, vectorised
    by expanding each particle's index box (no loop over particles).
    """
    lo = [np.searchsorted(a, points[:, k] - reach, side="left") for k, a in enumerate(axes)]
    hi = [np.searchsorted(a, points[:, k] + reach, side="right") for k, a in enumerate(axes)]
    counts = [h - l for h, l in zip(hi, lo)]
    per_particle = np.prod(counts, axis=0) if counts else np.zeros(len(points), int)
    particle = np.repeat(np.arange(len(points)), per_particle)
    local = np.arange(particle.size) - np.repeat(np.cumsum(per_particle) - per_particle, per_particle)
    index = [None] * len(axes)
    for k in reversed(range(len(axes))):  # last axis varies fastest
        c = counts[k][particle]
        index[k] = lo[k][particle] + local % c
        local = local // c
    return particle, tuple(index)


def _cell_edges(nodes: np.ndarray) -> np.ndarray:
    """Edges of the cells around grid nodes: midpoints, ends extended by half a spacing."""
    mid = 0.5 * (nodes[1:] + nodes[:-1])
    return np.concatenate([[nodes[0] - (mid[0] - nodes[0])], mid, [nodes[-1] + (nodes[-1] - mid[-1])]])


class Gaussian:
    """Truncated Gaussian kernel evaluated at the nodes of a grid.

    The three-dimensional kernel around particle centre :math:`\\mathbf{x}_i` is

    .. math::

        g(\\mathbf{r}) = \\frac{1}{Z} \\exp\\left(-\\frac{|\\mathbf{r} - \\mathbf{x}_i|^2}
        {2 w^2}\\right) \\Theta(c - |\\mathbf{r} - \\mathbf{x}_i|),

    with width :math:`w` and cutoff :math:`c`; :math:`Z` normalises the *truncated*
    kernel so that it integrates to one. It is resolved in the coordinate system:

    ``x``
        integrated over the box's :math:`y` and :math:`z`, a 1D Gaussian per unit
        cross-section :math:`A = L_y L_z`,

        .. math::

            w_{in} = \\frac{\\exp(-(x_n - x_i)^2 / 2w^2)}
            {\\sqrt{2\\pi}\\, w\\, \\mathrm{erf}(c/\\sqrt{2}w)\\, A}
            \\Theta(c - |x_n - x_i|);

    ``rz``
        averaged over the azimuth around the axis (axisymmetric density per unit
        volume at :math:`(r_n, z_n)`),

        .. math::

            w_{in} = \\frac{1}{\\pi} \\int_0^{\\theta_c} g\\big(d(\\phi)\\big)\\,\\mathrm{d}\\phi,
            \\quad d^2 = (r_n - r_i)^2 + (z_n - z_i)^2 + 4 r_n r_i \\sin^2(\\phi/2),

        with :math:`Z = (2\\pi w^2)^{3/2}[\\mathrm{erf}(c/\\sqrt2 w) -
        \\sqrt{2/\\pi}\\,(c/w)\\,e^{-c^2/2w^2}]` and :math:`\\theta_c` the arc where
        :math:`d < c`, integrated by Gauss-Legendre quadrature. Then
        :math:`\\int w_{in}\\, 2\\pi r\\, \\mathrm{d}r\\, \\mathrm{d}z = 1`.

    The normalisation is that of the continuous kernel: a sum of weight times
    node volume over the nodes equals one up to the grid's quadrature error,
    and particles within :math:`c` of the end of the grid or of a wall lose the
    part of their kernel outside (no boundary correction).

    :meth:`deposit` on ``rz`` coordinates with equally spaced nodes runs the
    compiled deposit of :mod:`postproc.cg_compiled` (the same weights to ~1e-8
    of a particle's weight sum, tabulated once per kernel on first use); any
    other case, or ``method="numpy"``, uses :func:`deposit_by_assignment`.

    Parameters
    ----------
    width : float
        Standard deviation :math:`w` of the Gaussian, length units.
    cutoff : float
        Truncation radius :math:`c`, length units (typically :math:`3w`).
    nodes : array_like or sequence of array_like
        Grid axes: one increasing array per coordinate (``x`` nodes; or ``r`` and
        ``z`` nodes).

    Attributes
    ----------
    paper_w : float or None
        The width :math:`w` of the paper's convention when built by :meth:`paper`
        (for labels), else None.
    """

    def __init__(self, width: float, cutoff: float, nodes):
        if width <= 0 or cutoff <= 0:
            raise ValueError("Gaussian width and cutoff must be positive")
        self.width = float(width)
        self.cutoff = float(cutoff)
        self.nodes = _as_axes(nodes)
        self.shape = tuple(len(a) for a in self.nodes)
        self.paper_w: float | None = None
        self._rz_tables = None  # built on the first compiled rz deposit

    @classmethod
    def paper(cls, w: float, nodes) -> "Gaussian":
        """The coarse-graining function of Rubio-Largo et al. (2016), section 2.1.

        .. math::

            \\phi(\\mathbf{R}) = A_w\\, e^{-(|\\mathbf{R}|/2w)^2}\\, \\Theta(4w - |\\mathbf{R}|)

        is a Gaussian of standard deviation :math:`\\sigma = \\sqrt2\\, w` truncated at
        :math:`c = 4w` (:math:`A_w` is our normalisation :math:`1/Z`).

        Parameters
        ----------
        w : float
            The paper's coarse-graining width, length units (e.g. :math:`2 r_b`).
        nodes : array_like or sequence of array_like
            Grid axes, as for the constructor.
        """
        kernel = cls(width=np.sqrt(2.0) * w, cutoff=4.0 * w, nodes=nodes)
        kernel.paper_w = float(w)
        return kernel

    @property
    def normalisation(self) -> float:
        """:math:`Z`, the integral of the truncated 3D Gaussian, volume units.

        .. math::

            Z = (2\\pi w^2)^{3/2}\\left[\\mathrm{erf}(s) - \\tfrac{2s}{\\sqrt\\pi}e^{-s^2}\\right],
            \\quad s = c / \\sqrt2 w
        """
        s = self.cutoff / (np.sqrt(2.0) * self.width)
        return (2.0 * np.pi * self.width**2) ** 1.5 * (erf(s) - 2.0 * s / np.sqrt(np.pi) * np.exp(-(s**2)))

    @property
    def n_nodes(self) -> int:
        return int(np.prod(self.shape))

    def node_columns(self, coordinates) -> dict[str, np.ndarray]:
        """Node position ``<c>`` for each coordinate ``c``."""
        _check_dimension(coordinates, len(self.nodes))
        return dict(zip(coordinates.names, _grid_columns(coordinates.names, self.nodes)))

    def node_volumes(self, coordinates, box) -> np.ndarray:
        """Volumes of the grid cells around the nodes (between midpoints)."""
        _check_dimension(coordinates, len(self.nodes))
        edges = tuple(_cell_edges(a) for a in self.nodes)
        return np.asarray(coordinates.cell_volumes(edges, box), dtype=float).ravel()

    def assign(self, points, coordinates, box) -> Assignment:
        """Weights of every particle at every node within the cutoff."""
        points = np.asarray(points, dtype=float).reshape(len(points), -1)
        _check_dimension(coordinates, len(self.nodes))
        if coordinates.kind == "x":
            return self._assign_x(points, coordinates.transverse_area(box))
        if coordinates.kind == "rz":
            return self._assign_rz(points)
        raise ValueError(f"Gaussian kernel supports coordinates 'x' and 'rz', not {coordinates.kind!r}")

    def deposit(self, points, values, coordinates, box, groups=None, n_groups: int = 1,
                method: str = "auto", n_threads: int | None = None) -> np.ndarray:
        """Kernel-weighted densities per group, shape (n_groups, n_nodes, K).

        Parameters
        ----------
        points, values, coordinates, box, groups, n_groups
            As for :func:`deposit_by_assignment`.
        method : {"auto", "compiled", "numpy"}
            ``auto`` takes the compiled path for ``rz`` coordinates on equally
            spaced nodes, else numpy; ``compiled`` insists on it.
        n_threads : int, optional
            Threads of the compiled path (default: all numba threads).
        """
        if method not in ("auto", "compiled", "numpy"):
            raise ValueError(f"method must be 'auto', 'compiled' or 'numpy', not {method!r}")
        if method != "numpy" and self._compiled_rz(coordinates):
            return self._deposit_rz_compiled(points, values, groups, n_groups, n_threads)
        if method == "compiled":
            raise ValueError("the compiled deposit needs rz coordinates and equally spaced r and z nodes")
        return deposit_by_assignment(self, points, values, coordinates, box, groups, n_groups)

    def _compiled_rz(self, coordinates) -> bool:
        if coordinates.kind != "rz" or len(self.nodes) != 2:
            return False
        from . import cg_compiled  # numba is imported only where it is used

        return all(cg_compiled.uniform_axis(a) is not None for a in self.nodes)

    @property
    def rz_tables(self):
        """Interpolation tables of the compiled ``rz`` deposit (:class:`postproc.cg_compiled.RZTables`).

        Built on first use for :math:`C = c^2/2w^2`; they cover every
        :math:`a = r_n r_i / w^2`, so they do not depend on the grid.
        """
        from . import cg_compiled

        if self._rz_tables is None:
            self._rz_tables = cg_compiled.RZTables.build(self.cutoff**2 / (2.0 * self.width**2))
        return self._rz_tables

    def _deposit_rz_compiled(self, points, values, groups, n_groups, n_threads) -> np.ndarray:
        from . import cg_compiled

        points = np.asarray(points, dtype=float).reshape(len(points), -1)
        if points.shape[1] != 2:
            raise ValueError(f"rz points must have 2 columns (r, z), got {points.shape[1]}")
        groups = _check_groups(groups, len(points), n_groups)
        if groups is None:
            groups = np.zeros(len(points), dtype=np.int64)
        return cg_compiled.deposit_rz(
            points, values, groups, n_groups, self.nodes[0], self.nodes[1], self.width, self.cutoff,
            1.0 / (np.pi * self.normalisation), self.rz_tables, n_threads=n_threads,
        )

    def _assign_x(self, points, area: float) -> Assignment:
        w, c = self.width, self.cutoff
        particle, (i,) = _candidate_pairs(points, self.nodes, c)
        dx = self.nodes[0][i] - points[particle, 0]
        keep = np.abs(dx) < c
        norm = np.sqrt(2.0 * np.pi) * w * erf(c / (np.sqrt(2.0) * w)) * area
        weight = np.exp(-0.5 * (dx[keep] / w) ** 2) / norm
        return Assignment(particle=particle[keep], node=i[keep], weight=weight)

    def _assign_rz(self, points) -> Assignment:
        w, c = self.width, self.cutoff
        particle, (ir, iz) = _candidate_pairs(points, self.nodes, c)
        r_node, r_p = self.nodes[0][ir], points[particle, 0]
        planar = (r_node - r_p) ** 2 + (self.nodes[1][iz] - points[particle, 1]) ** 2
        keep = planar < c**2
        particle, ir, iz = particle[keep], ir[keep], iz[keep]
        planar, rr = planar[keep], (r_node * r_p)[keep]
        # d^2 = planar + 2 r r_p (1 - cos phi) < c^2  <=>  phi < theta_c
        cos_c = 1.0 - np.divide(c**2 - planar, 2.0 * rr, out=np.full_like(rr, np.inf), where=rr > 0)
        theta_c = np.arccos(np.clip(cos_c, -1.0, 1.0))
        t, tw = np.polynomial.legendre.leggauss(AZIMUTHAL_QUADRATURE_POINTS)
        integral = np.zeros_like(planar)
        for tk, wk in zip(t, tw):  # loop over quadrature points, vectorised over pairs
            phi = 0.5 * theta_c * (tk + 1.0)
            d2 = planar + 4.0 * rr * np.sin(0.5 * phi) ** 2
            integral += wk * np.exp(-0.5 * d2 / w**2)
        integral *= 0.5 * theta_c
        weight = integral / (np.pi * self.normalisation)
        node = np.ravel_multi_index((ir, iz), self.shape)
        return Assignment(particle=particle, node=node, weight=weight)
