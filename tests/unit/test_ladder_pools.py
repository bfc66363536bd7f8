"""A ladder's pools (granflow.ladder.pool_checks): rungs run apart read as one record, the scene's validation
over all their cases, for the rows only a sweep across them gives (the heap's q* exponent across feed rates)."""
from __future__ import annotations

import copy
import json
import math

import numpy as np
import pytest

import granflow.ladder as lad
from granflow.config import ConfigError
from granflow.validation import Check, ValidationResult
from granflow.schema import PROJECT_ROOT

HEAP = PROJECT_ROOT / "config" / "ladders" / "heap.yaml"
QUANTITY = "δ/d̄ ∝ q*^a across feed rates at fixed x/L ≥ 0.2: exponent a"


@pytest.fixture
def ladder():
    """The heap's ladder: its three feed-rate rungs at W = 0.23 m are rungs (none planned)."""
    data = copy.deepcopy(lad.load_ladder(HEAP))
    names = [r["name"] for r in data["rungs"]]
    assert {"W023", "mdot10_W023", "mdot120_W023"} <= set(names)
    assert not [r for r in data.get("planned", []) if r["name"] in names]
    return data


@pytest.fixture
def seen(monkeypatch):
    """The scene's validation replaced by one that reports the cases it was given, as one sweep-wide row."""
    calls = []

    def validation(scene, base, cases):
        calls.append(sorted(cases))
        rates = sorted(float(c.split("mdot~")[1]) for c in cases)
        kind = "comparison" if len(rates) >= 3 else "diagnostic"
        return ValidationResult(checks=[Check(QUANTITY, "≈ 0.22", "§3.3", 0.2 + 0.01 * len(rates), 0.01,
                                              paper_range=(0.215, 0.225), kind=kind),
                                        Check("dynamic angle of repose α (planar middle)", "25.69", "§3.1", 26.0,
                                              0.1, case=cases and sorted(cases)[0], paper_range=(25.69, 25.69))])

    monkeypatch.setattr(lad, "scene_validation", validation)
    monkeypatch.setattr(lad, "case_summary", lambda p: {"dir": str(p), "cpu_hours": 1.5, "particles": 1000,
                                                        "status": "steady", "case": {}})
    return calls


def analysed(results, ladder, rung_name, case):
    rung = next(r for r in ladder["rungs"] if r["name"] == rung_name)
    path = lad.rung_cases_root(results, ladder, rung) / case / "analysis"
    path.mkdir(parents=True)
    (path / "scalars.json").write_text(json.dumps({}))


def pool_of(ladder):
    return next(p for p in ladder["pools"] if p["name"] == "W023_rates")


def test_a_pool_reads_every_case_of_its_rungs_as_one_record(tmp_path, ladder, seen):
    for rung, rate in (("W023", 33), ("mdot10_W023", 10), ("mdot120_W023", 120)):
        analysed(tmp_path, ladder, rung, f"mix~bi1-2/mdot~{rate}")
    checks, cases, waits = lad.pool_checks(ladder, pool_of(ladder), tmp_path)
    assert waits == "" and len(cases) == 3
    assert seen[-1] == ["mix~bi1-2/mdot~10", "mix~bi1-2/mdot~120", "mix~bi1-2/mdot~33"]
    assert [c.quantity for c in checks] == [QUANTITY]            # the pool's own headlines only
    df = lad.table(ladder, tmp_path)
    row = df[df["rung"] == "W023_rates"].iloc[0]
    assert row["state"] == "run (pooled: W023 + mdot10_W023 + mdot120_W023)"
    assert row["kind"] == "comparison" and row["cases"] == 3
    assert math.isclose(row["cpu_hours"], 4.5)                    # the rungs' CPU-hours together
    assert row["from_paper"] == pool_of(ladder)["from_paper"]
    assert row["verdict"].startswith("within")
    assert list(lad.rejudge(df, ladder)["verdict"]) == list(df["verdict"])


