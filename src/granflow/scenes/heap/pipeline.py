"""The heap scene's analysis of one finished case: surface, moving-frame kinematics, scalings."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from granflow.case import case_inputs
from granflow.registry import finite as _finite
from postproc.dump import particle_frames


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
                  record: dict | None = None, depth_and_gap: bool = True) -> tuple[dict, dict]:
    """Free surface, moving-frame kinematics and scalings of a finished heap case.

    Two passes over the dumps of the averaging window: the free surface of every
    frame (fitted as a rising plane, :func:`granflow.scenes.heap.analysis.fit_surface`), then the
    volume-weighted kinematics in the frame rotated by alpha that rises with it.
    Bins are the rung's ``bin_dx``, ``bin_dz_phi`` and ``bin_dz_u`` times the
    mixture's number-mean diameter. ``t_window`` keeps the frames (and thermo rows)
    of that part of the averaging window, timed from its first frame; ``record``
    replaces ``params.json`` (e.g. other bin widths). ``depth_and_gap`` adds φ in depth
    (the static bed, φ(z) from the bed to above the surface, the surface with the cutoffs
    0.1 and 0.5: :mod:`granflow.scenes.heap.analysis.phi`) and the slices of the gap
    (:mod:`granflow.scenes.heap.analysis.gap`); the headline numbers do not use them.

    Returns
    -------
    tables : dict of DataFrame
        ``per_x, profile, collapse, surface, alpha_t, rise_by_x, phi_columns, deposit``, and with
        ``depth_and_gap`` ``static_bed, phi_profile, surface_cutoff, gap_surface_velocity, deposit_gap``.
    scalars : dict
    """
    import granflow.scenes.heap.analysis as hp

    case_dir, record, status = case_inputs(case_dir, record)
    thermo = pd.read_csv(case_dir / "run" / "thermo.csv")
    dumps = [case_dir / "run" / d for d in status["dumps"]]
    knobs, dt = record["rung_knobs"], record["dt"]
    geometry = hp.HeapGeometry(**record["geometry"])
    species = record["species"]
    d_bar = mixture_mean_diameter(species)
    d_large = max(float(sp["d"]) for sp in species)  # the largest species' diameter
    dx, dz_phi, dz_u = (knobs[k] * d_bar for k in ("bin_dx", "bin_dz_phi", "bin_dz_u"))
    z_lo = geometry.z_base_end - 2 * d_bar
    z_hi = record["parameters"]["z_top"]
    phi_c = record["protocol"]["phi_surface"]

    # pass 1: free surface per frame and the phi columns (kept for phi_bed, below). The frames
    # are kept for pass 2, so each dump is read once (~60 MB for the demo's 14k particles x 75 frames)
    t_list, zs_list, phis, n_frames, frames = [], [], [], 0, []
    for frame in particle_frames(dumps, dt, t_window):
        frames.append(frame)
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
    if depth_and_gap:  # φ in thin bins deep into the bed and high above it; the kinematics of the gap's slices
        phi_acc = hp.phi_profile_accumulator(moving.L, dx, dz_phi, d_bar, geometry.T, len(species))
        gap = hp.GapKinematics(acc.x_edges, acc.z_edges, geometry.T, n_types=len(species), n_blocks=n_blocks)
        gap.prepare()
    tilt_free = []  # each frame's surface with the cutoffs 0.1 and 0.5, the columns' tilt removed
    for frame, zs in zip(frames, z_s):
        hp.accumulate_frame(acc, frame, moving, dt)
        if depth_and_gap:
            hp.accumulate_frame(phi_acc, frame, moving, dt)
            gap.accumulate(frame, moving, dt)
            tilt_free.append(hp.tilt_free_spans(frame.position, frame.radius, zs, x_edges, geometry.T, fit.alpha_deg,
                                                dz_phi, d_bar))
    # where the particles fed in the window's first half came to rest, and how far they flew over the heap
    travel = hp.fed_travel(frames, x_lab, z_s, geometry, len(species), d_large)
    del frames
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
    scalars.update(travel)
    if scalars.get("origin") == "local":  # z of every column from its own free surface, as per_x measured it
        profile = hp.shift_to_surface(profile, per_x.set_index("x")["z_surface_local"])
    collapsed = hp.collapse(profile, per_x, moving.v_r_normal)
    if scalars.get("origin") == "local":
        scalars.update(hp.species_flux_above(profile, len(species)))
        scalars.update(hp.species_flux_above(profile, len(species), d_large, "flux_above_d_max"))
    if len(species) == 2 and np.isfinite(scalars.get("delta_mean", np.nan)):
        deposit_variants = hp.deposit_variants(last.position, last.radius, last.type, fit, geometry,
                                               float(t[0]), float(t[-1]), scalars["delta_mean"], dx, d_large=d_large)
        central = (deposit_variants["variant"] == hp.DEPOSIT_CENTRAL) & (deposit_variants["slab"] == 0)
        deposit = deposit_variants.loc[central, ["x_lab", "c_s", "n", "volume"]].reset_index(drop=True)
    else:
        deposit = pd.DataFrame(columns=["x_lab", "c_s", "n"])
        deposit_variants = pd.DataFrame(columns=["variant", "slab", "x_lab", "c_s", "n", "volume"])
    extra_tables = {}
    if depth_and_gap:
        extra_tables, extra = _phi_and_gap(
            phis, z_s, tilt_free, x_edges, z_edges, geometry, fit, moving, phi_acc, gap.conclude(), per_x, scalars,
            last, (float(t[0]), float(t[-1])), dx, d_bar, phi_c, len(species))
        scalars.update(extra)
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
              "phi_columns": hp.phi_columns_table(np.mean(phis, axis=0), x_edges, z_edges), "deposit": deposit,
              "deposit_variants": deposit_variants, **extra_tables}
    return tables, scalars


def _phi_and_gap(phis, z_s, tilt_free, x_edges, z_edges, geometry, fit, moving, phi_acc, gap_profiles, per_x, scalars,
                 last, window, dx, d_bar, phi_c, n_types) -> tuple[dict, dict]:
    """The tables of φ in depth and of the gap's slices, and their central numbers as scalars (the
    record's rows read the tables: :mod:`granflow.scenes.heap.phi_checks`, :mod:`granflow.scenes.heap.gap_checks`)."""
    import granflow.scenes.heap.analysis as hp

    delta = scalars.get("delta_mean", float("nan"))
    tables = {"surface_cutoff": hp.surface_cutoff_table(phis, x_edges, z_edges, tilt_free=np.vstack(tilt_free))}
    tables["static_bed"] = (hp.static_bed_table(phis, z_s, x_edges, z_edges, geometry, delta=delta, d_bar=d_bar,
                                                alpha_deg=fit.alpha_deg) if np.isfinite(delta) else
                            pd.DataFrame(columns=["top_over_delta", "depth_lo", "depth_hi", "x_lab", "phi", "n_frames"]))
    base = hp.base_height(moving, geometry, window[0], phi_acc.x_edges)
    tables["phi_profile"] = hp.phi_profile_table(phi_acc.conclude(), base, phi_c)
    offsets = per_x.set_index("x")["z_surface_local"] if scalars.get("origin") == "local" else None
    tables["gap_surface_velocity"] = hp.gap_surface_velocity(gap_profiles, per_x, offsets)
    if n_types == 2 and np.isfinite(delta):
        tables["deposit_gap"] = hp.deposit_gap(last.position, last.radius, last.type, fit, geometry, *window, delta, dx)
    else:
        tables["deposit_gap"] = pd.DataFrame(columns=["variant", "slice", "slab", "x_lab", "c_s", "n", "volume"])
    phi_bed, phi_bed_se, _ = hp.static_bed_phi(tables["static_bed"])
    cut = hp.surface_cutoff_max(tables["surface_cutoff"], hp.surface_fit_range(geometry, dx), d_bar,
                                "span_tilt_free_mean")
    return tables, {"phi_static_bed": phi_bed, "phi_static_bed_se": phi_bed_se,
                    "surface_cutoff_span_max_over_d": cut["value"], "phi_c_range": list(hp.PHI_C_RANGE)}


def heap_observables(case_dir: str | Path, record: dict, t_window=None) -> dict:

    out = {}  # the scene fills what is not measured with NaN
    try:
        _, s = heap_analysis(case_dir, t_window=t_window, record=record, depth_and_gap=False)  # headlines only
    except (ValueError, np.linalg.LinAlgError):
        return out
    out.update({"alpha": _finite(s.get("alpha_deg")), "delta_over_d": _finite(s.get("delta_over_d")),
                "tail_exponent": _finite(s.get("tail_k"))})
    return out
