"""Adapter: run (or resume) one case with LAMMPS under MPI (granflow.simulate_job.simulate).

The launcher comes from the rule's ``mpi`` resource when a workflow profile sets one
(``profiles/slurm``: ``srun --mpi=pmi2``, LAMMPS then runs on the job's ``tasks``);
without it, the venv's mpirun (or ``GRANFLOW_MPIRUN``) on ``snakemake.threads`` ranks.
The log is opened only once the case lock is held: a job refused because another process
runs the case writes nothing of that case's (its refusal goes to the terminal).
"""
import sys

from granflow.simulate_job import simulate

launcher = snakemake.resources.get("mpi")
# under an MPI launcher the scheduler allocated `tasks` ranks: LAMMPS runs on exactly those
nprocs = snakemake.resources.get("tasks") if launcher else snakemake.threads
sys.exit(simulate(snakemake.log[0], snakemake.input.params, nprocs, launcher))
