#!/usr/bin/env bash
# Run the stock LAMMPS funnel example (in.granregion.funnel, see its header)
# on 2 MPI ranks and list the files it wrote.
#   usage: bench/stock_example/run.sh [OUTDIR]      (default /tmp/stock_example)
#   env:   NP (default 2), LMP, MPIRUN (default: the project's .venv)
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
root="$(cd "$here/../.." && pwd)"
out="${1:-/tmp/stock_example}"
np="${NP:-2}"
lmp="${LMP:-$root/.venv/bin/lmp}"
mpirun="${MPIRUN:-$root/.venv/bin/mpirun}"
mkdir -p "$out"
cd "$out"
export OMP_NUM_THREADS=1
start=$(date +%s)
"$mpirun" -np "$np" "$lmp" -in "$here/in.granregion.funnel" \
    -log log.lammps -screen none
end=$(date +%s)
echo "LAMMPS finished in $((end - start)) s on $np ranks; files in $out:"
ls -l "$out"
