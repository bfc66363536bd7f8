"""The radial kernels: :class:`RadialKernel`, truncated at a cutoff, and its :class:`Gaussian` (and Lucy's, kernels_lucy.py).

Each is resolved in every coordinate system of :mod:`postproc.coordinates`
(Cartesian with any resolved axes, ``r`` and ``rz`` through an azimuthal
integral), by :func:`~postproc.kernels_common.deposit_by_assignment` or, for the
Gaussian on ``rz``, by the compiled deposit of :mod:`postproc.cg_compiled`.
:mod:`postproc.kernels` (the kernel interface, Heaviside bins) re-exports them.
"""
from __future__ import annotations

from typing import Sequence

import numpy as np
from scipy.special import erf

from .kernels_common import Assignment, as_axes, check_dimension, check_groups, deposit_by_assignment, grid_columns

#: Gauss-Legendre points for the azimuthal integral of the ``r`` and ``rz``
#: radial kernels. For the Gaussian, over the truncated arc the exponent varies
#: by at most ``cutoff**2 / (2 width**2)``, a smooth (entire) integrand, for which
#: 24 points reach round-off; Lucy's polynomial is smooth on the arc too (it
#: vanishes with two continuous derivatives at its end).
AZIMUTHAL_QUADRATURE_POINTS = 24


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


def _azimuthal_integral(profile, planar: np.ndarray, rr: np.ndarray, cutoff: float) -> np.ndarray:
    """:math:`\\int_0^{\\theta_c} f\\big(d^2(\\varphi)\\big)\\,\\mathrm d\\varphi` over the arc inside the cutoff.

    For a particle at distance :math:`r_i` from the axis and a node ring of
    radius :math:`r_n`, :math:`d^2(\\varphi) = p^2 + 4 r_n r_i \\sin^2(\\varphi/2)`
    with ``planar`` :math:`= p^2` (the squared distance at equal azimuth) and
    ``rr`` :math:`= r_n r_i`; :math:`\\theta_c` is where :math:`d = c`
    (:math:`\\pi` when the whole ring is inside). Gauss-Legendre with
    :data:`AZIMUTHAL_QUADRATURE_POINTS` points, vectorised over pairs.
    """
    c = cutoff
    # d^2 = planar + 2 r r_p (1 - cos phi) < c^2  <=>  phi < theta_c
    cos_c = 1.0 - np.divide(c**2 - planar, 2.0 * rr, out=np.full_like(rr, np.inf), where=rr > 0)
    theta_c = np.arccos(np.clip(cos_c, -1.0, 1.0))
    t, tw = np.polynomial.legendre.leggauss(AZIMUTHAL_QUADRATURE_POINTS)
    integral = np.zeros_like(planar)
    for tk, wk in zip(t, tw):  # loop over quadrature points, vectorised over pairs
        phi = 0.5 * theta_c * (tk + 1.0)
        d2 = planar + 4.0 * rr * np.sin(0.5 * phi) ** 2
        integral += wk * profile(d2)
    integral *= 0.5 * theta_c
    return integral


