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


# -- judging replicates -----------------------------------------------------------------------
import math  # noqa: E402
from pathlib import Path  # noqa: E402

from granflow import replicates  # noqa: E402
from granflow.validation import Check, ValidationResult, scene_validation  # noqa: E402


def test_split_hands_each_seed_the_case_names_of_before(tmp_path):
    cases = {f"theta~{t}/seed~{s}": tmp_path / f"{t}_{s}" for t in (22, 25) for s in (7, 11)}
    groups = replicates.split(cases)
    assert list(groups) == [7, 11]
    assert groups[7] == {"theta~22": tmp_path / "22_7", "theta~25": tmp_path / "25_7"}
    assert replicates.split({"theta~22": tmp_path}) == {None: {"theta~22": tmp_path}}
    with pytest.raises(ValueError, match="seed 11 lacks the replicate of theta~25"):
        replicates.split({"theta~22/seed~7": tmp_path, "theta~25/seed~7": tmp_path, "theta~22/seed~11": tmp_path})


def _result(ratio, error, syst=0.001, kind="comparison"):
    return ValidationResult(checks=[
        Check("ratio", "1", "§2", ratio, error, case="theta~25", paper_range=(1.0, 1.0), syst=syst),
        Check("forced", "3", "eq. 1", 3.0 + ratio, 0.01, case="theta~25", paper_range=(3.0, 3.0), kind="consistency"),
    ], differences=["first"])


def test_pool_mean_stat_and_run_to_run_known_answer():
    # three seeds of the chute's 25 degree case: 0.988, 0.977, 0.996 (stat 0.005 each)
    values = [0.988, 0.977, 0.996]
    pooled = replicates.pool([_result(v, 0.005) for v in values], [1, 2, 3])
    ratio = pooled.checks[0]
    assert ratio.ours == pytest.approx(sum(values) / 3)
    assert ratio.error == pytest.approx(math.sqrt(3 * 0.005 ** 2) / 3)
    sd = math.sqrt(sum((v - sum(values) / 3) ** 2 for v in values) / 2)
    assert ratio.run_to_run == pytest.approx(sd / math.sqrt(3))
    assert ratio.n_replicates == 3 and ratio.syst == pytest.approx(0.001)
    # 0.013 off; stat 0.0029, syst 0.001, run-to-run 0.0055: combined 0.0063, 2.1 sigma
    assert ratio.note.startswith("Replicates (3 of 3 seeds measured it): seed 1: 0.988 ± 0.005; seed 2: 0.977")
    assert ratio.verdict == "differs by -1.3 % (2 σ with stat, syst and run-to-run)"
    # the kind survives pooling: a consistency row stays without a verdict
    assert pooled.checks[1].kind == "consistency" and "no verdict" in pooled.checks[1].verdict
    assert pooled.differences == ["first"]


def test_pool_two_replicates_may_differ_one_may_not():
    one = replicates.pool([_result(0.95, 0.002)], [1])
    assert one.checks[0].verdict.startswith("one sample: off by -5.0 %")
    two = replicates.pool([_result(0.95, 0.002), _result(0.951, 0.002)], [1, 2])
    assert two.checks[0].verdict.startswith("differs by -5.0 %") and two.checks[0].n_replicates == 2
    # a replicate that could not measure it: pooled over the one that did, and it says so
    half = replicates.pool([_result(0.95, 0.002), _result(float("nan"), 0.002)], [1, 2])
    assert half.checks[0].n_replicates == 1 and half.checks[0].ours == pytest.approx(0.95)
    assert math.isnan(half.checks[0].run_to_run) and "1 of 2 seeds" in half.checks[0].note
    # a check only the second replicate made is kept, as one sample
    extra = _result(0.95, 0.002)
    extra.checks.append(Check("late", "1", "§3", 1.0, 0.01, case="theta~25", paper_range=(1.0, 1.0)))
    both = replicates.pool([_result(0.95, 0.002), extra], [1, 2])
    (late,) = [c for c in both.checks if c.quantity == "late"]
    assert late.n_replicates == 1 and late.ours == 1.0


class _Toy:
    def __init__(self):
        self.calls = []

    def gives(self, what):
        return True

    def validation(self, scene_dir, cases):
        self.calls.append(sorted(cases))
        seed = int(Path(next(iter(cases.values()))).name)
        return _result(1.0 + 0.01 * seed, 0.002)


def test_scene_validation_judges_each_seed_then_pools(tmp_path):
    toy = _Toy()
    cases = {f"theta~25/seed~{s}": tmp_path / str(s) for s in (1, 3)}
    result = scene_validation(toy, tmp_path, cases)
    assert toy.calls == [["theta~25"], ["theta~25"]]      # the scene sees the names of before
    assert result.checks[0].ours == pytest.approx(1.02) and result.checks[0].n_replicates == 2
