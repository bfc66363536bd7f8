"""Damaged intermediates (issue 31, item 3): a file a rule reads that is junk, cut short or not
what its producer wrote is refused in one line naming it and the command that rebuilds it,
without a traceback, and the rule's last good output stays where it was.

The adapter scripts run as Snakemake runs them (a separate Python process whose stderr is
the terminal), with a stand-in for the ``snakemake`` object, on hand-made files."""
import json
import os
import shlex
import subprocess
import sys
from pathlib import Path

import pandas as pd
import pytest

from granflow.intermediates import (COMMAND_ENV, SUMS, DamagedIntermediate, read_csv, read_json, rebuild_command,
                                    replacing, replacing_folder, report_plainly, snakemake_command,
                                    verify_checksum, verify_folder, write_checksum, write_sums)

ROOT = Path(__file__).resolve().parents[2]
SCRIPTS = ROOT / "workflows" / "scripts"
PROFILE = "x,rho,u_y\n0.5,0.58,1.0\n1.5,0.60,2.0\n2.5,0.61,2.5\n"
SCALARS = {"W": 10.0, "phi_mean": 0.58, "u_slip": 1.25, "status": "steady"}


def one_line_naming(text: str, path: Path, target: Path) -> str:
    """The refusal: exactly one line, naming the file and a snakemake command forcing ``target``."""
    lines = [line for line in text.splitlines() if line.strip()]
    assert len(lines) == 1, text
    assert "Traceback" not in text
    line = lines[0]
    assert line.startswith("granflow: damaged intermediate: ") and str(path) in line, line
    command = line.split("rebuild it with: ", 1)[1].split(";")[0]
    words = shlex.split(command)
    assert words[:3] == ["snakemake", "--cores", "2"] and words[-1] == f"--forcerun={target}", command
    return line


# -- the readers -----------------------------------------------------------------------------

def test_junk_json_is_refused_by_name_with_its_rebuild_command(tmp_path, monkeypatch):
    monkeypatch.delenv(COMMAND_ENV, raising=False)
    path = tmp_path / "scalars.json"
    path.write_text("junk")
    with pytest.raises(DamagedIntermediate) as exc:
        read_json(path)
    one_line_naming(f"granflow: damaged intermediate: {exc.value}", path, path)
    assert "not JSON" in str(exc.value)


def test_json_checks(tmp_path):
    path = tmp_path / "status.json"
    for text, what in (("", "empty"), ('{"status": "steady"', "not JSON"), ("[1, 2]", "where an object"),
                       ('{"status": "steady"}', "lacks 'dumps'")):
        path.write_text(text)
        with pytest.raises(DamagedIntermediate, match=what):
            read_json(path, keys=("status", "dumps"))
    path.write_bytes(b'{"status": "\xff"}')
    with pytest.raises(DamagedIntermediate, match="not UTF-8"):
        read_json(path)
    with pytest.raises(DamagedIntermediate, match="missing"):
        read_json(tmp_path / "absent.json")
    path.write_text('{"status": "steady", "dumps": []}\n')
    assert read_json(path, keys=("status", "dumps")) == {"status": "steady", "dumps": []}


def test_truncated_csv_is_refused_not_read_with_nan(tmp_path):
    """pandas reads a row cut short with NaN in its missing fields; we refuse it."""
    path = tmp_path / "thermo.csv"
    path.write_text(PROFILE[:-7])  # cut inside the last row: no line end
    assert pd.read_csv(path).isna().any().any()  # what plain pandas would have done
    with pytest.raises(DamagedIntermediate, match="cut short: line 4 has no line end"):
        read_csv(path)
    path.write_text(PROFILE + "3.5,0.62\n")  # a row with a field too few
    with pytest.raises(DamagedIntermediate, match="line 5 has 2 fields where the header has 3"):
        read_csv(path)
    path.write_text("")
    with pytest.raises(DamagedIntermediate, match="empty"):
        read_csv(path)
    assert read_csv(path, allow_empty=True).empty  # a case that was not averaged writes empty tables
    path.write_text(PROFILE)
    assert read_csv(path)["u_y"].tolist() == [1.0, 2.0, 2.5]


