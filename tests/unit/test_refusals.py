"""Bad input never gets through: non-finite numbers, oversize cases, ambiguous YAML, templating
keys, colliding sweep values, targets outside the campaign, and CLI misuse. Each refusal names
key, value and allowed range, exits 2 without a traceback, and writes nothing."""
import json
import math

import pytest

from granflow.cli import main
from granflow.config import ConfigError, load_yaml, yaml_load
from granflow.targets import check_targets


def refused(capsys, argv) -> str:
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err and err.startswith("granflow: refused: "), err
    return err


# ------------------------------------------------------------------------ non-finite numbers
@pytest.mark.parametrize("value", [".nan", ".inf", "-.inf", ".NaN", "+.inf"])
def test_non_finite_number_is_refused_with_key_and_range(capsys, root, value):
    err = refused(capsys, ["check-config", str(root / "config/scenes/channel.yaml"),
                           "--set", f"contact.dt_max_fraction={value}"])
    assert "contact.dt_max_fraction" in err and "not a finite number" in err and "0 < value <= 0.2" in err


def test_non_finite_sweep_value_is_refused(capsys, root):
    err = refused(capsys, ["check-config", str(root / "config/config.yaml"), "--set", "scenes.channel.sweep.W=[.inf]"])
    assert "scenes.channel.sweep.W[0] = inf is not a finite number" in err


# ------------------------------------------------------------------------------ sizes
def silo_file(root, tmp_path, **rung):
    data = load_yaml(root / "config/scenes/silo.yaml")
    data["rungs"]["demo"].update(rung)
    path = tmp_path / "silo.yaml"
    path.write_text(json.dumps(data))  # JSON is YAML
    return path


def test_oversize_case_is_refused_before_anything_is_built(capsys, root, tmp_path):
    """R_c = 500 r_b: 8.5 million particles; refused by the estimate, no lattice is allocated."""
    path = silo_file(root, tmp_path, R_c=500)
    err = refused(capsys, ["check-config", str(root / "config/config.yaml"), "--set", f"scenes.silo.scene_file={path}"])
    assert "scenes.silo case R = 4.5 (rung demo) is too large: estimated 8,5" in err
    assert "allowed at most 2,000,000 particles" in err and "--max-particles" in err
    # the same through render: nothing written
    out = tmp_path / "out"
    err = refused(capsys, ["render", "silo", "--rung", "demo", "--config", str(path), "--out", str(out)])
    assert "too large" in err and not out.exists()


def test_size_limits_can_be_raised_and_lowered(capsys, root):
    campaign = str(root / "config/config.yaml")
    err = refused(capsys, ["check-config", campaign, "--max-particles", "1000"])
    assert "allowed at most 1,000 particles" in err
    err = refused(capsys, ["check-config", campaign, "--memory-mb", "100"])
    assert "MB of memory and" in err and "CPU-hours" in err and "allowed at most 100 MB" in err


def test_cost_study_size_factor_is_sized_before_it_is_built(capsys, root):
    err = refused(capsys, ["check-config", str(root / "config/config.yaml"), "--set", "cost.scenes.silo.knobs.size=[1,50]"])
    assert "cost.scenes.silo run 'size~50'" in err and "too large" in err


def test_particle_estimate_equals_the_built_count(root):
    """The cheap estimate is the count the deck holds (silo: gas + rim ring, not built)."""
    from granflow import registry
    from granflow.scene_files import load_scene

    for name, rung, case in [("silo", "demo", {"R": 6}), ("channel", "demo", None), ("chute", "smoke", None)]:
        scene = load_scene(root / f"config/scenes/{name}.yaml")
        sc = registry.get(name)
        built = sc.workload(sc.parameters(scene, rung, case)[1]["record"]).particles
        assert sc.particle_count(scene, rung, case) == built > 100


# ----------------------------------------------------------------------------- YAML
@pytest.mark.parametrize("text, key, reads", [
    ("seed: 0123", "seed = 0123", "83"), ("t: 1:30", "t = 1:30", "90"), ("flag: on", "flag = on", "True"),
    ("a: {b: [1, off]}", "a.b[1] = off", "False"), ("n: 1_000", "n = 1_000", "1000"), ("yes: 1", "the key yes", "True"),
])
def test_ambiguous_yaml_is_refused(text, key, reads):
    with pytest.raises(ConfigError) as exc:
        yaml_load(text, "f.yaml")
    assert f"f.yaml: {key} (line 1) is ambiguous YAML" in str(exc.value) and f"reads it as {reads}" in str(exc.value)


