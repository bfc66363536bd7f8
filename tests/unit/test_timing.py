"""Where the campaign's time goes (granflow.timing): benchmark files -> per rule and per phase."""
import csv
import json
import re
from pathlib import Path

import pytest
from numpy.testing import assert_allclose

from granflow.timing import (RULE_PHASE, TIMING_RULE, BenchmarkError, campaign_timing, main, markdown,
                             read_benchmark, rule_of, write_timing)

ROOT = Path(__file__).resolve().parents[2]
#: Snakemake's benchmark header (snakemake.benchmark.BenchmarkRecord.get_header(), 9.x)
HEADER = "s\th:m:s\tmax_rss\tmax_vms\tmax_uss\tmax_pss\tio_in\tio_out\tmean_load\tcpu_time"
# float sums of a few numbers: the shares add up to 1 within rounding, far below this
SUM_TOL = 1e-12


def bench(path: Path, wall, rss="100.00", cpu="1.00") -> Path:
    """One benchmark file as Snakemake writes it: the header and one record."""
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(f"{HEADER}\n{wall}\t0:00:00\t{rss}\t300.00\t80.00\t90.00\t0.00\t0.01\t50.00\t{cpu}\n")
    return path


@pytest.fixture
def campaign(tmp_path):
    """A campaign at rung demo: scene alpha with two cases, its table and two figures, the front page."""
    results = tmp_path / "results"
    scene = results / "alpha" / "demo"
    for case, (sim, loop, lmp) in {"x~1": (100.0, 90.0, 95.0), "x~2": (300.0, 280.0, 290.0)}.items():
        d = scene / case
        bench(d / "benchmarks" / "render.tsv", 2.0, cpu="1.50")
        bench(d / "benchmarks" / "simulate.tsv", sim, rss="200.00", cpu=f"{0.9 * sim:.2f}")
        bench(d / "benchmarks" / "analyse.tsv", 20.0, rss="800.00", cpu="19.00")
        bench(d / "benchmarks" / "provenance.tsv", 0.5, rss="NA", cpu="NA")  # ended before the first sample
        (d / "run").mkdir(parents=True)
        (d / "run" / "status.json").write_text(json.dumps({"loop_seconds": loop, "wall_seconds": lmp,
                                                           "cpu_seconds": 0.95 * lmp}))
    bench(scene / "benchmarks" / "table.tsv", 3.0)
    bench(scene / "benchmarks" / "figure_fig01_profile.tsv", 5.0)
    bench(scene / "benchmarks" / "figure_fig02_map.tsv", 7.0)
    bench(results / "benchmarks" / "demo" / "overview.tsv", 1.0)
    install = tmp_path / "install_seconds"
    install.write_text("60\n")
    return {"results": results, "install": install, "scene": scene}


def row(rows, key, value):
    (found,) = [r for r in rows if r[key] == value]
    return found


def test_sums_per_rule_and_phase(campaign):
    t = campaign_timing(campaign["results"], "demo", install=campaign["install"])
    rules, phases = t["rules"], t["phases"]
    assert row(rules, "rule", "simulate")["jobs"] == 2
    assert_allclose(row(rules, "rule", "simulate")["wall_s"], 400.0)
    assert_allclose(row(rules, "rule", "simulate")["cpu_s"], 360.0)
    assert row(rules, "rule", "analyse")["max_rss_mb"] == 800.0
    assert row(rules, "rule", "figure")["jobs"] == 2 and row(rules, "rule", "figure")["wall_s"] == 12.0
    # figures = table + figure; report = provenance + overview (+ the rows the Makefile times)
    assert row(phases, "phase", "figures")["wall_s"] == 15.0 and row(phases, "phase", "figures")["jobs"] == 3
    assert row(phases, "phase", "install")["wall_s"] == 60.0
    assert row(phases, "phase", "rendering")["wall_s"] == 4.0
    assert_allclose(row(phases, "phase", "report")["wall_s"], 2.0)
    total = 60 + 4 + 400 + 40 + 15 + 2
    assert_allclose(row(phases, "phase", "total")["wall_s"], total)
    assert_allclose(row(rules, "phase", "total")["wall_s"], total)
    assert_allclose(row(phases, "phase", "LAMMPS")["wall_share"], 400 / total)
    # provenance was never sampled: its CPU and memory are NA, not zero
    prov = row(rules, "rule", "provenance")
    assert prov["cpu_s"] is None and prov["max_rss_mb"] is None and prov["cpu_sampled_jobs"] == 0


def test_shares_sum_to_one(campaign):
    t = campaign_timing(campaign["results"], "demo", install=campaign["install"])
    for table in (t["rules"], t["phases"]):
        shares = [r["wall_share"] for r in table[:-1] if r["wall_share"] is not None]
        assert_allclose(sum(shares), 1.0, rtol=SUM_TOL)
        assert table[-1]["phase"] == "total" and table[-1]["wall_share"] == 1.0


