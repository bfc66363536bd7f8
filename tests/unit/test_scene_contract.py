"""The scene contract (granflow.registry.REQUIRED and OPTIONAL): each scene package is checked when
it is found, a broken one is refused by name with what it lacks while the other scenes keep working,
and the generic layers (config, plan, cost study, validation record, report) skip what a scene does
not give. The minimal scene of tests/data/minimal_scene, which gives only the required parts, is
registered here beside the shipped scenes (the registry monkeypatched); the Snakemake DAG with it
is tested in tests/integration/test_minimal_scene_dag.py."""
import importlib
import json
import shutil
import sys
from pathlib import Path

import pandas as pd
import pytest

from granflow import cost, overview, registry, schema, validation
from granflow.campaign import load_campaign
from granflow.cli import EXIT_BAD_INPUT, main
from granflow.config import ConfigError
from granflow.registry import Knob
from granflow.resources import plan_campaign

ROOT = Path(__file__).resolve().parents[2]


# ------------------------------------------------------------------------------ discovery
def test_the_registered_scenes_meet_the_contract():
    """Every scene package of the checkout is found and meets REQUIRED; none is refused."""
    assert registry.refused() == {}
    assert registry.names()
    for name, scene in registry.scenes().items():
        assert registry.missing(scene, name) == [], name


#: scene packages with one fault each, and the words their refusal must hold
BROKEN = {
    "nothing": ('"""A package without SCENE."""\n', "it lacks SCENE"),
    "typo": ("import granflow.no_such_module\n", "its package does not import (ModuleNotFoundError"),
    "partial": ("from granflow.registry import Scene, SweepAxis\n\n\n"
                "class Partial(Scene):\n    name = 'partial'\n    summary = 'no analyse, no schema'\n"
                "    sweep = (SweepAxis('theta_deg', 'theta'),)\n\n"
                "    def parameters(self, scene, rung, case=None):\n        return [], {}\n\n\nSCENE = Partial()\n",
                "analyse() (a finished case's tables and scalars); schema ("),
    "misnamed": ("from granflow.registry import Scene\n\n\nclass M(Scene):\n    name = 'other'\n\n\nSCENE = M()\n",
                 "name (SCENE.name = 'other': must be the package's name 'misnamed'); summary ("),
}


@pytest.fixture
def packages(tmp_path, monkeypatch, minimal_scene):
    """A package ``fakescenes`` of scene packages on sys.path: the minimal scene (``good``), one with a
    sweep axis its schema lacks, one with knobs but no observables, and the packages of BROKEN."""
    base = tmp_path / "pkgs" / "fakescenes"
    base.mkdir(parents=True)
    (base / "__init__.py").write_text("")
    config_dir = tmp_path / "config"
    minimal_scene(base, config_dir, "good")
    for name, (text, _) in BROKEN.items():
        (base / name).mkdir()
        (base / name / "__init__.py").write_text(text)
    axis = minimal_scene(base, config_dir, "axis")
    (axis / "__init__.py").write_text((axis / "__init__.py").read_text().replace(
        'SweepAxis("theta_deg", "theta")', 'SweepAxis("angle", "a")'))
    knobs = minimal_scene(base, config_dir, "knobs")
    (knobs / "__init__.py").write_text((knobs / "__init__.py").read_text().replace(
        "SCENE = MinimalScene()", "from granflow.registry import Knob\n\n"
        "MinimalScene.knobs = {'t_average': Knob(('rungs.{r}.t_average',), 'set', 'max', 's')}\n"
        "SCENE = MinimalScene()"))
    monkeypatch.syspath_prepend(str(tmp_path / "pkgs"))
    yield config_dir
    for module in [m for m in sys.modules if m == "fakescenes" or m.startswith("fakescenes.")]:
        del sys.modules[module]


def test_discovery_refuses_a_broken_package_by_name_and_keeps_the_others(packages):
    found = registry.discover("fakescenes", config_dir=packages)
    assert list(found.scenes) == ["good"]
    assert set(found.refused) == {*BROKEN, "axis", "knobs"}
    for name, (_, words) in BROKEN.items():
        assert words in found.refused[name], (name, found.refused[name])
    assert "sweep (axes angle are not keys of the case section of" in found.refused["axis"]
    assert found.refused["knobs"] == ("it lacks headline and observables() (its knobs declare a cost study, "
                                      "which needs all three)")
    # each missing file is named by its path
    for missing_file in ("schema/partial.schema.yaml", "scenes/partial.yaml", "partial/partial.lmp.j2"):
        assert f"{missing_file}: no such file" in found.refused["partial"]


