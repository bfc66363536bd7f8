"""Coordinate systems that coarse-grained fields are resolved in.

One of three independent choices of a coarse-graining (with the kernel,
:mod:`postproc.kernels`, and the fields, :mod:`postproc.fields`). A coordinate
system maps a :class:`~postproc.frame.ParticleFrame` to the particles' positions
in its space and measures volumes there; the dimensions it does not resolve are
integrated over.

=============================  ============  ============  =====================
class                          ``kind``      ``names``     resolves
=============================  ============  ============  =====================
:class:`CartesianCoordinates`  cartesian     e.g. x z      any of x, y, z
:class:`XCoordinates`          cartesian     one axis      one Cartesian axis
:class:`RCoordinates`          r             r             distance from an axis
:class:`RZCoordinates`         rz            r z           distance and height
=============================  ============  ============  =====================

Every coordinate system offers

``kind``
    ``"cartesian"``, ``"r"`` or ``"rz"``, which kernels dispatch on;
``cartesian``
    True for the Cartesian systems (lab-frame vector components);
``names``
    coordinate names, used as node columns of result tables;
``points(frame)``, ``map(positions)``
    particle (or any point's) coordinates, shape ``(N, len(names))``;
``cell_volumes(edges, box)``
    volumes of the product cells between edges (one array per coordinate),
    shape ``tuple(len(e) - 1 for e in edges)``;
``components``
    names of the three vector components fields are expressed in
    (``x y z``, or ``r t z`` for the cylindrical basis);
``local_vectors(positions, vectors)``, ``local_tensors(positions, tensors)``
    vectors ``(N, 3)`` and symmetric tensors ``(N, 6)``, in the order
    xx yy zz xy xz yz, expressed in that basis at each position.
"""
from __future__ import annotations

from typing import Sequence

import numpy as np

from .frame import ParticleFrame

_AXES = ("x", "y", "z")


def _box_lengths(box) -> np.ndarray:
    box = np.asarray(box, dtype=float)
    return box[:, 1] - box[:, 0]


