"""Limits and combinations refused before anything runs (issue 31): a CPU-hour limit beside
``max_particles`` (check-config, plan, render and the DAG's validation), effects a scene cannot run
with (refused at render with the reason), and check-config on a scene file running render's checks.
Each refusal exits 2, names the case or key, the value and what is allowed, and writes nothing;
the shipped campaign and scene files still pass."""
import copy
import re
from pathlib import Path

import pytest

from granflow import registry, resources
from granflow.campaign import load_campaign, validate_campaign
from granflow.cli import main
from granflow.config import ConfigError, load_yaml

pytestmark = pytest.mark.usefixtures("project_cwd")

SCENES = sorted(registry.names())
#: a case each scene file can render at the smoke rung (silo.yaml's own R = 6 r_b does not fit the
#: smoke silo of R_c = 6 r_b, heap.yaml's own 0.033 kg/s is more than the smoke feed delivers)
SMOKE_CASE = {"silo": ["--set", "case.R=4"], "heap": ["--set", "case.feed_rate=0.005"]}
#: far above any shipped case (the silo's paper case: 558 CPU-hours), so only the other checks count
NO_CPU_LIMIT = ["--max-cpu-hours", "1e6"]


@pytest.fixture
def project_cwd(monkeypatch, root):
    """Every command runs from the project root, as the README's do."""
    monkeypatch.chdir(root)


def refused(capsys, argv) -> str:
    assert main(argv) == 2, argv
    err = capsys.readouterr().err
    assert err.startswith("granflow: refused: ") and "Traceback" not in err, err
    return err[len("granflow: refused: "):]


def accepted(capsys, argv) -> str:
    code = main(argv)
    out = capsys.readouterr()
    assert code == 0, (argv, out.err)
    return out.out


def hours(text: str, after: str) -> float:
    """The number of CPU-hours printed after ``after`` (``1,234`` or ``23.9``)."""
    return float(re.search(re.escape(after) + r"([\d,.]+) CPU-hours", text).group(1).replace(",", ""))


# ------------------------------------------------------------------------------ CPU-hours
def study_plan() -> dict:
    """The default campaign at the study rung priced at the reference rate (no measured runs)."""
    cfg = load_campaign("config/config.yaml", ["rung=study"])
    return resources.plan_campaign(cfg, "/nonexistent-results", calibration=resources.Calibration())


def test_a_campaign_above_the_cpu_hour_limit_is_refused_with_plans_estimate(capsys):
    """All cases together: 79.2 CPU-hours at study, above 50; the total is what `plan` sums."""
    err = refused(capsys, ["check-config", "config/config.yaml", "--rung", "study", "--max-cpu-hours", "50"])
    assert err.startswith("config/config.yaml: the campaign at rung study is too large: its 11 cases are estimated at ")
    assert "allowed at most 50 CPU-hours (max_cpu_hours = 50); raise it with --max-cpu-hours H" in err
    assert "snakemake --config max_cpu_hours=H, or max_cpu_hours in the campaign file" in err
    # the estimate is granflow plan's, to the 3 significant digits printed
    assert hours(err, "estimated at ") == pytest.approx(study_plan()["total"]["cpu_hours"], rel=5e-3)
    # the same through plan, whose --max-cpu-hours is the same option
    err = refused(capsys, ["plan", "--rung", "study", "--max-cpu-hours", "50"])
    assert "the campaign at rung study is too large" in err and "allowed at most 50 CPU-hours" in err


def test_one_case_above_the_cpu_hour_limit_is_refused_by_name(capsys):
    """A case dearer than the limit is named before the total is summed (channel W = 20 at study: ~24 CPU-h)."""
    rows = {r["case"]: r for r in study_plan()["rows"] if r["scene"] == "channel"}
    err = refused(capsys, ["check-config", "config/config.yaml", "--rung", "study", "--max-cpu-hours", "20"])
    assert err.startswith("config/config.yaml: scenes.channel case W = 20, phi_mean = 0.56 (rung study) is too "
                          "large: estimated ")
    assert hours(err, "estimated ") == pytest.approx(rows["W~20/phi~0.56"]["cpu_hours"], rel=5e-3)
    assert "allowed at most 20 CPU-hours (max_cpu_hours = 20); raise it with --max-cpu-hours H" in err


def test_render_refuses_a_case_above_the_cpu_hour_limit_and_writes_nothing(capsys, tmp_path):
    out = tmp_path / "out"
    err = refused(capsys, ["render", "silo", "--rung", "paper", "--out", str(out), "--max-cpu-hours", "100"])
    assert "silo at rung paper is too large: estimated 558 CPU-hours (277,761 particles" in err
    assert "allowed at most 100 CPU-hours (max_cpu_hours = 100); raise it with --max-cpu-hours H" in err
    assert not out.exists()