# ---------------------------------------------------------------- a minimal scene registered
@pytest.fixture
def drum(tmp_path, monkeypatch, minimal_scene):
    """The minimal scene registered as ``drum`` beside the shipped scenes, its schema found with theirs,
    and a package ``broken`` refused at discovery (it has no SCENE). Returns the scene."""
    config_dir = tmp_path / "config"
    shutil.copytree(ROOT / "config" / "schema", config_dir / "schema")
    minimal_scene(tmp_path / "pkgs", config_dir, "drum")
    monkeypatch.syspath_prepend(str(tmp_path / "pkgs"))
    scene = importlib.import_module("drum").SCENE
    assert registry.missing(scene, "drum", config_dir) == []
    found = registry.Found({**registry.scenes(), "drum": scene},
                           {"broken": "it lacks " + "; ".join(registry.missing(None, "broken"))})
    monkeypatch.setattr(registry, "_found", lambda: found)
    monkeypatch.setattr(schema, "SCHEMA_DIR", config_dir / "schema")
    yield scene
    del sys.modules["drum"]
    schema._schema.cache_clear()  # drum's schema was read from this test's folder


def campaign_file(tmp_path, scenes: str, extra: str = "") -> Path:
    path = tmp_path / "campaign.yaml"
    path.write_text(f"rung: smoke\nresults_dir: {tmp_path / 'results'}\nscenes:\n{scenes}{extra}")
    return path


def drum_entry(tmp_path) -> str:
    return (f"  drum:\n    enabled: true\n    scene_file: {tmp_path / 'config' / 'scenes' / 'drum.yaml'}\n"
            "    sweep: {theta_deg: [22, 24]}\n")


def test_the_minimal_scene_gives_nothing_optional(drum):
    assert {hook: drum.gives(hook) for hook in registry.OPTIONAL} == dict.fromkeys(registry.OPTIONAL, False)
    with pytest.raises(KeyError, match="no optional hook 'knobs': allowed validation, cost_study"):
        drum.gives("knobs")


