"""Adapter: the campaign's time per rule and per phase (granflow.timing.write_timing)."""
import sys
from pathlib import Path

sys.stderr = open(snakemake.log[0], "w")
from granflow.timing import write_timing  # noqa: E402

text = write_timing(Path(snakemake.params.results), snakemake.params.rung, snakemake.output.rules,
                    snakemake.output.phases, snakemake.output.markdown, dirs=snakemake.params.dirs,
                    install=snakemake.params.install)
print(text, file=sys.stderr)
