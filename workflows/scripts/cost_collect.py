"""Adapter: one scene's cost study -> records, errors against the finest setting, the
"within p" table with the paper-size extrapolation, and the error-against-cost figure."""
import json
import sys
from pathlib import Path

sys.stderr = open(snakemake.log[0], "w")
import matplotlib  # noqa: E402

matplotlib.use("Agg")
import pandas as pd  # noqa: E402

from granflow.cost import paper_time_step  # noqa: E402
from granflow.cost_analysis import cost_scaling, knob_errors, summary_markdown, within_table  # noqa: E402
from granflow.cost_figure import plot_error_vs_cost  # noqa: E402
from granflow.intermediates import read_csv, read_json, report_plainly  # noqa: E402

report_plainly()

study = json.loads(snakemake.params.study)
scene = snakemake.wildcards.scene


def bench(path, output):
    """cpu_time (s) and max_rss (MB) of a Snakemake benchmark file (rebuilt with the job's ``output``)."""
    row = read_csv(path, rebuild=Path(path).parent / output, sep="\t").iloc[-1]
    return float(row["cpu_time"]), float(row["max_rss"]), float(row["s"])


sim_wall = {Path(p).parent.name: bench(p, "run/status.json")[2] for p in snakemake.input.sim_bench}
rows = []
for obs_path, post_path in zip(snakemake.input.observables, snakemake.input.post_bench):
    point = read_json(obs_path, keys=("point", "observables"))
    p = point["point"]
    # simulation: CPU-seconds of the LAMMPS processes of the segments this point needs (measured
    # by the runner; Snakemake's benchmark of the rule does not see the short-lived MPI children);
    # post-processing: Snakemake's benchmark of the analysis job
    sim_cpu, sim_rss = point["sim_cpu_s"], point["peak_rss_mb"]
    post_cpu, post_rss, _ = bench(post_path, "observables.json")
    knobs = list(study["base_values"]) if p["knob"] is None else [p["knob"]]
    for knob in knobs:
        value = study["base_values"][knob] if p["knob"] is None else p["value"]
        for key, o in point["observables"].items():
            if key == "window":
                continue
            rows.append({
                "scene": scene, "knob": knob, "value": value, "is_base": p["knob"] is None,
                "finest": study["finest"][knob], "unit": study["units"][knob], "point": p["name"], "run": p["run"],
                "observable": key, "label": o["label"], "x": o["x"], "se": o["se"], "n_blocks": o["n_blocks"],
                # the cross-check and the statistical inefficiency (absent from points measured before them)
                "se_method": o.get("se_method", "block"), "se_block": o.get("se_block", o["se"]),
                "g": o.get("g", float("nan")), "n_series": o.get("n_series", 0),
                "cpu_s": sim_cpu + post_cpu, "sim_cpu_s": sim_cpu, "post_cpu_s": post_cpu,
                "loop_s": point["loop_s"], "run_wall_s": sim_wall[p["run"]], "peak_mb": max(sim_rss, post_rss), "n_particles": point["n_particles"],
                "atom_steps": point["atom_steps"], "sim_time": point["sim_time"], "dt": point["dt"],
                "status": point["status"], "note": point["note"], "max_overlap": point["max_overlap"],
            })
records = pd.DataFrame(rows)
records.to_csv(snakemake.output.records, index=False)

errors = knob_errors(records, noise_sigmas=study["noise_sigmas"])
errors.to_csv(snakemake.output.errors, index=False)
scaling = cost_scaling(records)
paper = study["paper"]
if paper is None:  # the scene declares no paper_reference(): nothing to extrapolate to
    within = within_table(errors, tolerances=tuple(study["tolerances"]), scaling=scaling)
    within.insert(len(within.columns), "extrapolation",
                  f"none: the {scene} scene declares no paper_reference() (the paper's size and time)")
else:
    # the paper-size extrapolation counts steps: this run's simulated time in units of the time step
    # the paper-size run would take with this setting (the paper's, except for the knob's own value)
    dt_paper = [paper_time_step(None if b else k, v, dt, study["base_dt_fraction"], paper)
                for k, v, dt, b in zip(errors["knob"], errors["value"], errors["dt"], errors["is_base"])]
    steps_equivalent = errors.assign(
        sim_time=errors["sim_time"] * pd.Series(dt_paper, index=errors.index) / errors["dt"])
    within = within_table(steps_equivalent, tolerances=tuple(study["tolerances"]), scaling=scaling,
                          paper={"n_particles": paper["n_particles"], "sim_time": paper["sim_time"]})
    within.insert(len(within.columns), "extrapolation",
                  f"extrapolated: CPU x (N'/N)^{scaling['exponent']:.2f} x (t'/dt')/(t/dt) with "
                  f"N' = {paper['n_particles']}, t' = {paper['sim_time']:.4g} ({paper['how']}) and dt' the paper "
                  f"rung's step ({paper['dt']:.3g}) except for this knob's own setting; exponent "
                  f"{'measured from the size runs' if scaling['measured'] else 'assumed 1 (fewer than 2 sizes)'}")
within.to_csv(snakemake.output.within, index=False)

base = records[records["is_base"]].iloc[0]
footer = (f"cost study · base rung {study['rung']} ({study['base_note']}) · N = {int(base['n_particles'])} · "
          f"one knob at a time; error against the finest setting run; hollow = inside {study['noise_sigmas']:g}σ noise")
fig = plot_error_vs_cost(errors, scene, footer)
fig.savefig(snakemake.output.figure, dpi=110)
summary = {"scene": scene, "scaling": scaling, "paper": paper, "base": study["base_values"],
           "markdown": summary_markdown(within, tolerance=min(study["tolerances"]))}
Path(snakemake.output.summary).write_text(json.dumps(summary, indent=2, default=float) + "\n")
print(summary["markdown"], file=sys.stderr)
