"""The cluster path, for real: the smoke campaign through ``profiles/slurm`` on a SLURM cluster
equals the same campaign run locally (same seeds, same 2 MPI ranks per case).

Not part of ``make test`` (pytest collects ``test_*.py`` only): ``make test-slurm`` starts a
one-node cluster on localhost (``tools/slurm/start-local-slurm.sh``), runs this file with
``pytest tests/slurm/slurm_check.py`` and stops exactly the daemons it started
(``tests/slurm/run.sh``). Run by hand, it needs a cluster answering ``sinfo`` with an idle
partition ``$GRANFLOW_SLURM_PARTITION`` (default ``debug``).

The campaign: one channel case (W = 10, phi = 0.57) and one chute case (24 deg, 30 time
units of flow) at the smoke rung, each on 2 ranks, averaged although a smoke run is not
steady (as in tests/integration/test_channel_dag.py). LAMMPS is deterministic for a given
binary, input, seed and rank count (same domain decomposition, same order of
floating-point sums), so every number of both tables must be *equal*, not close. This is
the one place where granflow compares LAMMPS output exactly: the claim tested is not a
physical one but that both paths ran the same computation; a difference means they did
not (ranks, launcher, deck, binary). Only the columns that measure the machine may differ.
"""
import json
import os
import re
import shutil
import subprocess
import sys
import time
from pathlib import Path

import pandas as pd
import pytest
import yaml

pytestmark = pytest.mark.lammps
BIN = Path(sys.executable).parent
RANKS = 2
PARTITION = os.environ.get("GRANFLOW_SLURM_PARTITION", "debug")
#: the smoke campaign's scenes and sweep points
SWEEPS = {"channel": "      W: [10]\n      phi_mean: [0.57]\n", "chute": "      theta_deg: [24]\n"}
#: smoke-rung knobs changed for time: the chute flows 30 instead of up to 200 time units (3 of 20
#: segments; the runner's segments are what this test needs, not a steady chute)
KNOBS = {"channel": {}, "chute": {"t_flow_max": 30.0}}
#: columns that measure the machine, not the physics: the only ones two runs may differ in
MACHINE = {"matom_step_per_s", "loop_seconds", "cpu_seconds", "wall_seconds", "peak_rss_mb", "host", "launcher"}


def campaign(work: Path, root: Path, scenes_off) -> Path:
    """The smoke campaign's config in ``work`` (results in ``work/results``)."""
    work.mkdir(parents=True, exist_ok=True)
    lines = ["rung: smoke", f"results_dir: {work / 'results'}", "scenes:"]
    text = scenes_off(keep=tuple(SWEEPS))
    for name, sweep in SWEEPS.items():
        scene = yaml.safe_load((root / "config" / "scenes" / f"{name}.yaml").read_text())
        # smoke runs are too short to be judged steady: average anyway, so that the table has numbers
        scene["protocol"]["average_unsteady"] = True
        scene["rungs"]["smoke"].update(KNOBS[name])
        (work / f"{name}.yaml").write_text(yaml.safe_dump(scene, sort_keys=False))
        text += f"  {name}:\n    enabled: true\n    scene_file: {work / f'{name}.yaml'}\n    sweep:\n{sweep}"
    cfg = work / "config.yaml"
    cfg.write_text("\n".join(lines) + "\n" + text)
    return cfg


def cluster_profile(root: Path, out: Path) -> Path:
    """profiles/slurm as committed, with only what a user fills in (partition, no account)
    and this cluster's facts (no accounting: squeue for status; fast first poll; logs kept;
    no job asks for more CPUs than the node has)."""
    profile = yaml.safe_load((root / "profiles" / "slurm" / "config.yaml").read_text())
    profile["default-resources"]["slurm_partition"] = PARTITION
    profile["default-resources"].pop("slurm_account", None)
    cpus = int(subprocess.run(["sinfo", "-h", "-p", PARTITION, "-o", "%c"], capture_output=True, text=True,
                              check=True).stdout.split()[0])
    profile["set-threads"] = {rule: min(n, cpus) for rule, n in profile["set-threads"].items()}
    profile.update({"slurm-status-command": "squeue", "slurm-init-seconds-before-status-checks": 2,
                    "slurm-keep-successful-logs": True, "slurm-logdir": str(out.parent / "slurm-logs")})
    out.mkdir(parents=True, exist_ok=True)
    (out / "config.yaml").write_text(yaml.safe_dump(profile, sort_keys=False))
    return out


