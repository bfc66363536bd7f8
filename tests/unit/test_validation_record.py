"""The generic validation record: verdicts, the written record and its README table."""
import json
import math

import pandas as pd
import pytest

from granflow import validation
from granflow.validation import Check, ValidationResult, verdict


def test_inside_the_range_is_within_whatever_the_error():
    words, diff = verdict(1.385, float("nan"), (1.37, 1.40))
    assert words == "within the paper's range" and diff == 0.0


def test_difference_is_measured_to_the_nearest_end_of_the_range():
    words, diff = verdict(1.21, 0.01, (1.37, 1.40), n_replicates=2)
    assert diff == pytest.approx(1.21 / 1.37 - 1)          # -11.7 %
    assert words.startswith("differs by -11.7 %") and "(16 σ)" in words


def test_differs_needs_two_replicates():
    words, diff = verdict(1.21, 0.01, (1.37, 1.40))
    assert words.startswith("one sample: off by -11.7 % (16 σ)") and "two replicates" in words
    assert "differs by" not in words and diff == pytest.approx(1.21 / 1.37 - 1)


def test_run_to_run_scatter_enters_the_combined_error():
    # 0.977 against 1: stat 0.005 alone gives 4.6 sigma; with the replicates' scatter 0.0095 it is 2.1
    assert verdict(0.977, 0.005, (1.0, 1.0), n_replicates=3)[0].startswith("differs by -2.3 %")
    words, _ = verdict(0.977, 0.005, (1.0, 1.0), run_to_run=0.0095, n_replicates=3)
    assert words.startswith("differs by -2.3 % (2 σ with stat and run-to-run)")
    assert verdict(0.987, 0.005, (1.0, 1.0), run_to_run=0.0055, n_replicates=3)[0] == "within error (1.7 σ)"


def test_consistency_and_diagnostic_rows_carry_no_verdict():
    for kind in ("consistency", "diagnostic"):
        words, diff = verdict(5.0, 0.01, (1.0, 1.0), kind=kind, n_replicates=2)
        assert words == f"{kind}: no verdict against the paper" and math.isnan(diff)
        assert "differs" not in words and "within" not in words
    with pytest.raises(ValueError, match="allowed one of comparison, consistency, diagnostic"):
        verdict(1.0, 0.1, (1.0, 1.0), kind="verdict")


def test_an_error_too_wide_to_see_a_quarter_is_not_resolved():
    # W_r/W_f 2.3 +- 1.5 against 1: 2 errors (3.0) exceed 25 % of 1, "within error" would say nothing
    words, _ = verdict(2.3, 1.5, (1.0, 1.0))
    assert words.startswith("not resolved (± 1.5")
    # 0.91 +- 0.15: 2 errors 0.30 > 0.25 of the value: not resolved either; 0.91 +- 0.1 is resolved
    assert verdict(0.91, 0.15, (1.0, 1.0))[0].startswith("not resolved")
    assert verdict(0.91, 0.1, (1.0, 1.0))[0] == "within error (0.9 σ)"
    # the syst and the replicates' scatter count toward the width; against 0 nothing is relative
    assert verdict(1.05, 0.05, (1.0, 1.0), syst=0.12)[0].startswith("not resolved")
    assert verdict(0.05, 1.0, (0.0, 0.0))[0].startswith("within error")
    # a difference beyond 2 errors still differs, however wide
    assert verdict(9.0, 1.5, (1.0, 1.0), n_replicates=2)[0].startswith("differs by +800.0 %")


def test_within_two_combined_errors_counts_the_papers_error_too():
    # 0.63 against 0.60 +- 0.02: 0.03 off; our 0.01 alone gives 3 sigma, combined sqrt(0.01^2+0.02^2) 1.3 sigma
    assert verdict(0.63, 0.01, (0.60, 0.60), n_replicates=2)[0].startswith("differs")
    words, _ = verdict(0.63, 0.01, (0.60, 0.60), paper_error=0.02)
    assert words == "within error (1.3 σ)"


