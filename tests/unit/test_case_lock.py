"""`granflow run` on one case at a time, within its particles' worth of ranks, and an interrupted
run that says so (issue 31). No LAMMPS: the lock holder is a plain process, and LAMMPS is a
stand-in started by the real mpirun that writes the start of a log and waits to be signalled."""
import json
import os
import shutil
import signal
import socket
import stat
import subprocess
import sys
import time
from pathlib import Path

import pytest

from granflow.caselock import LOCK_NAME, CaseLocked, case_lock
from granflow.cli import main
from granflow.deck import render_case
from granflow.interrupts import launch_signal
from granflow.preflight import MIN_PARTICLES_PER_RANK, PreflightError, check_ranks

BIN = Path(sys.executable).parent

#: a stand-in for lmp: LAMMPS's banner for ``-h`` (the runner asks which LAMMPS it is), a clean exit
#: for the dry read of a restart, else the start of a log where the runner asked for it, then a wait
#: that only a signal ends, dying of it as LAMMPS (which installs no handlers) does
FAKE_LMP = """#!{python}
import signal, sys, time
if sys.argv[1:] == ["-h"]:
    sys.exit(print("Large-scale Atomic/Molecular Massively Parallel Simulator - stand-in"))
if "restart_check.lmp" in sys.argv:  # the dry read of a restart before a resume: it reads
    sys.exit(0)
signal.signal(signal.SIGINT, signal.SIG_DFL)
signal.signal(signal.SIGTERM, signal.SIG_DFL)
log = sys.argv[sys.argv.index("-log") + 1]
with open(log, "w") as f:
    f.write("LAMMPS (stand-in)\\n")
time.sleep(120)
"""


@pytest.fixture(scope="module")
def rendered(channel_scene, tmp_path_factory):
    """The smoke channel (450 particles), rendered once."""
    case = tmp_path_factory.mktemp("rendered") / "case"
    render_case(channel_scene, "smoke", case)
    return case


@pytest.fixture
def case(rendered, tmp_path):
    out = tmp_path / "case"
    shutil.copytree(rendered, out)
    return out


def _files(run: Path) -> dict:
    """Every file under ``run`` with its bytes and modification time."""
    return {p.relative_to(run).as_posix(): (p.read_bytes(), p.stat().st_mtime_ns)
            for p in sorted(run.rglob("*")) if p.is_file()}


def _earlier_run(case: Path) -> Path:
    """A run that got as far as init: its parameter stamp, restart, status and thermo."""
    run = case / "run"
    (run / "logs").mkdir(parents=True)
    shutil.copy(case / "params.json", run / "params.json")
    (run / "init.restart").write_bytes(b"restart of init")
    (run / "status.json").write_text('{"status": "unknown"}\n')
    (run / "thermo.csv").write_text("Step\n0\n")
    return run


