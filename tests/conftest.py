"""Shared fixtures: project paths and the LAMMPS executables of the venv."""
import shutil
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "src"))
BIN = Path(sys.executable).parent


@pytest.fixture(scope="session")
def root() -> Path:
    return ROOT


@pytest.fixture(scope="session")
def lmp() -> str:
    exe = BIN / "lmp"
    return str(exe) if exe.exists() else (shutil.which("lmp") or "lmp")


@pytest.fixture(scope="session")
def channel_scene():
    from granflow.config import load_scene

    return load_scene(ROOT / "config" / "scenes" / "channel.yaml")


@pytest.fixture(scope="session")
def heap_scene():
    from granflow.config import load_scene

    return load_scene(ROOT / "config" / "scenes" / "heap.yaml")


@pytest.fixture(scope="session")
def silo_scene():
    from granflow.config import load_scene

    return load_scene(ROOT / "config" / "scenes" / "silo.yaml")


@pytest.fixture
def smoke_variant():
    """A copy of a scene whose smoke rung has some knobs changed (hard-case tests)."""
    import copy

    def make(scene, **knobs):
        s = copy.deepcopy(scene)
        s["rungs"]["smoke"].update(knobs)
        return s

    return make


@pytest.fixture
def run_smoke():
    """Render a case at the smoke rung into a directory and run it; prints the status line."""
    import json

    from granflow.deck import render_case
    from granflow.runner import run_case

    def run(scene, tmp_path, case, nprocs=1):
        render_case(scene, "smoke", tmp_path, case)
        status = run_case(tmp_path, nprocs)
        print(json.dumps({k: status[k] for k in ("status", "reason", "max_overlap", "dangerous_builds")}))
        return status

    return run