def test_rebuild_command_names_the_campaign(monkeypatch, tmp_path):
    monkeypatch.delenv(COMMAND_ENV, raising=False)
    assert rebuild_command("results/a/run/status.json") == "snakemake --cores 2 --forcerun=results/a/run/status.json"
    # from the project root: the plain command; elsewhere the Snakefile and the working directory
    assert snakemake_command(ROOT / "Snakefile", ROOT, 4) == "snakemake --cores 4"
    cfg = tmp_path / "campaign.yaml"
    cmd = snakemake_command(ROOT / "Snakefile", tmp_path, None, [cfg], ["rung='smoke'"])
    assert shlex.split(cmd) == ["snakemake", "--cores", "2", "--snakefile", str(ROOT / "Snakefile"),
                                "--directory", str(tmp_path.resolve()), "--configfile", str(cfg.resolve()),
                                "--config", "rung='smoke'"]
    monkeypatch.setenv(COMMAND_ENV, cmd)
    assert rebuild_command("results/c/W~10/x.json") == cmd + " --forcerun='results/c/W~10/x.json'"


# -- checksums ---------------------------------------------------------------------------------

def analysis_folder(path: Path) -> Path:
    path.mkdir(parents=True)
    (path / "profile.csv").write_text(PROFILE)
    (path / "empty.csv").write_text("\n")
    (path / "scalars.json").write_text(json.dumps(SCALARS) + "\n")
    write_sums(path)
    return path


def test_folder_checksums_find_any_changed_file(tmp_path):
    folder = analysis_folder(tmp_path / "analysis")
    (folder / ".snakemake_timestamp").write_text("")  # hidden files are not part of the analysis
    assert [p.name for p in verify_folder(folder)] == ["empty.csv", "profile.csv", "scalars.json"]
    # sha256sum -c reads the same list
    assert (folder / SUMS).read_text().splitlines()[1].endswith("  profile.csv")
    profile = (folder / "profile.csv").read_bytes()
    (folder / "profile.csv").write_bytes(profile[:-10])  # cut short
    with pytest.raises(DamagedIntermediate, match="profile.csv: changed after it was written") as exc:
        verify_folder(folder)
    assert exc.value.rebuild == str(folder / SUMS)
    (folder / "profile.csv").write_bytes(profile)
    (folder / "scalars.json").write_text('{"W": 10.0, "phi_mean": 0.58, "u_slip": 9.99, "status": "steady"}\n')
    with pytest.raises(DamagedIntermediate, match="scalars.json: changed after"):  # well-formed, yet not ours
        verify_folder(folder)
    (folder / SUMS).write_text("junk\n")
    with pytest.raises(DamagedIntermediate, match="SHA256SUMS: line 1 is not"):
        verify_folder(folder)
    (folder / SUMS).unlink()
    with pytest.raises(DamagedIntermediate, match="SHA256SUMS: missing"):  # the analysis did not finish
        verify_folder(folder)


def test_file_checksum(tmp_path):
    table = tmp_path / "table.csv"
    table.write_text(PROFILE)
    assert write_checksum(table) == tmp_path / "table.csv.sha256"
    assert verify_checksum(table) == table
    table.write_text(PROFILE[:-5])
    with pytest.raises(DamagedIntermediate, match="table.csv: changed after it was written"):
        verify_checksum(table)
    (tmp_path / "table.csv.sha256").unlink()
    with pytest.raises(DamagedIntermediate, match="table.csv.sha256: missing"):
        verify_checksum(table)


# -- outputs that survive a failed rebuild -----------------------------------------------------

def test_replacing_keeps_the_last_good_file_on_failure(tmp_path):
    out = tmp_path / "figures" / "fig.png"
    with replacing(out) as tmp:
        assert tmp.suffix == ".png" and tmp.parent == out.parent  # writers that go by the suffix still work
        tmp.write_text("good")
    assert out.read_text() == "good"
    with pytest.raises(RuntimeError), replacing(out) as tmp:
        tmp.write_text("half")
        raise RuntimeError("the figure failed")
    assert out.read_text() == "good" and sorted(p.name for p in out.parent.iterdir()) == ["fig.png"]


