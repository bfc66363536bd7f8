"""Kinetic stress from fluctuations about the instantaneous local mean (Rubio-Largo et al. 2016, eq. 7).

:class:`~postproc.fields.FieldAccumulator` averages primitives over frames first, so its kinetic
stress :math:`\\overline{\\sum_i w_i m_i v_i v_i} - \\rho u u` counts every departure from the
*time-averaged* node velocity: between particles in one frame, the node's mean velocity changing
from frame to frame, and (through the kernel's width) the spread of the mean flow itself across
the kernel. The paper's eq. 7 instead takes each particle's velocity relative to the local mean
velocity of the same frame at the particle's position,

.. math::

    \\sigma^k_{ab}(\\mathbf r) = \\overline{\\textstyle\\sum_i m_i v'_{i,a} v'_{i,b}\\,
    W(\\mathbf r - \\mathbf r_i)}, \\qquad
    \\mathbf v'_i = \\mathbf v_i - \\mathbf u(\\mathbf r_i, t),

with :math:`\\mathbf u(\\cdot, t) = \\mathbf p/\\rho` the frame's own coarse-grained velocity at the
nodes, interpolated (linearly) to each particle. A rigid or steady converging flow without any
particle fluctuation has :math:`\\sigma^k = 0` up to the interpolation error (second order in
the node spacing); the time-averaged form gives it :math:`\\rho\\,\\mathrm{var}_W(u)`.

:class:`FluctuationAccumulator` does the two passes per frame: a deposit of mass and momentum
(in the coordinates' local basis) for :math:`\\mathbf u(\\cdot, t)`, then an ordinary
:class:`FieldAccumulator` fed with the fluctuation velocities, whose ``sigmak``/``pk`` are then
eq. 7 (the residual :math:`\\rho \\bar u' \\bar u'` it subtracts is the square of the mean
fluctuation, zero up to interpolation error). Grids are the kernel's node axes; a particle
outside them takes the nearest node's velocity.
"""
from __future__ import annotations

import numpy as np
from scipy.interpolate import RegularGridInterpolator

from .fields import FieldAccumulator


class FluctuationAccumulator:
    """Time-averaged fields of the fluctuations about the frame's local mean velocity.

    Parameters
    ----------
    kernel : postproc.kernels.Gaussian or Lucy (a kernel on node axes)
    coordinates : CartesianCoordinates, XCoordinates or RZCoordinates
    fields : sequence of str
        Fields of :class:`~postproc.fields.FieldAccumulator` computed from the fluctuations;
        ``sigmak`` and ``pk`` are eq. 7 (``u`` is the mean fluctuation, ~0).
    n_blocks : int
    method : {"auto", "compiled", "numpy"}
    """

    def __init__(self, kernel, coordinates, fields=("sigmak", "pk"), n_blocks: int = 8, method: str = "auto"):
        self.kernel, self.coordinates, self.method = kernel, coordinates, method
        self.inner = FieldAccumulator(kernel, coordinates, fields=fields, n_blocks=n_blocks, method=method)
        self.axes = tuple(np.asarray(a, dtype=float) for a in kernel.nodes)

    def prepare(self) -> None:
        """Start a new average (the inner accumulator's :meth:`~postproc.fields.FieldAccumulator.prepare`)."""
        self.inner.prepare()

    @property
    def n_frames(self) -> int:
        """Frames accumulated since :meth:`prepare`."""
        sums = self.inner._sums
        return 0 if sums is None else sums.n_frames

    def mean_velocity(self, frame) -> tuple[np.ndarray, np.ndarray]:
        """``(u at the nodes (n_nodes, 3), u at each particle (N, 3))`` of one frame, local basis.

        Parameters
        ----------
        frame : ParticleFrame
            Positions, velocities and masses in the dump's units.

        Returns
        -------
        u_nodes : ndarray, shape (n_nodes, 3)
            :math:`\\mathbf p/\\rho` at the nodes (0 where no mass), the dump's velocity unit.
        u_at : ndarray, shape (N, 3)
            Linearly interpolated to each particle (clipped to the node axes), same unit.
        """
        c = self.coordinates
        local = frame.velocity if c.cartesian else c.local_vectors(frame.position, frame.velocity)
        points = c.points(frame)
        values = np.column_stack([frame.mass, frame.mass[:, None] * local])
        dens = self.kernel.deposit(points, values, c, frame.box, method=self.method)[0]
        mass = dens[:, 0]
        u_nodes = np.divide(dens[:, 1:], mass[:, None], out=np.zeros((len(mass), 3)), where=mass[:, None] > 0)
        grid = u_nodes.reshape(*[len(a) for a in self.axes], 3)
        pts = np.asarray(points, dtype=float).reshape(len(local), -1)
        clipped = np.column_stack([np.clip(pts[:, k], a[0], a[-1]) for k, a in enumerate(self.axes)])
        u_at = RegularGridInterpolator(self.axes, grid, method="linear", bounds_error=False)(clipped)
        return u_nodes, u_at

    def accumulate(self, frame) -> None:
        """Add one frame: its particles' velocities relative to the frame's local mean.

        Parameters
        ----------
        frame : ParticleFrame
            The frame (dump units); its velocities minus the local mean, in Cartesian
            components, go to the inner :class:`~postproc.fields.FieldAccumulator`.
        """
        from dataclasses import replace

        _, u_local = self.mean_velocity(frame)
        c = self.coordinates
        if c.cartesian:
            u_cart = u_local
        else:   # back from (r, theta, z) at each particle's azimuth to Cartesian
            cos, sin = c.azimuth(frame.position)
            u_cart = np.column_stack([cos * u_local[:, 0] - sin * u_local[:, 1],
                                      sin * u_local[:, 0] + cos * u_local[:, 1], u_local[:, 2]])
        self.inner.accumulate(replace(frame, velocity=np.asarray(frame.velocity, float) - u_cart))

    def conclude(self):
        """The inner :meth:`FieldAccumulator.conclude` table (``sigmak``/``pk`` are eq. 7's)."""
        return self.inner.conclude()
