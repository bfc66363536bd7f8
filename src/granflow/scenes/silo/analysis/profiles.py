"""Orifice profiles, the kinetic pressure on the axis and its transition height, partial stresses, scalings."""
from __future__ import annotations

import numpy as np
import pandas as pd

from .discharge import PHI_MIN_PARTIAL, SQRT_PROFILE_RANGE, field_map, numeric_column, species_ids


# --------------------------------------------------------------------------- profiles
def _nearest(values: np.ndarray, target: float) -> float:
    values = values[np.isfinite(values)]
    return float(values[np.argmin(np.abs(values - target))])


def orifice_profiles(fields: pd.DataFrame, R: float, z_orifice: float = 0.0,
                     r_range: float = SQRT_PROFILE_RANGE) -> dict:
    """Volume fraction and vertical velocity across the orifice (paper figures 4, 5).

    The profiles are read on the node row nearest ``z_orifice`` (its height is
    returned as ``z_row``) and normalised by the values at the node nearest the
    axis, :math:`\\phi_c = \\phi(0)` and :math:`v_c = |u_z(0)|`:

    .. math:: \\hat\\phi(r) = \\phi(r)/\\phi(0), \\qquad \\hat v(r) = u_z(r)/u_z(0).

    The distance from the self-similar profile of Janda et al. (2012) is the
    rms over the nodes with :math:`r < r_{range} R`,

    .. math:: \\Delta = \\Big\\langle \\big(\\hat v(r) - \\sqrt{1-(r/R)^2}\\big)^2 \\Big\\rangle^{1/2}_{r < 0.9R}.

    The range stops at 0.9 R: there :math:`\\sqrt{1-x^2}` has fallen to 0.44
    with slope -2.1 and its slope diverges at the edge, so beyond it any
    smoothing by the coarse-graining kernel (width :math:`\\sim 2 r_b`, a
    sizable fraction of R) and the excluded volume at the orifice rim dominate
    the comparison.

    Parameters
    ----------
    fields : DataFrame
        Field table with ``r, z, phi, u_z`` (and ``phi_se, u_z_se``).
    R : float
        Orifice radius, m.
    z_orifice : float
        Height of the orifice plane, m.
    r_range : float
        Upper end of the comparison range in units of R.

    Returns
    -------
    dict
        ``profile`` (DataFrame ``r, r_over_R, phi, phi_se, u_z, u_z_se,
        phi_norm, vz_norm``, r < R_c), ``z_row`` (m), ``r_axis`` (r of the
        axis node, m), ``phi_c, phi_c_se, v_c, v_c_se`` (m/s),
        ``sqrt_profile_deviation``, ``n_deviation`` (nodes used).
    """
    if not R > 0:
        raise ValueError(f"orifice radius must be positive, got {R}")
    z = numeric_column(fields, "z")
    if not np.isfinite(z).any():
        raise ValueError("field table has no z nodes")
    z_row = _nearest(z, z_orifice)
    row = fields[z == z_row]
    r = numeric_column(row, "r")
    order = np.argsort(r, kind="stable")
    r = r[order]
    phi, phi_se = numeric_column(row, "phi")[order], numeric_column(row, "phi_se")[order]
    uz, uz_se = numeric_column(row, "u_z")[order], numeric_column(row, "u_z_se")[order]
    i0 = int(np.nanargmin(np.abs(r)))
    phi_c, uz_c = phi[i0], uz[i0]
    phi_norm = phi / phi_c if np.isfinite(phi_c) and phi_c != 0 else np.full_like(phi, np.nan)
    vz_norm = uz / uz_c if np.isfinite(uz_c) and uz_c != 0 else np.full_like(uz, np.nan)
    x = r / R
    sel = (x < r_range) & np.isfinite(vz_norm)
    dev = vz_norm[sel] - np.sqrt(1 - x[sel] ** 2)
    profile = pd.DataFrame(dict(r=r, r_over_R=x, phi=phi, phi_se=phi_se, u_z=uz, u_z_se=uz_se,
                                phi_norm=phi_norm, vz_norm=vz_norm))
    return dict(profile=profile, z_row=z_row, r_axis=float(r[i0]), phi_c=float(phi_c), phi_c_se=float(phi_se[i0]),
                v_c=float(abs(uz_c)), v_c_se=float(uz_se[i0]),
                sqrt_profile_deviation=float(np.sqrt(np.mean(dev ** 2))) if len(dev) else np.nan,
                n_deviation=int(len(dev)))


