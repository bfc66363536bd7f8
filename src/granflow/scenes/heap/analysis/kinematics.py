"""Kinematics of the heap in the frame that rotates by alpha and rises with the free surface."""
from __future__ import annotations

import numpy as np
import pandas as pd

from postproc.blocks import SUBBLOCKS_PER_BLOCK, ConcludedResult, BlockedSums, time_average_errors
from postproc.frame import ParticleFrame

from .surface import HeapGeometry, SurfaceFit, volume_pairs


# --------------------------------------------------------------------------- moving frame
class MovingFrame:
    """The paper's frame rotated by :math:`\\alpha` and rising with the free surface.

    Origin :math:`\\mathbf P(t) = (x_{feed}, \\cdot, z_s(x_{feed}, t))` on the
    fitted surface at the downstream edge of the feed zone; axes

    .. math::

        \\mathbf e_x = (\\cos\\alpha, 0, -\\sin\\alpha) \\;\\text{(downhill)}, \\qquad
        \\mathbf e_z = (\\sin\\alpha, 0, \\cos\\alpha) \\;\\text{(out of the heap)},

    and velocities relative to the surface, which moves normal to itself at
    :math:`v_r' = v_r\\cos\\alpha` (paper, section 3.1: "the z-component of the
    rise velocity in this coordinate system is :math:`v_r'`"):

    .. math::

        x = (\\mathbf r - \\mathbf P)\\cdot\\mathbf e_x, \\quad
        z = (\\mathbf r - \\mathbf P)\\cdot\\mathbf e_z, \\quad
        u = \\mathbf v\\cdot\\mathbf e_x, \\quad
        w = \\mathbf v\\cdot\\mathbf e_z - v_r' .

    The static bed is then at rest along the flow (:math:`u = 0`) and moves at
    :math:`w = -v_r'`, the boundary value of eqs. 3.5/3.6. (Subtracting the
    vertical rise :math:`v_r\\hat{\\mathbf z}` instead would give the bed a spurious
    streamwise drift :math:`v_r\\sin\\alpha`, which inflates q and hides the
    cutoff depth where :math:`u_s` is small.)

    Parameters
    ----------
    fit : SurfaceFit
    geometry : HeapGeometry
    """

    def __init__(self, fit: SurfaceFit, geometry: HeapGeometry):
        self.fit = fit
        self.geometry = geometry
        self.alpha = fit.alpha
        self.e_x = np.array([np.cos(self.alpha), 0.0, -np.sin(self.alpha)])
        self.e_z = np.array([np.sin(self.alpha), 0.0, np.cos(self.alpha)])

    @property
    def v_r(self) -> float:
        """Vertical rise velocity :math:`v_r`, m/s."""
        return self.fit.v_r

    @property
    def v_r_normal(self) -> float:
        """Rise velocity normal to the surface, :math:`v_r' = v_r\\cos\\alpha`, m/s (paper, section 3.1)."""
        return self.fit.v_r * np.cos(self.alpha)

    @property
    def L(self) -> float:
        """Length of the flowing layer along the surface, feed edge to end wall, :math:`(W - x_{feed})/\\cos\\alpha`, m."""
        return self.geometry.L_lab / np.cos(self.alpha)

    def origin(self, t):
        """Lab coordinates :math:`(x_{lab}, z_{lab})` of the origin at time ``t``."""
        x0 = self.geometry.x_feed
        return x0, self.fit.z_surface(x0, t)

    def transform(self, position, velocity, t):
        """Lab positions and velocities to :math:`(x, z, u, w)` of the moving frame.

        Parameters
        ----------
        position, velocity : array_like, shape (N, 3)
            Lab frame, m and m/s.
        t : float or array_like, shape (N,)
            Time, s.

        Returns
        -------
        x, z, u, w : ndarray, shape (N,)
        """
        position = np.asarray(position, dtype=float).reshape(-1, 3)
        velocity = np.asarray(velocity, dtype=float).reshape(-1, 3)
        x0, z0 = self.origin(t)
        rx, rz = position[:, 0] - x0, position[:, 2] - z0
        vx, vz = velocity[:, 0], velocity[:, 2]
        c, s = np.cos(self.alpha), np.sin(self.alpha)
        return rx * c - rz * s, rx * s + rz * c, vx * c - vz * s, vx * s + vz * c - self.v_r_normal

    def to_lab(self, x, z, t):
        """Moving-frame :math:`(x, z)` at time ``t`` back to lab :math:`(x_{lab}, z_{lab})`."""
        x0, z0 = self.origin(t)
        x, z = np.asarray(x, float), np.asarray(z, float)
        return x0 + x * self.e_x[0] + z * self.e_z[0], z0 + x * self.e_x[2] + z * self.e_z[2]