@pytest.mark.parametrize("text, value", [("x: 0", 0), ("x: 0.5", 0.5), ("x: 1e5", 1e5), ("x: true", True),
                                         ("x: '0123'", "0123"), ("x: -7", -7), ("x: .nan", None)])
def test_plain_yaml_reads_as_before(text, value):
    got = yaml_load(text)["x"]
    assert (math.isnan(got) if value is None else got == value and type(got) is type(value))


def test_templating_key_is_refused_with_why(capsys, tmp_path):
    path = tmp_path / "campaign.yaml"
    path.write_text("__use_yte__: true\nrung: demo\nscenes: {}\n")
    err = refused(capsys, ["check-config", str(path)])
    assert "__use_yte__ = True is not allowed" in err and "evaluates" in err and "even under -n" in err


# ------------------------------------------------------------------------ result directories
def test_sweep_values_naming_one_directory_are_refused(capsys, root):
    err = refused(capsys, ["check-config", str(root / "config/config.yaml"),
                           "--set", "scenes.channel.sweep.phi_mean=[0.6, 0.6000001]"])
    assert "scenes.channel.sweep.phi_mean = 0.6 and 0.6000001 name the same result directory phi~0.6" in err
    err = refused(capsys, ["check-config", str(root / "config/config.yaml"), "--set", "scenes.channel.sweep.phi_mean=[0.6000001]"])
    assert "it would run as 0.6" in err


# ---------------------------------------------------------------------------- targets
CASES = {"channel": ["W~20/phi~0.58", "W~20/phi~0.6"]}


@pytest.mark.parametrize("target, needle", [
    ("results/channel/demo/W~999/phi~0.99/run/status.json", "case W~999/phi~0.99 is not one of the campaign's channel cases"),
    ("results/channel/smoke/W~20/phi~0.6/params.json", "rung smoke is not this campaign's: allowed demo"),
    ("results/silo/demo/R~6/params.json", "scene silo is not enabled in this campaign: allowed channel"),
    ("results/cost/channel/runs/size~7/params.json", "cost-study run size~7 is not one of the channel study's"),
    ("./results//channel/demo/W~20/phi~0.61/analysis", "allowed W~20/phi~0.58, W~20/phi~0.6"),
])
def test_targets_outside_the_campaign_are_refused(target, needle):
    with pytest.raises(ConfigError) as exc:
        check_targets([target], "results", "demo", CASES, ["channel", "silo"], {"channel": (["base", "size~1.5"], ["base"])})
    assert needle in str(exc.value) and target in str(exc.value)


@pytest.mark.parametrize("target, examined", [
    ("results/channel/demo/W~20/phi~0.6/run/status.json", True),
    ("results/channel/demo/table.csv", True),
    ("results/cost/channel/runs/size~1.5/params.json", True),
    ("all", False),                          # a rule name
    ("results/report/x.csv", False),         # under results, not a scene's
    ("elsewhere/W~1/file", False),           # outside results
    ("{tmp}/results/channel/demo/W~99/x", False),  # absolute, outside the working directory
])
def test_campaign_targets_pass(target, examined, tmp_path):
    """A target of the campaign passes; it passes because the campaign lists it (refused, naming
    it, by a campaign without that scene and cost study), while a rule name or a path outside
    the scenes' results passes any campaign (it is not examined)."""
    target = target.format(tmp=tmp_path)
    check_targets([target], "results", "demo", CASES, ["channel", "silo"], {"channel": (["base", "size~1.5"], ["base"])})
    if examined:
        with pytest.raises(ConfigError) as exc:
            check_targets([target], "results", "demo", {}, ["channel", "silo"], {})
        assert f"target {target}: " in str(exc.value) and "channel" in str(exc.value), str(exc.value)
    else:
        check_targets([target], "results", "demo", {}, ["channel", "silo"], {})


def test_snakemake_command_line_targets_are_read():
    from granflow.targets import cli_targets

    argv = ["-n", "--cores", "2", "results/a/x", "--forcerun", "results/b/y", "--config", "rung=demo"]
    assert set(cli_targets(argv)) >= {"results/a/x", "results/b/y"}


