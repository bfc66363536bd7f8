"""The silo scene's analysis of one finished case: discharge rates, steady window, coarse-grained fields."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from granflow.case import case_inputs
from granflow.registry import finite as _finite
from postproc.dump import particle_frames


#: the paper's way for the kinetic pressure (its eq. 7, Figs. 8-12): w = r_b/2 on nodes r_b/4 apart,
#: over the orifice's neighbourhood r < AXIS_R_MAX R, z < AXIS_Z_MAX R
EQ7_W, EQ7_SPACING, AXIS_R_MAX, AXIS_Z_MAX = 0.5, 0.25, 1.5, 3.0


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


def _near_orifice(frame, r_max: float, z_max: float):
    """The frame's particles with r < r_max and z < z_max (those a kernel near the orifice reaches)."""
    from dataclasses import replace

    pos = frame.position
    sel = (np.hypot(pos[:, 0], pos[:, 1]) < r_max) & (pos[:, 2] < z_max)
    pick = {name: getattr(frame, name)[sel] for name in ("position", "velocity", "mass", "radius", "type", "id", "omega",
                                                        "contact_stress_volume") if getattr(frame, name) is not None}
    return replace(frame, **pick)


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
        ``flow`` (windowed W_f, W_r), ``fields``, ``contact``, ``kinetic_w<w>``, ``orifice_plane``
        (:class:`~granflow.scenes.silo.analysis.orifice.PlaneCrossing`: the orifice without a kernel),
        ``kinetic_eq7`` and ``kinetic_fine`` (the kinetic pressure at w = r_b/2 on nodes r_b/4 apart near
        the orifice: the paper's eq. 7, :class:`postproc.fluctuation.FluctuationAccumulator`, and the
        time-averaged form; scalars ``h_c_over_R_eq7``, ``h_c_over_R_fine`` with ``_se``).
    scalars : dict
    """
    import granflow.scenes.silo.analysis as sl
    from postproc.contacts import read_contact_dump
    from postproc.coordinates import RZCoordinates
    from postproc.fields import FieldAccumulator
    from postproc.kernels import Gaussian

    from postproc.fluctuation import FluctuationAccumulator

    from .analysis.orifice import PlaneCrossing

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
    # the orifice without a kernel: particles within a thin slab about the orifice plane
    plane = None if headline_only else PlaneCrossing(R, r_b, n_blocks=cg["n_blocks"])
    # the kinetic pressure the paper's way (eq. 7: about each frame's local mean) beside the time-averaged
    # form, both at w = r_b/2 on nodes r_b/4 apart near the orifice; particles beyond the kernel's reach skipped
    fine_nodes = (np.arange(0.0, AXIS_R_MAX * R + 0.5 * EQ7_SPACING * r_b, EQ7_SPACING * r_b),
                  np.arange(-2 * r_b, AXIS_Z_MAX * R + 0.5 * EQ7_SPACING * r_b, EQ7_SPACING * r_b))
    fine = {} if headline_only else {
        "kinetic_eq7": FluctuationAccumulator(Gaussian.paper(EQ7_W * r_b, fine_nodes), coords, fields=("rho", "pk"),
                                              n_blocks=cg["n_blocks"]),
        "kinetic_fine": FieldAccumulator(Gaussian.paper(EQ7_W * r_b, fine_nodes), coords, fields=("rho", "u", "pk"),
                                         n_blocks=cg["n_blocks"])}
    reach = 2 * 4 * EQ7_W * r_b    # twice the cutoff: the frame's mean velocity at the grid's edge is complete
    accumulators = [main, *scan.values(), contact]
    for acc in accumulators + list(fine.values()):
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
            if plane is not None:
                plane.accumulate(frame)
            if fine:
                near = _near_orifice(frame, AXIS_R_MAX * R + reach, AXIS_Z_MAX * R + reach)
                for acc in fine.values():
                    acc.accumulate(near)
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
    if plane is not None:
        tables["orifice_plane"], plane_scalars = plane.conclude()
        scalars.update(plane_scalars)
    for name, acc in fine.items():
        tables[name] = acc.conclude()
        ax = sl.axis_profile(tables[name], "pk")
        hw, hw_se = sl.transition_height(ax["z"], ax["value"], ax["value_se"])
        key = "h_c_over_R_eq7" if name == "kinetic_eq7" else "h_c_over_R_fine"
        scalars[key], scalars[key + "_se"] = hw / R, hw_se / R
        scalars[key.replace("h_c_over_R", "pk_max")] = float(np.nanmax(ax["value"])) if len(ax) else float("nan")
    axis = sl.axis_profile(tables["fields"], "pk")
    h_c, h_c_se = sl.transition_height(axis["z"], axis["value"], axis["value_se"])
    scalars.update({"h_c": h_c, "h_c_se": h_c_se, "h_c_over_R": h_c / R, "h_c_over_R_se": h_c_se / R})
    for w in w_scan:
        ax = sl.axis_profile(tables[f"kinetic_w{w:g}"], "pk")
        hw, hw_se = sl.transition_height(ax["z"], ax["value"], ax["value_se"])
        scalars[f"h_c_over_R_w{w:g}"], scalars[f"h_c_over_R_w{w:g}_se"] = hw / R, hw_se / R
    phi_bulk, _ = sl.bulk_volume_fraction(tables["fields"], record["fill_height"], R_c, r_b)
    scalars.update({"phi_bulk": phi_bulk, "rho_bulk": rho_p * phi_bulk, "n_frames": n_frames,
                    "n_contact_frames": contact.n_frames})
    # W_r with the measured bulk fraction
    tables["flow"] = sl.flow_rates(th, rho_p, phi_bulk if np.isfinite(phi_bulk) else phi_b, R_c, window)
    return tables, scalars


def silo_observables(case_dir: str | Path, record: dict, t_max=None, steady=None) -> tuple[dict, tuple]:
    """Silo headline numbers and the steady window they came from (NaNs if none)."""

    out = {}  # the scene fills what is not measured with NaN
    _, s = silo_analysis(case_dir, t_max=t_max, steady=steady, record=record, headline_only=True)
    out.update({"W_f": _finite(s.get("W_f")), "profile_deviation": _finite(s.get("sqrt_profile_deviation")),
                "h_c_over_R": _finite(s.get("h_c_over_R"))})
    return out, (_finite(s.get("t_start")), _finite(s.get("t_end")))
