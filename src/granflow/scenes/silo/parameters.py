"""Physical parameters of the 3D polydisperse silo (Rubio-Largo, Maza & Hidalgo 2016), SI units.

A flat-bottomed cylinder of radius :math:`R_c` (axis x = y = 0, floor at
z = 0) with a circular orifice of radius :math:`R` in the floor. The fill is an
fcc lattice gas of the seven sizes (equal numbers, random order) that settles
under gravity with the orifice closed; then the orifice opens and particles
that fall below it are deleted (``fix evaporate``), optionally re-created
above the free surface.

Everything here is computed once in Python and reaches the deck as numbers;
the gas positions reach LAMMPS as a data file of numbers written here.
"""
from __future__ import annotations

import functools
import math
from pathlib import Path

import numpy as np

from granflow.scene_files import check_rung
from granflow.contact import (Contact, ContactModel, TypePair, contact_block_model, contact_law, contact_time,
                              damping_for_restitution, per_pair_model, restitution_contacts)
from granflow.deck import Param, StepClock, number, contact_law_context, contact_law_params, record_head, shared_si_params
from granflow.preflight import PreflightError, check_time_step, neighbor_settings


def species(scene: dict) -> list[dict]:
    """Per-species radius, mass and volume (types 1 ... n, smallest first)."""
    p = scene["particles"]
    out = []
    for i, f in enumerate(p["radius_fractions"]):
        r = f * p["r_b"]
        v = 4.0 / 3.0 * math.pi * r**3
        out.append({"type": i + 1, "radius": r, "diameter": 2 * r, "volume": v, "mass": p["density"] * v})
    return out


def hertz_stiffness(Y: float, r_i: float, r_j: float, m_i: float, m_j: float, V_c: float) -> float:
    r"""Linear stiffness of the paper's eq. 10 (linearised Hertz at impact velocity :math:`V_c`).

    .. math::

        k_n = \frac{16}{15}\sqrt{R_{eff}}\,Y
              \left(\frac{15\, m_{eff} V_c^2}{16 \sqrt{R_{eff}}\, Y}\right)^{1/5}

    with :math:`R_{eff} = r_i r_j/(r_i + r_j)`, :math:`m_{eff} = m_i m_j/(m_i + m_j)`.
    The paper prints :math:`\sqrt{R_{eff} Y}`; only :math:`\sqrt{R_{eff}}\,Y` has units of
    force/length (the Hertz stiffness :math:`\propto Y\sqrt{R\delta}`), so that is used.
    """
    return eq10_stiffness(Y, r_i * r_j / (r_i + r_j), m_i * m_j / (m_i + m_j), V_c)


def eq10_stiffness(Y: float, R_eff: float, m_eff: float, V_c: float) -> float:
    """The paper's eq. 10 for a contact of effective radius ``R_eff`` and reduced mass ``m_eff``
    (a sphere against a flat wall: :math:`R_{eff} = r_i`, :math:`m_{eff} = m_i`); see
    :func:`hertz_stiffness`."""
    s = math.sqrt(R_eff) * Y
    return 16.0 / 15.0 * s * (15.0 * m_eff * V_c**2 / (16.0 * s)) ** 0.2


def contact_model(scene: dict, rung: dict) -> tuple[ContactModel, list[dict]]:
    """The contact law of the rung (``contact.model`` or the rung's ``contact_model``):
    :func:`single_spring_model` or :func:`eq10_pair_model` (the paper's); and the eq. 10
    stiffness of every pair (``eq10_pairs``)."""
    if contact_law(scene["contact"], rung) == "hooke/pair_eq10":
        return eq10_pair_model(scene, rung)
    return single_spring_model(scene, rung)


