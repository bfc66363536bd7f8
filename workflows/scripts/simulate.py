"""Adapter: run (or resume) one case with LAMMPS on snakemake.threads MPI ranks."""
import sys
from pathlib import Path

sys.stderr = open(snakemake.log[0], "a")
from granflow.runner import run_case  # noqa: E402

status = run_case(Path(snakemake.input.params).parent, nprocs=snakemake.threads)
print(f"finished: {status['status']}", file=sys.stderr)
