"""Adapter: headline observables of one point of the cost study, with their errors and the cost it took."""
import json
import os
import sys
from pathlib import Path

sys.stderr = open(snakemake.log[0], "w")
os.environ.setdefault("NUMBA_NUM_THREADS", str(snakemake.threads))
from granflow.cost import post_record, prefix_segments, segment_costs  # noqa: E402
from granflow.headline import measure_with_errors  # noqa: E402
from granflow.intermediates import read_csv, read_json, report_plainly  # noqa: E402

report_plainly()
point = json.loads(snakemake.params.point)
case_dir = Path(snakemake.input.params).parent
record = post_record(read_json(snakemake.input.params, keys=("scene",)), point["post"])
status = read_json(snakemake.input.status, keys=("status", "dumps"))
read_csv(snakemake.input.thermo)  # the measurement reads it itself: refuse a damaged one by name first
scene = snakemake.wildcards.scene

# a jammed or unstable run has no flow to measure, even where the deck averaged anyway
if status["dumps"] and status["status"] not in ("jammed", "unstable"):
    obs = measure_with_errors(scene, case_dir, record, point["t_average"], n_blocks=snakemake.params.n_blocks)
    note = ""
else:
    from granflow import registry

    nan = float("nan")
    obs = {k: {"x": nan, "se": nan, "se_method": "block", "se_block": nan, "n_blocks": 0, "g": nan, "n_series": 0,
               "reliable": False, "label": lab}
           for k, lab in registry.get(scene).headline}
    obs["window"] = [float("nan"), float("nan")]
    note = f"not measured: {status['status']}: {status.get('reason')}"

segments = segment_costs(case_dir / "run")
used = prefix_segments(segments, point["t_average"], record["t_segment"])
# particles of a run that stopped before any loop finished: the planned number
planned = int(record.get("n_particles") or record.get("n_particles_estimate") or record["parameters"].get("n_particles", 0))
out = {
    "point": point,
    "observables": obs,
    "status": status["status"],
    "reason": status.get("reason"),
    "note": note,
    "max_overlap": status.get("max_overlap"),
    "nprocs": status.get("nprocs", 1),
    "dt": record["dt"],
    "n_particles": max((int(s["atom_steps"] / s["steps"]) for s in used if s["steps"]), default=planned),
    "loop_s": sum(s["loop_s"] for s in used),
    # measured by the runner for each LAMMPS invocation (all ranks, user + system)
    "sim_cpu_s": sum(s["cpu_s"] for s in used),
    "peak_rss_mb": max((s["peak_rss_mb"] for s in used), default=float("nan")),
    "atom_steps": sum(s["atom_steps"] for s in used),
    "sim_time": sum(s["steps"] for s in used) * record["dt"],
    "segments": [s["segment"] for s in used],
    "provenance": {k: record["rung_knobs"].get(k) for k in ("k_n", "t_c", "Y_factor", "W", "T", "B", "H", "R_c",
                                                            "fill_height", "dt_fraction") if k in record["rung_knobs"]},
}
Path(snakemake.output.observables).write_text(json.dumps(out, indent=2, default=float) + "\n")
print(json.dumps(out, indent=2, default=float), file=sys.stderr)
