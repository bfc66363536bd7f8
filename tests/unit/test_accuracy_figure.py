"""granflow.accuracy_figure: what accuracy costs, per scene, from its committed ladder: measured rungs, the
series' extrapolation, planned rungs and the smoke cost study's points; a report item of every campaign."""
import math
import re
from pathlib import Path

import numpy as np
import pandas as pd
from numpy.testing import assert_allclose

from granflow.accuracy_figure import cost_study_points, measured_points, plot_accuracy_cost, series_curves
from granflow.ladder import load_ladder
from granflow.timing import RULE_PHASE

ROOT = Path(__file__).resolve().parents[2]
# a few exact operations on given numbers
TOL = 1e-12


def toy():
    ladder = {"scene": "toy", "rungs": [{"name": n} for n in ("b5", "b10", "b20", "seed2")],
              "series": [{"knob": "depth", "x": "1/B", "points": {"b5": 0.2, "b10": 0.1, "b20": 0.05},
                          "at": {"paper": 0.025, "infinite": 0.0}}]}
    ladder["rungs"][3]["replicate"] = True
    rows = [{"rung": r, "ours": 1.37 - 0.1 * x, "cpu_hours": 0.05 / x} for r, x in (("b5", 0.2), ("b10", 0.1),
                                                                                    ("b20", 0.05))]
    rows.append({"rung": "seed2", "ours": 1.37 - 0.02 + 0.004, "cpu_hours": 0.25})
    df = pd.DataFrame([dict(r, state="run", quantity="ratio", stat=0.002, syst=0.001, paper_lo=1.37, paper_hi=1.40,
                            abs_rel_difference=max(0.0, 1.37 - r["ours"]) / 1.37, rel_error=0.0, knob="k")
                       for r in rows])
    planned = {"rung": "paper", "state": "planned (cost model, not run)", "quantity": np.nan, "cpu_hours": 30.0}
    return pd.concat([df, pd.DataFrame([planned])], ignore_index=True), ladder


def test_measured_points_carry_the_combined_error_with_the_run_to_run_scatter():
    df, ladder = toy()
    points = measured_points(df, ladder, "ratio").set_index("rung")
    r2r = 0.004 / math.sqrt(2)            # seed2 − b5 = +0.004: one run's scatter |Δ|/√2
    assert_allclose(points.loc["b5", "error"], math.sqrt(0.002**2 + 0.001**2 + r2r**2) / 1.37, rtol=TOL)
    assert_allclose(points.loc["b20", "difference"], 0.005 / 1.37, rtol=TOL)
    assert points.loc["seed2", "replicate"] and not points.loc["b5", "replicate"]
    assert not points["diagnostic"].any()
    # a row its validation calls a diagnostic (no verdict against the paper) is drawn, marked as one
    df.loc[df["rung"] == "b10", "kind"] = "diagnostic"
    marked = measured_points(df, ladder, "ratio").set_index("rung")["diagnostic"]
    assert marked["b10"] and not marked.drop("b10").any()


def test_the_series_curve_follows_its_line_to_the_papers_size_at_its_measured_price():
    """On y = 1.37 − 0.1 x with cpu = 0.05/x: the curve ends at the paper's x = 0.025 (2 CPU-h, 0.25 % off)."""
    df, ladder = toy()
    (curve,) = series_curves(df, ladder, "ratio")
    assert_allclose([curve["cpu"][0], curve["cpu"][-1]], [0.25, 2.0], rtol=1e-9)
    assert_allclose(curve["difference"][-1], 0.0025 / 1.37, rtol=1e-9)
    assert all(lo <= d <= hi for lo, d, hi in zip(curve["low"], curve["difference"], curve["high"]))
    ((label, cpu, d),) = curve["at"]       # x = 0 has no finite price: not drawn
    assert label == "paper" and math.isclose(cpu, 2.0, rel_tol=1e-9)


def test_the_picture_draws_measured_extrapolated_planned_and_the_cost_studys_points(tmp_path):
    df, ladder = toy()
    errors = tmp_path / "errors.csv"
    pd.DataFrame({"knob": ["dt", "dt", "bins"], "cpu_s": [3600.0, 7200.0, 0.0], "error": [0.1, -0.05, 0.2]}
                 ).to_csv(errors, index=False)
    study = cost_study_points(errors)
    assert list(study["cpu_hours"]) == [1.0, 2.0] and list(study["difference"]) == [0.1, 0.05]   # |error|
    drawn = plot_accuracy_cost(df, ladder, tmp_path / "a.png", errors)
    assert drawn == {"measured": 4, "extrapolated": 1, "planned": 1, "cost_study": 2}
    assert (tmp_path / "a.png").stat().st_size > 5_000
    assert cost_study_points(tmp_path / "none.csv").empty


def test_every_committed_ladder_gets_its_picture(tmp_path):
    for scene in ("heap", "silo", "channel"):
        df = pd.read_csv(ROOT / "validation" / scene / "ladder.csv")
        drawn = plot_accuracy_cost(df, load_ladder(ROOT / "config" / "ladders" / f"{scene}.yaml"),
                                   tmp_path / f"{scene}.png")
        # every measured row is a point; a rung's row that measured nothing (ours NaN, with its reason) is none
        measured = df["state"].astype(str).str.startswith("run") & np.isfinite(df["ours"].astype(float))
        assert drawn["measured"] == measured.sum() and (tmp_path / f"{scene}.png").exists()
        assert drawn["extrapolated"] == (1 if scene == "channel" else 0)     # only the channel has a series


def test_the_report_item_is_a_rule_with_a_phase_and_a_caption_saying_measured_and_extrapolated():
    smk = (ROOT / "workflows" / "rules" / "validation.smk").read_text()
    assert re.search(r"^rule accuracy_cost_report:", smk, re.M) and "_accuracy_cost.png" in smk
    assert RULE_PHASE["accuracy_cost_report"] == "report"
    caption = (ROOT / "workflows" / "report" / "accuracy_cost.rst").read_text()
    assert "**Measured**" in caption and "**Extrapolated**" in caption and "not against the paper" in caption
