"""A restart is checked before a run resumes from it, and an OS error ends a run `interrupted`
(issue 41, defects 5 and 6). LAMMPS reads real restarts of 200 spheres (0.4 s each); the runner's
part uses stand-ins (``/bin/true`` reads any restart cleanly)."""
import errno
import json
import os
import shutil
import stat
import subprocess
import sys
import time
from pathlib import Path

import pytest

from granflow import restarts
from granflow.cli import main
from granflow.deck import render_case
from granflow.runner import CaseRunner, Tools

BIN = Path(sys.executable).parent
LMP = str(BIN / "lmp") if (BIN / "lmp").exists() else shutil.which("lmp")

#: 200 spheres under gran/hooke/history between two walls, ten steps, one restart
TINY_DECK = """units lj
atom_style sphere
comm_modify vel yes
boundary p p f
region box block 0 10 0 10 0 10
create_box 1 box
create_atoms 1 random 200 12345 NULL overlap 1.0 maxtry 100
set type 1 diameter 1.0
set type 1 density 1.0
pair_style gran/hooke/history 1000 NULL 100 NULL 0.5 1
pair_coeff * *
fix 1 all nve/sphere
fix w all wall/gran hooke/history 1000 NULL 100 NULL 0.5 1 zplane 0 10
run 10
write_restart flow_001.restart
"""


@pytest.fixture(scope="module")
def real_restart(tmp_path_factory):
    if LMP is None:
        pytest.skip("no lmp")
    d = tmp_path_factory.mktemp("tiny")
    (d / "tiny.lmp").write_text(TINY_DECK)
    subprocess.run([LMP, "-in", "tiny.lmp", "-log", "none", "-screen", "none", "-nocite"], cwd=d, check=True,
                   timeout=120)
    return d / "flow_001.restart"


@pytest.fixture
def restart(real_restart, tmp_path):
    out = tmp_path / real_restart.name
    shutil.copy(real_restart, out)
    return out


@pytest.mark.lammps
def test_lammps_reads_a_good_restart(restart):
    assert restarts.damage(restart, LMP) is None
    restarts.seal(restart)
    assert restarts.damage(restart, LMP) is None
    assert not (restart.parent / restarts.CHECK_DECK).exists(), "the dry read's deck is removed"


@pytest.mark.lammps
def test_a_truncated_restart_is_named_by_lammps_or_by_its_seal(restart):
    size = restart.stat().st_size
    data = restart.read_bytes()
    restart.write_bytes(data[:3000])  # as a full disk leaves it: no seal to compare with
    assert restarts.damage(restart, LMP) == \
        "LAMMPS cannot read it: ERROR: Incomplete or corrupted LAMMPS restart file (src/src/read_restart.cpp:1046)"
    restart.write_bytes(data)
    restarts.seal(restart)
    restart.write_bytes(data[:3000])
    assert restarts.damage(restart, LMP) == f"it has 3,000 bytes, {size:,} when it was written"
    restart.write_bytes(b"")
    assert restarts.damage(restart, LMP) == "it is empty (0 bytes)"