def axis_profile(fields: pd.DataFrame, column: str, r_max: float | None = None) -> pd.DataFrame:
    """A field on the silo axis against height.

    Without ``r_max`` the values of the radial node nearest :math:`r = 0`.
    With ``r_max`` the area-weighted mean over the nodes with :math:`r < r_{max}`,
    each node standing for the annulus between the midpoints to its
    neighbours (the innermost annulus starts at r = 0):

    .. math:: \\bar f(z) = \\frac{\\sum_i A_i f(r_i, z)}{\\sum_i A_i}, \\qquad
        A_i = \\pi (r_{i+1/2}^2 - r_{i-1/2}^2).

    The standard error of the mean is the same weighted mean of the nodes'
    standard errors (neighbouring nodes share particles through the kernel, so
    their errors are taken as fully correlated: an upper bound).

    Returns
    -------
    DataFrame
        ``z`` (m, ascending), ``value``, ``value_se`` (NaN without a
        ``<column>_se`` column); empty columns when ``column`` is absent.
    """
    r, z, values = field_map(fields, column)
    _, _, se = field_map(fields, f"{column}_se")
    if not len(r) or column not in fields:
        return pd.DataFrame(dict(z=z, value=np.full(len(z), np.nan), value_se=np.full(len(z), np.nan)))
    if r_max is None:
        i0 = int(np.argmin(np.abs(r)))
        return pd.DataFrame(dict(z=z, value=values[i0], value_se=se[i0]))
    mid = 0.5 * (r[1:] + r[:-1])
    lo = np.clip(np.concatenate([[0.0], mid]), 0.0, None)
    hi = np.concatenate([mid, [r[-1] + (r[-1] - mid[-1] if len(mid) else r[-1])]])
    area = np.pi * (hi ** 2 - lo ** 2)
    inside = r < r_max
    if not inside.any():
        inside = np.abs(r) == np.min(np.abs(r))
    a = np.where(np.isfinite(values[inside]), area[inside, None], 0.0)
    total = a.sum(axis=0)
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = np.nansum(a * values[inside], axis=0) / total
        mean_se = np.nansum(a * se[inside], axis=0) / total
    mean_se[~np.isfinite(se[inside]).any(axis=0)] = np.nan
    return pd.DataFrame(dict(z=z, value=mean, value_se=mean_se))


# --------------------------------------------------------------------------- kinetic pressure
def _peak(z: np.ndarray, y: np.ndarray) -> float:
    """Peak position from the three points around the maximum (z ascending, all finite).

    A parabola through :math:`\\ln y` when the three values are positive (exact
    for a Gaussian peak, and the kinetic pressure grows exponentially towards
    its maximum), through :math:`y` otherwise; the vertex is kept between the
    outer two points.  At an end of the range, that end.
    """
    i = int(np.argmax(y))
    if i == 0 or i == len(y) - 1:
        return float(z[i])
    zz, yy = z[i - 1:i + 2], y[i - 1:i + 2]
    if np.all(yy > 0):
        yy = np.log(yy)
    a, b, _ = np.polyfit(zz - zz[1], yy, 2)
    if not a < 0:
        return float(z[i])
    return float(np.clip(zz[1] - b / (2 * a), zz[0], zz[2]))


