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
