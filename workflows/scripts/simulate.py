"""Adapter: run (or resume) one case with LAMMPS under MPI.

The launcher comes from the rule's ``mpi`` resource when a workflow profile sets one
(``profiles/slurm``: ``srun --mpi=pmi2``, LAMMPS then runs on the job's ``tasks``);
without it, the venv's mpirun (or ``GRANFLOW_MPIRUN``) on ``snakemake.threads`` ranks.
"""
import sys
from pathlib import Path

sys.stderr = open(snakemake.log[0], "a")
from granflow.intermediates import read_json, report_plainly  # noqa: E402
from granflow.runner import run_case  # noqa: E402

report_plainly()
read_json(snakemake.input.params, keys=("scene",))  # the runner reads it: refuse a damaged one by name first

launcher = snakemake.resources.get("mpi")
# under an MPI launcher the scheduler allocated `tasks` ranks: LAMMPS runs on exactly those
nprocs = snakemake.resources.get("tasks") if launcher else snakemake.threads
status = run_case(Path(snakemake.input.params).parent, nprocs=nprocs, launcher=launcher)
print(f"finished: {status['status']} on {status['nprocs']} rank(s) via {status['launcher']}", file=sys.stderr)
