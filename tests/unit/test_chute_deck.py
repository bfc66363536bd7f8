"""The chute scene's deck numbers, refusals and rendered decks (Silbert et al. 2001)."""
import copy
import math
import re

import pytest

from granflow.config import ConfigError
from granflow.scene_files import load_scene
from granflow.deck import render_case
from granflow.preflight import PreflightError
from granflow.scenes.chute import SCENE
from granflow.scenes.chute.parameters import STAGES, chute_parameters

RUNGS = ("smoke", "demo", "study", "paper", "validation")


@pytest.fixture(scope="module")
def chute(root):
    return load_scene(root / "config" / "scenes" / "chute.yaml")


@pytest.mark.parametrize("rung", RUNGS)
def test_parameters_of_every_rung(chute, rung):
    params, context = chute_parameters(chute, rung)
    record = context["record"]
    values = {p.name: p.value for p in params}
    assert context["scene"] == "chute" and context["stages"] == STAGES
    # every number a finite int/float (decks take typed values only)
    assert all(isinstance(v, (int, float)) and math.isfinite(v) for v in values.values())
    # the time step resolves the pair contact (the stiffest one) within dt_max_fraction
    assert record["dt"] <= chute["contact"]["dt_max_fraction"] * values["t_c_min"] * (1 + 1e-12)
    # the runner's keys, and no fixed schedule (flow runs until steady / arrested)
    for key in ("scene", "rung", "case", "rung_knobs", "parameters", "protocol", "guards", "dt", "t_segment",
                "n_flow_segments", "n_average_segments", "dump_columns", "density", "effects"):
        assert key in record, key
    assert "schedule" not in record
    # a segment is a whole number of thermo intervals (relative rounding 1e-9)
    n = record["t_segment"] / (values["n_thermo"] * record["dt"])
    assert abs(n - round(n)) < 1e-9
    assert values["n_particles"] == record["parameters"]["n_particles"] > 0


def test_paper_rung_is_the_papers_contact(chute):
    params, context = chute_parameters(chute, "paper")
    values = {p.name: p.value for p in params}
    assert context["record"]["dt"] == pytest.approx(1e-4)
    assert values["k_n"] == 2e5
    assert values["k_t"] == pytest.approx(2 / 7 * 2e5)
    # gamma_n = 50 of the paper, from e_n = 0.8831 at m_eff = m/2 (rounded to 1e-6 in the config)
    assert values["xi_n"] == pytest.approx(50.0, rel=1e-6)
    assert values["xi_t"] == 0.0 and values["friction"] == 0.5


def test_unsafe_time_step_is_refused(chute):
    scene = copy.deepcopy(chute)
    scene["rungs"]["smoke"]["dt_fraction"] = 0.15  # above dt_max_fraction = 0.1
    with pytest.raises(PreflightError, match="too large"):
        chute_parameters(scene, "smoke")
    scene["rungs"]["smoke"]["dt"] = 1e-2  # an explicit dt > t_c/10 at k_n = 2e4 (t_c = 0.0157)
    with pytest.raises(PreflightError, match="too large"):
        chute_parameters(scene, "smoke")


def test_angle_and_margins_are_checked(chute):
    with pytest.raises(ConfigError, match="theta_deg"):
        chute_parameters(chute, "smoke", {"theta_deg": 75.0})
    scene = copy.deepcopy(chute)
    scene["rungs"]["smoke"]["bulk_margin"] = 6.0  # 2 x 6 + 1 > H = 10
    with pytest.raises(ConfigError, match="bulk_margin"):
        SCENE.check(scene, "x")


def test_numbers_reach_the_deck_as_variables(chute, tmp_path):
    record = render_case(chute, "smoke", tmp_path, {"theta_deg": 23.5})
    for stage in STAGES:
        text = (tmp_path / f"{stage}.lmp").read_text()
        for name, value in record["parameters"].items():
            assert re.search(rf"^variable {name}\s+equal {re.escape(str(value))}\s", text, re.M), (stage, name)
        # no side walls, no insertion after the fill, gravity tilted in the flow stages only
        assert "fix pour" not in text and "fix deposit" not in text
        assert "xplane" not in text and "yplane" not in text
        assert "boundary        p p fm" in text or stage != "init"
        body = text.split("# ----", 2)[-1]
        assert "23.5" not in body.split("variable theta_deg", 1)[-1].split("\n", 1)[1]  # only via ${theta_deg}
    flow, average = (tmp_path / "flow.lmp").read_text(), (tmp_path / "average.lmp").read_text()
    assert "gravity 1.0 chute ${theta_deg}" in flow
    assert "stress/atom" not in flow and "stress/atom" in average  # per-atom stress only when averaging
    assert "dump            contacts" not in average  # contact_dump: false
    assert "dump            particles mobile" in average  # the base is not dumped


def test_contact_dump_only_when_asked(chute, tmp_path):
    scene = copy.deepcopy(chute)
    scene["effects"]["contact_dump"] = True
    render_case(scene, "smoke", tmp_path)
    assert "dump            contacts" in (tmp_path / "average.lmp").read_text()


@pytest.mark.parametrize("rung", RUNGS)
def test_every_rung_passes_skiprun(chute, tmp_path, skiprun, rung):
    """Each stage's deck parses and sets up in LAMMPS (-skiprun skips the runs)."""
    render_case(chute, rung, tmp_path)
    skiprun(tmp_path, STAGES)


def test_cost_study_takes_the_chute(root, chute):
    """The campaign's chute study: its knobs set the scene's keys, every variant renders (preflight)."""
    from granflow.campaign import load_campaign

    cs = load_campaign(root / "config" / "config.yaml", root=root)["cost_studies"]["chute"]
    assert cs.base["case"]["theta_deg"] == 24.0
    rung = cs.base["rungs"][cs.rung]
    run = cs.scenes["size~1.5"]["rungs"][cs.rung]
    # the size knob scales the bed depth and both periodic lengths, nothing else
    assert (run["H"], run["Lx"], run["Ly"]) == (1.5 * rung["H"], 1.5 * rung["Lx"], 1.5 * rung["Ly"])
    assert run["k_n"] == rung["k_n"]
    stiff = cs.scenes["stiffness~200000"]["rungs"][cs.rung]
    assert stiff["k_n"] == 2.0e5 and stiff["dt_fraction"] == rung["dt_fraction"]
    # the post-processing knobs reuse the base run
    assert cs.point("bin_width~0.5")["run"] == "base" and cs.point("t_average~5")["run"] == "base"
