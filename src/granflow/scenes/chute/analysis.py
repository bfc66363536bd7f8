"""Height profiles of a chute flow and the checks of Silbert et al. (2001).

Units: length :math:`d`, mass :math:`m`, time :math:`\\sqrt{d/g}`; :math:`g = 1`.
Stresses follow :mod:`postproc.fields`: **compressive positive** (the negative of
LAMMPS's ``stress/atom``), contact plus kinetic. With gravity
:math:`\\mathbf g = g(\\sin\\theta, 0, -\\cos\\theta)` (``fix gravity ... chute``) the
momentum balance of a steady uniform flow with a free surface at :math:`z = h`
gives, in this convention,

.. math::

    \\sigma_{zz}(z) = g\\cos\\theta \\int_z^{h} \\rho\\, dz', \\qquad
    \\sigma_{xz}(z) = -g\\sin\\theta \\int_z^{h} \\rho\\, dz',

so the stress ratio :math:`\\mu(z) = -\\sigma_{xz}/\\sigma_{zz} = \\tan\\theta` at every
height (the paper writes the same with tension-positive shear stress). Heights are
measured from the top of the frozen base's centres, :math:`z_0` = ``base_height``.
"""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pandas as pd

from postproc.coordinates import XCoordinates
from postproc.dump import read_dump
from postproc.fields import FieldAccumulator
from postproc.frame import ParticleFrame
from postproc.kernels import HeavisideBins
from postproc.series import window_acceleration  # noqa: F401 (moved there; re-exported)

#: fields of the height profile
PROFILE_FIELDS = ("n", "phi", "rho", "u", "T", "sigmac", "sigmak", "sigma")


# ----------------------------------------------------------------- frames -> profile
def chute_frames(paths, dt: float, window: tuple[float, float] | None = None):
    """ParticleFrames of the dumps in order, each step once (a segment's first frame
    repeats the previous segment's last), keeping ``t0 <= t - t_first < t1`` if ``window``."""
    seen, t_first = set(), None
    for path in paths:
        for frame in read_dump(path):
            if frame.timestep in seen:
                continue
            seen.add(frame.timestep)
            t = frame.timestep * dt
            t_first = t if t_first is None else t_first
            if window is not None and not (window[0] - 1e-9 <= t - t_first < window[1] - 1e-9):
                continue
            yield ParticleFrame.from_dump(frame)


def height_profile(frames, bin_width: float, z_max: float, n_blocks: int = 8) -> pd.DataFrame:
    """Time-averaged fields in height bins :math:`[0, z_{max})` of width ``bin_width``.

    Columns as :meth:`postproc.fields.FieldAccumulator.conclude` (``z``, ``phi``, ``rho``,
    ``u_x``, ``T``, ``sigma_xz`` ... with ``_se``); mass-bearing fields in :math:`m`.
    """
    n_bins = max(1, int(math.ceil(z_max / bin_width)))
    edges = np.arange(n_bins + 1) * bin_width
    acc = FieldAccumulator(HeavisideBins(edges), XCoordinates(axis="z"), fields=PROFILE_FIELDS,
                           n_blocks=n_blocks)
    acc.prepare()
    n = 0
    for frame in frames:
        acc.accumulate(frame)
        n += 1
    if n == 0:
        raise ValueError("no frames to average")
    return acc.conclude()


# --------------------------------------------------------------------- the checks
def surface_height(profile: pd.DataFrame, phi_bulk: float) -> float:
    """Free-surface height: the highest :math:`z` where :math:`\\phi` falls through
    :math:`\\phi_{bulk}/2` (linear interpolation between bin centres)."""
    z, phi = profile["z"].to_numpy(), np.nan_to_num(profile["phi"].to_numpy())
    above = np.nonzero(phi >= 0.5 * phi_bulk)[0]
    if len(above) == 0:
        return float("nan")
    k = above[-1]
    if k + 1 >= len(z):
        return float(z[k])
    f = (phi[k] - 0.5 * phi_bulk) / (phi[k] - phi[k + 1])
    return float(z[k] + f * (z[k + 1] - z[k]))


def weight_above(profile: pd.DataFrame, theta_deg: float, g: float = 1.0) -> np.ndarray:
    """Normal weight per area of the material above each bin centre,

    .. math:: W(z) = g\\cos\\theta \\int_z^{\\infty} \\rho\\, dz' ,

    with bins of width :math:`\\Delta z` holding :math:`\\rho_k \\Delta z` each and half
    of the centre's own bin counted.
    """
    rho = np.nan_to_num(profile["rho"].to_numpy())
    dz = (profile["z_hi"] - profile["z_lo"]).to_numpy()
    per_bin = rho * dz
    above = np.cumsum(per_bin[::-1])[::-1] - 0.5 * per_bin
    return g * math.cos(math.radians(theta_deg)) * above


