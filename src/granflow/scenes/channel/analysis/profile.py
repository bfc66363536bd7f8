"""Scene analyses for the vertical channel (Debnath, Kesava Rao & Kumaran 2022).

Input is a cross-channel profile: a :class:`pandas.DataFrame` with one row per
bin across :math:`x` (walls at :math:`x = 0` and :math:`x = W`), columns ``x``
(bin centre), ``x_lo``, ``x_hi``, ``n``, ``phi``, ``rho``, ``u_x u_y u_z`` and
optionally ``Omega_x Omega_y Omega_z``, ``T``, ``sigma_xx ... sigma_yz``
(total stress, compressive positive), ``sigmac_*`` and ``sigmak_*``; every
field ``f`` has a standard error column ``f_se``.  A missing optional field
makes the analyses that need it report NaN plus a reason, never raise.

Conventions
-----------
* Units: lengths in :math:`d_p`, time in :math:`\\sqrt{d_p/g}`, :math:`\\rho_p = 1`.
* Gravity points along :math:`-y`; the analyses use the downward speed
  :math:`u = -u_y` (positive), which is the paper's :math:`u_y` (the paper
  points :math:`y` downwards).
* After :func:`fold_profile`, :math:`x` is the distance from the nearest wall,
  :math:`0 \\le x \\le W/2`, as in the paper's figures.
* Frame-dependent signs (shear stress, spin) are handled so that every
  reported ratio is frame independent: :math:`\\Omega_z/\\omega_z` uses the
  raw-frame vorticity :math:`\\omega_z = du_y/dx`; the shear production
  :math:`-\\sigma_{xy}\\,du_y/dx = \\sigma_{xy}\\,du/dx` is a scalar; the
  momentum-balance slope is compared with :math:`\\rho g_y` for the gravity
  direction given (``gravity_y = -1`` here, ``+1`` in the paper's frame).
"""
from __future__ import annotations

import re
from dataclasses import dataclass

import numpy as np
import pandas as pd
from scipy.optimize import curve_fit

#: Volume fraction of arrested dynamics, boundary of dense and loose shearing zones.
PHI_AD = 0.587
#: Volume fraction in the plug (paper, section 3.2): alternative plug criterion.
PHI_PLUG = 0.63
#: Thickness of the wall shearing layer, d_p ("within about two particle diameters").
WALL_LAYER = 2.0
#: Exponent of the universal profile, eq. (3.1).
EXPONENT_EQ31 = 3.0

COORDINATE_COLUMNS = ("x", "x_lo", "x_hi")
_ODD_COMPONENT = re.compile(r"^(sigma|sigmac|sigmak)_(xy|yx|xz|zx)$")


@dataclass(frozen=True)
class MuIParameters:
    """Constants of the :math:`\\mu(I)`-:math:`\\phi(I)` rheology, eqs. (B3)-(B4).

    Defaults are the published model constants of Jop (2015) that the paper
    draws as comparison curves.
    """

    mu_s: float = 0.384
    mu_inf: float = 0.625
    I_0: float = 0.3
    phi_max: float = 0.6
    phi_min: float = 0.4

    def mu(self, I):
        """Eq. (B3), :math:`\\mu(I) = \\mu_s + (\\mu_\\infty - \\mu_s)/(1 + I_0/I)`."""
        I = np.asarray(I, dtype=float)
        with np.errstate(divide="ignore", invalid="ignore"):
            return self.mu_s + (self.mu_inf - self.mu_s) / (1.0 + self.I_0 / I)

    def phi(self, I):
        """Eq. (B4), :math:`\\phi(I) = \\phi_{max} - (\\phi_{max} - \\phi_{min}) I`."""
        return self.phi_max - (self.phi_max - self.phi_min) * np.asarray(I, dtype=float)


JOP2015 = MuIParameters()


# --------------------------------------------------------------------------- helpers
def field_and_error(df: pd.DataFrame, name: str) -> tuple[np.ndarray, np.ndarray]:
    """Values and standard errors of column ``name``; NaN arrays when absent."""
    n = len(df)
    val = df[name].to_numpy(dtype=float) if name in df else np.full(n, np.nan)
    se = df[f"{name}_se"].to_numpy(dtype=float) if f"{name}_se" in df else np.full(n, np.nan)
    return val, se


