"""Contact parameters and the time-step preflight."""
import math

import pytest

from granflow.contact import build_contact_model, contact_time, damping_for_restitution
from granflow.preflight import PreflightError
from granflow.scenes.channel.parameters import channel_parameters


def test_damping_reproduces_paper_pair():
    # Debnath et al. (2022) App. A: k_n = 1e6 with xi_n = 180 gives e_n = 0.82 for
    # a d_p pair in m_p units (m_eff = 1/2). Our inversion must give xi_n ~ 180.
    xi = damping_for_restitution(1e6, 0.5, 0.82)
    assert xi == pytest.approx(180.0, rel=0.01)
    t_c, e = contact_time(1e6, 0.5, xi)
    assert e == pytest.approx(0.82, rel=1e-12)
    # paper time step 1.2e-4 resolves this contact with ~18 steps
    assert t_c / 1.2e-4 == pytest.approx(18.5, rel=0.02)


def test_stiffest_contact_is_smallest_pair(channel_scene):
    model = build_contact_model(channel_scene, channel_scene["rungs"]["demo"])
    assert model.stiffest.name == "0.9-0.9 pair"
    # walls have infinite mass: m_eff = m_i, so a wall contact lasts longer than the pair's
    walls = [c for c in model.contacts if "wall" in c.name]
    assert all(c.t_c > model.stiffest.t_c for c in walls)


def test_unsafe_time_step_refused_with_passing_value(channel_scene):
    import copy

    scene = copy.deepcopy(channel_scene)
    rung = scene["rungs"]["smoke"]
    soft = build_contact_model(scene, dict(rung, k_n=1e6))
    rung.update(k_n=1e8, dt=0.08 * soft.stiffest.t_c)  # the time step of k_n = 1e6
    with pytest.raises(PreflightError) as exc:
        channel_parameters(scene, "smoke")
    msg = str(exc.value)
    assert "dt =" in msg and "limit 0.1 x t_c" in msg and "a value that passes" in msg
    passing = float(msg.split("a value that passes: dt = ")[1].split()[0])
    rung["dt"] = passing
    channel_parameters(scene, "smoke")  # accepted


def hooke_contact_time(k_n: float, m_eff: float, xi_n: float) -> float:
    """t_c = pi / sqrt(k_n/m_eff - xi_n^2/4): half a period of the damped linear spring
    (LAMMPS gran/hooke: damping force m_eff xi_n v_n, so xi_n = 2 gamma_n of F = 2 gamma_n m_eff v)."""
    return math.pi / math.sqrt(k_n / m_eff - xi_n**2 / 4)


def test_stiff_case_with_proper_step_accepted(channel_scene):
    """The time step at k_n = 1e8 against a hand calculation from the scene file's numbers.

    Channel units: density 6/pi, so a sphere of diameter d has mass d^3; e_n = 0.82 for the
    d_p pair (m_eff = 1/2) fixes the damping, xi_n = -2 ln e / t_ref with
    t_ref = sqrt(m_eff (pi^2 + ln^2 e)/k_n). The shortest contact is the 0.9 d_p pair,
    m_eff = 0.9^3/2; the smoke rung's step is 0.08 of it.
    """
    import copy

    scene = copy.deepcopy(channel_scene)
    scene["rungs"]["smoke"]["k_n"] = 1e8
    params, ctx = channel_parameters(scene, "smoke")
    p = {q.name: q.value for q in params}
    k_n, ln_e = 1e8, math.log(0.82)
    xi_n = -2 * ln_e / math.sqrt(0.5 * (math.pi**2 + ln_e**2) / k_n)
    t_c = hooke_contact_time(k_n, 0.9**3 / 2, xi_n)
    assert t_c == pytest.approx(1.8995e-4, rel=1e-4)  # the number itself, written out
    # the record rounds t_c_min to 9 decimals and dt to 10
    assert p["t_c_min"] == pytest.approx(t_c, abs=5e-10)
    assert p["dt"] == pytest.approx(0.08 * t_c, abs=5e-11)
    assert p["dt"] <= 0.1 * t_c  # the preflight's limit, dt_max_fraction
    assert math.isclose(p["k_t"], 2 / 7 * 1e8, rel_tol=1e-9)


def test_neighbour_settings_scale_with_size_ratio():
    from granflow.preflight import LAMMPS_ONE, neighbor_settings

    mono = neighbor_settings([1.0], 0.3, 1e-3, 10.0)
    assert mono["neigh_one"] == LAMMPS_ONE
    # a size ratio of 30 needs far more than the default 2000 neighbours per particle
    big = neighbor_settings([1.0, 30.0], 0.3, 1e-3, 10.0)
    assert big["neigh_one"] > LAMMPS_ONE and big["neigh_page"] >= 10 * big["neigh_one"]
    # bound = 2 phi_rcp ((d_max + d_min)/2 + skin)^3 / (d_min/2)^3
    assert big["neigh_one"] == pytest.approx(2 * 0.64 * (15.5 + 0.3) ** 3 / 0.125, rel=1e-3)


def test_skin_too_small_refused_with_passing_value():
    from granflow.preflight import neighbor_settings

    with pytest.raises(PreflightError) as exc:
        neighbor_settings([1.0, 3.0], 0.01, 1e-3, 20.0)  # 0.02 per step > skin/2
    msg = str(exc.value)
    assert "skin = 0.01" in msg and "limit skin >=" in msg and "a value that passes" in msg