# --------------------------------------------------------------------------- kinematics
class KinematicsAccumulator(ConcludedResult):
    """Volume-weighted, time-averaged kinematics in (x, z) bins of the moving frame.

    Following the paper (section 3.2.1), particle :math:`j` contributes to bin
    :math:`i` its volume :math:`V_{ij}` inside the bin: the sphere is split
    exactly over the z-slabs it spans (:func:`sphere_slab_fraction`) and
    assigned in :math:`x` by its centre (``weight_axis="z"``; bins are
    :math:`\\Delta x \\gg d` long in x). Per frame only additive sums are kept,

    .. math::

        \\textstyle \\sum_j V_{ij}, \\; \\sum_j V_{ij} u_j, \\; \\sum_j V_{ij} w_j, \\;
        \\sum_j V_{ij} u_j^2, \\; \\sum_j V_{ij} w_j^2, \\; \\sum_{j \\in k} V_{ij}, \\;
        N_i, \\; \\sum_{j} d_j ,

    (the last two over particles whose centres are in the bin), and after
    averaging over :math:`n_f` frames (overbars)

    .. math::

        u_i = \\frac{\\overline{\\sum_j V_{ij} u_j}}{\\overline{\\sum_j V_{ij}}}, \\quad
        \\phi_i = \\frac{\\overline{\\sum_j V_{ij}}}{\\Delta x\\, T\\, \\Delta z}, \\quad
        \\phi_{k,i} = \\frac{\\overline{\\sum_{j \\in k} V_{ij}}}{\\Delta x\\, T\\, \\Delta z},

    .. math::

        u_{std,i}^2 = \\frac{\\overline{\\sum_j V_{ij} u_j^2}}{\\overline{\\sum_j V_{ij}}} - u_i^2, \\quad
        \\bar d_i = \\frac{\\overline{\\sum d_j}}{\\overline{N_i}} .

    As in :mod:`postproc.fields`, :math:`u_{std}` counts fluctuations of the
    bin's mean between frames as well as between particles. Standard errors
    ``u_se``, ``w_se`` allow for the correlation of consecutive frames, as in
    :mod:`postproc.fields` (:func:`postproc.blocks.time_average_errors`): the
    error of the time average of the velocity's series over sub-blocks of
    frames with its statistical inefficiency :math:`g`; while :math:`g` is not
    reliable (fewer than :math:`50\\,g` sub-blocks) at least the block error
    :math:`\\mathrm{std}_{ddof=1}(u_{block})/\\sqrt{n_{blocks}}` over ``n_blocks``
    contiguous blocks (:func:`postproc.autocorr.combined_error`).

    Parameters
    ----------
    x_edges, z_edges : array_like
        Increasing bin edges of the moving frame, m (``x`` from 0 to :math:`L`,
        ``z`` from some depth below the surface to a little above it).
    T : float
        Gap, m (bins span it).
    n_types : int
        Particle types 1..n_types get a ``phi_k`` column.
    n_blocks : int
        Blocks of the block error, at least 2 (the floor of ``u_se``, ``w_se``
        while the autocorrelation estimate is not reliable).
    """

    def __init__(self, x_edges, z_edges, T: float, n_types: int = 1, n_blocks: int = 8):
        self.x_edges = np.asarray(x_edges, dtype=float)
        self.z_edges = np.asarray(z_edges, dtype=float)
        for e in (self.x_edges, self.z_edges):
            if e.ndim != 1 or e.size < 2 or np.any(np.diff(e) <= 0):
                raise ValueError("bin edges need at least two strictly increasing values")
        if not T > 0:
            raise ValueError(f"gap T must be positive, got {T}")
        if int(n_types) < 1 or int(n_blocks) < 2:
            raise ValueError("need n_types >= 1 and n_blocks >= 2")
        self.T = float(T)
        self.n_types = int(n_types)
        self.n_blocks = int(n_blocks)
        self.shape = (len(self.x_edges) - 1, len(self.z_edges) - 1)
        self.bin_volume = (np.outer(np.diff(self.x_edges), np.diff(self.z_edges)) * self.T).ravel()
        self._sums: BlockedSums | None = None
        self._result: pd.DataFrame | None = None

    # columns of the per-frame sums
    _V, _VU, _VW, _VUU, _VWW, _N, _ND = range(7)

    def prepare(self) -> None:
        """Start a new average (discarding any previous one)."""
        self._sums = BlockedSums(SUBBLOCKS_PER_BLOCK * self.n_blocks)
        self._result = None

    def accumulate(self, x, z, u, w, radius, type=None, *, weight_axis: str | None = "z") -> None:
        """Add one frame of particles given in the moving frame.

        Parameters
        ----------
        x, z, u, w : array_like, shape (N,)
            From :meth:`MovingFrame.transform`.
        radius : array_like, shape (N,)
        type : array_like of int, shape (N,), optional
            Particle types 1..n_types; all type 1 when omitted.
        weight_axis : {"z", "x", None}
            Axis along which spheres are split exactly over bins (the other
            is assigned by the centre); None assigns whole particles by centre.
        """
        if self._sums is None:
            raise RuntimeError("KinematicsAccumulator.accumulate() called before prepare()")
        if self._result is not None:
            raise RuntimeError("KinematicsAccumulator already concluded; call prepare() to start anew")
        x, z, u, w, radius = (np.asarray(a, dtype=float).ravel() for a in (x, z, u, w, radius))
        kind = np.ones(len(x), dtype=int) if type is None else np.asarray(type).astype(int).ravel()
        if len(kind) and (kind.min() < 1 or kind.max() > self.n_types):
            raise ValueError(f"particle types {np.unique(kind)} outside 1..{self.n_types}")
        if weight_axis not in ("z", "x", None):
            raise ValueError(f"weight_axis must be 'z', 'x' or None, got {weight_axis!r}")
        split = {"z": "b", "x": "a", None: None}[weight_axis]
        p, flat, vol = volume_pairs(x, z, radius, self.x_edges, self.z_edges, split)
        n_bins = self.bin_volume.size
        per_pair = [vol, vol * u[p], vol * w[p], vol * u[p] ** 2, vol * w[p] ** 2]
        sums = [np.bincount(flat, weights=q, minlength=n_bins) for q in per_pair]
        cp, cflat, _ = volume_pairs(x, z, radius, self.x_edges, self.z_edges, None)
        sums.append(np.bincount(cflat, minlength=n_bins).astype(float))
        sums.append(np.bincount(cflat, weights=2.0 * radius[cp], minlength=n_bins))
        for k in range(1, self.n_types + 1):
            sums.append(np.bincount(flat, weights=vol * (kind[p] == k), minlength=n_bins))
        self._sums.add(np.column_stack(sums))

    def _derive(self, mean: np.ndarray) -> dict[str, np.ndarray]:
        V = mean[:, self._V]

        def ratio(num, den):
            return np.divide(num, den, out=np.full(len(den), np.nan), where=den > 0)

        u, w = ratio(mean[:, self._VU], V), ratio(mean[:, self._VW], V)
        out = {
            "phi": V / self.bin_volume, "u": u, "w": w,
            "u_std": np.sqrt(np.maximum(ratio(mean[:, self._VUU], V) - u**2, 0.0)),
            "w_std": np.sqrt(np.maximum(ratio(mean[:, self._VWW], V) - w**2, 0.0)),
            "n": mean[:, self._N], "d_mean": ratio(mean[:, self._ND], mean[:, self._N]),
        }
        for k in range(1, self.n_types + 1):
            out[f"phi_{k}"] = mean[:, self._ND + k] / self.bin_volume
        return out

    def conclude(self) -> pd.DataFrame:
        """Derive the time-averaged profile.

        Returns
        -------
        DataFrame
            One row per (x, z) bin, z fastest: ``x, z`` (centres), ``x_lo,
            x_hi, z_lo, z_hi``, ``phi, u, w, u_std, w_std, u_se, w_se, n,
            d_mean, phi_1 .. phi_<n_types>``; velocities NaN in bins that never
            held particle volume, ``n`` the mean number of centres per frame.
        """
        if self._sums is None:
            raise RuntimeError("KinematicsAccumulator.conclude() called before prepare()")
        if self._sums.n_frames == 0:
            raise RuntimeError("KinematicsAccumulator.conclude() called before any frame was accumulated")
        values = self._derive(self._sums.total_mean())
        errors, _ = time_average_errors(self._sums, self._derive, ("u", "w"), self.n_blocks)
        se = {f"{name}_se": errors[name] for name in ("u", "w")}
        xc = 0.5 * (self.x_edges[1:] + self.x_edges[:-1])
        zc = 0.5 * (self.z_edges[1:] + self.z_edges[:-1])
        grid = [g.ravel() for g in np.meshgrid(xc, zc, indexing="ij")]
        lo = [g.ravel() for g in np.meshgrid(self.x_edges[:-1], self.z_edges[:-1], indexing="ij")]
        hi = [g.ravel() for g in np.meshgrid(self.x_edges[1:], self.z_edges[1:], indexing="ij")]
        columns = {"x": grid[0], "z": grid[1], "x_lo": lo[0], "x_hi": hi[0], "z_lo": lo[1], "z_hi": hi[1]}
        order = ["phi", "u", "w", "u_std", "w_std", "u_se", "w_se", "n", "d_mean"]
        values.update(se)
        columns.update({k: values[k] for k in order})
        columns.update({f"phi_{k}": values[f"phi_{k}"] for k in range(1, self.n_types + 1)})
        self._result = pd.DataFrame(columns)
        return self._result



