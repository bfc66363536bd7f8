"""The executables and the case record a run is given (issue 41, defect 9): GRANFLOW_LMP and
GRANFLOW_MPIRUN naming anything but an executable LAMMPS or MPI launcher, a hand-edited params.json
and a results_dir that is a file are refused (exit 2, one line, nothing written); status.json names
the LAMMPS that ran. No LAMMPS runs here but ``lmp -h`` of the venv's."""
import json
import re
import shutil
import stat
import sys
from pathlib import Path

import pytest

from granflow.cli import main
from granflow.deck import render_case
from granflow.launch import ToolError, Tools
from granflow.preflight import PreflightError, check_record

#: answers ``-h`` as LAMMPS does (its banner line), and nothing else
BANNER_LMP = ("#!/bin/sh\necho\necho 'Large-scale Atomic/Molecular Massively Parallel Simulator - "
              "1 Jan 2099 - stand-in'\n")


@pytest.fixture(scope="module")
def rendered(channel_scene, tmp_path_factory):
    case = tmp_path_factory.mktemp("rendered") / "case"
    render_case(channel_scene, "smoke", case)
    return case


@pytest.fixture
def case(rendered, tmp_path):
    out = tmp_path / "case"
    shutil.copytree(rendered, out)
    return out


def _program(path: Path, text: str, mode: int = 0o755) -> Path:
    path.write_text(text)
    path.chmod(mode)
    return path


def refused(capsys, argv) -> str:
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err and err.startswith("granflow: refused: ") and err.count("\n") == 1, err
    return err


@pytest.mark.parametrize("make, named", [
    (lambda d: d / "missing" / "lmp", "no such file"),                        # was: the lmp on PATH ran
    (lambda d: d, "is a directory"),
    (lambda d: _program(d / "lmp", BANNER_LMP, 0o644), "is not executable"),
    (lambda d: _program(d / "lmp", "#!/bin/sh\necho hello\n"), "is not LAMMPS: "),
    (lambda d: Path("/bin/true"), "is not LAMMPS: "),
    (lambda d: "no-such-lmp-anywhere", "not found on PATH"),
])
def test_granflow_lmp_that_is_not_lammps_is_refused(case, capsys, monkeypatch, tmp_path, make, named):
    value = str(make(tmp_path))
    monkeypatch.setenv("GRANFLOW_LMP", value)
    err = refused(capsys, ["run", str(case)])
    assert f"GRANFLOW_LMP={value!r}" in err and named in err, err
    assert not (case / "run").exists(), "nothing is written"


@pytest.mark.parametrize("make, named", [
    (lambda d: d / "missing" / "mpirun", "no such file"),                     # was: the mpirun on PATH ran
    (lambda d: Path("/bin/sh"), "'/bin/sh' is not mpirun, mpiexec or srun"),  # was: exit 1, "granflow's fault"
    (lambda d: _program(d / "mpirun", "#!/bin/sh\n", 0o644), "is not executable"),
])
def test_granflow_mpirun_that_is_not_a_launcher_is_refused(case, capsys, monkeypatch, tmp_path, make, named):
    value = str(make(tmp_path))
    monkeypatch.setenv("GRANFLOW_MPIRUN", value)
    err = refused(capsys, ["run", str(case)])
    assert "GRANFLOW_MPIRUN" in err and named in err, err
    assert not (case / "run").exists(), "nothing is written"


def test_status_names_the_lammps_that_ran(tmp_path, monkeypatch):
    lmp = _program(tmp_path / "lmp_stand_in", BANNER_LMP)
    monkeypatch.setenv("GRANFLOW_LMP", str(lmp))
    tools = Tools.default()
    assert tools.lmp == str(lmp) and tools.version == "1 Jan 2099 - stand-in"
    (tmp_path / "params.json").write_text(json.dumps({"protocol": {}, "guards": {"report_overlap": 0.01}}))
    (tmp_path / "run" / "logs").mkdir(parents=True)
    from granflow.runner import CaseRunner

    status = CaseRunner(tmp_path, tools=tools)._conclude(None, 0, 0, None)
    assert status["lammps"] == {"path": str(lmp), "version": "1 Jan 2099 - stand-in"}
    assert json.loads((tmp_path / "run" / "status.json").read_text())["lammps"] == status["lammps"]


def test_the_venvs_lammps_is_found_with_its_version(monkeypatch):
    monkeypatch.delenv("GRANFLOW_LMP", raising=False)
    monkeypatch.delenv("GRANFLOW_MPIRUN", raising=False)
    tools = Tools.default()
    if not Path(tools.lmp).exists():
        pytest.skip("no lmp installed")
    assert re.fullmatch(r"\d{1,2} \w{3} \d{4}.*", tools.version), tools.version  # e.g. 22 Jul 2025 - Update 4


def test_tool_errors_are_refusals():
    assert issubclass(ToolError, PreflightError)


# ------------------------------------------------------------------------------ params.json
@pytest.mark.parametrize("edit, named", [
    (lambda r: r.update(dt="0.001"), "key 'dt' is '0.001', it must be a finite number > 0"),
    (lambda r: r.update(n_flow_segments=2.5), "key 'n_flow_segments' is 2.5, it must be a whole number >= 0"),
    (lambda r: r["protocol"].pop("steady_window"), "key 'protocol.steady_window' is missing"),
    (lambda r: r["guards"].update(report_overlap=-1), "key 'guards.report_overlap' is -1"),
    (lambda r: r.update(protocol=[]), "key 'protocol' is [], it must be a mapping"),
    (lambda r: r.update(schedule="forever"), "key 'schedule' is 'forever'"),
    (lambda r: r["parameters"].update(n_particles="many"), "key 'parameters.n_particles' is 'many'"),
])
def test_hand_edited_params_json_is_refused_naming_the_key(case, capsys, edit, named):
    record = json.loads((case / "params.json").read_text())
    check_record(record)  # as rendered: accepted
    edit(record)
    (case / "params.json").write_text(json.dumps(record))
    err = refused(capsys, ["run", str(case)])
    assert named in err and "render the case again" in err, err
    assert not (case / "run").exists(), "nothing is written"


def test_params_json_that_is_not_json_is_refused(case, capsys):
    (case / "params.json").write_text('{"scene": "channel",')
    err = refused(capsys, ["run", str(case)])
    assert "params.json is not valid JSON" in err, err


def test_run_case_refuses_an_edited_record_before_the_lock(case):
    """The workflow's path (run_case), not only the CLI's."""
    from granflow.runner import run_case

    record = json.loads((case / "params.json").read_text())
    record["t_segment"] = float("nan")
    (case / "params.json").write_text(json.dumps(record))
    with pytest.raises(PreflightError, match="key 't_segment' is nan"):
        run_case(case)
    assert not (case / "run").exists()


# ------------------------------------------------------------------------------ results_dir
def test_results_dir_naming_a_file_is_refused_by_check_config(capsys, root, tmp_path, monkeypatch):
    """check-config said 'valid' and Snakemake then failed with a traceback."""
    monkeypatch.chdir(root)
    afile = tmp_path / "results.txt"
    afile.write_text("not a directory\n")
    for value, named in ((afile, "is a regular file"), (afile / "sub", f"(its part {afile}) is a regular file")):
        err = refused(capsys, ["check-config", str(root / "config/config.yaml"), "--set", f"results_dir={value}"])
        assert f"results_dir = {str(value)!r}" in err and named in err, err
    assert main(["check-config", str(root / "config/config.yaml"), "--set", f"results_dir={tmp_path / 'new'}"]) == 0
