"""granflow.ladder and tools/ladder.py: each rung's scene is the ladder's with its knob turned, validated; planned
rungs priced."""
import importlib.util
import math
from pathlib import Path

import pandas as pd
import pytest
import yaml

from granflow import ladder as ladders
from granflow.config import ConfigError
from granflow.scene_files import load_scene

ROOT = Path(__file__).resolve().parents[2]
spec = importlib.util.spec_from_file_location("ladder_tool", ROOT / "tools" / "ladder.py")
ladder_tool = importlib.util.module_from_spec(spec)
spec.loader.exec_module(ladder_tool)


def test_each_rung_turns_one_knob_and_is_validated(tmp_path):
    ladder = ladder_tool.load_ladder(ROOT / "config" / "ladders" / "silo.yaml")
    base = load_scene(ROOT / ladder["scene_file"])
    for rung in ladder["rungs"]:
        campaign = ladder_tool.rung_campaign(ladder, rung, tmp_path)
        scene = campaign["scenes"]["silo"]["scene"]
        changed = {f"rungs.validation.{k}" for k in scene["rungs"]["validation"]
                   if scene["rungs"]["validation"][k] != base["rungs"]["validation"].get(k)}
        assert changed == set(rung.get("set") or {})          # exactly the rung's knob, nothing else
        assert {k: v for k, v in scene.items() if k != "rungs"} == {k: v for k, v in base.items() if k != "rungs"}
        assert list(campaign["scenes"]) == ["silo"]
        assert campaign["scenes"]["silo"]["sweep"] == {"R": [6.0, 12.0]}
        assert campaign["results_dir"] == str(tmp_path / "ladders" / "silo" / rung["name"])
    assert not any(tmp_path.iterdir())                        # in memory: nothing written


def test_a_knob_outside_the_schema_is_refused(tmp_path):
    ladder = ladder_tool.load_ladder(ROOT / "config" / "ladders" / "silo.yaml")
    bad = {"name": "bad", "knob": "a Young's modulus of zero", "set": {"rungs.validation.Y_factor": 0.0}}
    with pytest.raises(ConfigError, match="Y_factor"):
        ladder_tool.rung_campaign(ladder, bad, tmp_path)


def test_planned_rungs_are_priced_and_unrun_rungs_said_so(tmp_path):
    ladder = ladder_tool.load_ladder(ROOT / "config" / "ladders" / "silo.yaml")
    ladder["rungs"] = ladder["rungs"][1:2]           # no base: nothing falls back to the committed record
    df = ladder_tool.table(ladder, tmp_path)
    assert list(df["state"]) == ["not run", "planned (cost model, not run)"]
    paper = df[df["rung"] == "paper"].iloc[0]
    assert paper["cpu_hours"] > 100 and math.isfinite(paper["cpu_hours"])
    text = ladder_tool.markdown(df, ladder)
    assert "| paper |" in text and "planned" in text
    ladder_tool.figure(df, ladder, tmp_path / "ladder.png")
    assert (tmp_path / "ladder.png").stat().st_size > 5_000


def test_the_base_falls_back_to_the_committed_record():
    ladder = ladder_tool.load_ladder(ROOT / "config" / "ladders" / "channel.yaml")
    checks, cases = ladder_tool.committed_checks(ladder)
    assert checks and all(any(c.quantity.startswith(h) for h in ladder["headlines"]) for c in checks)
    assert any(c.quantity.startswith("u_max/u_slip") for c in checks)
    assert all("phi~0.61" in c.case for c in checks) and all("phi~0.61" in c["dir"] for c in cases)


def test_a_rung_may_change_one_sweep_value_and_a_refused_rung_is_one_line(tmp_path, capsys, monkeypatch):
    ladder = ladder_tool.load_ladder(ROOT / "config" / "ladders" / "heap.yaml")
    rung = next(r for r in ladder["rungs"] if r["name"] == "one_kn_mdot10")
    campaign = ladder_tool.rung_campaign(ladder, rung, tmp_path)
    assert campaign["scenes"]["heap"]["sweep"] == {"mixture": ["bi1-2"], "feed_rate": [0.01]}
    # 120 g/s through the validation rung's narrow feed: the scene refuses it, prepare says so and goes on
    ladder["rungs"] = [{"name": "narrow120", "knob": "120 g/s, feed as it is", "sweep": {"feed_rate": [0.12]}}]
    ladder["planned"] = []
    monkeypatch.setattr(ladder_tool, "load_ladder", lambda path: ladder)
    args = type("Args", (), {"ladder": ROOT / "config" / "ladders" / "heap.yaml", "results": tmp_path})
    assert ladder_tool.cmd_prepare(args) == 2
    out = capsys.readouterr().out
    assert "# narrow120: 120 g/s, feed as it is [refused]:" in out and "feed_rate = 0.12" in out
    assert "Traceback" not in out


