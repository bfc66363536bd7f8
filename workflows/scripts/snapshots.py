"""Adapter: a case's particle snapshots side by side (granflow.snapshots.compose).

A case that wrote none (it stopped before its first image) gets a figure saying so, so
that the campaign and its report still finish."""
import sys
from pathlib import Path

sys.stderr = open(snakemake.log[0], "w")
from granflow import registry  # noqa: E402
from granflow.snapshots import SnapshotError, compose, placeholder  # noqa: E402

case_dir = Path(snakemake.input.params).parent
title = f"{snakemake.wildcards.scene} {snakemake.wildcards.case}"
try:
    chosen = compose(case_dir, snakemake.output.png, title, registry.get(snakemake.wildcards.scene).time_unit)
    print(f"snapshots of {', '.join(chosen)}", file=sys.stderr)
except SnapshotError as exc:
    placeholder(snakemake.output.png, title, str(exc))
    print(f"no snapshot: {exc}", file=sys.stderr)
