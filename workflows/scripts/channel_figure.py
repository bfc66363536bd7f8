"""Adapter: one paper-style figure over every channel case of the campaign."""
import json
import sys
from pathlib import Path

sys.stderr = open(snakemake.log[0], "w")
import pandas as pd  # noqa: E402

from postproc import plots  # noqa: E402

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
    cases.append({"label": f"W={s['W']:g}, φ̄={s['phi_mean']:g}", "W": s["W"], "phi_mean": s["phi_mean"],
                  "profile": pd.read_csv(pp), "scalars": s, "provenance": s["provenance"]})
FIGURES[snakemake.wildcards.figure](cases, snakemake.output.figure)