# ------------------------------------------------------------------------------ the lock
def test_second_run_is_refused_naming_the_first_and_touches_nothing(case, capsys):
    run = _earlier_run(case)
    holder = subprocess.Popen(
        [sys.executable, "-c", "import sys, time\nfrom granflow.caselock import case_lock\n"
         "with case_lock(sys.argv[1]):\n    print('locked', flush=True)\n    time.sleep(120)\n", str(case)],
        stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout.readline().strip() == "locked"
        before = _files(run)
        t0 = time.monotonic()
        assert main(["run", str(case)]) == 2
        assert time.monotonic() - t0 < 5, "refused at once, not after waiting for the lock"
        err = capsys.readouterr().err
        assert err.startswith("granflow: refused: ") and err.count("\n") == 1, err
        assert f"is being run by process {holder.pid} on {socket.gethostname()}, started " in err, err
        assert "a second run would write over its restart files and run/status.json" in err, err
        assert "Traceback" not in err
        assert _files(run) == before, "the refused run changed files under run/"
    finally:
        holder.kill()
        holder.wait()


def test_stale_lock_of_a_killed_run_never_blocks(case):
    holder = subprocess.Popen(
        [sys.executable, "-c", "import sys, time\nfrom granflow.caselock import case_lock\n"
         "with case_lock(sys.argv[1]):\n    print('locked', flush=True)\n    time.sleep(120)\n", str(case)],
        stdout=subprocess.PIPE, text=True)
    assert holder.stdout.readline().strip() == "locked"
    holder.send_signal(signal.SIGKILL)  # no clean-up runs: the lock file stays, naming it
    holder.wait()
    lock = case / "run" / LOCK_NAME
    assert json.loads(lock.read_text())["pid"] == holder.pid
    with case_lock(case) as path:
        assert path == lock and json.loads(lock.read_text())["pid"] == os.getpid()
        with pytest.raises(CaseLocked, match=f"process {os.getpid()} on"):  # and it is held now
            with case_lock(case):
                pass
    with case_lock(case):  # released when the block ends
        pass


def test_the_lock_stays_put_when_a_stale_run_is_moved_aside(case, monkeypatch):
    """A run of other parameters is kept aside as run.stale-*; the lock file of the run that
    moves it stays in run/, so a third run still finds it held."""
    from granflow.runner import CaseRunner

    run = _earlier_run(case)
    (run / "params.json").write_text("{}\n")  # other parameters
    with case_lock(case):
        CaseRunner(case)._guard_stale()
        (stale,) = case.glob("run.stale-*")
        assert (stale / "init.restart").exists() and not (stale / LOCK_NAME).exists()
        assert (run / LOCK_NAME).exists() and not (run / "init.restart").exists()
        with pytest.raises(CaseLocked):
            with case_lock(case):
                pass


# ------------------------------------------------------------------------------ --np
def test_np_beyond_the_particles_is_refused_before_anything_runs(case, capsys):
    assert main(["run", str(case), "--np", "10000"]) == 2
    err = capsys.readouterr().err
    assert err == ("granflow: refused: --np 10000 is not allowed: the case has 450 particles, 0.045 per rank; "
                   "allowed at most 4 ranks (at least 100 particles per rank)\n"), err
    assert not (case / "run").exists(), "nothing is written"


def test_np_limit_counts_particles_per_rank():
    assert MIN_PARTICLES_PER_RANK == 100
    check_ranks({"parameters": {"n_particles": 450}}, 4)  # 112 per rank
    with pytest.raises(PreflightError, match="--np 5 is not allowed: .* allowed at most 4 ranks"):
        check_ranks({"parameters": {"n_particles": 450}}, 5)
    check_ranks({"parameters": {"n_particles": 150}}, 1)  # a tiny case still runs on one rank
    with pytest.raises(PreflightError, match="22,575 particles"):  # a heap: the estimate at the end of filling
        check_ranks({"parameters": {}, "n_particles_estimate": 22575}, 226)
    check_ranks({"parameters": {}}, 64)  # no count recorded: not checked


# ------------------------------------------------------------------------------ interrupted
@pytest.fixture
def fake_lmp(tmp_path):
    path = tmp_path / "bin" / "lmp"
    path.parent.mkdir()
    path.write_text(FAKE_LMP.format(python=sys.executable))
    path.chmod(path.stat().st_mode | stat.S_IEXEC)
    return path


def _lammps_of(case: Path) -> list[int]:
    """PIDs whose command line names a deck of ``case`` (launchers and stand-ins)."""
    pids = []
    for proc in Path("/proc").iterdir():
        if proc.name.isdigit() and int(proc.name) != os.getpid():
            try:
                if f"{case}/" in (proc / "cmdline").read_bytes().replace(b"\0", b" ").decode(errors="replace"):
                    pids.append(int(proc.name))
            except OSError:
                pass
    return pids


def _interrupt(case: Path, fake_lmp: Path, segment: str, send, ignore_sigint: bool = False):
    """Start `granflow run CASE`, wait until the stand-in runs ``segment``, ``send(pid)`` a signal;
    returns (exit status, stderr, status.json)."""
    env = dict(os.environ, GRANFLOW_LMP=str(fake_lmp), GRANFLOW_PROGRESS_SECONDS="0")
    ignore = (lambda: signal.signal(signal.SIGINT, signal.SIG_IGN)) if ignore_sigint else None
    proc = subprocess.Popen([str(BIN / "granflow"), "run", str(case)], env=env, stdout=subprocess.DEVNULL,
                            stderr=subprocess.PIPE, text=True, start_new_session=True, preexec_fn=ignore)
    log = case / "run" / "logs" / f"{segment}.log"
    try:
        deadline = time.time() + 60
        while not log.exists() and proc.poll() is None and time.time() < deadline:
            time.sleep(0.05)
        assert log.exists(), f"the stand-in never ran {segment}: {proc.stderr.read() if proc.poll() is not None else ''}"
        time.sleep(0.3)
        send(proc.pid)
        _, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
    time.sleep(0.3)
    left = _lammps_of(case)
    for pid in left:
        os.kill(pid, signal.SIGKILL)
    assert not left, "LAMMPS (the stand-in) still ran after the run was interrupted"
    return proc.returncode, err, json.loads((case / "run" / "status.json").read_text())


def test_sigint_to_a_background_run_says_interrupted(case, fake_lmp):
    """The issue's case: a run started in the background ignores SIGINT; Ctrl-C's SIGINT to the
    process group reached mpirun, which ended its ranks and exited 2 ('LAMMPS exited with status 2 and
    no ERROR line' before issue 31). Now: status interrupted, the log kept, a rerun resumes from init.
    Since issue 41 LAMMPS runs in its own process group, which the SIGINT does not reach: the runner
    takes it (though started ignoring it) and stops LAMMPS."""
    run = _earlier_run(case)
    restart = (run / "init.restart").read_bytes()
    rc, err, status = _interrupt(case, fake_lmp, "flow_001", lambda pid: os.killpg(pid, signal.SIGINT),
                                 ignore_sigint=True)
    assert rc == 130, err
    assert "granflow: interrupted" in err and "exited with status" not in err, err
    assert status["status"] == "interrupted", status
    reason = status["reason"]
    assert reason.startswith("interrupted by SIGINT (received by the runner) during segment flow_001"), reason
    assert f"its log is kept: {run / 'logs' / 'flow_001.log'}" in reason, reason
    assert reason.endswith("a rerun resumes from the last restart, init.restart"), reason
    assert (run / "logs" / "flow_001.log").read_text().startswith("LAMMPS (stand-in)"), "the log is kept"
    assert (run / "init.restart").read_bytes() == restart and not list(run.glob("flow_*.restart*"))
    assert status["flow_segments"] == 0 and status["average_segments"] == 0
    # the workflow's simulate job (outputs status.json and thermo.csv) stays unfinished
    assert not (run / "thermo.csv").exists()


def test_ctrl_c_before_any_segment_finished(case, fake_lmp):
    rc, err, status = _interrupt(case, fake_lmp, "init", lambda pid: os.killpg(pid, signal.SIGINT))
    assert rc == 130, err
    assert status["status"] == "interrupted", status
    assert status["reason"].startswith("interrupted by SIGINT (received by "), status["reason"]
    assert "during segment init" in status["reason"]
    assert status["reason"].endswith("no segment had finished: a rerun starts from the beginning")
    assert (case / "run" / "logs" / "init.log").exists()


def test_sigterm_to_the_runner_alone_says_interrupted(case, fake_lmp):
    _earlier_run(case)
    rc, err, status = _interrupt(case, fake_lmp, "flow_001", lambda pid: os.kill(pid, signal.SIGTERM))
    assert rc == 130, err
    assert status["status"] == "interrupted"
    assert status["reason"].startswith("interrupted by SIGTERM (received by the runner) during segment flow_001")


def test_launch_signal_reads_what_launchers_report():
    hydra = "===\nYOUR APPLICATION TERMINATED WITH THE EXIT STRING: Interrupt (signal 2)\n"
    assert launch_signal(2, hydra) == signal.SIGINT  # MPICH mpirun: exits 2, names the signal
    assert launch_signal(15, hydra.replace("Interrupt (signal 2)", "Terminated (signal 15)")) == signal.SIGTERM
    assert launch_signal(-signal.SIGTERM, "") == signal.SIGTERM  # the launcher itself killed
    assert launch_signal(128 + signal.SIGINT, "") == signal.SIGINT  # a shell's or srun's 130
    assert launch_signal(128 + signal.SIGKILL, "") == signal.SIGKILL  # the runner calls it a failure
    assert launch_signal(1, "ERROR: Lost atoms") is None
    assert launch_signal(2, "") is None  # a bare 2 says nothing of a signal


def test_kill_9_of_the_runner_takes_its_lammps_with_it(case, fake_lmp):
    """Issue 41, defect 8: kill -9 of the runner left mpirun and lmp running as orphans, the lock
    released, and a rerun started a second LAMMPS on the case. Now LAMMPS leads its own process
    group (a signal to the runner's group does not reach it) and its launcher gets SIGTERM from the
    kernel when the runner dies."""
    env = dict(os.environ, GRANFLOW_LMP=str(fake_lmp), GRANFLOW_PROGRESS_SECONDS="0")
    proc = subprocess.Popen([str(BIN / "granflow"), "run", str(case)], env=env, stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL, start_new_session=True)
    log = case / "run" / "logs" / "init.log"
    try:
        deadline = time.time() + 60
        while not log.exists() and proc.poll() is None and time.time() < deadline:
            time.sleep(0.05)
        assert log.exists(), "the stand-in never ran init"
        lammps = _lammps_of(case)
        assert lammps and all(os.getpgid(pid) != proc.pid for pid in lammps), "LAMMPS leads its own group"
    finally:
        os.kill(proc.pid, signal.SIGKILL)
        proc.wait()
    deadline = time.time() + 20  # mpirun passes SIGTERM on to its ranks
    while _lammps_of(case) and time.time() < deadline:
        time.sleep(0.1)
    left = _lammps_of(case)
    for pid in left:
        os.kill(pid, signal.SIGKILL)
    assert not left, "mpirun or LAMMPS outlived the runner killed with SIGKILL"


def test_a_job_refused_by_the_lock_writes_nothing_of_the_running_case(case, fake_lmp, capsys, monkeypatch):
    """Issue 41, defect 7: a second Snakemake with --nolock deletes the running job's log (as Snakemake
    does before any job); its own simulate job was refused with a traceback written there, and the
    first, successful job's simulate.log was lost. Now the refused job writes no file and says so in
    one line on the terminal; the running job puts its log back when it ends."""
    from granflow.simulate_job import simulate

    log = case / "logs" / "simulate.log"
    env = dict(os.environ, GRANFLOW_LMP=str(fake_lmp), GRANFLOW_PROGRESS_SECONDS="0")
    first = subprocess.Popen(
        [sys.executable, "-c", "import sys\nfrom granflow.simulate_job import simulate\n"
         "sys.exit(simulate(sys.argv[1], sys.argv[2], 1))", str(log), str(case / "params.json")],
        env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True, start_new_session=True)
    try:
        deadline = time.time() + 60
        while not (case / "run" / "logs" / "init.log").exists() and first.poll() is None and time.time() < deadline:
            time.sleep(0.05)
        assert (case / "run" / "logs" / "init.log").exists(), first.stderr.read() if first.poll() is not None else ""
        assert "particles" in log.read_text()
        log.unlink()  # what the second Snakemake does before its job starts
        before = _files(case / "run")
        monkeypatch.setenv("GRANFLOW_LMP", str(fake_lmp))
        assert simulate(log, case / "params.json", 1) == 2
        err = capsys.readouterr().err
        assert err.startswith("granflow: refused: ") and err.count("\n") == 1, err
        assert f"is being run by process {first.pid} on" in err and "Traceback" not in err, err
        assert not log.exists(), "the refused job wrote the running case's log"
        assert _files(case / "run") == before, "the refused job changed files under run/"
        os.kill(first.pid, signal.SIGTERM)  # the first job ends (interrupted here), and puts its log back
        assert first.wait(timeout=60) == 130, first.stderr.read()
    finally:
        if first.poll() is None:
            os.killpg(first.pid, signal.SIGKILL)
            first.wait()
    text = log.read_text()
    assert "particles" in text and text.rstrip().endswith("a rerun resumes after the last complete segment"), text
    assert "granflow: refused" not in text and "Traceback" not in text


# ------------------------------------------------------------------------------ damaged restarts
def test_a_damaged_restart_is_set_aside_and_the_run_resumes_before_it(case, fake_lmp):
    """Issue 41, defect 5: 64 random bytes in the last restart ran on, and the case ended 'unstable:
    lost atoms'. Now the restart's bytes differ from its seal: it is set aside, named, and the run
    resumes from init (the stand-in runs flow_001 again)."""
    from granflow.restarts import seal

    run = _earlier_run(case)
    seal(run / "init.restart")
    flow = run / "flow_001.restart"
    flow.write_bytes(b"restart of flow_001, " * 20)
    seal(flow)
    with open(flow, "r+b") as f:
        f.seek(100)
        f.write(os.urandom(64))
    rc, err, status = _interrupt(case, fake_lmp, "flow_001", lambda pid: os.kill(pid, signal.SIGTERM))
    assert rc == 130 and status["status"] == "interrupted", err
    assert ("flow_001.restart is damaged: its bytes changed since it was written (SHA-256 differs from its "
            "seal); set aside as flow_001.restart.damaged-") in err, err
    assert "resuming from init.restart (segment flow_001 runs again)" in err, err
    (aside,) = (p for p in run.glob("flow_001.restart.damaged-*") if not p.name.endswith(".sha256"))
    assert aside.stat().st_size == 420 and not flow.exists() and aside.with_name(aside.name + ".sha256").exists()
    assert status["reason"].endswith("a rerun resumes from the last restart, init.restart"), status["reason"]
