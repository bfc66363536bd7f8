"""Adapter: one paper-style figure over every heap case of the campaign."""
import json
import sys
from pathlib import Path

sys.stderr = open(snakemake.log[0], "w")
import pandas as pd  # noqa: E402

from granflow.scenes.heap.figures import HEAP_FIGURES  # noqa: E402

NAMES = ["per_x", "profile", "collapse", "surface", "alpha_t", "rise_by_x", "phi_columns", "deposit"]


def read(path):
    try:
        return pd.read_csv(path)
    except pd.errors.EmptyDataError:  # a case that was not averaged writes empty tables
        return pd.DataFrame()


cases = []
n = len(snakemake.input.scalars)
for i, sp in enumerate(snakemake.input.scalars):
    s = json.loads(Path(sp).read_text())
    tables = {name: read(snakemake.input.tables[j * n + i]) for j, name in enumerate(NAMES)}
    if tables["profile"].empty:  # not averaged: in the table with its status, not in the figures
        continue
    label = f"{s['mixture']}, {1000 * s['feed_rate']:g} g/s"
    cases.append({"label": label, "provenance": s["provenance"], "scalars": s, "bidisperse": s["bidisperse"],
                  **{k: v for k, v in tables.items()},
                  "deposit": tables["deposit"] if s["bidisperse"] else None})
HEAP_FIGURES[snakemake.wildcards.figure](cases, snakemake.output.figure)
