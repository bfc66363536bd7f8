"""Physical parameters of the bounded-heap scene (Fan et al. 2013), in SI units.

The heap is quasi-2D: a box of horizontal length ``W`` (feed-side wall at
x = 0, end wall at x = W), gap ``T`` between flat frictional side walls, and a
granular base inclined at :math:`\\theta` that descends from x = 0 to x = W,

.. math::

    z_{base}(x) = (W - x) \\tan\\theta .

Particles are poured (LAMMPS ``fix pour``) into a feed region above the
feed zone ``0 < x < feed_width`` at the requested mass rate; particles that
touch the base are immobilised (``fix freeze``, velocities zeroed) once per
``freeze_interval``. Only the steady filling stage is simulated.

Everything here is computed once in Python and reaches the deck as numbers.
"""
from __future__ import annotations

import math

from granflow.scene_files import check_rung
from granflow.contact import (ContactModel, TypePair, contact_law, contact_model_for_time, per_pair_model,
                              restitution_contacts, sphere_mass)
from granflow.deck import (Param, StepClock, number, contact_law_context, contact_law_params, record_head,
                           shared_si_params, time_step)
from granflow.preflight import PreflightError, check_time_step, neighbor_settings

#: gravitational acceleration, m/s^2
G = 9.81


def species(scene: dict, mixture: str) -> list[dict]:
    """Per-species size distribution of a mixture.

    Each species is uniform in diameter on :math:`[d(1-\\sqrt3 s), d(1+\\sqrt3 s)]`,
    which has standard deviation :math:`s d` (``size_spread`` = s). Returns, per
    species: type, mean diameter, range, volume fraction, mean particle volume
    :math:`\\langle \\pi d^3/6 \\rangle` and mean mass.
    """
    p = scene["particles"]
    mix = p["mixtures"][mixture]
    s = p["size_spread"] if scene["effects"]["polydisperse"] else 0.0
    out = []
    for i, (d, f) in enumerate(zip(mix["diameters"], mix["volume_fractions"])):
        lo, hi = d * (1 - math.sqrt(3) * s), d * (1 + math.sqrt(3) * s)
        # <d^3> of a uniform distribution on [lo, hi]
        d3 = (hi**4 - lo**4) / (4 * (hi - lo)) if hi > lo else d**3
        v = math.pi / 6 * d3
        out.append({"type": i + 1, "d": d, "d_lo": lo, "d_hi": hi, "volume_fraction": f,
                    "mean_volume": v, "mean_mass": p["density"] * v})
    return out


def contact_model(scene: dict, rung: dict, sp: list[dict]) -> ContactModel:
    """The contact law of the rung (``contact.model`` or the rung's ``contact_model``):
    :func:`single_spring_model` or :func:`pair_time_model` (the paper's)."""
    law = contact_law(scene["contact"], rung)
    if law == "hooke/pair_time":
        return pair_time_model(scene, rung, sp)
    return single_spring_model(scene, rung, sp)


def pair_time_model(scene: dict, rung: dict, sp: list[dict]) -> ContactModel:
    r"""The paper's law: every pair and wall contact lasts ``t_c`` and restitutes ``e`` (Fan et al. 2013, §2.1).

    The paper sets, per contact, :math:`\gamma_n = -\ln e/t_c` (its damping force
    :math:`2\gamma_n m_{eff} v_n`) and :math:`k_n = m_{eff}[(\pi/t_c)^2 + \gamma_n^2]`, so
    :math:`k_n \propto m_{eff}`. LAMMPS's ``pair granular`` takes coefficients per *type* pair:
    each type pair gets the k_n of its species' mean masses (a wall: :math:`m_{eff} = m_i`),
    :math:`k_t = (k_t/k_n)\,k_n`, and ``damping coeff_restitution``, which damps every
    contact from its own :math:`m_{eff}`: e is the paper's for every contact, exactly.
    Inside a species the diameters spread by ``size_spread`` (uniform), so a contact of two
    particles of one species lasts :math:`t_c\sqrt{m_{eff}/\langle m_{eff}\rangle}`: from
    the two smallest to the two largest of a species, 0.71 to 1.25 t_c at the paper's
    spread 0.1 (the paper's per-contact k_n keeps t_c for all). The listed contacts are
    these extremes, so the shortest limits the time step.
    """
    c, rho = scene["contact"], scene["particles"]["density"]
    t_c, e = rung["t_c"], c["e_n"]
    k_of = lambda m_eff: m_eff * ((math.pi / t_c) ** 2 + (math.log(e) / t_c) ** 2)  # noqa: E731
    pairs, contacts = [], []
    for a in sp:
        for b in sp[a["type"] - 1:]:
            m_eff = a["mean_mass"] * b["mean_mass"] / (a["mean_mass"] + b["mean_mass"])
            k = k_of(m_eff)
            pairs.append(TypePair(a["type"], b["type"], k, e, c["kt_over_kn"] * k, m_eff))
            for la, lb in (("d_lo", "d_lo"), ("d_hi", "d_hi")):
                ma, mb = sphere_mass(a[la], rho), sphere_mass(b[lb], rho)
                contacts.append((f"{a[la]:g}-{b[lb]:g} pair", k, ma * mb / (ma + mb), e))
        k = k_of(a["mean_mass"])
        pairs.append(TypePair(a["type"], None, k, e, c["kt_over_kn"] * k, a["mean_mass"]))
        for la in ("d_lo", "d_hi"):
            contacts.append((f"{a[la]:g}-wall", k, sphere_mass(a[la], rho), e))
    return per_pair_model(c, "hooke/pair_time", pairs, restitution_contacts(contacts))


