"""Adapter: fields from the dumps, channel analysis, momentum balance, provenance."""
import json
import sys
from pathlib import Path

sys.stderr = open(snakemake.log[0], "w")
import pandas as pd  # noqa: E402

from granflow.scenes.channel.analysis import analyse_channel  # noqa: E402
from granflow.scenes.channel.pipeline import channel_profile, momentum_balance  # noqa: E402

case_dir = Path(snakemake.input.params).parent
record = json.loads(Path(snakemake.input.params).read_text())
status = json.loads(Path(snakemake.input.status).read_text())
W, phi = record["parameters"]["W"], record["parameters"]["phi_mean"]
thermo = pd.read_csv(snakemake.input.thermo)
total_mass = sum(s["count"] * s["mass"] for s in record["species"])
if status["dumps"]:
    profile, facts = channel_profile(case_dir)
    scalars = analyse_channel(profile, W, phi)
    window = thermo[thermo["stage"] == "average"]
else:
    # not averaged (jammed, no steady state, unstable): an empty profile, the reason in the table
    profile = pd.DataFrame(columns=["x", "x_lo", "x_hi"])
    facts = {"n_particles": record["parameters"]["n_particles"], "n_frames": 0, "total_mass": total_mass}
    scalars = {"notes": f"not averaged: {status['status']}"}
    window = thermo
profile.to_csv(snakemake.output.profile, index=False)
balance = momentum_balance(window, facts["total_mass"])
k = record["rung_knobs"]
scalars.update({
    "rung": record["rung"], "W": W, "phi_mean": phi, "B": k["B"], "k_n": k["k_n"],
    "dt": record["dt"], "n_particles": facts["n_particles"], "n_frames": facts["n_frames"],
    "status": status["status"], "status_reason": status.get("reason"),
    "max_overlap": status.get("max_overlap"), "dangerous_builds": status.get("dangerous_builds"),
    "averaged_unsteady": bool(status["dumps"]) and status["status"] != "steady",
    "momentum_residual": balance["residual"], "momentum_steady_residual": balance["steady_residual"],
    "wall_force": balance["wall_force"], "weight": balance["weight"],
    "matom_step_per_s": status.get("matom_step_per_s"),
    "provenance": (f"rung {record['rung']} · W={W:g} d_p · B={k['B']:g} · k_n={k['k_n']:.0e} · "
                   f"N={facts['n_particles']} · {status['status']}"),
})
Path(snakemake.output.scalars).write_text(json.dumps(scalars, indent=2, default=float) + "\n")
print(json.dumps(scalars, indent=2, default=float), file=sys.stderr)