def test_missing_install_and_report_times_are_not_measured(campaign, tmp_path):
    t = campaign_timing(campaign["results"], "demo", install=tmp_path / "no_such_file")
    install = row(t["rules"], "rule", "install (.venv)")
    assert install["wall_s"] is None and install["wall_share"] is None and install["jobs"] == 0
    assert install["note"].startswith("not measured: no ")
    report = row(t["rules"], "rule", "snakemake --report")
    assert report["wall_s"] is None and report["note"].startswith("not measured")
    # the table's own rule is named, never timed
    own = row(t["rules"], "rule", TIMING_RULE)
    assert own["wall_s"] is None and "not timed" in own["note"]
    assert "not measured: install (.venv), snakemake --report, timing" in t["phases"][-1]["note"]
    # the shares are of what was measured
    shares = [r["wall_share"] for r in t["phases"][:-1] if r["wall_share"] is not None]
    assert_allclose(sum(shares), 1.0, rtol=SUM_TOL)
    text = markdown(t, "demo")
    assert "| install | install (.venv) | 0 | not measured |" in text
    assert "elapsed time is not measured" in text


def test_makefile_times_are_read(campaign):
    timing = campaign["results"] / "timing"
    timing.mkdir()
    (timing / "report_seconds").write_text("12\n")
    (timing / "workflow_seconds").write_text("250\n")
    t = campaign_timing(campaign["results"], "demo", install=campaign["install"])
    assert row(t["rules"], "rule", "snakemake --report")["wall_s"] == 12.0
    assert "took 250 s elapsed in the last make demo" in t["notes"][0]


def test_time_around_lammps(campaign):
    lost = campaign_timing(campaign["results"], "demo", install=None)["lammps"]
    assert lost["cases"] == 2 and lost["left_out"] == 0
    assert (lost["job_wall_s"], lost["lammps_wall_s"], lost["loop_s"]) == (400.0, 385.0, 370.0)
    assert_allclose(lost["lammps_cpu_s"], 0.95 * 385.0)
    note = row(campaign_timing(campaign["results"], "demo")["rules"], "rule", "simulate")["note"]
    assert "370 s of the simulate jobs' 400 s (92.5%" in note and "15 s inside LAMMPS" in note
    assert "15 s outside" in note and "used 366 CPU s (the runner's count" in note


def test_a_resumed_run_is_left_out_of_the_time_around_lammps(campaign):
    # LAMMPS ran longer than this job: earlier jobs of the same case ran part of it
    status = campaign["scene"] / "x~1" / "run" / "status.json"
    status.write_text(json.dumps({"loop_seconds": 150.0, "wall_seconds": 160.0}))
    lost = campaign_timing(campaign["results"], "demo")["lammps"]
    assert lost["cases"] == 1 and lost["left_out"] == 1 and lost["loop_s"] == 280.0


def test_other_rungs_and_dropped_cases_are_left_out(campaign):
    bench(campaign["results"] / "alpha" / "smoke" / "x~1" / "benchmarks" / "simulate.tsv", 1000.0)
    bench(campaign["results"] / "benchmarks" / "smoke" / "overview.tsv", 1000.0)
    bench(campaign["scene"] / "x~9" / "benchmarks" / "simulate.tsv", 1000.0)  # a case dropped from the sweep
    scene = campaign["scene"]
    dirs = [str(scene), str(scene / "x~1"), str(scene / "x~2")]
    t = campaign_timing(campaign["results"], "demo", dirs=dirs)
    assert row(t["rules"], "rule", "simulate")["wall_s"] == 400.0
    assert row(t["rules"], "rule", "overview")["wall_s"] == 1.0
    assert "1 benchmark file(s) of job directories no longer in the campaign left out" in t["notes"]
    # without the campaign's directories, every file at the rung counts
    assert campaign_timing(campaign["results"], "demo")["rules"][2]["wall_s"] == 1400.0


