"""Adapter: one case's analysis by its scene -> analysis/scalars.json and one CSV per table."""
import json
import os
import sys
from pathlib import Path

sys.stderr = open(snakemake.log[0], "w")
os.environ.setdefault("NUMBA_NUM_THREADS", str(snakemake.threads))
from granflow import registry  # noqa: E402

case_dir = Path(snakemake.input.params).parent
scene = registry.get(json.loads(Path(snakemake.input.params).read_text())["scene"])
tables, scalars = scene.analyse(case_dir)
out = Path(snakemake.output.analysis)
out.mkdir(parents=True, exist_ok=True)
for name, table in tables.items():
    table.to_csv(out / f"{name}.csv", index=False)
(out / "scalars.json").write_text(json.dumps(scalars, indent=2, default=float) + "\n")
print(json.dumps(scalars, indent=2, default=float), file=sys.stderr)
