"""Shared fixtures: project paths and the LAMMPS executables of the venv; the property-test budget."""
import json
import os
import shutil
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "src"))
BIN = Path(sys.executable).parent

#: ``GRANFLOW_THOROUGH=1`` (``make test-thorough``) loads the Hypothesis profile
#: ``granflow-thorough``: property tests draw :data:`THOROUGH_FACTOR` times as many examples,
#: from a fresh random seed each run (a failure prints its ``@reproduce_failure`` blob, and
#: ``pytest --hypothesis-seed=N`` repeats a run). Without it (``make test``) the profile is
#: ``granflow``: every run draws the same examples, a fixed, seeded budget.
THOROUGH = os.environ.get("GRANFLOW_THOROUGH", "") not in ("", "0")
THOROUGH_FACTOR = 20


def pytest_configure(config):
    """Register and load the Hypothesis profiles. A property test states its ``make test``
    budget ``n`` relative to the profile's ``max_examples`` (100 in ``granflow``, so it draws
    ``n * settings.default.max_examples // 100``). Neither profile writes an example database
    into the work tree or has a deadline (a slow machine is not a failure)."""
    from hypothesis import settings

    common = dict(database=None, deadline=None)
    settings.register_profile("granflow", derandomize=True, max_examples=100, print_blob=False, **common)
    settings.register_profile("granflow-thorough", derandomize=False, max_examples=100 * THOROUGH_FACTOR,
                              print_blob=True, **common)
    settings.load_profile("granflow-thorough" if THOROUGH else "granflow")
    # xdist keeps the files in our order (longest first, :func:`pytest_collection_modifyitems`), and
    # the controller (or a plain run) times each file
    if getattr(config.option, "dist", "no") in ("loadfile", "loadscope"):
        config.option.loadscopereorder = False
    if not hasattr(config, "workerinput") and not config.pluginmanager.has_plugin("granflow-file-clock"):
        config.pluginmanager.register(FileClock(config), "granflow-file-clock")


# ------------------------------------------------------------------ the order of files under xdist
#: seconds each test file takes (its tests' setup, call and teardown, summed): ``make test``
#: (``-n auto --dist loadfile``) hands files to the workers longest first, so that no long file
#: starts last and runs alone while the other worker idles. pytest-xdist's own order (its
#: ``--loadscope-reorder``, the default) puts the files with most tests first, which sent the
#: integration files, few tests of minutes each, to the end. Refreshed by ``make test-durations``.
DURATIONS = ROOT / "tests" / "durations.json"
#: seconds taken for a file the record does not hold: an integration file as long (LAMMPS,
#: Snakemake), a unit file as short
DEFAULT_SECONDS = {"integration": 300.0, "unit": 10.0}
#: where each full run leaves its measured seconds per file (pytest's cache), used before the record
CACHE_KEY = "granflow/file_seconds"
#: options that run part of a file: such a run's sums are not a file's duration
PARTIAL = ("keyword", "markexpr", "lf", "failedfirst", "stepwise", "deselect")


def file_seconds(config) -> dict:
    """Seconds per test file: the committed record, updated by this checkout's last full runs."""
    try:
        recorded = json.loads(DURATIONS.read_text())["seconds"]
    except (OSError, ValueError, KeyError):
        recorded = {}
    cached = config.cache.get(CACHE_KEY, {}) if getattr(config, "cache", None) else {}
    return {**recorded, **(cached if isinstance(cached, dict) else {})}


def expected_seconds(path: str, seconds: dict) -> float:
    """The seconds a file (``tests/unit/test_x.py``) is expected to take."""
    if path in seconds:
        return float(seconds[path])
    parts = Path(path).parts
    return DEFAULT_SECONDS.get(parts[1] if len(parts) > 2 else "", DEFAULT_SECONDS["unit"])


