"""Faults lose nothing: a killed run resumes; a damaged dump fails loudly and
leaves nothing downstream marked complete."""
import copy
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from granflow.deck import render_case
from granflow.runner import run_case
from granflow.scenes.channel.pipeline import channel_profile
from postproc.dump import DumpError

pytestmark = pytest.mark.lammps
BIN = Path(sys.executable).parent


def two_segment_scene(scene):
    s = copy.deepcopy(scene)
    s["protocol"]["average_unsteady"] = True
    s["rungs"]["smoke"].update(t_flow_max=5.0, t_segment=5.0, t_average=10.0, dump_interval=0.5)
    return s


@pytest.fixture(scope="module")
def finished_two_segment_run(channel_scene, tmp_path_factory) -> Path:
    """One uninterrupted run of the two-segment smoke case (phi = 0.58, one rank), shared: the
    reference of the resumed run and the source of the dump the truncation test damages (on its
    own copy). Tests only read it."""
    ref = tmp_path_factory.mktemp("faults") / "ref"
    render_case(two_segment_scene(channel_scene), "smoke", ref, {"phi_mean": 0.58})
    status = run_case(ref, 1)
    assert status["average_segments"] == 2, status
    return ref


def test_killed_run_resumes_and_agrees(channel_scene, tmp_path, finished_two_segment_run):
    scene = two_segment_scene(channel_scene)
    ref, killed = finished_two_segment_run, tmp_path / "killed"
    render_case(scene, "smoke", killed, {"phi_mean": 0.58})

    proc = subprocess.Popen([str(BIN / "granflow"), "run", str(killed), "--np", "1"],
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
    marker = killed / "run" / "average_001.restart"
    deadline = time.time() + 300
    while not marker.exists() and time.time() < deadline and proc.poll() is None:
        time.sleep(0.05)
    assert marker.exists(), "the run never reached its second averaging segment"
    # kill well inside the second averaging segment (several seconds long): once its LAMMPS has
    # started (its log exists; on a loaded machine the runner takes a while to launch it), half a second on
    second_log = killed / "run" / "logs" / "average_002.log"
    while not second_log.exists() and time.time() < deadline and proc.poll() is None:
        time.sleep(0.05)
    time.sleep(0.5)
    os.killpg(proc.pid, signal.SIGTERM)
    proc.wait(timeout=60)
    assert not (killed / "run" / "average_002.restart").exists(), "the kill came too late to test resuming"
    assert (killed / "run" / "logs" / "average_002.log").exists(), "the killed segment's log is kept"
    first_restart_mtime = marker.stat().st_mtime

    status = run_case(killed, 1)  # the rerun resumes
    assert status["average_segments"] == 2
    assert marker.stat().st_mtime == first_restart_mtime, "completed segments are not rerun"

    a, _ = channel_profile(ref)
    b, _ = channel_profile(killed)
    # statistically equal: within 3 combined standard errors in every bin
    diff = np.abs(a["u_y"] - b["u_y"])
    tol = 3 * np.hypot(a["u_y_se"], b["u_y_se"]) + 1e-9
    assert (diff <= tol).all(), pd.DataFrame({"x": a["x"], "diff": diff, "tol": tol})


def _processes_reading(path: Path) -> list[int]:
    """PIDs whose command line names ``path`` (LAMMPS ranks and launchers of that case)."""
    pids = []
    for proc in Path("/proc").iterdir():
        if proc.name.isdigit():
            try:
                if str(path) in (proc / "cmdline").read_bytes().replace(b"\0", b" ").decode(errors="replace"):
                    pids.append(int(proc.name))
            except OSError:
                pass
    return pids


def test_sigterm_to_the_runner_alone_stops_lammps_too(channel_scene, tmp_path):
    """A kill of the runner's PID only (not its process group) must not leave LAMMPS running in run/."""
    scene = two_segment_scene(channel_scene)
    scene["rungs"]["smoke"].update(t_flow_max=200.0, t_segment=200.0)  # one long flow segment
    # the kill needs a LAMMPS of the case in its flow segment, not a settled bed: 2 instead of the
    # 25 time units of settling (init was 3/4 of the test's CPU time)
    scene["protocol"]["settle_time"] = 2.0
    render_case(scene, "smoke", tmp_path, {"phi_mean": 0.58})
    proc = subprocess.Popen([str(BIN / "granflow"), "run", str(tmp_path), "--np", "1"],
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, start_new_session=True, text=True)
    log = tmp_path / "run" / "logs" / "flow_001.log"
    deadline = time.time() + 300
    while not log.exists() and time.time() < deadline and proc.poll() is None:
        time.sleep(0.05)
    assert log.exists(), "the run never reached its flow segment"
    time.sleep(1.0)
    lammps = [pid for pid in _processes_reading(tmp_path / "flow.lmp") if pid != proc.pid]
    assert lammps, "no LAMMPS process of the case was found while it ran"
    os.kill(proc.pid, signal.SIGTERM)  # the runner alone
    proc.wait(timeout=60)
    err = proc.stderr.read()
    assert proc.returncode == 130, err
    assert "a rerun resumes after the last complete segment" in err
    time.sleep(0.5)
    left = _processes_reading(tmp_path / "flow.lmp")
    for pid in left:  # never leave them running, whatever the verdict
        os.kill(pid, signal.SIGKILL)
    assert not left, "LAMMPS still ran after the runner was terminated"
    assert log.exists(), "the killed segment's log is kept"
    assert not (tmp_path / "run" / "flow_001.restart").exists()


def test_truncated_dump_fails_naming_file_and_frame(finished_two_segment_run, tmp_path):
    case = tmp_path / "case"
    shutil.copytree(finished_two_segment_run, case)  # the shared run stays whole
    channel_profile(case)  # whole, it reads
    dump = case / "run" / "dump_002.bin"
    size = dump.stat().st_size
    with open(dump, "r+b") as f:
        f.truncate(size - 1000)
    with pytest.raises(DumpError) as exc:
        channel_profile(case)
    msg = str(exc.value)
    assert "dump_002.bin" in msg and "frame" in msg and "truncated" in msg


def test_snakemake_marks_nothing_complete_after_a_failure(tmp_path, root, scenes_off, short_channel_file):
    """A damaged dump makes the analysis rule fail; its outputs do not exist afterwards."""
    results = tmp_path / "results"
    # the failure needs a dump, not a long run: the shorter smoke rung (as test_damaged_intermediates.py),
    # whose one dump is cut in half below
    short_channel_file(tmp_path / "channel.yaml")
    cfg = tmp_path / "config.yaml"
    # every other scene off (the campaign merges into config/config.yaml, where all are on)
    cfg.write_text(f"rung: smoke\nresults_dir: {results}\nscenes:\n" + scenes_off(keep=("channel",))
                   + "  channel:\n    enabled: true\n"
                   f"    scene_file: {tmp_path / 'channel.yaml'}\n    sweep:\n      W: [10]\n      phi_mean: [0.58]\n")
    case = results / "channel" / "smoke" / "W~10" / "phi~0.58"
    base = [str(BIN / "snakemake"), "--snakefile", str(root / "Snakefile"), "--directory", str(tmp_path),
            "--configfile", str(cfg), "--cores", "2"]
    sim = subprocess.run(base + [str(case / "run" / "status.json"), "--quiet", "rules"],
                         capture_output=True, text=True, timeout=600)
    assert sim.returncode == 0, sim.stderr[-2000:]
    dump = case / "run" / "dump_001.bin"
    with open(dump, "r+b") as f:
        f.truncate(dump.stat().st_size // 2)
    # the scene's table (and its checksum file), downstream of the failing analysis; `all` would add
    # the jobs that do not depend on the case (the committed record's report pages, ...), which
    # tell nothing about the failure
    table = results / "channel" / "smoke" / "table.csv"
    out = subprocess.run(base + [str(table), f"{table}.sha256"], capture_output=True, text=True, timeout=600)
    assert out.returncode != 0
    assert not (case / "analysis" / "scalars.json").exists()
    assert not table.exists()
    log = (case / "logs" / "analyse.log").read_text()
    assert "dump_001.bin" in log and "frame" in log