@pytest.mark.parametrize("text, message", [
    ("", "empty, not a Snakemake benchmark file"),
    ("s\th:m:s\tmax_rss\n1.0\t0:00:01\t10\n", "lacks the column(s) cpu_time"),
    (f"{HEADER}\n", "a header and no record"),
    (f"{HEADER}\nabc\t0:00:00\t1\t1\t1\t1\t0\t0\t1\t1\n", "column s: 'abc' is not a number"),
    (f"{HEADER}\n-3.0\t0:00:00\t1\t1\t1\t1\t0\t0\t1\t1\n", "'-3.0' is not a finite non-negative number"),
    (f"{HEADER}\n1.0\t0:00:01\t1\n", "3 tab-separated values for 10 columns"),
    (f"{HEADER}\nNA\t0:00:00\t1\t1\t1\t1\t0\t0\t1\t1\n", "the wall time is missing"),
])
def test_bad_benchmark_file_is_refused_naming_it(tmp_path, text, message):
    path = tmp_path / "benchmarks" / "render.tsv"
    path.parent.mkdir()
    path.write_text(text)
    with pytest.raises(BenchmarkError, match=re.escape(message)) as exc:
        read_benchmark(path)
    assert str(path) in str(exc.value)


def test_command_line_refuses_a_bad_file_without_traceback(campaign, capsys):
    bench(campaign["scene"] / "benchmarks" / "table.tsv", "1.5s")
    assert main([str(campaign["results"]), "--rung", "demo"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("granflow.timing: ") and "table.tsv, line 2, column s: '1.5s' is not a number" in err
    assert "Traceback" not in err


def test_written_tables(campaign, tmp_path):
    out = tmp_path / "out"
    text = write_timing(campaign["results"], "demo", out / "timing.csv", out / "phases.csv", out / "timing.md",
                        install=tmp_path / "none")
    with open(out / "phases.csv") as f:
        phases = list(csv.DictReader(f))
    assert [p["phase"] for p in phases] == ["install", "rendering", "LAMMPS", "analysis", "figures", "report", "total"]
    assert phases[0]["wall_s"] == "" and phases[0]["note"].startswith("not measured")
    assert phases[2]["wall_s"] == "400.00"
    assert (out / "timing.md").read_text() == text and "| LAMMPS | simulate | 2 | 400 |" in text


def test_reads_what_snakemake_writes(tmp_path):
    """The installed Snakemake's own writer, sampled and not sampled, reads back."""
    from snakemake.benchmark import BenchmarkRecord, write_benchmark_records

    sampled = BenchmarkRecord(running_time=12.5, max_rss=150.25, max_vms=300.0, max_uss=100.0, max_pss=110.0,
                              io_in=1.0, io_out=2.0, cpu_usage=600.0, cpu_time=11.75)
    sampled.data_collected = True
    quick = BenchmarkRecord(running_time=0.3)
    path = tmp_path / "simulate.tsv"
    write_benchmark_records([sampled, quick], str(path), False)
    assert read_benchmark(path) == [{"wall_s": 12.5, "cpu_s": 11.75, "max_rss_mb": 150.25},
                                    {"wall_s": 0.3, "cpu_s": None, "max_rss_mb": None}]


@pytest.mark.parametrize("name, rule", [("render", "render"), ("figure_fig04_velocity", "figure"),
                                        ("provenance", "provenance"), ("provenance_table", "provenance_table"),
                                        ("validation_report_channel", "validation_report"),
                                        ("something_new", "something_new")])
def test_rule_of_a_benchmark_file(name, rule):
    assert rule_of(f"x/benchmarks/{name}.tsv") == rule


def smk_rules():
    """(file, rule, directives) of every rule in workflows/rules/*.smk, read as text."""
    out = []
    for smk in sorted((ROOT / "workflows" / "rules").glob("*.smk")):
        name, directives = None, set()
        for line in smk.read_text().splitlines() + ["END"]:
            if line.strip() and not line[0].isspace():
                if name:
                    out.append((smk.name, name, directives))
                m = re.match(r"rule (\w+):", line)
                name, directives = (m.group(1), set()) if m else (None, set())
            elif name and (m := re.match(r" {4}(\w+):", line)):
                directives.add(m.group(1))
    return out


RULES = smk_rules()


@pytest.mark.parametrize("smk, rule, directives", RULES, ids=[f"{f}:{r}" for f, r, _ in RULES])
def test_every_rule_that_does_work_is_benchmarked(smk, rule, directives):
    if rule == TIMING_RULE:
        pytest.skip("the timing rule reads the others' benchmarks; it cannot time itself")
    if directives & {"script", "shell", "run"}:
        assert "benchmark" in directives, (
            f"{smk}: rule {rule} runs a script/shell/run but has no benchmark: (add one beside its log, "
            f"e.g. CASE + \"/benchmarks/{rule}.tsv\", and give the rule a phase in granflow.timing.RULE_PHASE)")


def test_every_benchmarked_campaign_rule_has_a_phase():
    # the cost study (rules cost_*) is not part of the campaign `make demo` runs
    campaign = {r for _, r, d in RULES if "benchmark" in d and not r.startswith("cost_")}
    assert campaign and campaign <= set(RULE_PHASE), campaign - set(RULE_PHASE)
    assert len(RULES) > 10  # the parser found the rule files' rules
