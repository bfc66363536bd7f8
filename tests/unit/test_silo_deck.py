"""Silo decks: eq. 10 stiffness, the gas and the rim, refusals, effects -> exactly those commands, skiprun."""
import copy
import math

import numpy as np
import pandas as pd
import pytest

from granflow.campaign import load_campaign
from granflow.config import ConfigError
from granflow.scene_files import validate_scene
from granflow.deck import render_case
from granflow.preflight import PreflightError
from granflow.scenes.silo.parameters import discharge_verdict, gas_lattice, hertz_stiffness, rim_ring, species

SMOKE_CASE = {"R": 3.5}


def test_eq10_stiffness_is_the_linearised_hertz_law():
    """k_n = 16/15 sqrt(R) Y (15 m V^2 / (16 sqrt(R) Y))^(1/5) and scales as Y^(4/5), V^(2/5)."""
    k = hertz_stiffness(1.2e11, 0.01, 0.01, 0.1, 0.1, 2.0)
    R, m = 0.005, 0.05
    expected = 16 / 15 * math.sqrt(R) * 1.2e11 * (15 * m * 4.0 / (16 * math.sqrt(R) * 1.2e11)) ** 0.2
    assert k == pytest.approx(expected, rel=1e-12)
    assert hertz_stiffness(1.2e8, 0.01, 0.01, 0.1, 0.1, 2.0) / k == pytest.approx(1e-3 ** 0.8, rel=1e-12)
    assert hertz_stiffness(1.2e11, 0.01, 0.01, 0.1, 0.1, 4.0) / k == pytest.approx(2 ** 0.4, rel=1e-12)


def test_paper_rung_time_step_is_the_papers(silo_scene, tmp_path):
    """Y = 120 GPa with V_c = 2.8 m/s: the paper's dt = t_c/50 = 6.3e-7 s, its t_c = pi sqrt(m_eff/(2 k_n))
    of the small pair with that pair's eq. 10 stiffness (the paper's law, hooke/pair_eq10).

    V_c is not in the paper; it was chosen so that this holds, and the test keeps the chain
    eq. 10 -> k_n -> t_c -> dt from drifting. The paper's t_c formula is 1/1.415 of the damped
    contact's duration that the record lists, so the paper rung's dt_fraction is 0.02/1.415.
    """
    import math

    record = render_case(silo_scene, "paper", tmp_path / "paper", {"R": 12})
    assert record["contact_law"]["law"] == "hooke/pair_eq10"
    small = next(p for p in record["contact_law"]["type_pairs"] if p["types"] == [1, 1])
    t_c_paper = math.pi * math.sqrt(small["m_eff_mean"] / (2 * small["k_n"]))
    assert t_c_paper / 50 == pytest.approx(6.3e-7, rel=0.01)  # the paper states two digits
    assert record["dt"] == pytest.approx(6.3e-7, rel=0.01)
    c = [c for c in record["contacts"] if c["name"] == "r1-r1 pair"][0]
    assert record["dt"] == pytest.approx(0.01413 * c["t_c"], rel=1e-9)
    # every contact of the paper's law restitutes the paper's e_n
    assert {round(c["e_n"], 12) for c in record["contacts"]} == {0.88}


