"""Adapter: a case's provenance record (rule provenance) or a scene's table of them (rule provenance_table)."""
import json
import sys
from pathlib import Path

sys.stderr = open(snakemake.log[0], "w")
from granflow.intermediates import read_json, report_plainly  # noqa: E402
from granflow.provenance import provenance_table, write_case_provenance  # noqa: E402

report_plainly()
if snakemake.rule == "provenance_table":
    scene_dir = Path(snakemake.output.table).parent
    records = {str(Path(p).parent.relative_to(scene_dir)): read_json(p, keys=("case",))
               for p in snakemake.input.records}
    table = provenance_table(records)
    table.to_csv(snakemake.output.table, index=False)
    print(table.T.to_string(), file=sys.stderr)
else:
    # write_case_provenance reads these itself: refuse a damaged one by name first
    read_json(snakemake.input.params)
    read_json(snakemake.input.status, keys=("status",))
    prov = write_case_provenance(Path(snakemake.input.params).parent, snakemake.output.provenance)
    print(json.dumps(prov, indent=2), file=sys.stderr)