def transition_height(z, pk, pk_se=None, z_min: float = 0.0, n_resample: int = 400,
                      seed: int = 0) -> tuple[float, float]:
    """Height :math:`h_c` of the kinetic-pressure maximum on the axis (the transition region).

    .. math:: h_c = \\arg\\max_{z > z_{min}} p^k(r = 0, z)

    refined by the vertex of a parabola through the three nodes around the
    largest value (through :math:`\\ln p^k` when positive, exact for a
    Gaussian bump, within a few hundredths of the node spacing for smooth
    symmetric peaks; a peak whose curvature differs on its two sides by a
    factor 4 can be off by a third of the spacing).  Only nodes above the
    orifice plane (``z > z_min``) count.

    Uncertainty: with ``pk_se`` the profile is resampled ``n_resample`` times
    as :math:`p^k + \\mathcal N(0, \\mathrm{se}^2)` (seeded; nodes taken as
    independent) and the standard deviation of the resampled :math:`h_c` is
    returned.  Without ``pk_se`` it is the delta-method error of the vertex of
    a least-squares parabola through the five nodes around the maximum (the
    residuals set the noise), or NaN with fewer than five nodes there.  A
    maximum at the lowest or highest node is not resolved: that node's height
    is returned with a NaN error.

    Parameters
    ----------
    z : array_like
        Heights, m.
    pk : array_like
        Kinetic pressure on the axis, Pa.
    pk_se : array_like, optional
        Its standard errors, Pa.
    z_min : float
        Only nodes with ``z > z_min`` are used (the orifice plane).
    n_resample : int
        Number of resamples.
    seed : int
        Seed of :func:`numpy.random.default_rng`.

    Returns
    -------
    h_c, h_c_se : float
        m; NaN when fewer than three usable nodes.
    """
    z = np.asarray(z, dtype=float)
    y = np.asarray(pk, dtype=float)
    se = np.full_like(y, np.nan) if pk_se is None else np.asarray(pk_se, dtype=float)
    ok = np.isfinite(z) & np.isfinite(y) & (z > z_min)
    order = np.argsort(z[ok], kind="stable")
    z, y, se = z[ok][order], y[ok][order], se[ok][order]
    if len(z) < 3:
        return np.nan, np.nan
    h_c = _peak(z, y)
    i = int(np.argmax(y))
    if i == 0 or i == len(y) - 1:
        return h_c, np.nan
    if np.isfinite(se).all() and np.any(se > 0):
        rng = np.random.default_rng(seed)
        samples = [_peak(z, y + se * rng.standard_normal(len(y))) for _ in range(int(n_resample))]
        return h_c, float(np.std(samples, ddof=1))
    if i < 2 or i > len(y) - 3:
        return h_c, np.nan
    zz, yy = z[i - 2:i + 3] - z[i], y[i - 2:i + 3]
    if np.all(yy > 0):
        yy = np.log(yy)
    (a, b, _), cov = np.polyfit(zz, yy, 2, cov=True)
    if not a < 0:
        return h_c, np.nan
    grad = np.array([b / (2 * a ** 2), -1 / (2 * a)])  # d(-b/2a)/d(a, b)
    return h_c, float(np.sqrt(grad @ cov[:2, :2] @ grad))


def cumulative_kinetic_pressure(fields: pd.DataFrame) -> pd.DataFrame:
    """Cumulative kinetic pressure of the particles at least as large as each size (paper figure 10).

    .. math:: P^k_{\\ge s}(\\mathbf r) = \\sum_{s' \\ge s} p^k_{s'}(\\mathbf r)

    with species ids ordered by size, so :math:`P^k_{\\ge 1}` (all sizes, the
    paper's limit :math:`r > r_s`) is the total :math:`p^k` and
    :math:`P^k_{\\ge 7}` the largest size alone.  Standard errors add in
    quadrature (species taken as independent).

    Returns
    -------
    DataFrame
        ``r, z`` and ``pk_cum_s<s>``, ``pk_cum_s<s>_se`` for every species ``s``
        with a ``pk_s<s>`` column.
    """
    ids = species_ids(fields, "pk")
    out = {key: numeric_column(fields, key) for key in ("r", "z")}
    total = np.zeros(len(fields))
    var = np.zeros(len(fields))
    for s in reversed(ids):
        total = total + numeric_column(fields, f"pk_s{s}")
        var = var + numeric_column(fields, f"pk_s{s}_se") ** 2
        out[f"pk_cum_s{s}"] = total.copy()
        out[f"pk_cum_s{s}_se"] = np.sqrt(var)
    cols = ["r", "z"] + [f"pk_cum_s{s}{e}" for s in ids for e in ("", "_se")]
    return pd.DataFrame(out)[cols]


