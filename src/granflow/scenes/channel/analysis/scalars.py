"""The channel scene's analysis of one profile: every check and the scalars of its table row."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from .profile import (
    StressChecks,
    UniversalFit,
    VelocityScales,
    bin_widths,
    field_and_error,
    fit_universal_profile,
    fold_profile,
    mean_velocity_eq32,
    stress_checks,
    velocity_scales,
    width_weighted_mean,
)
from .rheology import FlowZones, flow_zones, rheology


# --------------------------------------------------------------------------- scene
@dataclass
class ChannelAnalysis:
    """Everything :func:`analyse_profile` derives from one profile."""

    W: float
    folded: pd.DataFrame
    scales: VelocityScales
    fit: UniversalFit
    means: dict
    stress: StressChecks
    rheo: pd.DataFrame
    zones: FlowZones


def analyse_profile(profile: pd.DataFrame, W: float, gravity_y: float = -1.0) -> ChannelAnalysis:
    """Run all channel analyses on one unfolded profile."""
    folded = fold_profile(profile, W)
    scales = velocity_scales(folded)
    fit = fit_universal_profile(folded, scales)
    means = mean_velocity_eq32(scales, W, profile)
    stress = stress_checks(profile, gravity_y=gravity_y)
    rheo = rheology(folded, W)
    zones = flow_zones(folded, rheo)
    return ChannelAnalysis(float(W), folded, scales, fit, means, stress, rheo, zones)


#: Keys of the per-case scalar row written by :func:`analyse_channel`.
SCALAR_KEYS = (
    "W", "phi_mean", "phi_mean_measured",
    "u_slip", "u_slip_se", "u_max", "u_max_se", "ratio", "ratio_se",
    "delta_095", "delta_095_over_W",
    "fit_exponent", "fit_exponent_se", "fit_r2", "fit_r2_a3",
    "u_mean_measured", "u_mean_eq32",
    "sigma_xx_mean", "sigma_xx_rel_std",
    "sigma_xy_slope", "sigma_xy_slope_se", "sigma_xy_slope_r2", "rho_bulk",
    "sigma_xy_slope_over_rho_g", "mu_wall",
    "x_wall_layer", "x_loose_dense", "x_dense_plug", "x_plug_phi063", "plug_phi",
    "notes",
)


def plug_phi(a: ChannelAnalysis) -> tuple[float, float]:
    """Mean :math:`\\phi` over the plug bins and its error: the mean of the bins' (correlation-aware) errors
    (bins taken as fully correlated, an upper bound); NaN without a plug."""
    plug = a.zones.labels == "plug"
    phi = a.folded["phi"].to_numpy(float)[plug]
    if not plug.any() or not np.isfinite(phi).any():
        return float("nan"), float("nan")
    se = a.folded["phi_se"].to_numpy(float)[plug] if "phi_se" in a.folded else np.full(len(phi), np.nan)
    return float(np.nanmean(phi)), float(np.nanmean(se))


def scalars_from_analysis(a: ChannelAnalysis, phi_mean: float) -> dict:
    """Flatten a :class:`ChannelAnalysis` into the per-case CSV row (:data:`SCALAR_KEYS`)."""
    folded, zones = a.folded, a.zones
    phi, _ = field_and_error(folded, "phi")
    notes = [f"{k}: {v}" for k, v in (("velocity", a.scales.reason), ("fit", a.fit.reason),
                                      ("stress", a.stress.reason), ("zones", zones.reason)) if v]
    notes += [f"{k}: {v}" for k, v in a.rheo.attrs.get("unavailable", {}).items()]
    row = {
        "W": a.W, "phi_mean": float(phi_mean),
        "phi_mean_measured": width_weighted_mean(phi, bin_widths(folded)),
        "u_slip": a.scales.u_slip, "u_slip_se": a.scales.u_slip_se,
        "u_max": a.scales.u_max, "u_max_se": a.scales.u_max_se,
        "ratio": a.scales.ratio, "ratio_se": a.scales.ratio_se,
        "delta_095": a.scales.delta_095, "delta_095_over_W": a.scales.delta_095 / a.W,
        "fit_exponent": a.fit.a, "fit_exponent_se": a.fit.a_se,
        "fit_r2": a.fit.r2, "fit_r2_a3": a.fit.r2_a3,
        "u_mean_measured": a.means["u_mean_measured"], "u_mean_eq32": a.means["u_mean_eq32"],
        "sigma_xx_mean": a.stress.sigma_xx_mean, "sigma_xx_rel_std": a.stress.sigma_xx_rel_std,
        "sigma_xy_slope": a.stress.sigma_xy_slope, "sigma_xy_slope_se": a.stress.sigma_xy_slope_se,
        "sigma_xy_slope_r2": a.stress.sigma_xy_r2, "rho_bulk": a.stress.rho_bulk,
        "sigma_xy_slope_over_rho_g": a.stress.slope_over_rho_g, "mu_wall": a.stress.mu_wall,
        "x_wall_layer": zones.x_wall_layer, "x_loose_dense": zones.x_loose_dense,
        "x_dense_plug": zones.x_dense_plug, "x_plug_phi063": zones.x_plug_phi063,
        "plug_phi": plug_phi(a)[0], "notes": "; ".join(notes),
    }
    return {k: row[k] for k in SCALAR_KEYS}


def analyse_channel(profile: pd.DataFrame, W: float, phi_mean: float, gravity_y: float = -1.0) -> dict:
    """Scalars of one channel case for the per-case CSV row.

    Parameters
    ----------
    profile : DataFrame
        Unfolded cross-channel profile (module docstring).
    W : float
        Channel width, :math:`d_p`.
    phi_mean : float
        Nominal mean volume fraction :math:`\\bar\\phi` of the case (recorded;
        ``phi_mean_measured`` is the profile's own width-weighted mean).
    gravity_y : float
        y component of gravity in units of g (-1 for the project's decks).

    Returns
    -------
    dict
        Keys :data:`SCALAR_KEYS`; unavailable items are NaN and ``notes`` says why.
    """
    return scalars_from_analysis(analyse_profile(profile, W, gravity_y), phi_mean)
