"""``granflow campaign --only SCENE``: a campaign of one scene, as docs/campaign.md tells a newcomer to run it.

The overlay it writes, merged over the campaign the way Snakemake merges a ``--configfile``
(:func:`snakemake.utils.update_config`), validates and enables exactly SCENE, for every registered
scene; its refusals name key, value and what is allowed (exit 2) and write nothing; and a
``snakemake -n`` dry run of the documented command plans the one scene's jobs only, while the
other order of the arguments (``--configfile FILE TARGET``) fails, as the docs say. No LAMMPS
run: the dry runs take a few seconds each.
"""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest
from snakemake.utils import update_config

from granflow import registry
from granflow.campaign import validate_campaign
from granflow.cli import main
from granflow.config import load_yaml
from granflow.one_scene import HEADER

ROOT = Path(__file__).resolve().parents[2]
CAMPAIGN = ROOT / "config" / "config.yaml"
SNAKEMAKE = Path(sys.executable).with_name("snakemake")


def merged(overlay_file: Path, base_file: Path = CAMPAIGN) -> dict:
    """The campaign Snakemake reads from ``snakemake --configfile OVERLAY``: the base, the overlay over it."""
    config = load_yaml(base_file)
    update_config(config, load_yaml(overlay_file))
    return config


def enabled(campaign: dict) -> set[str]:
    return {name for name, sc in campaign["scenes"].items() if sc.get("enabled", True)}


def write(capsys, *argv: str) -> tuple[int, str, str]:
    """``granflow campaign ARGV`` run from the project root: exit code, stdout, stderr."""
    code = main(["campaign", *argv])
    out, err = capsys.readouterr()
    return code, out, err


@pytest.fixture(autouse=True)
def at_root(monkeypatch):
    monkeypatch.chdir(ROOT)  # scene files and results_dir are found from the project root, as for snakemake


@pytest.mark.parametrize("scene", registry.names())
def test_the_overlay_validates_and_enables_exactly_its_scene(scene, tmp_path, capsys):
    out = tmp_path / f"{scene}_only.yaml"
    code, stdout, err = write(capsys, "--only", scene, "--out", str(out))
    assert code == 0, err
    assert f"snakemake --cores 2 --configfile {out}" in stdout
    assert out.read_text().startswith(HEADER)
    campaign = validate_campaign(merged(out), root=ROOT, source=str(out))
    assert enabled(campaign) == {scene}
    # the cost study, a target of its own, keeps only this scene's study (if the campaign has one)
    assert set(campaign.get("cost_studies", {})) <= {scene}


def test_every_scene_but_the_one_is_disabled_even_when_the_campaign_does_not_list_it(tmp_path, capsys):
    """A campaign naming chute alone, switched off: the overlay switches it on and every other
    registered scene off (another campaign file Snakemake merges underneath may list them)."""
    base = tmp_path / "campaign.yaml"
    base.write_text("rung: demo  # fidelity rung\nscenes:\n  chute:\n    enabled: false  # off in the file\n")
    out = tmp_path / "chute.yaml"
    code, stdout, err = write(capsys, "--only", "chute", "--config", str(base), "--out", str(out))
    assert code == 0, err
    overlay = load_yaml(out)
    assert overlay["scenes"] == {name: {"enabled": name == "chute"} for name in registry.names()}
    assert "cost" not in overlay  # the campaign has no cost study to switch off
    assert enabled(validate_campaign(merged(out, base), root=ROOT)) == {"chute"}
    # another campaign than config/config.yaml: Snakemake needs both files, the campaign first
    assert f"--configfile {base} {out}" in stdout


