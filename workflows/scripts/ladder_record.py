"""Adapter: a ladder's record (granflow.ladder.record) from its rungs' analysed cases."""
import sys
from pathlib import Path

sys.stderr = open(snakemake.log[0], "w")
from granflow.ladder import load_ladder, record  # noqa: E402

ladder = load_ladder(snakemake.input.ladder)
print(record(ladder, Path(snakemake.params.results), Path(snakemake.output.table).parent), file=sys.stderr)
