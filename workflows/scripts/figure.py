"""Adapter: one paper-style figure over every case of a scene.

Reads each case's analysis files as listed in its SHA256SUMS (checked); the figure is drawn
under a temporary name and moved into place when complete, then <figure>.png.sha256 beside it."""
import sys
from pathlib import Path

sys.stderr = open(snakemake.log[0], "w")
from granflow import registry  # noqa: E402
from granflow.intermediates import (read_csv, read_json, replacing, report_plainly, verify_folder,  # noqa: E402
                                    write_checksum)

report_plainly(kept=[snakemake.output.figure])


def case_files(sums):
    """A case's (scalars, {table name: table}) from the files its analysis listed."""
    files = verify_folder(Path(sums).parent)
    scalars = read_json(Path(sums).with_name("scalars.json"), rebuild=sums)
    # a case that was not averaged writes empty tables
    return scalars, {p.stem: read_csv(p, rebuild=sums, allow_empty=True) for p in files if p.suffix == ".csv"}


scene = registry.get(snakemake.wildcards.scene)
figure_cases = scene.figure_cases([case_files(s) for s in snakemake.input.sums])
spec = scene.figures[snakemake.wildcards.figure]
with replacing(snakemake.output.figure) as tmp:
    spec.draw(figure_cases, tmp)
write_checksum(snakemake.output.figure)
