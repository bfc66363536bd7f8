"""Adapter: one scene's picture of what accuracy costs (granflow.accuracy_figure) from its committed ladder."""
import sys

sys.stderr = open(snakemake.log[0], "w")
import pandas as pd  # noqa: E402

from granflow.accuracy_figure import plot_accuracy_cost  # noqa: E402
from granflow.ladder import load_ladder  # noqa: E402

drawn = plot_accuracy_cost(pd.read_csv(snakemake.input.record), load_ladder(snakemake.input.ladder),
                           snakemake.output.figure, snakemake.input.get("cost_errors"))
print(f"drawn: {drawn}", file=sys.stderr)