@pytest.mark.lammps
def test_random_bytes_in_a_restart(restart):
    """Sealed: the SHA-256 names it at once. Unsealed (a run of older code): LAMMPS's own read."""
    restarts.seal(restart)
    with open(restart, "r+b") as f:
        f.seek(restart.stat().st_size // 2)
        f.write(bytes(range(64)))
    assert restarts.damage(restart, LMP) == "its bytes changed since it was written (SHA-256 differs from its seal)"
    (restart.parent / (restart.name + restarts.SEAL_SUFFIX)).unlink()
    assert restarts.damage(restart, LMP).startswith("LAMMPS cannot read it: ERROR: ")


def test_a_read_that_does_not_end_is_damage_and_is_stopped(tmp_path):
    """LAMMPS's read of a restart with 64 os.urandom bytes in its atoms did not end in 60 s (seen
    once by hand); a stand-in that never ends shows the read is bounded and stopped with its children."""
    reader = tmp_path / "lmp"
    reader.write_text("#!/bin/sh\nsleep 300.4141 &\nwait\n")  # a child that would outlive a plain kill
    reader.chmod(0o755)
    restart = tmp_path / "flow_001.restart"
    restart.write_bytes(b"restart")
    t0 = time.monotonic()
    assert restarts.damage(restart, str(reader), timeout=1.0) == "LAMMPS's read of it did not end within 1 s"
    assert time.monotonic() - t0 < 20
    time.sleep(0.2)
    left = [p.name for p in Path("/proc").iterdir() if p.name.isdigit() and _cmdline(p) == b"sleep\x00300.4141\x00"]
    assert not left, "the read's own children are stopped too"


def _cmdline(proc: Path) -> bytes:
    try:
        return (proc / "cmdline").read_bytes()
    except OSError:
        return b""


def _run_dir(tmp_path: Path, names: list[str]) -> Path:
    run = tmp_path / "run"
    run.mkdir()
    (tmp_path / "params.json").write_text(json.dumps({"protocol": {}, "guards": {"report_overlap": 0.01}}))
    for name in names:
        (run / f"{name}.restart").write_bytes(f"restart of {name}".encode())
        restarts.seal(run / f"{name}.restart")
    return run


def test_the_restart_a_run_resumes_from_is_the_last_in_protocol_order(tmp_path):
    run = _run_dir(tmp_path, ["init", "flow_009", "flow_010", "average_001"])
    (run / "flow_011.restart.partial").write_bytes(b"")
    (run / "notes.restart").write_bytes(b"")
    assert restarts.latest(run).name == "average_001.restart"
    (run / "average_001.restart").unlink()
    assert restarts.latest(run).name == "flow_010.restart"  # flow_010 after flow_009, whatever the glob's order


def test_damaged_restarts_are_set_aside_back_to_a_good_one(tmp_path, capsys):
    run = _run_dir(tmp_path, ["init", "flow_001", "flow_002"])
    (run / "flow_002.restart").write_bytes(b"restart of flow_00X")  # same size, other bytes
    (run / "flow_001.restart").write_bytes(b"")
    runner = CaseRunner(tmp_path, tools=Tools(lmp="/bin/true", mpirun="mpirun"))
    runner._check_resume()
    err = capsys.readouterr().err
    assert "flow_002.restart is damaged: its bytes changed since it was written" in err, err
    assert "resuming from flow_001.restart (segment flow_002 runs again)" in err, err
    assert "flow_001.restart is damaged: it is empty (0 bytes)" in err, err
    assert "resuming from init.restart (segment flow_001 runs again)" in err, err
    assert sorted(p.name.split(".damaged-")[0] for p in run.glob("*.damaged-*")
                   if not p.name.endswith(restarts.SEAL_SUFFIX)) == \
        ["flow_001.restart", "flow_002.restart"]
    assert restarts.latest(run).name == "init.restart"
    (run / "init.restart").write_bytes(b"")
    runner._check_resume()
    assert "no good restart is left: the run starts from the beginning (segment init)" in capsys.readouterr().err
    assert restarts.latest(run) is None


# ------------------------------------------------------------------------------ OS errors
#: completes any segment at once: its restart where the runner asked, a log without thermo
DONE_LMP = """#!/bin/sh
case "$*" in -h) echo 'Large-scale Atomic/Molecular Massively Parallel Simulator - stand-in'; exit 0;; esac
case "$*" in *restart_check.lmp*) exit 0;; esac
while [ $# -gt 0 ]; do
  case "$1" in -log) log="$2";; -var) [ "$2" = restart_out ] && out="$3";; esac
  shift
done
echo 'LAMMPS (stand-in)' > "$log"
echo restart > "$out"
"""


@pytest.fixture(scope="module")
def rendered(channel_scene, tmp_path_factory):
    case = tmp_path_factory.mktemp("rendered") / "case"
    render_case(channel_scene, "smoke", case)
    return case


def test_a_full_disk_ends_the_run_interrupted_in_one_line(rendered, tmp_path, monkeypatch, capsys):
    """Issue 41, defect 6: a full disk during simulate gave a traceback and 'refused'. Here the disk
    fills as the runner seals init's restart."""
    case = tmp_path / "case"
    shutil.copytree(rendered, case)
    lmp = tmp_path / "lmp"
    lmp.write_text(DONE_LMP)
    lmp.chmod(lmp.stat().st_mode | stat.S_IEXEC)
    monkeypatch.setenv("GRANFLOW_LMP", str(lmp))
    monkeypatch.setenv("GRANFLOW_PROGRESS_SECONDS", "0")

    def full(path):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(path) + restarts.SEAL_SUFFIX)

    monkeypatch.setattr(restarts, "seal", full)
    assert main(["run", str(case)]) == 1
    err = capsys.readouterr().err.splitlines()
    last = err[-1]
    assert not any("Traceback" in line or "refused" in line for line in err), err
    run = case / "run"
    assert last == (f"granflow: interrupted: case: stopped by an OS error during segment init (No space left on "
                    f"device: {run / 'init.restart.sha256'}); fix its cause (free the disk) and rerun: a rerun "
                    f"resumes from the last restart, init.restart"), last
    status = json.loads((run / "status.json").read_text())
    assert status["status"] == "interrupted" and "No space left on device" in status["reason"]
    assert not (run / "thermo.csv").exists(), "the workflow's simulate job stays unfinished"