def downward_speed(df: pd.DataFrame) -> tuple[np.ndarray, np.ndarray]:
    """Downward speed :math:`u = -u_y` and its standard error, :math:`\\sqrt{g d_p}`."""
    if "u_y" not in df:
        raise KeyError("profile has no u_y column; the channel analyses need the velocity")
    u_y, se = field_and_error(df, "u_y")
    return -u_y, se


def bin_widths(df: pd.DataFrame) -> np.ndarray:
    return (df["x_hi"] - df["x_lo"]).to_numpy(dtype=float)


def width_weighted_mean(values: np.ndarray, width: np.ndarray) -> float:
    ok = np.isfinite(values) & np.isfinite(width)
    if not ok.any() or width[ok].sum() <= 0:
        return float("nan")
    return float(np.sum(values[ok] * width[ok]) / np.sum(width[ok]))


def _r_squared(y: np.ndarray, y_model: np.ndarray) -> float:
    ss_res = float(np.sum((y - y_model) ** 2))
    ss_tot = float(np.sum((y - np.mean(y)) ** 2))
    return 1.0 - ss_res / ss_tot if ss_tot > 0 else float("nan")


def mirror_parity(name: str) -> int:
    """Sign a profile column takes under the mirror :math:`x \\to W - x`.

    The mirror is the reflection :math:`R = \\mathrm{diag}(-1, 1, 1)` about the
    centre plane.  Scalars (``n``, ``phi``, ``rho``, ``T``) are even.  A polar
    vector transforms as :math:`v' = R v`: only :math:`u_x` changes sign.  The
    angular velocity is an axial vector, :math:`\\Omega' = \\det(R)\\, R\\,\\Omega
    = -R\\,\\Omega`: :math:`\\Omega_x` is even, :math:`\\Omega_y` and
    :math:`\\Omega_z` are odd (consistent with :math:`\\Omega_z \\approx
    \\tfrac12 du_y/dx`, odd because :math:`u_y` is even).  A rank-2 tensor
    transforms as :math:`\\sigma' = R \\sigma R^T`: components with exactly one
    :math:`x` index, :math:`\\sigma_{xy}` and :math:`\\sigma_{xz}`, are odd.

    Returns
    -------
    int
        ``-1`` for odd fields, ``+1`` otherwise (unknown columns count as even).
    """
    if name in ("u_x", "Omega_y", "Omega_z", "du_y_dx") or _ODD_COMPONENT.match(name):
        return -1
    return 1


