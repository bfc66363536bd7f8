#!/usr/bin/env python
"""Benchmark the LAMMPS dump readers of :mod:`postproc.dump` against MDAnalysis.

Runs LAMMPS once to write a binary and a text custom dump of the same frames
(a random packing of ``--natoms`` granular spheres settling under gravity),
then times, best of ``--repeat``:

* ``postproc.dump.read_binary_dump`` (all 13 columns, and x y z only),
* ``postproc.dump.read_text_dump`` (numpy.loadtxt per frame),
* a pandas ``read_csv`` per-frame text reader,
* MDAnalysis ``LAMMPSDUMP`` reader on the text dump (universe construction
  included; it parses ids, positions and velocities).

Throughput is in atom-frames per second. Example::

    PYTHONPATH=src .venv/bin/python bench/bench_reader.py --natoms 10000 --frames 20
"""
from __future__ import annotations

import argparse
import io
import itertools
import subprocess
import sys
import time
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
try:
    from postproc.dump import count_frames, read_binary_dump, read_text_dump
except ImportError:  # run without PYTHONPATH=src
    sys.path.insert(0, str(ROOT / "src"))
    from postproc.dump import count_frames, read_binary_dump, read_text_dump

COLUMNS = "id type radius mass x y z vx vy vz omegax omegay omegaz"

DECK = """\
units lj
atom_style sphere
boundary p p f
region box block 0 {L} 0 {L} 0 {H}
create_box 1 box
create_atoms 1 random {natoms} 4711 NULL overlap 1.0 maxtry 200
set type 1 diameter 1.0 density 1.0
pair_style gran/hooke/history 2000.0 NULL 50.0 NULL 0.5 0
pair_coeff * *
comm_modify vel yes
neighbor 0.3 bin
neigh_modify delay 0
fix 1 all nve/sphere
fix 2 all gravity 1.0 vector 0 0 -1
fix 3 all wall/gran hooke/history 2000.0 NULL 50.0 NULL 0.5 0 zplane 0.0 {H}
timestep 0.001
run {settle}
reset_timestep 0
dump b all custom {every} dump.bin {cols}
dump t all custom {every} dump.txt {cols}
dump_modify t format float %20.15g
run {nrun}
"""


def write_dumps(outdir: Path, natoms: int, frames: int, every: int, settle: int, nproc: int) -> None:
    """Run LAMMPS to write ``dump.bin`` and ``dump.txt`` in ``outdir``."""
    outdir.mkdir(parents=True, exist_ok=True)
    # box with packing fraction ~0.2 so random insertion succeeds
    L = round((natoms * np.pi / 6 / 0.2 / 2) ** (1 / 3), 1)
    deck = DECK.format(
        L=L, H=2 * L, natoms=natoms, cols=COLUMNS, every=every, settle=settle, nrun=every * (frames - 1)
    )
    (outdir / "in.bench").write_text(deck)
    binpath = Path(sys.executable).parent
    cmd = [str(binpath / "lmp"), "-in", "in.bench", "-log", "log.lammps", "-screen", "none"]
    if nproc > 1:
        cmd = [str(binpath / "mpirun"), "-np", str(nproc), *cmd]
    for name in ("dump.bin", "dump.txt"):
        (outdir / name).unlink(missing_ok=True)
    t0 = time.perf_counter()
    subprocess.run(cmd, cwd=outdir, check=True)
    print(f"lmp ({nproc} rank(s)): {time.perf_counter() - t0:.1f} s", file=sys.stderr)


def pandas_text_frames(path: Path):
    """Per-frame pandas reader of a text dump (ids sorted); yields (timestep, DataFrame)."""
    import pandas as pd

    with open(path) as fh:
        while True:
            line = fh.readline()
            if not line:
                return
            step = int(fh.readline())
            fh.readline()
            natoms = int(fh.readline())
            for _ in range(4):  # BOX BOUNDS + 3 bound lines
                fh.readline()
            names = fh.readline().split()[2:]
            block = "".join(itertools.islice(fh, natoms))
            df = pd.read_csv(io.StringIO(block), sep=" ", skipinitialspace=True, header=None, names=names)
            yield step, df.sort_values("id", kind="stable")


