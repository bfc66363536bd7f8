"""One smoke channel case through the whole Snakemake DAG, and the physics it must obey."""
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from granflow.runner import parse_thermo
from granflow.scenes.channel.pipeline import momentum_balance
from postproc.dump import read_dump

pytestmark = pytest.mark.lammps
BIN = Path(sys.executable).parent


@pytest.fixture(scope="module")
def smoke_campaign(tmp_path_factory, root, scenes_off, replace_once):
    work = tmp_path_factory.mktemp("campaign")
    results = work / "results"
    # smoke runs are too short to be steady: average anyway to test the plumbing
    # (the status column still says no_steady_state)
    scene = (root / "config" / "scenes" / "channel.yaml").read_text()
    (work / "channel.yaml").write_text(replace_once(scene, "average_unsteady: false", "average_unsteady: true"))
    cfg = work / "config.yaml"
    cfg.write_text(
        "rung: smoke\n"
        f"results_dir: {results}\n"
        "scenes:\n"
        + scenes_off(keep=("channel",)) +
        "  channel:\n"
        "    enabled: true\n"
        f"    scene_file: {work / 'channel.yaml'}\n"
        "    sweep:\n"
        "      W: [10]\n"
        "      phi_mean: [0.57]\n"
    )
    cmd = [str(BIN / "snakemake"), "--snakefile", str(root / "Snakefile"), "--directory", str(work),
           "--configfile", str(cfg), "--cores", "2", "--quiet", "rules"]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=900)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    return {"work": work, "results": results, "cmd": cmd,
            "case": results / "channel" / "smoke" / "W~10" / "phi~0.57"}


def test_dag_produces_table_and_figures(smoke_campaign, check_png):
    base = smoke_campaign["results"] / "channel" / "smoke"
    table = pd.read_csv(base / "table.csv")
    assert len(table) == 1 and table["rung"].iloc[0] == "smoke"
    for name in ("fig04_velocity", "fig05c_ratio", "fig06_stress", "fig08_phi_shear_T", "fig11_rheology"):
        assert (base / "figures" / f"{name}.png").stat().st_size > 10_000
        check_png(base / "figures" / f"{name}.png")
    row = table.iloc[0]
    assert row["status"] in ("steady", "no_steady_state", "jammed")
    assert "rung smoke" in row["provenance"]


def test_rerun_has_nothing_to_do(smoke_campaign):
    cmd = smoke_campaign["cmd"][:-2] + ["--dry-run"]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0
    assert "Nothing to be done" in proc.stdout + proc.stderr


def test_momentum_balance_holds(smoke_campaign):
    """Wall force + weight = rate of change of momentum, over the averaging window.

    Exact for the particles, as pair forces cancel in pairs: the residual is
    limited by the 8 significant digits of thermo output and the half-step
    offset of velocity Verlet (dt |F_end - F_start| / (M g T) ~ 1e-5), so a
    tolerance of 1e-3 is generous yet catches any missing force (one particle's
    weight among ~430 is 2e-3).

    The momentum comes from two independent sources: LAMMPS's total v_py in the
    thermo rows, and the particles of the dumps (sum of m v_y, full precision);
    the impulse from the thermo rows' every-step average wall force. This case
    (phi = 0.57) accelerates and never becomes steady, so the wall force is not
    compared with the weight (that holds for a steady flow only).
    """
    case = smoke_campaign["case"]
    th = pd.read_csv(case / "run" / "thermo.csv")
    scalars = json.loads((case / "analysis" / "scalars.json").read_text())
    status = json.loads((case / "run" / "status.json").read_text())
    frames = [f for name in status["dumps"] for f in read_dump(case / "run" / name)]
    mass = frames[0].columns["mass"].sum()
    avg = th[th["stage"] == "average"].set_index("Step")
    bal = momentum_balance(avg.reset_index(), mass)
    assert abs(bal["residual"]) < 1e-3, bal
    assert scalars["momentum_residual"] == pytest.approx(bal["residual"], abs=1e-12)

    # the dumps' momentum is LAMMPS's v_py (printed with 8 significant digits)
    p_dump = {f.timestep: float(np.sum(f.columns["mass"] * f.columns["vy"])) for f in frames}
    assert len(p_dump) >= 3 and set(p_dump) <= set(avg.index)
    np.testing.assert_allclose(avg.loc[list(p_dump), "v_py"], list(p_dump.values()), rtol=1e-7)
    # and obeys the balance between the first and the last frame
    first, last = min(p_dump), max(p_dump)
    rows = avg.loc[first:last]
    t = rows["Time"].to_numpy()
    impulse = float(np.sum(rows["f_fwavg"].to_numpy()[1:] * np.diff(t)))
    weight_impulse = mass * 1.0 * (t[-1] - t[0])  # g = 1 in units of sqrt(d_p/g)
    residual = (p_dump[last] - p_dump[first] - impulse + weight_impulse) / weight_impulse
    assert abs(residual) < 1e-3, residual
    # not trivially: the column gained momentum against the weight over the window
    assert abs(p_dump[last] - p_dump[first]) > 0.01 * weight_impulse


