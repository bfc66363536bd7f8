"""Coordinate systems that coarse-grained fields are resolved in.

One of three independent choices of a coarse-graining (with the kernel,
:mod:`postproc.kernels`, and the fields, :mod:`postproc.fields`). A coordinate
system maps a :class:`~postproc.frame.ParticleFrame` to the particles' positions
in its space and measures volumes there; the dimensions it does not resolve are
integrated over.

Every coordinate system offers

``kind``
    ``"x"`` or ``"rz"``, which kernels dispatch on;
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


class XCoordinates:
    """Profiles along one Cartesian axis: resolve it, integrate over the other two.

    By default the axis is :math:`x` (across a channel); ``axis="z"`` gives
    profiles in height (e.g. across a flowing layer). The volume of a slab
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
    """

    kind = "x"
    components = ("x", "y", "z")

    def __init__(self, walls: tuple[float, float] | None = None, axis: str = "x"):
        if axis not in _AXES:
            raise ValueError(f"axis {axis!r} is not one of {', '.join(_AXES)}")
        if walls is not None:
            walls = (float(walls[0]), float(walls[1]))
            if walls[1] <= walls[0]:
                raise ValueError(f"walls {walls} must be increasing")
        self.walls = walls
        self.axis = _AXES.index(axis)
        self.names = (axis,)

    def points(self, frame: ParticleFrame) -> np.ndarray:
        """Particle coordinate along the axis, shape (N, 1)."""
        return self.map(frame.position)

    def map(self, positions) -> np.ndarray:
        """The axis coordinate of positions ``(N, 3)``, shape (N, 1)."""
        return np.asarray(positions, dtype=float).reshape(-1, 3)[:, self.axis : self.axis + 1]

    @staticmethod
    def local_vectors(positions, vectors) -> np.ndarray:
        """Cartesian components unchanged (the basis is the lab frame everywhere)."""
        return np.asarray(vectors, dtype=float)

    @staticmethod
    def local_tensors(positions, tensors) -> np.ndarray:
        """Cartesian components unchanged."""
        return np.asarray(tensors, dtype=float)

    def transverse_area(self, box) -> float:
        """Cross-section of the box normal to the axis (:math:`L_y L_z` for x), area units."""
        box = np.asarray(box, dtype=float)
        lengths = box[:, 1] - box[:, 0]
        return float(np.prod([lengths[k] for k in range(3) if k != self.axis]))

    def cell_volumes(self, edges: Sequence[np.ndarray], box) -> np.ndarray:
        """Slab volumes :math:`\\Delta x\\, L_y L_z`."""
        (x_edges,) = edges
        return np.diff(np.asarray(x_edges, dtype=float)) * self.transverse_area(box)


class RZCoordinates:
    """Axisymmetric fields: resolve radius and height, integrate over the azimuth.

    .. math::

        r = \\sqrt{(x - x_0)^2 + (y - y_0)^2}, \\qquad z = z,

    and the volume of a ring cell :math:`[r_\\mathrm{lo}, r_\\mathrm{hi}) \\times
    [z_\\mathrm{lo}, z_\\mathrm{hi})` is

    .. math::

        V = \\pi (r_\\mathrm{hi}^2 - r_\\mathrm{lo}^2)(z_\\mathrm{hi} - z_\\mathrm{lo}),

    with radial edges below zero clipped to the axis.

    Vectors and tensors are expressed in the cylindrical basis at each point's
    own azimuth :math:`\\theta = \\operatorname{atan2}(y - y_0, x - x_0)`,

    .. math::

        \\mathbf e_r = (\\cos\\theta, \\sin\\theta, 0), \\quad
        \\mathbf e_\\theta = (-\\sin\\theta, \\cos\\theta, 0), \\quad
        \\mathbf e_z = (0, 0, 1),

    components ``r t z`` (``t`` for :math:`\\theta`); on the axis itself
    (:math:`r = 0`) :math:`\\theta = 0` is taken. A coarse-grained field then
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
    components = ("r", "t", "z")

    def __init__(self, axis_center: tuple[float, float] = (0.0, 0.0)):
        self.axis_center = (float(axis_center[0]), float(axis_center[1]))

    def points(self, frame: ParticleFrame) -> np.ndarray:
        """Particle :math:`(r, z)`, shape (N, 2)."""
        return self.map(frame.position)

    def map(self, positions) -> np.ndarray:
        """:math:`(r, z)` of positions ``(N, 3)``, shape (N, 2)."""
        pos = np.asarray(positions, dtype=float).reshape(-1, 3)
        r = np.hypot(pos[:, 0] - self.axis_center[0], pos[:, 1] - self.axis_center[1])
        return np.column_stack([r, pos[:, 2]])

    def azimuth(self, positions) -> tuple[np.ndarray, np.ndarray]:
        """:math:`(\\cos\\theta, \\sin\\theta)` of positions ``(N, 3)``; (1, 0) on the axis."""
        pos = np.asarray(positions, dtype=float).reshape(-1, 3)
        dx, dy = pos[:, 0] - self.axis_center[0], pos[:, 1] - self.axis_center[1]
        r = np.hypot(dx, dy)
        with np.errstate(invalid="ignore", divide="ignore"):
            cos, sin = dx / r, dy / r
        on_axis = r == 0
        if on_axis.any():
            cos[on_axis], sin[on_axis] = 1.0, 0.0
        return cos, sin

    def local_vectors(self, positions, vectors) -> np.ndarray:
        """Components :math:`(v_r, v_\\theta, v_z)`, shape (N, 3)."""
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

    def cell_volumes(self, edges: Sequence[np.ndarray], box=None) -> np.ndarray:
        """Ring volumes :math:`\\pi\\,\\Delta(r^2)\\,\\Delta z`, shape (n_r, n_z)."""
        r_edges, z_edges = (np.asarray(e, dtype=float) for e in edges)
        r_edges = np.clip(r_edges, 0.0, None)
        return np.outer(np.pi * np.diff(r_edges**2), np.diff(z_edges))