# --------------------------------------------------------------------------- folding
def fold_profile(df: pd.DataFrame, W: float, odd_fields=None) -> pd.DataFrame:
    """Average the two halves of a symmetric channel profile.

    Bin :math:`i` is mirrored onto bin :math:`n-1-i`; bins must be placed
    symmetrically about :math:`W/2`.  For every field :math:`f` with parity
    :math:`s = \\pm 1` (see :func:`mirror_parity`),

    .. math::
        f^{fold}_i = \\tfrac12 (f_i + s f_{n-1-i}), \\qquad
        \\mathrm{se}^{fold}_i = \\tfrac12 \\sqrt{\\mathrm{se}_i^2 + \\mathrm{se}_{n-1-i}^2},

    treating the two halves as independent measurements.  Where one side is
    NaN (an empty bin) the other side is used alone.  With an odd number of
    bins the centre bin is its own mirror: even fields keep their value and
    error, odd fields are set to zero (their symmetric part).

    Parameters
    ----------
    df : DataFrame
        Unfolded profile (input contract in the module docstring).
    W : float
        Channel width, :math:`d_p`.
    odd_fields : iterable of str, optional
        Columns that change sign; default from :func:`mirror_parity`.

    Returns
    -------
    DataFrame
        Bins with :math:`0 \\le x \\le W/2`, :math:`x` the distance from the wall;
        the centre bin of an odd bin count has ``x_hi`` clipped to :math:`W/2`
        so bin widths sum to :math:`W/2`.  Adds the downward speed ``u`` and
        ``u_se``.  ``attrs["W"]`` holds the width.
    """
    df = df.sort_values("x").reset_index(drop=True)
    n = len(df)
    if n < 2:
        raise ValueError("a profile needs at least two bins to fold")
    x_lo = df["x_lo"].to_numpy(dtype=float)
    x_hi = df["x_hi"].to_numpy(dtype=float)
    tol = 1e-6 * max(W, 1.0)
    wall = x_lo[0]  # 0 by contract; any offset is removed below
    if abs(x_hi[-1] - wall - W) > tol:
        raise ValueError(f"bins span {x_hi[-1] - wall:g} d_p, not the channel width W = {W:g}")
    if np.any(np.abs(x_lo + x_hi[::-1] - 2 * wall - W) > tol):
        raise ValueError("bins are not symmetric about W/2; cannot fold")
    odd = set(odd_fields) if odd_fields is not None else None
    half = (n + 1) // 2
    mirror = n - 1 - np.arange(half)
    out = df.iloc[:half].copy()
    fields = [c for c in df.columns if c not in COORDINATE_COLUMNS and not c.endswith("_se")
              and pd.api.types.is_numeric_dtype(df[c])]
    for name in fields:
        sign = (-1 if name in odd else 1) if odd is not None else mirror_parity(name)
        a, a_se = field_and_error(df, name)
        a, a_se = a[:half], a_se[:half]
        b, b_se = field_and_error(df, name)
        b, b_se = sign * b[mirror], b_se[mirror]
        both = np.isfinite(a) & np.isfinite(b)
        val = np.where(both, 0.5 * (a + b), np.where(np.isfinite(a), a, b))
        se = np.where(both, 0.5 * np.sqrt(a_se**2 + b_se**2), np.where(np.isfinite(a), a_se, b_se))
        if n % 2 == 1:  # centre bin is its own mirror
            val[-1] = a[-1] if sign == 1 else 0.0
            se[-1] = a_se[-1]
        out[name] = val
        if f"{name}_se" in df:
            out[f"{name}_se"] = se
    for col in COORDINATE_COLUMNS:
        out[col] = out[col] - wall
    if n % 2 == 1:
        out.loc[out.index[-1], "x_hi"] = 0.5 * W
    if "u_y" in out:
        out["u"], out["u_se"] = downward_speed(out)
    out.attrs["W"] = float(W)
    return out.reset_index(drop=True)


def channel_width(folded: pd.DataFrame, W: float | None) -> float:
    if W is not None:
        return float(W)
    if "W" in folded.attrs:
        return float(folded.attrs["W"])
    return 2.0 * float(folded["x_hi"].iloc[-1])


# --------------------------------------------------------------------------- velocity
@dataclass(frozen=True)
class VelocityScales:
    """Velocity scales of the channel profile (paper, figures 4-5).

    Attributes
    ----------
    u_slip : float
        Slip velocity: downward speed of the bin nearest the wall, :math:`\\sqrt{g d_p}`.
    u_max : float
        Maximum downward speed (the centre, plug), :math:`\\sqrt{g d_p}`.
    delta_095 : float
        Shear-layer thickness :math:`\\delta_{0.95}`, distance from the wall where
        :math:`(u-u_{slip})/(u_{max}-u_{slip}) = 0.95`, :math:`d_p`.
    u_slip_se, u_max_se : float
        Standard errors.
    reason : str
        Why an item is NaN, empty otherwise.
    """

    u_slip: float
    u_max: float
    delta_095: float
    u_slip_se: float = float("nan")
    u_max_se: float = float("nan")
    reason: str = ""

    @property
    def ratio(self) -> float:
        """:math:`u_{max}/u_{slip}` (NaN when :math:`u_{slip} \\le 0`)."""
        return self.u_max / self.u_slip if self.u_slip > 0 else float("nan")

    @property
    def ratio_se(self) -> float:
        """Standard error of the ratio, errors of the two speeds taken as independent,

        .. math:: \\mathrm{se}(r) = r\\sqrt{(\\mathrm{se}_{max}/u_{max})^2 + (\\mathrm{se}_{slip}/u_{slip})^2}.
        """
        r = self.ratio
        return float(abs(r) * np.hypot(self.u_max_se / self.u_max, self.u_slip_se / self.u_slip)) \
            if np.isfinite(r) else float("nan")


