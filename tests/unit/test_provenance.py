"""granflow.provenance on hand-made case directories and throw-away git repositories."""
import hashlib
import json
import os
import shutil
import subprocess
from datetime import datetime, timezone

import pytest

from granflow import provenance
from granflow.provenance import case_provenance, git_state, lammps_version, provenance_table, seeds

VERSION = "LAMMPS (22 Jul 2025 - Update 4)"
FINISHED = 1_700_000_000  # 2023-11-14T22:13:20Z


def digest(path):
    return hashlib.sha256(path.read_bytes()).hexdigest()


def make_case(path, status=None, logs=None):
    """A case directory as render + run leave it (decks, a data file, params.json, run/status.json, logs)."""
    path.mkdir(parents=True, exist_ok=True)
    record = {"scene": "anything", "rung": "smoke",
              "case": {"W": 10.0, "seed": 11},
              "parameters": {"W": 10.0, "seed": 11, "feed_seed": 7, "seeds_used": 3,
                             "mixture": {"pack_seed": 5, "seedless": 1}},
              "protocol": {"seed": 999}}  # outside parameters/case: not a seed of the record
    (path / "params.json").write_text(json.dumps(record, indent=2, sort_keys=True) + "\n")
    (path / "init.lmp").write_text("units lj\nrun 0\n")
    (path / "flow.lmp").write_text("run 100\n")
    (path / "atoms.data").write_bytes(b"LAMMPS data file\n\n3 atoms\n")
    (path / "notes.txt").write_text("not a rendered input\n")
    logs_dir = path / "run" / "logs"
    logs_dir.mkdir(parents=True)
    for name, text in (logs if logs is not None else {
            "init.log": f"{VERSION}\n  using 1 OpenMP thread(s) per MPI task\nLoop time of 1\n",
            "init.screen": f"{VERSION}\n",
            "flow_001.log": f"{VERSION}\nread_restart init.restart\n"}).items():
        (logs_dir / name).write_text(text)
    st = path / "run" / "status.json"
    st.write_text(json.dumps(status if status is not None else {
        "status": "steady", "reason": "", "nprocs": 2, "wall_seconds": 12.5, "cpu_seconds": 24.0,
        "host": "node7", "launcher": "mpirun -np 2"}))
    os.utime(st, (FINISHED, FINISHED))
    return path


def test_case_provenance_of_a_hand_made_case(tmp_path):
    case = make_case(tmp_path / "case")
    nogit = tmp_path / "nogit"
    nogit.mkdir()
    before = datetime.now(timezone.utc).replace(microsecond=0)
    prov = case_provenance(case, repo=nogit)
    written = datetime.fromisoformat(prov.pop("written"))
    assert before <= written <= datetime.now(timezone.utc)
    assert prov == {
        "scene": "anything",
        "rung": "smoke",
        "case": {"W": 10.0, "seed": 11},
        "status": "steady",
        "granflow_commit": "unknown",
        "granflow_dirty": "unknown",
        "granflow_dirty_files": "unknown",
        "granflow_untracked_files": "unknown",
        "lammps_version": VERSION,
        "inputs_sha256": {name: digest(case / name)
                          for name in ("atoms.data", "flow.lmp", "init.lmp", "params.json")},
        "seeds": {"seed": 11, "feed_seed": 7, "mixture.pack_seed": 5},
        "ranks": 2,
        "wall_seconds": 12.5,
        "cpu_seconds": 24.0,
        "host": "node7",
        "launcher": "mpirun -np 2",
        "run_finished": "2023-11-14T22:13:20+00:00",
    }
    json.dumps(prov, allow_nan=False)  # strict JSON


def test_missing_fields_are_unknown_or_null(tmp_path):
    """A runner that records no host/launcher, a NaN wall time, no LAMMPS log: named as unknown, no crash."""
    case = make_case(tmp_path / "case", status={"status": "jammed", "nprocs": 1, "wall_seconds": float("nan")},
                     logs={})
    prov = case_provenance(case, repo=tmp_path)
    assert (prov["host"], prov["launcher"], prov["lammps_version"]) == ("unknown",) * 3
    assert (prov["status"], prov["ranks"], prov["wall_seconds"], prov["cpu_seconds"]) == ("jammed", 1, None, None)
    (case / "run" / "status.json").unlink()
    prov = case_provenance(case, repo=tmp_path)
    assert (prov["status"], prov["ranks"], prov["run_finished"]) == ("unknown", None, "unknown")


def test_lammps_version_from_screen_and_of_mixed_versions(tmp_path):
    (tmp_path / "a.screen").write_text(f"{VERSION}\n")
    assert lammps_version(tmp_path) == VERSION  # no *.log: the screen output
    (tmp_path / "init.log").write_text("LAMMPS (2 Aug 2023 - Update 3)\n")
    (tmp_path / "flow_001.log").write_text(f"{VERSION}\n")
    assert lammps_version(tmp_path) == f"{VERSION}; LAMMPS (2 Aug 2023 - Update 3)"
    assert lammps_version(tmp_path / "absent") == "unknown"


def test_seeds_conflicting_between_parameters_and_case():
    assert seeds({"parameters": {"seed": 1}, "case": {"seed": 2, "x": 0}}) == {"seed": 1, "case.seed": 2}
    assert seeds({}) == {}


def git(repo, *args):
    return subprocess.run(["git", "-C", str(repo), "-c", "user.name=t", "-c", "user.email=t@example.org",
                           "-c", "commit.gpgsign=false", *args],
                          check=True, capture_output=True, text=True).stdout.strip()


