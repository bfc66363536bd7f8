"""Adapter: the report's front page from the scenes' records (granflow.overview.write_overview)."""
import sys
from pathlib import Path

sys.stderr = open(snakemake.log[0], "w")
from granflow.intermediates import read_json, report_plainly  # noqa: E402
from granflow.overview import write_overview  # noqa: E402

report_plainly()
for summary in snakemake.input.summaries:  # write_overview reads them itself
    read_json(summary, keys=("scene",))
text = write_overview([Path(p) for p in snakemake.input.summaries], snakemake.params.rung,
                      Path(snakemake.output.page), [Path(p) for p in snakemake.input.ladders])
print(text, file=sys.stderr)