def stress_ratio(profile: pd.DataFrame) -> np.ndarray:
    """:math:`\\mu(z) = -\\sigma_{xz}/\\sigma_{zz}` (total stress, compressive positive): tan theta when steady."""
    szz = profile["sigma_zz"].to_numpy()
    return np.divide(-profile["sigma_xz"].to_numpy(), szz, out=np.full(len(szz), np.nan), where=szz > 0)


def bagnold_shape(z: np.ndarray, h: float) -> np.ndarray:
    """:math:`f(z) = h^{3/2} - (h - z)^{3/2}` for :math:`0 \\le z \\le h` (z above the base)."""
    return h**1.5 - np.clip(h - np.asarray(z, float), 0.0, None) ** 1.5


def fit_bagnold(z: np.ndarray, u: np.ndarray, h: float) -> dict:
    """Least-squares amplitude of :math:`u(z) = A[h^{3/2} - (h - z)^{3/2}]` with ``h`` fixed.

    .. math:: A = \\frac{\\sum_k u_k f_k}{\\sum_k f_k^2}

    Returns ``A``, ``r2`` (:math:`1 - \\sum (u - Af)^2 / \\sum (u - \\bar u)^2`) and
    ``rel_rms`` (rms residual over rms u), NaN with fewer than 2 points.
    """
    z, u = np.asarray(z, float), np.asarray(u, float)
    good = np.isfinite(z) & np.isfinite(u)
    z, u = z[good], u[good]
    nan = float("nan")
    if len(z) < 2 or not np.isfinite(h):
        return {"A": nan, "r2": nan, "rel_rms": nan, "n_points": int(len(z))}
    f = bagnold_shape(z, h)
    A = float(np.dot(u, f) / np.dot(f, f))
    res = u - A * f
    ss_tot = float(np.sum((u - u.mean()) ** 2))
    u_rms = float(np.sqrt(np.mean(u**2)))
    return {"A": A, "r2": 1.0 - float(np.sum(res**2)) / ss_tot if ss_tot > 0 else nan,
            "rel_rms": float(np.sqrt(np.mean(res**2))) / u_rms if u_rms > 0 else nan, "n_points": int(len(z))}


def bulk_mask(profile: pd.DataFrame, z_base: float, z_surface: float, margin: float) -> np.ndarray:
    """Bins whose centres lie in :math:`[z_0 + m, z_s - m]`: ``margin`` m away from base and surface."""
    z = profile["z"].to_numpy()
    return (z >= z_base + margin) & (z <= z_surface - margin)