def snakemake(root: Path, work: Path, cfg: Path, *args: str, timeout: int = 1500):
    cmd = [str(BIN / "snakemake"), "--snakefile", str(root / "Snakefile"), "--directory", str(work),
           "--configfile", str(cfg), *args]
    t0 = time.time()
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout,
                          env=dict(os.environ, OMP_NUM_THREADS="1", PATH=f"{BIN}:{os.environ['PATH']}"))
    print(f"{' '.join(args[:4])}...: {time.time() - t0:.0f} s")
    assert proc.returncode == 0, proc.stdout[-4000:] + proc.stderr[-6000:]
    return proc


@pytest.fixture(scope="module")
def runs(tmp_path_factory, root, scenes_off):
    if shutil.which("sbatch") is None or subprocess.run(["sinfo", "-h", "-p", PARTITION, "-o", "%a"],
                                                        capture_output=True, text=True).stdout.strip() != "up":
        pytest.fail(f"no SLURM partition {PARTITION!r} up here: run `make test-slurm`, which starts one")
    base = tmp_path_factory.mktemp("slurm_campaign")
    local, cluster = base / "local", base / "slurm"
    # locally: today's path (the venv's mpirun, ranks = the rule's threads), forced to 2 ranks
    snakemake(root, local, campaign(local, root, scenes_off), "--cores", "2",
              "--set-threads", f"simulate={RANKS}", "--quiet", "rules")
    # through the profile: sbatch, srun --mpi=pmi2 -n <tasks>; a smoke case asks for 2 tasks
    # (one rank by its size, and the SLURM executor's MPI jobs have at least 2)
    profile = cluster_profile(root, base / "profile")
    proc = snakemake(root, cluster, campaign(cluster, root, scenes_off), "--workflow-profile", str(profile))
    return {"local": local / "results", "slurm": cluster / "results", "log": proc.stdout + proc.stderr,
            "slurm_logs": base / "slurm-logs"}


def test_profile_placeholders_are_refused_by_name(tmp_path, root, scenes_off):
    """The committed profile, unedited, does not submit anywhere: sbatch names the placeholder."""
    cfg = campaign(tmp_path, root, scenes_off)
    target = tmp_path / "results" / "chute" / "smoke" / "theta~24" / "params.json"
    cmd = [str(BIN / "snakemake"), "--snakefile", str(root / "Snakefile"), "--directory", str(tmp_path),
           "--configfile", str(cfg), "--workflow-profile", str(root / "profiles" / "slurm"),
           "--slurm-status-command", "squeue", "--slurm-init-seconds-before-status-checks", "2", "--retries", "0",
           str(target)]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
    assert proc.returncode != 0 and "SET-YOUR-PARTITION" in proc.stdout + proc.stderr, proc.stderr[-3000:]
    assert not target.exists()


def cases(results: Path) -> dict[str, Path]:
    return {str(p.parent.parent.relative_to(results)): p.parent.parent
            for p in sorted(results.glob("*/smoke/**/run/status.json"))}


