"""Adapter: a case's provenance record (rule provenance) or a scene's table of them (rule provenance_table)."""
import json
import sys
from pathlib import Path

sys.stderr = open(snakemake.log[0], "w")
from granflow.provenance import provenance_table, write_case_provenance  # noqa: E402

if snakemake.rule == "provenance_table":
    scene_dir = Path(snakemake.output.table).parent
    records = {str(Path(p).parent.relative_to(scene_dir)): json.loads(Path(p).read_text())
               for p in snakemake.input.records}
    table = provenance_table(records)
    table.to_csv(snakemake.output.table, index=False)
    print(table.T.to_string(), file=sys.stderr)
else:
    prov = write_case_provenance(Path(snakemake.input.params).parent, snakemake.output.provenance)
    print(json.dumps(prov, indent=2), file=sys.stderr)