def test_rejudge_keeps_a_rows_own_kind(tmp_path, ladder, seen):
    # two of the three rates: the validation calls its q* row a diagnostic; the ladder.csv row says so and its
    # verdict, judged again from the file, stays none
    # the pool alone: another pool of W023 with a rung's kept profiles would read these synthetic cases' params
    ladder["pools"] = [dict(pool_of(ladder), rungs=["W023", "mdot120_W023"])]
    analysed(tmp_path, ladder, "W023", "mix~bi1-2/mdot~33")
    analysed(tmp_path, ladder, "mdot120_W023", "mix~bi1-2/mdot~120")
    df = lad.table(ladder, tmp_path)
    row = df[df["rung"] == "W023_rates"].iloc[0]
    assert row["kind"] == "diagnostic" and row["verdict"].startswith("diagnostic")
    again = lad.rejudge(df, ladder)
    assert again.loc[row.name, "verdict"] == row["verdict"]
    assert list(again["verdict"]) == list(df["verdict"])


def test_a_pool_waits_for_a_rung_without_its_cases(tmp_path, ladder, seen):
    analysed(tmp_path, ladder, "W023", "mix~bi1-2/mdot~33")
    analysed(tmp_path, ladder, "mdot120_W023", "mix~bi1-2/mdot~120")
    # root: a record that kept no rung's profiles
    checks, _, waits = lad.pool_checks(ladder, pool_of(ladder), tmp_path, root=tmp_path)
    assert checks == [] and waits == "waits for mdot10_W023"
    row = lad.table(ladder, tmp_path, root=tmp_path).set_index("rung").loc["W023_rates"]
    assert row["state"] == "not run (waits for mdot10_W023)"
    # the shipped ladder without that rung's runs or kept profiles: its pool waits for it too
    shipped = lad.load_ladder(HEAP)
    assert lad.pool_checks(shipped, pool_of(shipped), tmp_path, root=tmp_path)[2] == "waits for mdot10_W023"


def test_rungs_sharing_a_case_cannot_be_pooled(tmp_path, ladder, seen):
    for rung in ("W023", "mdot10_W023", "mdot120_W023"):
        analysed(tmp_path, ladder, rung, "mix~bi1-2/mdot~33")
    with pytest.raises(ConfigError, match="is in two of its rungs"):
        lad.pool_checks(ladder, pool_of(ladder), tmp_path)


@pytest.mark.parametrize("rungs", [["W023"], ["W023", "nowhere"], "W023", ["W023", "W023"]])
def test_a_pool_of_fewer_than_two_known_rungs_is_refused(tmp_path, rungs):
    text = HEAP.read_text().replace("    rungs: [W023, mdot10_W023, mdot120_W023]", f"    rungs: {json.dumps(rungs)}")
    assert text != HEAP.read_text()
    path = tmp_path / "heap.yaml"
    path.write_text(text)
    with pytest.raises(ConfigError, match="pool 'W023_rates': rungs = "):
        lad.load_ladder(path)


# -- a pool with the committed record: its profiles beside the rungs' (granflow.ladder_record_pool) -----------
import pandas as pd  # noqa: E402

import granflow.ladder_record_pool as rp  # noqa: E402


def _bins(rate: float, a: float = 0.22, n: int = 25) -> pd.DataFrame:
    """A case's streamwise bins: δ/d̄ = e^{-0.8 x/L} q*^a, q* falling along the heap (n bins over L)."""
    x = (np.arange(n) + 0.5) / n
    q = rate * (1.0 - x) * 0.15
    return pd.DataFrame({"case": f"mix~bi1-2/mdot~{rate:g}", "x_over_L": np.round(x, 4), "q_star": q,
                         "d_bar": 1.2e-3, "delta": 1.2e-3 * np.exp(-0.8 * x) * q ** a, "usable": True})


@pytest.fixture
def record_root(tmp_path, monkeypatch):
    """A committed heap record of two feed rates and two seeds (profiles: the first seed's), and a scene
    validation that gives each rung case's streamwise bins as its profile (two rates, the second's flowing layer
    shorter: 19 bins)."""
    root = tmp_path / "repo"
    (root / "validation" / "heap" / "profiles").mkdir(parents=True)
    pd.concat([_bins(20), _bins(33)]).to_csv(root / "validation" / "heap" / "profiles" / "streamwise.csv", index=False)
    cases = [{"dir": f"mix~bi1-2/mdot~{r}/seed~{s}", "seed": s, "seeds": [1, 2], "cpu_hours": 1.0, "case": {}}
             for r in (20, 33) for s in (1, 2)]
    (root / "validation" / "heap" / "summary.json").write_text(json.dumps({"cases": cases}))

    def validation(scene, base, cases):
        rates = sorted(float(c.split("mdot~")[1]) for c in cases)
        return ValidationResult(checks=[], profiles={"streamwise": pd.concat(
            [_bins(r, n=25 if r < 100 else 19) for r in rates])})

    monkeypatch.setattr(rp, "scene_validation", validation)
    monkeypatch.setattr(rp, "case_summary", lambda p: {"dir": str(p), "cpu_hours": 1.5, "case": {}})
    return root


