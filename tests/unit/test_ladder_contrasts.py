"""A ladder's contrasts (granflow.ladder_contrasts, granflow.ladder.table): one rung read against a reference, row
by row, for a paper's claim that a knob changes nothing or moves a quantity one way."""
from __future__ import annotations

import copy
import math

import pytest

import granflow.ladder as lad
from granflow.config import ConfigError
from granflow.ladder_contrasts import check_contrasts, contrast_check, contrast_checks, nominal, variants
from granflow.schema import PROJECT_ROOT
from granflow.validation import Check

CONTRAST = {"name": "kn_contrast", "knob": "k", "rung": "soft", "reference": "record", "paper": "independent of k",
            "source": "§3", "from_paper": 1}


def check(ours, error=0.01, syst=float("nan"), variants="", run_to_run=float("nan"), n=1, note="", q="u_max/u_slip"):
    return Check(q, "1.3", "§3", ours, error, case="W~60", paper_range=(1.3, 1.3), syst=syst, variants=variants,
                 run_to_run=run_to_run, n_replicates=n, note=note)


def test_a_ratio_carries_both_errors_and_the_claims_range():
    row = {"quantity": "u_max/u_slip", "claim": "equal", "form": "ratio"}
    c = contrast_check(CONTRAST, row, check(2.0, 0.02), check(2.2, 0.044))
    assert math.isclose(c.ours, 1.1)
    assert math.isclose(c.error, 1.1 * math.hypot(0.01, 0.02))
    assert c.paper_range == (1.0, 1.0) and c.quantity == "u_max/u_slip: soft over the record"
    assert c.n_replicates == 1 and not math.isfinite(c.run_to_run)          # no side has replicates
    assert c.verdict.startswith("one sample")                                 # 1.1 is 4.5 σ from 1: never "differs"


def test_run_to_run_comes_from_the_side_with_replicates():
    # the reference pooled 2 seeds: run_to_run = s/√2, so one run's scatter s = 0.1 √2 ... and the contrast
    # of a 2-run mean with one run has s √(1/2 + 1)
    row = {"quantity": "u_max/u_slip", "claim": "equal", "form": "difference"}
    ref = check(2.0, 0.0, run_to_run=0.1, n=2)
    c = contrast_check(CONTRAST, row, ref, check(2.5, 0.0))
    s = 0.1 * math.sqrt(2)
    assert math.isclose(c.run_to_run, s * math.sqrt(1 / 2 + 1))
    assert c.n_replicates == 2
    assert c.verdict.startswith("differs")                                    # 0.5 against 0.17: 2.9 σ


def test_a_measurement_choice_that_moves_both_sides_alike_leaves_the_contrast_alone():
    row = {"quantity": "u_max/u_slip", "claim": "equal", "form": "ratio"}
    # the wall bin moves both by +10 %: no syst; the bins move the rung only: 0.05 relative
    ref = check(1.0, variants="wall bin 1 d_p: 1.1; bins 2 d_p: 1.0 (± 0.01, beyond its statistics 0)")
    turned = check(2.0, variants="wall bin 1 d_p: 2.2; bins 2 d_p: 2.1")
    c = contrast_check(CONTRAST, row, ref, turned)
    assert math.isclose(c.syst, 2.0 * 0.05)
    assert "each of 2 measurement choices applied to both sides" in c.note
    # differences: the same choices
    d = contrast_check(CONTRAST, dict(row, form="difference"), ref, turned)
    assert math.isclose(d.syst, 0.1)                  # each choice moves the difference 1.0 by 0.1


def test_without_a_common_choice_the_larger_syst_counts():
    row = {"quantity": "q", "claim": "equal", "form": "difference"}
    c = contrast_check(CONTRAST, row, check(1.0, syst=0.2), check(1.1, syst=0.3, variants="other: 1.2"))
    assert math.isclose(c.syst, 0.3) and "no common choice" in c.note


def test_a_pooled_reference_reads_its_variants_against_its_first_replicate():
    note = "x. Replicates (2 of 2 seeds measured it): seed 11: 1.2 ± 0.01; seed 22: 1.0 ± 0.01; mean 1.1"
    ref = check(1.1, note=note, n=2, run_to_run=0.1, variants="a: 1.3")
    assert nominal(ref) == 1.2 and variants(ref) == {"a": 1.3}
    assert nominal(check(1.1, note=note, n=1)) == 1.1                        # one run: its own value


