"""The ladders as targets of the workflow: every rung's cases are jobs of the campaign's render / simulate /
analyse rules, the record is a rule of the same DAG, a rung resumes through the same target, and
`granflow plan --config config/ladders/<scene>.yaml` prices every rung as a campaign's cases."""
import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

from granflow import cli
from granflow.ladder import ladder_files, ladder_plan, load_ladder, rung_case_dirs, rung_setups

ROOT = Path(__file__).resolve().parents[2]
SNAKEMAKE = Path(sys.executable).parent / "snakemake"


def dry_run(workdir: Path, *targets: str) -> str:
    """`snakemake -n TARGETS` of this checkout's Snakefile in ``workdir`` (results/ and validation/ there)."""
    env = dict(os.environ, PYTHONPATH=str(ROOT / "src"))
    done = subprocess.run([str(SNAKEMAKE), "-n", "--cores", "2", "-s", str(ROOT / "Snakefile"), "--directory",
                           str(workdir), *targets], capture_output=True, text=True, env=env, timeout=300)
    assert done.returncode == 0, done.stderr + done.stdout
    return done.stdout


def job_counts(text: str) -> dict[str, int]:
    table = text.split("Job stats:", 1)[1]
    return {m.group(1): int(m.group(2)) for m in re.finditer(r"^(\w+)\s+(\d+)$", table, re.M)}


def expected_cases(results: Path) -> dict[str, list[str]]:
    out = {}
    for path in ladder_files(ROOT):
        ladder = load_ladder(path)
        out[ladder["scene"]] = [d for s in rung_setups(ladder, results, ROOT).values()
                                for d in rung_case_dirs(ladder, s)]
    return out


@pytest.fixture(scope="module")
def ladder_dry_run(tmp_path_factory):
    workdir = tmp_path_factory.mktemp("ladder")
    return workdir, dry_run(workdir, "ladder")


def test_snakemake_ladder_lists_every_rungs_cases_with_the_campaigns_rules(ladder_dry_run):
    workdir, text = ladder_dry_run
    cases = expected_cases(Path("results"))
    n = sum(len(c) for c in cases.values())
    counts = job_counts(text)
    assert counts["render"] == counts["simulate"] == counts["analyse"] == n
    assert counts["ladder_record"] == len(cases) and counts["ladder"] == 1
    for scene, dirs in cases.items():
        for d in dirs:            # each case of each rung (planned rungs are priced, never jobs)
            assert f"output: {d}/params.json" in text
        assert f"output: validation/{scene}/ladder.csv, validation/{scene}/ladder.md, " \
               f"validation/{scene}/figures/ladder.png" in text
    assert "/ladders/heap/paper/" not in text and "/ladders/silo/paper/" not in text


def test_a_rung_runs_its_own_scene_and_one_scene_target_runs_one_ladder(tmp_path):
    counts = job_counts(dry_run(tmp_path, "ladder_channel"))
    n = len(expected_cases(Path("results"))["channel"])
    assert counts == {"render": n, "simulate": n, "analyse": n, "ladder_record": 1, "ladder_channel": 1, "total": 3 * n + 2}


def test_a_rung_interrupted_mid_run_resumes_through_the_same_target(tmp_path):
    """A case with complete segments (restart files) and no final status: the plan says partial, and the target
    schedules only its simulate job (the runner resumes after its last complete segment), not its render."""
    ladder = load_ladder(ROOT / "config" / "ladders" / "channel.yaml")
    setup = rung_setups(ladder, Path("results"), ROOT)["B10"]
    (case,) = rung_case_dirs(ladder, setup)
    run = tmp_path / case / "run"
    run.mkdir(parents=True)
    (run / "flow_000.restart").write_bytes(b"restart")
    from granflow.deck import render_case
    from granflow import registry

    scene = setup["scenes"]["channel"]["scene"]
    render_case(scene, setup["rung"], tmp_path / case, registry.get("channel").case_from_dir(case.split("/validation/")[1]))
    plan = ladder_plan(ladder, tmp_path / "results", ROOT)
    (row,) = [r for r in plan["rows"] if r["scene"] == "channel/B10"]
    assert (row["state"], row["segments_done"]) == ("partial", 1)
    text = dry_run(tmp_path, "ladder_channel")
    assert f"output: {case}/run/status.json" in text            # simulate again: it resumes
    assert f"output: {case}/params.json" not in text             # its deck is as rendered: no render job
    assert job_counts(text)["render"] == len(ladder["rungs"]) - 1   # every other rung's case, B10's not


