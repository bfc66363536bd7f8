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

Kernels: :class:`HeavisideBins` (top-hat bins on the particle centres) and the
radial kernels :class:`Gaussian` and :class:`Lucy` (:class:`RadialKernel`), each
in every coordinate system of :mod:`postproc.coordinates`: Cartesian with any
resolved axes (``x``, ``xz``, ``xyz``, ...), ``r`` and ``rz``.

Multi-dimensional nodes are numbered in C order (last coordinate fastest).
"""
from __future__ import annotations

import numpy as np

from .kernels_common import (DEPOSIT_CHUNK, Assignment, as_axes, check_dimension,  # noqa: F401 (re-exported)
                             deposit_by_assignment, grid_columns)
from .kernels_lucy import Lucy  # noqa: F401 (re-exported)
from .kernels_radial import AZIMUTHAL_QUADRATURE_POINTS, Gaussian, RadialKernel  # noqa: F401 (re-exported)


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
        Target interior bin width :math:`d`, same unit.
    wall_bin_width : float
        Width of each wall bin, same unit.

    Returns
    -------
    ndarray, shape (n + 3,)
        Increasing edges from ``walls[0]`` to ``walls[1]``, same unit.

    Raises
    ------
    ValueError
        If a bin width is not positive, or the two wall bins fill the channel.
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


class HeavisideBins:
    """Top-hat bins on the particle centres (MercuryCG's Heaviside function).

    A particle belongs to the bin containing its centre, with weight

    .. math::

        w_{in} = \\frac{1}{V_n}\\, \\Theta(\\mathbf{x}_i \\in \\text{bin } n),

    so :math:`\\sum_n w_{in} V_n = 1` exactly. :math:`V_n` is the coordinate
    system's cell volume (``cell_volumes``): in Cartesian coordinates the product
    of the bin widths along the resolved axes times the box measure of the
    others, a cylindrical shell for ``r``, a ring for ``rz``. Bins are half-open
    :math:`[e_k, e_{k+1})`, except that the last edge is included; particles
    outside all bins are dropped.

    Parameters
    ----------
    edges : array_like or sequence of array_like
        Bin edges, one increasing array per coordinate (a single array for 1D).
    """

    def __init__(self, edges):
        self.edges = as_axes(edges)
        self.shape = tuple(len(e) - 1 for e in self.edges)

    @property
    def n_nodes(self) -> int:
        """Number of bins, the product of the bin counts along each coordinate."""
        return int(np.prod(self.shape))

    def node_columns(self, coordinates) -> dict[str, np.ndarray]:
        """Bin centre ``<c>`` and bounds ``<c>_lo``, ``<c>_hi`` for each coordinate ``c``.

        Parameters
        ----------
        coordinates : CartesianCoordinates, RCoordinates or RZCoordinates
            Gives the column names; one per axis of the bins.

        Returns
        -------
        dict of str to ndarray, shape (n_nodes,)
            In the unit of the edges (the dump's length unit), bins in C order.

        Raises
        ------
        ValueError
            If the coordinates resolve another number of axes than the bins have.
        """
        check_dimension(coordinates, len(self.edges))
        centres = grid_columns(coordinates.names, [0.5 * (e[1:] + e[:-1]) for e in self.edges])
        lows = grid_columns(coordinates.names, [e[:-1] for e in self.edges])
        highs = grid_columns(coordinates.names, [e[1:] for e in self.edges])
        columns = {}
        for name, c, lo, hi in zip(coordinates.names, centres, lows, highs):
            columns.update({name: c, f"{name}_lo": lo, f"{name}_hi": hi})
        return columns

    def node_volumes(self, coordinates, box) -> np.ndarray:
        """Bin volumes :math:`V_n` from the coordinate system's cell measure.

        Parameters
        ----------
        coordinates : CartesianCoordinates, RCoordinates or RZCoordinates
        box : array_like, shape (3, 2)
            Box bounds of the frame, the dump's length unit (the measure of the
            unresolved axes).

        Returns
        -------
        ndarray, shape (n_nodes,)
            That unit cubed.

        Raises
        ------
        ValueError
            If the coordinates resolve another number of axes than the bins have.
        """
        check_dimension(coordinates, len(self.edges))
        return np.asarray(coordinates.cell_volumes(self.edges, box), dtype=float).ravel()

    def assign(self, points, coordinates, box) -> Assignment:
        """Assign each particle centre to its bin with weight :math:`1/V_n`.

        Parameters
        ----------
        points : array_like, shape (N, ndim)
            Particle coordinates in the space of ``coordinates``, the unit of the edges.
        coordinates : CartesianCoordinates, RCoordinates or RZCoordinates
        box : array_like, shape (3, 2)
            Box bounds of the frame, same unit.

        Returns
        -------
        Assignment
            One pair per particle inside the bins; weights in 1/volume.

        Raises
        ------
        ValueError
            If the coordinates resolve another number of axes than the bins have.
        """
        points = np.asarray(points, dtype=float).reshape(len(points), -1)
        check_dimension(coordinates, len(self.edges))
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

        Parameters
        ----------
        points, values, coordinates, box, groups, n_groups
            As for :func:`deposit_by_assignment`.
        method : str
            Any value but ``"compiled"`` (refused) gives the numpy deposit.

        Returns
        -------
        ndarray, shape (n_groups, n_nodes, K)
            Densities: the unit of ``values`` per volume.

        Raises
        ------
        ValueError
            For ``method="compiled"``, or groups or coordinates that do not fit.
        """
        if method == "compiled":
            raise ValueError("Heaviside bins have no compiled deposit")
        return deposit_by_assignment(self, points, values, coordinates, box, groups, n_groups)
