"""Physical parameters of the periodic vertical channel (Debnath, Kesava Rao & Kumaran 2022), LJ units.

Every number of the channel deck is computed here once from the validated scene
file and reaches the deck as a ``variable ... equal`` line.
"""
from __future__ import annotations

import math

from granflow.scene_files import check_rung
from granflow.contact import build_contact_model, sphere_mass
from granflow.deck import (
    contact_law_context,
    contact_law_params,
    SPIN_COLUMNS,
    STRESS_COLUMNS,
    Param,
    StepClock,
    number,
    rain_lattice,
    species_counts,
    time_step,
)
from granflow.preflight import PreflightError, check_time_step, neighbor_settings


def case_values(scene: dict, rung_name: str, case: dict | None = None) -> dict:
    """Merge the scene's default case, the rung and a sweep point into one case dict."""
    rung = check_rung(scene, rung_name)
    merged = dict(scene["case"], **(case or {}))
    if merged.get("W") is None:
        merged["W"] = rung["W"]
    return merged


def channel_parameters(scene: dict, rung_name: str, case: dict | None = None) -> tuple[list[Param], dict]:
    """All numbers of a channel deck, and the template context besides them.

    Raises
    ------
    PreflightError
        If the time step does not resolve the stiffest contact.
    """
    rung = check_rung(scene, rung_name)
    case = case_values(scene, rung_name, case)
    model = build_contact_model(scene, rung)
    dt = time_step(rung, model)
    check_time_step(dt, model, scene["contact"]["dt_max_fraction"])

    p = scene["particles"]
    eff = scene["effects"]
    diameters = p["diameters"] if eff["polydisperse"] else [1.0]
    fractions = p["number_fractions"] if eff["polydisperse"] else [1.0]
    v_mean = sum(f * math.pi * d**3 / 6 for d, f in zip(diameters, fractions))
    W, B, H = float(case["W"]), float(rung["B"]), float(rung["H"])
    n_particles = int(round(case["phi_mean"] * W * B * H / v_mean))
    counts = species_counts(n_particles, fractions)
    v_particles = sum(n * math.pi * d**3 / 6 for n, d in zip(counts, diameters))
    H_per = v_particles / (case["phi_mean"] * W * B)
    # lattice of the raining gas: cells of about v_mean/fill_packing, never
    # narrower than the largest diameter; enough layers for n_particles sites
    d_max = max(diameters)
    a, a_x, a_z, n_layers = rain_lattice(n_particles, v_mean, scene["protocol"]["fill_packing"], d_max, W - 1.2, B)
    if min(a_x, a_z) < d_max:
        raise PreflightError(f"channel W = {W:g}, B = {B:g} too small for one lattice cell of {d_max:g} d_p")
    fill_height = 1.2 + n_layers * a + 1.0

    # the fastest expected motion: free fall of the gas from the top of the fill
    # region, three times over for collisions and the flow
    v_max = 3.0 * math.sqrt(2.0 * fill_height)
    skin = scene["contact"]["neighbor_skin"]
    neigh = neighbor_settings(diameters, skin, dt, v_max)

    # Segments and dump intervals are whole multiples of the thermo interval, so
    # every thermo row closes a full interval of the every-step wall-force average.
    clock = StepClock(dt, rung["thermo_interval"])
    steps, thermo_multiple, n_thermo = clock.steps, clock.thermo_multiple, clock.n_thermo

    params = [
        Param("W", W, "channel width (walls at x = 0 and x = W), d_p"),
        Param("B", B, "spanwise periodic depth (z), d_p"),
        Param("H_nominal", H, "nominal periodic height; the deck sets H = V_particles/(phi_mean W B)"),
        Param("phi_mean", number(case["phi_mean"]), "mean volume fraction phi-bar"),
        Param("n_particles", n_particles, "particles inserted: phi_mean W B H_nominal / <pi d^3/6>"),
        Param("H_per", round(H_per, 9), "periodic height V_particles/(phi_mean W B), d_p"),
        Param("fill_height", round(fill_height, 6), "box height while the gas rains, d_p"),
        Param("d_max", d_max, "largest diameter, d_p"),
        Param("d_min", min(diameters), "smallest diameter, d_p"),
        Param("max_overlap", scene["guards"]["max_overlap"], "halt: largest overlap / d_min above this"),
        Param("max_speed", scene["guards"]["max_speed"], "halt: rms particle speed above this, sqrt(g d_p)"),
        Param("a_x", round(a_x, 9), "gas lattice cell along x, d_p"),
        Param("a_y", round(a, 9), "gas lattice cell along y, d_p"),
        Param("a_z", round(a_z, 9), "gas lattice cell along z, d_p"),
        Param("n_layers", n_layers, "lattice layers of the gas"),
        Param("jiggle", round(0.45 * (min(a_x, a, a_z) - d_max), 9), "random displacement of gas particles, d_p"),
        Param("density", p["density"], "material density, m_p/d_p^3 (a d_p sphere has mass 1)"),
        Param("seed", int(case["seed"]), "random seed of insertion and species assignment"),
        Param("k_n", model.k_n, "normal stiffness, m_p g/d_p"),
        Param("k_t", round(model.k_t, 9), "tangential stiffness k_t = kt_over_kn k_n"),
        Param("xi_n", round(model.xi_n, 9), f"normal damping rate (x m_eff): e_n = {scene['contact']['e_n']} for a d_p pair"),
        Param("xi_t", round(model.xi_t, 9), "tangential damping rate xi_t = xi_t_over_xi_n xi_n"),
        *contact_law_params(model),
        Param("friction", model.friction, "particle-particle sliding friction mu_p"),
        Param("wall_friction", model.wall_friction, "particle-wall sliding friction"),
        Param("fill_friction", scene["protocol"]["fill_friction"], "friction while the bed settles"),
        Param("t_c_min", round(model.stiffest.t_c, 9), f"shortest contact time ({model.stiffest.name}), sqrt(d_p/g)"),
        Param("dt", round(dt, 10), f"time step = {dt / model.stiffest.t_c:.4g} t_c_min"),
        Param("skin", skin, "neighbour skin, d_p (>= 2 v_max dt; bin size from the largest cutoff)"),
        Param("neigh_one", neigh["neigh_one"], f"max neighbours per particle (size ratio {neigh['size_ratio']:.3g})"),
        Param("neigh_page", neigh["neigh_page"], "neighbour page size (>= 10 neigh_one)"),
        Param("n_settle", steps(scene["protocol"]["settle_time"]), "steps to settle the rained bed"),
        Param("lid_speed", 0.2, "speed of the compressing lid, d_p/sqrt(d_p/g)"),
        Param("n_relax", steps(0.2 * scene["protocol"]["settle_time"]), "steps to relax the bed under the lid (0.2 settle_time)"),
        Param("n_segment", thermo_multiple(rung["t_segment"]), "steps per flow/averaging segment"),
        Param("n_thermo", n_thermo, "steps between thermo samples"),
        Param("n_dump", thermo_multiple(rung["dump_interval"]), "steps between dumped frames"),
    ]
    for prm in params:
        number(prm.value)

    n_types = len(diameters)
    species_split = [{"to_type": i + 1, "count": counts[i]} for i in range(1, n_types)]
    columns = list(eff["dump_columns"])
    if eff["spin_output"]:
        columns += SPIN_COLUMNS
    if eff["per_atom_stress"]:
        columns += STRESS_COLUMNS
    context = {
        "contact": contact_law_context(model),
        "scene": "channel",
        "rung": rung_name,
        "units_note": "lj: length d_p, mass m_p, time sqrt(d_p/g)",
        "effects": eff,
        "ntypes": n_types,
        "species": [{"type": i + 1, "diameter": d} for i, d in enumerate(diameters)],
        "species_split": species_split,
        "dump_columns": columns,
    }
    record = {
        "scene": "channel",
        "rung": rung_name,
        "case": case,
        "rung_knobs": rung,
        "parameters": {prm.name: prm.value for prm in params},
        "contacts": [
            {"name": c.name, "m_eff": c.m_eff, "t_c": c.t_c, "e_n": c.e_n} for c in model.contacts
        ],
        "contact_law": model.record(),
        "n_flow_segments": max(1, math.ceil(rung["t_flow_max"] / rung["t_segment"] - 1e-9)),
        "n_average_segments": max(1, math.ceil(rung["t_average"] / rung["t_segment"] - 1e-9)),
        "dt": dt,
        "t_segment": thermo_multiple(rung["t_segment"]) * dt,
        "dump_columns": columns,
        "density": p["density"],
        "species": [{"type": i + 1, "diameter": d, "count": counts[i], "mass": sphere_mass(d, p["density"])}
                    for i, d in enumerate(diameters)],
        "effects": eff,
        "protocol": scene["protocol"],
        "guards": scene["guards"],
    }
    return params, {**context, "record": record}