def test_a_pool_with_the_record_reads_its_profiles_beside_the_rungs(tmp_path, record_root):
    cases = {"mix~bi1-2/mdot~10": tmp_path / "a", "mix~bi1-2/mdot~120": tmp_path / "b"}
    checks, summaries, waits = rp.record_pool_checks("heap", tmp_path, cases, ["δ/d̄ ∝ q*^a across feed rates"],
                                                     root=record_root)
    assert waits == "" and [c.quantity for c in checks] == [QUANTITY]
    (check,) = checks
    # four rates 10-120 g/s, the 120's bins elsewhere in x/L: read at common x/L, the exponent is recovered
    assert check.kind == "comparison" and "10, 20, 33, 120 g/s" in check.note
    assert check.ours == pytest.approx(0.22, abs=2e-3) and "different x/L" in check.note
    assert math.isfinite(check.syst) and check.syst < 2e-3
    # the record's first seed only (the profiles' replicate), then the rungs' cases
    assert [s["cpu_hours"] for s in summaries] == [1.0, 1.0, 1.5, 1.5]
    assert [s["dir"] for s in summaries[:2]] == ["mix~bi1-2/mdot~20/seed~1", "mix~bi1-2/mdot~33/seed~1"]


def test_a_pool_with_the_record_refuses_a_case_the_record_has(tmp_path, record_root):
    with pytest.raises(ConfigError, match="mdot~33 are in the record and in the rungs at hand"):
        rp.record_pool_checks("heap", tmp_path, {"mix~bi1-2/mdot~33": tmp_path}, [QUANTITY], root=record_root)


def test_a_pool_with_the_record_waits_for_its_profiles(tmp_path):
    assert rp.record_pool_checks("heap", tmp_path, {}, [QUANTITY], root=tmp_path)[2].startswith(
        "waits for the record's profiles")


def test_the_shipped_record_pool_waits_for_its_rungs(tmp_path):
    shipped = lad.load_ladder(HEAP)
    pool = next(p for p in shipped["pools"] if p["name"] == "record_rates")
    assert pool["rungs"][0] == "record"
    assert lad.pool_checks(shipped, pool, tmp_path, root=tmp_path)[2] == "waits for mdot10"


def _kept(record_root, monkeypatch, rung: str, rate: float, seed_note: str = "") -> Path:
    """Keep a rung of one feed rate in the record at ``record_root`` as recording the ladder does."""
    monkeypatch.setattr(rp, "scene_validation", lambda scene, base, cases: ValidationResult(
        checks=[], profiles={"streamwise": _bins(rate), "empty": pd.DataFrame({"case": []})}))
    monkeypatch.setattr(rp, "case_summary", lambda p: {"cpu_hours": 2.0, "note": seed_note, "wall_hours": math.nan})
    return rp.keep_pooled("heap", rung, record_root, {f"mix~bi1-2/mdot~{rate:g}": record_root},
                          record_root / "validation" / "heap")


def test_a_pooled_rungs_profiles_are_kept_whole_and_read_back(record_root, monkeypatch):
    where = _kept(record_root, monkeypatch, "mdot10_W023", 10)
    assert where == record_root / "validation" / "heap" / rp.POOLED / "mdot10_W023"
    first = {p.name: p.read_bytes() for p in where.iterdir()}
    assert set(first) == {"streamwise.csv.gz", "empty.csv.gz", "cases.json"}
    profiles, cases = rp.kept_pooled("heap", "mdot10_W023", record_root)
    assert np.allclose(profiles["streamwise"]["delta"], _bins(10)["delta"], rtol=1e-5)   # 6 digits, as the record's
    assert cases == [{"dir": "mix~bi1-2/mdot~10", "cpu_hours": 2.0, "note": "", "wall_hours": None}]
    # kept again: the same bytes (no time stamp in the gzip); a new keep replaces the directory whole
    assert {p.name: p.read_bytes() for p in _kept(record_root, monkeypatch, "mdot10_W023", 10).iterdir()} == first
    _kept(record_root, monkeypatch, "mdot10_W023", 12, seed_note="again")
    assert rp.kept_pooled("heap", "mdot10_W023", record_root)[1][0]["note"] == "again"
    assert sorted(p.name for p in where.parent.iterdir()) == ["mdot10_W023"]      # no partial or old copy left
    assert rp.kept_pooled("heap", "nowhere", record_root) is None


