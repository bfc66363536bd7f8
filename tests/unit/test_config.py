"""Invalid configuration is refused before anything runs, naming key, value and range."""
import subprocess
import sys

import pytest

from granflow.campaign import load_campaign
from granflow.cli import main
from granflow.config import ConfigError, apply_overrides
from granflow.scene_files import load_scene


def refuse(capsys, argv):
    assert main(argv) == 2  # bad input: refused, nothing ran
    return capsys.readouterr().err


def test_default_files_are_valid(root):
    cfg = load_campaign(root / "config" / "config.yaml", root=root)
    assert cfg["rung"] in cfg["scenes"]["channel"]["scene"]["rungs"]


@pytest.mark.parametrize(
    "override, needles",
    [
        ("scenes.channel.sweep.phi_mean=[0.70]", ["scenes.channel.sweep.phi_mean[0]", "0.7", "0.5 <= value <= 0.64"]),
        ("scenes.channel.sweep.W=[-5]", ["scenes.channel.sweep.W[0]", "-5", "4 <= value <= 1000"]),
        ("scenes.channel.colour=red", ["unknown key scenes.channel.colour", "red", "allowed keys"]),
        ("rung=fast", ["rung", "'fast'", "'smoke', 'demo', 'study', 'paper'"]),
    ],
)
def test_campaign_refusals(capsys, root, override, needles):
    err = refuse(capsys, ["check-config", str(root / "config" / "config.yaml"), "--set", override])
    for n in needles:
        assert n in err, (n, err)


@pytest.mark.parametrize(
    "override, needles",
    [
        ("case.phi_mean=0.70", ["case.phi_mean", "0.7", "0.5 <= value <= 0.64"]),
        ("case.W=-5", ["case.W", "-5", "4 <= value <= 1000"]),
        ("contact.e_n=1.3", ["contact.e_n", "1.3", "0 < value <= 1"]),
        ("contact.stiffness=3", ["unknown key contact.stiffness", "allowed keys"]),
        ("contact.model=hertz", ["contact.model", "'hertz'", "hooke/history"]),
        ("particles.number_fractions=[0.5,0.4,0.3]", ["number_fractions", "sum to 1.2", "sum = 1"]),
    ],
)
def test_scene_refusals(capsys, root, override, needles):
    err = refuse(capsys, ["check-config", str(root / "config" / "scenes" / "channel.yaml"), "--set", override])
    for n in needles:
        assert n in err, (n, err)


def test_unknown_rung_refused_by_render(capsys, tmp_path):
    err = refuse(capsys, ["render", "channel", "--rung", "ultra", "--out", str(tmp_path)])
    assert "'ultra'" in err and "smoke, demo, study, validation, paper" in err
    assert not any(tmp_path.iterdir()), "a refused render must write nothing"


def test_override_types_follow_yaml():
    out = apply_overrides({"a": {"b": 1}}, ["a.b=0.61", "a.c=[20, 30]", "d=true"])
    assert out == {"a": {"b": 0.61, "c": [20, 30]}, "d": True}
    with pytest.raises(ConfigError, match="KEY=VALUE"):
        apply_overrides({}, ["novalue"])


def test_free_text_cannot_reach_a_deck(root):
    # a string where a number is expected is refused by type, whatever it contains
    with pytest.raises(ConfigError, match="wrong type"):
        load_scene(root / "config" / "scenes" / "channel.yaml", ['case.phi_mean="0.6; shell rm -rf /"'])


def test_console_script_help():
    out = subprocess.run([sys.executable, "-m", "granflow.cli", "--help"], capture_output=True, text=True)
    assert out.returncode == 0 and "check-config" in out.stdout and "render" in out.stdout


def test_a_campaign_entry_without_enabled_is_enabled(root, tmp_path, scenes_off, capsys, monkeypatch):
    """Issue 41: a campaign entry had to say `enabled: true` although the schema's default is true."""
    cfg = tmp_path / "campaign.yaml"
    cfg.write_text("rung: smoke\nscenes:\n  chute:\n    scene_file: config/scenes/chute.yaml\n"
                   + scenes_off(keep=("chute",)))
    loaded = load_campaign(cfg, root=root)
    assert loaded["scenes"]["chute"].get("enabled", True) is True and "scene" in loaded["scenes"]["chute"]
    monkeypatch.chdir(root)
    assert main(["check-config", str(cfg)]) == 0, capsys.readouterr().err