@pytest.mark.parametrize("claim, form, ours, inside", [("rises", "ratio", 1.5, True), ("rises", "ratio", 0.5, False),
                                                       ("falls", "difference", -0.4, True),
                                                       ("falls", "difference", 0.4, False)])
def test_a_one_way_claim_is_an_open_range(claim, form, ours, inside):
    row = {"quantity": "q", "claim": claim, "form": form}
    a = 1.0
    b = a * ours if form == "ratio" else a + ours
    c = contrast_check(CONTRAST, row, check(a, 0.001), check(b, 0.001))
    assert (c.verdict == "within the paper's range") is inside


def test_rows_that_match_no_one_check_are_named():
    rows = [{"quantity": "u_max/u_slip", "claim": "equal"}, {"quantity": "nothing", "claim": "equal"}]
    out, missing = contrast_checks(dict(CONTRAST, rows=rows), [check(1.0)], [check(1.1)])
    assert len(out) == 1 and missing == ["nothing"]


@pytest.mark.parametrize("change, words", [({"rung": "nope"}, "rung = 'nope'"),
                                           ({"reference": "soft"}, "reference = 'soft'"),
                                           ({"rows": [{"quantity": "q", "claim": "grows"}]}, "claim = 'grows'"),
                                           ({"rows": [{"quantity": "q", "claim": "equal", "form": "log"}]},
                                            "form = 'log'")])
def test_a_bad_contrast_is_refused_by_name(change, words):
    ladder = {"rungs": [{"name": "soft"}, {"name": "base"}],
              "contrasts": [{**CONTRAST, "rows": [{"quantity": "q", "claim": "equal"}], **change}]}
    with pytest.raises(ConfigError, match=words.replace("(", r"\(")):
        check_contrasts(ladder, "x.yaml")


def test_the_shipped_contrasts_name_quantities_of_their_records():
    # every contrast row of the shipped ladders matches one check of the committed record
    for path in lad.ladder_files():
        ladder = lad.load_ladder(path)
        for contrast in ladder.get("contrasts") or []:
            quantities = [r["quantity"] for r in contrast["rows"]]
            ref, _ = lad.committed_checks(ladder, quantities)
            _, missing = contrast_checks(contrast, ref, ref)
            assert missing == [], (path.name, contrast["name"], missing)


def test_contrast_rows_in_the_table_stay_out_of_the_cost_rows(tmp_path, monkeypatch):
    ladder = copy.deepcopy(lad.load_ladder(PROJECT_ROOT / "config" / "ladders" / "channel.yaml"))
    contrast = ladder["contrasts"][0]
    ref = [check(1.34, 0.002, q="u_max/u_slip", n=2, run_to_run=0.001)]
    rung = [check(1.30, 0.002, q="u_max/u_slip")]
    monkeypatch.setattr(lad, "committed_checks", lambda lad_, qs=None: (ref, []))
    real = lad._headline_checks

    def measured(ladder_, base, cases, headlines):
        return (rung, [{"cpu_hours": 0.3, "particles": 10, "status": "steady"}]) if cases else real(
            ladder_, base, cases, headlines)

    monkeypatch.setattr(lad, "_headline_checks", measured)
    case = lad.rung_cases_root(tmp_path, ladder, next(r for r in ladder["rungs"] if r["name"] == contrast["rung"]))
    (case / "W~60/phi~0.61/analysis").mkdir(parents=True)
    (case / "W~60/phi~0.61/analysis/scalars.json").write_text("{}")
    contrast["rows"] = contrast["rows"][:1]
    rows = lad.table(ladder, tmp_path)
    mine = rows[rows["rung"] == contrast["name"]]
    assert list(mine["state"]) == ["contrast: kn1e5 against the record"]
    assert math.isclose(mine["ours"].iloc[0], 1.30 / 1.34) and mine["cpu_hours"].iloc[0] == 0.3
    assert list(lad.rejudge(rows, ladder)["verdict"]) == list(rows["verdict"])
    text = lad.markdown(rows, ladder)
    assert "| kn_contrast |" in text and "(contrast: kn1e5 against the record)" in text