class CartesianCoordinates:
    """Cartesian fields: resolve some of the axes x, y, z, integrate over the others.

    ``axes`` is a non-empty ordered subset of ``"xyz"`` without repeats, e.g.
    ``"x"`` (profiles across a channel), ``"z"`` (profiles in height), ``"xz"``
    (maps in a vertical plane, averaged over :math:`y`) or ``"xyz"``. With
    :math:`R` the resolved axes and :math:`U` the others, the volume of a
    product cell :math:`\\prod_{a \\in R} [a_\\mathrm{lo}, a_\\mathrm{hi})` is

    .. math::

        V = \\prod_{a \\in R} (a_\\mathrm{hi} - a_\\mathrm{lo})\\; A, \\qquad
        A = \\prod_{a \\in U} L_a ,

    with :math:`L_a` the frame's box lengths (:meth:`transverse_area`;
    :math:`A = 1` when all three axes are resolved). Vectors and tensors keep
    their lab-frame components ``x y z``.

    Parameters
    ----------
    axes : str
        The resolved axes in order, e.g. ``"x"`` or ``"xz"``; their names are the
        node columns of result tables, and points have one column per axis in
        this order.
    walls : optional
        Wall positions bounding the resolved axes, e.g. ``(0, W)`` for one axis
        (the extent that channel bins are built on,
        :func:`postproc.kernels.channel_bin_edges`), or one increasing pair per
        axis (or None) for several. Informative only: nothing is clipped to them.

    Attributes
    ----------
    indices : tuple of int
        Indices (0, 1, 2 for x, y, z) of the resolved axes, in order.
    """

    kind = "cartesian"
    cartesian = True
    components = _AXES

    def __init__(self, axes: str = "x", walls=None):
        if (not isinstance(axes, str) or not axes or len(set(axes)) != len(axes)
                or any(a not in _AXES for a in axes)):
            raise ValueError(f"axes {axes!r} must be a non-empty ordered subset of 'xyz' without repeats")
        self.names = tuple(axes)
        self.indices = tuple(_AXES.index(a) for a in axes)
        self.walls = self._check_walls(walls)

    def _check_walls(self, walls):
        if walls is None:
            return None
        if len(self.indices) == 1 and np.ndim(walls) == 1:
            return self._pair(walls)
        if len(walls) != len(self.indices):
            raise ValueError(f"walls {walls!r}: need one pair (or None) per axis of {''.join(self.names)!r}")
        return tuple(None if w is None else self._pair(w) for w in walls)

    @staticmethod
    def _pair(walls) -> tuple[float, float]:
        walls = (float(walls[0]), float(walls[1]))
        if walls[1] <= walls[0]:
            raise ValueError(f"walls {walls} must be increasing")
        return walls

    def points(self, frame: ParticleFrame) -> np.ndarray:
        """Particle coordinates along the resolved axes, shape (N, d).

        Parameters
        ----------
        frame : ParticleFrame
            Its ``position``, shape (N, 3), in the dump's length unit.

        Returns
        -------
        ndarray, shape (N, d)
            Same unit; d = ``len(names)``.
        """
        return self.map(frame.position)

    def map(self, positions) -> np.ndarray:
        """The resolved coordinates of positions ``(N, 3)``, shape (N, d).

        Parameters
        ----------
        positions : array_like, shape (N, 3)
            Points, any length unit (the dump's).

        Returns
        -------
        ndarray, shape (N, d)
            The columns of the resolved axes, in their order; same unit.
        """
        pos = np.asarray(positions, dtype=float).reshape(-1, 3)
        if len(self.indices) == 1:
            return pos[:, self.indices[0] : self.indices[0] + 1]
        return pos[:, list(self.indices)]

    @staticmethod
    def local_vectors(positions, vectors) -> np.ndarray:
        """Cartesian components unchanged (the basis is the lab frame everywhere).

        Parameters
        ----------
        positions : array_like, shape (N, 3)
            Unused (the basis does not depend on position).
        vectors : array_like, shape (N, 3)
            Any vectors (velocities, spins), any unit.

        Returns
        -------
        ndarray, shape (N, 3)
            ``vectors`` as a float array.
        """
        return np.asarray(vectors, dtype=float)

    @staticmethod
    def local_tensors(positions, tensors) -> np.ndarray:
        """Cartesian components unchanged.

        Parameters
        ----------
        positions : array_like, shape (N, 3)
            Unused.
        tensors : array_like, shape (N, 6)
            Symmetric tensors, xx yy zz xy xz yz, any unit.

        Returns
        -------
        ndarray, shape (N, 6)
            ``tensors`` as a float array.
        """
        return np.asarray(tensors, dtype=float)

    def transverse_area(self, box) -> float:
        """:math:`A = \\prod_{a \\notin R} L_a`, the box measure of the unresolved axes.

        An area for one resolved axis (:math:`L_y L_z` for x), a length for two,
        1.0 for three (then ``box`` may be None).

        Parameters
        ----------
        box : array_like, shape (3, 2) or None
            Lower and upper box bounds per axis, the dump's length unit.

        Returns
        -------
        float
            In that unit to the power ``3 - d``.
        """
        if len(self.indices) == 3:
            return 1.0
        lengths = _box_lengths(box)
        return float(np.prod([lengths[k] for k in range(3) if k not in self.indices]))

    def cell_volumes(self, edges: Sequence[np.ndarray], box) -> np.ndarray:
        """Cell volumes :math:`\\prod_{a \\in R} \\Delta a \\; A`, shape (n_1, ..., n_d).

        Parameters
        ----------
        edges : sequence of ndarray
            Increasing cell edges, one array per resolved axis in order, the dump's
            length unit.
        box : array_like, shape (3, 2) or None
            Box bounds for :meth:`transverse_area`, same unit.

        Returns
        -------
        ndarray, shape (n_1, ..., n_d)
            Volumes in that unit cubed (:math:`n_k` = ``len(edges[k]) - 1``).

        Raises
        ------
        ValueError
            If there is not one edge array per resolved axis.
        """
        if len(edges) != len(self.indices):
            raise ValueError(f"{len(edges)} edge arrays for {len(self.indices)} axes {''.join(self.names)!r}")
        widths = [np.diff(np.asarray(e, dtype=float)) for e in edges]
        product = widths[0]
        for w in widths[1:]:
            product = np.multiply.outer(product, w)
        return product * self.transverse_area(box)


