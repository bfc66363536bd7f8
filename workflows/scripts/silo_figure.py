"""Adapter: one paper-style figure over every silo case of the campaign."""
import json
import sys
from pathlib import Path

sys.stderr = open(snakemake.log[0], "w")
import pandas as pd  # noqa: E402

from granflow.scenes.silo.figures import SILO_FIGURES  # noqa: E402


def read(path):
    try:
        return pd.read_csv(path)
    except pd.errors.EmptyDataError:  # a case without a steady window writes empty tables
        return pd.DataFrame()


scalars = [json.loads(Path(p).read_text()) for p in snakemake.input.scalars]
n = len(scalars)
names = ["flow", "fields", "contact"]
n_tables = len(snakemake.input.tables) // max(n, 1)
cases = []
for i, s in enumerate(scalars):
    tables = [read(snakemake.input.tables[j * n + i]) for j in range(n_tables)]
    scan = {}
    for j in range(len(names), n_tables):
        w = float(Path(snakemake.input.tables[j * n + i]).stem.split("_w", 1)[1])
        scan[w * s["r_b"]] = tables[j]
    if tables[1].empty:  # no steady window: in the table with its status, not in the figures
        continue
    cases.append({"label": s["label"], "provenance": s["provenance"], "scalars": s, "flow": tables[0],
                  "fields": tables[1], "contact": tables[2], "kinetic_scan": scan})
SILO_FIGURES[snakemake.wildcards.figure](cases, snakemake.output.figure)