def test_a_replicate_rung_sets_the_run_to_run_scatter_beside_each_rungs_shift():
    """Two samples of the base (another seed, nothing else) differ by Δ; each rung's shift from the base is
    said as a multiple of |Δ|; planned and unrun rungs are left out."""
    import pandas as pd

    ladder = {"scene": "toy", "rung": "validation", "rungs": [{"name": "base"}, {"name": "deep"},
                                                             {"name": "seed2", "replicate": True}]}
    nan = float("nan")
    df = pd.DataFrame([
        {"rung": "base", "knob": "b", "state": "run", "quantity": "ratio", "ours": 1.340, "stat": 0.003, "syst": nan},
        {"rung": "deep", "knob": "d", "state": "run", "quantity": "ratio", "ours": 1.356, "stat": 0.004, "syst": nan},
        {"rung": "seed2", "knob": "s", "state": "run", "quantity": "ratio", "ours": 1.348, "stat": 0.003, "syst": nan},
        {"rung": "paper", "knob": "p", "state": "planned (cost model, not run)", "quantity": nan, "ours": nan,
         "stat": nan, "syst": nan}]).assign(paper="1.37–1.40", verdict="differs", cpu_hours=1.0)
    text = ladder_tool.scatter_lines(df, ladder)
    assert "base and its replicate seed2 (another seed, nothing else) differ by Δ = +0.008" in text
    assert f"|Δ|/√2 = {0.008 / math.sqrt(2):.2g}" in text and "quoted stat error of 0.003" in text
    assert "deep +0.016 (2.0 × |Δ|)" in text and "paper" not in text
    assert ladder_tool.scatter_lines(df, dict(ladder, rungs=ladder["rungs"][:2])) == ""   # no replicate, no lines
    assert text in ladder_tool.markdown(df, ladder)


def test_a_series_reads_the_straight_line_through_its_rungs_at_the_papers_size():
    """Points on an exact line y = 1.37 − 0.1 x recover 1.37 at x = 0 (χ² 0) and its value at the paper's size;
    the verdict is the scene's (inside the paper's range: within it)."""
    import pandas as pd

    ladder = {"rungs": [{"name": n} for n in ("b5", "b10", "b20")],
              "series": [{"knob": "depth", "x": "1/B", "points": {"b5": 0.2, "b10": 0.1, "b20": 0.05},
                          "at": {"paper": 0.025, "infinite": 0.0}}]}
    df = pd.DataFrame([{"rung": r, "state": "run", "quantity": "ratio", "ours": 1.37 - 0.1 * x, "stat": 0.002,
                        "syst": 0.001, "paper_lo": 1.37, "paper_hi": 1.40} for r, x in
                       ladder["series"][0]["points"].items()])
    text = ladder_tool.series_lines(df, ladder)
    assert "through b5, b10, b20 (slope -0.1 ±" in text and "χ²/ν = 0.00)" in text
    assert "at infinite (1/B = 0) 1.3700 ±" in text and "within the paper's range" in text
    assert "at paper (1/B = 0.025) 1.3675 ±" in text
    assert ladder_tool.series_lines(df[df["rung"] != "b20"], ladder) == ""    # two rungs: no fit with a dof


def test_the_channel_series_points_are_its_rungs_depths(tmp_path):
    """The x of each rung in the channel ladder's series is 1/B of that rung's own scene file."""
    ladder = ladder_tool.load_ladder(ROOT / "config" / "ladders" / "channel.yaml")
    rungs = {r["name"]: r for r in ladder["rungs"]}
    (series,) = ladder["series"]
    for name, x in series["points"].items():
        scene = ladder_tool.rung_campaign(ladder, rungs[name], tmp_path)["scenes"]["channel"]["scene"]
        assert x == pytest.approx(1.0 / scene["rungs"]["validation"]["B"])


# ------------------------------------------------------------------ each rung's order from the paper's setup
LADDER_FILES = sorted((ROOT / "config" / "ladders").glob("*.yaml"))


