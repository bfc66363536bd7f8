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

import numpy as np
import pandas as pd

from postproc.overlap import slab_pairs, sphere_slab_fraction  # noqa: F401 (sphere_slab_fraction re-exported by the analysis package)

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
#: the planar middle of the free surface, as fractions of the flowing length from the feed zone's edge
#: to the end wall: away from the flat patch where the fed particles land and bounce (one bounce carries
#: ~0.08 m on a 0.12 m heap; the paper's is 0.46 m long) and from the pool against the end wall
ALPHA_PLANAR_MIDDLE = (0.25, 0.75)
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
    "origin", "delta_over_d_other_origin", "tail_A_other_origin", "tail_k_other_origin",
    "surface_offset_rms", "surface_offset_max_over_d",
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
def centre_bins(c: np.ndarray, edges: np.ndarray) -> np.ndarray:
    """Bin index of each centre in ``[e_k, e_{k+1})`` (last edge included); -1 outside.

    Parameters
    ----------
    c : ndarray, shape (n,)
        Coordinate of each particle's centre along one axis, m.
    edges : ndarray, shape (n_bins + 1,)
        Increasing bin edges along that axis, m.

    Returns
    -------
    ndarray of int, shape (n,)
        The bin of each centre, ``0 .. n_bins - 1``; -1 for a centre outside the edges.
    """
    n = len(edges) - 1
    i = np.searchsorted(edges, c, side="right") - 1
    i[c == edges[-1]] = n - 1
    i[(i < 0) | (i >= n)] = -1
    return i


def volume_pairs(a, b, radius, a_edges, b_edges, split: str | None):
    """Particle volumes on a 2D grid of bins (a, b).

    ``split="b"`` splits each sphere exactly over the b-slabs and assigns it
    in a by its centre; ``split="a"`` the converse; ``None`` assigns whole
    particles by their centres. Returns ``particle, flat_bin, volume``.

    Parameters
    ----------
    a, b : ndarray, shape (n,)
        Coordinates of each particle's centre along the grid's two axes, m.
    radius : ndarray, shape (n,)
        Radius of each particle, m.
    a_edges, b_edges : ndarray, shapes (n_a + 1,) and (n_b + 1,)
        Increasing bin edges along each axis, m.
    split : {"a", "b", None}
        The axis along which spheres are split exactly over the slabs, or None.

    Returns
    -------
    particle : ndarray of int, shape (n_pairs,)
        Index of the particle of each (particle, bin) pair inside the grid.
    flat_bin : ndarray of int, shape (n_pairs,)
        The pair's bin, ``i_a * n_b + i_b``.
    volume : ndarray of float, shape (n_pairs,)
        The particle's volume in that bin, m^3.

    Raises
    ------
    ValueError
        If ``split`` is none of ``"a"``, ``"b"`` and None.
    """
    volume = 4.0 / 3.0 * np.pi * radius**3
    n_b = len(b_edges) - 1
    if split == "b":
        ia = centre_bins(a, a_edges)
        p, ib, f = slab_pairs(b, radius, b_edges)
        ia = ia[p]
    elif split == "a":
        ib = centre_bins(b, b_edges)
        p, ia, f = slab_pairs(a, radius, a_edges)
        ib = ib[p]
    elif split is None:
        p = np.arange(len(a))
        ia, ib, f = centre_bins(a, a_edges), centre_bins(b, b_edges), np.ones(len(a))
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
    _, flat, vol = volume_pairs(position[:, 0], position[:, 2], radius, x_edges, z_edges, "b")
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


def line_fit(x, y):
    """One least-squares line (see :func:`_row_line_fits`); floats ``a, b, a_se, b_se``.

    Parameters
    ----------
    x, y : array_like, shape (n,)
        The points, any units; pairs where either is not finite are left out.

    Returns
    -------
    a, b, a_se, b_se : float
        Intercept (unit of y) and slope (unit of y per unit of x) of :math:`y = a + b x`
        and their standard errors; the line is NaN without two points spread in x,
        the errors without three points.
    """
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


def surface_grid(surface: pd.DataFrame):
    """``(t, x_lab, z_s (n_t, n_x))`` of a :func:`surface_table` (``t, x_lab, z_s``; rows with an unknown
    time or column dropped, duplicates averaged), or None without at least two times, three columns and
    one finite height."""
    if surface is None or surface.empty or not {"t", "x_lab", "z_s"} <= set(surface):
        return None
    s = surface.dropna(subset=["t", "x_lab"])
    if s.empty or not np.isfinite(s["z_s"].to_numpy(float)).any():
        return None
    grid = s.pivot_table(index="t", columns="x_lab", values="z_s", aggfunc="mean", dropna=False)
    if grid.shape[0] < 2 or grid.shape[1] < 3:
        return None
    return grid.index.to_numpy(float), grid.columns.to_numpy(float), grid.to_numpy(float)


def rise_inefficiency(surface: pd.DataFrame, x_range) -> float:
    """Statistical inefficiency :math:`g` of the residuals of the mean surface height's rise.

    The mean :math:`\\bar z_s(t)` of the free surface over the columns with
    centres in ``x_range`` (the fit range of :func:`fit_surface`) is fitted by a
    line in time; :math:`g` of its residuals
    (:func:`postproc.autocorr.statistical_inefficiency`) says how many frames
    one independent residual spans.  The least-squares error of the rise
    velocity assumes independent residuals; :math:`\\sqrt g` times it allows for
    their correlation (surges of the flowing layer last several frames).

    Parameters
    ----------
    surface : DataFrame
        :func:`surface_table` output, ``t, x_lab, z_s``.
    x_range : (float, float)
        Open interval of column centres.

    Returns
    -------
    float
        :math:`g \\ge 1`; NaN with fewer than four frames.
    """
    from postproc.autocorr import statistical_inefficiency

    s = surface[(surface["x_lab"] > x_range[0]) & (surface["x_lab"] < x_range[1])]
    mean = s.groupby("t")["z_s"].mean().dropna()
    if len(mean) < 4:
        return float("nan")
    t, z = mean.index.to_numpy(float), mean.to_numpy(float)
    a, b, _, _ = line_fit(t, z)
    return statistical_inefficiency(z - (a + b * t))