def eq10_pair_model(scene: dict, rung: dict) -> tuple[ContactModel, list[dict]]:
    r"""The paper's law: every pair's k_n from eq. 10 at its own R_eff and m_eff, damped for e_n (eq. 11).

    The seven sizes are seven atom types, so LAMMPS ``pair granular`` per type pair gives
    every pair of the paper its eq. 10 stiffness exactly; ``damping coeff_restitution``
    gives each the paper's e_n (eq. 11 is printed without its square root; read as the
    damping of restitution e_n, which is what it is for) and the tangential damping is
    ``xi_t_over_xi_n`` of the normal one (paper: :math:`\gamma_t/\gamma_n = 0.1`). A wall
    is a flat surface of infinite mass: :math:`R_{eff} = r_i`, :math:`m_{eff} = m_i` (not
    stated in the paper). The frozen rim ring (the last type) acts on each size as a wall.
    """
    c = scene["contact"]
    sp = species(scene)
    Y, V_c, e = rung["Y_factor"] * c["youngs_modulus"], c["impact_velocity"], c["e_n"]
    rim = len(sp) + 1
    pairs, contacts, eq10 = [], [], []
    for i, a in enumerate(sp):
        for b in sp[i:]:
            m_eff = a["mass"] * b["mass"] / (a["mass"] + b["mass"])
            k = hertz_stiffness(Y, a["radius"], b["radius"], a["mass"], b["mass"], V_c)
            pairs.append(TypePair(a["type"], b["type"], k, e, c["kt_over_kn"] * k, m_eff))
            contacts.append((f"r{a['type']}-r{b['type']} pair", k, m_eff, e))
            eq10.append({"pair": f"r{a['type']}-r{b['type']}", "k_n_eq10": k})
    for a in sp:
        k = eq10_stiffness(Y, a["radius"], a["mass"], V_c)
        pairs.append(TypePair(a["type"], None, k, e, c["kt_over_kn"] * k, a["mass"]))
        pairs.append(TypePair(a["type"], rim, k, e, c["kt_over_kn"] * k, a["mass"]))
        contacts.append((f"r{a['type']}-wall", k, a["mass"], e))
    big = pairs[-2]  # the rim's own pairs are excluded from the neighbour list; any coefficients do
    pairs.append(TypePair(rim, rim, big.k_n, e, big.k_t, big.m_eff))
    return per_pair_model(c, "hooke/pair_eq10", pairs, restitution_contacts(contacts)), eq10


def single_spring_model(scene: dict, rung: dict) -> tuple[ContactModel, list[dict]]:
    """One k_n for all pairs: eq. 10 for two largest spheres, damping for e_n of that pair.

    ``gran/hooke/history`` has one k_n; eq. 10 gives each pair its own, from
    the reference (largest) pair down to 0.56 of it for the smallest pair. The
    per-pair eq. 10 stiffness of every pair is listed (``eq10_pairs``) beside
    the t_c and e_n that the single k_n gives it. Every particle-wall contact is
    listed too; the shortest contact (the smallest pair) limits the time step.
    """
    c = scene["contact"]
    sp = species(scene)
    Y = rung["Y_factor"] * c["youngs_modulus"]
    big = sp[-1]
    k_n = hertz_stiffness(Y, big["radius"], big["radius"], big["mass"], big["mass"], c["impact_velocity"])
    xi_n = damping_for_restitution(k_n, big["mass"] / 2.0, c["e_n"])
    contacts, eq10 = [], []
    for i, a in enumerate(sp):
        for b in sp[i:]:
            m_eff = a["mass"] * b["mass"] / (a["mass"] + b["mass"])
            contacts.append(Contact(f"r{a['type']}-r{b['type']} pair", m_eff, *contact_time(k_n, m_eff, xi_n)))
            eq10.append({"pair": f"r{a['type']}-r{b['type']}",
                         "k_n_eq10": hertz_stiffness(Y, a["radius"], b["radius"], a["mass"], b["mass"],
                                                     c["impact_velocity"])})
        contacts.append(Contact(f"r{a['type']}-wall", a["mass"], *contact_time(k_n, a["mass"], xi_n)))
    return contact_block_model(c, k_n, xi_n, contacts), eq10


def beverloo_estimate(scene: dict, R: float) -> float:
    r"""Outflow estimate :math:`W = C \rho_b \sqrt g (D - k d)^{5/2}`, kg/s (for checks only).

    :math:`\rho_b = \phi_{bed}\rho`, :math:`D = 2R`, :math:`d` the mean diameter;
    C and k are ``protocol.beverloo_C/k``, never fitted values.
    """
    proto, p = scene["protocol"], scene["particles"]
    d = 2 * p["r_b"] * float(np.mean(p["radius_fractions"]))
    rho_b = proto["phi_bed_estimate"] * p["density"]
    gap = max(0.0, 2 * R - proto["beverloo_k"] * d)
    return proto["beverloo_C"] * rho_b * math.sqrt(proto["gravity"]) * gap**2.5