def test_mass_is_conserved_in_the_profile(smoke_campaign):
    """Binning conserves mass: sum of rho V over the bins equals the particle mass."""
    case = smoke_campaign["case"]
    prof = pd.read_csv(case / "analysis" / "profile.csv")
    params = json.loads((case / "params.json").read_text())
    frame = next(read_dump(case / "run" / "dump_001.bin"))
    Ly = frame.box[1, 1] - frame.box[1, 0]
    Lz = frame.box[2, 1] - frame.box[2, 0]
    # profile rho is in rho_p units; convert back with the material density
    mass_binned = (prof["rho"] * (prof["x_hi"] - prof["x_lo"]) * Ly * Lz).sum() * params["density"]
    assert mass_binned == pytest.approx(frame.columns["mass"].sum(), rel=1e-9)


#: a stand-in for mpirun: starts LAMMPS (the words after ``-np N``) and, in the segment named
#: below, kills it with SIGKILL once its log shows two thermo rows; exits as a shell reports a
#: child killed by signal 9 (128 + 9)
KILLER = """#!{python}
import signal, subprocess, sys, time
from pathlib import Path
sys.path.insert(0, {src!r})
from granflow.runner import parse_thermo
argv = sys.argv[3:]
log = Path(argv[argv.index("-log") + 1])
proc = subprocess.Popen(argv)
if log.stem == {segment!r}:
    while proc.poll() is None and not (log.exists() and len(parse_thermo(log)) >= 2):
        time.sleep(0.05)
    proc.send_signal(signal.SIGKILL)
code = proc.wait()
sys.exit(128 + signal.SIGKILL if code == -signal.SIGKILL else code)
"""


