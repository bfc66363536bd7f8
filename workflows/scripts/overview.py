"""Adapter: the report's front page from the scenes' records (granflow.overview.write_overview)."""
import sys
from pathlib import Path

sys.stderr = open(snakemake.log[0], "w")
from granflow.overview import write_overview  # noqa: E402

text = write_overview([Path(p) for p in snakemake.input.summaries], snakemake.params.rung,
                      Path(snakemake.output.page))
print(text, file=sys.stderr)