def gas_count(scene: dict, rung: dict) -> int:
    """Particles of the gas: the multiple of the species count nearest to
    :math:`\\phi_{bed}\\pi R_c^2 H / \\langle V \\rangle` (a formula: nothing is built)."""
    sp = species(scene)
    r_b = scene["particles"]["r_b"]
    R_c, H = rung["R_c"] * r_b, rung["fill_height"] * r_b
    v_mean = float(np.mean([s["volume"] for s in sp]))
    n_sp = len(sp)
    return n_sp * max(1, round(scene["protocol"]["phi_bed_estimate"] * math.pi * R_c**2 * H / v_mean / n_sp))


def gas_lattice(scene: dict, rung: dict, seed: int) -> dict:
    """Sites of the fcc gas in the cylinder and the species of each (equal numbers, random order).

    The nearest-neighbour distance is ``gas_spacing`` x 2 r_b, so no two
    particles touch; sites keep one r_b (+2 %) from the side wall and the floor.
    The lowest ``n`` sites are used, ``n`` the multiple of the species count
    nearest to :math:`\\phi_{bed}\\pi R_c^2 H / \\langle V \\rangle`.
    """
    sp = species(scene)
    r_b = scene["particles"]["r_b"]
    R_c = rung["R_c"] * r_b
    n_sp = len(sp)
    n = gas_count(scene, rung)
    a = scene["protocol"]["gas_spacing"] * 2 * r_b * math.sqrt(2.0)  # fcc cube edge
    r_in = R_c - 1.02 * r_b
    if r_in < 0.75 * a:
        raise PreflightError(f"silo radius R_c = {rung['R_c']:g} r_b is too small for the gas lattice: "
                             f"allowed R_c >= {(0.75 * a + 1.02 * r_b) / r_b:.3g} r_b")
    m = int(math.ceil(r_in / a)) + 1
    g = np.arange(-m, m + 1)
    base = np.array([[0, 0, 0], [0.5, 0.5, 0], [0.5, 0, 0.5], [0, 0.5, 0.5]])
    layers = []
    k = 0
    count = 0
    while count < n:
        cells = np.array([[i, j, k] for i in g for j in g], dtype=float)
        pts = (cells[:, None, :] + base[None, :, :]).reshape(-1, 3) * a
        pts[:, 2] += 1.02 * r_b
        pts = pts[np.hypot(pts[:, 0], pts[:, 1]) <= r_in]
        for z in np.unique(pts[:, 2]):
            layer = pts[pts[:, 2] == z]
            layers.append(layer)
            count += len(layer)
        k += 1
        if k > 100000:
            raise PreflightError("gas lattice did not fill: check R_c and fill_height")
    sites = np.concatenate(layers)[:n]
    rng = np.random.default_rng(seed)
    types = rng.permutation(np.repeat(np.arange(1, n_sp + 1), n // n_sp))
    return {"positions": sites, "types": types, "n": n, "counts": [n // n_sp] * n_sp,
            "gas_top": float(sites[:, 2].max()), "a": a}


def rim_ring(R: float, r_s: float) -> dict:
    """Frozen spheres that round the orifice rim: radius r_s/2, inscribed in the corner.

    LAMMPS region walls have faces, not edges: in the union of the silo and the
    orifice column a contact point that falls inside the other part is dropped,
    so a particle crossing the rim feels neither the floor nor the orifice wall
    until its centre passes below the floor, and then meets the orifice wall at
    an overlap of up to its radius (measured: the overlap guard stopped a smoke
    silo at 0.56 d_min). A ring of frozen spheres of radius :math:`\rho`, centred
    at :math:`(R + \rho, -\rho)` and so tangent to the floor and to the orifice
    wall, gives the corner a rounded surface that particles meet gradually; the
    orifice radius stays R. Neighbours overlap (spacing 1.8 rho) so no gap opens.
    """
    rho = 0.5 * r_s
    n = int(math.ceil(2 * math.pi * (R + rho) / (1.8 * rho)))
    phi = 2 * math.pi * np.arange(n) / n
    pos = np.column_stack([(R + rho) * np.cos(phi), (R + rho) * np.sin(phi), np.full(n, -rho)])
    return {"positions": pos, "radius": rho, "n": n}


def write_gas_data(path: str | Path, gas: dict, sp: list[dict], box: dict, density: float,
                   rim: dict | None = None) -> None:
    """LAMMPS data file (atom_style sphere: id type diameter density x y z) of the gas (+ rim ring)."""
    diam = {s["type"]: s["diameter"] for s in sp}
    n_rim = rim["n"] if rim else 0
    lines = ["granflow silo gas: fcc lattice, equal numbers of each size, random order"
             + ("; frozen rim ring of the last type" if rim else ""), "",
             f"{gas['n'] + n_rim} atoms", f"{len(sp) + (1 if rim else 0)} atom types", "",
             f"{box['x_lo']:.9g} {box['x_hi']:.9g} xlo xhi", f"{box['x_lo']:.9g} {box['x_hi']:.9g} ylo yhi",
             f"{box['z_lo']:.9g} {box['z_hi']:.9g} zlo zhi", "", "Atoms # sphere", ""]
    for i, (t, (x, y, z)) in enumerate(zip(gas["types"], gas["positions"]), start=1):
        lines.append(f"{i} {int(t)} {diam[int(t)]:.12g} {density:.9g} {x:.9g} {y:.9g} {z:.9g}")
    for j, (x, y, z) in enumerate(rim["positions"] if rim else [], start=gas["n"] + 1):
        lines.append(f"{j} {len(sp) + 1} {2 * rim['radius']:.12g} {density:.9g} {x:.9g} {y:.9g} {z:.9g}")
    Path(path).write_text("\n".join(lines) + "\n")


def silo_parameters(scene: dict, rung_name: str, case: dict | None = None) -> tuple[list[Param], dict]:
    """All numbers of a silo deck, the template context, and the gas to write."""
    case = dict(scene["case"], **(case or {}))
    rung = check_rung(scene, rung_name)
    eff, proto, p = scene["effects"], scene["protocol"], scene["particles"]
    if set(eff["walls"]) != {"side", "floor"}:
        raise PreflightError(f"effects.walls = {eff['walls']}: the silo needs both the side wall and the "
                             f"floor with the orifice: allowed [side, floor]")
    sp = species(scene)
    model, eq10 = contact_model(scene, rung)
    dt = rung["dt_fraction"] * model.stiffest.t_c
    check_time_step(dt, model, scene["contact"]["dt_max_fraction"])
    r_b, g = p["r_b"], proto["gravity"]
    R, R_c = case["R"] * r_b, rung["R_c"] * r_b
    if R > R_c - 2 * r_b:
        raise PreflightError(f"orifice radius R = {case['R']:g} r_b does not fit the silo of R_c = "
                             f"{rung['R_c']:g} r_b: allowed R <= R_c - 2 = {rung['R_c'] - 2:g} r_b")
    gas = gas_lattice(scene, rung, int(case["seed"]))
    rim = rim_ring(R, sp[0]["radius"])
    z_top = gas["gas_top"] + 3 * r_b
    # the deletion plane: 1.05 r_b below the orifice in the orifice column (the original geometry), or
    # delete_depth r_b below a floor plate as thick as the rim's spheres (open below to R_c)
    depth = rung.get("delete_depth")
    plate = depth is not None
    z_delete = -(depth if plate else 1.05) * r_b
    box = {"x_lo": -R_c - 2 * r_b, "x_hi": R_c + 2 * r_b, "z_lo": -max(12.0, (depth or 0.0) + 4.0) * r_b,
           "z_hi": z_top}
    d_min = 2 * sp[0]["radius"]
    # fastest motion: free fall from the top of the gas to below the orifice, with margin
    v_max = 1.5 * math.sqrt(2 * g * (z_top - box["z_lo"]))
    skin = scene["contact"]["neighbor_skin"] * d_min
    neigh = neighbor_settings([s["diameter"] for s in sp], skin, dt, v_max)
    W_est = beverloo_estimate(scene, R)

    clock = StepClock(dt, rung["thermo_interval"])
    steps, thermo_multiple, n_thermo = clock.steps, clock.thermo_multiple, clock.n_thermo

    n_segment = thermo_multiple(rung["t_segment"])
    n_dump = steps(rung["dump_interval"])
    t_segment = n_segment * dt
    H = rung["fill_height"] * r_b
    ins_lo, ins_hi = H + 1.5 * r_b, min(H + 16 * r_b, z_top - 1.1 * r_b)
    params = [
        Param("r_b", r_b, "largest radius, m"),
        Param("R", round(R, 12), f"orifice radius ({case['R']:g} r_b), m"),
        Param("R_c", round(R_c, 12), f"silo radius ({rung['R_c']:g} r_b), m"),
        Param("x_lo", round(box["x_lo"], 12), "box: -R_c - 2 r_b, m"),
        Param("x_hi", round(box["x_hi"], 12), "box: R_c + 2 r_b, m"),
        Param("z_lo", round(box["z_lo"], 12), "box bottom, below the orifice, m"),
        Param("z_hi", round(box["z_hi"], 12), "box top, above the gas, m"),
        Param("z_delete", round(z_delete, 12), "particles whose centre is below this are deleted, m"),
        Param("z_hole", round(0.01 * r_b, 12), "top of the orifice column (just above the floor), m"),
        Param("ins_lo", round(ins_lo, 12), "re-insertion slab bottom (fill height + 1.5 r_b), m"),
        Param("ins_hi", round(ins_hi, 12), "re-insertion slab top, m"),
        Param("ins_r", round(R_c - 1.1 * r_b, 12), "re-insertion slab radius, m"),
        Param("insert_speed", 1.0, "downward speed given to the particles in the re-insertion slab, m/s"),
        Param("fill_height", round(H, 12), f"bed height at rest ({rung['fill_height']:g} r_b), m"),
        Param("n_particles", gas["n"], "particles in the gas (equal numbers of each size)"),
        Param("n_per_type", gas["counts"][0], "particles of each size"),
        Param("density", p["density"], "material density, kg/m^3"),
        Param("gravity", g, "gravitational acceleration, m/s^2"),
        Param("seed", int(case["seed"]), "random seed (re-insertion)"),
        Param("d_min", round(d_min, 12), "smallest diameter, m"),
        Param("k_n", round(model.k_n, 6), (f"normal stiffness: eq. 10 for two r_b spheres at Y = {rung['Y_factor'] * scene['contact']['youngs_modulus']:.4g} Pa, N/m"
                                           if not model.per_pair else "softest type pair's normal stiffness (record only: the overlap guard divides by each type's own kn_i_i), N/m")),
        Param("xi_n", round(model.xi_n, 9), f"normal damping rate (x m_eff): e_n = {scene['contact']['e_n']} for the r_b pair, 1/s"),
        Param("xi_t", round(model.xi_t, 9), "tangential damping rate xi_t = 0.1 xi_n, 1/s"),
        Param("dt", round(dt, 13), f"time step = {rung['dt_fraction']:g} t_c_min, s"),
        *shared_si_params(model, skin, neigh, scene["guards"]),
        *contact_law_params(model),
        Param("n_settle_min", thermo_multiple(proto["t_settle_min"]), "shortest settling with the orifice closed, steps"),
        Param("n_settle", thermo_multiple(max(proto["t_settle_max"], proto["t_settle_min"])),
              "longest settling with the orifice closed, steps"),
        Param("ke_settled", round(proto["settle_ke_ratio"] * gas["n"] * float(np.mean([s["mass"] for s in sp]))
                                  * g * H, 9),
              f"settled below this kinetic energy: {proto['settle_ke_ratio']:g} M g H, J"),
        Param("n_segment", n_segment, "steps per discharge segment"),
        Param("n_thermo", n_thermo, "steps between thermo samples"),
        Param("n_dump", n_dump, "steps between dumped particle frames"),
        Param("n_contact", n_dump * max(1, round(rung["contact_interval"] / (n_dump * dt))),
              "steps between dumped contact frames (a multiple of n_dump: each has its particle frame)"),
        Param("n_evaporate", steps(rung["evaporate_interval"]), "steps between deletions below the orifice"),
        Param("n_max_delete", gas["n"], "most particles deleted at once (all of them)"),
    ]
    if plate:
        params.append(Param("z_plate", round(-2 * rim["radius"], 12),
                            "underside of the floor plate (as thick as the rim's spheres), m"))
    for prm in params:
        number(prm.value)
    n_seg = max(1, math.ceil(rung["t_discharge"] / t_segment - 1e-9))
    context = {
        "scene": "silo",
        "rung": rung_name,
        "stages": ("init", "average"),
        "units_note": "si: metres, kilograms, seconds",
        "effects": eff,
        "ntypes": len(sp),
        "rim_type": len(sp) + 1,
        "plate": plate,
        "contact": contact_law_context(model),
        "species": [{"type": s["type"], "diameter": round(s["diameter"], 12), "mass": s["mass"]} for s in sp],
        "dump_columns": list(eff["dump_columns"]),
        "data_files": {"atoms.data": functools.partial(write_gas_data, gas=gas, sp=sp, box=box,
                                                       density=p["density"], rim=rim)},
    }
    record = {
        **record_head("silo", rung_name, case, rung, params, model),
        "eq10_pairs": eq10,
        "Y": rung["Y_factor"] * scene["contact"]["youngs_modulus"],
        "k_n": model.k_n,
        "species": [{"type": s["type"], "radius": s["radius"], "mass": s["mass"], "count": gas["counts"][i]}
                    for i, s in enumerate(sp)],
        "r_b": r_b, "R": R, "R_c": R_c, "R_over_rb": case["R"], "fill_height": H,
        "gravity": g,
        "reinsert": bool(eff["reinsert"]),
        "beverloo_estimate": W_est,
        "n_particles": gas["n"],
        "rim": {"type": len(sp) + 1, "n": rim["n"], "radius": rim["radius"]},
        "n_flow_segments": 0,
        "n_average_segments": n_seg,
        "dt": dt,
        "t_segment": t_segment,
        "dump_columns": context["dump_columns"],
        "density": p["density"],
        "effects": eff,
        "protocol": proto,
        "cg": scene["cg"],
        "guards": scene["guards"],
    }
    return params, {**context, "record": record}


def discharge_verdict(segment_thermo, record: dict) -> tuple[str, str] | None:
    """Stop the discharge early, with a named reason, or None to go on.

    ``clogged``: after the first segment (the start-up), the segment's outflow (deleted mass over its duration) is below
    ``protocol.clog_rate_fraction`` of the Beverloo estimate (an arch blocks the
    orifice). ``completed``: the fill height (mass over :math:`\\rho\\phi\\pi R_c^2`)
    fell below ``protocol.empty_height`` x R; the discharge is no longer steady.
    """
    th = segment_thermo
    if th is None or len(th) < 2 or "v_mdel" not in th:
        return None
    if float(th["Time"].iloc[0]) <= 0.0:
        return None  # the first segment includes the start-up: the flow has not reached the orifice yet
    proto = record["protocol"]
    duration = float(th["Time"].iloc[-1] - th["Time"].iloc[0])
    outflow = float(th["v_mdel"].iloc[-1] - th["v_mdel"].iloc[0])
    rate = outflow / duration if duration > 0 else 0.0
    if rate < proto["clog_rate_fraction"] * record["beverloo_estimate"]:
        return ("clogged", f"outflow {rate:.3g} kg/s in the last segment is below "
                           f"{proto['clog_rate_fraction']:g} x the Beverloo estimate "
                           f"{record['beverloo_estimate']:.3g} kg/s: an arch blocks the orifice")
    rho_b = proto["phi_bed_estimate"] * record["density"]
    height = float(th["v_mtot"].iloc[-1]) / (rho_b * math.pi * record["R_c"] ** 2)
    if not record["reinsert"] and height < proto["empty_height"] * record["R"]:
        return ("completed", f"fill height {height / record['r_b']:.3g} r_b fell below "
                             f"{proto['empty_height']:g} R: discharge stopped")
    return None