def longest_files_first(items: list, seconds: dict) -> list:
    """``items`` grouped by file, the files by expected seconds (longest first), collection order
    kept within a file and between files of equal time."""
    first = {}
    for item in items:
        first.setdefault(item.nodeid.split("::")[0], len(first))
    return sorted(items, key=lambda it: (-expected_seconds(it.nodeid.split("::")[0], seconds),
                                         first[it.nodeid.split("::")[0]]))


def pytest_collection_modifyitems(config, items):
    """On an xdist worker (every worker sorts alike, from the same files), longest files first."""
    if hasattr(config, "workerinput"):
        items[:] = longest_files_first(items, file_seconds(config))


class FileClock:
    """Sums each file's test durations from the reports (in the xdist controller, or a plain run)
    and, after a run of whole files, keeps them in pytest's cache; with ``GRANFLOW_RECORD_DURATIONS=1``
    also writes :data:`DURATIONS`."""

    def __init__(self, config):
        self.config, self.seconds = config, {}

    def pytest_runtest_logreport(self, report):
        path = report.nodeid.split("::")[0]
        self.seconds[path] = self.seconds.get(path, 0.0) + report.duration

    def pytest_sessionfinish(self, session):
        option = self.config.option
        if not self.seconds or any(getattr(option, name, None) for name in PARTIAL):
            return
        measured = {path: round(s, 1) for path, s in self.seconds.items()}
        if getattr(self.config, "cache", None):
            self.config.cache.set(CACHE_KEY, {**self.config.cache.get(CACHE_KEY, {}), **measured})
        if os.environ.get("GRANFLOW_RECORD_DURATIONS", "") not in ("", "0"):
            try:
                recorded = json.loads(DURATIONS.read_text())["seconds"]
            except (OSError, ValueError, KeyError):
                recorded = {}
            merged = dict(sorted({**recorded, **measured}.items(), key=lambda kv: (-kv[1], kv[0])))
            DURATIONS.write_text(json.dumps({"about": RECORD_ABOUT, "seconds": merged}, indent=1) + "\n")


#: the record's own description, written with it
RECORD_ABOUT = ("seconds per test file (setup + call + teardown of its tests, summed), measured by "
                "`make test-durations`; tests/conftest.py hands files to the xdist workers longest first")


def pytest_report_header(config):
    from hypothesis import settings

    mode = "thorough: a fresh random seed" if THOROUGH else "fixed and seeded (GRANFLOW_THOROUGH=1 for the long run)"
    return f"granflow property tests: {mode}, max_examples {settings.default.max_examples}"


@pytest.fixture(scope="session")
def root() -> Path:
    return ROOT


@pytest.fixture(scope="session")
def lmp() -> str:
    exe = BIN / "lmp"
    return str(exe) if exe.exists() else (shutil.which("lmp") or "lmp")


@pytest.fixture(scope="session")
def channel_scene():
    from granflow.scene_files import load_scene

    return load_scene(ROOT / "config" / "scenes" / "channel.yaml")


@pytest.fixture(scope="session")
def heap_scene():
    from granflow.scene_files import load_scene

    return load_scene(ROOT / "config" / "scenes" / "heap.yaml")


