"""Adapter: one CSV row of scalar results per case of a scene (the scene adds sweep-wide fits)."""
import json
import sys
from pathlib import Path

sys.stderr = open(snakemake.log[0], "w")
from granflow import registry  # noqa: E402

rows = [json.loads((Path(p) / "scalars.json").read_text()) for p in snakemake.input.analyses]
table = registry.get(snakemake.wildcards.scene).table(rows)
table.to_csv(snakemake.output.table, index=False)
print(table.T.to_string(), file=sys.stderr)
