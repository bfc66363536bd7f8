"""Replicates: a campaign that lists seeds runs every case once per seed, one directory level deeper."""
import pytest

from granflow import registry
from granflow.campaign import load_campaign
from granflow.cli import main


@pytest.mark.parametrize("name", registry.names())
def test_seed_level_round_trips(name, root):
    scene = registry.get(name)
    cfg = load_campaign(root / "config" / "config.yaml", root=root)
    sc = cfg["scenes"][name]["scene"]
    plain = scene.sweep_points(sc, {}, "smoke")
    reps = scene.sweep_points(sc, {"seed": [11, 900000000]}, "smoke")
    assert len(reps) == 2 * len(plain)
    dirs = [scene.case_dir(p) for p in reps]
    assert len(set(dirs)) == len(dirs)
    for point, rel in zip(reps, dirs):
        assert rel.endswith(f"/seed~{point['seed']}")  # written in full: 9e+08 would lose digits
        assert scene.case_from_dir(rel) == point
    # no seeds listed: no replicate level, the directories of before
    assert all("seed~" not in scene.case_dir(p) for p in plain)


def test_seed_listed_twice_refused(capsys, root):
    assert main(["check-config", str(root / "config" / "config.yaml"), "--set",
                 "scenes.chute.sweep.seed=[5,5]"]) == 2
    err = capsys.readouterr().err
    assert "scenes.chute.sweep.seed" in err and "non-unique" in err


def test_seed_out_of_range_refused(capsys, root):
    assert main(["check-config", str(root / "config" / "config.yaml"), "--set",
                 "scenes.chute.sweep.seed=[0]"]) == 2
    err = capsys.readouterr().err
    assert "scenes.chute.sweep.seed[0]" in err and "1 <= value" in err