def test_plan_prices_a_ladder_like_a_campaign(capsys):
    assert cli.main(["plan", "--config", "config/ladders/channel.yaml", "--json"]) == 0
    plan = json.loads(capsys.readouterr().out)
    ladder = load_ladder(ROOT / "config" / "ladders" / "channel.yaml")
    labels = [f"channel/{r['name']}" for r in ladder["rungs"]] + \
             [f"channel/{r['name']} (planned)" for r in ladder["planned"]]
    assert list(plan["scenes"]) == labels
    assert plan["total"]["cpu_hours"] == pytest.approx(sum(t["cpu_hours"] for t in plan["scenes"].values()))
    assert all("/ladders/channel/" in r["case_dir"] for r in plan["rows"])
    assert cli.main(["plan", "--config", "config/ladders/channel.yaml", "--rung", "paper"]) == 2
    assert "is a ladder: --rung and --set are not allowed" in capsys.readouterr().err


def test_a_file_target_under_the_ladders_names_one_of_their_rungs_and_cases():
    """`snakemake results/ladders/...` is checked as a campaign's case target is: a rung the ladder does not
    run, or a case of another rung, is refused by name (granflow.targets)."""
    from granflow.config import ConfigError
    from granflow.targets import check_targets

    ladders = {"heap": {"base": ("validation", ["mixture~bi1-2/feed_rate~0.033"]),
                        "one_kn_mdot10": ("validation", ["mixture~bi1-2/feed_rate~0.01"])}}

    def check(target):
        check_targets([target], "results", "demo", {}, ["heap"], {}, ladders=ladders)

    check("results/ladders/heap/base/heap/validation/mixture~bi1-2/feed_rate~0.033/params.json")
    check("results/ladders/heap/benchmarks/ladder_record.tsv")
    with pytest.raises(ConfigError, match="rung W046 is not one the heap ladder runs: allowed base, one_kn_mdot10"):
        check("results/ladders/heap/W046/heap/validation/mixture~bi1-2/feed_rate~0.033/params.json")
    with pytest.raises(ConfigError, match="case mixture~bi1-2/feed_rate~0.01 is not one of the heap ladder's rung base"):
        check("results/ladders/heap/base/heap/validation/mixture~bi1-2/feed_rate~0.01/params.json")
    with pytest.raises(ConfigError, match="scene silo has no ladder: allowed heap"):
        check("results/ladders/silo/base/silo/validation/R~6/params.json")


def test_a_rung_renders_at_its_ladders_rung_whatever_the_campaigns(tmp_path):
    """Before: the render rule took the campaign's rung, so `snakemake ladder_chute` beside the default campaign
    (rung demo) wrote demo decks (H = 20 d, k_n 2e4) into the ladder's validation case directories. Now a
    rung's case renders at its ladder's rung: the same params.json as granflow.deck.render_case writes."""
    from granflow.deck import render_case

    ladder = load_ladder(ROOT / "config" / "ladders" / "chute.yaml")
    assert ladder["rung"] == "validation"
    setup = rung_setups(ladder, Path("results"), ROOT)["base"]
    case = rung_case_dirs(ladder, setup)[0]
    env = dict(os.environ, PYTHONPATH=str(ROOT / "src"))
    done = subprocess.run([str(SNAKEMAKE), "--cores", "1", "-s", str(ROOT / "Snakefile"), "--directory",
                           str(tmp_path), f"{case}/params.json"], capture_output=True, text=True, env=env, timeout=300)
    assert done.returncode == 0, done.stderr + done.stdout
    record = json.loads((tmp_path / case / "params.json").read_text())
    assert record["rung"] == "validation" and record["rung_knobs"]["H"] == 30.0
    from granflow import registry

    expected = render_case(setup["scenes"]["chute"]["scene"], "validation", tmp_path / "direct",
                           registry.get("chute").case_from_dir(case.split("/validation/", 1)[1]))
    assert record == json.loads(json.dumps(expected))