@pytest.mark.parametrize("argv, says", [
    (["--only", "drum"], f"--only = 'drum' is not allowed: allowed one of {', '.join(map(repr, registry.names()))}"),
    (["--only", "chute", "--config", "config/scenes/chute.yaml"],
     "--config config/scenes/chute.yaml is a scene file (scene = 'chute'): allowed a campaign file"),
    (["--only", "chute", "--config", "config/config.yaml", "--out", "config/config.yaml"],
     "--out config/config.yaml is the campaign file (--config): allowed another file"),
    (["--only", "chute", "--out", "config"], "--out config is a directory: allowed a file path"),
    (["--only", "chute", "--out", "README.md"],
     "--out README.md exists and was not written by granflow campaign: allowed a new file"),
    (["--only", "chute", "--out", ""], "--out '' is not allowed: allowed a file path"),
])
def test_refusals_name_key_value_and_what_is_allowed(argv, says, capsys):
    argv = argv if "--out" in argv else [*argv, "--out", "/nonexistent-dir/never.yaml"]
    code, stdout, err = write(capsys, *argv)
    assert code == 2
    assert says in err, err
    assert not Path("/nonexistent-dir/never.yaml").exists()


def test_a_refused_campaign_writes_nothing(tmp_path, capsys):
    """The campaign with the overlay is checked before the file is written: here its results_dir leaves the project."""
    base = tmp_path / "campaign.yaml"
    base.write_text("rung: demo\nresults_dir: ../elsewhere\nscenes:\n  chute:\n    enabled: true\n")
    out = tmp_path / "chute.yaml"
    code, _, err = write(capsys, "--only", "chute", "--config", str(base), "--out", str(out))
    assert code == 2
    assert "results_dir = '../elsewhere'" in err and "allowed a relative path" in err
    assert not out.exists()


def test_the_overlay_is_replaced_by_a_second_run_and_another_file_only_with_force(tmp_path, capsys):
    out = tmp_path / "one.yaml"
    assert write(capsys, "--only", "silo", "--out", str(out))[0] == 0
    assert write(capsys, "--only", "heap", "--out", str(out))[0] == 0  # granflow campaign's own file
    assert load_yaml(out)["scenes"]["heap"] == {"enabled": True}
    other = tmp_path / "notes.yaml"
    other.write_text("mine: 1\n")
    assert write(capsys, "--only", "heap", "--out", str(other))[0] == 2
    assert other.read_text() == "mine: 1\n"
    assert write(capsys, "--only", "heap", "--out", str(other), "--force")[0] == 0


def dry_run(*argv: str) -> subprocess.CompletedProcess:
    return subprocess.run([str(SNAKEMAKE), "-n", "--nolock", "--cores", "1", *argv], cwd=ROOT,
                          capture_output=True, text=True, timeout=300)


def test_the_documented_command_plans_the_one_scene_only(tmp_path, capsys):
    """docs/campaign.md's ``snakemake TARGET --cores 2 --configfile FILE``, with the target ``all`` (the
    default target, what ``snakemake --cores 2 --configfile FILE`` builds): only the scene's jobs are planned."""
    out = tmp_path / "chute_only.yaml"
    assert write(capsys, "--only", "chute", "--out", str(out))[0] == 0
    proc = dry_run("all", "--configfile", str(out))
    assert proc.returncode == 0, (proc.stdout + proc.stderr)[-2000:]
    planned = {line.split("results/")[1].split("/")[0] for line in proc.stdout.splitlines()
               if line.strip().startswith("output: results/")}
    assert "chute" in planned
    assert not planned & (set(registry.names()) - {"chute"}), planned


def test_configfile_before_the_target_swallows_the_target(tmp_path, capsys):
    """``--configfile FILE TARGET`` reads TARGET as a second config file (docs/campaign.md shows both orders)."""
    out = tmp_path / "chute_only.yaml"
    assert write(capsys, "--only", "chute", "--out", str(out))[0] == 0
    proc = dry_run("--configfile", str(out), "results/chute/demo/table.csv")
    assert proc.returncode != 0
    assert "This was a dry-run" not in proc.stdout
    # a missing target: no such config file; a table already built: a CSV is no config file
    said = ("No such file or directory: 'results/chute/demo/table.csv'",
            "Config file must be given as JSON or YAML with keys at top level")
    said_here = proc.stdout + proc.stderr  # snakemake prints this traceback on stdout
    assert any(s in said_here for s in said), said_here[-2000:]