def single_spring_model(scene: dict, rung: dict, sp: list[dict]) -> ContactModel:
    """One k_n for all pairs, set by t_c of two particles of the largest species' mean diameter.

    The paper gives every pair the same t_c (a stiffness proportional to the
    reduced mass); ``gran/hooke/history`` has one k_n. Referring it to the
    largest species keeps their overlaps at the paper's level; smaller pairs are
    then stiffer than in the paper (shorter t_c, by sqrt(m_small/m_large)),
    which costs time steps but not accuracy. Referring it to the smallest
    species instead let 2 mm particles of a 1/2 mm mix overlap by more than a
    small diameter on impact (measured: the overlap guard stopped the smoke case).
    Contacts are listed for the smallest and largest particle of every species,
    so the shortest contact of the case (the smallest particles' pair) limits dt.
    """
    sizes = sorted({round(x, 12) for s in sp for x in (s["d_lo"], s["d"], s["d_hi"])})
    return contact_model_for_time(scene["contact"], scene["particles"]["density"], rung["t_c"],
                                  d_ref=sp[-1]["d"], diameters=sizes, walls=True)


def _geometry(scene: dict, rung: dict, sp: list[dict]) -> dict:
    theta = math.radians(scene["geometry"]["theta_deg"])
    W, T = rung["W"], rung["T"]
    r_max = max(s["d_hi"] for s in sp) / 2
    z_base0 = W * math.tan(theta)
    feed_lo = z_base0 + rung["feed_drop"]
    feed_hi = feed_lo + rung["feed_height"]
    region = {"x_lo": r_max, "x_hi": rung["feed_width"] - r_max,
              "y_lo": r_max, "y_hi": T - r_max, "z_lo": feed_lo, "z_hi": feed_hi}
    if region["x_hi"] - region["x_lo"] <= 0 or region["y_hi"] - region["y_lo"] <= 0:
        raise PreflightError(
            f"feed region is empty: feed_width = {rung['feed_width']:g} m and T = {T:g} m must exceed "
            f"the largest diameter {2 * r_max:.4g} m; a value that passes: T >= {4 * r_max:.3g}")
    return {"theta": theta, "W": W, "T": T, "r_max": r_max, "z_base0": z_base0, "region": region,
            "z_top": feed_hi + 2 * r_max, "z_bottom": -2 * r_max}


def _rung_and_model(scene: dict, rung_name: str, case: dict):
    rung = check_rung(scene, rung_name)
    sp = species(scene, case["mixture"])
    model = contact_model(scene, rung, sp)
    dt = time_step(rung, model)
    check_time_step(dt, model, scene["contact"]["dt_max_fraction"])
    return rung, sp, model, dt