@pytest.fixture(scope="session")
def silo_scene():
    from granflow.scene_files import load_scene

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
    # as the runner does (granflow.runner.Case._segment): decks that write a snapshot name it so
    for stage, args in variables.items():
        args += ["-var", "snapshot_file", f"snapshot_{stage}.jpg"]

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
    (including scenes added after the test was written). ``indent`` is that of the scene keys.
    With ``cost=True`` the lines are for the ``cost.scenes`` section: only the studies that
    config/config.yaml holds (an entry there needs its base rung and knobs; a scene without one
    has no study to switch off)."""
    import yaml

    from granflow import registry

    studies = (yaml.safe_load((ROOT / "config" / "config.yaml").read_text()).get("cost") or {}).get("scenes") or {}

    def lines(keep=(), indent: int = 2, cost: bool = False) -> str:
        names = [n for n in registry.names() if n not in keep and (not cost or n in studies)]
        return "".join(f"{' ' * indent}{name}: {{enabled: false}}\n" for name in names)

    return lines


def _replace_once(text: str, old: str, new: str) -> str:
    """``text`` with its one occurrence of ``old`` replaced by ``new``; fails loudly if ``old``
    is absent or repeated (a config file edited by a test must still say what the test expects)."""
    found = text.count(old)
    assert found == 1, f"expected {old!r} exactly once in the text a test edits, found it {found} times"
    return text.replace(old, new)


@pytest.fixture(scope="session")
def replace_once():
    """``replace_once(text, old, new)``: :func:`str.replace` of exactly one occurrence, else a failure."""
    return _replace_once


@pytest.fixture(scope="session")
def short_channel_file():
    """``short_channel_file(dest)``: config/scenes/channel.yaml, averaging even an unsteady run, with a shorter
    smoke rung (4 + 3 time units, 6 frames: a dump to damage, not a long run), written to ``dest``."""
    def write(dest: Path) -> Path:
        text = _replace_once((ROOT / "config" / "scenes" / "channel.yaml").read_text(),
                             "average_unsteady: false", "average_unsteady: true")
        head, rest = text.split("\n  smoke:", 1)
        smoke, tail = rest.split("\n  demo:", 1)
        for old, new in (("t_flow_max: 20.0", "t_flow_max: 4.0"), ("t_segment: 10.0", "t_segment: 4.0"),
                         ("t_average: 10.0", "t_average: 3.0"), ("dump_interval: 1.0", "dump_interval: 0.5")):
            smoke = _replace_once(smoke, old, new)
        Path(dest).write_text(head + "\n  smoke:" + smoke + "\n  demo:" + tail)
        return Path(dest)

    return write


def _check_png(path: Path, min_pixels: tuple[int, int] = (400, 300)):
    """Assert ``path`` is a real PNG image of at least ``min_pixels`` (width, height), not blank.

    Not blank: at least 1 % of the pixels differ from the most common colour (the
    background). A figure at our 150 dpi is >= 6 x 4 inches (900 x 600 pixels); axes,
    labels and a footer alone cover a few per cent of it. Returns the RGB(A) array.
    """
    import numpy as np
    from matplotlib.image import imread

    path = Path(path)
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n", f"{path} is not a PNG file"
    image = imread(path)
    height, width = image.shape[:2]
    assert width >= min_pixels[0] and height >= min_pixels[1], f"{path}: only {width} x {height} pixels"
    rgb = image[..., :3].reshape(-1, 3)
    assert rgb.std() > 0, f"{path} is one flat colour"
    # one integer per colour: a PNG channel holds 8 or 16 bits, which imread returns as
    # k / (2**bits - 1); times 65535 that is within 0.004 of an integer below 2**16 (k * 257
    # for 8 bits), so the rounded channels packed into 48 bits name each colour exactly.
    # (np.unique over rows of floats gives the same counts ~20 times slower: 4 s a figure.)
    levels = np.rint(rgb * np.float32(65535)).astype(np.uint64)
    codes = (levels[:, 0] << np.uint64(32)) | (levels[:, 1] << np.uint64(16)) | levels[:, 2]
    colours, counts = np.unique(codes, return_counts=True)
    drawn = 1 - counts.max() / len(rgb)
    assert drawn > 0.01, f"{path}: {100 * drawn:.2f} % of the pixels differ from the background"
    return image


@pytest.fixture(scope="session")
def check_png():
    """``check_png(path, min_pixels=(400, 300))``: a real, non-blank PNG of plausible size."""
    return _check_png


def _plotted(ax) -> list[tuple]:
    """Every (x, y) series drawn in ``ax``: lines (errorbar data lines included) and scatter offsets."""
    import numpy as np

    series = [(np.asarray(line.get_xdata(), float), np.asarray(line.get_ydata(), float)) for line in ax.get_lines()]
    for coll in ax.collections:
        offsets = np.asarray(coll.get_offsets(), float)
        if offsets.ndim == 2 and offsets.shape[1] == 2 and len(offsets):
            series.append((offsets[:, 0], offsets[:, 1]))
    return series


def _assert_plotted(ax, x, y, rtol: float = 1e-12) -> None:
    """Assert that ``ax`` shows the points (x, y), finite ones only, as one series (in order)."""
    import numpy as np

    x, y = np.asarray(x, float), np.asarray(y, float)
    ok = np.isfinite(x) & np.isfinite(y)
    want_x, want_y = x[ok], y[ok]
    for px, py in _plotted(ax):
        keep = np.isfinite(px) & np.isfinite(py)
        px, py = px[keep], py[keep]
        if len(px) == len(want_x) and np.allclose(px, want_x, rtol=rtol, atol=0) \
                and np.allclose(py, want_y, rtol=rtol, atol=0):
            return
    shown = [(len(px), px[:3].tolist(), py[:3].tolist()) for px, py in _plotted(ax)]
    raise AssertionError(f"{ax.get_title()!r}: no series with the {len(want_x)} points "
                         f"x = {want_x[:3].tolist()}..., y = {want_y[:3].tolist()}...; shown: {shown}")


@pytest.fixture(scope="session")
def assert_plotted():
    """``assert_plotted(ax, x, y)``: the axes show exactly these points as one series."""
    return _assert_plotted


def _minimal_scene(scenes_dir: Path, config_dir: Path, name: str = "tmp_throwaway", edits: dict | None = None) -> Path:
    """Add the minimal scene of ``tests/data/minimal_scene`` as package ``scenes_dir/<name>`` (its
    ``__init__.py`` and the chute's deck template renamed), with the chute's schema and scene file
    renamed under ``config_dir/schema`` and ``config_dir/scenes``: the three places a new scene's
    files go. ``edits`` maps a text of the scene file to its replacement (each found exactly once).
    Returns the package folder."""
    package = scenes_dir / name
    package.mkdir(parents=True)
    shutil.copyfile(ROOT / "tests" / "data" / "minimal_scene" / "__init__.py", package / "__init__.py")
    shutil.copyfile(ROOT / "src" / "granflow" / "scenes" / "chute" / "chute.lmp.j2", package / f"{name}.lmp.j2")
    schema = (ROOT / "config" / "schema" / "chute.schema.yaml").read_text()
    schema = _replace_once(schema, "scene: {const: chute, default: chute,", f"scene: {{const: {name}, default: {name},")
    (config_dir / "schema").mkdir(parents=True, exist_ok=True)
    (config_dir / "schema" / f"{name}.schema.yaml").write_text(schema)
    text = _replace_once((ROOT / "config" / "scenes" / "chute.yaml").read_text(), "scene: chute ", f"scene: {name} ")
    for old, new in (edits or {}).items():
        text = _replace_once(text, old, new)
    (config_dir / "scenes").mkdir(parents=True, exist_ok=True)
    (config_dir / "scenes" / f"{name}.yaml").write_text(text)
    return package


@pytest.fixture(scope="session")
def minimal_scene():
    """``minimal_scene(scenes_dir, config_dir, name="tmp_throwaway", edits=None)``: write a scene that gives only
    what granflow.registry.REQUIRED asks (see :func:`_minimal_scene`); returns its package folder."""
    return _minimal_scene


def _project_copy(dest: Path) -> Path:
    """A copy of the project's code and workflow (Snakefile, workflows/, config/, src/, lammps_inputs/)
    at ``dest``: a checkout to add scene packages to. Run it with ``PYTHONPATH=<dest>/src`` so that
    granflow is imported from the copy."""
    skip = shutil.ignore_patterns("__pycache__", "*.egg-info")
    for name in ("workflows", "config", "src", "lammps_inputs"):
        shutil.copytree(ROOT / name, dest / name, ignore=skip)
    shutil.copyfile(ROOT / "Snakefile", dest / "Snakefile")
    return dest


@pytest.fixture(scope="session")
def project_copy():
    """``project_copy(dest)``: a copy of the project's code and workflow (see :func:`_project_copy`)."""
    return _project_copy
