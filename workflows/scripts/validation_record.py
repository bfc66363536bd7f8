"""Adapter: one scene's validation record (granflow.validation.write_record on Scene.validation; a
scene that declares none gets a record of its cases that says so)."""
import sys
from pathlib import Path

sys.stderr = open(snakemake.log[0], "w")
from granflow import registry, validation  # noqa: E402
from granflow.intermediates import read_csv, read_json, report_plainly, verify_checksum, verify_folder  # noqa: E402

report_plainly()
name = snakemake.wildcards.scene
scene = registry.get(name)
cases = {rel: Path(path) for rel, path in snakemake.params.cases.items()}
# the scene's validation reads these itself: refuse a damaged one by name first
read_csv(verify_checksum(snakemake.input.table))
read_csv(snakemake.input.provenance)
for figure in snakemake.input.figures:
    verify_checksum(figure)
for sums in snakemake.input.analyses:
    verify_folder(Path(sums).parent)
for path in cases.values():
    read_json(path / "params.json", keys=("scene",))
    read_json(path / "run" / "status.json", keys=("status",))
    read_csv(path / "run" / "thermo.csv")
    if (path / "provenance.json").exists():
        read_json(path / "provenance.json", keys=("case",))
result = validation.scene_validation(scene, Path(snakemake.params.scene_dir), cases)
summary = validation.write_record(name, snakemake.params.rung, result, cases,
                                  Path(snakemake.params.scene_dir) / "figures",
                                  Path(snakemake.output.summary).parent, paper=scene.paper)
print(f"{name}: {result.note}" if result.note else validation.readme_table([summary]), file=sys.stderr)
