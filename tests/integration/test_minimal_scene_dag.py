"""A fifth scene added as a new user adds one: its package, scene file and schema in a copy of the
project, nothing else changed. The scene (tests/data/minimal_scene) gives only the required parts,
so the workflow must skip what it does not give and say so where asked: no validation (the record
says "no validation declared"), no cost study, and in a second scene a cost study without a paper
reference. A third package, without SCENE, is refused by name while the others keep working.
The scenes are named ``tmp_throwaway*``, names no user would give a scene: the copy is of the
working tree, which may hold a user's own scene (one called ``drum``, the docs' example, made
every test here fail with FileExistsError)."""
import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

from granflow import registry

BIN = Path(sys.executable).parent

#: the minimal scene's scene file made quick at smoke (the chute's, renamed): short flow, averaged anyway
QUICK = {"    t_flow_max: 200.0 ": "    t_flow_max: 20.0 ", "  average_unsteady: false ": "  average_unsteady: true "}

#: the second scene: the minimal one with a cost study (knobs, headline, observables()) but no paper_reference()
WITH_STUDY = '''from granflow.registry import Knob
from granflow.scenes import chute
from granflow.scenes.tmp_throwaway import MinimalScene


class WithStudy(MinimalScene):
    name = "tmp_throwawaycost"
    knobs = {"t_average": Knob(("rungs.{r}.t_average",), "set", "max", "sqrt(d/g)")}
    headline = chute.SCENE.headline

    def observables(self, case_dir, record, t_average, block=None):
        return chute.SCENE.observables(case_dir, record, t_average, block)


SCENE = WithStudy()
'''


@pytest.fixture(scope="module")
def project(tmp_path_factory, project_copy, minimal_scene):
    """The copy with ``tmp_throwaway`` (required parts only), ``tmp_throwawaycost`` (and a cost study)
    and ``tmp_throwaway_broken`` (no SCENE); returns (root, environment that imports granflow from the copy)."""
    root = project_copy(tmp_path_factory.mktemp("project"))
    scenes = root / "src" / "granflow" / "scenes"
    minimal_scene(scenes, root / "config", "tmp_throwaway", edits=QUICK)
    package = minimal_scene(scenes, root / "config", "tmp_throwawaycost", edits=QUICK)
    (package / "__init__.py").write_text(WITH_STUDY)
    (scenes / "tmp_throwaway_broken").mkdir()
    broken = scenes / "tmp_throwaway_broken" / "__init__.py"
    broken.write_text('"""A scene package still being written: no SCENE yet."""\n')
    env = dict(os.environ, PYTHONPATH=str(root / "src"))
    return root, env


def campaign(root: Path, work: Path, extra: str = "") -> Path:
    """Only tmp_throwaway enabled at smoke, one angle; every study of config/config.yaml off; ``extra`` appended."""
    work.mkdir(exist_ok=True)
    cfg = work / "config.yaml"
    cfg.write_text(
        "rung: smoke\n"
        f"results_dir: {work / 'results'}\n"
        "scenes:\n"
        + "".join(f"  {name}: {{enabled: false}}\n" for name in registry.names()) +
        "  tmp_throwaway:\n    enabled: true\n    scene_file: config/scenes/tmp_throwaway.yaml\n"
        "    sweep: {theta_deg: [24]}\n"
        "cost:\n  scenes:\n"
        + "".join(f"    {name}: {{enabled: false}}\n" for name in registry.names())
        + extra)
    return cfg


def snakemake(project, work: Path, cfg: Path, *args, timeout=600) -> subprocess.CompletedProcess:
    root, env = project
    # the options that take lists (--configfile, --quiet) after the targets
    cmd = [str(BIN / "snakemake"), "--snakefile", str(root / "Snakefile"), "--directory", str(work), *args,
           "--configfile", str(cfg)]
    return subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, env=env)


def test_scenes_lists_the_new_ones_and_names_the_refused_one(project):
    root, env = project
    proc = subprocess.run([str(BIN / "granflow"), "scenes"], capture_output=True, text=True, env=env, cwd=root,
                          timeout=120)
    assert proc.returncode == 0, proc.stderr
    names = [line.split()[0] for line in proc.stdout.splitlines()]
    assert names == sorted(registry.names() + ("tmp_throwaway", "tmp_throwawaycost")) + ["tmp_throwaway_broken"]
    assert re.search(r"^tmp_throwaway_broken +refused: it lacks SCENE", proc.stdout, re.M), proc.stdout
    proc = subprocess.run([str(BIN / "granflow"), "render", "tmp_throwaway_broken", "--rung", "smoke",
                           "--out", "x"],
                          capture_output=True, text=True, env=env, cwd=root, timeout=120)
    assert proc.returncode == 2, proc.stderr
    assert "scene 'tmp_throwaway_broken' is refused: it lacks SCENE" in proc.stderr, proc.stderr
    assert not (root / "x").exists()


