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
