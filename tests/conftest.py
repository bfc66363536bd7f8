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


@pytest.fixture
def skiprun(lmp):
    """Set up each stage deck of a rendered case in LAMMPS with ``-skiprun`` (the runs are skipped),
    passing the variables the runner passes; assert that no stage prints an ERROR.

    ``extra`` adds variables per stage; ``edit(stage, text)`` may change a deck first (its copy
    ``<stage>_skiprun.lmp`` is what runs). Returns LAMMPS's output per stage.
    """
    import subprocess

    variables = {
        "init": ["-var", "restart_out", "init.restart"],
        "flow": ["-var", "restart_in", "init.restart", "-var", "restart_out", "flow.restart"],
        "average": ["-var", "restart_in", "init.restart", "-var", "restart_out", "avg.restart",
                    "-var", "dump_file", "dump.bin", "-var", "contacts_file", "contacts.dump"],
    }

    def run(case_dir: Path, stages, extra: dict | None = None, edit=None) -> dict:
        run_dir = case_dir / "run"
        run_dir.mkdir(exist_ok=True)
        out = {}
        for stage in stages:
            text = (case_dir / f"{stage}.lmp").read_text()
            deck = case_dir / f"{stage}_skiprun.lmp"
            deck.write_text(edit(stage, text) if edit else text)
            args = variables[stage] + list((extra or {}).get(stage, ()))
            proc = subprocess.run([lmp, "-skiprun", "-in", str(deck), "-log", "none", "-nocite", *args],
                                  cwd=run_dir, capture_output=True, text=True, timeout=300)
            errors = [line for line in proc.stdout.splitlines() if line.startswith("ERROR")]
            assert proc.returncode == 0 and not errors, f"{case_dir.name}/{stage}: {errors or proc.stdout[-2000:]}"
            out[stage] = proc.stdout
        assert (run_dir / "init.restart").exists()
        return out

    return run


@pytest.fixture(scope="session")
def scenes_off():
    """YAML lines that disable every registered scene but ``keep``: a test campaign passed with
    ``--configfile`` merges into config/config.yaml, so each scene it does not run must be off
    (including scenes added after the test was written). ``indent`` is that of the scene keys."""
    from granflow import registry

    def lines(keep=(), indent: int = 2) -> str:
        return "".join(f"{' ' * indent}{name}: {{enabled: false}}\n" for name in registry.names() if name not in keep)

    return lines