def test_killed_segment_leaves_log_and_resumes(smoke_campaign, root, tmp_path):
    """LAMMPS killed in the middle of a segment: the run fails naming the segment, the exit status
    and the log; the killed segment's log is kept (rows, no end), no restart is made of it, and
    its rows never reach the runner's thermo. Run again, the runner resumes after the last
    complete restart: the segments before are not rerun, the killed one starts from that
    restart and completes.

    A copy of the smoke case with its averaging segment undone; the runner is given a launcher
    that kills LAMMPS as soon as that segment has progressed (two thermo rows in its log).
    """
    import shutil
    import stat

    from granflow.runner import CaseRunner, RunError, Tools, run_case

    case = tmp_path / "case"
    shutil.copytree(smoke_campaign["case"], case)
    run = case / "run"
    status = json.loads((run / "status.json").read_text())
    assert status["average_segments"] == 1 and status["flow_segments"] >= 1
    last_flow = f"flow_{status['flow_segments']:03d}"
    for name in ("average_001.restart", "status.json", "thermo.csv", "dump_001.bin", "logs/average_001.log"):
        (run / name).unlink()
    (run / "contacts_001.dump").unlink(missing_ok=True)
    done = {p.name: p.stat().st_mtime_ns for p in run.glob("*.restart")}
    assert set(done) == {"init.restart", *(f"flow_{k:03d}.restart" for k in range(1, status["flow_segments"] + 1))}

    killer = tmp_path / "bin" / "mpirun"
    killer.parent.mkdir()
    killer.write_text(KILLER.format(python=sys.executable, src=str(root / "src"), segment="average_001"))
    killer.chmod(killer.stat().st_mode | stat.S_IEXEC)
    lmp = Tools.default().lmp
    with pytest.raises(RunError) as exc:
        CaseRunner(case, 1, tools=Tools(lmp=lmp, mpirun=str(killer))).run()
    log = run / "logs" / "average_001.log"
    message = str(exc.value)
    assert "segment average_001 failed" in message and "exited with status 137" in message, message
    assert "no ERROR line" in message and str(log) in message, message
    text = log.read_text()
    assert len(parse_thermo(log)) >= 2 and "Loop time" not in text, "the log was not cut mid-run"
    assert not (run / "average_001.restart").exists() and not (run / "status.json").exists()
    assert CaseRunner(case, 1).thermo("average").empty  # the killed segment's rows are never used
    assert {p.name: p.stat().st_mtime_ns for p in run.glob("*.restart")} == done

    status = run_case(case, 1)  # resumes
    assert status["average_segments"] == 1 and status["dumps"] == ["dump_001.bin"]
    assert {p.name: p.stat().st_mtime_ns for p in run.glob("*.restart") if p.name in done} == done
    assert (run / "average_001.restart").exists() and not list(run.glob("*.partial"))
    text = log.read_text()
    assert f"{last_flow}.restart" in text and "Loop time" in text
    th = pd.read_csv(run / "thermo.csv")
    flow, avg = th[th["stage"] == "flow"], th[th["stage"] == "average"]
    assert avg["Step"].iloc[0] == flow["Step"].iloc[-1]  # continued from the last complete restart


def test_provenance_per_case_in_the_report(smoke_campaign, root):
    """`snakemake` writes each case's provenance.json and the scene's provenance.csv, and the report holds the table."""
    import base64
    import hashlib

    case, work = smoke_campaign["case"], smoke_campaign["work"]
    prov = json.loads((case / "provenance.json").read_text())
    git = subprocess.run(["git", "-C", str(root), "rev-parse", "HEAD"], capture_output=True, text=True)
    assert prov["granflow_commit"] == (git.stdout.strip() if git.returncode == 0 else "unknown")
    assert prov["granflow_dirty"] in ((True, False) if git.returncode == 0 else ("unknown",))
    assert prov["inputs_sha256"] == {name: hashlib.sha256((case / name).read_bytes()).hexdigest()
                                     for name in ("average.lmp", "flow.lmp", "init.lmp", "params.json")}
    status = json.loads((case / "run" / "status.json").read_text())
    assert prov["lammps_version"].startswith("LAMMPS (")
    assert (prov["scene"], prov["rung"], prov["status"], prov["ranks"]) == ("channel", "smoke", status["status"],
                                                                           status["nprocs"])
    assert prov["seeds"] == {"seed": json.loads((case / "params.json").read_text())["parameters"]["seed"]}
    assert prov["cpu_seconds"] > 0 and prov["wall_seconds"] > 0
    assert prov["host"] == status.get("host", "unknown")
    csv = smoke_campaign["results"] / "channel" / "smoke" / "provenance.csv"
    table = pd.read_csv(csv)
    assert list(table["case"]) == ["W~10/phi~0.57"]
    assert table["sha256:init.lmp"].iloc[0] == prov["inputs_sha256"]["init.lmp"]
    assert table["granflow_commit"].iloc[0] == prov["granflow_commit"]

    report = work / "report.html"
    cmd = smoke_campaign["cmd"][:-2] + ["--report", str(report)]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    lines = {line.split("=", 1)[0].split()[-1]: line.split("=", 1)[1].strip().rstrip(";")
             for line in report.read_text().splitlines() if line.lstrip().startswith(("var results =",
                                                                                     "var categories ="))}
    results, categories = json.loads(lines["results"]), json.loads(lines["categories"])
    assert categories["provenance"] == {"channel": [str(csv)]}
    entry = results[str(csv)]
    assert "Provenance of every case of the channel scene" in entry["caption"]
    assert base64.b64decode(entry["data_uri"].split("base64,", 1)[1]) == csv.read_bytes()
