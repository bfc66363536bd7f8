"""The cost study's runs and points: knobs applied to the base scene, refusals before anything runs, cost bookkeeping."""
import copy

import numpy as np
import pytest

from granflow import registry
from granflow.campaign import validate_campaign
from granflow.config import ConfigError, load_yaml
from granflow.cost import CostStudy, apply_knob, post_record, prefix_segments, segment_costs
from granflow.headline import block_errors


@pytest.fixture(scope="module")
def campaign(root):
    return load_yaml(root / "config" / "config.yaml")


def study(campaign, scene_fixture, name, **changes):
    entry = copy.deepcopy(campaign["cost"]["scenes"][name])
    entry.update(changes)
    return CostStudy(name, scene_fixture, entry)


@pytest.fixture(scope="module")
def studies(campaign, root):
    """The default campaign's cost studies, validated."""
    return validate_campaign(campaign, root)["cost_studies"]


@pytest.mark.parametrize("name", registry.names())
def test_each_study_of_the_default_campaign_shares_its_base(name, studies):
    """Per registered scene: a scene without a cost study, or whose study the default campaign does
    not hold, is skipped, saying so (nothing forces a scene into the default campaign)."""
    if not registry.get(name).gives("cost_study"):
        pytest.skip(f"the {name} scene declares no cost study (knobs, headline and observables())")
    if name not in studies:
        pytest.skip(f"the default campaign holds no cost study of the {name} scene")
    cs = studies[name]
    # every knob's values contain the base's, so the base point is shared and not rerun
    assert cs.points()[0] == "base" and len(cs.points()) == 1 + sum(len(v) - 1 for v in cs.knobs.values())
    # post-processing knobs reuse the base run; simulation knobs get one run per value
    sims = sum(len(v) - 1 for k, v in cs.knobs.items() if k not in ("t_average", "bin_width"))
    assert len(cs.runs()) == 1 + sims
    for point in cs.points():
        assert cs.point(point)["run"] in cs.runs()


def test_the_default_campaign_studies_only_scenes_that_declare_a_study(studies):
    assert studies and all(registry.get(name).gives("cost_study") for name in studies)


def test_base_run_averages_for_the_longest_time(campaign, channel_scene):
    cs = study(campaign, channel_scene, "channel")
    rung = cs.base["rungs"]["smoke"]
    assert rung["W"] == 12.0 and rung["t_average"] == 40.0            # from `set`
    assert cs.scenes["base"]["rungs"]["smoke"]["t_average"] == 80.0   # longest of the knob list
    assert cs.point("base")["t_average"] == 40.0                      # but the base point uses the first 40
    assert cs.point("t_average~20")["t_average"] == 20.0 and cs.point("t_average~20")["run"] == "base"


def test_size_knob_scales_the_extents(campaign, channel_scene, heap_scene, silo_scene):
    ch = study(campaign, channel_scene, "channel")
    big = ch.scenes["size~1.5"]["rungs"]["smoke"]
    assert (big["W"], big["B"], big["H"]) == pytest.approx((18.0, 6.0, 15.0))
    hp = study(campaign, heap_scene, "heap")
    v = hp.scenes["size~1.5"]
    assert v["rungs"]["smoke"]["W"] == pytest.approx(0.09) and v["case"]["feed_rate"] == pytest.approx(0.0075)
    assert v["rungs"]["smoke"]["T"] == pytest.approx(1.5 * heap_scene["rungs"]["smoke"]["T"])
    sl = study(campaign, silo_scene, "silo")
    assert sl.scenes["size~0.75"]["rungs"]["smoke"]["R_c"] == pytest.approx(7.5)
    # only the one knob changes
    other = apply_knob("silo", sl.base, "smoke", "dt_fraction", 0.01)
    assert other["rungs"]["smoke"]["dt_fraction"] == 0.01 and other["rungs"]["smoke"]["R_c"] == 10.0