def test_jobs_ran_on_the_cluster_with_srun(runs):
    """Every simulation was an sbatch job whose LAMMPS ran as `srun --mpi=pmi2 -n 2`."""
    submitted = re.findall(r"SLURM jobid (\d+)", runs["log"])
    found = cases(runs["slurm"])
    assert len(found) == len(SWEEPS)
    assert len(submitted) >= len(found), runs["log"][-3000:]
    for case, path in found.items():
        status = json.loads((path / "run" / "status.json").read_text())
        assert status["nprocs"] == RANKS, case
        assert Path(status["launcher"].split()[0]).name == "srun", status["launcher"]
        assert status["launcher"].endswith(f"--mpi=pmi2 -n {RANKS}"), status["launcher"]
        assert status["host"]
        # LAMMPS itself says how many ranks it ran on
        init = (path / "run" / "logs" / "init.log").read_text()
        assert f"on {RANKS} procs" in init
    assert len(list((runs["slurm_logs"] / "rule_simulate").rglob("*.log"))) == len(SWEEPS), "job logs kept"
    # each simulate job declared the case's resources and the profile's launcher
    declared = re.findall(r"rule simulate:.*?resources: ([^\n]*)", runs["log"], re.S)
    assert len(declared) == len(SWEEPS), runs["log"][-3000:]
    for res in declared:
        assert f"tasks={RANKS}," in res and "mpi=srun --mpi=pmi2" in res, res
        assert re.search(r"mem_mb=[1-9]\d*,", res) and re.search(r"runtime=[1-9]\d*,", res), res
    # SLURM gave each simulate job 2 CPUs, and LAMMPS ran as job steps inside those allocations
    slurm_dir = os.environ.get("GRANFLOW_SLURM_DIR")
    if slurm_dir:
        slurmctld = (Path(slurm_dir) / "log" / "slurmctld.log").read_text()
        slurmd = (Path(slurm_dir) / "log" / "slurmd.log").read_text()
        jobs = re.findall(r"SLURM jobid (\d+) \(log: [^)]*rule_simulate", runs["log"])
        assert len(jobs) == len(SWEEPS)
        for job in jobs:
            # the main scheduler logs the CPUs it allocates; the backfill scheduler logs only the start
            allocated = re.search(rf"Allocate JobId={job} NodeList=\S+ #CPUs=(\d+) ", slurmctld)
            started = re.search(rf"backfill: _start_job: Started JobId={job} ", slurmctld)
            assert allocated or started, f"slurmctld never started job {job}"
            if allocated:
                assert int(allocated.group(1)) == RANKS, job
            assert f"launch task StepId={job}.0 " in slurmd, f"no srun step in simulate job {job}"


def test_local_run_used_the_venv_mpirun(runs):
    for case, path in cases(runs["local"]).items():
        status = json.loads((path / "run" / "status.json").read_text())
        assert status["nprocs"] == RANKS and status["launcher"] == f"{BIN / 'mpirun'} -np {RANKS}", status


@pytest.mark.parametrize("scene", sorted(SWEEPS))
def test_headline_numbers_equal_local_run(runs, scene):
    """Same binary, seeds and ranks: every column of the scene's table is equal, machine columns aside."""
    a = pd.read_csv(runs["local"] / scene / "smoke" / "table.csv")
    b = pd.read_csv(runs["slurm"] / scene / "smoke" / "table.csv")
    assert list(a.columns) == list(b.columns) and len(a) == len(b) == 1
    numeric = [c for c in a.columns if c not in MACHINE and pd.api.types.is_numeric_dtype(a[c])]
    assert len(numeric) >= 10, list(a.columns)
    diff = {c: (a[c].iloc[0], b[c].iloc[0]) for c in a.columns
            if not (a[c].iloc[0] == b[c].iloc[0] or (pd.isna(a[c].iloc[0]) and pd.isna(b[c].iloc[0])))}
    physics = {c: d for c, d in diff.items() if c not in MACHINE}
    assert not physics, f"{scene}: columns that differ between the local and the SLURM run: {physics}"
    print(f"{scene}: {len(a.columns) - len(diff)} of {len(a.columns)} columns equal ({len(numeric)} numbers, "
          f"e.g. " + ", ".join(f"{c} = {a[c].iloc[0]:.6g}" for c in numeric[2:5])
          + f"); differ: {', '.join(diff) or 'none'}")
