"""Deck numbers of the chute (Silbert et al. 2001), computed once from the scene file.

Units (LAMMPS ``lj``): length :math:`d`, mass :math:`m` (material density
:math:`6/\\pi`), time :math:`\\sqrt{d/g}`. The bed holds

.. math::

    N = \\mathrm{round}\\left(\\frac{\\phi_\\mathrm{fill} L_x L_y (H + h_b)}{\\pi d^3/6}\\right)

particles, :math:`h_b` the height below which settled particles become the frozen
base; the flowing depth is measured by the analysis, not assumed.
"""
from __future__ import annotations

import math

from granflow.config import ConfigError
from granflow.scene_files import check_rung
from granflow.contact import Contact, build_contact_model, contact_time, sphere_mass
from granflow.deck import (STRESS_COLUMNS, Param, StepClock, number, contact_law_context, contact_law_params,
                           rain_lattice, record_head, time_step)
from granflow.preflight import PreflightError, check_time_step, neighbor_settings

STAGES = ("init", "flow", "average")


def contact_model(scene: dict, rung: dict):
    """Contact model of a monodisperse bed on a frozen base (no walls).

    The pair of two mobile particles has :math:`m_{eff} = m/2` and is the stiffest
    contact; a base contact (frozen partner) has :math:`m_{eff} = m`.
    """
    p, c = scene["particles"], scene["contact"]
    model_scene = {
        "particles": {"diameters": [p["diameter"]], "density": p["density"]},
        "contact": {**c, "wall_friction": c["friction"]},
        "effects": {"polydisperse": False, "walls": False},
    }
    model = build_contact_model(model_scene, rung)
    m = sphere_mass(p["diameter"], p["density"])
    model.contacts.append(Contact("1-base (frozen)", m, *contact_time(model.k_n, m, model.xi_n)))
    return model