class XCoordinates(CartesianCoordinates):
    """Profiles along one Cartesian axis: resolve it, integrate over the other two.

    :class:`CartesianCoordinates` with one axis. By default the axis is
    :math:`x` (across a channel); ``axis="z"`` gives profiles in height (e.g.
    across a flowing layer). The volume of a slab
    :math:`[x_\\mathrm{lo}, x_\\mathrm{hi})` is

    .. math::

        V = (x_\\mathrm{hi} - x_\\mathrm{lo})\\, L_y L_z

    with :math:`L_y, L_z` the frame's box lengths along the two other axes.

    Parameters
    ----------
    walls : (float, float), optional
        Wall positions bounding the axis, e.g. ``(0, W)``; the extent that
        channel bins are built on (:func:`postproc.kernels.channel_bin_edges`).
    axis : {"x", "y", "z"}
        The resolved axis (its name is the node column of result tables).

    Attributes
    ----------
    axis : int
        Index of the resolved axis (0, 1, 2 for x, y, z).
    """

    def __init__(self, walls: tuple[float, float] | None = None, axis: str = "x"):
        if axis not in _AXES:
            raise ValueError(f"axis {axis!r} is not one of {', '.join(_AXES)}")
        super().__init__(axes=axis, walls=walls)
        self.axis = _AXES.index(axis)


