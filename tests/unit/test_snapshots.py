"""Particle snapshots: which rungs write them, what the decks say, which images the report shows."""
import json

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402

from granflow import registry  # noqa: E402
from granflow.config import ConfigError  # noqa: E402
from granflow.scene_files import load_scene  # noqa: E402
from granflow.deck import render_case  # noqa: E402
from granflow.registry import SnapshotView  # noqa: E402
from granflow.snapshots import SnapshotError, compose, images, pick, segment_times  # noqa: E402

#: the case of a scene where its scene file's own case is not feasible at the smoke rung
SMOKE_CASES = {"heap": {"feed_rate": 0.005}, "silo": {"R": 3.0}}


@pytest.mark.parametrize("name", registry.names())
def test_decks_write_images_only_at_the_listed_rungs(tmp_path, name):
    if not registry.get(name).gives("snapshots"):
        pytest.skip(f"the {name} scene declares no snapshot view: it writes no images")
    scene = load_scene(f"config/scenes/{name}.yaml")
    assert scene["effects"]["snapshots"] == ["demo"]
    view = registry.get(name).snapshot
    render_case(scene, "smoke", tmp_path / "off", SMOKE_CASES.get(name))
    assert not any("write_dump" in p.read_text() for p in (tmp_path / "off").glob("*.lmp"))
    assert json.loads((tmp_path / "off" / "params.json").read_text())["snapshots"] is None

    scene["effects"]["snapshots"] = ["smoke"]
    render_case(scene, "smoke", tmp_path / "on", SMOKE_CASES.get(name))
    for deck in sorted((tmp_path / "on").glob("*.lmp")):
        text = deck.read_text()
        lines = [ln for ln in text.splitlines() if ln.startswith("write_dump")]
        assert len(lines) == (1 if deck.stem in view.stages else 0), deck.name
        if lines:
            # the image is written before the restart, so a completed segment always has its image
            assert text.index("write_dump") < text.index("write_restart   ${restart_out}")
            assert "image ${snapshot_file}" in lines[0]
            assert ("v_snap_speed" in lines[0]) == (view.color == "speed")
    rec = json.loads((tmp_path / "on" / "params.json").read_text())
    assert rec["snapshots"] == {"color": view.color, "stages": list(view.stages)}


def test_a_rung_name_outside_the_list_is_refused(tmp_path):
    import yaml

    text = yaml.safe_load(open("config/scenes/chute.yaml"))
    text["effects"]["snapshots"] = ["demo", "fast"]
    path = tmp_path / "chute.yaml"
    path.write_text(yaml.safe_dump(text))
    with pytest.raises(ConfigError, match="snapshots"):
        load_scene(str(path))


def test_snapshot_view_takes_typed_values_only():
    with pytest.raises(ValueError, match="color"):
        SnapshotView(color="rainbow; shell rm -rf /")
    with pytest.raises(ValueError, match="finite"):
        SnapshotView(zoom=float("nan"))


@pytest.mark.parametrize("names, expected", [
    (["init", "flow_001", "flow_002", "average_001", "average_002"], ["init", "flow_002", "average_002"]),
    (["flow_001", "flow_002", "flow_003", "average_001"], ["flow_001", "flow_003", "average_001"]),
    (["init", "average_001", "average_002", "average_003"], ["init", "average_002", "average_003"]),
    (["init", "flow_001", "flow_002", "flow_003"], ["init", "flow_002", "flow_003"]),
    (["init", "flow_001"], ["init", "flow_001"]),
    (["init"], ["init"]),
    ([], []),
])
def test_pick_first_end_of_flow_and_last(names, expected):
    assert pick(names) == expected


def _case(tmp_path, names, restart_missing=()):
    case = tmp_path / "case"
    run = case / "run"
    run.mkdir(parents=True)
    (case / "params.json").write_text(json.dumps({"rung": "demo", "snapshots": {"color": "type", "stages": []}}))
    rows = []
    for i, name in enumerate(names):
        plt.imsave(run / f"snapshot_{name}.jpg", np.full((40, 60, 3), 30 * i % 255, dtype=np.uint8))
        if name not in restart_missing:
            (run / f"{name}.restart").write_text("")
        rows += [(10 * i, 0.5 * i, name), (10 * i + 5, 0.5 * i + 0.25, name)]
    with open(run / "thermo.csv", "w") as f:
        f.write("Step,Time,segment\n" + "".join(f"{a},{b},{c}\n" for a, b, c in rows))
    (run / "status.json").write_text(json.dumps({"status": "steady"}))
    return case


def test_images_of_completed_segments_in_run_order(tmp_path):
    case = _case(tmp_path, ["average_001", "init", "flow_010", "flow_002", "average_002"],
                 restart_missing=("average_002",))
    assert list(images(case / "run")) == ["init", "flow_002", "flow_010", "average_001"]
    assert segment_times(case / "run" / "thermo.csv")["flow_010"] == pytest.approx(1.25)


def test_compose_writes_the_picked_images(tmp_path):
    case = _case(tmp_path, ["init", "flow_001", "flow_002", "average_001"])
    out = tmp_path / "snapshots.png"
    assert compose(case, out, "a case") == ["init", "flow_002", "average_001"]
    assert plt.imread(out).shape[1] > 300


def test_compose_says_why_when_there_is_nothing(tmp_path):
    case = _case(tmp_path, [])
    with pytest.raises(SnapshotError, match="no snapshot"):
        compose(case, tmp_path / "x.png")
    (case / "params.json").write_text(json.dumps({"rung": "smoke", "snapshots": None}))
    with pytest.raises(SnapshotError, match="write no snapshots"):
        compose(case, tmp_path / "x.png")


def test_the_cost_study_writes_no_snapshots():
    from granflow.cost import base_scene

    scene = load_scene("config/scenes/chute.yaml")
    base = base_scene(scene, {"base_rung": "demo", "set": {}}, "cost.scenes.chute")
    assert base["effects"]["snapshots"] == []
    assert registry.get("chute").snapshots_at(base, "demo") is None
    assert registry.get("chute").snapshots_at(scene, "demo") is not None


def test_every_scene_names_the_unit_of_its_time():
    """Snapshot titles give t in the scene's own unit (seconds for the SI scenes), not 'simulation units'."""
    from granflow import registry

    units = {name: registry.get(name).time_unit for name in registry.scenes()}
    assert all(u and u != "simulation units" for u in units.values()), units
    assert units["heap"] == units["silo"] == "s"