def test_the_campaign_plans_the_validation_record_of_a_scene_without_validation(project, tmp_path):
    root, _ = project
    proc = snakemake(project, tmp_path, campaign(root, tmp_path), "-n", "--cores", "1")
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    for rule in ("render", "simulate", "analyse", "table", "figure", "validation_record", "overview", "timing"):
        assert f"rule {rule}:" in proc.stdout, rule
    assert "NotImplementedError" not in proc.stdout + proc.stderr


def test_validate_says_what_it_skips(project, tmp_path):
    root, _ = project
    proc = snakemake(project, tmp_path, campaign(root, tmp_path), "-n", "--cores", "1", "validate")
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    assert ("validate: the tmp_throwaway scene declares no validation(): its record lists its cases and says "
            "'no validation declared'") in proc.stderr


def test_cost_runs_a_study_without_a_paper_reference_and_skips_a_scene_without_one(project, tmp_path):
    root, _ = project
    study = "    tmp_throwawaycost:\n      base_rung: smoke\n      knobs: {t_average: [5.0, 10.0]}\n"
    proc = snakemake(project, tmp_path, campaign(root, tmp_path, study), "-n", "--cores", "1", "cost")
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    assert "cost_collect" in proc.stdout and "results/cost/tmp_throwawaycost" in proc.stdout
    assert "cost: the tmp_throwaway scene declares no cost study (knobs, headline and observables()): none is run" \
           in proc.stderr
    assert ("cost: the tmp_throwawaycost scene declares no paper_reference(): its study is not extrapolated"
            in proc.stderr)


def test_a_cost_study_of_a_scene_without_one_is_refused_before_anything_runs(project, tmp_path):
    root, _ = project
    study = "    tmp_throwaway:\n      base_rung: smoke\n      knobs: {t_average: [5.0, 10.0]}\n"
    proc = snakemake(project, tmp_path, campaign(root, tmp_path, study), "-n", "--cores", "1", "cost")
    assert proc.returncode == 2, proc.stdout[-3000:] + proc.stderr[-3000:]
    assert "cost.scenes.tmp_throwaway is not allowed: the tmp_throwaway scene declares no cost study" in proc.stderr
    assert "Traceback" not in proc.stderr


def test_a_campaign_that_enables_a_refused_scene_is_refused(project, tmp_path):
    root, _ = project
    cfg = campaign(root, tmp_path)
    cfg.write_text(cfg.read_text().replace("cost:\n", "  tmp_throwaway_broken: {enabled: true}\ncost:\n"))
    proc = snakemake(project, tmp_path, cfg, "-n", "--cores", "1")
    assert proc.returncode == 2, proc.stdout[-3000:] + proc.stderr[-3000:]
    assert "scenes.tmp_throwaway_broken is enabled, but the scene is refused: it lacks SCENE" in proc.stderr


@pytest.mark.lammps
def test_the_campaign_with_the_minimal_scene_runs_to_its_end(project, tmp_path, check_png):
    """One smoke case of the minimal scene through the whole campaign: LAMMPS, analysis, table, figure,
    provenance, the validation record (no checks, saying so) and the report's front page."""
    root, _ = project
    proc = snakemake(project, tmp_path, campaign(root, tmp_path), "--cores", "2", "--quiet", "rules", timeout=1800)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    results = tmp_path / "results"
    assert (results / "tmp_throwaway" / "smoke" / "table.csv").stat().st_size > 0
    check_png(results / "tmp_throwaway" / "smoke" / "figures" / "fig_regimes.png")
    summary = json.loads((results / "validation_smoke" / "tmp_throwaway" / "summary.json").read_text())
    assert summary["checks"] == [] and summary["note"].startswith("no validation declared")
    assert [c["dir"] for c in summary["cases"]] == ["theta~24"]
    # the front page is reStructuredText: the scene's underscore comes escaped
    assert "tmp\\_throwaway: no validation declared" in (results / "report" / "overview_smoke.rst").read_text()
    # `validate` on the finished cases: the record's README, one line saying what was skipped
    proc = snakemake(project, tmp_path, campaign(root, tmp_path), "validate", "--cores", "1", "--quiet", "rules")
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    assert "validate: the tmp_throwaway scene declares no validation()" in proc.stderr
    assert "- tmp_throwaway: no validation declared" in (results / "validation_smoke" / "README.md").read_text()


@pytest.mark.lammps
def test_a_cost_study_without_a_paper_reference_runs_to_its_end(project, tmp_path):
    """tmp_throwawaycost's study (one run, two averaging times): its table says there is no extrapolation."""
    import pandas as pd

    root, _ = project
    study = "    tmp_throwawaycost:\n      base_rung: smoke\n      knobs: {t_average: [5.0, 10.0]}\n"
    proc = snakemake(project, tmp_path, campaign(root, tmp_path, study), "cost", "--cores", "2", "--quiet", "rules",
                     timeout=1800)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    base = tmp_path / "results" / "cost" / "tmp_throwawaycost"
    within = pd.read_csv(base / "within.csv")
    assert len(within) and set(within["extrapolation"]) == {
        "none: the tmp_throwawaycost scene declares no paper_reference() (the paper's size and time)"}
    assert within["paper_cpu_h"].isna().all()
    assert json.loads((base / "summary.json").read_text())["paper"] is None