class _Cylindrical:
    """Distance :math:`r` from a vertical axis through :math:`(x_0, y_0)` and the cylindrical basis.

    Vectors and tensors are expressed in the cylindrical basis at each point's
    own azimuth :math:`\\theta = \\operatorname{atan2}(y - y_0, x - x_0)`,

    .. math::

        \\mathbf e_r = (\\cos\\theta, \\sin\\theta, 0), \\quad
        \\mathbf e_\\theta = (-\\sin\\theta, \\cos\\theta, 0), \\quad
        \\mathbf e_z = (0, 0, 1),

    components ``r t z`` (``t`` for :math:`\\theta`); on the axis itself
    (:math:`r = 0`) :math:`\\theta = 0` is taken.
    """

    cartesian = False
    components = ("r", "t", "z")

    def __init__(self, axis_center: tuple[float, float] = (0.0, 0.0)):
        self.axis_center = (float(axis_center[0]), float(axis_center[1]))

    def points(self, frame: ParticleFrame) -> np.ndarray:
        """Particle coordinates, shape (N, len(names)).

        Parameters
        ----------
        frame : ParticleFrame
            Its ``position``, shape (N, 3), in the dump's length unit.

        Returns
        -------
        ndarray, shape (N, len(names))
            :math:`r` (and :math:`z`), same unit.
        """
        return self.map(frame.position)

    def radius(self, positions) -> np.ndarray:
        """:math:`r = \\sqrt{(x - x_0)^2 + (y - y_0)^2}` of positions ``(N, 3)``, shape (N,).

        Parameters
        ----------
        positions : array_like, shape (N, 3)
            Points, any length unit (that of the axis centre).

        Returns
        -------
        ndarray, shape (N,)
            Same unit.
        """
        pos = np.asarray(positions, dtype=float).reshape(-1, 3)
        dx, dy = pos[:, 0] - self.axis_center[0], pos[:, 1] - self.axis_center[1]
        return np.sqrt(dx * dx + dy * dy)  # np.hypot guards overflow we cannot meet, at 5x the cost

    def azimuth(self, positions) -> tuple[np.ndarray, np.ndarray]:
        """:math:`(\\cos\\theta, \\sin\\theta)` of positions ``(N, 3)``; (1, 0) on the axis.

        Parameters
        ----------
        positions : array_like, shape (N, 3)
            Points, the unit of the axis centre.

        Returns
        -------
        cos, sin : ndarray, shape (N,)
        """
        pos = np.asarray(positions, dtype=float).reshape(-1, 3)
        dx, dy = pos[:, 0] - self.axis_center[0], pos[:, 1] - self.axis_center[1]
        r = np.sqrt(dx * dx + dy * dy)
        with np.errstate(invalid="ignore", divide="ignore"):
            cos, sin = dx / r, dy / r
        on_axis = r == 0
        if on_axis.any():
            cos[on_axis], sin[on_axis] = 1.0, 0.0
        return cos, sin

    def local_vectors(self, positions, vectors) -> np.ndarray:
        """Components :math:`(v_r, v_\\theta, v_z)`, shape (N, 3).

        Parameters
        ----------
        positions : array_like, shape (N, 3)
            Where each vector is, the unit of the axis centre (only the azimuth matters).
        vectors : array_like, shape (N, 3)
            Cartesian vectors (velocities, spins), any unit.

        Returns
        -------
        ndarray, shape (N, 3)
            Same unit.
        """
        c, s = self.azimuth(positions)
        v = np.asarray(vectors, dtype=float)
        out = np.empty_like(v)
        out[:, 0] = c * v[:, 0] + s * v[:, 1]
        out[:, 1] = c * v[:, 1] - s * v[:, 0]
        out[:, 2] = v[:, 2]
        return out

    def local_tensors(self, positions, tensors) -> np.ndarray:
        """Symmetric tensors rotated to :math:`(r, \\theta, z)`: rr tt zz rt rz tz, shape (N, 6).

        .. math::

            T' = R\\, T R^{\\mathsf T}, \\qquad R = (\\mathbf e_r, \\mathbf e_\\theta, \\mathbf e_z)^{\\mathsf T}

        Parameters
        ----------
        positions : array_like, shape (N, 3)
            Where each tensor is, the unit of the axis centre (only the azimuth matters).
        tensors : array_like, shape (N, 6)
            Cartesian symmetric tensors, xx yy zz xy xz yz, any unit.

        Returns
        -------
        ndarray, shape (N, 6)
            Same unit.
        """
        c, s = self.azimuth(positions)
        t = np.asarray(tensors, dtype=float)
        xx, yy, zz, xy, xz, yz = (t[:, k] for k in range(6))
        cc, ss, cs = c * c, s * s, c * s
        return np.column_stack([
            cc * xx + ss * yy + 2.0 * cs * xy,
            ss * xx + cc * yy - 2.0 * cs * xy,
            zz,
            cs * (yy - xx) + (cc - ss) * xy,
            c * xz + s * yz,
            -s * xz + c * yz,
        ])