def test_no_error_and_outside_says_so_and_shapes_are_words():
    assert verdict(2.0, float("nan"), (1.0, 1.0), n_replicates=2)[0] == "differs by +100.0 % (no statistical error)"
    assert verdict(2.0, 0.1, None)[0] == "shape compared (see note)"
    words, diff = verdict(float("nan"), 0.1, (1.0, 1.0))
    assert words == "not measured" and math.isnan(diff)
    assert verdict(float("nan"), 0.1, None)[0] == "not measured"
    # against 0 the difference is absolute, and one-sided ranges work
    assert verdict(0.05, 0.01, (0.0, 0.0), n_replicates=2) == ("differs by +0.05 (the paper's value is 0) (5 σ)", 0.05)
    assert verdict(1.5, 0.2, (1.0, float("inf")))[0] == "within the paper's range"


def test_systematic_error_is_the_largest_shift_over_the_measurement_choices():
    syst, text = validation.systematic(0.50, {"slab 0.25": 0.52, "slab 1": 0.45, "fit form": float("nan")})
    assert syst == pytest.approx(0.05)
    assert text == "slab 0.25: 0.52; slab 1: 0.45; fit form: nan"
    assert math.isnan(validation.systematic(0.5, {})[0])
    assert math.isnan(validation.systematic(float("nan"), {"a": 1.0})[0])


def test_a_difference_the_measurement_choices_explain_is_not_called_n_sigma():
    # 1.30 against 0.5 with stat 0.1: 8 sigma; with a syst of 0.9 the choices alone cover it
    assert verdict(1.30, 0.10, (0.5, 0.5), n_replicates=2)[0].startswith("differs by +160.0 % (8 σ)")
    words, rel = verdict(0.55, 0.01, (0.5, 0.5), syst=0.06)
    assert words.startswith("within the systematic error") and rel == pytest.approx(0.1)
    # stat and syst in quadrature: 0.03 off, stat 0.01, syst 0.012 -> combined 0.0156: 1.9 sigma
    assert verdict(0.53, 0.010, (0.5, 0.5), syst=0.012)[0] == "within error (1.9 σ)"
    # and when even both do not reach: the sigma says it counted both
    assert verdict(1.30, 0.10, (0.5, 0.5), syst=0.2, n_replicates=2)[0] == "differs by +160.0 % (4 σ with stat and syst)"
    # a syst as large as the effect: not a verdict of agreement
    check = Check("a", "1/2", "Fig. 5", 1.30, 0.10, paper_range=(0.5, 0.5), syst=0.9, variants="x: 1")
    assert check.verdict.startswith("not resolved (± 0.91") and check.syst == 0.9


def test_the_table_shows_stat_and_syst_and_old_records_without_syst():
    assert validation.format_with_errors(1.2964, 0.1031, 0.2412) == "1.30 ± 0.10 ± 0.24"
    assert validation.format_with_errors(1.2964, 0.1031, float("nan")) == "1.30 ± 0.10"
    assert validation.format_with_errors(1.2964, 0.1031) == "1.30 ± 0.10"
    assert validation.format_with_errors(1.2964, float("nan"), 0.02) == "1.296 ± – ± 0.020"


def _case(tmp_path, rel, cpu_s, overlap):
    case = tmp_path / "results" / rel
    (case / "run" / "logs").mkdir(parents=True)
    (case / "params.json").write_text(json.dumps({"scene": "toy", "rung": "validation", "case": {"x": 1},
                                                  "n_particles": 1000}))
    (case / "run" / "status.json").write_text(json.dumps({"status": "steady", "reason": "flat",
                                                         "cpu_seconds": cpu_s, "wall_seconds": cpu_s,
                                                         "nprocs": 1, "max_overlap": overlap}))
    (case / "run" / "logs" / "flow_001.log").write_text(
        "LAMMPS (22 Jul 2025 - Update 1)\nLoop time of 1.0 on 1 procs\nWARNING: something\nLoop time of 2.0 on 1 procs\n")
    return case


