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
``points(frame)``
    particle coordinates, shape ``(N, len(names))``;
``cell_volumes(edges, box)``
    volumes of the product cells between edges (one array per coordinate),
    shape ``tuple(len(e) - 1 for e in edges)``.
"""
from __future__ import annotations

from typing import Sequence

import numpy as np

from .frame import ParticleFrame


class XCoordinates:
    """Profiles across a channel: resolve :math:`x`, integrate over :math:`y` and :math:`z`.

    The volume of a slab :math:`[x_\\mathrm{lo}, x_\\mathrm{hi})` is

    .. math::

        V = (x_\\mathrm{hi} - x_\\mathrm{lo})\\, L_y L_z

    with :math:`L_y, L_z` the frame's box lengths.

    Parameters
    ----------
    walls : (float, float), optional
        Wall positions bounding :math:`x`, e.g. ``(0, W)``; the extent that
        channel bins are built on (:func:`postproc.kernels.channel_bin_edges`).
    """

    kind = "x"
    names = ("x",)

    def __init__(self, walls: tuple[float, float] | None = None):
        if walls is not None:
            walls = (float(walls[0]), float(walls[1]))
            if walls[1] <= walls[0]:
                raise ValueError(f"walls {walls} must be increasing")
        self.walls = walls

    def points(self, frame: ParticleFrame) -> np.ndarray:
        """Particle :math:`x`, shape (N, 1)."""
        return np.asarray(frame.position, dtype=float)[:, :1]

    @staticmethod
    def transverse_area(box) -> float:
        """Cross-section :math:`A = L_y L_z` of the box, area units."""
        box = np.asarray(box, dtype=float)
        return float((box[1, 1] - box[1, 0]) * (box[2, 1] - box[2, 0]))

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

    Parameters
    ----------
    axis_center : (float, float)
        :math:`(x_0, y_0)` of the vertical symmetry axis.
    """

    kind = "rz"
    names = ("r", "z")

    def __init__(self, axis_center: tuple[float, float] = (0.0, 0.0)):
        self.axis_center = (float(axis_center[0]), float(axis_center[1]))

    def points(self, frame: ParticleFrame) -> np.ndarray:
        """Particle :math:`(r, z)`, shape (N, 2)."""
        pos = np.asarray(frame.position, dtype=float)
        r = np.hypot(pos[:, 0] - self.axis_center[0], pos[:, 1] - self.axis_center[1])
        return np.column_stack([r, pos[:, 2]])

    def cell_volumes(self, edges: Sequence[np.ndarray], box=None) -> np.ndarray:
        """Ring volumes :math:`\\pi\\,\\Delta(r^2)\\,\\Delta z`, shape (n_r, n_z)."""
        r_edges, z_edges = (np.asarray(e, dtype=float) for e in edges)
        r_edges = np.clip(r_edges, 0.0, None)
        return np.outer(np.pi * np.diff(r_edges**2), np.diff(z_edges))
