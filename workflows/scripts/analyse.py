"""Adapter: one case's analysis by its scene -> analysis/scalars.json, one CSV per table and
analysis/SHA256SUMS (written last: the rules that read the folder check it).

The new folder is written beside the old one and put in its place only when complete, so a
failed analysis leaves the last good one where it was."""
import json
import os
import sys
from pathlib import Path

sys.stderr = open(snakemake.log[0], "w")
os.environ.setdefault("NUMBA_NUM_THREADS", str(snakemake.threads))
from granflow import registry  # noqa: E402
from granflow.intermediates import read_csv, read_json, replacing_folder, report_plainly, write_sums  # noqa: E402

out = Path(snakemake.output.sums).parent
report_plainly(kept=[out])
# the scene reads these itself: refuse a damaged one by name first
record = read_json(snakemake.input.params, keys=("scene",))
read_json(snakemake.input.status, keys=("status", "dumps"))
read_csv(snakemake.input.thermo)
scene = registry.get(record["scene"])
tables, scalars = scene.analyse(Path(snakemake.input.params).parent)
with replacing_folder(out) as new:
    for name, table in tables.items():
        table.to_csv(new / f"{name}.csv", index=False)
    (new / "scalars.json").write_text(json.dumps(scalars, indent=2, default=float) + "\n")
    write_sums(new)
print(json.dumps(scalars, indent=2, default=float), file=sys.stderr)