# ------------------------------------------------------------------------------- CLI
def test_run_refuses_what_is_not_a_case(capsys, tmp_path):
    err = refused(capsys, ["run", str(tmp_path / "missing")])
    assert "does not exist" in err
    err = refused(capsys, ["run", str(tmp_path)])
    assert "has no params.json" in err and "granflow render" in err
    (tmp_path / "params.json").write_text("{broken")
    err = refused(capsys, ["run", str(tmp_path)])
    assert "params.json is not valid JSON" in err
    (tmp_path / "params.json").write_text('{"a": 1}')
    err = refused(capsys, ["run", str(tmp_path)])
    assert "not a granflow parameter record" in err
    assert not (tmp_path / "run").exists()


def test_render_refuses_another_scenes_file_and_writes_nothing(capsys, root, tmp_path):
    out = tmp_path / "out"
    err = refused(capsys, ["render", "silo", "--rung", "smoke", "--config", str(root / "config/scenes/channel.yaml"),
                           "--out", str(out)])
    assert "describes the channel scene: allowed a silo scene file" in err and not out.exists()


def test_render_never_overwrites_a_users_files(capsys, tmp_path):
    err = refused(capsys, ["render", "channel", "--rung", "smoke", "--out", ""])
    assert "--out '' is not allowed" in err
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "init.lmp").write_text("my own deck\n")
    err = refused(capsys, ["render", "channel", "--rung", "smoke", "--out", str(mine)])
    assert "not empty and was not rendered by granflow" in err and "--force" in err
    assert (mine / "init.lmp").read_text() == "my own deck\n"
    assert main(["render", "channel", "--rung", "smoke", "--out", str(mine), "--force"]) == 0
    # granflow's own directory may be rendered again, with the same parameters even beside a run
    assert main(["render", "channel", "--rung", "smoke", "--out", str(mine)]) == 0
    (mine / "run").mkdir()
    assert main(["render", "channel", "--rung", "smoke", "--out", str(mine)]) == 0
    before = (mine / "params.json").read_text()
    err = refused(capsys, ["render", "channel", "--rung", "smoke", "--out", str(mine), "--set", "case.phi_mean=0.61"])
    assert "holds a run of other parameters" in err and (mine / "params.json").read_text() == before


def test_bad_out_path_is_refused_not_a_traceback(capsys, tmp_path):
    (tmp_path / "afile").write_text("x")
    err = refused(capsys, ["render", "channel", "--rung", "smoke", "--out", str(tmp_path / "afile")])
    assert "is a file" in err
    err = refused(capsys, ["render", "channel", "--rung", "smoke", "--out", str(tmp_path / "afile" / "case")])
    assert "afile" in err


def test_debug_shows_the_traceback(capsys, root):
    assert main(["--debug", "check-config", str(root / "config/scenes/channel.yaml"), "--set", "case.W=-5"]) == 2
    assert "Traceback" in capsys.readouterr().err


def test_debug_shows_the_error_of_a_scene_package_that_does_not_import(capsys, tmp_path, monkeypatch):
    """Issue 41: --debug on a scene whose package fails to import showed the registry's traceback, not
    the package's own error with its file and line. Now that error is the refusal's cause."""
    import sys

    from granflow import registry

    broke = tmp_path / "scenes41" / "broke"
    broke.mkdir(parents=True)
    (tmp_path / "scenes41" / "__init__.py").write_text("")
    (broke / "__init__.py").write_text('"""A scene with a bug."""\n\nFLOW = 1 / 0\n')
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.setattr(registry, "_found", lambda: registry.discover("scenes41"))
    try:
        argv = ["render", "broke", "--rung", "smoke", "--out", str(tmp_path / "out")]
        assert main(argv) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and "Traceback" not in err, err  # without --debug: one line
        assert "scene 'broke' is refused: its package does not import (ZeroDivisionError: division by zero)" in err
        assert main(["--debug", *argv]) == 2
        err = capsys.readouterr().err
        assert f'File "{broke / "__init__.py"}", line 3, in <module>' in err, err
        assert "FLOW = 1 / 0" in err and "The above exception was the direct cause of the following" in err, err
    finally:
        for name in [m for m in sys.modules if m == "scenes41" or m.startswith("scenes41.")]:
            del sys.modules[name]