def test_size_ratio_three_renders(channel_scene, tmp_path):
    import copy

    from granflow.deck import render_case

    scene = copy.deepcopy(channel_scene)
    scene["particles"].update(diameters=[1.0, 3.0], number_fractions=[0.9, 0.1])
    scene["rungs"]["smoke"].update(W=12.0, B=7.0)
    record = render_case(scene, "smoke", tmp_path)
    prm = record["parameters"]
    # the gas lattice cell holds the largest particle: no overlaps at insertion
    assert min(prm["a_x"], prm["a_y"], prm["a_z"]) >= 3.0
    assert prm["jiggle"] < 0.5 * (min(prm["a_x"], prm["a_y"], prm["a_z"]) - 3.0)


# ---------------------------------------------------------------- the per-pair laws (issue 27)
def _with_law(scene, rung, law):
    import copy

    s = copy.deepcopy(scene)
    s["rungs"][rung]["contact_model"] = law
    return s


def test_pair_time_law_gives_every_pair_and_wall_the_papers_t_c_and_e(heap_scene):
    """Fan et al. (2013): k_n = m_eff[(pi/t_c)^2 + (ln e/t_c)^2] per pair, so each type pair's
    contact at its mean reduced mass lasts t_c exactly and every contact restitutes e."""
    from granflow.scenes.heap.parameters import contact_model, species

    scene = _with_law(heap_scene, "validation", "hooke/pair_time")
    rung = scene["rungs"]["validation"]
    model = contact_model(scene, rung, species(scene, "bi1-2"))
    assert model.law == "hooke/pair_time" and model.pair_style == "granular"
    assert {(p.i, p.j) for p in model.type_pairs} == {(1, 1), (1, 2), (2, 2), (1, None), (2, None)}
    for p in model.type_pairs:
        assert p.t_c == pytest.approx(rung["t_c"], rel=1e-12)
        assert p.e_n == heap_scene["contact"]["e_n"]
        assert p.k_t == pytest.approx(heap_scene["contact"]["kt_over_kn"] * p.k_n, rel=1e-12)
    # k_n proportional to m_eff: a wall contact (m_eff = m) is twice as stiff as the same-type pair (m/2)
    k = {(p.i, p.j): p.k_n for p in model.type_pairs}
    assert k[(1, None)] == pytest.approx(2 * k[(1, 1)], rel=1e-12)
    # within a species the size spread makes contacts shorter and longer than t_c: the extremes are listed
    assert min(c.t_c for c in model.contacts) < rung["t_c"] < max(c.t_c for c in model.contacts)
    assert {c.e_n for c in model.contacts} == {heap_scene["contact"]["e_n"]}


def test_eq10_law_gives_each_pair_its_own_stiffness(silo_scene):
    from granflow.scenes.silo.parameters import contact_model, hertz_stiffness, species

    rung = silo_scene["rungs"]["validation"]
    assert rung.get("contact_model") in (None, "hooke/pair_eq10")  # the paper's law at validation
    model, eq10 = contact_model(silo_scene, rung)
    sp = species(silo_scene)
    c = silo_scene["contact"]
    Y = rung["Y_factor"] * c["youngs_modulus"]
    k = {(p.i, p.j): p.k_n for p in model.type_pairs}
    for a in sp:
        for b in sp[a["type"] - 1:]:
            want = hertz_stiffness(Y, a["radius"], b["radius"], a["mass"], b["mass"], c["impact_velocity"])
            assert k[(a["type"], b["type"])] == pytest.approx(want, rel=1e-12)
        # the frozen rim ring acts on each size as the wall does
        assert k[(a["type"], len(sp) + 1)] == k[(a["type"], None)]
    # eq. 10 grows with R_eff and m_eff: the largest pair is the stiffest of the seven same-size pairs
    same = [k[(t, t)] for t in range(1, len(sp) + 1)]
    assert same == sorted(same)
    assert {round(x.e_n, 12) for x in model.contacts} == {c["e_n"]}


def test_single_law_is_the_default_below_validation(silo_scene):
    from granflow.scenes.silo.parameters import contact_model

    model, _ = contact_model(silo_scene, silo_scene["rungs"]["demo"])
    assert model.law == "hooke/history" and model.type_pairs == [] and model.pair_style == "gran/hooke/history"
    # one k_n: each pair's e differs (the mass-proportional dashpot), which the record lists
    assert max(c.e_n for c in model.contacts) - min(c.e_n for c in model.contacts) > 0.05


def test_unknown_law_is_refused_naming_key_and_choices(tmp_path, root):
    import subprocess
    import sys

    text = (root / "config" / "scenes" / "heap.yaml").read_text().replace(
        "  model: hooke/history ", "  model: hooke/mindlin ", 1)
    (tmp_path / "heap.yaml").write_text(text)
    out = subprocess.run([sys.executable, "-m", "granflow.cli", "check-config", str(tmp_path / "heap.yaml")],
                         capture_output=True, text=True, cwd=root)
    assert out.returncode == 2
    assert "contact.model" in out.stderr and "hooke/pair_time" in out.stderr and "Traceback" not in out.stderr