def partial_over_fraction(fields: pd.DataFrame, phi_min: float = PHI_MIN_PARTIAL) -> pd.DataFrame:
    """Partial kinetic pressure per unit partial volume fraction (paper figure 12).

    .. math:: \\pi_s = p^k_s / \\phi_s, \\qquad
        \\sigma_{\\pi_s}^2 = \\frac{\\sigma_{p_s}^2}{\\phi_s^2} + \\frac{p_s^2\\sigma_{\\phi_s}^2}{\\phi_s^4}

    in Pa; NaN where :math:`\\phi_s < \\phi_{min}` (no particles of that size there).

    Returns
    -------
    DataFrame
        ``r, z`` and ``pk_over_phi_s<s>``, ``pk_over_phi_s<s>_se`` for every
        species with both ``pk_s<s>`` and ``phi_s<s>``.
    """
    ids = [s for s in species_ids(fields, "pk") if f"phi_s{s}" in fields]
    out = {key: numeric_column(fields, key) for key in ("r", "z")}
    for s in ids:
        pk, phi = numeric_column(fields, f"pk_s{s}"), numeric_column(fields, f"phi_s{s}")
        pk_se, phi_se = numeric_column(fields, f"pk_s{s}_se"), numeric_column(fields, f"phi_s{s}_se")
        phi = np.where(phi >= phi_min, phi, np.nan)
        out[f"pk_over_phi_s{s}"] = pk / phi
        out[f"pk_over_phi_s{s}_se"] = np.sqrt((pk_se / phi) ** 2 + (pk * phi_se / phi ** 2) ** 2)
    return pd.DataFrame(out)


# --------------------------------------------------------------------------- scaling
def scaled_flow_rate(W, rho_p: float, phi_c, v_c, R):
    """Flow rate in units of the orifice flux (paper figure 2b).

    .. math:: \\tilde W = \\frac{W}{\\rho_p \\phi_c v_c \\pi R^2}

    With :math:`\\phi(r)` and :math:`v_z(r)` self-similar across the orifice,
    :math:`\\tilde W` is a constant fixed by the shape of the profiles (2/3 for
    a flat :math:`\\phi` and :math:`v_z \\propto \\sqrt{1-(r/R)^2}`).
    """
    return np.asarray(W, dtype=float) / (rho_p * np.asarray(phi_c, dtype=float) * np.asarray(v_c, dtype=float)
                                         * np.pi * np.asarray(R, dtype=float) ** 2)


def velocity_scaling_fit(R, v_c, v_c_se=None) -> dict:
    """Fit :math:`v_c = a\\sqrt R` (a line through the origin against :math:`\\sqrt R`, paper figure 5c).

    .. math:: a = \\frac{\\sum_i w_i \\sqrt{R_i}\\, v_i}{\\sum_i w_i R_i}, \\qquad
        \\sigma_a^2 = \\frac{1}{\\sum_i w_i R_i}\\cdot\\max(1, \\chi^2/\\nu)

    with :math:`w_i = 1/\\sigma_i^2` (or 1 and the residual variance when no
    errors are given).  For free fall from a height :math:`\\propto R`,
    :math:`a = \\sqrt{2 g c}` for a fall height :math:`c R`.

    Returns
    -------
    dict
        ``a`` (m^{1/2}/s), ``a_se``, ``n``; NaN with no point.
    """
    x = np.sqrt(np.asarray(R, dtype=float))
    y = np.asarray(v_c, dtype=float)
    ok = np.isfinite(x) & np.isfinite(y)
    s = None
    if v_c_se is not None:
        s = np.asarray(v_c_se, dtype=float)
        if not np.all(np.isfinite(s[ok]) & (s[ok] > 0)):
            s = None
    x, y = x[ok], y[ok]
    n = len(x)
    if n == 0 or not np.any(x > 0):
        return dict(a=np.nan, a_se=np.nan, n=n)
    w = np.ones(n) if s is None else 1.0 / s[ok] ** 2
    sxx = np.sum(w * x ** 2)
    a = float(np.sum(w * x * y) / sxx)
    if n < 2:
        return dict(a=a, a_se=np.nan, n=n)
    chi2 = np.sum(w * (y - a * x) ** 2) / (n - 1)
    scale = chi2 if s is None else max(1.0, chi2)
    return dict(a=a, a_se=float(np.sqrt(scale / sxx)), n=n)