def test_the_default_limit_is_a_week_of_this_machines_cores(capsys, monkeypatch):
    """7 x 24 x os.cpu_count(): on one core 168 CPU-hours, which the study campaign (79 CPU-h) fits
    and the paper campaign (its silo cases alone 558 CPU-h each) does not."""
    monkeypatch.setattr("os.cpu_count", lambda: 1)
    assert resources.default_max_cpu_hours() == 7 * 24
    accepted(capsys, ["check-config", "config/config.yaml", "--rung", "study"])
    err = refused(capsys, ["check-config", "config/config.yaml", "--rung", "paper"])
    assert "(rung paper) is too large: estimated 558 CPU-hours" in err
    assert "allowed at most 168 CPU-hours (the default: a week of this machine's 1 core, 7 x 24 x 1 = 168)" in err
    monkeypatch.setattr("os.cpu_count", lambda: 64)  # a cluster node: the whole paper campaign fits
    accepted(capsys, ["plan", "--rung", "paper"])


def test_the_limit_is_a_campaign_key_and_reaches_the_dag(capsys, tmp_path):
    """``max_cpu_hours`` in the campaign file; Snakemake's ``config`` (``--config max_cpu_hours=H``)
    goes through validate_campaign, as workflows/rules/common.smk calls it."""
    data = load_yaml("config/config.yaml")
    campaign = tmp_path / "campaign.yaml"
    campaign.write_text(f"max_cpu_hours: 50\nrung: study\nscenes: {dict(data['scenes'])!r}\n".replace("'", '"'))
    err = refused(capsys, ["check-config", str(campaign)])
    assert "the campaign at rung study is too large" in err and "(max_cpu_hours = 50)" in err
    config = {**data, "rung": "study", "max_cpu_hours": 50}
    with pytest.raises(ConfigError, match=r"^config: the campaign at rung study is too large: .* allowed at most 50 "):
        validate_campaign(config, root=Path.cwd(), source="config")
    validate_campaign({**config, "max_cpu_hours": 100}, root=Path.cwd(), source="config")


@pytest.mark.parametrize("argv", [
    ["check-config", "config/config.yaml"], ["check-config", "config/scenes/channel.yaml"],
    ["render", "channel", "--rung", "smoke", "--out", "/tmp/granflow-refused"],
])
@pytest.mark.parametrize("value, what", [("0", "is not allowed: allowed 0 < value"),
                                         ("nan", "is not a finite number"), ("-3", "is not allowed")])
def test_a_nonsense_limit_is_refused(capsys, argv, value, what):
    err = refused(capsys, [*argv, "--max-cpu-hours", value])
    assert re.search(r"(max_cpu_hours|--max-cpu-hours) = ", err) and what in err, err


# ------------------------------------------------------------------------------ effects
EFFECTS = [  # (scene, --set, what the refusal says after "effects.")
    ("heap", "effects.feed=false", "feed = false is not allowed: the heap holds only the particles the feed pours"),
    ("heap", "effects.gravity=false", "gravity = false is not allowed with effects.feed = true: the feed is LAMMPS's "
                                      "fix pour, which needs a fix gravity"),
    ("heap", "effects.walls=[]", "walls = [] is not allowed: it lacks end, feed_side, sides"),
    ("heap", "effects.walls=[base,end,sides]", "walls = ['base', 'end', 'sides'] is not allowed: it lacks feed_side"),
    ("channel", "effects.walls=[]", "walls = [] is not allowed: the channel is bounded across x by its two walls"),
    ("channel", "effects.periodic=[y]", "periodic = ['y'] is not allowed: the channel has no walls in z"),
    ("channel", "effects.periodic=[z]", "periodic = ['z'] is not allowed: the flow direction y is made periodic"),
    ("silo", "effects.deletion=false", "deletion = false is not allowed: the outflow is measured as the mass deleted"),
    ("silo", "effects.gravity=false", "gravity = false is not allowed: the silo drains under gravity alone"),
]


@pytest.mark.parametrize("scene, setting, message", EFFECTS, ids=[f"{s}-{e}" for s, e, _ in EFFECTS])
def test_effects_that_cannot_run_are_refused_at_render_with_the_reason(capsys, tmp_path, scene, setting, message):
    out = tmp_path / "out"
    err = refused(capsys, ["render", scene, "--rung", "demo", "--out", str(out), "--set", setting])
    assert f"config/scenes/{scene}.yaml: effects.{message}" in err and "allowed " in err
    assert not out.exists()
    # the same refusal from check-config on the scene file, and from the campaign that uses it
    assert f"effects.{message}" in refused(capsys, ["check-config", f"config/scenes/{scene}.yaml", "--set", setting])


def test_heap_without_base_wall_needs_frozen_base(capsys):
    """Without the base wall the particles frozen on the base plane are the base (it ran at smoke);
    without either, they fall out of the box."""
    heap = "config/scenes/heap.yaml"
    walls = "effects.walls=[end,feed_side,sides]"
    accepted(capsys, ["check-config", heap, "--rung", "demo", "--set", walls])
    err = refused(capsys, ["check-config", heap, "--set", walls, "--set", "effects.freeze_base=false"])
    assert "without base is not allowed with effects.freeze_base = false" in err


