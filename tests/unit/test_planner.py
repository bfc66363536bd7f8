"""granflow plan --target 'SCENE:QUANTITY:P%' (granflow.planner): the cheapest measured rung within P of the
paper, else the series' extrapolation priced, else why neither; bad input refused naming key, value, allowed."""
import json
import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from numpy.testing import assert_allclose

from granflow import cli
from granflow.config import ConfigError
from granflow.planner import answer, cost_along, excess, extrapolate, parse_target, wall_hours

# exact arithmetic on a few numbers: far below any difference the tests tell apart
TOL = 1e-12


def test_excess_is_how_far_ours_with_its_error_reaches_outside_the_paper_relative_to_the_edge():
    assert excess(1.385, 0.01, 1.37, 1.40) == 0.0                         # inside the range with its error
    assert_allclose(excess(1.36, 0.002, 1.37, 1.40), (1.37 - 1.358) / 1.37, rtol=TOL)
    assert_allclose(excess(26.1, 0.1, 25.69, 25.69), (26.2 - 25.69) / 25.69, rtol=TOL)   # a point value
    assert excess(0.09, 0.02, 0.0, math.inf) == 0.0                       # "> 0", all of ours above it
    assert excess(-0.07, 0.02, 0.0, math.inf) == math.inf                 # past an edge at 0: no relative size


def test_wall_hours_follow_the_plans_scaling():
    # 20,000 particles: two ranks at most (one per 10,000), efficiency 0.7 on more than one
    assert_allclose(wall_hours(4.0, 64, [20_000]), (4.0 / (2 * 0.7), 2), rtol=TOL)
    assert_allclose(wall_hours(4.0, 1, [20_000]), (4.0, 1), rtol=TOL)
    assert_allclose(wall_hours(7.0, 10), (1.0, 10), rtol=TOL)            # particles unknown: every core


def test_cost_along_a_series_is_the_power_law_through_its_measured_cpu_hours():
    df = pd.DataFrame({"rung": ["a", "b", "c"], "cpu_hours": [1.0, 2.0, 4.0]})
    price = cost_along(["a", "b", "c"], np.array([0.2, 0.1, 0.05]), df)          # cpu ∝ 1/x exactly
    assert_allclose(price(0.025), 8.0, rtol=1e-9) and price(0.0) == math.inf


def toy(values, errors=(0.002, 0.002, 0.002), cpu=(1.0, 2.0, 4.0)):
    ladder = {"rungs": [{"name": n} for n in ("b5", "b10", "b20")],
              "series": [{"knob": "the depth B", "x": "1/B (1/d_p)", "points": {"b5": 0.2, "b10": 0.1, "b20": 0.05},
                          "at": {"paper": 0.025, "infinite": 0.0}}]}
    df = pd.DataFrame([{"rung": r, "state": "run", "quantity": "ratio", "ours": v, "stat": e, "syst": 0.0,
                        "paper_lo": 1.37, "paper_hi": 1.40, "cpu_hours": c}
                       for r, v, e, c in zip(("b5", "b10", "b20"), values, errors, cpu)])
    return df, ladder


def test_the_extrapolation_finds_the_cheapest_setting_within_p_on_a_known_line():
    """y = 1.37 − 0.1 x: within 0.5 % of 1.37 (with the line's error) needs x small enough; cpu ∝ 1/x."""
    df, ladder = toy([1.37 - 0.1 * x for x in (0.2, 0.1, 0.05)])
    best, why = extrapolate(df, ladder, "ratio", 0.005, float("nan"))
    assert why == "" and best["series"] == "the depth B"
    assert excess(best["value"], best["error"], 1.37, 1.40) <= 0.005
    assert 0.0 < best["x"] < 0.2 and "(B ≈" in best["setting"]
    assert_allclose(best["cpu_hours"], 0.2 / best["x"], rtol=1e-6)     # the power law through (0.2, 1) ... (0.05, 4)
    # a setting a little cheaper (larger x) is not within P
    y, e = 1.37 - 0.1 * (best["x"] + 0.001), best["error"]
    assert excess(y, e, 1.37, 1.40) > 0.005 - 1e-4
    # errors larger than P everywhere: no setting, and the reason says where the line ends
    df, ladder = toy([1.37 - 0.1 * x for x in (0.2, 0.1, 0.05)], errors=(0.05, 0.05, 0.05))
    best, why = extrapolate(df, ladder, "ratio", 0.005, float("nan"))
    assert best is None and "is not within it anywhere up to 1/B (1/d_p) = 0" in why


@pytest.mark.parametrize("target, match", [
    ("drum:u_max:5%", "scene = 'drum' has no committed ladder: allowed channel, chute, heap, silo"),
    ("silo:exponent a:5%", "quantity = 'exponent a' names more than one of the silo ladder's quantities"),
    ("silo:nothing like it:5%", "quantity = 'nothing like it' names none"),
    ("channel:u_max:-5%", "P = '-5%': allowed a positive percentage"),
    ("channel:u_max:0%", "P = '0%': allowed a positive percentage"),
    ("channel:u_max:nan%", "P = 'nan%': allowed a positive percentage"),
    ("channel:u_max", "allowed SCENE:QUANTITY:P%"),
])
def test_bad_targets_are_refused_naming_key_value_and_allowed(target, match, capsys):
    with pytest.raises(ConfigError, match=match.replace("(", r"\(").replace(")", r"\)")):
        answer(target, 4)
    assert cli.main(["plan", "--target", target]) == 2
    err = capsys.readouterr().err
    assert "refused" in err and "Traceback" not in err