class RadialKernel:
    """A radially symmetric kernel truncated at a cutoff, evaluated at the nodes of a grid.

    The base of :class:`Gaussian` and :class:`~postproc.kernels_lucy.Lucy`. A subclass gives the
    unnormalised radial profile :math:`f(d)`, :math:`d = |\\mathbf r - \\mathbf x_i|`,
    zero for :math:`d \\ge c` (:meth:`profile`, a function of :math:`d^2`), and its
    integral over :math:`D`-dimensional space (:meth:`normalisation_in`),

    .. math::

        Z_D = \\int_{\\mathbb R^D} f(|\\mathbf s|)\\,\\mathrm d^D s
            = \\frac{2 \\pi^{D/2}}{\\Gamma(D/2)} \\int_0^c f(d)\\, d^{D-1}\\,\\mathrm dd .

    The weights, units 1/volume, in each coordinate system
    (:mod:`postproc.coordinates`):

    Cartesian, :math:`D` resolved axes
        the :math:`D`-dimensional kernel per unit measure :math:`A` of the
        unresolved axes (``transverse_area``),

        .. math::

            w_{in} = \\frac{f(|\\mathbf x_n - \\mathbf x_i|)}{Z_D\\, A},

        with :math:`\\mathbf x` the resolved coordinates only: the 3D kernel
        integrated over the unresolved axes is not used, so that every
        coordinate choice smooths over the same distance :math:`c`;

    ``rz``
        the 3D kernel averaged over the azimuth around the axis (axisymmetric
        density per unit volume at :math:`(r_n, z_n)`),

        .. math::

            w_{in} = \\frac{1}{\\pi Z_3} \\int_0^{\\theta_c} f\\big(d(\\varphi)\\big)\\,\\mathrm{d}\\varphi,
            \\quad d^2 = (r_n - r_i)^2 + (z_n - z_i)^2 + 4 r_n r_i \\sin^2(\\varphi/2),

        with :math:`\\theta_c` the arc where :math:`d < c`, integrated by
        Gauss-Legendre quadrature (:data:`AZIMUTHAL_QUADRATURE_POINTS`); then
        :math:`\\int w_{in}\\, 2\\pi r\\, \\mathrm{d}r\\, \\mathrm{d}z = 1`;

    ``r``
        the 2D kernel in the horizontal plane averaged over the azimuth, per unit
        box height :math:`L_z`,

        .. math::

            w_{in} = \\frac{1}{\\pi Z_2 L_z} \\int_0^{\\theta_c} f\\big(d(\\varphi)\\big)\\,\\mathrm{d}\\varphi,
            \\quad d^2 = (r_n - r_i)^2 + 4 r_n r_i \\sin^2(\\varphi/2),

        so that :math:`\\int w_{in}\\, 2\\pi r\\, \\mathrm dr\\, L_z = 1`.

    The normalisation is that of the continuous kernel: a sum of weight times
    node volume over the nodes equals one up to the grid's quadrature error,
    and particles within :math:`c` of the end of the grid or of a wall lose the
    part of their kernel outside (no boundary correction).

    Parameters
    ----------
    cutoff : float
        Truncation radius :math:`c`, length units.
    nodes : array_like or sequence of array_like
        Grid axes: one increasing array per coordinate (e.g. ``x`` nodes, or
        ``x`` and ``z`` nodes, or ``r`` and ``z`` nodes).

    Attributes
    ----------
    width : float
        The kernel's standard deviation along one axis (of the 3D kernel), the
        length scale the contact-stress branch quadrature must resolve.
    """

    width: float

    def __init__(self, cutoff: float, nodes):
        if not cutoff > 0:
            raise ValueError(f"kernel cutoff must be positive, not {cutoff}")
        self.cutoff = float(cutoff)
        self.nodes = as_axes(nodes)
        self.shape = tuple(len(a) for a in self.nodes)

    def profile(self, d2) -> np.ndarray:
        """Unnormalised radial profile :math:`f` at squared distances ``d2`` (below :math:`c^2`).

        Parameters
        ----------
        d2 : ndarray
            Squared distances from the particle centre, in the cutoff's unit squared.

        Returns
        -------
        ndarray
            Dimensionless, the shape of ``d2``.

        Raises
        ------
        NotImplementedError
            In this base class (the subclasses define it).
        """
        raise NotImplementedError

    def normalisation_in(self, dim: int) -> float:
        """:math:`Z_D`, the integral of :math:`f` over :math:`D`-dimensional space (D = 1, 2, 3).

        Parameters
        ----------
        dim : int
            D, the dimension of the space integrated over.

        Returns
        -------
        float
            In the cutoff's unit to the power D.

        Raises
        ------
        NotImplementedError
            In this base class (the subclasses define it).
        """
        raise NotImplementedError

    @property
    def normalisation(self) -> float:
        """:math:`Z_3`, the integral of the truncated 3D kernel, volume units."""
        return self.normalisation_in(3)

    @property
    def n_nodes(self) -> int:
        """Number of nodes, the product of the node counts along each coordinate."""
        return int(np.prod(self.shape))

    def node_columns(self, coordinates) -> dict[str, np.ndarray]:
        """Node position ``<c>`` for each coordinate ``c``.

        Parameters
        ----------
        coordinates : CartesianCoordinates, RCoordinates or RZCoordinates
            Gives the column names; one per axis of the grid.

        Returns
        -------
        dict of str to ndarray, shape (n_nodes,)
            In the unit of the nodes (the dump's length unit), nodes in C order.

        Raises
        ------
        ValueError
            If the coordinates resolve another number of axes than the grid has.
        """
        check_dimension(coordinates, len(self.nodes))
        return dict(zip(coordinates.names, grid_columns(coordinates.names, self.nodes)))

    def node_volumes(self, coordinates, box) -> np.ndarray:
        """Volumes of the grid cells around the nodes (between midpoints).

        The cells extend half a spacing beyond the first and last nodes.

        Parameters
        ----------
        coordinates : CartesianCoordinates, RCoordinates or RZCoordinates
        box : array_like, shape (3, 2)
            Box bounds of the frame, the unit of the nodes (the measure of the
            unresolved axes).

        Returns
        -------
        ndarray, shape (n_nodes,)
            That unit cubed.

        Raises
        ------
        ValueError
            If the coordinates resolve another number of axes than the grid has.
        """
        check_dimension(coordinates, len(self.nodes))
        edges = tuple(_cell_edges(a) for a in self.nodes)
        return np.asarray(coordinates.cell_volumes(edges, box), dtype=float).ravel()

    def assign(self, points, coordinates, box) -> Assignment:
        """Weights of every particle at every node within the cutoff.

        Parameters
        ----------
        points : array_like, shape (N, ndim)
            Particle coordinates in the space of ``coordinates``, the unit of the nodes
            and the cutoff.
        coordinates : CartesianCoordinates, RCoordinates or RZCoordinates
        box : array_like, shape (3, 2)
            Box bounds of the frame, same unit.

        Returns
        -------
        Assignment
            Weights in 1/volume (:class:`RadialKernel` gives them per coordinate system).

        Raises
        ------
        ValueError
            If the coordinates resolve another number of axes than the grid has, or
            are of an unknown kind.
        """
        points = np.asarray(points, dtype=float).reshape(len(points), -1)
        check_dimension(coordinates, len(self.nodes))
        if coordinates.kind == "cartesian":
            return self._assign_cartesian(points, coordinates.transverse_area(box))
        if coordinates.kind == "rz":
            return self._assign_rz(points)
        if coordinates.kind == "r":
            return self._assign_r(points, coordinates.axial_length(box))
        raise ValueError(f"{type(self).__name__} kernel supports coordinates 'cartesian', 'r' and 'rz', "
                         f"not {coordinates.kind!r}")

    def deposit(self, points, values, coordinates, box, groups=None, n_groups: int = 1,
                method: str = "auto", n_threads: int | None = None) -> np.ndarray:
        """Kernel-weighted densities per group, shape (n_groups, n_nodes, K).

        :func:`deposit_by_assignment` (``method`` "auto" or "numpy";
        "compiled" is refused: only :class:`Gaussian` on ``rz`` has a compiled path).

        Parameters
        ----------
        points, values, coordinates, box, groups, n_groups
            As for :func:`deposit_by_assignment`.
        method : {"auto", "compiled", "numpy"}
        n_threads : int, optional
            Unused (accepted for the signature of :meth:`Gaussian.deposit`).

        Returns
        -------
        ndarray, shape (n_groups, n_nodes, K)
            Densities: the unit of ``values`` per volume.

        Raises
        ------
        ValueError
            For ``method="compiled"`` or an unknown method, or groups or coordinates
            that do not fit.
        """
        if method not in ("auto", "compiled", "numpy"):
            raise ValueError(f"method must be 'auto', 'compiled' or 'numpy', not {method!r}")
        if method == "compiled":
            raise ValueError(f"{type(self).__name__} kernel has no compiled deposit")
        return deposit_by_assignment(self, points, values, coordinates, box, groups, n_groups)

    def _assign_cartesian(self, points, area: float) -> Assignment:
        c = self.cutoff
        particle, index = _candidate_pairs(points, self.nodes, c)
        d2 = np.zeros(particle.size)
        for k, i in enumerate(index):
            d2 += (self.nodes[k][i] - points[particle, k]) ** 2
        keep = d2 < c**2
        index = tuple(i[keep] for i in index)
        norm = self.normalisation_in(len(self.nodes)) * area
        weight = self.profile(d2[keep]) / norm
        node = index[0] if len(index) == 1 else np.ravel_multi_index(index, self.shape)
        return Assignment(particle=particle[keep], node=node, weight=weight)

    def _assign_r(self, points, length: float) -> Assignment:
        c = self.cutoff
        particle, (ir,) = _candidate_pairs(points, self.nodes, c)
        r_node, r_p = self.nodes[0][ir], points[particle, 0]
        planar = (r_node - r_p) ** 2
        keep = planar < c**2
        particle, ir, planar, rr = particle[keep], ir[keep], planar[keep], (r_node * r_p)[keep]
        integral = _azimuthal_integral(self.profile, planar, rr, c)
        weight = integral / (np.pi * self.normalisation_in(2) * length)
        return Assignment(particle=particle, node=ir, weight=weight)

    def _assign_rz(self, points) -> Assignment:
        c = self.cutoff
        particle, (ir, iz) = _candidate_pairs(points, self.nodes, c)
        r_node, r_p = self.nodes[0][ir], points[particle, 0]
        planar = (r_node - r_p) ** 2 + (self.nodes[1][iz] - points[particle, 1]) ** 2
        keep = planar < c**2
        particle, ir, iz = particle[keep], ir[keep], iz[keep]
        planar, rr = planar[keep], (r_node * r_p)[keep]
        integral = _azimuthal_integral(self.profile, planar, rr, c)
        weight = integral / (np.pi * self.normalisation_in(3))
        node = np.ravel_multi_index((ir, iz), self.shape)
        return Assignment(particle=particle, node=node, weight=weight)


