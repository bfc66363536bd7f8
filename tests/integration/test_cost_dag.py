"""The error-versus-cost study's plumbing at smoke size: one channel base case, two values of a
simulation knob (dt) and of a post-processing knob (averaging time), through the Snakemake DAG."""
import json
import subprocess
import sys
from pathlib import Path

import pandas as pd
import pytest

pytestmark = pytest.mark.lammps

BIN = Path(sys.executable).parent


@pytest.fixture(scope="module")
def cost_campaign(tmp_path_factory, root, scenes_off):
    work = tmp_path_factory.mktemp("cost")
    results = work / "results"
    cfg = work / "config.yaml"
    # --configfile merges into config/config.yaml: every key of the default study is set here
    cfg.write_text(
        "rung: smoke\n"
        f"results_dir: {results}\n"
        "scenes:\n"
        + scenes_off() +
        "cost:\n"
        "  n_blocks: 2\n"
        "  scenes:\n"
        + scenes_off(keep=("channel",), indent=4, cost=True) +
        "    channel:\n"
        "      base_rung: smoke\n"
        "      set:\n"
        "        rungs.smoke.W: 10.0\n"
        "        rungs.smoke.dt_fraction: 0.08\n"
        "        rungs.smoke.t_flow_max: 20.0\n"
        "        rungs.smoke.t_segment: 5.0\n"
        "        rungs.smoke.t_average: 10.0\n"
        "        protocol.steady_fluct_tol: 0.15\n"
        "        protocol.average_unsteady: true\n"
        "        case.phi_mean: 0.58\n"
        "      knobs: {dt_fraction: [0.08, 0.05], stiffness: [], size: [], t_average: [5.0, 10.0], bin_width: []}\n"
    )
    cmd = [str(BIN / "snakemake"), "--snakefile", str(root / "Snakefile"), "--directory", str(work), "cost",
           "--configfile", str(cfg), "--cores", "2", "--quiet", "rules"]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=900)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    base = results / "cost" / "channel"
    return {"base": base, "records": pd.read_csv(base / "records.csv"), "errors": pd.read_csv(base / "errors.csv"),
            "within": pd.read_csv(base / "within.csv")}


def test_outputs_exist(cost_campaign, check_png):
    base = cost_campaign["base"]
    assert (base / "error_vs_cost.png").stat().st_size > 10_000
    check_png(base / "error_vs_cost.png")
    assert sorted(p.name for p in (base / "runs").iterdir()) == ["base", "dt_fraction~0.05"]
    assert sorted(p.name for p in (base / "points").iterdir()) == ["base", "dt_fraction~0.05", "t_average~5"]
    summary = json.loads((base / "summary.json").read_text())
    assert summary["paper"]["n_particles"] > 1e5          # the paper rung's channel, for the extrapolation


def test_every_point_records_cost_and_observables(cost_campaign):
    rec = cost_campaign["records"]
    assert set(rec["knob"]) == {"dt_fraction", "t_average"}
    assert set(rec["observable"]) == {"u_ratio", "delta_over_W", "sigma_xx_over_W", "eq31_exponent"}
    assert (rec["cpu_s"] > 0).all() and (rec["sim_cpu_s"] > 0).all() and (rec["post_cpu_s"] > 0).all()
    assert (rec["peak_mb"] > 0).all() and (rec["loop_s"] > 0).all()
    # the simulation's CPU time is that of the LAMMPS processes, which spend most of it in their loops
    assert (rec["sim_cpu_s"] > 0.3 * rec["loop_s"]).all()
    base = rec[rec["is_base"] & (rec["observable"] == "u_ratio")].iloc[0]
    assert base["x"] > 1.0 and base["se"] > 0          # the centre outruns the wall: u_max > u_slip


def test_time_step_knob_changes_the_steps_not_the_simulated_time(cost_campaign):
    rec = cost_campaign["records"].drop_duplicates(["knob", "value"]).set_index(["knob", "value"])
    coarse, fine = rec.loc[("dt_fraction", 0.08)], rec.loc[("dt_fraction", 0.05)]
    assert fine["dt"] / coarse["dt"] == pytest.approx(0.05 / 0.08, rel=1e-6)
    # same schedule (settling, flow to t_flow_max, averaging): about the same simulated time,
    # and 1.6x the atom-steps per unit of it (same particles, 0.08/0.05 more steps)
    assert fine["sim_time"] == pytest.approx(coarse["sim_time"], rel=0.05)
    rate = (fine["atom_steps"] / fine["sim_time"]) / (coarse["atom_steps"] / coarse["sim_time"])
    assert rate == pytest.approx(0.08 / 0.05, rel=0.01)


def test_shorter_averaging_is_charged_its_part_of_the_run(cost_campaign):
    rec = cost_campaign["records"].drop_duplicates(["knob", "value"]).set_index(["knob", "value"])
    full, half = rec.loc[("t_average", 10.0)], rec.loc[("t_average", 5.0)]
    assert full["sim_time"] - half["sim_time"] == pytest.approx(5.0, rel=0.02)   # one 5-unit segment less
    assert half["loop_s"] < full["loop_s"] and half["sim_cpu_s"] < full["sim_cpu_s"]


def test_errors_are_against_the_finest_setting(cost_campaign):
    err = cost_campaign["errors"]
    dt = err[err["knob"] == "dt_fraction"]
    ref = dt[dt["is_ref"]]
    assert set(ref["value"]) == {0.05} and (ref["error"] == 0).all()
    other = dt[~dt["is_ref"] & dt["x"].notna() & dt["x_ref"].notna()]
    assert len(other) >= 1
    assert ((other["x"] - other["x_ref"]) / other["x_ref"].abs()).to_numpy() == pytest.approx(other["error"].to_numpy())
    ta = err[err["knob"] == "t_average"]
    assert set(ta.loc[ta["is_ref"], "value"]) == {10.0}
    within = cost_campaign["within"]
    assert {"all", "u_ratio"} <= set(within["observable"]) and set(within["tolerance"]) == {0.05, 0.1}
    assert within["paper_cpu_h"].dropna().gt(0).all()
