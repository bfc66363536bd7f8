"""Adapter: free surface, moving-frame kinematics, scalings and checks of one heap case."""
import json
import sys
from pathlib import Path

sys.stderr = open(snakemake.log[0], "w")
import pandas as pd  # noqa: E402

from granflow.scenes.heap.pipeline import heap_analysis  # noqa: E402

case_dir = Path(snakemake.input.params).parent
record = json.loads(Path(snakemake.input.params).read_text())
status = json.loads(Path(snakemake.input.status).read_text())
names = ["per_x", "profile", "collapse", "surface", "alpha_t", "rise_by_x", "phi_columns", "deposit"]
if status["dumps"]:
    tables, scalars = heap_analysis(case_dir)
    # the steady filling stage: the surface rises uniformly (paper fig. 4c) and the feed delivers its rate
    problems = []
    if not scalars["feed_rate_ok"]:
        problems.append(f"feed rate {scalars['feed_rate_measured']:.4g} kg/s is {100 * scalars['feed_rate_error']:+.1f} % "
                        f"off the requested {scalars['feed_rate']:.4g}")
    if not scalars["rise_velocity_cv"] < 0.25:
        problems.append(f"rise velocity varies by {100 * scalars['rise_velocity_cv']:.0f} % along the heap")
    verdict = "steady" if not problems else "unsteady"
else:
    tables, scalars = {}, {"notes": f"not averaged: {status['status']}"}
    problems, verdict = [status.get("reason") or status["status"]], status["status"]
for name, path in zip(names, snakemake.output.tables):
    tables.get(name, pd.DataFrame()).to_csv(path, index=False)
k = record["rung_knobs"]
mixture = record["case"]["mixture"]
n = scalars.get("n_particles", record.get("n_particles_estimate"))
scalars.update({
    "rung": record["rung"], "mixture": mixture, "feed_rate": record["case"]["feed_rate"],
    "bidisperse": len(record["species"]) == 2,
    "W": k["W"], "T": k["T"], "t_c": k["t_c"], "dt": record["dt"], "k_n": record["parameters"]["k_n"],
    "status": verdict if status["status"] == "completed" else status["status"],
    "status_reason": "; ".join(problems) or status.get("reason"),
    "max_overlap": status.get("max_overlap"), "dangerous_builds": status.get("dangerous_builds"),
    "matom_step_per_s": status.get("matom_step_per_s"), "loop_seconds": status.get("loop_seconds"),
    "provenance": (f"rung {record['rung']} · W={k['W']:g} m · T={k['T'] * 1e3:g} mm · t_c={k['t_c']:g} s · "
                   f"N={n} · {verdict}"),
})
Path(snakemake.output.scalars).write_text(json.dumps(scalars, indent=2, default=float) + "\n")
print(json.dumps(scalars, indent=2, default=float), file=sys.stderr)