def mean_diameter(radii) -> float:
    """Number-mean particle diameter of equal numbers per size, :math:`d = 2\\langle r_s\\rangle`, m."""
    return float(2 * np.mean(np.asarray(radii, dtype=float)))


# --------------------------------------------------------------------------- comparisons over cases
def weighted_line_fit(x, y, y_se=None) -> dict:
    """Least-squares line :math:`y = a + b x`, weighted by :math:`1/\\sigma_y^2` when errors are given.

    .. math:: (a, b) = \\arg\\min \\sum_i w_i (y_i - a - b x_i)^2, \\qquad
        \\mathrm{cov} = (X^T W X)^{-1} \\cdot \\max(1, \\chi^2/\\nu)

    With errors the covariance is the weighted one, scaled up by
    :math:`\\chi^2/\\nu` when the points scatter more than their errors allow
    (as :func:`beverloo_fit` does); without errors (or with any missing or
    non-positive) the fit is unweighted and the residuals set the covariance.
    Two points give the line with the weights' errors only (no
    :math:`\\chi^2`); one point gives NaN.

    Returns
    -------
    dict
        ``slope, intercept, slope_se, intercept_se, chi2_dof, n``.
    """
    x = np.asarray(x, dtype=float).ravel()
    y = np.asarray(y, dtype=float).ravel()
    ok = np.isfinite(x) & np.isfinite(y)
    s = None
    if y_se is not None:
        s = np.asarray(y_se, dtype=float).ravel()
        if not np.all(np.isfinite(s[ok]) & (s[ok] > 0)):
            s = None
    x, y = x[ok], y[ok]
    s = s[ok] if s is not None else None
    n = len(x)
    out = dict(slope=np.nan, intercept=np.nan, slope_se=np.nan, intercept_se=np.nan, chi2_dof=np.nan, n=n)
    if n < 2 or np.ptp(x) == 0:
        return out
    w = np.ones(n) if s is None else 1.0 / s ** 2
    X = np.column_stack([np.ones(n), x])
    A = X.T @ (X * w[:, None])
    coef = np.linalg.solve(A, X.T @ (w * y))
    resid = y - X @ coef
    dof = n - 2
    chi2_dof = float(np.sum(w * resid ** 2) / dof) if dof > 0 else np.nan
    if s is None:
        scale = chi2_dof  # NaN with two points: no error without weights
    else:
        scale = max(1.0, chi2_dof) if np.isfinite(chi2_dof) else 1.0
    cov = np.linalg.inv(A) * scale
    out.update(slope=float(coef[1]), intercept=float(coef[0]), slope_se=float(np.sqrt(cov[1, 1])),
               intercept_se=float(np.sqrt(cov[0, 0])), chi2_dof=chi2_dof if s is not None else np.nan)
    return out


def scaling_exponent(x, y, y_se=None) -> dict:
    """Exponent :math:`a` of :math:`y = c\\,x^a` by :func:`weighted_line_fit` of the logarithms.

    .. math:: \\ln y = \\ln c + a \\ln x, \\qquad \\sigma_{\\ln y} = \\sigma_y / y

    (e.g. :math:`v_c \\propto R^{1/2}` over orifice sizes, paper figure 5).
    Points with non-positive x or y are left out.

    Returns
    -------
    dict
        ``exponent, exponent_se, prefactor, chi2_dof, n``.
    """
    x = np.asarray(x, dtype=float).ravel()
    y = np.asarray(y, dtype=float).ravel()
    se = None if y_se is None else np.asarray(y_se, dtype=float).ravel()
    ok = np.isfinite(x) & np.isfinite(y) & (x > 0) & (y > 0)
    fit = weighted_line_fit(np.log(x[ok]), np.log(y[ok]), None if se is None else se[ok] / y[ok])
    return dict(exponent=fit["slope"], exponent_se=fit["slope_se"], prefactor=float(np.exp(fit["intercept"])),
                chi2_dof=fit["chi2_dof"], n=fit["n"])


