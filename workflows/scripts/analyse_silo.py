"""Adapter: discharge rates, steady window and coarse-grained fields of one silo case."""
import json
import os
import sys
from pathlib import Path

sys.stderr = open(snakemake.log[0], "w")
os.environ.setdefault("NUMBA_NUM_THREADS", str(snakemake.threads))
import pandas as pd  # noqa: E402

from granflow.scenes.silo.pipeline import silo_analysis  # noqa: E402

case_dir = Path(snakemake.input.params).parent
record = json.loads(Path(snakemake.input.params).read_text())
status = json.loads(Path(snakemake.input.status).read_text())
if status["dumps"] and status["status"] in ("completed", "clogged"):
    tables, scalars = silo_analysis(case_dir)
    verdict = "steady" if "W_f" in scalars else "unsteady"
else:
    tables, scalars, verdict = {}, {}, status["status"]
names = ["flow", "fields", "contact"] + [Path(p).stem for p in snakemake.output.kinetic]
for name, path in zip(names, list(snakemake.output.tables) + list(snakemake.output.kinetic)):
    tables.get(name, pd.DataFrame()).to_csv(path, index=False)
k = record["rung_knobs"]
r_b = record["r_b"]
run_status = status["status"]
scalars.update({
    "rung": record["rung"], "R": record["R"], "R_over_rb": record["R_over_rb"], "R_c": record["R_c"],
    "r_b": r_b, "radii": [s["radius"] for s in record["species"]], "density": record["density"],
    "gravity": record["gravity"], "reinsert": record["reinsert"], "Y": record["Y"], "k_n": record["k_n"],
    "t_c_min": record["parameters"]["t_c_min"], "dt": record["dt"], "n_particles": record["n_particles"],
    "status": verdict if run_status == "completed" else run_status,
    "status_reason": scalars.get("steady_reason") if run_status == "completed" else status.get("reason"),
    "run_reason": status.get("reason"),
    "max_overlap": status.get("max_overlap"), "dangerous_builds": status.get("dangerous_builds"),
    "matom_step_per_s": status.get("matom_step_per_s"), "loop_seconds": status.get("loop_seconds"),
    "label": f"R = {record['R_over_rb']:g} r_b",
    "provenance": (f"rung {record['rung']} · R_c={k['R_c']:g} r_b · Y={record['Y']:.3g} Pa "
                   f"(k_n={record['k_n']:.3g} N/m) · t_c={record['parameters']['t_c_min']:.2g} s · "
                   f"N={record['n_particles']} · {'re-insertion' if record['reinsert'] else 'no re-insertion'} · "
                   f"{verdict if run_status == 'completed' else run_status}"),
})
Path(snakemake.output.scalars).write_text(json.dumps(scalars, indent=2, default=float) + "\n")
print(json.dumps(scalars, indent=2, default=float), file=sys.stderr)