def test_a_quantity_is_named_by_a_unique_part_or_whole_even_with_colons():
    tables = {"heap": pd.read_csv("validation/heap/ladder.csv")}
    assert parse_target("heap:tail u/u_s = A e^{k z/δ}: exponent k:2 %", tables)[1:] == \
        ("tail u/u_s = A e^{k z/δ}: exponent k", 0.02)
    assert parse_target("heap:ANGLE:3", tables)[1].startswith("dynamic angle of repose")


def test_every_headline_of_every_ladder_is_answered_or_said_why_not():
    for scene in ("heap", "silo", "channel"):
        df = pd.read_csv(f"validation/{scene}/ladder.csv")
        df = df[~df["state"].astype(str).str.startswith("contrast")]   # a contrast's rows cost nothing of their own
        for q in dict.fromkeys(df["quantity"].dropna()):
            for p in ("1%", "10%", "50%"):
                a = answer(f"{scene}:{q}:{p}", 16)
                assert a["answer"] in ("measured", "extrapolated", "cannot answer")
                assert "\n" not in a["line"] and a["line"].startswith(f"{scene} '{q}' within")
                if a["answer"] == "cannot answer":
                    assert a["reasons"] and all(a["reasons"])


def test_a_rungs_own_headline_without_rows_yet_names_the_rung_that_reads_it():
    """A headline only a rung names (phi062's loose zone, t_paper's u_cm) is answered before the rung has run:
    'cannot answer', naming the rung and its state; a ladder quantity keeps its name when a headline shares a part."""
    from granflow.ladder import load_ladder
    from granflow.planner import rung_headlines

    heads = rung_headlines(load_ladder(Path("config/ladders/channel.yaml")))
    for head, rungs in heads.items():
        a = answer(f"channel:{head}:10%", 4)
        if a["answer"] == "cannot answer" and "headline of" in a["reasons"][0]:
            assert all(r in a["line"] for r in rungs)
    tables = {"channel": pd.read_csv("validation/channel/ladder.csv")}
    assert parse_target("channel:u_max:1%", tables, {"channel": heads})[1] == "u_max/u_slip"
    # the pool W60_W100's row is named by a part only it holds
    assert parse_target("channel:u_max at the wider:1%", tables, {"channel": heads})[1].startswith("u_max at the wider W")


def test_the_channel_answers_measured_extrapolated_and_noise():
    """From the committed channel ladder: B20 is within 1 % (1.3619 ± its errors ⊕ the seed2 scatter against
    1.37–1.40), nothing measured is within 0.6 % but the 1/B line is (not within 0.5 %: at 1/B = 0 it reads
    1.3675 ± 0.0051), and 0.1 % is below every error."""
    a = answer("channel:u_max:1%", 64)
    assert (a["answer"], a["rung"]) == ("measured", "B20") and a["excess"] <= 0.01
    assert a["run_to_run"] > 0 and "run-to-run from a replicate rung included" in a["line"]
    assert_allclose(a["cpu_hours"], 4.11876, rtol=1e-5)
    assert "kept from the committed ladder.csv" in a["line"]      # B20's row predates the wall-bin syst
    b = answer("channel:u_max:0.6%", 64)
    assert b["answer"] == "extrapolated" and b["x"] < 0.05 and b["cpu_hours"] > a["cpu_hours"]
    assert answer("channel:u_max:0.5%", 64)["answer"] == "cannot answer"   # the line reaches 0.55 % outside
    c = answer("channel:u_max:0.1%", 64)
    assert c["answer"] == "cannot answer" and c["reasons"][0].startswith("noise:")
    assert any("B20_H24 (planned" in r for r in c["reasons"])


def test_a_paper_value_of_zero_and_a_ladder_without_series_say_so():
    a = answer("silo:W_f:5%", 4)
    assert a["answer"] == "cannot answer"
    assert "no relative size" in a["reasons"][0] and "no series" in a["reasons"][1]
    df = pd.read_csv("validation/silo/ladder.csv")
    price = float(df.loc[df["rung"] == "paper", "cpu_hours"].iloc[0])
    assert f"paper (planned, {price:.3g} CPU-h)" in a["line"]


def test_json_holds_one_answer_per_target(capsys):
    assert cli.main(["plan", "--target", "channel:u_max:1%", "--target", "heap:angle:3%", "--cores", "8",
                     "--json"]) == 0
    found = json.loads(capsys.readouterr().out)
    assert [f["scene"] for f in found] == ["channel", "heap"] and all(f["cores"] == 8 for f in found)
    assert cli.main(["plan", "--target", "channel:u_max:1%"]) == 0
    assert len(capsys.readouterr().out.strip().splitlines()) == 1
    assert cli.main(["plan", "--target", "channel:u_max:1%", "--cores", "0"]) == 2
    assert "--cores = 0: allowed" in capsys.readouterr().err


def test_a_diagnostic_row_is_no_answer_within_p():
    """The heap's q* exponent over two feed rates (W023_steady_rates, 0.223) is a diagnostic: no verdict against
    the paper, so never the measured answer, however near 0.22; the comparisons over three rates are."""
    df = pd.read_csv("validation/heap/ladder.csv")
    q = "δ/d̄ ∝ q*^a across feed rates at fixed x/L ≥ 0.2: exponent a"
    kinds = df[df["quantity"] == q].set_index("rung")["kind"]
    assert kinds["W023_steady_rates"] == "diagnostic" and kinds["W023_rates"] == "comparison"
    for p in ("2%", "10%", "30%"):
        a = answer(f"heap:q*^a:{p}", 4)
        assert a.get("rung") != "W023_steady_rates"
        if a["answer"] == "cannot answer":
            assert any("W023_steady_rates measures it only as a diagnostic" in r for r in a["reasons"])
    assert answer("heap:q*^a:30%", 4)["answer"] == "measured"