def shifted_power_fit(x, y, y_se=None) -> dict:
    """Fit :math:`y = A (x - x_0)^b` (a power law with an offset, Beverloo's "empty annulus").

    Weighted least squares (``scipy.optimize.curve_fit`` with ``sigma = y_se``, errors scaled by
    :math:`\\chi^2/\\nu` when it exceeds 1, as :func:`weighted_line_fit`), started from the pure
    power law (:func:`scaling_exponent`, :math:`x_0 = 0`). Needs four points (three parameters
    and one degree of freedom); fewer give NaN. ``x_0`` is kept below the smallest x.

    Returns
    -------
    dict
        ``exponent, exponent_se, x0, x0_se, prefactor, chi2_dof, n``.
    """
    from scipy.optimize import curve_fit

    x = np.asarray(x, dtype=float).ravel()
    y = np.asarray(y, dtype=float).ravel()
    se = None if y_se is None else np.asarray(y_se, dtype=float).ravel()
    ok = np.isfinite(x) & np.isfinite(y) & (x > 0) & (y > 0)
    if se is not None:
        ok &= np.isfinite(se) & (se > 0)
    x, y = x[ok], y[ok]
    se = se[ok] if se is not None else None
    n = len(x)
    out = dict(exponent=np.nan, exponent_se=np.nan, x0=np.nan, x0_se=np.nan, prefactor=np.nan,
               chi2_dof=np.nan, n=n)
    if n < 4:
        return out
    start = scaling_exponent(x, y, se)

    def model(xx, A, x0, b):
        return A * np.clip(xx - x0, 1e-12, None) ** b

    try:
        p, cov = curve_fit(model, x, y, p0=(start["prefactor"], 0.0, start["exponent"]), sigma=se,
                           absolute_sigma=se is not None, bounds=([0, -10 * x.max(), 0.0], [np.inf, 0.999 * x.min(), 10.0]),
                           maxfev=20000)
    except (RuntimeError, ValueError):
        return out
    resid = (y - model(x, *p)) / (se if se is not None else 1.0)
    chi2_dof = float(np.sum(resid**2) / (n - 3))
    if se is not None and chi2_dof > 1:
        cov = cov * chi2_dof
    err = np.sqrt(np.diag(cov))
    out.update(exponent=float(p[2]), exponent_se=float(err[2]), x0=float(p[1]), x0_se=float(err[1]),
               prefactor=float(p[0]), chi2_dof=chi2_dof if se is not None else np.nan)
    return out


def bulk_volume_fraction(fields: pd.DataFrame, fill_height: float, R_c: float, r_b: float) -> tuple[float, float]:
    """Bulk volume fraction of the silo: the mean of :math:`\\phi` over a slab at half the fill height.

    .. math:: \\phi_{bulk} = \\langle \\phi(r, z) \\rangle_{|z - H/2| < 4 r_b,\\ r < R_c - 3 r_b}

    (nodes within three largest radii of the side wall are left out: the wall
    orders the packing there).  The standard error is the mean of the nodes'
    standard errors: nodes closer than the kernel share particles, so their
    errors are taken as fully correlated (an upper bound).  The paper measures
    :math:`\\phi_{bulk}` in a slab touching the top surface (its section 3).

    Returns
    -------
    phi_bulk, phi_bulk_se : float
        NaN when no node lies in the slab.
    """
    r, z, phi = numeric_column(fields, "r"), numeric_column(fields, "z"), numeric_column(fields, "phi")
    se = numeric_column(fields, "phi_se")
    sel = (z > 0.5 * fill_height - 4 * r_b) & (z < 0.5 * fill_height + 4 * r_b) & (r < R_c - 3 * r_b)
    if not sel.any():
        return float("nan"), float("nan")
    return float(np.mean(phi[sel])), float(np.nanmean(se[sel])) if np.isfinite(se[sel]).any() else float("nan")


