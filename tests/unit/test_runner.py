"""Runner pieces that need no LAMMPS: log parsing, error lines, resumable thermo."""
import json
import shutil

import pandas as pd

from granflow.runner import CaseRunner, error_line, loop_cost, parse_thermo, performance


def test_parse_thermo_and_performance(root):
    log = root / "tests" / "data" / "segment_two_runs.log"
    th = parse_thermo(log)
    assert list(th["Step"]) == [0, 2, 4]
    assert th["f_fwavg"].iloc[-1] == 0.5
    assert performance(log.read_text()) == [0.171]
    # "Loop time of 0.01 on 1 procs for 4 steps with 428 atoms": wall seconds and atom-steps
    assert loop_cost(log.read_text()) == (0.01, 4 * 428)


def test_loop_cost_sums_the_short_runs_of_run_every():
    text = ("Loop time of 0.5 on 2 procs for 50 steps with 100 atoms\n"
            "Loop time of 0.25 on 2 procs for 50 steps with 120 atoms\n")
    assert loop_cost(text) == (0.75, 50 * 100 + 50 * 120)


def test_error_line_quotes_lammps_error_not_echoed_commands(root):
    text = (root / "tests" / "data" / "segment_two_runs.log").read_text()
    assert error_line(text) is None  # an echoed `print "GRANFLOW_ERROR..."` command is not an error
    bad = text + "ERROR: Lost atoms: original 428 current 403 (src/thermo.cpp:494)\n"
    assert error_line(bad).startswith("ERROR: Lost atoms")
    assert error_line("GRANFLOW_ERROR: packed column top 9.9 reaches ...\n").startswith("GRANFLOW_ERROR")


def test_thermo_ignores_killed_segments(root, tmp_path):
    """A segment killed part-way (log but no restart) must not feed steady detection."""
    (tmp_path / "params.json").write_text(json.dumps({"protocol": {}}))
    logs = tmp_path / "run" / "logs"
    logs.mkdir(parents=True)
    src = root / "tests" / "data" / "segment_two_runs.log"
    for name in ("flow_001", "flow_002"):
        shutil.copy(src, logs / f"{name}.log")
    (tmp_path / "run" / "flow_001.restart").write_text("complete")
    runner = CaseRunner(tmp_path)
    th = runner.thermo("flow")
    assert set(th["segment"]) == {"flow_001"}
    assert runner.thermo("flow", upto=0).empty
    assert isinstance(th, pd.DataFrame) and len(th) == 3


def test_cpu_of_lammps_descendants_is_recorded_per_segment(tmp_path):
    """The runner charges a segment the CPU time of every process under mpirun (here a fake
    mpirun whose child burns 0.3 CPU-seconds), and keeps it beside the segment's log."""
    import stat
    import sys

    from granflow.runner import Tools

    fake = tmp_path / "mpirun"
    fake.write_text(
        f"#!{sys.executable}\n"
        "import subprocess, sys\n"
        "burn = 'import time\\nwhile time.process_time() < 0.3: pass'\n"
        "subprocess.run([sys.executable, '-c', burn], check=True)\n"
    )
    fake.chmod(fake.stat().st_mode | stat.S_IEXEC)
    (tmp_path / "params.json").write_text(json.dumps({"protocol": {}}))
    (tmp_path / "run").mkdir()
    runner = CaseRunner(tmp_path, tools=Tools(lmp="lmp", mpirun=str(fake)))
    runner._lammps("init.lmp", "init", {})
    usage = json.loads((tmp_path / "run" / "logs" / "init.usage.json").read_text())
    assert usage["cpu_s"] >= 0.3 and usage["peak_rss_mb"] > 0 and usage["wall_s"] >= usage["cpu_s"] * 0.5
    total = runner.usage()
    assert total["cpu_seconds"] == usage["cpu_s"] and total["peak_rss_mb"] == usage["peak_rss_mb"]