@pytest.mark.skipif(shutil.which("git") is None, reason="needs git")
def test_git_state_clean_then_dirty(tmp_path):
    repo = tmp_path / "repo"
    (repo / "src" / "pkg").mkdir(parents=True)
    git(repo, "init", "-q")
    (repo / "src" / "pkg" / "mod.py").write_text("x = 1\n")
    (repo / "README").write_text("r\n")
    git(repo, "add", ".")
    git(repo, "commit", "-q", "-m", "first")
    head = git(repo, "rev-parse", "HEAD")
    where = repo / "src" / "pkg"
    assert git_state(where) == {"commit": head, "dirty": False, "dirty_files": [], "untracked_files": []}
    (repo / "untracked.txt").write_text("u\n")  # untracked files do not make the tree dirty
    assert git_state(where)["dirty"] is False
    (repo / "README").write_text("changed\n")  # a tracked file anywhere in the checkout does
    assert git_state(where) == {"commit": head, "dirty": True, "dirty_files": ["README"], "untracked_files": []}
    # a directory of the checkout holding no tracked file (a venv inside the tree) is not credited
    (repo / "venv" / "pkg").mkdir(parents=True)
    assert git_state(repo / "venv" / "pkg")["commit"] == "unknown"
    # case_provenance takes the state of the given checkout
    case = make_case(tmp_path / "case")
    prov = case_provenance(case, repo=where)
    assert (prov["granflow_commit"], prov["granflow_dirty"], prov["granflow_dirty_files"]) == (head, True, ["README"])


@pytest.mark.skipif(shutil.which("git") is None, reason="needs git")
def test_untracked_files_under_src_and_config_make_the_checkout_dirty(tmp_path):
    """A scene file or module in use but never committed is dirt; an ignored file, or an untracked one
    outside src/ and config/, is not."""
    repo = tmp_path / "repo"
    for folder in ("src/pkg", "config/scenes"):
        (repo / folder).mkdir(parents=True)
    git(repo, "init", "-q")
    (repo / "src" / "pkg" / "mod.py").write_text("x = 1\n")
    (repo / "config" / "config.yaml").write_text("rung: demo\n")
    (repo / ".gitignore").write_text("__pycache__/\n*.tmp\n")
    git(repo, "add", ".")
    git(repo, "commit", "-q", "-m", "first")
    head = git(repo, "rev-parse", "HEAD")
    where = repo / "src" / "pkg"
    # ignored (bytecode, a scratch file) and outside the counted folders: still clean
    (repo / "src" / "pkg" / "__pycache__").mkdir()
    (repo / "src" / "pkg" / "__pycache__" / "mod.cpython-311.pyc").write_bytes(b"\0")
    (repo / "config" / "scratch.tmp").write_text("t\n")
    (repo / "notes.txt").write_text("n\n")
    (repo / "results").mkdir()
    (repo / "results" / "table.csv").write_text("a\n")
    assert git_state(where) == {"commit": head, "dirty": False, "dirty_files": [], "untracked_files": []}
    # an untracked scene file and module: dirty, named from the checkout's top (even in a new folder)
    (repo / "config" / "scenes" / "new scene.yaml").write_text("case: {}\n")
    (repo / "src" / "pkg" / "extra").mkdir()
    (repo / "src" / "pkg" / "extra" / "more.py").write_text("y = 2\n")
    untracked = ["config/scenes/new scene.yaml", "src/pkg/extra/more.py"]
    assert git_state(where) == {"commit": head, "dirty": True, "dirty_files": untracked,
                                "untracked_files": untracked}
    # with a tracked change as well, dirty_files names both kinds
    (repo / "config" / "config.yaml").write_text("rung: study\n")
    state = git_state(where)
    assert state["dirty_files"] == ["config/config.yaml", *untracked] and state["untracked_files"] == untracked
    # the provenance record lists them; the table keeps lists out of its cells
    prov = case_provenance(make_case(tmp_path / "case"), repo=where)
    assert prov["granflow_dirty"] is True and prov["granflow_untracked_files"] == untracked
    assert "granflow_untracked_files" not in provenance_table({"case": prov}).columns


def test_git_state_unknown_without_a_checkout_or_git(tmp_path, monkeypatch):
    unknown = {"commit": "unknown", "dirty": "unknown", "dirty_files": "unknown", "untracked_files": "unknown"}
    assert git_state(tmp_path) == unknown
    assert git_state(tmp_path / "absent") == unknown
    monkeypatch.setenv("PATH", str(tmp_path))  # no git executable at all
    assert git_state(provenance.PACKAGE_DIR) == unknown


@pytest.mark.skipif(shutil.which("git") is None, reason="needs git")
def test_default_is_granflow_checkout(root):
    """By default the commit is that of the checkout granflow is imported from."""
    if subprocess.run(["git", "-C", str(root), "rev-parse"], capture_output=True).returncode:
        pytest.skip("granflow is not a git checkout here")
    assert git_state()["commit"] == git(root, "rev-parse", "HEAD")


def test_table_has_one_row_per_case(tmp_path):
    nogit = tmp_path / "nogit"
    nogit.mkdir()
    records = {f"W~{w}": case_provenance(make_case(tmp_path / f"W~{w}"), repo=nogit) for w in (10, 20)}
    table = provenance_table(records)
    assert list(table["case"]) == ["W~10", "W~20"]
    assert list(table.columns[:4]) == ["case", "scene", "rung", "status"]
    assert {"seed", "feed_seed", "mixture.pack_seed", "sha256:init.lmp", "sha256:params.json", "lammps_version",
            "granflow_commit", "granflow_dirty", "ranks", "wall_seconds", "cpu_seconds", "host",
            "written"} <= set(table.columns)
    assert "granflow_dirty_files" not in table.columns
    assert table["sha256:init.lmp"].iloc[0] == digest(tmp_path / "W~10" / "init.lmp")
    assert list(table["host"]) == ["node7", "node7"]
