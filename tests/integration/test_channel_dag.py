"""One smoke channel case through the whole Snakemake DAG, and the physics it must obey."""
import json
import subprocess
import sys
from pathlib import Path

import pandas as pd
import pytest

from granflow.scenes.channel.pipeline import momentum_balance
from postproc.dump import read_dump

pytestmark = pytest.mark.lammps
BIN = Path(sys.executable).parent


@pytest.fixture(scope="module")
def smoke_campaign(tmp_path_factory, root, scenes_off):
    work = tmp_path_factory.mktemp("campaign")
    results = work / "results"
    # smoke runs are too short to be steady: average anyway to test the plumbing
    # (the status column still says no_steady_state)
    scene = (root / "config" / "scenes" / "channel.yaml").read_text()
    (work / "channel.yaml").write_text(scene.replace("average_unsteady: false", "average_unsteady: true"))
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


def test_dag_produces_table_and_figures(smoke_campaign):
    base = smoke_campaign["results"] / "channel" / "smoke"
    table = pd.read_csv(base / "table.csv")
    assert len(table) == 1 and table["rung"].iloc[0] == "smoke"
    for name in ("fig04_velocity", "fig05c_ratio", "fig06_stress", "fig08_phi_shear_T", "fig11_rheology"):
        assert (base / "figures" / f"{name}.png").stat().st_size > 10_000
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
    """
    case = smoke_campaign["case"]
    th = pd.read_csv(case / "run" / "thermo.csv")
    scalars = json.loads((case / "analysis" / "scalars.json").read_text())
    frame = next(read_dump(case / "run" / "dump_001.bin"))
    mass = frame.columns["mass"].sum()
    bal = momentum_balance(th[th["stage"] == "average"], mass)
    assert abs(bal["residual"]) < 1e-3, bal
    assert scalars["momentum_residual"] == pytest.approx(bal["residual"], abs=1e-12)
    # shear force on both walls together against the weight (steady part only):
    # it equals the weight up to the measured acceleration of the column
    assert bal["steady_residual"] == pytest.approx(bal["acceleration_term"], abs=1e-3)


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


def test_killed_segment_leaves_log_and_resumes(smoke_campaign):
    """Restarts are renamed only after a clean segment; logs of every segment are kept."""
    run = smoke_campaign["case"] / "run"
    assert not list(run.glob("*.partial"))
    assert (run / "logs" / "init.log").exists()
    assert all((run / f"{p.stem}.restart").exists() for p in (run / "logs").glob("*.log"))


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