def test_record_and_readme(tmp_path):
    cases = {"x~1": _case(tmp_path, "x~1", 3600.0, 0.004), "x~2": _case(tmp_path, "x~2", 7200.0, 0.02)}
    figs = tmp_path / "figs"
    figs.mkdir()
    (figs / "f1.png").write_bytes(b"\x89PNG fake")
    result = ValidationResult(
        checks=[Check("ratio", "1.37-1.40", "Fig. 5c", 1.21, 0.01, case="x~1", paper_range=(1.37, 1.40), n_replicates=2),
                Check("balance", "1 (exact)", "§2", 1.001, 0.002, case="x~2", paper_range=(1, 1))],
        profiles={"p": pd.DataFrame({"x": [0.0, 1.0], "u": [0.1, 0.2]})}, figures=["f1", "missing"],
        differences=["thin box: B = 5 instead of 40"])
    out = tmp_path / "validation" / "toy"
    summary = validation.write_record("toy", "validation", result, cases, figs, out, paper="Someone 2020")
    assert summary["cpu_hours"] == pytest.approx(3.0)
    assert summary["figures"] == ["figures/f1.png"]
    assert [c["dir"] for c in summary["cases"]] == ["x~1", "x~2"]
    assert summary["lammps_versions"] == ["LAMMPS (22 Jul 2025 - Update 1)"]
    saved = json.loads((out / "summary.json").read_text())
    assert saved["checks"][1]["verdict"] == "within error (0.5 σ)"
    log = (out / "logs" / "x~1.txt").read_text()
    assert "status: steady: flat" in log and "Loop time of 2.0" in log and "WARNING: something" in log
    assert pd.read_csv(out / "profiles" / "p.csv")["u"].tolist() == [0.1, 0.2]
    (out / "ladder.md").write_text("### toy: ladder toward the paper\n\n| rung | knob |\n")
    text = validation.write_readme(tmp_path / "validation")
    assert "## Ladders: one knob at a time toward the paper" in text and "### toy: ladder toward" in text
    assert "](toy/figures/ladder.png)" not in text                  # no figure, no image link
    # the ladder's figure, where there is one, is shown under its table (a path relative to the README)
    (out / "figures" / "ladder.png").write_bytes(b"\x89PNG fake")
    text = validation.write_readme(tmp_path / "validation")
    assert "| rung | knob |\n\n![toy: error against the paper against CPU-hours, one point per rung](toy/figures/ladder.png)" in text
    assert "| toy | ratio | comparison | 1.37-1.40 (Fig. 5c) | 1.210 ± 0.010 | – (2) | x~1 |" in text
    assert "differs by -11.7 %" in text and "thin box: B = 5 instead of 40" in text
    assert "| toy | x~2 | steady | 1000 | 2.00 % | 2.00 |" in text
    # a rewrite of the record keeps the ladder (measured on other runs) and nothing else of the old folder
    (out / "stale.csv").write_text("old\n")
    validation.write_record("toy", "validation", result, cases, figs, out, paper="Someone 2020")
    assert (out / "ladder.md").read_text().startswith("### toy: ladder") and not (out / "stale.csv").exists()


def test_a_record_over_the_size_limit_is_refused(tmp_path, monkeypatch):
    cases = {"x~1": _case(tmp_path, "x~1", 10.0, 0.001)}
    monkeypatch.setattr(validation, "MAX_SCENE_BYTES", 2000)
    big = pd.DataFrame({"x": range(2000)})
    with pytest.raises(ValueError, match="validation record of toy is .* MB: allowed"):
        validation.write_record("toy", "validation", ValidationResult([], profiles={"big": big}), cases,
                                tmp_path, tmp_path / "validation" / "toy")


def _fixed_schedule_case(tmp_path, analysed: dict | None):
    import json as _json

    case = tmp_path / "R~4.5"
    (case / "run").mkdir(parents=True)
    (case / "run" / "status.json").write_text(_json.dumps(
        {"status": "completed", "reason": "fixed schedule ran to its end", "max_overlap": 0.01}))
    (case / "params.json").write_text(_json.dumps({"n_particles": 100}))
    (case / "provenance.json").write_text(_json.dumps(
        {"case": {"R": 4.5}, "status": "completed", "granflow_commit": "abc", "granflow_dirty": False,
         "lammps_version": "LAMMPS (22 Jul 2025)", "ranks": 1, "cpu_seconds": 36.0, "wall_seconds": 40.0}))
    if analysed is not None:
        (case / "analysis").mkdir()
        (case / "analysis" / "scalars.json").write_text(_json.dumps(analysed))
    return case


