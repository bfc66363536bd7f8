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
