"""Adapter: one paper-style figure over every case of a scene."""
import json
import sys
from pathlib import Path

sys.stderr = open(snakemake.log[0], "w")
import pandas as pd  # noqa: E402

from granflow import registry  # noqa: E402


def read(path):
    try:
        return pd.read_csv(path)
    except pd.errors.EmptyDataError:  # a case that was not averaged writes empty tables
        return pd.DataFrame()


scene = registry.get(snakemake.wildcards.scene)
cases = [(json.loads((Path(p) / "scalars.json").read_text()),
          {t.stem: read(t) for t in sorted(Path(p).glob("*.csv"))}) for p in snakemake.input.analyses]
figure_cases = scene.figure_cases(cases)
spec = scene.figures[snakemake.wildcards.figure]
spec.draw(figure_cases, snakemake.output.figure)
