"""Rendered decks: StrictUndefined, typed values, effects -> exactly those commands."""
import copy
import json
import math
import re

import jinja2
import pytest

from granflow import registry, scene_files
from granflow.schema import PROJECT_ROOT
from granflow.deck import STAGES, environment, render_case, template_path


def test_template_has_no_undefined_slack():
    env = environment()
    assert env.undefined is jinja2.StrictUndefined
    with pytest.raises(jinja2.UndefinedError, match="'scene' is undefined"):  # the first value it needs
        env.get_template("channel.lmp.j2").render(stage="init")


def test_every_number_is_a_commented_variable(channel_scene, tmp_path):
    render_case(channel_scene, "demo", tmp_path)
    text = (tmp_path / "init.lmp").read_text()
    lines = [l for l in text.splitlines() if l.startswith("variable") and " equal " in l]
    assert len(lines) > 20
    for line in lines[:30]:
        assert "#" in line, line
    # the deck's time step against a hand calculation from config/scenes/channel.yaml (demo rung):
    # k_n = 1e6, e_n = 0.82 for the d_p pair (m_eff = 1/2: density 6/pi gives a d^3 mass),
    # shortest contact the 0.9 d_p pair (m_eff = 0.9^3/2), dt = 0.08 t_c
    ln_e = math.log(0.82)
    xi_n = -2 * ln_e / math.sqrt(0.5 * (math.pi**2 + ln_e**2) / 1e6)
    t_c = math.pi / math.sqrt(1e6 / (0.9**3 / 2) - xi_n**2 / 4)
    assert t_c == pytest.approx(1.8995e-3, rel=1e-4)
    deck = dict(re.findall(r"^variable +(\w+) +equal +([-+.0-9eE]+) +#", text, re.M))
    deck = {name: float(value) for name, value in deck.items()}
    assert deck["xi_n"] == pytest.approx(xi_n, abs=5e-10)
    assert deck["t_c_min"] == pytest.approx(t_c, abs=5e-10)   # written with 9 decimals
    assert deck["dt"] == pytest.approx(0.08 * t_c, abs=5e-11)  # written with 10 decimals
    for stage in ("init", "flow", "average"):  # and it is the step LAMMPS takes
        assert re.search(r"^timestep +\$\{dt\}$", (tmp_path / f"{stage}.lmp").read_text(), re.M), stage


def _commands(path):
    return [l.split()[0:3] for l in path.read_text().splitlines() if l and not l.startswith("#")]


def test_effects_off_means_commands_absent(channel_scene, tmp_path):
    scene = copy.deepcopy(channel_scene)
    scene["effects"].update(per_atom_stress=False, spin_output=False, wall_force=False)
    render_case(scene, "smoke", tmp_path)
    avg = (tmp_path / "average.lmp").read_text()
    assert "stress/atom" not in avg and "c_stress" not in avg
    assert "omegax" not in avg
    assert "contacts" not in avg and "f_fwavg" not in avg
    # and with them on, they are present
    render_case(channel_scene, "smoke", tmp_path / "on")
    on = (tmp_path / "on" / "average.lmp").read_text()
    assert "compute         stress all stress/atom NULL pair" in on
    assert re.search(r"dump .* omegax omegay omegaz c_stress\[1\]", on)
    # stress is computed only where it is dumped: never in the init or flow decks
    for stage in ("init", "flow"):
        assert "stress/atom" not in (tmp_path / "on" / f"{stage}.lmp").read_text()


def test_monodisperse_has_one_type(channel_scene, tmp_path):
    scene = copy.deepcopy(channel_scene)
    scene["effects"]["polydisperse"] = False
    render_case(scene, "smoke", tmp_path)
    init = (tmp_path / "init.lmp").read_text()
    assert "create_box      1 box" in init and "type/subset" not in init


@pytest.mark.lammps
@pytest.mark.parametrize("rung", ["smoke", "demo", "study", "paper", "validation"])
def test_every_rung_passes_skiprun(channel_scene, tmp_path, skiprun, rung):
    """Each stage's deck parses and sets up in LAMMPS (-skiprun skips the runs; the packing check needs a run)."""
    render_case(channel_scene, rung, tmp_path)
    skiprun(tmp_path, STAGES, extra={"init": ["-var", "check_packing", "0"]})


@pytest.mark.parametrize("name", registry.names())
def test_the_header_names_the_real_template(name, tmp_path):
    """Each deck's header names the template it came from, in the scene's package, by its path in
    the project (it said lammps_inputs/<scene>.lmp.j2, where no template is)."""
    scene = scene_files.load_scene(PROJECT_ROOT / "config" / "scenes" / f"{name}.yaml")
    render_case(scene, "demo", tmp_path)
    for deck in sorted(tmp_path.glob("*.lmp")):
        m = re.search(r"^# Rendered by granflow from (\S+); do not edit by hand,$", deck.read_text(), re.M)
        assert m and m.group(1) == f"src/granflow/scenes/{name}/{name}.lmp.j2", (deck.name, m)
        assert (PROJECT_ROOT / m.group(1)).is_file()


def test_template_path_outside_the_project(tmp_path):
    """A scene package outside the project (granflow check-scene PATH) is named by its folder."""
    assert template_path(str(tmp_path / "drum" / "drum.lmp.j2")) == "drum/drum.lmp.j2"
