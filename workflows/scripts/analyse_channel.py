"""Adapter: fields from the dumps, channel analysis, momentum balance, provenance."""
import json
import sys
from pathlib import Path

sys.stderr = open(snakemake.log[0], "w")
import pandas as pd  # noqa: E402

from postproc.channel import analyse_channel  # noqa: E402
from postproc.pipeline import channel_profile, momentum_balance  # noqa: E402

case_dir = Path(snakemake.input.params).parent
record = json.loads(Path(snakemake.input.params).read_text())
status = json.loads(Path(snakemake.input.status).read_text())
profile, facts = channel_profile(case_dir)
profile.to_csv(snakemake.output.profile, index=False)

W, phi = record["parameters"]["W"], record["parameters"]["phi_mean"]
scalars = analyse_channel(profile, W, phi)
thermo = pd.read_csv(snakemake.input.thermo)
balance = momentum_balance(thermo[thermo["stage"] == "average"], facts["total_mass"])
k = record["rung_knobs"]
scalars.update({
    "rung": record["rung"], "W": W, "phi_mean": phi, "B": k["B"], "k_n": k["k_n"],
    "dt": record["dt"], "n_particles": facts["n_particles"], "n_frames": facts["n_frames"],
    "status": status["status"], "steady_reason": (status.get("steady") or {}).get("reason"),
    "momentum_residual": balance["residual"], "momentum_steady_residual": balance["steady_residual"],
    "wall_force": balance["wall_force"], "weight": balance["weight"],
    "matom_step_per_s": status.get("matom_step_per_s"),
    "provenance": (f"rung {record['rung']} · W={W:g} d_p · B={k['B']:g} · k_n={k['k_n']:.0e} · "
                   f"N={facts['n_particles']} · {status['status']}"),
})
Path(snakemake.output.scalars).write_text(json.dumps(scalars, indent=2, default=float) + "\n")
print(json.dumps(scalars, indent=2, default=float), file=sys.stderr)