def scaled_velocity(folded: pd.DataFrame, scales: VelocityScales) -> np.ndarray:
    """Scaled velocity :math:`(u - u_{slip})/(u_{max} - u_{slip})` per folded bin."""
    u, _ = downward_speed(folded)
    return (u - scales.u_slip) / (scales.u_max - scales.u_slip)


def velocity_scales(folded: pd.DataFrame) -> VelocityScales:
    """Slip velocity, maximum velocity and shear-layer thickness.

    :math:`u_{slip}` is the speed of the interval closest to the wall (the
    paper's definition, not the particle surface velocity at contact),
    :math:`u_{max}` the maximum of the folded profile, and
    :math:`\\delta_{0.95}` the first distance from the wall where the scaled
    velocity reaches 0.95, linearly interpolated between bin centres.

    Parameters
    ----------
    folded : DataFrame
        Output of :func:`fold_profile`.
    """
    u, se = downward_speed(folded)
    x = folded["x"].to_numpy(dtype=float)
    ok = np.isfinite(u)
    if ok.sum() < 2:
        return VelocityScales(np.nan, np.nan, np.nan, reason="fewer than two bins with a velocity")
    i_wall = int(np.flatnonzero(ok)[0])
    i_max = int(np.nanargmax(u))
    u_slip, u_max = float(u[i_wall]), float(u[i_max])
    reason = ""
    delta = float("nan")
    if not u_max > u_slip:
        reason = "no shear: u_max does not exceed u_slip"
    else:
        s = (u - u_slip) / (u_max - u_slip)
        k = int(np.flatnonzero(ok & (s >= 0.95) & (np.arange(len(s)) > i_wall))[0])
        j = max(i for i in range(k) if ok[i])
        delta = float(x[j] + (0.95 - s[j]) * (x[k] - x[j]) / (s[k] - s[j]))
    if not u_slip > 0:
        reason = (reason + "; " if reason else "") + "u_slip not positive, ratio undefined"
    return VelocityScales(u_slip, u_max, delta, float(se[i_wall]), float(se[i_max]), reason)


@dataclass(frozen=True)
class UniversalFit:
    """Fit of the scaled profile to :math:`1 - \\exp(-a x/\\delta_{0.95})`.

    Attributes
    ----------
    a, a_se : float
        Fitted exponent and its standard error (eq. 3.1 has :math:`a = 3`).
    r2 : float
        Coefficient of determination of the free fit.
    r2_a3 : float
        Coefficient of determination of eq. (3.1) with :math:`a = 3` fixed.
    n_points : int
    reason : str
    """

    a: float
    a_se: float
    r2: float
    r2_a3: float
    n_points: int = 0
    reason: str = ""


def universal_profile(xi, a: float = EXPONENT_EQ31):
    """Eq. (3.1): :math:`(u-u_{slip})/(u_{max}-u_{slip}) = 1 - \\exp(-a\\,x/\\delta_{0.95})`."""
    return 1.0 - np.exp(-a * np.asarray(xi, dtype=float))