def mdanalysis_frames(path: Path):
    """Iterate MDAnalysis's LAMMPSDUMP reader; yields positions per frame."""
    import MDAnalysis as mda

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        u = mda.Universe(str(path), format="LAMMPSDUMP", atom_style="id type x y z")
        for ts in u.trajectory:
            yield ts.positions


def best_time(fn, repeat: int) -> tuple[float, int]:
    """Best wall time of ``repeat`` runs of ``fn`` (which returns the frames read)."""
    best, nframes = float("inf"), 0
    for _ in range(repeat):
        t0 = time.perf_counter()
        nframes = fn()
        best = min(best, time.perf_counter() - t0)
    return best, nframes


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--natoms", type=int, default=10000, help="atoms (default 10000)")
    p.add_argument("--frames", type=int, default=20, help="dump frames (default 20)")
    p.add_argument("--every", type=int, default=50, help="steps between frames (default 50)")
    p.add_argument("--settle", type=int, default=500, help="steps run before dumping (default 500)")
    p.add_argument("--np", type=int, default=1, dest="nproc", help="MPI ranks for lmp (default 1)")
    p.add_argument("--repeat", type=int, default=3, help="timing repeats, best kept (default 3)")
    p.add_argument("--out", type=Path, default=ROOT / "bench" / "out", help="output dir (default bench/out, git-ignored)")
    p.add_argument("--reuse", action="store_true", help="reuse existing dumps in --out instead of running lmp")
    p.add_argument("--skip-mdanalysis", action="store_true", help="do not time MDAnalysis")
    args = p.parse_args(argv)

    outdir = args.out
    if not (args.reuse and (outdir / "dump.bin").exists() and (outdir / "dump.txt").exists()):
        write_dumps(outdir, args.natoms, args.frames, args.every, args.settle, args.nproc)
    binf, txtf = outdir / "dump.bin", outdir / "dump.txt"
    nframes = count_frames(binf)
    natoms = next(read_binary_dump(binf, columns=["id"])).natoms
    print(
        f"{natoms} atoms x {nframes} frames; dump.bin {binf.stat().st_size / 1e6:.1f} MB, "
        f"dump.txt {txtf.stat().st_size / 1e6:.1f} MB"
    )

    def consume(it) -> int:
        return sum(1 for _ in it)

    cases = [
        ("ours binary (13 cols)", lambda: consume(read_binary_dump(binf))),
        ("ours binary (x y z)", lambda: consume(read_binary_dump(binf, columns=["x", "y", "z"]))),
        ("count_frames binary", lambda: count_frames(binf)),
        ("ours text (loadtxt)", lambda: consume(read_text_dump(txtf))),
        ("pandas text (read_csv)", lambda: consume(pandas_text_frames(txtf))),
    ]
    if not args.skip_mdanalysis:
        cases.append(("MDAnalysis text", lambda: consume(mdanalysis_frames(txtf))))

    results = {}
    print(f"{'reader':<24} {'time [s]':>10} {'atom-frames/s':>15}")
    for name, fn in cases:
        t, n = best_time(fn, args.repeat)
        if n != nframes:
            raise SystemExit(f"{name} read {n} frames, expected {nframes}")
        results[name] = natoms * n / t
        print(f"{name:<24} {t:>10.4f} {results[name]:>15.3e}")
    if "MDAnalysis text" in results:
        ref = results["MDAnalysis text"]
        print(f"ratio ours binary / MDAnalysis text: {results['ours binary (13 cols)'] / ref:.0f}x")
        print(f"ratio ours text   / MDAnalysis text: {results['ours text (loadtxt)'] / ref:.1f}x")
    return 0


if __name__ == "__main__":
    sys.exit(main())
