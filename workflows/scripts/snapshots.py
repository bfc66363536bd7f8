"""Adapter: a case's particle snapshots side by side (granflow.snapshots.compose).

A case that wrote none (it stopped before its first image) gets a figure saying so, so
that the campaign and its report still finish. The picture is drawn under a temporary
name and moved into place when complete, then snapshots.png.sha256 beside it."""
import sys
from pathlib import Path

sys.stderr = open(snakemake.log[0], "w")
from granflow import registry  # noqa: E402
from granflow.intermediates import read_csv, read_json, replacing, report_plainly, write_checksum  # noqa: E402
from granflow.snapshots import SnapshotError, compose, placeholder  # noqa: E402

report_plainly(kept=[snakemake.output.png])
case_dir = Path(snakemake.input.params).parent
# compose reads these itself: refuse a damaged one by name first
read_json(snakemake.input.params)
read_json(snakemake.input.status, keys=("status",))
read_csv(snakemake.input.thermo)
title = f"{snakemake.wildcards.scene} {snakemake.wildcards.case}"
with replacing(snakemake.output.png) as tmp:
    try:
        chosen = compose(case_dir, tmp, title, registry.get(snakemake.wildcards.scene).time_unit)
        print(f"snapshots of {', '.join(chosen)}", file=sys.stderr)
    except SnapshotError as exc:
        placeholder(tmp, title, str(exc))
        print(f"no snapshot: {exc}", file=sys.stderr)
write_checksum(snakemake.output.png)
