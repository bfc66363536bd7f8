"""Per-case post-processing of a channel run: dumps -> profile -> scalars.

Runs write masses in units of :math:`m_p` (a :math:`d_p` sphere has mass 1, so
the contact parameters match Debnath et al. 2022, Appendix A). The paper reports
mass-bearing quantities with particle density :math:`\\rho_p = 1`; this module
converts the profile to those units (stress in :math:`\\rho_p g d_p`,
temperature in :math:`\\rho_p d_p^3 \\cdot g d_p`) by dividing by the material
density :math:`\\rho_p = 6/\\pi\\, m_p/d_p^3`.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from granflow.case import case_inputs
from granflow.registry import finite as _finite
from postproc.dump import particle_frames
from postproc.channel_profile import profile_from_frames

#: profile columns (and prefixes of columns) that carry one power of mass
MASS_COLUMNS = ("rho", "T")
MASS_PREFIXES = ("sigma_", "sigmac_", "sigmak_")
#: what the channel's T and kinetic stress are fluctuations about (postproc.fields): each frame's bin mean
FLUCTUATION = "frame"


def to_paper_units(profile: pd.DataFrame, density: float) -> pd.DataFrame:
    """Divide mass-bearing columns (and their standard errors) by the material density."""
    out = profile.copy()
    for col in out.columns:
        base = col[:-3] if col.endswith("_se") else col
        if base in MASS_COLUMNS or base.startswith(MASS_PREFIXES):
            out[col] = out[col] / density
    return out


def momentum_balance(thermo: pd.DataFrame, total_mass: float, g: float = 1.0) -> dict:
    """Vertical momentum balance of the particles over a thermo series.

    Each thermo row carries the wall force along y averaged over every step of
    the interval that ends at that row (``f_fwavg``) and the total momentum
    :math:`P_y` (``v_py``). Over the window :math:`[t_0, t_n]`

    .. math::

        P_y(t_n) - P_y(t_0) = \\sum_k \\bar F_{wall,k}\\, \\Delta t_k - M g (t_n - t_0),

    exactly, up to the time discretisation. Two residuals are returned, both
    relative to the weight impulse :math:`M g (t_n - t_0)`:

    ``residual`` — the balance above (should vanish for any run, steady or not);
    ``steady_residual`` — :math:`(\\bar F_{wall} - M g)/(M g)`, which vanishes only
    for a steady flow (wall shear force = weight, the paper's check).
    """
    th = thermo.sort_values("Step").reset_index(drop=True)
    if len(th) < 2 or "f_fwavg" not in th:
        return {"residual": np.nan, "steady_residual": np.nan, "wall_force": np.nan, "weight": total_mass * g}
    t = th["Time"].to_numpy()
    dt = np.diff(t)
    impulse_wall = float(np.sum(th["f_fwavg"].to_numpy()[1:] * dt))
    span = float(t[-1] - t[0])
    weight = total_mass * g
    dP = float(th["v_py"].iloc[-1] - th["v_py"].iloc[0])
    # per-interval balance, for its scatter
    F = th["f_fwavg"].to_numpy()[1:]
    return {
        "residual": (dP - impulse_wall + weight * span) / (weight * span),
        "steady_residual": (impulse_wall / span - weight) / weight,
        "wall_force": impulse_wall / span,
        "wall_force_se": float(np.std(F, ddof=1) / np.sqrt(len(F))) if len(F) > 1 else np.nan,
        "weight": weight,
        "acceleration_term": dP / (weight * span),
        "window": [float(t[0]), float(t[-1])],
    }


def channel_profile(case_dir: str | Path, n_blocks: int = 8, t_window: tuple[float, float] | None = None,
                    record: dict | None = None) -> tuple[pd.DataFrame, dict]:
    """Time-averaged cross-channel profile of a finished case, in paper units.

    ``t_window`` keeps the frames of that part of the averaging window (times from
    its first frame); ``record`` replaces ``params.json`` (e.g. another bin width).
    Returns the profile and a small dict of run facts (total mass, frames used).
    """
    case_dir, record, status = case_inputs(case_dir, record)
    dumps = [case_dir / "run" / d for d in status["dumps"]]
    knobs = record["rung_knobs"]
    frames = list(particle_frames(dumps, record["dt"], t_window))
    if not frames:
        raise ValueError(f"{case_dir}: no frames in {', '.join(map(str, dumps))}")
    # T and the kinetic stress about each frame's own bin velocity, as the paper's eqs. 2.1-2.4 read (the N
    # particles in a bin at one instant): about the window's mean the plug's change of speed counts as agitation
    profile = profile_from_frames(frames, W=record["parameters"]["W"], bin_width=knobs["bin_width"],
                                  wall_bin_width=knobs["wall_bin_width"], n_blocks=n_blocks,
                                  fluctuation=FLUCTUATION)
    facts = {"total_mass": float(frames[0].mass.sum()), "n_frames": len(frames),
             "n_particles": int(len(frames[0].mass))}
    return to_paper_units(profile, record["density"]), facts


def channel_blocks(case_dir: str | Path, record: dict, window: float, n_blocks: int = 8) -> pd.DataFrame:
    """u_max/u_slip and the plug's φ per block of the averaging window (:func:`.analysis.plug.block_ratios`)."""
    from .analysis.plug import block_ratios

    edges = np.linspace(0.0, window, n_blocks + 1)
    edges[-1] += 1e-9 * max(window, 1.0)  # the last frame sits on the window's end
    profiles = []
    for lo, hi in zip(edges[:-1], edges[1:]):
        try:
            profiles.append((float(lo), float(min(hi, window)), channel_profile(case_dir, t_window=(lo, hi),
                                                                                record=record)[0]))
        except ValueError:  # a block without frames
            continue
    return block_ratios(profiles, float(record["parameters"]["W"]))


def channel_plug_structure(case_dir: str | Path, record: dict, plug_edge: float, profile: pd.DataFrame):
    """:func:`.analysis.plug.plug_structure` over every frame of the averaging window, the mean flow
    taken from the case's time-averaged ``profile`` (x, u_x, u_y, u_z; linearly interpolated across x)."""
    from .analysis.plug import plug_structure

    case_dir, record, status = case_inputs(case_dir, record)
    frames = particle_frames([case_dir / "run" / d for d in status["dumps"]], record["dt"])
    x = profile["x"].to_numpy(float)
    u = [np.nan_to_num(profile[c].to_numpy(float)) if c in profile else np.zeros(len(x)) for c in ("u_x", "u_y", "u_z")]

    def mean_velocity(xp):
        return np.column_stack([np.interp(xp, x, c) for c in u])

    return plug_structure(frames, float(record["parameters"]["W"]), plug_edge, dt=float(record["dt"]),
                          mean_velocity=mean_velocity)


def channel_observables(case_dir: str | Path, record: dict, t_window=None) -> dict:
    from .analysis import analyse_channel

    out = {}  # the scene fills what is not measured with NaN
    try:
        profile, _ = channel_profile(case_dir, t_window=t_window, record=record)
    except ValueError:  # no frame in the window
        return out
    W, phi = record["parameters"]["W"], record["parameters"]["phi_mean"]
    s = analyse_channel(profile, W, phi)
    out.update({"u_ratio": _finite(s.get("ratio")), "delta_over_W": _finite(s.get("delta_095_over_W")),
                "sigma_xx_over_W": _finite(s.get("sigma_xx_mean")) / W,
                "eq31_exponent": _finite(s.get("fit_exponent"))})
    return out