def feed_plan(scene: dict, rung_name: str, case: dict) -> dict:
    r"""How ``fix pour`` delivers the requested mass rate, or a refusal.

    Particles enter the feed region with downward speed ``feed_speed`` (v0).
    ``fix pour`` inserts ``nper`` particles every ``nfreq`` steps, ``nfreq`` the
    time to fall through the region of height H,
    :math:`t_f = (\sqrt{v_0^2 + 2gH} - v_0)/g`, in steps (rounded), and
    ``nper = floor(vol V_region / V_max)`` with ``V_max`` the volume of the
    largest particle. Each species pours its share of the mass rate (mixtures
    are equal volumes). The delivered rate is

    .. math::

        \dot m = \frac{\sum_i n_{per,i} \langle m_i \rangle}{n_{freq}\, dt}.

    ``fix pour`` draws insertion heights :math:`h = h_{top} - u^2 H` (u uniform),
    so a fraction :math:`\sqrt{d/H}` of each batch lands in the top slab of one
    largest diameter d, where random insertion fails first. The volume fraction
    of that slab, :math:`n_{per}\sqrt{d/H}\langle V\rangle/(A d)` (A the region's
    cross-section), may not exceed ``protocol.feed_max_fraction``. Measured on
    the demo feed zone: at 0.64 one insertion in five fell short, at 0.2 none.

    Raises
    ------
    PreflightError
        If the feed region cannot deliver the rate (the message gives the largest
        feasible rate), or if rounding ``nper`` misses the rate by more than half
        of ``protocol.feed_rate_tol``.
    """
    rung, sp, model, dt = _rung_and_model(scene, rung_name, case)
    geo = _geometry(scene, rung, sp)
    reg = geo["region"]
    proto = scene["protocol"]
    H = reg["z_hi"] - reg["z_lo"]
    area = (reg["x_hi"] - reg["x_lo"]) * (reg["y_hi"] - reg["y_lo"])
    v0 = rung["feed_speed"]
    nfreq = int((math.sqrt(v0**2 + 2 * G * H) - v0) / G / dt + 0.5)
    period = nfreq * dt
    rate = case["feed_rate"]
    d_top = max(s["d_hi"] for s in sp)
    slab = math.sqrt(min(1.0, d_top / H)) / (area * d_top)  # top-slab fraction per unit particle volume
    rho = scene["particles"]["density"]
    # the mass per insertion at which the top slab reaches the limit
    rate_max = proto["feed_max_fraction"] / slab * rho / period
    if rate > rate_max:
        raise PreflightError(
            f"feed rate {rate:g} kg/s is more than the feed region can deliver: the region "
            f"({reg['x_hi'] - reg['x_lo']:.4g} x {reg['y_hi'] - reg['y_lo']:.4g} x {H:.4g} m, entry speed "
            f"{v0:g} m/s, filled every {period:.4g} s) would pack its top slab above the volume fraction "
            f"{proto['feed_max_fraction']:g}; largest feasible rate {rate_max:.4g} kg/s "
            f"(or raise the rung's feed_width or feed_speed)")
    pours = []
    for s in sp:
        target = s["volume_fraction"] * rate * period / s["mean_mass"]
        nper = max(1, int(round(target)))
        v_max = math.pi / 6 * s["d_hi"] ** 3
        vol = (nper + 0.5) * v_max / (area * H)  # LAMMPS: nper = floor(vol V_region / V_max)
        pours.append({"type": s["type"], "nper": nper, "vol": vol, "d_lo": s["d_lo"], "d_hi": s["d_hi"],
                      "rate": nper * s["mean_mass"] / period})
    planned = sum(p["rate"] for p in pours)
    if abs(planned / rate - 1) > 0.5 * proto["feed_rate_tol"]:
        raise PreflightError(
            f"feed rate {rate:g} kg/s cannot be resolved: whole particles per insertion give "
            f"{planned:.4g} kg/s ({', '.join(str(p['nper']) for p in pours)} per {period:.4g} s), "
            f"off by {100 * (planned / rate - 1):.1f} %, limit {50 * proto['feed_rate_tol']:g} %; "
            f"raise the rung's feed_height or lower its feed_speed (more particles per insertion)")
    top = sum(p["nper"] * s["mean_volume"] for p, s in zip(pours, sp)) * slab
    return {"nfreq": nfreq, "period": period, "pours": pours, "rate_planned": planned, "rate_max": rate_max,
            "region": reg, "top_slab_fraction": top, "dt": dt, "feed_speed": v0}


