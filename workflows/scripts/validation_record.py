"""Adapter: one scene's validation record (granflow.validation.write_record on Scene.validation)."""
import sys
from pathlib import Path

sys.stderr = open(snakemake.log[0], "w")
from granflow import registry, validation  # noqa: E402

name = snakemake.wildcards.scene
scene = registry.get(name)
cases = {rel: Path(path) for rel, path in snakemake.params.cases.items()}
result = scene.validation(Path(snakemake.params.scene_dir), cases)
summary = validation.write_record(name, snakemake.params.rung, result, cases,
                                  Path(snakemake.params.scene_dir) / "figures",
                                  Path(snakemake.output.summary).parent, paper=scene.paper)
print(validation.readme_table([summary]), file=sys.stderr)