def chute_parameters(scene: dict, rung_name: str, case: dict | None = None) -> tuple[list[Param], dict]:
    """All numbers of a chute deck, and the template context besides them.

    Raises
    ------
    PreflightError
        If the time step does not resolve a contact, or the skin is too small.
    ConfigError
        If the angle is outside 0 < theta <= 60 degrees.
    """
    rung = check_rung(scene, rung_name)
    case = dict(scene["case"], **(case or {}))
    theta = float(case["theta_deg"])
    if not 0.0 < theta <= 60.0:
        raise ConfigError(f"case.theta_deg = {theta:g} is not allowed: allowed 0 < theta_deg <= 60")
    model = contact_model(scene, rung)
    dt = time_step(rung, model)
    check_time_step(dt, model, scene["contact"]["dt_max_fraction"])

    p, proto, eff = scene["particles"], scene["protocol"], scene["effects"]
    d = float(p["diameter"])
    v_particle = math.pi * d**3 / 6.0
    Lx, Ly, H = float(rung["Lx"]), float(rung["Ly"]), float(rung["H"])
    h_b = float(proto["base_height"])
    n_particles = int(round(proto["phi_fill"] * Lx * Ly * (H + h_b) / v_particle))
    # the raining gas: a lattice of cell ~ (v/fill_packing)^(1/3), never narrower than 1.02 d
    a_z, a_x, a_y, n_layers = rain_lattice(n_particles, v_particle, proto["fill_packing"], d, Lx, Ly)
    if min(a_x, a_y) < d:
        raise PreflightError(f"chute Lx = {Lx:g}, Ly = {Ly:g} too small for one lattice cell of {d:g} d")
    fill_height = 0.6 + n_layers * a_z + 1.0

    # fastest expected motion: free fall from the top of the gas, three times over
    v_max = 3.0 * math.sqrt(2.0 * fill_height)
    skin = scene["contact"]["neighbor_skin"]
    neigh = neighbor_settings([d], skin, dt, v_max)

    clock = StepClock(dt, rung["thermo_interval"])
    steps, thermo_multiple, n_thermo = clock.steps, clock.thermo_multiple, clock.n_thermo

    t_fall = math.sqrt(2.0 * fill_height)  # free-fall time of the top of the gas
    params = [
        Param("theta_deg", number(theta), "inclination theta, degrees (gravity tilted towards +x)"),
        Param("Lx", Lx, "periodic length along the flow (x), d"),
        Param("Ly", Ly, "periodic width (y), d"),
        Param("H_nominal", H, "nominal bed depth above the base, d (the analysis measures it)"),
        Param("n_particles", n_particles, "particles inserted (base + bed): phi_fill Lx Ly (H + base_height) / (pi d^3/6)"),
        Param("base_height", h_b, "settled particles with centres below this become the frozen base, d"),
        Param("fill_height", round(fill_height, 6), "box height while the gas rains, d"),
        Param("diameter", d, "particle diameter, d"),
        Param("d_min", d, "smallest diameter (overlap guard), d"),
        Param("density", p["density"], "material density, m/d^3 (a particle has mass 1)"),
        Param("a_x", round(a_x, 9), "gas lattice cell along x, d"),
        Param("a_y", round(a_y, 9), "gas lattice cell along y, d"),
        Param("a_z", round(a_z, 9), "gas lattice cell along z, d"),
        Param("n_layers", n_layers, "lattice layers of the gas"),
        Param("jiggle", round(0.45 * (min(a_x, a_y, a_z) - d), 9), "random displacement of gas particles, d"),
        Param("seed", int(case["seed"]), "random seed of the gas"),
        Param("k_n", model.k_n, "normal stiffness, m g/d"),
        Param("k_t", round(model.k_t, 9), "tangential stiffness k_t = kt_over_kn k_n"),
        Param("xi_n", round(model.xi_n, 9), f"normal damping rate (x m_eff): e_n = {scene['contact']['e_n']:.4g} for a pair"),
        Param("xi_t", round(model.xi_t, 9), "tangential damping rate xi_t = xi_t_over_xi_n xi_n"),
        *contact_law_params(model),
        Param("friction", model.friction, "sliding friction mu"),
        Param("t_c_min", round(model.stiffest.t_c, 9), f"shortest contact time ({model.stiffest.name}), sqrt(d/g)"),
        Param("dt", round(dt, 10), f"time step = {dt / model.stiffest.t_c:.4g} t_c_min"),
        Param("skin", skin, "neighbour skin, d (>= 2 v_max dt)"),
        Param("neigh_one", neigh["neigh_one"], "max neighbours per particle"),
        Param("neigh_page", neigh["neigh_page"], "neighbour page size (>= 10 neigh_one)"),
        Param("max_overlap", scene["guards"]["max_overlap"], "halt: largest overlap / d above this"),
        Param("max_speed", scene["guards"]["max_speed"], "halt: rms particle speed above this, sqrt(g d)"),
        Param("n_fall", steps(1.2 * t_fall), "steps before the settling check: 1.2 x free-fall time of the gas top"),
        Param("n_settle", steps(proto["settle_time"]), "longest settling after the fall"),
        Param("n_settle_check", n_thermo, "steps between settling checks"),
        Param("settle_ke", proto["settle_ke"], "settled below this kinetic energy per particle, m g d"),
        Param("n_segment", thermo_multiple(rung["t_segment"]), "steps per flow/averaging segment"),
        Param("n_thermo", n_thermo, "steps between thermo samples"),
        Param("n_dump", thermo_multiple(rung["dump_interval"]), "steps between dumped frames"),
    ]
    for prm in params:
        number(prm.value)

    columns = list(eff["dump_columns"])
    if eff["per_atom_stress"]:
        columns += STRESS_COLUMNS
    context = {
        "contact": contact_law_context(model),
        "scene": "chute",
        "rung": rung_name,
        "units_note": "lj: length d, mass m, time sqrt(d/g)",
        "effects": eff,
        "dump_columns": columns,
    }
    record = record_head("chute", rung_name, case, rung, params, model)
    del record["schedule"]  # the runner runs flow segments until steady (or arrested)
    t_segment = thermo_multiple(rung["t_segment"]) * dt
    record.update({
        "n_flow_segments": max(1, math.ceil(rung["t_flow_max"] / rung["t_segment"] - 1e-9)),
        "n_average_segments": max(1, math.ceil(rung["t_average"] / rung["t_segment"] - 1e-9)),
        "dt": dt,
        "t_segment": t_segment,
        "dump_columns": columns,
        "density": p["density"],
        "effects": eff,
        "protocol": proto,
        "guards": scene["guards"],
    })
    return params, {**context, "record": record, "stages": STAGES}