def steady_time_estimate(scene: dict, rung: dict, case: dict, sp: list[dict], geo: dict) -> float:
    """Time until the deposit is ``steady_depth`` largest diameters deep everywhere.

    The fall from the feed region, then the mass of the wedge between the base
    (:math:`\\theta`) and a surface at the estimated dynamic angle, plus a layer
    of ``steady_depth`` d_max over the whole length, at the bed volume fraction
    ``phi_bed_estimate`` (paper: :math:`t_0 \\approx 10 d_l / v_r`).
    """
    proto = scene["protocol"]
    rho, phi = scene["particles"]["density"], proto["phi_bed_estimate"]
    W, T = rung["W"], rung["T"]
    alpha = math.radians(max(proto["alpha_estimate_deg"], scene["geometry"]["theta_deg"]))
    wedge = 0.5 * W**2 * (math.tan(alpha) - math.tan(geo["theta"])) * T
    layer = W * T * rung["steady_depth"] * 2 * geo["r_max"] / math.cos(geo["theta"])
    v0 = rung["feed_speed"]
    fall = (math.sqrt(v0**2 + 2 * G * geo["region"]["z_hi"]) - v0) / G
    return fall + rho * phi * (wedge + layer) / case["feed_rate"]


#: largest over smallest diameter from which the deck bins neighbours per species
#: (``neighbor multi``, ``comm_modify mode multi``). bench/bench_decks.py on 2 ranks: the 1/2 mm
#: validation heap (20.7k particles, ratio 2.1) ran 0.59 and 0.87 of the multi variant in two
#: runs of 2026-11-24, commit 931c90a (3.0 against 5.1, 3.6 against 4.1 Matom-step/s); the mono 1.5 mm demo heap
#: (ratio 1.2) the same either way (6.39 against 6.32).
MULTI_NEIGHBOR_RATIO = 1.5


