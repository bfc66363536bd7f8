"""Before/after throughput of the compiled rz deposit: the working tree against a git revision. Run by hand.

  .venv/bin/python bench/bench_cg_versions.py --rev HEAD --frames 5 --repeats 5

The data and accumulators of bench/bench_cg.py (its synthetic silo frames; default the
kinetic fields and eq. 7 at w = r_b/2 on nodes every r_b/4). The revision's
``src/postproc/cg_compiled.py`` (with its ``rz_tables.py``, where it has one) is loaded as
a package of its own and put in place of ``postproc.cg_compiled`` pass by pass, so that the
two versions and the thread counts take turns on the same frames: a burst of load from
other processes hits them alike. Printed per configuration and thread count: the best
wall-clock rate of each version, and the after/before ratios of the best wall time and of
the best CPU time (the CPU time of all threads; on a busy machine it leaves out the time
the process waited for a core, so its ratio is the steadier one single-threaded), and the
largest relative difference between the two versions' tables. Figures are recorded, not
asserted.
"""
from __future__ import annotations

import argparse
import importlib
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "src"))
sys.path.insert(0, str(ROOT / "bench"))

import numba  # noqa: E402

import bench_cg as bench  # noqa: E402
import postproc  # noqa: E402
import postproc.cg_compiled  # noqa: E402

#: name: (kernel, accumulator, node spacing / r_b, with contacts)
CONFIGURATIONS = {
    "kinetic": (bench.contact_kernel, bench.kinetic_accumulator, 0.25, False),
    "eq7": (bench.contact_kernel, bench.eq7_accumulator, 0.25, False),
    "bulk": (bench.bulk_kernel, bench.bulk_accumulator, 1.0, False),
    "contacts": (bench.contact_kernel, bench.contact_accumulator, 0.5, True),
}


def load_revision(rev: str, into: Path):
    """``postproc.cg_compiled`` as of git revision ``rev``, imported as a package of its own under ``into``."""
    sha = subprocess.run(["git", "rev-parse", "--short", rev], cwd=ROOT, check=True, capture_output=True,
                         text=True).stdout.strip()
    package = into / f"postproc_{sha}"
    package.mkdir()
    (package / "__init__.py").write_text("")
    for name in ("cg_compiled.py", "rz_tables.py"):
        shown = subprocess.run(["git", "show", f"{rev}:src/postproc/{name}"], cwd=ROOT, capture_output=True,
                               text=True)
        if shown.returncode == 0:
            (package / name).write_text(shown.stdout)
    sys.path.insert(0, str(into))
    return sha, importlib.import_module(f"{package.name}.cg_compiled")


def use(module) -> None:
    """Make ``module`` the compiled path that postproc.kernels imports."""
    sys.modules["postproc.cg_compiled"] = module
    postproc.cg_compiled = module


def compare(name, versions, frames, contacts, threads, repeats):
    """Best wall and CPU time per (version, threads), interleaved, and the tables of the last passes."""
    make_kernel, make_accumulator, spacing, with_contacts = CONFIGURATIONS[name]
    cts = contacts if with_contacts else None
    kernels = {}
    for label, module in versions.items():  # tables and compilation outside the timings
        use(module)
        kernels[label] = make_kernel(spacing * bench.R_B)
        _ = kernels[label].rz_tables
        for t in threads:
            numba.set_num_threads(t)
            bench.one_pass(lambda: make_accumulator(kernels[label], "compiled"), frames[:1],
                           None if cts is None else cts[:1])
    best, tables = {}, {}
    for _ in range(repeats):
        for t in threads:
            numba.set_num_threads(t)
            for label, module in versions.items():
                use(module)
                wall, cpu, tables[label] = bench.one_pass(lambda: make_accumulator(kernels[label], "compiled"),
                                                          frames, cts)
                w0, c0 = best.get((label, t), (np.inf, np.inf))
                best[(label, t)] = (min(w0, wall), min(c0, cpu))
    return best, tables


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rev", default="HEAD", help="git revision of the 'before' version")
    parser.add_argument("--configurations", default="kinetic,eq7", help=f"any of {', '.join(CONFIGURATIONS)}")
    parser.add_argument("--frames", type=int, default=5)
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--seed", type=int, default=2016)
    args = parser.parse_args(argv)

    rng = np.random.default_rng(args.seed)
    position, radius, species = bench.random_packing(rng)
    frames = bench.make_frames(rng, position, radius, species, args.frames)
    names = args.configurations.split(",")
    contacts = [bench.make_contacts(rng, f) for f in frames] if "contacts" in names else None
    threads = [t for t in (1, 2) if t <= numba.config.NUMBA_NUM_THREADS]
    with tempfile.TemporaryDirectory() as tmp:
        sha, before = load_revision(args.rev, Path(tmp))
        versions = {"before": before, "after": postproc.cg_compiled}
        print(f"before: {args.rev} ({sha}); after: the working tree; {len(radius)} particles, {args.frames} frames; "
              f"load average before {os.getloadavg()[0]:.2f}")
        t0 = time.perf_counter()
        for name in names:
            best, tables = compare(name, versions, frames, contacts, threads, args.repeats)
            unit = args.frames * (np.mean([len(c) for c in contacts]) if CONFIGURATIONS[name][3] else len(radius))
            for t in threads:
                (wall_b, cpu_b), (wall_a, cpu_a) = best[("before", t)], best[("after", t)]
                print(f"{name:9s} {t} thread{'s' if t > 1 else ' '}: before {unit / wall_b / 1e6:6.3f} M/s "
                      f"({cpu_b / wall_b:.2f} cores), after {unit / wall_a / 1e6:6.3f} M/s ({cpu_a / wall_a:.2f} "
                      f"cores); after/before {wall_b / wall_a:.3f} wall, {cpu_b / cpu_a:.3f} CPU")
            columns = [c for c in tables["before"].columns if not c.endswith("_se") and c not in ("r", "z")]
            print(f"{name:9s} largest relative difference after - before: "
                  f"{bench.max_relative_difference(tables['after'], tables['before'], columns):.1e}")
        use(postproc.cg_compiled)
    print(f"({time.perf_counter() - t0:.0f} s) load average after {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
