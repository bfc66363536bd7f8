"""Adapter: one CSV row of scalar results per heap case."""
import json
import sys
from pathlib import Path

sys.stderr = open(snakemake.log[0], "w")
import pandas as pd  # noqa: E402

rows = [json.loads(Path(p).read_text()) for p in snakemake.input.scalars]
table = pd.DataFrame(rows).sort_values(["mixture", "feed_rate"])
table.to_csv(snakemake.output.table, index=False)
print(table.to_string(), file=sys.stderr)