def fit_universal_profile(folded: pd.DataFrame, scales: VelocityScales) -> UniversalFit:
    """Fit the exponent of the universal velocity profile, eq. (3.1).

    The scaled velocity :math:`s = (u-u_{slip})/(u_{max}-u_{slip})` is fitted
    against :math:`\\xi = x/\\delta_{0.95}` by unweighted least squares
    (:func:`scipy.optimize.curve_fit`) with the exponent :math:`a` free,

    .. math:: s = 1 - e^{-a \\xi}, \\qquad R^2 = 1 - \\frac{\\sum (s - \\hat s)^2}{\\sum (s - \\bar s)^2}.

    The wall bin is left out: it defines :math:`u_{slip}`, so :math:`s \\equiv 0`
    there by construction and it carries no information on the shape.

    Parameters
    ----------
    folded : DataFrame
        Output of :func:`fold_profile`.
    scales : VelocityScales
        From :func:`velocity_scales` (or built by hand).
    """
    nan = float("nan")
    if not (np.isfinite(scales.delta_095) and scales.delta_095 > 0 and scales.u_max > scales.u_slip):
        return UniversalFit(nan, nan, nan, nan, 0, scales.reason or "no shear-layer thickness")
    xi = folded["x"].to_numpy(dtype=float) / scales.delta_095
    s = scaled_velocity(folded, scales)
    ok = np.isfinite(xi) & np.isfinite(s)
    ok[: int(np.flatnonzero(ok)[0]) + 1] = False  # drop the wall (slip) bin
    if ok.sum() < 3:
        return UniversalFit(nan, nan, nan, nan, int(ok.sum()), "fewer than three bins to fit")
    xi, s = xi[ok], s[ok]
    try:
        popt, pcov = curve_fit(universal_profile, xi, s, p0=[EXPONENT_EQ31])
    except (RuntimeError, ValueError) as err:
        return UniversalFit(nan, nan, nan, _r_squared(s, universal_profile(xi)), len(s), f"fit failed: {err}")
    a = float(popt[0])
    return UniversalFit(a, float(np.sqrt(pcov[0, 0])), _r_squared(s, universal_profile(xi, a)),
                        _r_squared(s, universal_profile(xi, EXPONENT_EQ31)), int(ok.sum()))


def mean_velocity_eq32(scales: VelocityScales, W: float, profile: pd.DataFrame | None = None) -> dict:
    """Mean velocity from eq. (3.2) and, given a profile, the measured one.

    .. math::
        \\bar u = u_{max} - \\frac{2\\delta_{0.95}(u_{max}-u_{slip})
                  \\left(1 - e^{-3W/2\\delta_{0.95}}\\right)}{3W},

    the average over :math:`0 \\le x \\le W/2` of eq. (3.1).  The measured mean
    is the bin-width-weighted mean of :math:`u` over the profile (full or
    folded: the folded bins cover exactly half the channel).

    Returns
    -------
    dict
        ``u_mean_eq32`` and ``u_mean_measured`` (NaN without a profile), :math:`\\sqrt{g d_p}`.
    """
    d = scales.delta_095
    du = scales.u_max - scales.u_slip
    eq32 = scales.u_max - 2.0 * d * du * (1.0 - np.exp(-1.5 * W / d)) / (3.0 * W) \
        if np.isfinite(d) and d > 0 else float("nan")
    measured = float("nan")
    if profile is not None:
        u, _ = downward_speed(profile)
        measured = width_weighted_mean(u, bin_widths(profile))
    return {"u_mean_eq32": float(eq32), "u_mean_measured": measured}


# --------------------------------------------------------------------------- stress
@dataclass(frozen=True)
class StressChecks:
    """Momentum-balance checks on the stress profile (paper, eqs. B1-B2, figures 6-7).

    Attributes
    ----------
    sigma_xx_mean, sigma_xx_rel_std : float
        Mean of :math:`\\sigma_{xx}` over the interior bins and its relative
        standard deviation (zero for a perfectly flat profile, eq. B1).
    sigma_xy_slope, sigma_xy_slope_se, sigma_xy_r2 : float
        Slope of :math:`\\sigma_{xy}(x)` from a line through the centre, its
        standard error and :math:`R^2`.
    rho_bulk : float
        :math:`\\rho_p\\,\\langle\\phi\\rangle` over the whole profile.
    slope_over_rho_g : float
        Slope divided by the momentum-balance prediction :math:`\\rho_{bulk} g_y`.
    mu_wall : float
        :math:`|\\sigma_{xy}/\\sigma_{xx}|` in the wall bins (mean of both walls).
    reason : str
    """

    sigma_xx_mean: float
    sigma_xx_rel_std: float
    sigma_xy_slope: float
    sigma_xy_slope_se: float
    sigma_xy_r2: float
    rho_bulk: float
    slope_over_rho_g: float
    mu_wall: float
    reason: str = ""