def test_gas_has_equal_numbers_and_no_contacts(silo_scene):
    rung = silo_scene["rungs"]["smoke"]
    gas = gas_lattice(silo_scene, rung, seed=3)
    sp = species(silo_scene)
    assert gas["n"] % len(sp) == 0
    assert np.bincount(gas["types"])[1:].tolist() == [gas["n"] // len(sp)] * len(sp)
    pos = gas["positions"]
    r_b = silo_scene["particles"]["r_b"]
    d = np.linalg.norm(pos[:, None, :] - pos[None, :, :], axis=-1) + np.eye(len(pos)) * 1e9
    assert d.min() >= 2 * r_b * 1.0 - 1e-12          # no two largest spheres touch
    assert np.hypot(pos[:, 0], pos[:, 1]).max() <= (rung["R_c"] - 1.0) * r_b  # none touches the side wall
    assert pos[:, 2].min() >= r_b                      # nor the floor


def test_rim_ring_is_tangent_to_floor_and_orifice_wall():
    R, r_s = 0.1, 0.01
    rim = rim_ring(R, r_s)
    pos, rho = rim["positions"], rim["radius"]
    r = np.hypot(pos[:, 0], pos[:, 1])
    np.testing.assert_allclose(r - rho, R, rtol=1e-12)          # touches the orifice wall r = R
    np.testing.assert_allclose(pos[:, 2] + rho, 0.0, atol=1e-15)  # touches the floor z = 0 from below
    gap = 2 * (R + rho) * np.sin(np.pi / rim["n"])
    assert gap < 2 * rho                                        # neighbours overlap: no hole in the rim


def test_refusals_name_key_value_and_range(silo_scene, root):
    with pytest.raises(PreflightError, match=r"orifice radius R = 5 r_b does not fit .*allowed R <= R_c - 2 = 4"):
        render_case(silo_scene, "smoke", "/tmp/never", {"R": 5})
    with pytest.raises(ConfigError, match=r"scenes.silo.sweep.R = 15 .*allowed 1 <= R <= R_c - 2 = 14"):
        load_campaign(root / "config" / "config.yaml", ["scenes.silo.sweep.R=[15]"], root=root)
    bad = copy.deepcopy(silo_scene)
    bad["effects"]["walls"] = ["side"]
    with pytest.raises(ConfigError, match=r"effects.walls = \['side'\]: allowed \[side, floor\]"):
        validate_scene(bad, "silo.yaml")
    bad = copy.deepcopy(silo_scene)
    bad["rungs"]["smoke"]["dt_fraction"] = 0.3
    with pytest.raises(PreflightError, match="time step dt = .* is too large"):
        render_case(bad, "smoke", "/tmp/never", SMOKE_CASE)


@pytest.mark.parametrize("effect, absent", [
    ("contact_output", "dump            contacts"),
    ("deletion", " evaporate ${n_evaporate}"),
    ("reinsert", "create_atoms"),
])
def test_effects_off_means_commands_absent(silo_scene, tmp_path, effect, absent):
    scene = copy.deepcopy(silo_scene)
    scene["effects"]["reinsert"] = True
    on = render_case(scene, "smoke", tmp_path / "on", SMOKE_CASE)
    assert absent in (tmp_path / "on" / "average.lmp").read_text()
    scene["effects"][effect] = False
    if effect == "deletion":
        scene["effects"]["reinsert"] = False
    render_case(scene, "smoke", tmp_path / "off", SMOKE_CASE)
    assert absent not in (tmp_path / "off" / "average.lmp").read_text()
    assert on["reinsert"] is True


@pytest.mark.lammps
@pytest.mark.parametrize("rung", ["smoke", "demo", "study", "paper", "validation"])
def test_every_rung_passes_skiprun(silo_scene, tmp_path, skiprun, rung):
    """Both stages parse and set up in LAMMPS with the gas, the rim and the open orifice.

    (The re-insertion deck needs a real ``run 0`` before ``create_atoms``, which
    -skiprun skips; it runs in tests/integration/test_silo_dag.py instead.)
    """
    record = render_case(silo_scene, rung, tmp_path, SMOKE_CASE if rung == "smoke" else None)
    skiprun(tmp_path, ("init", "average"))
    n_rim = record["rim"]["n"]
    assert f"{record['n_particles'] + n_rim} atoms" in (tmp_path / "atoms.data").read_text()


def test_discharge_verdict_names_a_clog_and_an_empty_silo(silo_scene, tmp_path):
    record = render_case(silo_scene, "demo", tmp_path, {"R": 5.5})
    t = np.linspace(0.2, 0.4, 41)
    full = record["n_particles"] * np.mean([s["mass"] for s in record["species"]])
    flowing = pd.DataFrame({"Time": t, "v_mdel": 50.0 * t, "v_mtot": full - 50.0 * t})
    assert discharge_verdict(flowing, record) is None
    # the first segment (from the opening) is the start-up: never called a clog
    assert discharge_verdict(flowing.assign(Time=t - 0.2, v_mdel=0.0), record) is None
    clogged = flowing.assign(v_mdel=0.01 * t)
    status, reason = discharge_verdict(clogged, record)
    assert status == "clogged" and "arch" in reason
    empty = flowing.assign(v_mtot=0.05 * full + 0 * t)
    status, reason = discharge_verdict(empty, record)
    assert status == "completed" and "fell below 2 R" in reason