class RCoordinates(_Cylindrical):
    """Radial profiles: resolve the distance from a vertical axis, integrate over azimuth and height.

    .. math::

        r = \\sqrt{(x - x_0)^2 + (y - y_0)^2},

    and the volume of a cylindrical shell :math:`[r_\\mathrm{lo}, r_\\mathrm{hi})`
    through the box height :math:`L_z` is

    .. math::

        V = \\pi (r_\\mathrm{hi}^2 - r_\\mathrm{lo}^2)\\, L_z,

    with radial edges below zero clipped to the axis. Vectors and tensors are
    in the cylindrical basis at each particle's azimuth, as for
    :class:`RZCoordinates` (components ``r t z``).

    Parameters
    ----------
    axis_center : (float, float)
        :math:`(x_0, y_0)` of the vertical symmetry axis.
    """

    kind = "r"
    names = ("r",)

    def map(self, positions) -> np.ndarray:
        """:math:`r` of positions ``(N, 3)``, shape (N, 1).

        Parameters
        ----------
        positions : array_like, shape (N, 3)
            Points, the unit of the axis centre (the dump's length unit).

        Returns
        -------
        ndarray, shape (N, 1)
            Same unit.
        """
        return self.radius(positions)[:, None]

    @staticmethod
    def axial_length(box) -> float:
        """:math:`L_z`, the box height the fields are averaged over, length units.

        Parameters
        ----------
        box : array_like, shape (3, 2)
            Lower and upper box bounds per axis.

        Returns
        -------
        float
        """
        return float(_box_lengths(box)[2])

    def cell_volumes(self, edges: Sequence[np.ndarray], box) -> np.ndarray:
        """Shell volumes :math:`\\pi\\,\\Delta(r^2)\\, L_z`, shape (n_r,).

        Parameters
        ----------
        edges : sequence of one ndarray
            Increasing radial edges, the dump's length unit.
        box : array_like, shape (3, 2)
            Box bounds (for :math:`L_z`), same unit.

        Returns
        -------
        ndarray, shape (n_r,)
            Volumes in that unit cubed.
        """
        (r_edges,) = edges
        r_edges = np.clip(np.asarray(r_edges, dtype=float), 0.0, None)
        return np.pi * np.diff(r_edges**2) * self.axial_length(box)


class RZCoordinates(_Cylindrical):
    """Axisymmetric fields: resolve radius and height, integrate over the azimuth.

    .. math::

        r = \\sqrt{(x - x_0)^2 + (y - y_0)^2}, \\qquad z = z,

    and the volume of a ring cell :math:`[r_\\mathrm{lo}, r_\\mathrm{hi}) \\times
    [z_\\mathrm{lo}, z_\\mathrm{hi})` is

    .. math::

        V = \\pi (r_\\mathrm{hi}^2 - r_\\mathrm{lo}^2)(z_\\mathrm{hi} - z_\\mathrm{lo}),

    with radial edges below zero clipped to the axis.

    Vectors and tensors are expressed in the cylindrical basis at each point's
    own azimuth, components ``r t z`` (``_Cylindrical`` above gives the basis;
    :math:`\\theta = 0` on the axis). A coarse-grained field then
    averages each particle's components in its own basis: exact for the
    :math:`z` components and for traces (pressures), and, since a kernel of
    width :math:`w` mixes azimuths within :math:`\\sim w / r` of each other, accurate
    to :math:`O(w/r)` for the other components near the axis.

    Parameters
    ----------
    axis_center : (float, float)
        :math:`(x_0, y_0)` of the vertical symmetry axis.
    """

    kind = "rz"
    names = ("r", "z")

    def map(self, positions) -> np.ndarray:
        """:math:`(r, z)` of positions ``(N, 3)``, shape (N, 2).

        Parameters
        ----------
        positions : array_like, shape (N, 3)
            Points, the unit of the axis centre (the dump's length unit).

        Returns
        -------
        ndarray, shape (N, 2)
            Same unit.
        """
        pos = np.asarray(positions, dtype=float).reshape(-1, 3)
        return np.column_stack([self.radius(pos), pos[:, 2]])

    def cell_volumes(self, edges: Sequence[np.ndarray], box=None) -> np.ndarray:
        """Ring volumes :math:`\\pi\\,\\Delta(r^2)\\,\\Delta z`, shape (n_r, n_z).

        Parameters
        ----------
        edges : sequence of two ndarray
            Increasing edges in :math:`r` and in :math:`z`, the dump's length unit.
        box : optional
            Unused (accepted for the common signature).

        Returns
        -------
        ndarray, shape (n_r, n_z)
            Volumes in that unit cubed.
        """
        r_edges, z_edges = (np.asarray(e, dtype=float) for e in edges)
        r_edges = np.clip(r_edges, 0.0, None)
        return np.outer(np.pi * np.diff(r_edges**2), np.diff(z_edges))