def test_a_pool_reads_a_rung_without_its_runs_from_its_kept_profiles(tmp_path, ladder, record_root, monkeypatch):
    _kept(record_root, monkeypatch, "mdot10_W023", 10)
    monkeypatch.setattr(rp, "scene_validation", lambda scene, base, cases: ValidationResult(checks=[], profiles={
        "streamwise": pd.concat([_bins(float(c.split("mdot~")[1])) for c in sorted(cases)])}))
    monkeypatch.setattr(rp, "case_summary", lambda p: {"dir": str(p), "cpu_hours": 1.5})
    analysed(tmp_path, ladder, "W023", "mix~bi1-2/mdot~33")
    analysed(tmp_path, ladder, "mdot120_W023", "mix~bi1-2/mdot~120")
    checks, cases, waits = lad.pool_checks(ladder, pool_of(ladder), tmp_path, root=record_root)
    assert waits == "" and len(checks) == len(pool_of(ladder)["headlines"])
    # three rates 10-120 g/s, the 10 g/s from the committed profiles: the exponent is recovered
    (qstar,) = [c for c in checks if c.quantity == QUANTITY]
    assert "10, 33, 120 g/s" in qstar.note and qstar.ours == pytest.approx(0.22, abs=2e-3)
    assert sorted(c["cpu_hours"] for c in cases) == [1.5, 1.5, 2.0]
    # the kept rung and a rung at hand with the same sweep point: refused, naming both
    analysed(tmp_path, ladder, "mdot10_W023", "mix~bi1-2/mdot~10")
    ladder["pools"][0]["rungs"] = ["W023", "mdot10_W023", "mdot120_W023"]
    monkeypatch.setattr(lad, "kept_pooled", lambda scene, rung, root: rp.kept_pooled(scene, "mdot10_W023", root)
                        if rung == "mdot120_W023" else None)
    (lad.rung_cases_root(tmp_path, ladder, ladder["rungs"][[r["name"] for r in ladder["rungs"]].index(
        "mdot120_W023")]) / "mix~bi1-2/mdot~120/analysis/scalars.json").unlink()
    with pytest.raises(ConfigError, match="mdot~10 are in mdot120_W023's kept profiles and in the rungs at hand"):
        lad.pool_checks(ladder, pool_of(ladder), tmp_path, root=record_root)


def test_a_record_written_again_keeps_the_pooled_profiles(record_root, monkeypatch):
    from granflow import validation

    where = _kept(record_root, monkeypatch, "mdot10", 10)
    assert "pooled" in validation.KEPT_FILES
    out = record_root / "validation" / "heap"
    kept = {p.relative_to(out) for p in where.rglob("*")}
    # write_record's own keep step: everything else under out is replaced
    monkeypatch.setattr(validation.provenance, "git_state", lambda: {"commit": "abc", "dirty_files": [], "dirty": False})
    validation.write_record("heap", "validation", ValidationResult(checks=[]), {}, record_root, out)
    assert not (out / "profiles" / "streamwise.csv").exists()        # the record's own files: replaced
    assert {p.relative_to(out) for p in (out / "pooled").rglob("*") if p.is_file()} == kept


def test_the_shipped_record_pool_reads_its_rung_from_the_kept_profiles_as_recorded(tmp_path):
    # no runs at hand: the record's profiles and mdot10's kept ones give the pool's rows, the numbers its
    # ladder.csv rows were recorded with from the runs (the kept tables hold 6 digits)
    shipped = lad.load_ladder(HEAP)
    pool = next(p for p in shipped["pools"] if p["name"] == "record_rates")
    checks, cases, waits = lad.pool_checks(shipped, pool, tmp_path)
    assert waits == "" and len(checks) == len(pool["headlines"])
    rows = pd.read_csv(PROJECT_ROOT / "validation" / "heap" / "ladder.csv").query("rung == 'record_rates'")
    recorded = dict(zip(rows["quantity"], rows["ours"]))
    assert {c.quantity: c.ours for c in checks} == pytest.approx(recorded, rel=1e-4)
    assert sum(c["cpu_hours"] for c in cases) == pytest.approx(rows["cpu_hours"].iloc[0], rel=1e-6)