def contact_fall(contact: pd.DataFrame, R: float, span: float = 2.0) -> dict:
    """How the contact pressure on the axis falls towards the orifice (paper figure 6).

    Over the axis nodes with :math:`0 \\le z \\le` ``span`` :math:`R`: the Spearman
    rank correlation :math:`\\rho_s` of :math:`p^c(r=0, z)` with :math:`z` (1 for a
    monotonic fall towards the outlet, whatever its shape), and the pressure
    at the orifice plane relative to the one at the top of the span,

    .. math:: f = \\frac{p^c(0, 0)}{p^c(0, \\mathrm{span}\\cdot R)}

    (0 when it vanishes at the outlet), with its error from the nodes' standard
    errors (independent).

    Returns
    -------
    dict
        ``rho_s, ratio, ratio_se, n`` (nodes used); NaN with fewer than three nodes.
    """
    from scipy.stats import spearmanr

    prof = axis_profile(contact, "pc")
    z, p, se = prof["z"].to_numpy(float), prof["value"].to_numpy(float), prof["value_se"].to_numpy(float)
    sel = np.isfinite(z) & np.isfinite(p) & (z >= -1e-12) & (z <= span * R + 1e-12)
    out = dict(rho_s=np.nan, ratio=np.nan, ratio_se=np.nan, n=int(sel.sum()))
    if sel.sum() < 3:
        return out
    z, p, se = z[sel], p[sel], se[sel]
    out["rho_s"] = float(spearmanr(z, p).statistic)
    lo, hi = int(np.argmin(z)), int(np.argmax(z))
    if p[hi] > 0:
        out.update(ratio=float(p[lo] / p[hi]),
                   ratio_se=float(np.hypot(se[lo] / p[hi], p[lo] * se[hi] / p[hi] ** 2)))
    return out


def partial_ratio(fields: pd.DataFrame, z: float, phi_min: float = PHI_MIN_PARTIAL) -> dict:
    """Kinetic pressure per unit partial volume fraction of the smallest size over the largest's, on the axis.

    .. math:: \\rho_{sl} = \\frac{p^k_1/\\phi_1}{p^k_{n}/\\phi_{n}}

    at the axis node nearest height ``z`` (species ids ordered by size, 1 the
    smallest), from :func:`partial_over_fraction`; the paper's figure 12 shows
    :math:`\\rho_{sl} > 1` ("the small particles carry a higher fraction of
    kinetic stress respect to their concentration").  Also the plain ratio of
    the partial pressures largest over smallest, :math:`p^k_n/p^k_1` (its
    figure 11: "larger for bigger particles").  Errors are propagated with the
    two species taken as independent.

    Returns
    -------
    dict
        ``ratio, ratio_se, pk_large_over_small, z_node, small, large`` (species ids);
        NaN without two species or at a node without both.
    """
    table = partial_over_fraction(fields, phi_min)
    ids = species_ids(table, "pk_over_phi")
    out = dict(ratio=np.nan, ratio_se=np.nan, pk_large_over_small=np.nan, z_node=np.nan,
               small=ids[0] if ids else None, large=ids[-1] if ids else None)
    if len(ids) < 2 or not np.isfinite(z):
        return out
    small, large = ids[0], ids[-1]
    a = axis_profile(table, f"pk_over_phi_s{small}")
    b = axis_profile(table, f"pk_over_phi_s{large}")
    i = int(np.argmin(np.abs(a["z"].to_numpy(float) - z)))
    va, sa, vb, sb = (float(t[c].iloc[i]) for t in (a, b) for c in ("value", "value_se"))
    pa = axis_profile(fields, f"pk_s{small}")["value"].iloc[i]
    pb = axis_profile(fields, f"pk_s{large}")["value"].iloc[i]
    out["z_node"] = float(a["z"].iloc[i])
    if vb != 0 and np.isfinite(va) and np.isfinite(vb):
        out.update(ratio=float(va / vb), ratio_se=float(np.hypot(sa / vb, va * sb / vb ** 2)))
    if pa:
        out["pk_large_over_small"] = float(pb / pa)
    return out
