"""Adapter: one CSV row of scalar results per case of a scene (the scene adds sweep-wide fits).

Each case's analysis is checked against its SHA256SUMS first; the table is written under a
temporary name and moved into place when complete, then table.csv.sha256 beside it."""
import sys
from pathlib import Path

sys.stderr = open(snakemake.log[0], "w")
from granflow import registry  # noqa: E402
from granflow.intermediates import read_json, replacing, report_plainly, verify_folder, write_checksum  # noqa: E402

report_plainly(kept=[snakemake.output.table])
for sums in snakemake.input.sums:
    verify_folder(Path(sums).parent)
rows = [read_json(p, rebuild=Path(p).with_name("SHA256SUMS")) for p in snakemake.input.scalars]
table = registry.get(snakemake.wildcards.scene).table(rows)
with replacing(snakemake.output.table) as tmp:
    table.to_csv(tmp, index=False)
write_checksum(snakemake.output.table)
print(table.T.to_string(), file=sys.stderr)
