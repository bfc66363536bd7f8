"""Each scene's check kinds name checks its record has, with a kind the verdict knows."""
import pandas as pd
import pytest

from granflow import registry
from granflow.validation import Check, ValidationResult, with_kinds
from granflow.verdicts import KINDS


@pytest.mark.parametrize("name", registry.names())
def test_kinds_name_recorded_quantities(name, root):
    kinds = registry.get(name).check_kinds
    assert set(kinds.values()) <= set(KINDS) - {"comparison"}
    checks = root / "validation" / name / "checks.csv"
    if kinds:
        recorded = set(pd.read_csv(checks)["quantity"])
        assert set(kinds) <= recorded, set(kinds) - recorded


def test_with_kinds_takes_the_verdict_away():
    result = ValidationResult(checks=[Check("a", "3", "eq. 1", 2.93, 0.02, paper_range=(3.0, 3.0)),
                                      Check("b", "1", "§2", 1.5, 0.01, paper_range=(1.0, 1.0))])
    judged = with_kinds(result, {"a": "consistency"})
    assert judged.checks[0].kind == "consistency" and judged.checks[0].verdict.startswith("consistency: no verdict")
    assert judged.checks[1].kind == "comparison" and judged.checks[1].verdict.startswith("one sample: off by")


@pytest.mark.parametrize("name", [p.parent.name for p in sorted(__import__("pathlib").Path(__file__).resolve()
                                                                  .parents[2].glob("validation/*/summary.json"))])
def test_committed_record_judges_only_comparisons(name, root):
    import json

    summary = json.loads((root / "validation" / name / "summary.json").read_text())
    kinds = registry.get(name).check_kinds
    for c in summary["checks"]:
        assert c.get("kind") in KINDS, (c["quantity"], c.get("kind"))
        if c["quantity"] in kinds:
            assert c["kind"] == kinds[c["quantity"]], c["quantity"]
        if c["kind"] != "comparison":
            assert c["verdict"] == f"{c['kind']}: no verdict against the paper", c["quantity"]
        # a row not measured (NaN, stored as null: e.g. a regime bracket before the sweep has both regimes)
        # was measured by no replicate
        assert int(c.get("n_replicates") or 0) >= 1 or c["ours"] is None, c["quantity"]
    for case in summary["cases"]:
        assert case["seed"] in case["seeds"], case["dir"]


def test_rejudging_a_record_twice_changes_nothing(root, tmp_path):
    import json
    import shutil

    from granflow.rejudge import rejudge

    for name in ("heap", "silo"):
        shutil.copytree(root / "validation" / name, tmp_path / name)
        first = rejudge(tmp_path / name, name)
        second = rejudge(tmp_path / name, name)
        assert json.dumps(first["checks"], sort_keys=True) == json.dumps(second["checks"], sort_keys=True)
        assert (tmp_path / name / "checks.csv").read_text().splitlines()[0].endswith(
            "kind,run_to_run,n_replicates,verdict,difference")


def test_rejudging_keeps_the_rows_the_record_pooled_over_replicates(root, tmp_path):
    # the heap record's q* exponent across its feed rates pooled two seeds; profiles/ holds the first seed's
    # only, whose exponent differs: judged again, the row keeps both seeds' number and its run-to-run scatter
    import json
    import shutil

    from granflow import registry
    from granflow.rejudge import rejudge

    shutil.copytree(root / "validation" / "heap", tmp_path / "heap")
    before = {c["quantity"]: c for c in json.loads((tmp_path / "heap" / "summary.json").read_text())["checks"]}
    pooled = {q: c for q, c in before.items() if int(c.get("n_replicates") or 1) > 1}
    profiles = {p.stem: pd.read_csv(p) for p in sorted((tmp_path / "heap" / "profiles").glob("*.csv"))}
    first_seed = {c.quantity: c.ours for c in registry.get("heap").profile_checks(profiles)}
    moved = [q for q in pooled if q in first_seed and abs(first_seed[q] - pooled[q]["ours"]) > 1e-6]
    assert moved, "no pooled profile row that one seed's profiles read otherwise: the test tests nothing"
    after = {c["quantity"]: c for c in rejudge(tmp_path / "heap", "heap")["checks"]}
    for q in moved:
        assert after[q]["ours"] == pooled[q]["ours"] and after[q]["n_replicates"] == pooled[q]["n_replicates"]
        assert after[q]["run_to_run"] == pooled[q]["run_to_run"]
