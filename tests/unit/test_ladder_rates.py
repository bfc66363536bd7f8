"""granflow.ladder_rates: a rung not run is priced at the rate the ladder's own measured rungs ran at."""
import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from granflow import ladder as ladders
from granflow.ladder_rates import (_measured_rows, calibration, cost_columns, leave_one_out, measured_rates,
                                   planned_state, price_lines)

ROOT = Path(__file__).resolve().parents[2]


def rung_row(name, n_mean, rate, steps=1e5, style="granular", state="run"):
    """One ladder.csv row of a rung whose cases ran ``steps`` with ``n_mean`` particles at ``rate``."""
    ast = n_mean * steps
    return {"rung": name, "state": state, "quantity": "q", "atom_steps": ast, "steps": steps,
            "pair_style": style, "cpu_hours": ast / rate / 3600}


def test_a_rate_that_falls_as_a_power_of_the_particle_count_is_recovered():
    rows = [rung_row(f"r{i}", n, 2e6 * (n / 1e4) ** -0.2) for i, n in enumerate((1e4, 3e4, 9e4))]
    rate = measured_rates(pd.DataFrame(rows))["granular"]
    assert rate.b == pytest.approx(-0.2, abs=1e-9)
    assert rate.at(2.7e5) == pytest.approx(2e6 * 27 ** -0.2, rel=1e-9)     # read beyond them along the line
    assert rate.rungs == ("r0", "r1", "r2")


def test_each_rung_left_out_is_priced_by_the_others():
    exact = [rung_row(f"r{i}", n, 2e6 * (n / 1e4) ** -0.2) for i, n in enumerate((1e4, 2e4, 4e4, 8e4))]
    assert measured_rates(pd.DataFrame(exact))["granular"].error == pytest.approx(0.0, abs=1e-9)
    off = exact[:3] + [rung_row("slow", 8e4, 0.5 * 2e6 * 8 ** -0.2)]            # took twice its line's time
    priced = dict((rung, p / t) for rung, p, t in leave_one_out("granular", _measured_rows(pd.DataFrame(off))))
    assert priced["slow"] == pytest.approx(0.5) and priced["r0"] != pytest.approx(1.0)
    assert "slow 1.68 against 3.37 (-50 %)" in price_lines(pd.DataFrame(off))
    assert price_lines(pd.DataFrame(off[:2])) == ""                              # two rungs: nothing to leave out


def test_too_few_rungs_or_too_narrow_a_size_range_give_the_pooled_rate():
    two = [rung_row("a", 1e4, 2e6), rung_row("b", 5e4, 1e6, steps=2e5)]
    rate = measured_rates(pd.DataFrame(two))["granular"]
    pooled = sum(r["atom_steps"] for r in two) / sum(3600 * r["cpu_hours"] for r in two)
    assert rate.b == 0 and rate.at(1e6) == pytest.approx(pooled)
    narrow = [rung_row(f"n{i}", n, 2e6 - 10 * n) for i, n in enumerate((1e4, 1.2e4, 1.5e4))]
    assert measured_rates(pd.DataFrame(narrow))["granular"].b == 0


def test_pools_unmeasured_rows_and_other_pair_styles_are_kept_apart():
    rows = [rung_row("a", 1e4, 2e6), rung_row("a", 1e4, 2e6),                         # one rung, two headlines
            rung_row("pool", 1e4, 1e3, state="run (pooled: a + b)"),                 # repeats its rungs' runs
            rung_row("soft", 1e4, 8e6, style="gran/hooke/history"),
            rung_row("old", 1e4, 1e3, state="run (kept from the committed ladder.csv)") | {"atom_steps": np.nan},
            rung_row("never", 1e4, 1e3, state="not run")]
    rates = measured_rates(pd.DataFrame(rows))
    assert set(rates) == {"granular", "gran/hooke/history"}
    assert rates["granular"].rungs == ("a",) and rates["granular"].at(1e4) == pytest.approx(2e6)
    assert rates["gran/hooke/history"].at(1e4) == pytest.approx(8e6)
    assert measured_rates(pd.DataFrame([{"rung": "x", "state": "run", "cpu_hours": 1.0}])) == {}


def test_a_rungs_cost_columns_need_every_case():
    cases = [{"atom_steps": 1e9, "steps": 1e5, "pair_style": "granular"},
             {"atom_steps": 3e9, "steps": 1e5, "pair_style": "granular"}]
    assert cost_columns(cases) == {"atom_steps": 4e9, "steps": 2e5, "pair_style": "granular"}
    out = cost_columns(cases + [{"atom_steps": None, "steps": 1e5, "pair_style": "granular"}])
    assert math.isnan(out["atom_steps"]) and out["steps"] == 3e5


def plan_of(rate_source, style="granular", n=5e4, steps=1e5):
    return {"rates": {"heap": rate_source},
            "rows": [{"pair_style": style, "atom_steps": n * steps, "steps": steps, "particles": 2 * n}]}


def test_a_rung_is_priced_at_the_ladder_rate_only_without_runs_of_its_own():
    rates = measured_rates(pd.DataFrame([rung_row(f"r{i}", n, 2e6 * (n / 1e4) ** -0.2)
                                         for i, n in enumerate((1e4, 3e4, 9e4))]))
    cal = calibration(plan_of("reference: 4.4 Matom-step per CPU-second"), "heap", rates)
    assert cal.rates["heap"].value == pytest.approx(2e6 * 5 ** -0.2)          # at the rung's mean count, 5e4
    assert "r0, r1, r2" in cal.rates["heap"].source
    assert calibration(plan_of("measured: 1 heap run(s)"), "heap", rates) is None
    assert calibration(plan_of("reference", style="gran/hooke/history"), "heap", rates) is None
    assert planned_state(plan_of("reference"), "heap", rates) == "planned (cost model, not run)"
    assert planned_state(plan_of(cal.rates["heap"].source), "heap", rates).startswith(
        "planned (cost model at 1.45 Matom-step per CPU-s at 50,000 particles, as rungs r0, r1, r2 ran (±")


def test_a_planned_rung_is_priced_at_the_rate_its_ladders_measured_rungs_ran_at(tmp_path):
    ladder = ladders.load_ladder(ROOT / "config" / "ladders" / "silo.yaml")
    ladder["rungs"] = ladder["rungs"][1:2]
    reference = ladders.plan(ladder, ladder["planned"][0], tmp_path, priced_only=True)
    rows = [rung_row("fast", 2e4, 40e6, style="granular")]                   # ten times the reference rate
    priced = ladders.plan(ladder, ladder["planned"][0], tmp_path, priced_only=True,
                          rates=measured_rates(pd.DataFrame(rows)))
    ratio = reference["total"]["cpu_hours"] / priced["total"]["cpu_hours"]
    assert ratio == pytest.approx(40e6 / reference["rows"][0]["rate"], rel=1e-9)
    assert priced["total"]["atom_steps"] == reference["total"]["atom_steps"]
    assert priced["rates"]["silo"].startswith("measured on this ladder's rungs fast")
