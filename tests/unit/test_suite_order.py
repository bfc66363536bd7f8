"""`make test` hands the test files to its xdist workers longest first (issue 41: the suite's last
minutes ran a few long files alone, because xdist's default order, most tests first, sent the
integration files of few long tests to the end). tests/conftest.py orders them by the seconds
recorded per file (tests/durations.json, updated by each full run in pytest's cache)."""
import json
import os
import re
import subprocess
import sys
from pathlib import Path
from types import SimpleNamespace

import conftest

ROOT = Path(__file__).resolve().parents[2]
FILES = ["tests/unit/test_autocorr.py", "tests/unit/test_structure.py", "tests/unit/test_check_kinds.py",
         "tests/unit/test_series.py"]  # 12, 10, 5 and 25 tests


def test_longest_files_first_keeps_each_files_order():
    items = [SimpleNamespace(nodeid=f"tests/{d}/test_{f}.py::t{i}") for d, f, n in
             (("unit", "a", 3), ("unit", "b", 2), ("integration", "c", 1), ("unit", "d", 2)) for i in range(n)]
    seconds = {"tests/unit/test_b.py": 400.0, "tests/unit/test_a.py": 1.0}
    got = [it.nodeid for it in conftest.longest_files_first(items, seconds)]
    assert got == ["tests/unit/test_b.py::t0", "tests/unit/test_b.py::t1",     # 400 s, recorded
                   "tests/integration/test_c.py::t0",                           # 300 s, an integration file
                   "tests/unit/test_d.py::t0", "tests/unit/test_d.py::t1",     # 10 s, a unit file
                   "tests/unit/test_a.py::t0", "tests/unit/test_a.py::t1", "tests/unit/test_a.py::t2"]


def test_the_record_holds_every_test_file_it_names():
    record = json.loads((ROOT / "tests" / "durations.json").read_text())["seconds"]
    assert record and all((ROOT / path).is_file() for path in record), [p for p in record if not (ROOT / p).is_file()]
    assert all(s >= 0 for s in record.values())


def test_xdist_runs_the_longest_file_first_and_records_the_seconds(tmp_path):
    """One worker runs the files in the order it is handed them: test_check_kinds.py, recorded as the
    longest, first (xdist alone would start with test_series.py, the most tests); afterwards the
    cache holds what each file took."""
    cache = tmp_path / "cache"
    (cache / "v" / "granflow").mkdir(parents=True)
    (cache / "v" / "granflow" / "file_seconds").write_text(json.dumps(
        {FILES[0]: 2.0, FILES[1]: 2.0, FILES[2]: 100.0, FILES[3]: 1.0}))
    env = dict(os.environ, PYTHONPATH=str(ROOT / "src"))
    env.pop("GRANFLOW_RECORD_DURATIONS", None)
    done = subprocess.run([sys.executable, "-m", "pytest", "-v", "-n", "1", "--dist", "loadfile",
                           "-o", f"cache_dir={cache}", *FILES], cwd=ROOT, env=env, capture_output=True, text=True,
                          timeout=600)
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-2000:]
    ran = list(dict.fromkeys(re.findall(r"PASSED (tests/unit/test_\w+\.py)::", done.stdout)))
    assert ran == [FILES[2], FILES[0], FILES[1], FILES[3]], ran
    measured = json.loads((cache / "v" / "granflow" / "file_seconds").read_text())
    assert set(measured) == set(FILES) and measured[FILES[2]] < 100.0  # measured now, not the seed