def heap_parameters(scene: dict, rung_name: str, case: dict | None = None) -> tuple[list[Param], dict]:
    """All numbers of a heap deck, and the template context besides them."""
    case = dict(scene["case"], **(case or {}))
    rung, sp, model, dt = _rung_and_model(scene, rung_name, case)
    geo = _geometry(scene, rung, sp)
    plan = feed_plan(scene, rung_name, case)
    eff, proto = scene["effects"], scene["protocol"]
    d_min = min(s["d_lo"] for s in sp)
    d_ref = sp[-1]["d"]
    size_ratio = max(s["d_hi"] for s in sp) / d_min

    v_max = 1.5 * math.sqrt(2 * G * (geo["z_top"] - geo["z_bottom"]))  # free fall over the box, with margin
    skin = scene["contact"]["neighbor_skin"] * d_ref
    neigh = neighbor_settings([s["d_lo"] for s in sp] + [s["d_hi"] for s in sp], skin, dt, v_max)

    steps = StepClock(dt).steps

    nfreq = plan["nfreq"]
    # segments are whole numbers of feed periods, so the pour keeps its cadence across restarts
    n_segment = nfreq * max(1, int(round(rung["t_segment"] / (nfreq * dt))))
    t_segment = n_segment * dt
    t_steady = steady_time_estimate(scene, rung, case, sp, geo)
    reg = plan["region"]
    params = [
        Param("W", rung["W"], "horizontal length: feed-side wall x = 0 to end wall x = W, m"),
        Param("T", rung["T"], "gap between the side walls (y = 0, y = T), m"),
        Param("theta", round(geo["theta"], 12), f"base inclination, rad ({scene['geometry']['theta_deg']:g} deg)"),
        Param("sin_theta", round(math.sin(geo["theta"]), 12), "sin(theta): base normal (sin, 0, cos)"),
        Param("cos_theta", round(math.cos(geo["theta"]), 12), "cos(theta)"),
        Param("z_base0", round(geo["z_base0"], 9), "base height at x = 0: W tan(theta), m"),
        Param("z_bottom", round(geo["z_bottom"], 9), "box bottom, m"),
        Param("z_top", round(geo["z_top"], 9), "lowest box top, above the feed region (the top shrink-wraps above it), m"),
        Param("feed_xlo", round(reg["x_lo"], 9), "feed region, inset by the largest radius from the walls, m"),
        Param("feed_xhi", round(reg["x_hi"], 9), "feed region x upper bound, m"),
        Param("feed_ylo", round(reg["y_lo"], 9), "feed region y lower bound, m"),
        Param("feed_yhi", round(reg["y_hi"], 9), "feed region y upper bound, m"),
        Param("feed_zlo", round(reg["z_lo"], 9), "feed region bottom: z_base0 + feed_drop, m"),
        Param("feed_zhi", round(reg["z_hi"], 9), "feed region top, m"),
        Param("feed_rate", number(case["feed_rate"]), "requested mass feed rate, kg/s"),
        Param("feed_rate_planned", round(plan["rate_planned"], 9), "rate the pour delivers: sum nper <m> / (nfreq dt), kg/s"),
        Param("feed_attempts", proto["feed_attempts"], "insertion attempts per particle"),
        Param("feed_speed", rung["feed_speed"], "downward speed of the poured particles, m/s"),
        Param("density", scene["particles"]["density"], "material density, kg/m^3"),
        Param("gravity", G, "gravitational acceleration, m/s^2"),
        Param("seed", int(case["seed"]), "random seed of the feed (each segment adds its index)"),
        Param("d_min", round(d_min, 12), "smallest diameter, m"),
        Param("d_ref", d_ref, "reference diameter (largest species' mean): its pair has contact time t_c, m"),
        Param("k_n", round(model.k_n, 9), (f"normal stiffness: t_c = {rung['t_c']:g} s, e = {scene['contact']['e_n']} for the d_ref pair, N/m"
                                           if not model.per_pair else "softest type pair's normal stiffness (record only: the overlap guard divides by each type's own kn_i_i), N/m")),
        Param("xi_n", round(model.xi_n, 9), "normal damping rate -2 ln(e)/t_c (force m_eff xi_n v_n), 1/s"),
        Param("xi_t", round(model.xi_t, 9), "tangential damping rate, 1/s"),
        Param("dt", round(dt, 12), f"time step = {dt / model.stiffest.t_c:.4g} t_c_min, s"),
        *shared_si_params(model, skin, neigh, scene["guards"]),
        *contact_law_params(model),
        Param("n_feed", nfreq, "steps between insertions (free fall through the feed region)"),
        Param("n_segment", n_segment, "steps per segment (a whole number of insertion periods)"),
        Param("n_thermo", steps(rung["thermo_interval"]), "steps between thermo samples"),
        Param("n_dump", steps(rung["dump_interval"]), "steps between dumped frames"),
        Param("n_freeze", steps(rung["freeze_interval"]), "steps between immobilising particles that touch the base"),
        Param("n_balance", 1000, "steps between load-balancing shifts along x"),
    ]
    side = scene["contact"].get("side_wall_friction")
    if side is not None:  # the side walls' own friction (absent: wall_friction, and the deck is unchanged)
        params.append(Param("side_wall_friction", number(side), "side walls' sliding friction (wall_friction: base and end walls)"))
    for prm in params:
        number(prm.value)
    pours = [{"type": p["type"], "nper": p["nper"], "vol": round(p["vol"], 12),
              "d_lo": round(p["d_lo"], 12), "d_hi": round(p["d_hi"], 12),
              # enough particles for one segment: insertions per segment (+1) x nper
              "count": (n_segment // nfreq + 1) * p["nper"]} for p in plan["pours"]]
    context = {
        "scene": "heap",
        "rung": rung_name,
        "units_note": "si: metres, kilograms, seconds",
        "effects": eff,
        "ntypes": len(sp),
        "neighbor_multi": size_ratio >= MULTI_NEIGHBOR_RATIO,
        "contact": contact_law_context(model),
        "side_friction": "${wall_friction}" if side is None else "${side_wall_friction}",
        "pours": pours,
        "dump_columns": list(eff["dump_columns"]),
    }
    n_particles_est = int(case["feed_rate"] * (t_steady + rung["t_average"]) / (
        sum(s["volume_fraction"] * s["mean_mass"] for s in sp)))
    record = {
        **record_head("heap", rung_name, case, rung, params, model),
        "species": sp,
        "feed": {k: plan[k] for k in ("nfreq", "period", "rate_planned", "rate_max", "top_slab_fraction", "pours", "feed_speed")},
        "t_steady_estimate": t_steady,
        "n_flow_segments": max(1, math.ceil(t_steady / t_segment - 1e-9)),
        # whole segments nearest to t_average (segments are whole feed periods, so
        # t_segment is only close to the rung's value)
        "n_average_segments": max(1, round(rung["t_average"] / t_segment)),
        "n_particles_estimate": n_particles_est,
        "dt": dt,
        "t_segment": t_segment,
        "size_ratio": size_ratio,
        "neighbor_multi": context["neighbor_multi"],
        "dump_columns": context["dump_columns"],
        "density": scene["particles"]["density"],
        "geometry": {"W": rung["W"], "T": rung["T"], "theta_deg": scene["geometry"]["theta_deg"],
                     "x_feed": rung["feed_width"], "z_base_end": 0.0},
        "effects": eff,
        "protocol": proto,
        "guards": scene["guards"],
    }
    return params, {**context, "record": record}