def test_replacing_folder_keeps_the_last_good_folder_on_failure(tmp_path):
    folder = analysis_folder(tmp_path / "analysis")
    before = {p.name: p.read_bytes() for p in folder.iterdir()}
    with pytest.raises(RuntimeError), replacing_folder(folder) as new:
        (new / "scalars.json").write_text("{}")
        raise RuntimeError("the analysis failed")
    assert {p.name: p.read_bytes() for p in folder.iterdir()} == before
    with replacing_folder(folder) as new:
        (new / "scalars.json").write_text("{}\n")
    assert sorted(p.name for p in folder.iterdir()) == ["scalars.json"]  # no stale file of the old one
    assert sorted(p.name for p in tmp_path.iterdir()) == ["analysis"]


# -- the adapter scripts, run as Snakemake runs them ---------------------------------------------

RUNNER = """
import json, runpy, sys, types
spec = json.loads(sys.argv[2])
ns = {k: types.SimpleNamespace(**spec.pop(k)) for k in ("input", "output", "params", "wildcards")}
snakemake = types.SimpleNamespace(**ns, **spec)
runpy.run_path(sys.argv[1], init_globals={"snakemake": snakemake}, run_name="__main__")
"""


def run_script(name: str, tmp_path: Path, **spec) -> subprocess.CompletedProcess:
    """Run workflows/scripts/<name> with a stand-in ``snakemake`` object; stderr is the terminal's."""
    full = {"input": {}, "output": {}, "params": {}, "wildcards": {}, "threads": 1,
            "log": [str(tmp_path / f"{name}.log")], "rule": name.removesuffix(".py")}
    for key, value in spec.items():
        full[key] = {k: (str(v) if isinstance(v, Path) else [str(x) for x in v] if isinstance(v, list) else v)
                     for k, v in value.items()} if isinstance(value, dict) else value
    env = {**os.environ, "PYTHONPATH": str(ROOT / "src"), "MPLBACKEND": "Agg"}
    env.pop(COMMAND_ENV, None)
    return subprocess.run([sys.executable, "-c", RUNNER, str(SCRIPTS / name), json.dumps(full)],
                          capture_output=True, text=True, env=env, cwd=tmp_path, timeout=120)


def scene_with_one_case(tmp_path: Path) -> tuple[Path, Path]:
    scene = tmp_path / "results" / "channel" / "smoke"
    case = scene / "W~10" / "phi~0.58"
    analysis_folder(case / "analysis")
    (case / "run").mkdir()
    (case / "params.json").write_text(json.dumps({"scene": "channel", "rung": "smoke"}) + "\n")
    (case / "run" / "status.json").write_text(json.dumps({"status": "steady", "dumps": ["dump_001.bin"]}) + "\n")
    (case / "run" / "thermo.csv").write_text("Step,Time,v_ucm\n0,0.0,0.0\n100,0.05,0.1\n")
    return scene, case


def table_spec(scene: Path, case: Path) -> dict:
    return {"input": {"scalars": [case / "analysis" / "scalars.json"], "sums": [case / "analysis" / SUMS]},
            "output": {"table": scene / "table.csv", "sha256": scene / "table.csv.sha256"},
            "wildcards": {"scene": "channel"}}


def test_junk_in_scalars_json_refuses_the_table_and_keeps_the_last_good_one(tmp_path):
    """The issue's defect: junk in analysis/scalars.json gave a JSONDecodeError traceback and no table."""
    scene, case = scene_with_one_case(tmp_path)
    proc = run_script("table.py", tmp_path, **table_spec(scene, case))
    assert proc.returncode == 0, proc.stderr + (tmp_path / "table.py.log").read_text()
    assert verify_checksum(scene / "table.csv") and pd.read_csv(scene / "table.csv")["u_slip"].tolist() == [1.25]
    good = (scene / "table.csv").read_bytes()
    scalars = case / "analysis" / "scalars.json"
    scalars.write_text("junk")
    proc = run_script("table.py", tmp_path, **table_spec(scene, case))
    assert proc.returncode == 1
    line = one_line_naming(proc.stderr, scalars, case / "analysis" / SUMS)
    assert line.endswith(f"the last good {scene / 'table.csv'} stays in place")
    assert (tmp_path / "table.py.log").read_text().strip() == line  # the rule's log says the same
    assert (scene / "table.csv").read_bytes() == good
    assert not list(scene.glob(".*partial*"))


