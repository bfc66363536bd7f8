"""The heap's side walls may have their own friction (contact.side_wall_friction, the ladder's wall_mu02):
only the two side-wall fixes read it; without the key the deck and params.json are those of wall_friction."""
from __future__ import annotations

import json
import re

import pytest

from granflow.config import ConfigError
from granflow.deck import render_case
from granflow.scene_files import load_scene
from granflow.schema import PROJECT_ROOT

SCENE = PROJECT_ROOT / "config" / "scenes" / "heap.yaml"
CASE = {"mixture": "bi1-2", "feed_rate": 0.033}


def render(tmp_path, overrides):
    out = tmp_path / ("side" if overrides else "base")
    render_case(load_scene(SCENE, overrides), "validation", out, CASE)
    return (out / "flow.lmp").read_text(), json.loads((out / "params.json").read_text())


def frictions(deck):
    """fix id -> the friction each granular wall fix reads (the word before its wall style)."""
    found = {}
    for line in deck.splitlines():
        m = re.match(r"fix\s+(\S+)\s+\S+\s+wall/gran(?:/region)?\s.*\s(\$\{\w+\})\s+(?:xplane|yplane|zplane|region)\s", line)
        if m:
            found[m.group(1)] = m.group(2)
    return found


def test_only_the_side_walls_read_their_own_friction(tmp_path):
    base_deck, base_params = render(tmp_path, [])
    side_deck, side_params = render(tmp_path, ["contact.side_wall_friction=0.2"])
    base, side = frictions(base_deck), frictions(side_deck)
    assert set(base) == set(side) and any(k.startswith("sides") for k in base) and any(k.startswith("base") for k in base)
    for fix in base:
        assert base[fix] == "${wall_friction}"
        assert side[fix] == ("${side_wall_friction}" if fix.startswith("sides") else "${wall_friction}")
    assert "variable side_wall_friction equal 0.2" in side_deck and "side_wall_friction" not in base_deck
    assert side_params["parameters"]["side_wall_friction"] == 0.2
    assert "side_wall_friction" not in base_params["parameters"]


@pytest.mark.parametrize("value", [-0.1, 11, "rough"])
def test_a_side_wall_friction_outside_its_range_is_refused(value):
    with pytest.raises(ConfigError, match="side_wall_friction"):
        load_scene(SCENE, [f"contact.side_wall_friction={value}"])
