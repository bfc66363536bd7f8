"""Per-case post-processing of a channel run: dumps -> profile -> scalars.

Runs write masses in units of :math:`m_p` (a :math:`d_p` sphere has mass 1, so
the contact parameters match Debnath et al. 2022, Appendix A). The paper reports
mass-bearing quantities with particle density :math:`\\rho_p = 1`; this module
converts the profile to those units (stress in :math:`\\rho_p g d_p`,
temperature in :math:`\\rho_p d_p^3 \\cdot g d_p`) by dividing by the material
density :math:`\\rho_p = 6/\\pi\\, m_p/d_p^3`.
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd

from .dump import read_dump
from .fields import profile_from_frames
from .frame import ParticleFrame

#: profile columns (and prefixes of columns) that carry one power of mass
MASS_COLUMNS = ("rho", "T")
MASS_PREFIXES = ("sigma_", "sigmac_", "sigmak_")


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


def particle_frames(paths, dt: float | None = None, t_window: tuple[float, float] | None = None):
    """ParticleFrames from a sequence of dump files, in order.

    With ``t_window = (lo, hi)`` (and the time step ``dt``) only the frames with
    ``lo <= t - t_0 < hi`` are yielded, ``t_0`` being the time of the first frame:
    a block or a prefix of the averaging window.
    """
    t0 = None
    for path in paths:
        for frame in read_dump(path):
            if t_window is not None:
                t = frame.timestep * dt
                t0 = t if t0 is None else t0
                if not t_window[0] - 1e-9 * abs(t) <= t - t0 < t_window[1] - 1e-9 * abs(t):
                    continue
            yield ParticleFrame.from_dump(frame)


def case_inputs(case_dir: str | Path, record: dict | None = None) -> tuple[Path, dict, dict]:
    """The case directory, its parameter record (or ``record``, e.g. with other bin widths) and run status."""
    case_dir = Path(case_dir)
    if record is None:
        record = json.loads((case_dir / "params.json").read_text())
    status = json.loads((case_dir / "run" / "status.json").read_text())
    return case_dir, record, status


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
    profile = profile_from_frames(frames, W=record["parameters"]["W"], bin_width=knobs["bin_width"],
                                  wall_bin_width=knobs["wall_bin_width"], n_blocks=n_blocks)
    facts = {"total_mass": float(frames[0].mass.sum()), "n_frames": len(frames),
             "n_particles": int(len(frames[0].mass))}
    return to_paper_units(profile, record["density"]), facts


# ----------------------------------------------------------------------- heap
def feed_rate_measured(thermo: pd.DataFrame, t_range: tuple[float, float] | None = None) -> tuple[float, float]:
    """Delivered mass rate over the averaging window (or the times ``t_range``): slope of
    the total mass against time.

    Returns the rate (kg/s) and its standard error from the least-squares fit.
    """
    th = thermo[thermo["stage"] == "average"] if "stage" in thermo else thermo
    if t_range is not None:
        th = th[(th["Time"] >= t_range[0]) & (th["Time"] <= t_range[1])]
    t, m = th["Time"].to_numpy(float), th["v_mtot"].to_numpy(float)
    if len(t) < 3:
        return float("nan"), float("nan")
    (slope, icpt), cov = np.polyfit(t, m, 1, cov=True)
    return float(slope), float(np.sqrt(cov[0, 0]))


def mixture_mean_diameter(species: list[dict]) -> float:
    """Number-mean diameter of a mixture given by volume fractions, m."""
    n = np.array([s["volume_fraction"] / s["mean_volume"] for s in species])
    d = np.array([s["d"] for s in species])
    return float(np.sum(n * d) / np.sum(n))


def heap_analysis(case_dir: str | Path, n_blocks: int = 8, t_window: tuple[float, float] | None = None,
                  record: dict | None = None) -> tuple[dict, dict]:
    """Free surface, moving-frame kinematics and scalings of a finished heap case.

    Two passes over the dumps of the averaging window: the free surface of every
    frame (fitted as a rising plane, :func:`postproc.heap.fit_surface`), then the
    volume-weighted kinematics in the frame rotated by alpha that rises with it.
    Bins are the rung's ``bin_dx``, ``bin_dz_phi`` and ``bin_dz_u`` times the
    mixture's number-mean diameter. ``t_window`` keeps the frames (and thermo rows)
    of that part of the averaging window, timed from its first frame; ``record``
    replaces ``params.json`` (e.g. other bin widths).

    Returns
    -------
    tables : dict of DataFrame
        ``per_x, profile, collapse, surface, alpha_t, rise_by_x, phi_columns, deposit``.
    scalars : dict
    """
    from . import heap as hp

    case_dir, record, status = case_inputs(case_dir, record)
    thermo = pd.read_csv(case_dir / "run" / "thermo.csv")
    dumps = [case_dir / "run" / d for d in status["dumps"]]
    knobs, dt = record["rung_knobs"], record["dt"]
    geometry = hp.HeapGeometry(**record["geometry"])
    species = record["species"]
    d_bar = mixture_mean_diameter(species)
    dx, dz_phi, dz_u = (knobs[k] * d_bar for k in ("bin_dx", "bin_dz_phi", "bin_dz_u"))
    z_lo = geometry.z_base_end - 2 * d_bar
    z_hi = record["parameters"]["z_top"]
    phi_c = record["protocol"]["phi_surface"]

    # pass 1: free surface per frame and the phi columns (kept for phi_bed, below)
    t_list, zs_list, phis, n_frames = [], [], [], 0
    for frame in particle_frames(dumps, dt, t_window):
        phi, x_edges, z_edges = hp.volume_fraction_columns(frame.position, frame.radius, geometry,
                                                           dx, dz_phi, z_lo, z_hi)
        z_s = hp.free_surface(phi, z_edges, phi_c)
        t_list.append(frame.timestep * dt)
        zs_list.append(z_s)
        phis.append(phi)
        n_frames += 1
        last = frame
    if not n_frames:
        raise ValueError(f"{case_dir}: no frames in {', '.join(map(str, dumps))}")
    t = np.asarray(t_list)
    x_lab = 0.5 * (x_edges[1:] + x_edges[:-1])
    z_s = np.vstack(zs_list)
    fit = hp.fit_surface(t, x_lab, z_s, hp.surface_fit_range(geometry, dx))

    # pass 2: kinematics in the moving frame
    moving = hp.MovingFrame(fit, geometry)
    acc = hp.KinematicsAccumulator(hp.uniform_edges(0.0, moving.L, dx),
                                   hp.uniform_edges(-15 * d_bar, 2 * d_bar, dz_u),
                                   geometry.T, n_types=len(species), n_blocks=n_blocks)
    acc.prepare()
    for frame in particle_frames(dumps, dt, t_window):
        hp.accumulate_frame(acc, frame, moving, dt)
    profile = acc.conclude()

    rate, rate_se = feed_rate_measured(thermo, None if t_window is None else (float(t[0]), float(t[-1])))
    per_x, scalars = hp.analyse_heap(profile, fit, geometry, density=record["density"], feed_rate=rate,
                                     phi_bed=float("nan"), d_ref=d_bar, n_types=len(species))
    # the static bed, from 1.5 flowing-layer thicknesses below the surface down to 2 d
    # above the base, gives phi_bed and with it the mass balance
    delta = scalars.get("delta_mean", np.nan)
    depth_lo = 1.5 * delta if np.isfinite(delta) else 6 * d_bar
    downstream = x_lab > geometry.x_feed + dx
    beds = []
    for phi, zs in zip(phis, z_s):
        bed = hp.bed_volume_fraction(phi, z_edges, zs, depth_lo, depth_lo + 20 * d_bar,
                                     z_base=geometry.z_base(x_edges[:-1]), clearance=2 * d_bar)[downstream]
        beds.extend(bed[np.isfinite(bed)])
    phi_bed = float(np.mean(beds)) if beds else float("nan")
    scalars.update(hp.mass_balance(fit, geometry, density=record["density"], feed_rate=rate, phi_bed=phi_bed))
    collapsed = hp.collapse(profile, per_x, moving.v_r_normal)
    if len(species) == 2 and np.isfinite(scalars.get("delta_mean", np.nan)):
        deposit = hp.deposit_concentration(last.position, last.radius, last.type, fit, geometry,
                                           float(t[0]), float(t[-1]), scalars["delta_mean"], dx)
    else:
        deposit = pd.DataFrame(columns=["x_lab", "c_s", "n"])
    requested = record["case"]["feed_rate"]
    tol = record["protocol"]["feed_rate_tol"]
    spread = fit.rise_by_x.loc[fit.rise_by_x["in_fit"].astype(bool), "v_r"]
    rise_cv = float(np.std(spread, ddof=1) / abs(np.mean(spread))) if len(spread) > 1 else float("nan")
    scalars.update({
        "feed_rate": requested,
        "feed_rate_measured": rate,
        "feed_rate_measured_se": rate_se,
        "feed_rate_error": rate / requested - 1,
        "feed_rate_ok": bool(abs(rate / requested - 1) <= tol),
        "rise_velocity_cv": rise_cv,
        "phi_bed_depth": [depth_lo, depth_lo + 20 * d_bar],
        "phi_bed_bins": len(beds),
        "surface_residual_over_d": fit.residual_std / d_bar,
        "d_bar": d_bar,
        "t_start": float(t[0]),
        "t_end": float(t[-1]),
        "n_frames": n_frames,
        "n_particles": int(len(last.mass)),
    })
    tables = {"per_x": per_x, "profile": profile, "collapse": collapsed,
              "surface": hp.surface_table(t, x_lab, z_s), "alpha_t": fit.alpha_t, "rise_by_x": fit.rise_by_x,
              "phi_columns": hp.phi_columns_table(np.mean(phis, axis=0), x_edges, z_edges), "deposit": deposit}
    return tables, scalars


# --------------------------------------------------------------------------- silo
def silo_discharge_thermo(thermo: pd.DataFrame) -> pd.DataFrame:
    """Discharge rows with the deleted and re-inserted mass cumulated over segments.

    The deck's ``v_mdel`` and ``v_mins`` count from the start of each segment
    (LAMMPS fixes restart their tallies); adding each segment's final value to
    the following segments gives the totals since the orifice opened.
    """
    th = thermo[thermo["stage"] == "average"].copy() if "stage" in thermo else thermo.copy()
    th = th.sort_values("Step").reset_index(drop=True)
    for col in ("v_mdel", "v_mins"):
        offset, values = 0.0, th[col].to_numpy(dtype=float).copy()
        for seg in th["segment"].unique():
            rows = (th["segment"] == seg).to_numpy()
            values[rows] += offset
            offset = values[rows][-1]
        th[col] = values
    return th


def silo_grid(record: dict, spacing_rb: float) -> tuple[np.ndarray, np.ndarray]:
    """Node axes (r, z) of the silo fields: r from the axis to R_c, z from 4 r_b below the floor."""
    r_b = record["r_b"]
    h = spacing_rb * r_b
    z_top = min(record["cg"]["z_max"] * r_b, record["fill_height"])
    r_nodes = np.arange(0.0, record["R_c"] + 0.5 * h, h)
    z_nodes = np.arange(-4.0 * r_b, z_top + 0.5 * h, h)
    return r_nodes, z_nodes


def silo_analysis(case_dir: str | Path, t_max: float | None = None, steady: tuple[float, float] | None = None,
                  record: dict | None = None, headline_only: bool = False) -> tuple[dict, dict]:
    """Discharge rates, steady window and coarse-grained fields of a finished silo case.

    One pass over the particle frames of the steady window feeds every
    accumulator: the main fields at the paper's w = 2 r_b (``cg.w_fields``), the
    kinetic-pressure scan (``cg.w_scan``) and, from the contact frames, the
    contact stress at ``cg.w_contact``.

    ``t_max`` uses only the discharge up to that time since the opening (a shorter
    run); ``steady = (t_0, t_1)`` imposes the steady window (a block of it);
    ``record`` replaces ``params.json`` (e.g. another ``cg.w_fields``);
    ``headline_only`` skips the kernel-width scan and the contact stress.

    Returns
    -------
    tables : dict of DataFrame
        ``flow`` (windowed W_f, W_r), ``fields``, ``contact``, ``kinetic_w<w>``.
    scalars : dict
    """
    from . import silo as sl
    from .contacts import read_contact_dump
    from .coordinates import RZCoordinates
    from .fields import FieldAccumulator
    from .kernels import Gaussian

    case_dir, record, status = case_inputs(case_dir, record)
    th = silo_discharge_thermo(pd.read_csv(case_dir / "run" / "thermo.csv"))
    if t_max is not None:
        th = th[th["Time"] <= t_max + 1e-9].reset_index(drop=True)
    r_b, R, R_c, dt = record["r_b"], record["R"], record["R_c"], record["dt"]
    cg = record["cg"]
    rho_p = record["density"]
    window = max(5 * record["rung_knobs"]["thermo_interval"], 0.05)
    phi_b = record["protocol"]["phi_bed_estimate"]
    flow = sl.flow_rates(th, rho_p, phi_b, R_c, window)
    height = th["v_mtot"].to_numpy() / (rho_p * phi_b * np.pi * R_c**2)
    fill = np.interp(flow["t"].to_numpy(), th["Time"].to_numpy(), height)
    # the start-up (the first startup_td free-fall times t_d = sqrt(2 r_b/g)) never counts as steady
    t_d = np.sqrt(2 * r_b / record["gravity"])
    after = (flow["t_lo"] >= record["protocol"]["startup_td"] * t_d).to_numpy()
    if steady is None:
        t_start, t_end, why = sl.steady_window(flow["t"][after], flow["W_f"][after], window=window,
                                               fill_height=fill[after],
                                               min_fill_height=record["protocol"]["empty_height"] * R)
    else:
        (t_start, t_end), why = steady, f"imposed window {steady[0]:.4g}-{steady[1]:.4g} s"
    scalars = {"steady_reason": why, "t_start": t_start, "t_end": t_end, "window": window}
    tables = {"flow": flow}
    if not np.isfinite(t_start):
        return tables, scalars
    W, W_se = sl.steady_flow_rate(th, t_start, t_end)
    scalars.update({"W_f": W, "W_f_se": W_se})

    species_ids = [s["type"] for s in record["species"]]
    coords = RZCoordinates((0.0, 0.0))
    nodes = silo_grid(record, cg["node_spacing"])
    main = FieldAccumulator(Gaussian.paper(cg["w_fields"] * r_b, nodes), coords,
                            fields=("n", "phi", "rho", "u", "sigmak", "pk"),
                            species=None if headline_only else species_ids,
                            n_blocks=cg["n_blocks"])
    # the scan keeps the partials per size too: the paper's figs 10-12 use w = r_b/2
    w_scan = [] if headline_only else cg["w_scan"]
    scan = {w: FieldAccumulator(Gaussian.paper(w * r_b, nodes), coords, fields=("phi", "rho", "u", "sigmak", "pk"),
                                species=species_ids, n_blocks=cg["n_blocks"]) for w in w_scan}
    contact = FieldAccumulator(Gaussian.paper(cg["w_contact"] * r_b, silo_grid(record, cg["contact_node_spacing"])),
                               coords, fields=("sigmac", "pc"), n_blocks=cg["n_blocks"])
    accumulators = [main, *scan.values(), contact]
    for acc in accumulators:
        acc.prepare()
    contact_frames = {}
    for name in ([] if headline_only else status.get("contact_dumps", [])):
        for cf in read_contact_dump(case_dir / "run" / name):
            if t_start <= cf.timestep * dt <= t_end:
                contact_frames[cf.timestep] = cf
    n_frames = 0
    for name in status["dumps"]:
        for frame in particle_frames([case_dir / "run" / name]):
            if not t_start <= frame.timestep * dt <= t_end:
                continue
            n_frames += 1
            main.accumulate(frame)
            for acc in scan.values():
                acc.accumulate(frame)
            if frame.timestep in contact_frames:
                contact.accumulate(frame, contacts=contact_frames[frame.timestep])
    if not n_frames:
        scalars["steady_reason"] += "; no particle frame in the steady window"
        return tables, scalars
    tables["fields"] = main.conclude()
    tables["contact"] = contact.conclude() if contact.n_frames else pd.DataFrame()
    for w, acc in scan.items():
        tables[f"kinetic_w{w:g}"] = acc.conclude()
    prof = sl.orifice_profiles(tables["fields"], R)
    scalars.update({k: v for k, v in prof.items() if np.isscalar(v)})
    axis = sl.axis_profile(tables["fields"], "pk")
    h_c, h_c_se = sl.transition_height(axis["z"], axis["value"], axis["value_se"])
    scalars.update({"h_c": h_c, "h_c_se": h_c_se, "h_c_over_R": h_c / R, "h_c_over_R_se": h_c_se / R})
    for w in w_scan:
        ax = sl.axis_profile(tables[f"kinetic_w{w:g}"], "pk")
        hw, hw_se = sl.transition_height(ax["z"], ax["value"], ax["value_se"])
        scalars[f"h_c_over_R_w{w:g}"], scalars[f"h_c_over_R_w{w:g}_se"] = hw / R, hw_se / R
    bulk = tables["fields"]
    sel = (bulk["z"] > 0.5 * record["fill_height"] - 4 * r_b) & (bulk["z"] < 0.5 * record["fill_height"] + 4 * r_b) \
        & (bulk["r"] < R_c - 3 * r_b)
    phi_bulk = float(bulk.loc[sel, "phi"].mean()) if sel.any() else float("nan")
    scalars.update({"phi_bulk": phi_bulk, "rho_bulk": rho_p * phi_bulk, "n_frames": n_frames,
                    "n_contact_frames": contact.n_frames})
    # W_r with the measured bulk fraction
    tables["flow"] = sl.flow_rates(th, rho_p, phi_bulk if np.isfinite(phi_bulk) else phi_b, R_c, window)
    return tables, scalars