def accumulate_frame(accumulator: KinematicsAccumulator, frame: ParticleFrame, moving: MovingFrame,
                     dt: float, weight_axis: str | None = "z") -> None:
    """Transform one :class:`~postproc.frame.ParticleFrame` (time ``timestep * dt``) and accumulate it."""
    x, z, u, w = moving.transform(frame.position, frame.velocity, frame.timestep * dt)
    accumulator.accumulate(x, z, u, w, frame.radius, frame.type, weight_axis=weight_axis)


# --------------------------------------------------------------------------- one profile
def finite_profile(z, u, z_max: float | None = None):
    """Finite points of a profile sorted by z, optionally only :math:`z \\le z_{max}`.

    Parameters
    ----------
    z : array_like, shape (n,)
        Depth of each point, m (relative to the free surface: :math:`z = 0` on it, negative below).
    u : array_like, shape (n,)
        The profile's value at each point (e.g. a velocity, m/s).
    z_max : float, optional
        Keep only points at or below this depth, m; None keeps all.

    Returns
    -------
    z, u : ndarray of float, shape (m,)
        The points where both are finite (and ``z <= z_max``), in increasing z (a stable sort).
    """
    z, u = np.asarray(z, dtype=float).ravel(), np.asarray(u, dtype=float).ravel()
    ok = np.isfinite(z) & np.isfinite(u)
    if z_max is not None:
        ok &= z <= z_max
    order = np.argsort(z[ok], kind="stable")
    return z[ok][order], u[ok][order]