def profile_checks(profile: pd.DataFrame, theta_deg: float, z_base: float, margin: float) -> dict:
    """The paper's checks on a height profile (bulk = ``margin`` from base and surface).

    Returns ``phi_bulk``, ``z_surface``, ``H_flow`` (:math:`z_s - z_0`), the bulk
    range, ``stress_ratio`` (mean of :math:`\\mu(z)` over bulk bins) with
    ``stress_ratio_se`` (standard error from the bins' (correlation-aware) errors and their
    scatter, whichever is larger), ``stress_ratio_error`` (:math:`\\mu/\\tan\\theta - 1`),
    ``weight_residual`` (:math:`\\sqrt{\\langle((\\sigma_{zz} - W)/W)^2\\rangle}` over the bulk)
    and the Bagnold fit (``bagnold_A``, ``bagnold_r2``, ``bagnold_rel_rms``, ``bagnold_H``).
    """
    tan = math.tan(math.radians(theta_deg))
    z = profile["z"].to_numpy()
    phi = np.nan_to_num(profile["phi"].to_numpy())
    # first guess of the bulk packing: the densest bins above the base
    dense = phi[z > z_base]
    phi_guess = float(np.median(np.sort(dense)[-max(1, len(dense) // 2):])) if len(dense) else float("nan")
    z_s = surface_height(profile, phi_guess)
    bulk = bulk_mask(profile, z_base, z_s, margin)
    out = {"z_base": z_base, "z_surface": z_s, "H_flow": z_s - z_base,
           "bulk_lo": z_base + margin, "bulk_hi": z_s - margin, "n_bulk_bins": int(bulk.sum())}
    nan = float("nan")
    if bulk.sum() == 0:
        return {**out, "phi_bulk": nan, "stress_ratio": nan, "stress_ratio_se": nan, "stress_ratio_error": nan,
                "weight_residual": nan, "bagnold_A": nan, "bagnold_r2": nan, "bagnold_rel_rms": nan,
                "bagnold_H": z_s - z_base, "u_mean": nan}
    mu = stress_ratio(profile)[bulk]
    out["phi_bulk"] = float(np.mean(phi[bulk]))
    out["stress_ratio"] = float(np.nanmean(mu))
    # error of mu from the (correlation-aware) errors of sigma_xz and sigma_zz (first order), and the scatter between bins
    szz, sxz = profile["sigma_zz"].to_numpy()[bulk], profile["sigma_xz"].to_numpy()[bulk]
    se_zz, se_xz = profile["sigma_zz_se"].to_numpy()[bulk], profile["sigma_xz_se"].to_numpy()[bulk]
    se_bins = np.abs(mu) * np.sqrt((se_xz / sxz) ** 2 + (se_zz / szz) ** 2)
    se_blocks = float(np.sqrt(np.nansum(se_bins**2)) / len(mu))
    se_scatter = float(np.nanstd(mu, ddof=1) / math.sqrt(len(mu))) if len(mu) > 1 else nan
    out["stress_ratio_se"] = float(np.nanmax([se_blocks, se_scatter]))
    out["stress_ratio_error"] = out["stress_ratio"] / tan - 1.0
    weight = weight_above(profile, theta_deg)[bulk]
    out["weight_residual"] = float(np.sqrt(np.mean(((szz - weight) / weight) ** 2)))
    fit = fit_bagnold(z[bulk] - z_base, profile["u_x"].to_numpy()[bulk], z_s - z_base)
    out.update({"bagnold_A": fit["A"], "bagnold_r2": fit["r2"], "bagnold_rel_rms": fit["rel_rms"],
                "bagnold_H": z_s - z_base})
    # depth-averaged downslope speed (mass weighted, whole bed)
    rho = np.nan_to_num(profile["rho"].to_numpy())
    ux = np.nan_to_num(profile["u_x"].to_numpy())
    out["u_mean"] = float(np.sum(rho * ux) / np.sum(rho)) if rho.sum() > 0 else nan
    return out


# ----------------------------------------------------------------------- one case
def provenance(record: dict, status: str) -> str:
    """Where a number came from: rung, size, stiffness, particle count, status."""
    r, p = record["rung_knobs"], record["parameters"]
    return (f"chute rung {record['rung']}: {r['Lx']:g}x{r['Ly']:g} d, H {r['H']:g} d, k_n {r['k_n']:.3g}, "
            f"dt {record['dt']:.3g}, N {p['n_particles']}, theta {p['theta_deg']:g} deg, {status}")


def case_profile(case_dir: Path, record: dict, status: dict, window=None, n_blocks: int = 8):
    """Height profile of a finished case (``None`` if it has no dumps or no frame in ``window``)."""
    dumps = [case_dir / "run" / d for d in status.get("dumps") or []]
    if not dumps:
        return None
    frames = list(chute_frames(dumps, record["dt"], window))
    if not frames:
        return None
    z_max = max(float(f.position[:, 2].max()) for f in frames) + 1.0
    return height_profile(frames, record["rung_knobs"]["bin_width"], z_max, n_blocks=n_blocks), len(frames)


def analyse_case(case_dir: str | Path, window=None) -> tuple[dict[str, pd.DataFrame], dict]:
    """``(tables, scalars)`` of one case; empty tables and the status if nothing was averaged."""
    case_dir = Path(case_dir)
    record = json.loads((case_dir / "params.json").read_text())
    status = json.loads((case_dir / "run" / "status.json").read_text())
    theta = float(record["parameters"]["theta_deg"])
    scalars = {
        "status": status["status"], "status_reason": status.get("reason", ""),
        "theta": theta, "tan_theta": math.tan(math.radians(theta)),
        "max_overlap": status.get("max_overlap", float("nan")),
        "dangerous_builds": status.get("dangerous_builds", 0),
        "matom_step_per_s": status.get("matom_step_per_s"),
        "n_particles": record["parameters"]["n_particles"],
        "provenance": provenance(record, status["status"]),
    }
    thermo_path = case_dir / "run" / "thermo.csv"
    if thermo_path.exists():
        th = pd.read_csv(thermo_path)
        if "v_ucm" in th and len(th):
            scalars["u_cm_last"] = float(th["v_ucm"].iloc[-1])
            scalars["atoms_min"], scalars["atoms_max"] = int(th["Atoms"].min()), int(th["Atoms"].max())
            scalars.update(window_acceleration(th))
    got = case_profile(case_dir, record, status, window)
    if got is None:
        return {}, scalars
    profile, n_frames = got
    margin = record["rung_knobs"]["bulk_margin"]
    checks = profile_checks(profile, theta, float(record["parameters"]["base_height"]), margin)
    profile = profile.assign(
        stress_ratio=stress_ratio(profile), weight_above=weight_above(profile, theta),
        u_bagnold=checks["bagnold_A"] * bagnold_shape(profile["z"].to_numpy() - checks["z_base"], checks["bagnold_H"])
        if np.isfinite(checks["bagnold_A"]) else np.nan)
    scalars.update(checks)
    scalars["n_frames"] = n_frames
    scalars["bulk_rule"] = (f"bulk: bin centres from {margin:g} d above the base (z0 = {checks['z_base']:g}) "
                            f"to {margin:g} d below the surface (phi = phi_bulk/2)")
    return {"profile": profile}, scalars
