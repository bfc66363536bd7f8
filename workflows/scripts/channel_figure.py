"""Adapter: one paper-style figure over every channel case of the campaign."""
import json
import sys
from pathlib import Path

sys.stderr = open(snakemake.log[0], "w")
import pandas as pd  # noqa: E402

from granflow.scenes.channel import figures as plots  # noqa: E402

FIGURES = {
    "fig04_velocity": plots.fig_velocity_profiles,
    "fig05c_ratio": plots.fig_ratio_vs_phi,
    "fig06_stress": plots.fig_stress_profiles,
    "fig08_phi_shear_T": plots.fig_phi_shear_temperature,
    "fig11_rheology": plots.fig_rheology,
}
cases = []
for sp, pp in zip(snakemake.input.scalars, snakemake.input.profiles):
    s = json.loads(Path(sp).read_text())
    profile = pd.read_csv(pp)
    if profile.empty:  # not averaged: shown in the table with its status, not in the figures
        continue
    cases.append({"label": f"W={s['W']:g}, φ̄={s['phi_mean']:g}", "W": s["W"], "phi_mean": s["phi_mean"],
                  "profile": profile, "scalars": s, "provenance": s["provenance"]})
if cases:
    FIGURES[snakemake.wildcards.figure](cases, snakemake.output.figure)
else:  # say so in the figure's place rather than fail the campaign
    from matplotlib.figure import Figure

    fig = Figure(figsize=(6, 2))
    fig.text(0.5, 0.5, "no averaged case: every case is jammed, unsteady or unstable\n(see table.csv)",
             ha="center", va="center")
    fig.savefig(snakemake.output.figure, dpi=150)