def surface_tolerance(z) -> float:
    """Round-off allowance for 'z <= 0' on bin centres.

    Parameters
    ----------
    z : array_like
        Bin centres' depths relative to the free surface, m (any shape).

    Returns
    -------
    float
        :math:`10^{-9}` times the largest finite :math:`|z|`, m (:math:`10^{-9}` when none is finite):
        a centre at or below this counts as at or below the surface.
    """
    z = np.asarray(z, dtype=float)
    scale = np.nanmax(np.abs(z)) if np.isfinite(z).any() else 1.0
    return 1e-9 * scale


def surface_velocity(z, u) -> float:
    """Surface velocity :math:`u_s = u(z = 0)`, linearly interpolated.

    Between the finite points bracketing :math:`z = 0`; when no point lies
    above the surface, extrapolated from the two highest points provided the
    highest is within one spacing of the surface; NaN otherwise.
    """
    z, u = finite_profile(z, u)
    if len(z) == 0:
        return float("nan")
    if z[0] <= 0.0 <= z[-1]:
        return float(np.interp(0.0, z, u))
    if z[-1] < 0 and len(z) >= 2 and -z[-1] <= z[-1] - z[-2]:
        return float(u[-1] + (u[-1] - u[-2]) * (0.0 - z[-1]) / (z[-1] - z[-2]))
    return float("nan")