def test_post_knobs_change_only_the_analysis(campaign, silo_scene):
    sl = study(campaign, silo_scene, "silo")
    p = sl.point("bin_width~3")
    assert p["run"] == "base" and p["post"] == {"cg.w_fields": 3.0}
    record = {"cg": {"w_fields": 2.0}, "rung_knobs": {"bin_width": 1.0}}
    assert post_record(record, p["post"])["cg"]["w_fields"] == 3.0
    assert post_record(record, {"rungs.smoke.bin_width": 0.5})["rung_knobs"]["bin_width"] == 0.5
    assert record["cg"]["w_fields"] == 2.0  # the run's record is untouched


def test_knob_list_without_the_base_value_is_refused(campaign, channel_scene):
    knobs = dict(campaign["cost"]["scenes"]["channel"]["knobs"], dt_fraction=[0.1, 0.02])
    with pytest.raises(ConfigError, match=r"knobs\.dt_fraction = \[0\.1, 0\.02\].*base case's value 0\.05"):
        study(campaign, channel_scene, "channel", knobs=knobs)


def test_unknown_set_key_is_refused(campaign, channel_scene):
    with pytest.raises(ConfigError, match=r"set\.rungs\.smoke\.Wx = 3.*not a key"):
        study(campaign, channel_scene, "channel", set={"rungs.smoke.Wx": 3})


def test_variant_outside_the_scene_range_is_refused(campaign, root):
    data = copy.deepcopy(campaign)
    data["cost"]["scenes"]["channel"]["knobs"]["dt_fraction"] = [0.5, 0.05]
    with pytest.raises(ConfigError, match=r"dt_fraction"):
        validate_campaign(data, root)


def test_free_text_in_set_is_refused(campaign, root):
    data = copy.deepcopy(campaign)
    data["cost"]["scenes"]["channel"]["set"]["rungs.smoke.W"] = "12; shell rm -rf /"
    with pytest.raises(ConfigError, match=r"cost\.scenes\.channel\.set\.rungs\.smoke\.W"):
        validate_campaign(data, root)


def _log(path, runs):
    path.write_text("".join(f"Loop time of {s} on 1 procs for {n} steps with {a} atoms\n" for s, n, a in runs))


def test_segment_costs_and_prefix(tmp_path):
    logs = tmp_path / "logs"
    logs.mkdir()
    _log(logs / "init.log", [(1.0, 100, 10)])
    _log(logs / "flow_001.log", [(2.0, 200, 10), (0.5, 10, 10)])
    for k in (1, 2, 3):
        _log(logs / f"average_{k:03d}.log", [(3.0, 300, 20)])
    (logs / "init.usage.json").write_text('{"cpu_s": 1.25, "wall_s": 1.3, "peak_rss_mb": 80.0, "nprocs": 1}')
    segs = segment_costs(tmp_path)
    assert [s["segment"] for s in segs] == ["init", "flow_001", "average_001", "average_002", "average_003"]
    assert segs[0]["cpu_s"] == 1.25 and segs[0]["peak_rss_mb"] == 80.0 and np.isnan(segs[1]["cpu_s"])
    assert segs[1]["loop_s"] == 2.5 and segs[1]["steps"] == 210 and segs[1]["atom_steps"] == 2100
    used = prefix_segments(segs, t_average=1.5, t_segment=1.0)   # needs two averaging segments
    assert [s["segment"] for s in used] == ["init", "flow_001", "average_001", "average_002"]
    assert sum(s["loop_s"] for s in used) == pytest.approx(9.5)


def test_block_errors_are_the_standard_error_of_the_block_values():
    blocks = [{"a": 1.0, "b": np.nan}, {"a": 2.0, "b": 5.0}, {"a": 3.0, "b": 7.0}, {"a": 4.0, "b": np.nan}]
    out = block_errors(blocks, ["a", "b"])
    assert out["a"]["se"] == pytest.approx(np.std([1, 2, 3, 4], ddof=1) / 2) and out["a"]["n_blocks"] == 4
    assert out["b"]["se"] == pytest.approx(np.std([5, 7], ddof=1) / np.sqrt(2)) and out["b"]["n_blocks"] == 2
    # every scene with a cost study names its headline observables, each once and labelled
    for scene in (s for s in registry.scenes().values() if s.gives("cost_study")):
        keys = [key for key, _ in scene.headline]
        assert len(keys) == len(set(keys)) and all(label for _, label in scene.headline), scene.name