def test_scenes_lists_the_good_ones_and_names_the_refused_one(drum, capsys):
    assert main(["scenes"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert [line.split()[0] for line in out] == [*registry.names(), "broken"]
    assert out[-1] == "broken     refused: it lacks SCENE (the package's SCENE, an instance of a " \
                      "granflow.registry.Scene subclass; found NoneType)"


def test_a_command_that_needs_a_refused_scene_exits_2_naming_it(drum, tmp_path, capsys):
    assert main(["render", "broken", "--rung", "smoke", "--out", str(tmp_path / "out")]) == EXIT_BAD_INPUT
    err = capsys.readouterr().err
    assert "granflow: refused: scene 'broken' is refused: it lacks SCENE" in err and "Traceback" not in err
    assert not (tmp_path / "out").exists()
    # a campaign that enables it is refused; one that leaves it off runs the others
    on = campaign_file(tmp_path, drum_entry(tmp_path) + "  broken: {enabled: true}\n")
    assert main(["check-config", str(on)]) == EXIT_BAD_INPUT
    assert "scenes.broken is enabled, but the scene is refused: it lacks SCENE" in capsys.readouterr().err
    off = campaign_file(tmp_path, drum_entry(tmp_path) + "  broken: {enabled: false}\n")
    assert main(["check-config", str(off)]) == 0
    assert "valid campaign, rung smoke, scenes: drum" in capsys.readouterr().out
    # a rendered case of it
    case = tmp_path / "case"
    case.mkdir()
    (case / "params.json").write_text(json.dumps({"scene": "broken", "rung": "smoke", "parameters": {}}))
    assert main(["run", str(case)]) == EXIT_BAD_INPUT
    assert "scene = 'broken': it lacks SCENE" in capsys.readouterr().err


def test_plan_prices_the_minimal_scene(drum, tmp_path, capsys):
    cfg = load_campaign(campaign_file(tmp_path, drum_entry(tmp_path)), root=tmp_path)
    plan = plan_campaign(cfg, tmp_path / "results")
    assert [r["case"] for r in plan["rows"]] == ["theta~22", "theta~24"]
    assert all(r["particles"] > 0 and r["cpu_hours"] > 0 and r["state"] == "todo" for r in plan["rows"])
    assert main(["plan", "--config", str(tmp_path / "campaign.yaml")]) == 0  # drum's scene file: an absolute path
    assert "drum     total (2 cases)" in capsys.readouterr().out


def test_a_cost_study_of_a_scene_without_one_is_refused(drum, tmp_path):
    study = ("cost:\n  scenes:\n    drum:\n      base_rung: smoke\n      knobs: {t_average: [10.0]}\n")
    with pytest.raises(ConfigError, match=r"cost\.scenes\.drum is not allowed: the drum scene declares no cost "
                                          r"study \(it needs knobs, headline and observables\(\).*enabled: false"):
        load_campaign(campaign_file(tmp_path, drum_entry(tmp_path), study), root=tmp_path)
    off = study.replace("base_rung: smoke", "enabled: false\n      base_rung: smoke")
    cfg = load_campaign(campaign_file(tmp_path, drum_entry(tmp_path), off), root=tmp_path)
    assert cfg["cost_studies"] == {}


def test_a_cost_study_without_a_paper_reference_has_no_extrapolation(drum, tmp_path, monkeypatch):
    """Knobs, headline and observables() make a cost study; without paper_reference() the study
    runs and its record of the paper is None (the collect step then writes no extrapolation)."""
    chute = registry.get("chute")

    class WithStudy(type(drum)):
        package_dir = drum.package_dir  # its deck template
        knobs = {"t_average": Knob(("rungs.{r}.t_average",), "set", "max", "sqrt(d/g)")}
        headline = chute.headline

        def observables(self, case_dir, record, t_average, block=None):
            return chute.observables(case_dir, record, t_average, block)

    scene = WithStudy()
    assert scene.gives("cost_study") and not scene.gives("paper_reference")
    monkeypatch.setattr(registry, "_found", lambda: registry.Found({"drum": scene}, {}))
    study = "cost:\n  scenes:\n    drum:\n      base_rung: smoke\n      knobs: {t_average: [5.0, 10.0]}\n"
    cfg = load_campaign(campaign_file(tmp_path, drum_entry(tmp_path), study), root=tmp_path)
    cs = cfg["cost_studies"]["drum"]
    assert cs.points() == ["base", "t_average~5"]
    assert cost.paper_reference("drum", cs.base) is None


# ------------------------------------------------------------------------ validation record
def _case(root: Path, rel: str) -> Path:
    """A finished case of the minimal scene: its parameter record, status and one LAMMPS log."""
    case = root / rel
    (case / "run" / "logs").mkdir(parents=True)
    (case / "params.json").write_text(json.dumps({"scene": "drum", "rung": "smoke", "case": {"theta_deg": 24.0},
                                                  "parameters": {"n_particles": 665}}))
    (case / "run" / "status.json").write_text(json.dumps({"status": "steady", "reason": "flat", "cpu_seconds": 36.0,
                                                         "wall_seconds": 36.0, "nprocs": 1}))
    (case / "run" / "logs" / "flow_001.log").write_text("LAMMPS (22 Jul 2025)\nLoop time of 1.0 on 1 procs\n")
    return case


def test_the_record_of_a_scene_without_validation_says_so(drum, tmp_path):
    scene_dir = tmp_path / "results" / "drum" / "smoke"
    cases = {"theta~24": _case(scene_dir, "theta~24")}
    result = validation.scene_validation(drum, scene_dir, cases)
    assert result.checks == [] and result.note == validation.NO_VALIDATION
    assert validation.NO_VALIDATION.startswith("no validation declared")
    out = tmp_path / "validation_smoke"
    summary = validation.write_record("drum", "smoke", result, cases, scene_dir / "figures", out / "drum")
    assert summary["note"] == validation.NO_VALIDATION and summary["checks"] == []
    assert [c["dir"] for c in summary["cases"]] == ["theta~24"] and summary["cpu_hours"] == pytest.approx(0.01)
    assert list(pd.read_csv(out / "drum" / "checks.csv").columns[:3]) == ["quantity", "paper", "source"]
    readme = validation.write_readme(out)
    assert f"- drum: {validation.NO_VALIDATION}\n" in readme
    assert "| drum | theta~24 | steady |" in readme
    page = overview.overview_rst([json.loads((out / "drum" / "summary.json").read_text())], "smoke")
    assert "drum: no validation declared" in page


def test_a_record_with_checks_carries_no_note(tmp_path):
    """The records of scenes that give validation() keep their keys (the committed ones do not move)."""
    case = _case(tmp_path / "results", "a")
    result = validation.ValidationResult([validation.Check("q", "1", "Fig. 1", 1.0, 0.1, paper_range=(1.0, 1.0))])
    summary = validation.write_record("toy", "smoke", result, {"a": case}, tmp_path / "figures", tmp_path / "out")
    assert "note" not in summary and "note" not in json.loads((tmp_path / "out" / "summary.json").read_text())