def test_junk_in_status_json_refuses_the_analysis_and_keeps_the_last_good_one(tmp_path):
    """The issue's defect: junk in run/status.json gave a traceback and the earlier analysis/ was gone."""
    _, case = scene_with_one_case(tmp_path)
    before = {p.name: p.read_bytes() for p in (case / "analysis").iterdir()}
    status = case / "run" / "status.json"
    status.write_text('{"status": "steady", "dum')
    spec = {"input": {"params": case / "params.json", "status": status, "thermo": case / "run" / "thermo.csv"},
            "output": {"scalars": case / "analysis" / "scalars.json", "sums": case / "analysis" / SUMS}}
    proc = run_script("analyse.py", tmp_path, **spec)
    assert proc.returncode == 1
    line = one_line_naming(proc.stderr, status, status)
    assert "not JSON" in line and line.endswith(f"the last good {case / 'analysis'} stays in place")
    assert {p.name: p.read_bytes() for p in (case / "analysis").iterdir()} == before


def test_truncated_thermo_csv_refuses_the_analysis(tmp_path):
    _, case = scene_with_one_case(tmp_path)
    thermo = case / "run" / "thermo.csv"
    thermo.write_bytes(thermo.read_bytes()[:-4])
    spec = {"input": {"params": case / "params.json", "status": case / "run" / "status.json", "thermo": thermo},
            "output": {"scalars": case / "analysis" / "scalars.json", "sums": case / "analysis" / SUMS}}
    proc = run_script("analyse.py", tmp_path, **spec)
    assert proc.returncode == 1
    assert "cut short" in one_line_naming(proc.stderr, thermo, thermo)


def test_truncated_analysis_csv_refuses_the_figure_and_keeps_the_last_good_one(tmp_path):
    """A table the figure reads, cut short after analyse wrote it: refused by its checksum."""
    scene, case = scene_with_one_case(tmp_path)
    figure = scene / "figures" / "fig04_velocity.png"
    figure.parent.mkdir()
    figure.write_bytes(b"the last good figure")
    profile = case / "analysis" / "profile.csv"
    profile.write_bytes(profile.read_bytes()[:-12])
    spec = {"input": {"scalars": [case / "analysis" / "scalars.json"], "sums": [case / "analysis" / SUMS]},
            "output": {"figure": figure, "sha256": figure.with_name(figure.name + ".sha256")},
            "wildcards": {"scene": "channel", "figure": "fig04_velocity"}}
    proc = run_script("figure.py", tmp_path, **spec)
    assert proc.returncode == 1
    line = one_line_naming(proc.stderr, profile, case / "analysis" / SUMS)
    assert "changed after it was written" in line
    assert figure.read_bytes() == b"the last good figure"


def test_other_errors_keep_their_traceback(monkeypatch, capsys):
    """Only a damaged intermediate is reported in one line: a bug still shows where it is."""
    seen = []
    monkeypatch.setattr(sys, "excepthook", lambda *args: seen.append(args[0]))
    report_plainly()
    try:
        raise KeyError("u_slip")
    except KeyError as exc:
        sys.excepthook(KeyError, exc, exc.__traceback__)
    assert seen == [KeyError] and capsys.readouterr().err == ""
    try:
        raise DamagedIntermediate("a/scalars.json", "empty")
    except DamagedIntermediate as exc:
        sys.excepthook(DamagedIntermediate, exc, exc.__traceback__)
    assert seen == [KeyError]
    assert capsys.readouterr().err.startswith("granflow: damaged intermediate: a/scalars.json: empty; rebuild it")


def test_junk_in_status_json_refuses_the_snapshots_and_keeps_the_last_good_one(tmp_path):
    _, case = scene_with_one_case(tmp_path)
    png = case / "snapshots.png"
    spec = {"input": {"params": case / "params.json", "status": case / "run" / "status.json",
                      "thermo": case / "run" / "thermo.csv"},
            "output": {"png": png, "sha256": case / "snapshots.png.sha256"},
            "wildcards": {"scene": "channel", "case": "W~10/phi~0.58"}}
    proc = run_script("snapshots.py", tmp_path, **spec)  # no snapshots at this rung: a figure saying so
    assert proc.returncode == 0, proc.stderr + (tmp_path / "snapshots.py.log").read_text()
    assert verify_checksum(png)
    good = png.read_bytes()
    (case / "run" / "status.json").write_text("")
    proc = run_script("snapshots.py", tmp_path, **spec)
    assert proc.returncode == 1
    assert "empty" in one_line_naming(proc.stderr, case / "run" / "status.json", case / "run" / "status.json")
    assert png.read_bytes() == good
