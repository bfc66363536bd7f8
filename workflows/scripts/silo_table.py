"""Adapter: one CSV row of scalar results per silo case, with the Beverloo fit over the sweep."""
import json
import sys
from pathlib import Path

sys.stderr = open(snakemake.log[0], "w")
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402

from granflow.scenes.silo.analysis import beverloo_fit, mean_diameter  # noqa: E402

rows = [json.loads(Path(p).read_text()) for p in snakemake.input.scalars]
table = pd.DataFrame(rows).sort_values("R")
for col in ("W_f", "W_f_se", "rho_bulk"):
    if col not in table:
        table[col] = np.nan
ok = table[np.isfinite(table["W_f"]) & (table["status"] == "steady")]
fit = {"beverloo_n": len(ok)}
if len(ok) >= 3:
    try:
        res = beverloo_fit(2 * ok["R"], ok["W_f"], ok["W_f_se"], rho_b=float(ok["rho_bulk"].mean()),
                           g=float(ok["gravity"].iloc[0]), d=mean_diameter(ok["radii"].iloc[0]))
        fit.update({f"beverloo_{k}": v for k, v in res.items() if np.isscalar(v)})
    except ValueError as exc:
        fit["beverloo_note"] = str(exc)
else:
    fit["beverloo_note"] = f"{len(ok)} steady orifice sizes: a Beverloo fit needs at least 3"
for key, value in fit.items():
    table[key] = value
table = table.drop(columns=[c for c in ("radii",) if c in table])
table.to_csv(snakemake.output.table, index=False)
print(table.T.to_string(), file=sys.stderr)