def stress_checks(profile: pd.DataFrame, gravity_y: float = -1.0, rho_p: float = 1.0) -> StressChecks:
    """Flatness of :math:`\\sigma_{xx}`, slope of :math:`\\sigma_{xy}` and wall friction.

    With compressive-positive stress :math:`\\sigma = -\\tau` and gravity
    :math:`g_y` (units of :math:`g`), the steady fully developed momentum balance is

    .. math::
        \\frac{d\\sigma_{xx}}{dx} = 0, \\qquad \\frac{d\\sigma_{xy}}{dx} = \\rho\\, g_y ,

    which is the paper's (B2) for :math:`g_y = +1` (its :math:`y` points down);
    here gravity points along :math:`-y`, so :math:`g_y = -1` and
    :math:`\\sigma_{xy}` decreases from :math:`+\\rho g W/2` at :math:`x = 0`.
    The slope is fitted through the centre,
    :math:`\\sigma_{xy} = b\\,(x - W/2)`, over the interior bins (the two wall
    bins are excluded from the flatness and slope measures, as wall contacts
    make them special), and compared with :math:`\\rho_{bulk} g_y`,
    :math:`\\rho_{bulk} = \\rho_p \\langle\\phi\\rangle` (bin-width weighted).

    Parameters
    ----------
    profile : DataFrame
        Unfolded profile spanning the full width (walls at both ends).
    gravity_y : float
        y component of gravity in units of g.
    rho_p : float
        Particle density (1 in the project's units).
    """
    nan = float("nan")
    reasons = []
    profile = profile.sort_values("x").reset_index(drop=True)
    x = profile["x"].to_numpy(dtype=float)
    W = float(profile["x_hi"].iloc[-1] + profile["x_lo"].iloc[0])
    interior = np.zeros(len(x), dtype=bool)
    interior[1:-1] = True
    sxx, _ = field_and_error(profile, "sigma_xx")
    sxy, _ = field_and_error(profile, "sigma_xy")
    phi, _ = field_and_error(profile, "phi")

    sxx_mean = sxx_rel = nan
    if "sigma_xx" not in profile:
        reasons.append("no sigma_xx column")
    else:
        v = sxx[interior & np.isfinite(sxx)]
        if len(v) >= 2:
            sxx_mean = float(np.mean(v))
            sxx_rel = float(np.std(v, ddof=1) / abs(sxx_mean)) if sxx_mean != 0 else nan

    slope = slope_se = r2 = nan
    if "sigma_xy" not in profile:
        reasons.append("no sigma_xy column")
    else:
        ok = interior & np.isfinite(sxy)
        xi, y = x[ok] - 0.5 * W, sxy[ok]
        if len(y) >= 3 and np.sum(xi**2) > 0:
            slope = float(np.sum(xi * y) / np.sum(xi**2))
            resid = y - slope * xi
            slope_se = float(np.sqrt(np.sum(resid**2) / (len(y) - 1) / np.sum(xi**2)))
            r2 = _r_squared(y, slope * xi)

    rho_bulk = rho_p * width_weighted_mean(phi, bin_widths(profile)) if "phi" in profile else nan
    if "phi" not in profile:
        reasons.append("no phi column for the bulk density")
    ratio = slope / (rho_bulk * gravity_y) if np.isfinite(rho_bulk) and rho_bulk > 0 else nan

    with np.errstate(divide="ignore", invalid="ignore"):
        mu_ends = np.abs(sxy[[0, -1]] / sxx[[0, -1]])
    mu_wall = float(np.nanmean(mu_ends)) if np.isfinite(mu_ends).any() else nan
    return StressChecks(sxx_mean, sxx_rel, slope, slope_se, r2, rho_bulk, ratio, mu_wall, "; ".join(reasons))
