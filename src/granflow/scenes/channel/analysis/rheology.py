"""Local rheology and flow zones of the channel profile (Debnath et al. 2022, sections 3.4 and 4)."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from .profile import JOP2015, PHI_AD, PHI_PLUG, WALL_LAYER, MuIParameters, channel_width, downward_speed, field_and_error


# --------------------------------------------------------------------------- rheology
def _mirror_extended_gradient_operator(x: np.ndarray, W: float) -> np.ndarray:
    """Matrix :math:`D` with :math:`du/dx \\approx D u` on the folded bins.

    The folded (even) profile is continued by its mirror image beyond
    :math:`W/2`, differentiated with :func:`numpy.gradient` (second-order
    central differences on the non-uniform grid, first order at the wall),
    and the mirrored columns are added back onto their originals, so that
    :math:`du/dx = 0` at the centre comes out by symmetry, not by a one-sided
    difference.
    """
    n = len(x)
    centre_bin = abs(x[-1] - 0.5 * W) < 1e-9 * max(W, 1.0)
    mirror_idx = np.arange(n - 2, -1, -1) if centre_bin else np.arange(n - 1, -1, -1)
    x_ext = np.concatenate([x, W - x[mirror_idx]])
    d_ext = np.gradient(np.eye(len(x_ext)), x_ext, axis=0)[:n]
    d = d_ext[:, :n].copy()
    np.add.at(d.T, mirror_idx, d_ext[:, n:].T)
    return d


def shear_rate_and_error(folded: pd.DataFrame, W: float) -> tuple[np.ndarray, np.ndarray]:
    """:math:`\\dot\\gamma = du/dx` (``u = -u_y``, the downward speed) per folded bin and its error.

    From the profile's own shear-rate column where it has one (``du_y_dx``, :func:`postproc.channel_profile.
    shear_rate`: each block's and sub-block's profile differenced, so its error holds no change of speed of the
    whole channel, which moves every bin alike); else the folded speed differenced
    (:func:`_mirror_extended_gradient_operator`) with the bins' errors propagated as independent, which counts
    that common change of speed into every gradient (an upper bound)."""
    if "du_y_dx" in folded:
        gd, gd_se = field_and_error(folded, "du_y_dx")
        return -gd, gd_se
    u, u_se = downward_speed(folded)
    d = _mirror_extended_gradient_operator(folded["x"].to_numpy(dtype=float), W)
    touches = np.abs(d) > 0  # bins entering each gradient
    gd = d @ np.nan_to_num(u, nan=0.0)
    gd[touches @ ~np.isfinite(u)] = np.nan
    gd_se = np.sqrt((d**2) @ np.nan_to_num(u_se, nan=0.0) ** 2)
    gd_se[touches @ ~np.isfinite(u_se)] = np.nan
    return gd, gd_se


def rheology(folded: pd.DataFrame, W: float | None = None, rho_p: float = 1.0,
             params: MuIParameters = JOP2015) -> pd.DataFrame:
    """Local rheology of the folded profile (paper, figures 8, 9, 11).

    Per bin, with :math:`u = -u_y` the downward speed and :math:`x` the
    distance from the wall:

    .. math::
        \\dot\\gamma = \\frac{du}{dx}, \\qquad
        \\mu = \\frac{|\\sigma_{xy}|}{\\sigma_{xx}}, \\qquad
        I = \\frac{d_p|\\dot\\gamma|}{\\sqrt{\\sigma_{xx}/\\rho_p}}, \\qquad
        P = -\\sigma_{xy}\\frac{du_y}{dx} = \\sigma_{xy}\\,\\dot\\gamma,

    :math:`P` being the shear production of fluctuation energy (eq. B7), and
    :math:`\\Omega_z/\\omega_z` with the vorticity :math:`\\omega_z = du_y/dx =
    -\\dot\\gamma` in the same (raw) frame as :math:`\\Omega_z`, so that the
    ratio is 1/2 where particles co-rotate with the material.  The gradient
    is a linear operator (see :func:`_mirror_extended_gradient_operator`), so
    its standard error is propagated exactly, :math:`\\mathrm{se}(\\dot\\gamma)_i
    = \\sqrt{\\sum_j D_{ij}^2 \\mathrm{se}(u)_j^2}`; the others by first-order
    propagation with independent errors.  ``mu_B3`` and ``phi_B4`` are eqs.
    (B3)-(B4) evaluated at the measured :math:`I`.

    Parameters
    ----------
    folded : DataFrame
        Output of :func:`fold_profile`.
    W : float, optional
        Channel width; default ``folded.attrs["W"]``.
    rho_p : float
        Particle density.
    params : MuIParameters
        Constants for (B3)-(B4).

    Returns
    -------
    DataFrame
        Columns ``x gamma_dot gamma_dot_se mu mu_se I I_se mu_B3 phi_B4
        Omega_z_over_omega_z Omega_z_over_omega_z_se shear_production
        shear_production_se``; ``attrs["unavailable"]`` maps NaN columns to the reason.
    """
    W = channel_width(folded, W)
    x = folded["x"].to_numpy(dtype=float)
    gd, gd_se = shear_rate_and_error(folded, W)

    sxx, sxx_se = field_and_error(folded, "sigma_xx")
    sxy, sxy_se = field_and_error(folded, "sigma_xy")
    omz, omz_se = field_and_error(folded, "Omega_z")
    unavailable = {}
    with np.errstate(divide="ignore", invalid="ignore"):
        pos = sxx > 0
        mu = np.where(pos, np.abs(sxy) / sxx, np.nan)
        mu_se = np.hypot(sxy_se / sxx, mu * sxx_se / sxx)
        I = np.where(pos, np.abs(gd) / np.sqrt(sxx / rho_p), np.nan)
        I_se = np.hypot(gd_se / np.sqrt(sxx / rho_p), 0.5 * I * sxx_se / sxx)
        omega_z = -gd  # raw-frame vorticity du_y/dx, same frame as Omega_z
        ratio = omz / omega_z
        ratio_se = np.hypot(omz_se, ratio * gd_se) / np.abs(omega_z)
        prod = sxy * gd
        prod_se = np.hypot(sxy_se * gd, sxy * gd_se)
    if "sigma_xx" not in folded:
        unavailable.update(mu="no sigma_xx column", I="no sigma_xx column")
    if "sigma_xy" not in folded:
        unavailable.update(mu="no sigma_xy column", shear_production="no sigma_xy column")
    if "Omega_z" not in folded:
        unavailable["Omega_z_over_omega_z"] = "no Omega_z column"
    if "u_y_se" not in folded and "du_y_dx_se" not in folded:
        unavailable["gamma_dot_se"] = "no u_y_se or du_y_dx_se column"
    out = pd.DataFrame({
        "x": x, "gamma_dot": gd, "gamma_dot_se": gd_se, "mu": mu, "mu_se": mu_se,
        "I": I, "I_se": I_se, "mu_B3": params.mu(I), "phi_B4": params.phi(I),
        "Omega_z_over_omega_z": ratio, "Omega_z_over_omega_z_se": ratio_se,
        "shear_production": prod, "shear_production_se": prod_se,
    })
    out.attrs["unavailable"] = unavailable
    return out


# --------------------------------------------------------------------------- zones
@dataclass
class FlowZones:
    """Zone boundaries (distance from the wall, :math:`d_p`) and per-bin labels.

    Attributes
    ----------
    x_wall_layer : float
        Edge of the wall shearing layer (red line in the paper's figures).
    x_loose_dense : float
        Where :math:`\\phi` crosses :math:`\\phi_{ad}`; NaN when there is no loose
        zone (the crossing lies inside the wall layer, or never happens).
    x_dense_plug : float
        Start of the plug: from here to the centre the shear rate is zero to within
        the measurement's accuracy, :math:`|\\dot\\gamma| \\le \\max(2\\,\\mathrm{se}, s_c)`
        (:func:`flow_zones`); NaN if there is no such region.
    x_plug_phi063 : float
        Alternative plug edge: where :math:`\\phi` first reaches 0.63.
    labels : ndarray of str
        ``"wall"``, ``"loose"``, ``"dense"`` or ``"plug"`` per folded bin.
    reason : str
    """

    x_wall_layer: float
    x_loose_dense: float
    x_dense_plug: float
    x_plug_phi063: float
    labels: np.ndarray = field(default_factory=lambda: np.array([], dtype=object))
    reason: str = ""


def _first_crossing(x: np.ndarray, y: np.ndarray, level: float) -> float:
    """First :math:`x` (from the wall) where ``y`` rises to ``level``, linear interpolation."""
    ok = np.isfinite(y)
    x, y = x[ok], y[ok]
    above = np.flatnonzero(y >= level)
    if len(above) == 0:
        return float("nan")
    k = int(above[0])
    if k == 0:
        return float(x[0])
    return float(x[k - 1] + (level - y[k - 1]) * (x[k] - x[k - 1]) / (y[k] - y[k - 1]))


def flow_zones(folded: pd.DataFrame, rheo: pd.DataFrame, phi_ad: float = PHI_AD,
               wall_layer: float = WALL_LAYER, phi_plug: float = PHI_PLUG,
               n_se: float = 2.0, floor_from: float = 0.35) -> FlowZones:
    """Zones of the channel flow by the paper's criteria (section 3.2).

    * wall shearing layer: within ``wall_layer`` (2 :math:`d_p`) of the wall;
    * dense / loose boundary: :math:`\\phi = \\phi_{ad} = 0.587`, found scanning
      from the centre towards the wall (the last bin with
      :math:`\\phi \\ge \\phi_{ad}` and its outer neighbour, interpolated);
    * plug / dense boundary: the inner edge of the outermost bin from which,
      all the way to the centre, :math:`|\\dot\\gamma| \\le \\max(n_{se}\\,\\mathrm{se}(\\dot\\gamma), s_c)`
      (:math:`n_{se} = 2`), "zero to within the simulation accuracy" (§3.2): ``se`` the time
      average's error, :math:`s_c` three times the rms of :math:`\\dot\\gamma` over the bins of the channel's
      central 30 % (:math:`x \\ge` ``floor_from`` :math:`W`, 0.35 W): the scatter a plug's frozen
      configuration leaves in a gradient over the whole window, which ``se`` (what changes in
      time) does not hold;
    * alternative plug edge: first :math:`x` where :math:`\\phi` reaches 0.63.

    Labels use bin centres: ``wall`` if :math:`x < x_{wall}`, else ``plug`` beyond
    the plug edge, else ``loose`` below the dense/loose boundary, else ``dense``.
    """
    x = folded["x"].to_numpy(dtype=float)
    x_lo = folded["x_lo"].to_numpy(dtype=float)
    phi, _ = field_and_error(folded, "phi")
    gd = rheo["gamma_dot"].to_numpy(dtype=float)
    gd_se = rheo["gamma_dot_se"].to_numpy(dtype=float)
    reasons = []
    nan = float("nan")
    x_wall = float(wall_layer) if x[-1] > wall_layer else nan

    x_ld = nan
    if "phi" not in folded:
        reasons.append("no phi column: dense/loose boundary unavailable")
    else:
        ok = np.flatnonzero(np.isfinite(phi))
        below = [i for i in ok if phi[i] < phi_ad]
        if below:
            # scan from the centre: the first bin below phi_ad seen from the centre
            inner = [i for i in ok if phi[i] >= phi_ad]
            k = max(below)
            nxt = [i for i in inner if i > k]
            if not nxt:
                reasons.append("phi below phi_ad up to the centre: no dense zone")
            else:
                j = min(nxt)
                x_cross = float(x[k] + (phi_ad - phi[k]) * (x[j] - x[k]) / (phi[j] - phi[k]))
                if np.isfinite(x_wall) and x_cross > x_wall:
                    x_ld = x_cross
                else:
                    reasons.append("phi reaches phi_ad inside the wall layer: no loose zone")
        else:
            reasons.append("phi never below phi_ad: no loose zone")

    x_dp = nan
    if not np.isfinite(gd_se).any():
        reasons.append("no shear-rate standard error: plug boundary unavailable")
    else:
        # <= so that the centre bin, whose gradient is exactly zero by symmetry
        # (with zero error), counts as unsheared
        # 3 × the central 30 %'s rms shear rate: what a frozen configuration leaves in a gradient (see above);
        # a bin of that scatter passes 3 rms once in ~400
        W = channel_width(folded, None)
        central = (x >= floor_from * W) & np.isfinite(gd)
        floor = 3.0 * float(np.sqrt(np.mean(gd[central] ** 2))) if central.sum() >= 3 else 0.0
        zero = np.abs(gd) <= np.maximum(n_se * gd_se, floor)
        if zero[-1]:
            k = len(zero) - 1
            while k > 0 and zero[k - 1]:
                k -= 1
            x_dp = float(x_lo[k])
        else:
            reasons.append("shear rate distinguishable from zero at the centre: no plug")

    x_p63 = _first_crossing(x, phi, phi_plug)

    labels = np.full(len(x), "dense", dtype=object)
    if np.isfinite(x_ld):
        labels[x < x_ld] = "loose"
    if np.isfinite(x_dp):
        labels[x >= x_dp] = "plug"
    if np.isfinite(x_wall):
        labels[x < x_wall] = "wall"
    return FlowZones(x_wall, x_ld, x_dp, x_p63, labels, "; ".join(reasons))