def test_effects_the_scenes_run_with_still_pass(capsys):
    """What the shipped decks and their tests use: the shipped effects, other scenes' optional ones."""
    accepted(capsys, ["check-config", "config/scenes/silo.yaml", "--set", "effects.reinsert=true"])
    accepted(capsys, ["check-config", "config/scenes/channel.yaml", "--set", "effects.wall_force=false",
                      "--set", "effects.gravity=false", "--set", "effects.polydisperse=false"])
    accepted(capsys, ["check-config", "config/scenes/heap.yaml", "--set", "effects.freeze_base=false"])
    accepted(capsys, ["check-config", "config/scenes/chute.yaml", "--set", "effects.per_atom_stress=false"])


# ------------------------------------------------------------------- check-config on a scene file
def test_check_config_on_a_scene_file_applies_renders_size_and_geometry_checks(capsys, tmp_path):
    """The orifice larger than the demo silo and --max-particles: refused by check-config --rung as
    by render, with the same message."""
    silo = "config/scenes/silo.yaml"
    for extra in (["--set", "case.R=15"], ["--max-particles", "1000"], ["--max-cpu-hours", "0.01"]):
        by_render = refused(capsys, ["render", "silo", "--rung", "demo", "--config", silo, "--out", str(tmp_path / "x"),
                                     *extra])
        assert refused(capsys, ["check-config", silo, "--rung", "demo", *extra]) == by_render
    assert "silo at rung demo is not allowed: orifice radius R = 15 r_b does not fit the silo of R_c = 16 r_b" in \
        refused(capsys, ["check-config", silo, "--rung", "demo", "--set", "case.R=15"])
    # the time step, as render checks it
    err = refused(capsys, ["check-config", "config/scenes/channel.yaml", "--rung", "smoke",
                           "--set", "rungs.smoke.dt_fraction=0.5"])
    assert "channel at rung smoke is not allowed: time step dt = 0.003003 is too large" in err
    assert not (tmp_path / "x").exists()


def test_check_config_without_rung_refuses_a_case_no_rung_can_render(capsys):
    err = refused(capsys, ["check-config", "config/scenes/silo.yaml", "--max-particles", "1000"])
    assert err.startswith("config/scenes/silo.yaml: its case cannot be rendered at any rung (--rung R checks one):")
    for rung in load_yaml("config/scenes/silo.yaml")["rungs"]:
        assert f"silo at rung {rung} is " in err
    assert "silo at rung demo is too large: estimated 8,828 particles" in err
    err = refused(capsys, ["check-config", "config/scenes/silo.yaml", "--set", "case.R=60"])
    assert err.count("does not fit the silo") == 5


def test_check_config_without_rung_lists_the_rungs_that_cannot_render(capsys):
    out = accepted(capsys, ["check-config", "config/scenes/channel.yaml", "--max-particles", "5000"])
    assert out.startswith("config/scenes/channel.yaml: valid channel scene file; its case renders at rungs "
                          "smoke, demo, validation\n")
    assert "  not at rung study (render and check-config --rung study refuse it): " in out
    assert "channel at rung paper is too large: estimated 270,157 particles" in out


def test_an_unknown_rung_is_refused(capsys):
    err = refused(capsys, ["check-config", "config/scenes/chute.yaml", "--rung", "ultra"])
    assert err.startswith("--rung = 'ultra' does not exist: allowed smoke, demo")


# ------------------------------------------------------------------- shipped files still pass
def test_the_default_campaign_passes(capsys):
    out = accepted(capsys, ["check-config", "config/config.yaml"])
    assert out.startswith("config/config.yaml: valid campaign, rung demo")


@pytest.mark.parametrize("scene", SCENES)
def test_every_shipped_scene_file_passes_at_every_rung(capsys, tmp_path, scene):
    """Without --rung; and at each rung (the CPU-hour limit lifted: the paper rung is for clusters)
    with the file's own case, except where render refuses that case too (the smoke silo and heap:
    their smoke runs use the smaller case of SMOKE_CASE, with which they pass)."""
    path = f"config/scenes/{scene}.yaml"
    assert f"valid {scene} scene file" in accepted(capsys, ["check-config", path])
    for rung in load_yaml(path)["rungs"]:
        argv = ["check-config", path, "--rung", rung, *NO_CPU_LIMIT]
        if rung == "smoke" and scene in SMOKE_CASE:
            render = ["render", scene, "--rung", rung, "--config", path, "--out", str(tmp_path / "x"), *NO_CPU_LIMIT]
            assert refused(capsys, argv) == refused(capsys, render)
            argv += SMOKE_CASE[scene]
        assert f"its case renders at rung {rung}" in accepted(capsys, argv)


def test_shipped_effects_pass_every_scene_check():
    """Each scene's own effect rules accept its shipped file (the campaign loads them all)."""
    for scene in SCENES:
        data = load_yaml(f"config/scenes/{scene}.yaml")
        registry.get(scene).check(copy.deepcopy(data), scene)