def test_every_rung_declares_its_order_from_the_papers_setup_and_a_reseed_is_no_step():
    assert LADDER_FILES
    for path in LADDER_FILES:
        ladder = ladder_tool.load_ladder(path)
        rungs = ladder["rungs"] + ladder.get("planned", [])
        assert all(isinstance(r["from_paper"], (int, float)) and r["from_paper"] >= 0 for r in rungs), path
        assert [r["from_paper"] for r in rungs if r.get("rung") == "paper"] == [0], path   # the paper's setup is 0
        first = ladder["rungs"][0]["from_paper"]
        assert all(r["from_paper"] == first for r in rungs if r.get("replicate")), path
        assert ladder["from_paper_order"].strip()


def write_ladder(tmp_path, **change) -> Path:
    data = yaml.safe_load((ROOT / "config" / "ladders" / "channel.yaml").read_text())
    for name, order in change.items():
        rung = next(r for r in data["rungs"] if r["name"] == name)
        if order is None:
            del rung["from_paper"]
        else:
            rung["from_paper"] = order
    path = tmp_path / "channel.yaml"
    path.write_text(yaml.safe_dump(data, allow_unicode=True))
    return path


def test_a_rung_without_an_order_or_a_reseed_given_a_step_is_refused(tmp_path):
    with pytest.raises(ConfigError, match="rung 'B10': from_paper"):
        ladder_tool.load_ladder(write_ladder(tmp_path, B10=None))
    with pytest.raises(ConfigError, match="rung 'B10': from_paper"):
        ladder_tool.load_ladder(write_ladder(tmp_path, B10=-1))
    with pytest.raises(ConfigError, match="replicate rung 'seed2' has from_paper 1, its first rung 4"):
        ladder_tool.load_ladder(write_ladder(tmp_path, seed2=1))


def test_the_channels_order_follows_its_depth_toward_the_papers():
    """The channel's rungs along its series are ordered by |1/B − 1/B_paper| (the series' x against the paper's)."""
    ladder = ladder_tool.load_ladder(ROOT / "config" / "ladders" / "channel.yaml")
    (series,) = ladder["series"]
    paper_x = series["at"]["the paper's B = 40 d_p"]
    order = {r["name"]: r["from_paper"] for r in ladder["rungs"]}
    by_distance = sorted(series["points"], key=lambda name: abs(series["points"][name] - paper_x))
    assert [order[name] for name in by_distance] == sorted(order[name] for name in by_distance)
    assert len({order[name] for name in by_distance}) == len(by_distance)    # each step a step


def test_the_committed_ladders_carry_their_files_order():
    """validation/<scene>/ladder.csv has each rung's from_paper as its ladder file says, and ladder.md the order."""
    import pandas as pd

    for path in LADDER_FILES:
        ladder = ladder_tool.load_ladder(path)
        record = ROOT / "validation" / ladder["scene"]
        df = pd.read_csv(record / "ladder.csv")
        order = {r["name"]: r["from_paper"] for r in ladder["rungs"] + ladder.get("planned", []) + ladder.get("pools", [])
                 + ladder.get("contrasts", [])}
        assert list(df.columns[:3]) == ["rung", "knob", "from_paper"]
        assert set(df["rung"]) == set(order), path
        assert all(df["from_paper"] == df["rung"].map(order)), path
        assert ladder_tool.order_line(ladder) in (record / "ladder.md").read_text()


def test_order_carries_the_key_into_a_record_without_its_runs_and_changes_nothing_else(tmp_path):
    import pandas as pd

    ladder = ladder_tool.load_ladder(ROOT / "config" / "ladders" / "heap.yaml")
    for name in ("ladder.csv", "ladder.md"):
        (tmp_path / name).write_bytes((ROOT / "validation" / "heap" / name).read_bytes())
    before = pd.read_csv(tmp_path / "ladder.csv", dtype=str, keep_default_na=False)
    old = before.drop(columns="from_paper")
    old.to_csv(tmp_path / "ladder.csv", index=False)              # a record of before the key
    md = (tmp_path / "ladder.md").read_text()
    (tmp_path / "ladder.md").write_text(md.replace(ladder_tool.order_line(ladder), ""))
    args = type("Args", (), {"ladder": ROOT / "config" / "ladders" / "heap.yaml", "out": tmp_path})
    assert ladder_tool.cmd_order(args) == 0
    after = pd.read_csv(tmp_path / "ladder.csv", dtype=str, keep_default_na=False)
    assert after.equals(before) and (tmp_path / "ladder.md").read_text() == md
    assert ladder_tool.cmd_order(args) == 0                       # twice: the same files
    assert (tmp_path / "ladder.md").read_text() == md
    assert pd.read_csv(tmp_path / "ladder.csv", dtype=str, keep_default_na=False).equals(before)
    # the table the record writes has the column in the same place
    df = ladder_tool.with_from_paper(old.assign(ours=pd.to_numeric(old["ours"], errors="coerce")), ladder)
    assert list(df.columns[:3]) == ["rung", "knob", "from_paper"] and df["from_paper"].iloc[0] == 3