def test_case_summary_shows_the_analysed_verdict_of_a_fixed_schedule_run(tmp_path):
    from granflow.validation import case_summary

    case = _fixed_schedule_case(tmp_path, {"status": "steady", "status_reason": "a steady outflow window"})
    s = case_summary(case)
    assert (s["status"], s["reason"], s["run_status"]) == ("steady", "a steady outflow window", "completed")
    assert s["cpu_hours"] == 0.01 and s["particles"] == 100


def test_case_summary_keeps_the_runner_status_without_an_analysis(tmp_path):
    from granflow.validation import case_summary

    s = case_summary(_fixed_schedule_case(tmp_path / "b", None))
    assert (s["status"], s["reason"], s["run_status"]) == ("completed", "fixed schedule ran to its end", "completed")


def test_record_figures_are_copied_as_smaller_palette_pngs(tmp_path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np
    from PIL import Image

    fig, ax = plt.subplots(figsize=(8, 4))
    x = np.linspace(0, 10, 400)
    for k in range(6):
        ax.errorbar(x[::20], np.sin(x[::20] + k), yerr=0.1, marker="os^Dv<"[k], label=f"case {k}")
    ax.legend()
    src, dst = tmp_path / "f.png", tmp_path / "out.png"
    fig.savefig(src, dpi=150)
    validation.copy_figure(src, dst)
    assert dst.stat().st_size < src.stat().st_size
    with Image.open(src) as a, Image.open(dst) as b:
        assert a.size == b.size and b.format == "PNG"
    # not an image Pillow reads: copied as it is
    (tmp_path / "fake.png").write_bytes(b"\x89PNG fake")
    validation.copy_figure(tmp_path / "fake.png", tmp_path / "copy.png")
    assert (tmp_path / "copy.png").read_bytes() == b"\x89PNG fake"


def test_a_subset_variant_counts_only_its_shift_beyond_its_own_statistics():
    # central 0.88 +- 0.43 on 5 points; the fit on 4 of them 1.32 +- 0.60: sigma_diff^2 = 0.60^2 - 0.43^2
    syst, text = validation.systematic(0.88, {"R >= 6.75": (1.32, 0.60)}, central_se=0.43)
    assert syst == pytest.approx(math.sqrt(max(0.0, 0.44**2 - (0.60**2 - 0.43**2))))
    assert "R >= 6.75: 1.32 (± 0.6" in text
    # a shift far beyond the statistics stays almost whole; without central_se nothing is taken out
    assert validation.systematic(1.0, {"half": (2.0, 0.11)}, central_se=0.1)[0] == pytest.approx(
        math.sqrt(1 - (0.11**2 - 0.1**2)))
    assert validation.systematic(1.0, {"half": (2.0, 0.11)})[0] == pytest.approx(1.0)
    # plain values and pairs mix
    assert validation.systematic(1.0, {"a": 1.2, "b": (1.05, 0.2)}, central_se=0.1)[0] == pytest.approx(0.2)


def test_read_table_takes_a_table_without_columns_as_empty(tmp_path):
    """An analysis of a run that was not averaged writes its tables from empty DataFrames (a lone newline):
    reading them gives empty tables, not pandas' EmptyDataError (the heap ladder's unstable rung hit it)."""
    import pandas as pd

    from granflow.validation import read_table

    pd.DataFrame().to_csv(tmp_path / "none.csv", index=False)
    assert (tmp_path / "none.csv").stat().st_size > 0 and read_table(tmp_path / "none.csv").empty
    assert read_table(tmp_path / "absent.csv").empty
    pd.DataFrame({"x": [1.0, 2.0]}).to_csv(tmp_path / "x.csv", index=False)
    assert list(read_table(tmp_path / "x.csv")["x"]) == [1.0, 2.0]
