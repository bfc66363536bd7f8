"""Scene analyses for the quasi-2D bounded heap (Fan, Umbanhowar, Ottino & Lueptow 2013).

The analysis follows the paper's sections 2-3 in order:

1. lab-frame volume fraction in columns :math:`\\Delta x \\times T \\times \\Delta z`
   (:func:`volume_fraction_columns`) and the free surface where :math:`\\phi`
   reaches :math:`\\phi_c = 0.35` (:func:`free_surface`);
2. a plane :math:`z_s = z_0 - x_{lab}\\tan\\alpha + v_r t` fitted to the free
   surface over time: dynamic angle of repose :math:`\\alpha` and rise velocity
   :math:`v_r` (:func:`fit_surface`);
3. the frame rotated by :math:`\\alpha` and moving up with the surface
   (:class:`MovingFrame`), in which volume-weighted velocity profiles are
   accumulated (:class:`KinematicsAccumulator`);
4. per streamwise position: surface velocity, flow rate, flowing-layer
   thickness by the paper's three methods, mean shear rate, eq. (3.1), and the
   scalings of figures 7-11 (:func:`analyse_heap`, :func:`collapse`);
5. the concentration of small particles in the deposit, figure 3
   (:func:`deposit_concentration`).

Conventions
-----------
* SI units throughout; the time of a frame is ``timestep * dt``.
* Lab frame: :math:`x_{lab}` horizontal and streamwise, the feed-side wall at
  :math:`x_{lab} = 0` and the end wall at :math:`x_{lab} = W`; :math:`y` across
  the gap, :math:`0 \\le y \\le T`; :math:`z_{lab}` vertical, up. The base
  descends from left to right at :math:`\\theta`; the feed zone is
  :math:`0 \\le x_{lab} \\le x_{feed}`.
* Moving frame (paper, section 2.1): :math:`x` downhill along the free surface
  from the downstream edge of the feed zone, :math:`z` normal to the surface,
  :math:`z = 0` on it and :math:`z < 0` in the heap; velocities
  :math:`(u, w)` relative to the rising surface.
* Species: type 1 is "small" (the only species of a monodisperse run), type 2
  "large".
* Profiles (:class:`KinematicsAccumulator` output, the input of
  :func:`analyse_heap`) have one row per (x, z) bin, C order (z fastest).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Iterable, NamedTuple

import numpy as np
import pandas as pd
from scipy.optimize import curve_fit

from .fields import _SUBBLOCKS_PER_BLOCK, ConcludedResult, _BlockedSums
from .frame import ParticleFrame

#: Volume-fraction cutoff of the free surface, :math:`f_c` (paper, section 3.1).
PHI_C = 0.35
#: :math:`\delta = 2.3\,z_0` for the exponential-fit method (paper, section 3.2.2).
EXPONENTIAL_DEPTH_FACTOR = 2.3
#: Points with :math:`u > 0.01\,u_s` enter the exponential fit.
EXPONENTIAL_FIT_MIN_FRACTION = 0.01
#: The "approximately linear part" of the profile, :math:`0.2 \le u/u_s \le 0.8`.
LINEAR_RANGE = (0.2, 0.8)
#: Cutoff :math:`u_c = 0.1\,u_s` locating the bottom of the flowing layer.
CUTOFF_FRACTION = 0.1
#: :math:`k = \delta/z_0` of the exponential streamwise profile in eq. (3.6).
K_EXPONENTIAL = 2.3
#: Range of :math:`z/\delta` of the exponential tail fit (paper, figure 7b).
TAIL_RANGE = (-1.6, -0.7)
#: Fewest bins with a velocity inside the flowing layer for a usable profile.
MIN_LAYER_POINTS = 3
#: Range of :math:`x/L` over which mean thicknesses are reported (away from
#: the feed zone, where particles bounce, and from the end wall).
DELTA_MEAN_RANGE = (0.2, 0.9)
#: Figure 11 uses :math:`x/L \ge 0.2`.
Q_STAR_MIN_X_OVER_L = 0.2

#: Keys of the scalar dict returned by :func:`analyse_heap`.
SCALAR_KEYS = (
    "alpha_deg", "alpha_se", "v_r", "v_r_se", "v_r_normal", "surface_z0",
    "v_r_predicted", "mass_balance_residual", "L", "phi_bed",
    "delta_mean", "delta_over_d", "delta_exp_mean", "delta_lin_mean", "delta_cut_mean",
    "tail_A", "tail_A_se", "tail_k", "tail_k_se",
    "q_star_exponent", "q_star_exponent_se", "q_star_prefactor",
    "q0", "q0_rise", "n_usable", "notes",
)


# --------------------------------------------------------------------------- geometry
@dataclass(frozen=True)
class HeapGeometry:
    """Lab-frame geometry of the quasi-2D bounded heap (paper, figure 2).

    Attributes
    ----------
    W : float
        Horizontal width from the feed-side wall to the end wall, m.
    T : float
        Gap between the flat side walls, m.
    theta_deg : float
        Inclination :math:`\\theta` of the base, degrees, descending from left to right.
    x_feed : float
        Width of the feed zone :math:`0 \\le x_{lab} \\le x_{feed}`, m.
    z_base_end : float
        Height of the base at the end wall, m.
    """

    W: float
    T: float
    theta_deg: float
    x_feed: float
    z_base_end: float = 0.0

    def __post_init__(self):
        if not (self.W > 0 and self.T > 0):
            raise ValueError(f"W and T must be positive, got W = {self.W}, T = {self.T}")
        if not 0 <= self.x_feed < self.W:
            raise ValueError(f"x_feed = {self.x_feed} must lie in [0, W = {self.W})")

    def z_base(self, x_lab):
        """Height of the base, :math:`z_{base}(x_{lab}) = z_{base,end} + (W - x_{lab})\\tan\\theta`, m."""
        return self.z_base_end + (self.W - np.asarray(x_lab, dtype=float)) * np.tan(np.radians(self.theta_deg))

    @property
    def L_lab(self) -> float:
        """Horizontal length of the heap downstream of the feed zone, :math:`W - x_{feed}`, m."""
        return self.W - self.x_feed


def uniform_edges(lo: float, hi: float, width: float) -> np.ndarray:
    """Edges of :math:`n = \\max(1, \\mathrm{round}((hi - lo)/\\Delta))` equal bins from ``lo`` to ``hi``.

    The bins are :math:`(hi - lo)/n` wide, the closest to ``width`` that tiles
    the interval exactly.
    """
    if not width > 0 or not hi > lo:
        raise ValueError(f"need width > 0 and hi > lo, got width = {width}, [{lo}, {hi}]")
    n = max(1, int(round((hi - lo) / width)))
    return np.linspace(lo, hi, n + 1)


# --------------------------------------------------------------------------- binning
def _fraction_below(plane, c, r):
    """Fraction of a sphere (centre ``c``, radius ``r``) below the plane at ``plane``.

    With :math:`h` the signed distance of the plane from the centre, the part
    below is a cap of height :math:`r + h` and volume :math:`\\frac{\\pi}{3}(r+h)^2(2r-h)`.
    """
    with np.errstate(divide="ignore", invalid="ignore"):
        s = np.clip((plane - c) / r, -1.0, 1.0)
    s = np.where(r > 0, s, np.where(plane > c, 1.0, -1.0))  # a point particle
    return 0.25 * (1.0 + s) ** 2 * (2.0 - s)


def sphere_slab_fraction(c, r, lo, hi):
    """Exact fraction of a sphere's volume between two parallel planes.

    Along any axis, for a sphere of centre coordinate :math:`c` and radius
    :math:`r`, the volume below a plane at signed distance :math:`h` from the
    centre (:math:`|h| \\le r`) is the cap

    .. math::

        V_{below}(h) = \\frac{\\pi}{3} (r + h)^2 (2r - h),

    so the fraction between :math:`lo < hi` is
    :math:`[V_{below}(hi - c) - V_{below}(lo - c)] / \\tfrac43\\pi r^3`.

    Parameters
    ----------
    c, r, lo, hi : array_like
        Broadcast together; lengths in any consistent unit.

    Returns
    -------
    ndarray
        Fractions in :math:`[0, 1]`.
    """
    c, r, lo, hi = (np.asarray(a, dtype=float) for a in (c, r, lo, hi))
    return _fraction_below(hi, c, r) - _fraction_below(lo, c, r)


def _centre_bins(c: np.ndarray, edges: np.ndarray) -> np.ndarray:
    """Bin index of each centre in ``[e_k, e_{k+1})`` (last edge included); -1 outside."""
    n = len(edges) - 1
    i = np.searchsorted(edges, c, side="right") - 1
    i[c == edges[-1]] = n - 1
    i[(i < 0) | (i >= n)] = -1
    return i


def _slab_pairs(c: np.ndarray, r: np.ndarray, edges: np.ndarray):
    """Every (particle, slab) pair with the exact fraction of the particle in the slab.

    Returns ``particle, slab, fraction``; parts of spheres outside the edges
    are not assigned to any slab.
    """
    n = len(edges) - 1
    first = np.clip(np.searchsorted(edges, c - r, side="right") - 1, 0, n - 1)
    last = np.clip(np.searchsorted(edges, c + r, side="left") - 1, 0, n - 1)
    count = np.maximum(last - first + 1, 1)
    particle = np.repeat(np.arange(len(c)), count)
    offset = np.arange(particle.size) - np.repeat(np.cumsum(count) - count, count)
    slab = first[particle] + offset
    fraction = sphere_slab_fraction(c[particle], r[particle], edges[slab], edges[slab + 1])
    keep = fraction > 0
    return particle[keep], slab[keep], fraction[keep]


def _volume_pairs(a, b, radius, a_edges, b_edges, split: str | None):
    """Particle volumes on a 2D grid of bins (a, b).

    ``split="b"`` splits each sphere exactly over the b-slabs and assigns it
    in a by its centre; ``split="a"`` the converse; ``None`` assigns whole
    particles by their centres. Returns ``particle, flat_bin, volume``.
    """
    volume = 4.0 / 3.0 * np.pi * radius**3
    n_b = len(b_edges) - 1
    if split == "b":
        ia = _centre_bins(a, a_edges)
        p, ib, f = _slab_pairs(b, radius, b_edges)
        ia = ia[p]
    elif split == "a":
        ib = _centre_bins(b, b_edges)
        p, ia, f = _slab_pairs(a, radius, a_edges)
        ib = ib[p]
    elif split is None:
        p = np.arange(len(a))
        ia, ib, f = _centre_bins(a, a_edges), _centre_bins(b, b_edges), np.ones(len(a))
    else:
        raise ValueError(f"split axis must be one of the two grid axes or None, got {split!r}")
    inside = (ia >= 0) & (ib >= 0)
    return p[inside], ia[inside] * n_b + ib[inside], (f * volume[p])[inside]


def volume_fraction_columns(position, radius, geometry: HeapGeometry, dx: float, dz: float,
                            z_lo: float, z_hi: float):
    """Lab-frame solids volume fraction in columns of bins (paper, section 3.1).

    Bins are :math:`\\Delta x \\times T \\times \\Delta z`, the whole gap in
    :math:`y`, with :math:`x_{lab}` edges from 0 to :math:`W` and :math:`z_{lab}`
    edges from ``z_lo`` to ``z_hi`` (:func:`uniform_edges`). Each particle's
    volume is split exactly over the z-slabs it spans
    (:func:`sphere_slab_fraction`) and assigned in :math:`x` by its centre,
    which is exact in the mean and adequate because :math:`\\Delta x \\gg d`
    (10 mm against 1-3 mm in the paper); then

    .. math::

        \\phi_i = \\frac{\\sum_j V_{ij}}{\\Delta x\\, T\\, \\Delta z}.

    Volume outside ``[z_lo, z_hi]``, and particles whose centres lie outside
    :math:`[0, W]`, are not counted.

    Parameters
    ----------
    position : array_like, shape (N, 3)
        Lab-frame centres, m.
    radius : array_like, shape (N,)
        Radii, m.
    geometry : HeapGeometry
    dx, dz : float
        Target bin sizes, m.
    z_lo, z_hi : float
        Vertical range, m.

    Returns
    -------
    phi : ndarray, shape (n_x, n_z)
    x_edges, z_edges : ndarray
    """
    position = np.asarray(position, dtype=float).reshape(-1, 3)
    radius = np.asarray(radius, dtype=float)
    x_edges = uniform_edges(0.0, geometry.W, dx)
    z_edges = uniform_edges(z_lo, z_hi, dz)
    _, flat, vol = _volume_pairs(position[:, 0], position[:, 2], radius, x_edges, z_edges, "b")
    n_x, n_z = len(x_edges) - 1, len(z_edges) - 1
    total = np.bincount(flat, weights=vol, minlength=n_x * n_z).reshape(n_x, n_z)
    bin_volume = np.outer(np.diff(x_edges), np.diff(z_edges)) * geometry.T
    return total / bin_volume, x_edges, z_edges


def phi_columns_table(phi, x_edges, z_edges) -> pd.DataFrame:
    """Long table ``x_lab, z_lab, phi`` (bin centres) of :func:`volume_fraction_columns` output."""
    xc = 0.5 * (x_edges[1:] + x_edges[:-1])
    zc = 0.5 * (z_edges[1:] + z_edges[:-1])
    X, Z = np.meshgrid(xc, zc, indexing="ij")
    return pd.DataFrame({"x_lab": X.ravel(), "z_lab": Z.ravel(), "phi": np.asarray(phi, float).ravel()})


# --------------------------------------------------------------------------- free surface
def free_surface(phi, z_edges, phi_c: float = PHI_C) -> np.ndarray:
    """Free-surface height of each column, where :math:`\\phi` reaches :math:`\\phi_c`.

    Scanning down from the top, the first bin :math:`k` with
    :math:`\\phi_k \\ge \\phi_c` and the bin above it bracket the surface; it is
    interpolated linearly between their centres,

    .. math::

        z_s = z_k + (z_{k+1} - z_k)\\,\\frac{\\phi_k - \\phi_c}{\\phi_k - \\phi_{k+1}} .

    Bouncing particles above the surface stay below :math:`\\phi_c` (paper:
    :math:`f_c = 0.35`; the surface moves by less than a diameter for
    :math:`0.1 \\le f_c \\le 0.5`), so they are ignored.

    Parameters
    ----------
    phi : array_like, shape (n_x, n_z)
        Volume fraction per column, z increasing along the last axis.
    z_edges : array_like, shape (n_z + 1,)
    phi_c : float

    Returns
    -------
    ndarray, shape (n_x,)
        :math:`z_s`, m; NaN where :math:`\\phi` never reaches :math:`\\phi_c`, and
        where the top bin is already at or above it (the surface then lies
        above the range).
    """
    phi = np.nan_to_num(np.atleast_2d(np.asarray(phi, dtype=float)), nan=0.0)
    z_edges = np.asarray(z_edges, dtype=float)
    zc = 0.5 * (z_edges[1:] + z_edges[:-1])
    n_x, n_z = phi.shape
    above = phi >= phi_c
    # highest bin at or above the cutoff; -1 where none
    k = np.where(above.any(axis=1), n_z - 1 - np.argmax(above[:, ::-1], axis=1), -1)
    z_s = np.full(n_x, np.nan)
    ok = (k >= 0) & (k < n_z - 1)
    rows, kk = np.flatnonzero(ok), k[ok]
    p0, p1 = phi[rows, kk], phi[rows, kk + 1]
    z_s[rows] = zc[kk] + (zc[kk + 1] - zc[kk]) * (p0 - phi_c) / (p0 - p1)
    return z_s


def bed_volume_fraction(phi, z_edges, z_s, depth_lo: float, depth_hi: float, *,
                        z_base=None, clearance: float = 0.0) -> np.ndarray:
    """Mean volume fraction of the static bed below the free surface, per column.

    Averages :math:`\\phi` over the bins lying entirely between
    :math:`z_s - d_{hi}` and :math:`z_s - d_{lo}`, deep enough to be below the
    flowing and creeping layers (paper, figure 4a: :math:`\\phi \\approx 0.65`
    there). Bins reaching below ``z_base + clearance`` are ignored (the
    packing is looser against the base, and bins below it are empty); a
    column with no bin left is NaN. :math:`\\phi_{bed}` for
    :func:`analyse_heap` is the mean over the columns downstream of the feed zone.

    Parameters
    ----------
    phi : array_like, shape (n_x, n_z)
    z_edges : array_like, shape (n_z + 1,)
    z_s : array_like, shape (n_x,)
        Free surface per column (:func:`free_surface`), m.
    depth_lo, depth_hi : float
        Depth window below the surface, :math:`0 \\le d_{lo} < d_{hi}`, m.
    z_base : array_like, shape (n_x,), optional
        Highest base height under each column, e.g.
        ``geometry.z_base(x_edges[:-1])``; without it no bin is excluded.
    clearance : float
        Extra height above the base to exclude, m.

    Returns
    -------
    ndarray, shape (n_x,)
    """
    phi = np.atleast_2d(np.asarray(phi, dtype=float))
    z_edges = np.asarray(z_edges, dtype=float)
    z_s = np.asarray(z_s, dtype=float)[:, None]
    lo, hi = z_edges[None, :-1], z_edges[None, 1:]
    inside = (lo >= z_s - depth_hi) & (hi <= z_s - depth_lo) & np.isfinite(phi)
    if z_base is not None:
        inside &= lo >= np.asarray(z_base, dtype=float)[:, None] + clearance
    count = inside.sum(axis=1)
    total = np.where(inside, phi, 0.0).sum(axis=1)
    return np.divide(total, count, out=np.full(len(count), np.nan), where=count > 0)


def surface_history(frames: Iterable[ParticleFrame], geometry: HeapGeometry, dt: float, dx: float,
                    dz: float, z_lo: float, z_hi: float, phi_c: float = PHI_C):
    """Free surface of every frame.

    Returns
    -------
    t : ndarray, shape (n_t,)
        Frame times ``timestep * dt``, s.
    x_lab : ndarray, shape (n_x,)
        Column centres, m.
    z_s : ndarray, shape (n_t, n_x)
        :func:`free_surface` of :func:`volume_fraction_columns` per frame.
    """
    t, rows, x_edges = [], [], None
    for frame in frames:
        phi, x_edges, z_edges = volume_fraction_columns(frame.position, frame.radius, geometry,
                                                        dx, dz, z_lo, z_hi)
        t.append(frame.timestep * dt)
        rows.append(free_surface(phi, z_edges, phi_c))
    if x_edges is None:
        x_edges = uniform_edges(0.0, geometry.W, dx)
    x_lab = 0.5 * (x_edges[1:] + x_edges[:-1])
    return np.asarray(t, float), x_lab, np.asarray(rows, float).reshape(len(t), len(x_lab))


def surface_table(t, x_lab, z_s) -> pd.DataFrame:
    """Long table ``t, x_lab, z_s`` of a surface history."""
    T, X = np.meshgrid(np.asarray(t, float), np.asarray(x_lab, float), indexing="ij")
    return pd.DataFrame({"t": T.ravel(), "x_lab": X.ravel(), "z_s": np.asarray(z_s, float).ravel()})


# --------------------------------------------------------------------------- fits
def _least_squares(design: np.ndarray, y: np.ndarray):
    """Parameters and covariance :math:`s^2 (A^TA)^{-1}`, :math:`s^2 = RSS/(n-p)` (NaN if :math:`n \\le p`)."""
    n, p = design.shape
    if n < p:
        return np.full(p, np.nan), np.full((p, p), np.nan), np.nan
    params, *_ = np.linalg.lstsq(design, y, rcond=None)
    resid = y - design @ params
    s2 = float(resid @ resid / (n - p)) if n > p else np.nan
    try:
        cov = s2 * np.linalg.inv(design.T @ design)
    except np.linalg.LinAlgError:
        cov = np.full((p, p), np.nan)
    return params, cov, np.sqrt(s2)


def _row_line_fits(x, y):
    """Least-squares lines :math:`y_k = a_k + b_k x` through every row of ``y`` (NaN = missing).

    Returns ``a, b, a_se, b_se`` per row; slopes need two points with spread
    in :math:`x`, standard errors three,

    .. math:: \\mathrm{se}(b)^2 = \\frac{\\sum r^2/(n-2)}{\\sum (x - \\bar x)^2}, \\quad
              \\mathrm{se}(a)^2 = \\frac{\\sum r^2}{n-2}\\left(\\frac1n + \\frac{\\bar x^2}{\\sum (x-\\bar x)^2}\\right).
    """
    y = np.atleast_2d(np.asarray(y, dtype=float))
    x = np.broadcast_to(np.asarray(x, dtype=float), y.shape)
    m = np.isfinite(x) & np.isfinite(y)
    n = m.sum(axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        mx = np.where(m, x, 0.0).sum(axis=1) / n
        my = np.where(m, y, 0.0).sum(axis=1) / n
        dx = np.where(m, x - mx[:, None], 0.0)
        dy = np.where(m, y - my[:, None], 0.0)
        sxx = (dx**2).sum(axis=1)
        b = np.where(sxx > 0, (dx * dy).sum(axis=1) / sxx, np.nan)
        a = my - b * mx
        rss = np.where(m, (dy - b[:, None] * dx) ** 2, 0.0).sum(axis=1)
        s2 = np.where(n > 2, rss / (n - 2), np.nan)
        b_se = np.sqrt(s2 / sxx)
        a_se = np.sqrt(s2 * (1.0 / n + mx**2 / sxx))
    return a, b, a_se, b_se


def _line_fit(x, y):
    """One least-squares line (see :func:`_row_line_fits`); floats ``a, b, a_se, b_se``."""
    return tuple(float(v[0]) for v in _row_line_fits(np.asarray(x, float)[None, :], np.asarray(y, float)[None, :]))


@dataclass(frozen=True, eq=False)
class SurfaceFit:
    """The fitted free surface :math:`z_s = z_0 - x_{lab}\\tan\\alpha + v_r t` (paper, figure 4).

    Attributes
    ----------
    alpha_deg, alpha_se : float
        Dynamic angle of repose :math:`\\alpha` and its standard error, degrees.
    v_r, v_r_se : float
        Vertical rise velocity of the surface and its standard error, m/s.
    z0, z0_se : float
        Surface height at :math:`x_{lab} = 0`, :math:`t = 0`, m.
    n_points : int
        Surface points in the fit.
    residual_std : float
        Standard deviation of the plane's residuals, m (paper: below one
        small-particle diameter).
    x_range : (float, float)
        Columns with centres strictly inside were fitted.
    alpha_t : DataFrame
        ``t, alpha_deg, alpha_se``: angle of a line fitted to each frame.
    rise_by_x : DataFrame
        ``x_lab, v_r, v_r_se, in_fit``: slope of :math:`z_s(t)` in each column.
    """

    alpha_deg: float
    alpha_se: float
    v_r: float
    v_r_se: float
    z0: float
    z0_se: float = float("nan")
    n_points: int = 0
    residual_std: float = float("nan")
    x_range: tuple = (float("nan"), float("nan"))
    alpha_t: pd.DataFrame = field(default_factory=lambda: pd.DataFrame(columns=["t", "alpha_deg", "alpha_se"]))
    rise_by_x: pd.DataFrame = field(
        default_factory=lambda: pd.DataFrame(columns=["x_lab", "v_r", "v_r_se", "in_fit"]))

    @property
    def alpha(self) -> float:
        """:math:`\\alpha` in radians."""
        return float(np.radians(self.alpha_deg))

    def z_surface(self, x_lab, t):
        """Fitted surface height :math:`z_0 - x_{lab}\\tan\\alpha + v_r t`, m."""
        return self.z0 - np.asarray(x_lab, float) * np.tan(self.alpha) + self.v_r * np.asarray(t, float)


def surface_fit_range(geometry: HeapGeometry, dx: float) -> tuple[float, float]:
    """Default ``x_range`` of :func:`fit_surface`: no column touching the feed zone, not the last column.

    With column centres, ``(x_feed + dx/2, W - dx)`` keeps the columns whose
    lower edge is downstream of the feed zone and drops the column at the end
    wall, where the surface bends up against the wall.
    """
    return geometry.x_feed + 0.5 * dx, geometry.W - dx


def fit_surface(t, x_lab, z_s, x_range) -> SurfaceFit:
    """Fit the rising plane surface :math:`z_s = z_0 - x_{lab}\\tan\\alpha + v_r t`.

    One least-squares fit over all frames and the columns with
    :math:`x_{lo} < x_{lab} < x_{hi}` (exclude the feed zone and the column at
    the end wall, see :func:`surface_fit_range`); standard errors from the
    parameter covariance :math:`s^2 (A^TA)^{-1}`, and for :math:`\\alpha` by
    propagation, :math:`\\mathrm{se}(\\alpha) = \\mathrm{se}(\\tan\\alpha)/(1 + \\tan^2\\alpha)`.
    The paper fits the surface at :math:`t_0` and shifts it by :math:`v_r (t - t_0)`;
    the joint plane is the same model fitted to all the data at once.

    Also returned: :math:`\\alpha(t)` from a line per frame (paper, figure 4b
    inset) and :math:`v_r(x_{lab})` from a line through :math:`z_s(t)` per
    column (figure 4c).

    Parameters
    ----------
    t : array_like, shape (n_t,)
        Frame times, s.
    x_lab : array_like, shape (n_x,)
        Column centres, m.
    z_s : array_like, shape (n_t, n_x)
        Free surface per frame and column, NaN where unknown.
    x_range : (float, float)
        Open interval of column centres to fit.
    """
    t = np.asarray(t, dtype=float).ravel()
    x_lab = np.asarray(x_lab, dtype=float).ravel()
    z_s = np.asarray(z_s, dtype=float).reshape(len(t), len(x_lab))
    cols = (x_lab > x_range[0]) & (x_lab < x_range[1])
    T, X = np.meshgrid(t, x_lab[cols], indexing="ij")
    Z = z_s[:, cols]
    ok = np.isfinite(Z)
    design = np.column_stack([np.ones(ok.sum()), -X[ok], T[ok]])
    params, cov, s = _least_squares(design, Z[ok])
    se = np.sqrt(np.diag(cov))
    tan_a = params[1]
    a, b, a_se, b_se = _row_line_fits(x_lab[cols], z_s[:, cols])
    alpha_t = pd.DataFrame({"t": t, "alpha_deg": np.degrees(np.arctan(-b)),
                            "alpha_se": np.degrees(b_se / (1.0 + b**2))})
    _, v, _, v_se = _row_line_fits(t, z_s.T)
    rise = pd.DataFrame({"x_lab": x_lab, "v_r": v, "v_r_se": v_se, "in_fit": cols})
    return SurfaceFit(
        alpha_deg=float(np.degrees(np.arctan(tan_a))),
        alpha_se=float(np.degrees(se[1] / (1.0 + tan_a**2))),
        v_r=float(params[2]), v_r_se=float(se[2]), z0=float(params[0]), z0_se=float(se[0]),
        n_points=int(ok.sum()), residual_std=float(s), x_range=(float(x_range[0]), float(x_range[1])),
        alpha_t=alpha_t, rise_by_x=rise,
    )


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
    ``u_se``, ``w_se`` come from ``n_blocks`` contiguous blocks of frames,
    :math:`\\mathrm{std}_{ddof=1}(u_{block})/\\sqrt{n_{blocks}}` (NaN with fewer
    than two blocks).

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
        Blocks for standard errors, at least 2.
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
        self._sums: _BlockedSums | None = None
        self._result: pd.DataFrame | None = None

    # columns of the per-frame sums
    _V, _VU, _VW, _VUU, _VWW, _N, _ND = range(7)

    def prepare(self) -> None:
        """Start a new average (discarding any previous one)."""
        self._sums = _BlockedSums(_SUBBLOCKS_PER_BLOCK * self.n_blocks)
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
        p, flat, vol = _volume_pairs(x, z, radius, self.x_edges, self.z_edges, split)
        n_bins = self.bin_volume.size
        per_pair = [vol, vol * u[p], vol * w[p], vol * u[p] ** 2, vol * w[p] ** 2]
        sums = [np.bincount(flat, weights=q, minlength=n_bins) for q in per_pair]
        cp, cflat, _ = _volume_pairs(x, z, radius, self.x_edges, self.z_edges, None)
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
        blocks = [self._derive(m) for m in self._sums.block_means(self.n_blocks)]
        se = {}
        for name in ("u", "w"):
            stack = np.array([b[name] for b in blocks])
            se[f"{name}_se"] = (stack.std(axis=0, ddof=1) / np.sqrt(len(blocks)) if len(blocks) >= 2
                                else np.full(stack.shape[1], np.nan))
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
def _profile(z, u, z_max: float | None = None):
    """Finite points of a profile sorted by z, optionally only :math:`z \\le z_{max}`."""
    z, u = np.asarray(z, dtype=float).ravel(), np.asarray(u, dtype=float).ravel()
    ok = np.isfinite(z) & np.isfinite(u)
    if z_max is not None:
        ok &= z <= z_max
    order = np.argsort(z[ok], kind="stable")
    return z[ok][order], u[ok][order]


def _surface_tolerance(z) -> float:
    """Round-off allowance for 'z <= 0' on bin centres."""
    z = np.asarray(z, dtype=float)
    scale = np.nanmax(np.abs(z)) if np.isfinite(z).any() else 1.0
    return 1e-9 * scale


def surface_velocity(z, u) -> float:
    """Surface velocity :math:`u_s = u(z = 0)`, linearly interpolated.

    Between the finite points bracketing :math:`z = 0`; when no point lies
    above the surface, extrapolated from the two highest points provided the
    highest is within one spacing of the surface; NaN otherwise.
    """
    z, u = _profile(z, u)
    if len(z) == 0:
        return float("nan")
    if z[0] <= 0.0 <= z[-1]:
        return float(np.interp(0.0, z, u))
    if z[-1] < 0 and len(z) >= 2 and -z[-1] <= z[-1] - z[-2]:
        return float(u[-1] + (u[-1] - u[-2]) * (0.0 - z[-1]) / (z[-1] - z[-2]))
    return float("nan")


class ExponentialDepth(NamedTuple):
    """Result of :func:`delta_exponential`."""

    delta: float
    z0: float


def delta_exponential(z, u, u_s) -> ExponentialDepth:
    """Flowing-layer thickness from an exponential fit, :math:`\\delta = 2.3 z_0`.

    Fits :math:`u = u_0 e^{z/z_0}` (:func:`scipy.optimize.curve_fit`,
    unweighted, started from a log-linear fit) to the points with
    :math:`z \\le 0` and :math:`u > 0.01 u_s` (paper, section 3.2.2, after
    Komatsu et al. 2001).

    Returns
    -------
    ExponentialDepth
        ``(delta, z0)``, m; NaN with fewer than three points or a failed fit.
    """
    nan = ExponentialDepth(float("nan"), float("nan"))
    z, u = _profile(z, u, _surface_tolerance(z))
    keep = u > EXPONENTIAL_FIT_MIN_FRACTION * u_s
    z, u = z[keep], u[keep]
    if not (np.isfinite(u_s) and u_s > 0) or len(z) < 3:
        return nan
    a, b, _, _ = _line_fit(z, np.log(u))
    if not (np.isfinite(b) and b > 0):
        return nan
    try:
        popt, _ = curve_fit(lambda zz, u0, z0: u0 * np.exp(zz / z0), z, u, p0=(np.exp(a), 1.0 / b),
                            maxfev=2000)
    except (RuntimeError, ValueError):
        return nan
    z0 = float(popt[1])
    if not (np.isfinite(z0) and z0 > 0):
        return nan
    return ExponentialDepth(EXPONENTIAL_DEPTH_FACTOR * z0, z0)


def delta_linear(z, u, u_s) -> float:
    """Flowing-layer thickness by extrapolating the linear part of the profile to zero.

    A least-squares line :math:`u = a + b z` through the points with
    :math:`z \\le 0` and :math:`0.2 u_s \\le u \\le 0.8 u_s` (after GDR MiDi
    2004) meets :math:`u = 0` at :math:`z_{bottom} = -a/b`;
    :math:`\\delta = -z_{bottom}`, m. NaN with fewer than two points or a
    non-positive slope.
    """
    z, u = _profile(z, u, _surface_tolerance(z))
    if not (np.isfinite(u_s) and u_s > 0):
        return float("nan")
    keep = (u >= LINEAR_RANGE[0] * u_s) & (u <= LINEAR_RANGE[1] * u_s)
    if keep.sum() < 2:
        return float("nan")
    a, b, _, _ = _line_fit(z[keep], u[keep])
    return float(a / b) if np.isfinite(b) and b > 0 else float("nan")


def delta_cutoff(z, u, u_s, fraction: float = CUTOFF_FRACTION) -> float:
    """Flowing-layer thickness where :math:`u` first falls to ``fraction`` :math:`\\cdot u_s`.

    Going down from the surface (the point :math:`(0, u_s)` heads the
    profile), the first point with :math:`u \\le u_c = f u_s` and the one
    above it bracket the bottom of the layer, interpolated linearly;
    :math:`\\delta = -z_{bottom}`, m. NaN if :math:`u` never falls that low.
    """
    z, u = _profile(z, u, _surface_tolerance(z))
    if not (np.isfinite(u_s) and u_s > 0) or len(z) == 0:
        return float("nan")
    z, u = z[::-1], u[::-1]  # from the surface down
    if z[0] < 0:
        z, u = np.concatenate([[0.0], z]), np.concatenate([[u_s], u])
    u_c = fraction * u_s
    below = np.flatnonzero(u <= u_c)
    if len(below) == 0 or below[0] == 0:
        return float("nan")
    k = int(below[0])
    z_bottom = z[k - 1] + (u_c - u[k - 1]) * (z[k] - z[k - 1]) / (u[k] - u[k - 1])
    return float(-z_bottom)


def delta_eq31(x, gamma_bar, v_r, L, delta_L):
    """Eq. (3.1) of Khakhar et al. (2001), flowing-layer thickness from mass conservation.

    .. math::

        \\delta(x) = \\left[\\delta_L^2 + \\frac{2 v_r (L - x)}{\\bar{\\dot\\gamma}}\\right]^{1/2}.
    """
    x, gamma_bar = np.asarray(x, dtype=float), np.asarray(gamma_bar, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.sqrt(delta_L**2 + 2.0 * v_r * (L - x) / gamma_bar)


def normal_velocity_linear(zt):
    """Eq. (3.5), scaled normal velocity for a linear streamwise profile, :math:`\\tilde w = 2\\tilde z + \\tilde z^2`."""
    zt = np.asarray(zt, dtype=float)
    return 2.0 * zt + zt**2


def normal_velocity_exponential(zt, k: float = K_EXPONENTIAL):
    """Eq. (3.6), scaled normal velocity for an exponential profile,

    .. math:: \\tilde w = \\frac{e^{k\\tilde z} - 1}{1 - e^{-k}}, \\qquad
              \\tilde z = z/\\delta, \\; \\tilde w = w/v_r'.
    """
    zt = np.asarray(zt, dtype=float)
    return (np.exp(k * zt) - 1.0) / (1.0 - np.exp(-k))


class TailFit(NamedTuple):
    """Result of :func:`fit_exponential_tail`: :math:`u/u_s = A e^{k z/\\delta}`."""

    A: float
    k: float
    A_se: float
    k_se: float


def fit_exponential_tail(zt, ut, lo: float = TAIL_RANGE[0], hi: float = TAIL_RANGE[1]) -> TailFit:
    """Exponential tail of the collapsed profile, :math:`u/u_s = A e^{k z/\\delta}` (paper, figure 7b).

    Least squares of :math:`\\ln(u/u_s) = \\ln A + k\\,z/\\delta` over
    :math:`lo < z/\\delta < hi` and positive :math:`u/u_s`;
    :math:`\\mathrm{se}(A) = A\\,\\mathrm{se}(\\ln A)`. NaN with fewer than two points
    (standard errors need three).
    """
    zt, ut = np.asarray(zt, dtype=float).ravel(), np.asarray(ut, dtype=float).ravel()
    ok = np.isfinite(zt) & np.isfinite(ut) & (zt > lo) & (zt < hi) & (ut > 0)
    if ok.sum() < 2:
        return TailFit(*(float("nan"),) * 4)
    a, k, a_se, k_se = _line_fit(zt[ok], np.log(ut[ok]))
    A = float(np.exp(a))
    return TailFit(A, k, A * a_se, k_se)


class PowerLawFit(NamedTuple):
    """Result of :func:`fit_power_law`: :math:`y = c\\,x^a`."""

    prefactor: float
    exponent: float
    exponent_se: float


def fit_power_law(x, y) -> PowerLawFit:
    """Power law :math:`y = c\\,x^a` by least squares of :math:`\\ln y = \\ln c + a \\ln x`.

    Only points with positive finite :math:`x` and :math:`y`; NaN with fewer
    than two.
    """
    x, y = np.asarray(x, dtype=float).ravel(), np.asarray(y, dtype=float).ravel()
    ok = np.isfinite(x) & np.isfinite(y) & (x > 0) & (y > 0)
    if ok.sum() < 2:
        return PowerLawFit(*(float("nan"),) * 3)
    a, b, _, b_se = _line_fit(np.log(x[ok]), np.log(y[ok]))
    return PowerLawFit(float(np.exp(a)), b, b_se)


# --------------------------------------------------------------------------- along the heap
def _column(df: pd.DataFrame, name: str) -> np.ndarray:
    return df[name].to_numpy(dtype=float) if name in df else np.full(len(df), np.nan)


def _widths_below_surface(group: pd.DataFrame) -> np.ndarray:
    """Length of each bin below :math:`z = 0` (bin edges from ``z_lo``/``z_hi`` or centre midpoints)."""
    z = group["z"].to_numpy(dtype=float)
    if "z_lo" in group and "z_hi" in group:
        lo, hi = group["z_lo"].to_numpy(dtype=float), group["z_hi"].to_numpy(dtype=float)
    elif len(z) >= 2:
        mid = 0.5 * (z[1:] + z[:-1])
        edges = np.concatenate([[z[0] - (mid[0] - z[0])], mid, [z[-1] + (z[-1] - mid[-1])]])
        lo, hi = edges[:-1], edges[1:]
    else:
        return np.zeros(len(z))
    return np.clip(np.minimum(hi, 0.0) - lo, 0.0, None)


def _nanmean(values) -> float:
    values = np.asarray(values, dtype=float)
    values = values[np.isfinite(values)]
    return float(values.mean()) if len(values) else float("nan")


def _column_kinematics(group: pd.DataFrame, n_types: int, d_ref: float) -> dict:
    """Everything :func:`analyse_heap` derives from one streamwise bin."""
    nan = float("nan")
    z, u = group["z"].to_numpy(dtype=float), group["u"].to_numpy(dtype=float)
    row = dict(q=nan, u_s=nan, gamma_bar=nan, delta_exp=nan, delta_lin=nan, delta_cut=nan,
               delta=nan, d_bar=nan, n_profile=0, usable=False)
    if n_types == 2:
        row["c_s"] = nan
    finite = np.isfinite(u)
    if finite.any():
        row["q"] = float(np.sum(np.where(finite, u, 0.0) * _widths_below_surface(group)))
    u_s = surface_velocity(z, u)
    row["u_s"] = u_s
    if not (np.isfinite(u_s) and u_s > 0):
        return row
    row["delta_exp"] = delta_exponential(z, u, u_s).delta
    row["delta_lin"] = delta_linear(z, u, u_s)
    row["delta_cut"] = delta = delta_cutoff(z, u, u_s)
    row["delta"] = delta
    if not np.isfinite(delta):
        return row
    layer = (z > -delta) & (z <= _surface_tolerance(z))
    row["n_profile"] = int(np.sum(layer & finite))
    if row["n_profile"] < MIN_LAYER_POINTS:
        return row
    row["usable"] = True
    zp, up = _profile(z, u)
    row["gamma_bar"] = float((u_s - np.interp(-delta, zp, up)) / delta)
    if "d_mean" in group and "n" in group:
        n, d = _column(group, "n")[layer], _column(group, "d_mean")[layer]
        ok = np.isfinite(n) & np.isfinite(d) & (n > 0)
        row["d_bar"] = float(np.sum(n[ok] * d[ok]) / np.sum(n[ok])) if ok.any() else nan
    else:
        row["d_bar"] = float(d_ref)
    if n_types == 2 and "phi_1" in group and "phi_2" in group:
        f1, f2 = np.nansum(_column(group, "phi_1")[layer]), np.nansum(_column(group, "phi_2")[layer])
        row["c_s"] = float(f1 / (f1 + f2)) if f1 + f2 > 0 else nan
    return row


def mass_balance(fit: SurfaceFit, geometry: HeapGeometry, *, density: float, feed_rate: float,
                 phi_bed: float) -> dict:
    """Rise velocity predicted by mass conservation, and the measured one's residual.

    .. math::

        v_{r,pred} = \\frac{\\dot m}{\\rho\\,\\phi_{bed}\\,T\\,W_h}, \\qquad W_h = W .
    """
    v_pred = feed_rate / (density * phi_bed * geometry.T * geometry.W)
    return {"v_r_predicted": float(v_pred), "mass_balance_residual": float(fit.v_r / v_pred - 1.0),
            "phi_bed": float(phi_bed)}


def analyse_heap(profile: pd.DataFrame, fit: SurfaceFit, geometry: HeapGeometry, *, density: float,
                 feed_rate: float, phi_bed: float, d_ref: float, g: float = 9.81, n_types: int = 1):
    """Streamwise kinematics and scalings of the bounded heap (paper, sections 3.2-3.3).

    Per streamwise bin (``per_x``):

    * :math:`q(x) = \\int_{z_{wall}}^0 u\\,dz`, the 2D flow rate, by the
      midpoint rule over the bins below the surface (NaN bins count as no
      flow). The static bed is at rest along the flow (:class:`MovingFrame`),
      so bins below the layer add nothing but noise;
    * :math:`u_s` (:func:`surface_velocity`);
    * :math:`\\delta` by the exponential fit (``delta_exp``), the linear
      extrapolation (``delta_lin``) and the :math:`0.1 u_s` cutoff
      (``delta_cut``); ``delta`` is ``delta_cut``;
    * :math:`\\bar{\\dot\\gamma} = \\frac1\\delta\\int_{-\\delta}^0 \\frac{\\partial u}{\\partial z} dz
      = [u_s - u(-\\delta)]/\\delta`, the mean shear rate over the layer
      (exact mean of the gradient, without differencing noisy bins);
    * ``delta_eq31``, eq. (3.1) with the local :math:`\\bar{\\dot\\gamma}`,
      :math:`\\delta_L` the thickness at the last usable bin and the normal
      rise speed :math:`v_r'`, the rate at which the layer loses material per
      unit length along the slope (:math:`dq/dx = -v_r'`);
    * :math:`\\bar d`, the number-mean diameter over :math:`-\\delta < z \\le 0`
      (``n``-weighted ``d_mean``; ``d_ref`` when the profile has no diameters),
      and :math:`q^* = q/(\\bar d\\sqrt{g\\bar d})`;
    * ``c_s`` (two species): :math:`\\phi_1/(\\phi_1 + \\phi_2)` summed over the layer;
    * ``n_profile``: bins with a velocity in the layer; a bin is ``usable``
      with a positive :math:`u_s`, a cutoff thickness and at least
      :data:`MIN_LAYER_POINTS` of them; other bins keep NaN in what they lack.

    Scalars: the surface fit; :math:`v_r' = v_r\\cos\\alpha`;
    :math:`L = (W - x_{feed})/\\cos\\alpha`; mass conservation
    :math:`v_{r,pred} = \\dot m/(\\rho\\,\\phi_{bed}\\,T\\,W_h)` with
    :math:`W_h = W` and ``mass_balance_residual`` :math:`= v_r/v_{r,pred} - 1`;
    means of the three thicknesses over :math:`0.2 \\le x/L \\le 0.9` and
    ``delta_over_d`` = ``delta_mean / d_ref``; the tail fit of the collapsed
    profiles (:func:`fit_exponential_tail`); the power law
    :math:`\\delta/\\bar d = c\\,(q^*)^a` over :math:`x/L \\ge 0.2`;
    ``q0`` = :math:`q` at the first usable bin and ``q0_rise`` =
    :math:`v_r' L = v_r (W - x_{feed})`, the flow rate at :math:`x = 0` that
    mass conservation requires (the paper writes :math:`q_0 = v_r L`, which
    omits the factor :math:`\\cos\\alpha`).

    Parameters
    ----------
    profile : DataFrame
        :meth:`KinematicsAccumulator.conclude` output (needs ``x, z, u``;
        uses ``w, n, d_mean, phi_1, phi_2, z_lo, z_hi`` when present).
    fit : SurfaceFit
    geometry : HeapGeometry
    density : float
        Particle material density :math:`\\rho`, kg/m³.
    feed_rate : float
        Mass feed rate :math:`\\dot m`, kg/s.
    phi_bed : float
        Volume fraction of the static bed (:func:`bed_volume_fraction`).
    d_ref : float
        Reference particle diameter, m.
    g : float
        Gravity, m/s².
    n_types : int

    Returns
    -------
    per_x : DataFrame
        ``x, x_over_L, q, u_s, gamma_bar, delta_exp, delta_lin, delta_cut,
        delta, delta_eq31, d_bar, q_star, n_profile, usable`` (+ ``c_s``);
        ``attrs`` holds ``v_r_normal``, ``L`` and ``delta_L``.
    scalars : dict
        Keys :data:`SCALAR_KEYS`.
    """
    moving = MovingFrame(fit, geometry)
    L, v_rn = moving.L, moving.v_r_normal
    notes = []
    rows = []
    for x, group in profile.sort_values(["x", "z"]).groupby("x", sort=True):
        rows.append({"x": float(x), **_column_kinematics(group, n_types, d_ref)})
    per_x = pd.DataFrame(rows)
    if per_x.empty:
        per_x = pd.DataFrame(columns=["x", *_column_kinematics(profile.iloc[:0], n_types, d_ref)])
        notes.append("empty profile")
    per_x["usable"] = per_x["usable"].astype(bool)
    usable = per_x["usable"].to_numpy()
    x = per_x["x"].to_numpy(dtype=float)
    per_x["x_over_L"] = x / L
    delta = per_x["delta"].to_numpy(dtype=float)
    delta_L = float(delta[usable][-1]) if usable.any() else float("nan")
    per_x["delta_eq31"] = np.where(usable, delta_eq31(x, per_x["gamma_bar"].to_numpy(float), v_rn, L, delta_L),
                                   np.nan)
    d_bar = per_x["d_bar"].to_numpy(dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        per_x["q_star"] = np.where(usable, per_x["q"].to_numpy(float) / (d_bar * np.sqrt(g * d_bar)), np.nan)
    order = ["x", "x_over_L", "q", "u_s", "gamma_bar", "delta_exp", "delta_lin", "delta_cut", "delta",
             "delta_eq31", "d_bar", "q_star", "n_profile", "usable"] + (["c_s"] if n_types == 2 else [])
    per_x = per_x[order]
    per_x.attrs.update(v_r_normal=float(v_rn), L=float(L), delta_L=delta_L)
    if not usable.all():
        notes.append(f"{int((~usable).sum())} of {len(per_x)} streamwise bins unusable "
                     f"(no surface velocity, no cutoff depth or fewer than {MIN_LAYER_POINTS} bins in the layer)")

    xl = x / L
    window = usable & (xl >= DELTA_MEAN_RANGE[0]) & (xl <= DELTA_MEAN_RANGE[1])
    delta_mean = _nanmean(delta[window])
    scaled = collapse(profile, per_x)
    tail = fit_exponential_tail(scaled["zt"], scaled["ut"])
    far = usable & (xl >= Q_STAR_MIN_X_OVER_L)
    with np.errstate(divide="ignore", invalid="ignore"):
        power = fit_power_law(per_x["q_star"].to_numpy(float)[far], delta[far] / d_bar[far])
    scalars = {
        "alpha_deg": fit.alpha_deg, "alpha_se": fit.alpha_se, "v_r": fit.v_r, "v_r_se": fit.v_r_se,
        "v_r_normal": float(v_rn), "surface_z0": fit.z0,
        **mass_balance(fit, geometry, density=density, feed_rate=feed_rate, phi_bed=phi_bed),
        "L": float(L),
        "delta_mean": delta_mean, "delta_over_d": delta_mean / d_ref,
        "delta_exp_mean": _nanmean(per_x["delta_exp"].to_numpy(float)[window]),
        "delta_lin_mean": _nanmean(per_x["delta_lin"].to_numpy(float)[window]),
        "delta_cut_mean": _nanmean(per_x["delta_cut"].to_numpy(float)[window]),
        "tail_A": tail.A, "tail_A_se": tail.A_se, "tail_k": tail.k, "tail_k_se": tail.k_se,
        "q_star_exponent": power.exponent, "q_star_exponent_se": power.exponent_se,
        "q_star_prefactor": power.prefactor,
        "q0": float(per_x["q"].to_numpy(float)[usable][0]) if usable.any() else float("nan"),
        "q0_rise": float(v_rn * L), "n_usable": int(usable.sum()), "notes": "; ".join(notes),
    }
    return per_x, {k: scalars[k] for k in SCALAR_KEYS}


def collapse(profile: pd.DataFrame, per_x: pd.DataFrame, v_r_normal: float | None = None) -> pd.DataFrame:
    """Scaled profiles of every usable streamwise bin (paper, figures 7-9).

    Long table ``x, z, zt, ut, wt`` over the bins with :math:`z \\le 0`:
    :math:`\\tilde z = z/\\delta`, :math:`u/u_s` and :math:`\\tilde w = w/v_r'`,
    with :math:`\\delta`, :math:`u_s` from ``per_x`` and :math:`v_r'` from
    ``v_r_normal`` or else ``per_x.attrs["v_r_normal"]`` (``wt`` is NaN
    without either, or without a ``w`` column).
    """
    v_rn = v_r_normal if v_r_normal is not None else per_x.attrs.get("v_r_normal", float("nan"))
    columns = ["x", "z", "zt", "ut", "wt"]
    if per_x.empty or profile.empty:
        return pd.DataFrame(columns=columns)
    keep = per_x["usable"].astype(bool) if "usable" in per_x else np.isfinite(per_x["delta"])
    scales = per_x.loc[keep, ["x", "u_s", "delta"]]
    merged = profile.merge(scales, on="x", how="inner")
    merged = merged[merged["z"] <= _surface_tolerance(merged["z"])]
    w = _column(merged, "w")
    out = pd.DataFrame({
        "x": merged["x"].to_numpy(float), "z": merged["z"].to_numpy(float),
        "zt": (merged["z"] / merged["delta"]).to_numpy(float),
        "ut": (merged["u"] / merged["u_s"]).to_numpy(float),
        "wt": w / v_rn if np.isfinite(v_rn) and v_rn != 0 else np.full(len(merged), np.nan),
    })
    return out.sort_values(["x", "z"]).reset_index(drop=True)


# --------------------------------------------------------------------------- deposit
def deposit_concentration(position, radius, type, fit: SurfaceFit, geometry: HeapGeometry,
                          t_start: float, t_end: float, delta: float, dx: float, *,
                          y_range=None) -> pd.DataFrame:
    """Small-particle volume concentration of the material deposited in a time window (paper, figure 3).

    The deposit of the window lies between the fitted surface at ``t_start``
    and the fitted surface at ``t_end`` lowered by the flowing-layer
    thickness :math:`\\delta` (measured normal to the surface, as everywhere
    in the paper; vertically :math:`\\delta/\\cos\\alpha`), which excludes the
    flowing layer. In the moving frame at ``t_end`` that is
    :math:`-v_r'(t_{end} - t_{start}) \\le z < -\\delta`. Per :math:`\\Delta x`
    column in :math:`x_{lab}` (from 0 to :math:`W`, particles by centre),

    .. math:: c_s = \\frac{\\sum_{type\\,1} V_j}{\\sum V_j} .

    Positions should come from a frame at or after ``t_end`` (the deposit is
    static by then). ``y_range=(y_lo, y_hi)`` restricts to a slice of the gap
    (the paper compares particles within :math:`2 d_l` of the front wall with
    experiments).

    Returns
    -------
    DataFrame
        ``x_lab`` (column centre), ``c_s`` (NaN in empty columns), ``n``
        (particles counted).
    """
    position = np.asarray(position, dtype=float).reshape(-1, 3)
    radius = np.asarray(radius, dtype=float).ravel()
    kind = np.ones(len(radius), dtype=int) if type is None else np.asarray(type).astype(int).ravel()
    moving = MovingFrame(fit, geometry)
    _, z, _, _ = moving.transform(position, np.zeros_like(position), t_end)
    thickness = moving.v_r_normal * (t_end - t_start)
    inside = (z >= -thickness) & (z < -delta)
    if y_range is not None:
        inside &= (position[:, 1] >= y_range[0]) & (position[:, 1] <= y_range[1])
    edges = uniform_edges(0.0, geometry.W, dx)
    col = _centre_bins(position[:, 0], edges)
    inside &= col >= 0
    vol = 4.0 / 3.0 * np.pi * radius**3
    n_cols = len(edges) - 1
    total = np.bincount(col[inside], weights=vol[inside], minlength=n_cols)
    small = np.bincount(col[inside], weights=(vol * (kind == 1))[inside], minlength=n_cols)
    count = np.bincount(col[inside], minlength=n_cols)
    return pd.DataFrame({
        "x_lab": 0.5 * (edges[1:] + edges[:-1]),
        "c_s": np.divide(small, total, out=np.full(n_cols, np.nan), where=total > 0),
        "n": count,
    })