def test_committed_ladders_are_judged_by_todays_rules(root):
    """Every committed ladder row's verdict is what granflow.ladder.rejudge gives its numbers: a diagnostic of
    the scene carries none, and one run never reads 'differs'."""
    import pandas as pd

    from granflow.ladder import load_ladder, rejudge

    for path in sorted((root / "config" / "ladders").glob("*.yaml")):
        ladder = load_ladder(path)
        csv = root / "validation" / ladder["scene"] / "ladder.csv"
        if not csv.exists():
            continue
        df = pd.read_csv(csv)
        assert list(rejudge(df, ladder)["verdict"].fillna("")) == list(df["verdict"].fillna("")), ladder["scene"]
        run = df[df["state"].astype(str).str.startswith("run")]
        assert not run["verdict"].astype(str).str.startswith("differs").any(), ladder["scene"]


def test_a_rung_without_runs_may_keep_its_committed_rows(tmp_path):
    """``--keep-committed``: a rung whose runs are absent keeps its rows of the committed ladder.csv (same rung,
    same knob), said so in its state and judged by today's rules; a rung whose knob changed keeps nothing."""
    ladder = ladder_tool.load_ladder(ROOT / "config" / "ladders" / "channel.yaml")
    committed = pd.read_csv(ROOT / "validation" / "channel" / "ladder.csv")
    rung = next(r for r in ladder["rungs"] if r["name"] == "B10")
    kept = ladders.committed_rows(ladder, rung)
    row = committed[(committed["rung"] == "B10") & committed["quantity"].notna()].iloc[0]
    assert len(kept) == 1 and kept[0]["ours"] == row["ours"] and kept[0]["cpu_hours"] == row["cpu_hours"]
    assert kept[0]["state"].startswith("run (kept from the committed ladder.csv")
    assert ladders.committed_rows(ladder, dict(rung, knob="depth B 5 → 11 d_p")) == []
    ladder["rungs"], ladder["planned"], ladder["contrasts"], ladder["pools"] = [rung], [], [], []
    assert list(ladder_tool.table(ladder, tmp_path)["state"]) == ["not run"]          # off unless asked
    df = ladder_tool.table(ladder, tmp_path, keep_committed=True)
    assert list(df["rung"]) == ["B10"] and df["state"].iloc[0] == kept[0]["state"]
    assert "kept from the committed ladder.csv" in ladder_tool.markdown(df, ladder)


def test_rejudge_counts_the_papers_error_and_reads_an_open_range():
    """A row's verdict from its numbers alone matches the check's: the paper's own error enters the combined
    error, a range open on one side ("> 0") is a range, and a row of before the paper_error column is judged
    without one."""
    from granflow.ladder import rejudge
    from granflow.validation import Check

    alpha = Check("α", "25.69 ± 0.07", "Fig. 5", ours=27.43, error=0.041, paper_range=(25.69, 25.69), paper_error=0.07,
                  syst=0.055)
    sign = Check("c_s", "> 0", "Fig. 8", ours=0.19, error=0.054, paper_range=(0.0, math.inf), syst=0.042)
    rows = [{"rung": "r", "knob": "k", "state": "run", "quantity": c.quantity, "ours": c.ours, "stat": c.error,
             "syst": c.syst, "verdict": "", "paper_error": c.paper_error, "paper_lo": min(c.paper_range),
             "paper_hi": max(c.paper_range), "kind": "comparison"} for c in (alpha, sign)]
    ladder = {"scene": "heap"}
    got = rejudge(pd.DataFrame(rows), ladder)["verdict"].tolist()
    assert got == [alpha.verdict, sign.verdict]
    assert "18 σ" in got[0] and got[1] == "within the paper's range"
    old = rejudge(pd.DataFrame(rows).drop(columns="paper_error"), ladder)["verdict"].tolist()
    assert "25 σ" in old[0]                                    # without the paper's error: stat ⊕ syst only
