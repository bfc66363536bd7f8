"""Progress lines while a segment runs (granflow.progress, CaseRunner._lammps)."""
import json
import re
import stat
import sys
import time

import pytest

from granflow.progress import ProgressSettingError, SegmentProgress, Target, progress_interval
from granflow.runner import CaseRunner, Tools


@pytest.mark.parametrize("raw, expected", [("", 10.0), ("0", 0.0), ("2.5", 2.5), (" 30 ", 30.0)])
def test_interval_from_the_environment(raw, expected):
    assert progress_interval({"GRANFLOW_PROGRESS_SECONDS": raw}) == expected
    assert progress_interval({}) == 10.0


@pytest.mark.parametrize("raw", ["abc", "-1", "nan", "inf", "1e400"])
def test_a_bad_interval_is_refused_by_name(raw):
    with pytest.raises(ProgressSettingError) as exc:
        progress_interval({"GRANFLOW_PROGRESS_SECONDS": raw})
    msg = str(exc.value)
    assert msg.startswith(f"GRANFLOW_PROGRESS_SECONDS = {raw!r} is not allowed")
    assert "allowed a number of seconds >= 0" in msg


class Clock:
    def __init__(self, t):
        self.t = t

    def __call__(self):
        return self.t


def test_line_from_a_growing_log(tmp_path):
    """Rows appended between polls give the simulated time, the segment's share, the measured
    rate and the end estimates; a partial row and a warning inside the block are not read."""
    log = tmp_path / "flow_003.log"
    log.write_text("LAMMPS (22 Jul 2025)\n   Step          Time         Atoms\n")
    clock = Clock(time.mktime((2026, 11, 24, 10, 0, 0, 0, 0, -1)))
    tgt = Target(stage="flow", index=3, count=4, n_steps=10000, dt=1e-4, unit="s", t_segment=1.0)
    p = SegmentProgress("flow_003", log, tgt, interval=5.0, clock=clock)
    with open(log, "a") as fh:
        fh.write("     20000   2.0   500\n")
    assert p.update() is None                     # one row: no rate yet
    clock.t += 4.0
    with open(log, "a") as fh:
        fh.write("WARNING: something (src/x.cpp:1)\n     22000   2.2   510\n     23000   2.3   5")
    line = p.update()                             # 2000 steps in 4 s; the partial row waits
    assert line == ("flow_003: t = 2.2 of 4 s before averaging (segment 20 %), 500 steps/s, "
                    "segment ends ~10:00:20, flow stage ~10:00:40 at this rate")
    clock.t += 1.0
    with open(log, "a") as fh:
        fh.write("20\n")                          # completes the partial row: 23000
    assert p.update() is None                     # 1 s after the last line: not due
    clock.t += 4.0
    with open(log, "a") as fh:
        fh.write("     24000   2.4   520\n")
    line = p.update()                             # 4000 steps in 9 s
    assert line.startswith("flow_003: t = 2.4 of 4 s before averaging (segment 40 %), 444 steps/s")


def test_no_lines_when_turned_off(tmp_path):
    log = tmp_path / "init.log"
    log.write_text("Step Atoms\n 0 10\n 100 10\n")
    p = SegmentProgress("init", log, Target("init", 0, 0, 0, 1e-4, "s", 0.0), interval=0.0)
    assert p.update() is None


def test_runner_prints_rate_limited_progress_while_lammps_runs(tmp_path, monkeypatch, capsys):
    """A stand-in mpirun writes a thermo row every 0.1 s for 2.4 s: the runner's log gets
    progress lines no closer than the interval, with the rows' simulated time, and the
    segment's own line after them."""
    fake = tmp_path / "mpirun"
    fake.write_text(
        f"#!{sys.executable}\n"
        "import sys, time\n"
        "log = sys.argv[sys.argv.index('-log') + 1]\n"
        "with open(log, 'w') as fh:\n"
        "    fh.write('Step Time Atoms\\n'); fh.flush()\n"
        "    for k in range(25):\n"
        "        fh.write(f'{k * 100} {k * 100 * 0.01:.2f} 10\\n'); fh.flush(); time.sleep(0.1)\n"
        "    fh.write('Loop time of 2.4 on 1 procs for 2400 steps with 10 atoms\\n')\n"
    )
    fake.chmod(fake.stat().st_mode | stat.S_IEXEC)
    (tmp_path / "params.json").write_text(json.dumps({
        "protocol": {}, "dt": 0.01, "t_segment": 24.0, "n_flow_segments": 2, "n_average_segments": 1,
        "parameters": {"n_segment": 2400}}))
    (tmp_path / "init.lmp").write_text("units lj\n")
    (tmp_path / "run").mkdir()
    monkeypatch.setenv("GRANFLOW_PROGRESS_SECONDS", "0.5")
    runner = CaseRunner(tmp_path, tools=Tools(lmp="lmp", mpirun=str(fake)))
    runner._lammps("flow.lmp", "flow_001", {})
    err = capsys.readouterr().err
    stamps, times = [], []
    for m in re.finditer(r"flow_001: t = ([0-9.]+) of 48 tau before averaging \(segment (\d+) %\), "
                         r"([0-9,]+) steps/s, segment ends ~\d\d:\d\d:\d\d, flow stage ~", err):
        times.append(float(m.group(1)))
        assert float(m.group(1)) == pytest.approx(int(m.group(2)) / 100 * 24, abs=0.25)
        assert 300 < float(m.group(3).replace(",", "")) < 1500    # ~1000 steps/s written
    assert 2 <= len(times) <= 6, err              # 2.4 s of rows, one line per 0.5 s at most
    assert times == sorted(times) and 0 < times[-1] <= 24
    assert err.rstrip().splitlines()[-1].split("] ", 1)[1].startswith("flow_001: ")
    assert "steps/s" not in err.rstrip().splitlines()[-1]


def test_runner_refuses_a_bad_interval_before_running(tmp_path, monkeypatch):
    (tmp_path / "params.json").write_text(json.dumps({"protocol": {}}))
    monkeypatch.setenv("GRANFLOW_PROGRESS_SECONDS", "soon")
    with pytest.raises(ProgressSettingError, match="GRANFLOW_PROGRESS_SECONDS = 'soon' is not allowed"):
        CaseRunner(tmp_path, tools=Tools(lmp="lmp", mpirun="mpirun"))
