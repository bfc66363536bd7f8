#!/usr/bin/env bash
# make test-slurm: the cluster path for real. Starts a one-node SLURM cluster on localhost
# (tools/slurm/start-local-slurm.sh installs Debian's slurm and munge packages if missing;
# root), runs tests/slurm/slurm_check.py against it (the smoke campaign through
# profiles/slurm, 2-rank MPI jobs, equal to the same campaign run locally), then stops
# exactly the daemons this script started, also when the test fails or is interrupted.
#
# Usage: tests/slurm/run.sh [pytest args...]     (from the repository, with .venv installed)
set -euo pipefail
cd "$(dirname "$0")/../.."
ROOT=$PWD
T0=$(date +%s)
log() { echo "[test-slurm] $*"; }

[ "$(id -u)" -eq 0 ] || { log "must run as root (packages, daemons, /etc/slurm)"; exit 1; }
# A controller already answering would be someone else's cluster: do not start a second one
# on its ports, and never stop it.
if command -v scontrol >/dev/null && timeout 10 scontrol ping 2>/dev/null | grep -q "is UP"; then
    conf=$(readlink /etc/slurm/slurm.conf 2>/dev/null || true)
    log "a SLURM controller is already running here (scontrol ping); stop it first" \
        "${conf:+(a local cluster: bash tools/slurm/stop-local-slurm.sh ${conf%/etc/slurm.conf})}"
    exit 1
fi

DIR=$(mktemp -d "${TMPDIR:-/tmp}/granflow-slurm.XXXXXX")
STARTED=""
stop() {
    local rc=$?
    trap - EXIT INT TERM
    set +e
    # the daemons this run started: the PID files start-local-slurm.sh wrote into our fresh DIR
    STARTED=$(cd "$DIR/pids" 2>/dev/null && for f in *.pid; do [ -s "$f" ] && echo "${f%.pid}:$(cat "$f")"; done || true)
    # jobs still on our cluster (a failed or interrupted run): cancel them, or their
    # slurmstepd would outlive slurmd
    if [ -s "$DIR/pids/slurmctld.pid" ]; then
        jobs=$(timeout 10 squeue -h -o %i 2>/dev/null || true)
        if [ -n "$jobs" ]; then
            log "cancelling jobs left on the cluster: $(echo $jobs)"
            timeout 10 scancel $jobs || true
            for _ in $(seq 30); do [ -z "$(timeout 5 squeue -h -o %i 2>/dev/null)" ] && break; sleep 1; done
        fi
    fi
    bash "$ROOT/tools/slurm/stop-local-slurm.sh" "$DIR" || true
    local alive=""
    for entry in $STARTED; do
        pid=${entry#*:}
        if [ -d "/proc/$pid" ] && [ "$(awk '{print $3}' "/proc/$pid/stat" 2>/dev/null)" != Z ]; then
            alive="$alive $entry"
        fi
    done
    if [ -n "$alive" ]; then
        log "still running after stop:$alive"; rc=1
    else
        log "stopped exactly what was started: ${STARTED:-nothing}" | tr '\n' ' '; echo
    fi
    # pytest's counts as the closing line (the daemons' stop messages came after its own)
    local last="" passed failed
    [ -s "$DIR/pytest.out" ] && last=$(grep -E '^=*.*[0-9]+ (passed|failed|errors?)\b.* in [0-9.]+s' "$DIR/pytest.out" | tail -1)
    if [ "$rc" -eq 0 ]; then
        rm -rf "$DIR"
        log "took $(( $(date +%s) - T0 )) s"
    else
        log "took $(( $(date +%s) - T0 )) s (the cluster's logs and state are kept in $DIR)"
    fi
    if [ -z "$last" ]; then
        log "pytest did not finish (exit status $rc)"
    else
        passed=$(grep -oE '[0-9]+ passed' <<<"$last" | cut -d' ' -f1)
        failed=$(( $(grep -oE '[0-9]+ failed' <<<"$last" | cut -d' ' -f1) + 0 \
                 + $(grep -oE '[0-9]+ errors?' <<<"$last" | cut -d' ' -f1) + 0 ))
        echo "test-slurm: ${passed:-0} passed, $failed failed"
    fi
    exit "$rc"
}
PYTEST_PID=""
# on a signal, end our pytest and what it started (its own process group, by its id) first:
# SIGINT makes Snakemake cancel its jobs and exit (on SIGTERM it would wait for them), then
# SIGKILL whatever is left after 20 s
interrupted() {
    if [ -n "$PYTEST_PID" ]; then
        kill -INT -- "-$PYTEST_PID" 2>/dev/null
        for _ in $(seq 20); do kill -0 -- "-$PYTEST_PID" 2>/dev/null || break; sleep 1; done
        kill -KILL -- "-$PYTEST_PID" 2>/dev/null
    fi
    exit "$1"
}
trap stop EXIT
trap 'interrupted 130' INT
trap 'interrupted 143' TERM

bash "$ROOT/tools/slurm/start-local-slurm.sh" "$DIR"
export GRANFLOW_SLURM_DIR=$DIR
export OMP_NUM_THREADS=1 PATH="$ROOT/.venv/bin:$PATH"
# in the background, so that a signal reaches the traps at once (bash defers them until a
# foreground command ends)
: >"$DIR/pytest.out"
setsid "$ROOT/.venv/bin/python" -m pytest -q -p no:cacheprovider -s "$ROOT/tests/slurm/slurm_check.py" "$@" \
    >"$DIR/pytest.out" 2>&1 &
PYTEST_PID=$!
tail -n +1 -f --pid="$PYTEST_PID" "$DIR/pytest.out" &   # shows it as it runs; ends after pytest
TAIL_PID=$!
rc=0
wait "$PYTEST_PID" || rc=$?
PYTEST_PID=""
wait "$TAIL_PID" || true
exit "$rc"