class Gaussian(RadialKernel):
    """Truncated Gaussian kernel evaluated at the nodes of a grid.

    The kernel around particle centre :math:`\\mathbf{x}_i` is

    .. math::

        g(\\mathbf{r}) = \\frac{1}{Z_D} \\exp\\left(-\\frac{|\\mathbf{r} - \\mathbf{x}_i|^2}
        {2 w^2}\\right) \\Theta(c - |\\mathbf{r} - \\mathbf{x}_i|),

    with width (standard deviation) :math:`w` and cutoff :math:`c`; :math:`Z_D`
    normalises the *truncated* kernel in :math:`D` dimensions,

    .. math::

        Z_D = (2\\pi w^2)^{D/2}\\, P\\!\\left(\\tfrac D2, \\tfrac{c^2}{2w^2}\\right),

    with :math:`P` the regularised lower incomplete gamma function
    (:func:`scipy.special.gammainc`), in closed form
    :math:`P(\\tfrac12, x) = \\mathrm{erf}\\sqrt x`, :math:`P(1, x) = 1 - e^{-x}`,
    :math:`P(\\tfrac32, x) = \\mathrm{erf}\\sqrt x - 2\\sqrt{x/\\pi}\\, e^{-x}`.
    How it is resolved in each coordinate system is described in
    :class:`RadialKernel`; in particular on one Cartesian axis :math:`x` with
    cross-section :math:`A = L_y L_z`

    .. math::

        w_{in} = \\frac{\\exp(-(x_n - x_i)^2 / 2w^2)}
        {\\sqrt{2\\pi}\\, w\\, \\mathrm{erf}(c/\\sqrt{2}w)\\, A}
        \\Theta(c - |x_n - x_i|),

    and on ``rz`` the azimuthal average of the 3D kernel, with
    :math:`Z_3 = (2\\pi w^2)^{3/2}[\\mathrm{erf}(c/\\sqrt2 w) -
    \\sqrt{2/\\pi}\\,(c/w)\\,e^{-c^2/2w^2}]`.

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
        super().__init__(cutoff, nodes)
        self.width = float(width)
        self.paper_w: float | None = None
        self._rz_tables = None  # built on the first compiled rz deposit
        self._rz_axes = None  # (first, spacing, count) of r and z, or False: checked on first use

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

    def profile(self, d2) -> np.ndarray:
        """:math:`e^{-d^2/2w^2}`.

        Parameters
        ----------
        d2 : ndarray
            Squared distances, in the unit of ``width`` squared.

        Returns
        -------
        ndarray
            Dimensionless, the shape of ``d2``.
        """
        return np.exp(-0.5 * d2 / self.width**2)

    def normalisation_in(self, dim: int) -> float:
        """:math:`Z_D = (2\\pi w^2)^{D/2} P(D/2, c^2/2w^2)`, in closed form for D = 1, 2, 3.

        .. math::

            Z_1 = \\sqrt{2\\pi}\\, w\\, \\mathrm{erf}(s), \\quad
            Z_2 = 2\\pi w^2 (1 - e^{-s^2}), \\quad
            Z_3 = (2\\pi w^2)^{3/2}\\left[\\mathrm{erf}(s) - \\tfrac{2s}{\\sqrt\\pi}e^{-s^2}\\right],
            \\quad s = c / \\sqrt2 w

        Parameters
        ----------
        dim : int
            D: 1, 2 or 3.

        Returns
        -------
        float
            In the unit of ``width`` to the power D.

        Raises
        ------
        ValueError
            For another ``dim``.
        """
        w, c = self.width, self.cutoff
        s = c / (np.sqrt(2.0) * w)
        if dim == 1:
            return np.sqrt(2.0 * np.pi) * w * erf(s)
        if dim == 2:
            return 2.0 * np.pi * w**2 * -np.expm1(-(s**2))
        if dim == 3:
            return (2.0 * np.pi * w**2) ** 1.5 * (erf(s) - 2.0 * s / np.sqrt(np.pi) * np.exp(-(s**2)))
        raise ValueError(f"dimension must be 1, 2 or 3, not {dim}")

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

        Returns
        -------
        ndarray, shape (n_groups, n_nodes, K)
            Densities: the unit of ``values`` per volume.

        Raises
        ------
        ValueError
            For an unknown method, ``method="compiled"`` where there is no compiled
            path, ``rz`` points that are not (N, 2), or groups or coordinates that do
            not fit.
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
        if self._rz_axes is None:
            from . import cg_compiled  # numba is imported only where it is used

            axes = tuple(cg_compiled.uniform_axis(a) for a in self.nodes)
            self._rz_axes = axes if all(a is not None for a in axes) else False
        return bool(self._rz_axes)

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

        points = np.asarray(points, dtype=float)
        if points.ndim != 2 or points.shape[1] != 2:
            raise ValueError(f"rz points must have 2 columns (r, z), got shape {points.shape}")
        groups = check_groups(groups, len(points), n_groups)
        if groups is None:
            groups = np.zeros(len(points), dtype=np.int64)
        return cg_compiled.deposit_rz(
            points, values, groups, n_groups, *self._rz_axes, self.width, self.cutoff,
            1.0 / (np.pi * self.normalisation), self.rz_tables, n_threads=n_threads,
        )
