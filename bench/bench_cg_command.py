"""Throughput of `granflow cg` (postproc.cg.coarse_grain) end to end: read a binary dump, coarse-grain. Run by hand.

  .venv/bin/python bench/bench_cg_command.py                 # 20k particles x 20 frames
  .venv/bin/python bench/bench_cg_command.py --particles 50000 --frames 40

A synthetic binary dump (LAMMPS layout, written with postproc-independent
struct code): N spheres of radius 0.5-1 (4 types) at uniform random positions in
a cylinder of radius 20 and height 60 about an axis at (23, 21) (off the origin,
as in a hopper deck), moving down at 1 with unit random velocities; each frame
is jittered. The fields are the axisymmetric Gaussian fields of `granflow cg
--coords rz --kernel gaussian --width 1 --spacing 0.5` (rho, phi, v, kinetic
stress, with --species the 4 partials), on the compiled path (numba, 1 and 2
threads) and the straightforward numpy path (Gaussian.assign + one bincount
per primitive, method="numpy"). Reported: particle-frames per second of the
whole call (reading, checks, SHA-256 of the input included), best of
--repeats, and the ratio compiled / numpy measured in the same run. The
machine is shared: the load average is printed; the figures are recorded, not
asserted.
"""
from __future__ import annotations

import argparse
import os
import struct
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "src"))

import numpy as np  # noqa: E402


def write_dump(path: Path, n: int, frames: int, seed: int = 1) -> None:
    rng = np.random.default_rng(seed)
    axis = np.array([23.0, 21.0])
    r = 20.0 * np.sqrt(rng.uniform(size=n))
    th = rng.uniform(0, 2 * np.pi, n)
    base = np.column_stack([axis[0] + r * np.cos(th), axis[1] + r * np.sin(th), rng.uniform(0, 60, n)])
    types = rng.integers(1, 5, n)
    radius = 0.5 + 0.5 * (types - 1) / 3
    mass = 4 / 3 * np.pi * radius**3
    columns = ["id", "type", "x", "y", "z", "vx", "vy", "vz", "radius", "mass"]
    colstr = " ".join(columns).encode()
    box = [0.0, 46.0, 0.0, 42.0, -1.0, 61.0]
    with open(path, "wb") as fh:
        for k in range(frames):
            pos = base + rng.normal(scale=0.05, size=base.shape)
            vel = rng.normal(size=(n, 3)) + [0, 0, -1]
            data = np.column_stack([np.arange(1, n + 1), types, pos, vel, radius, mass])
            fh.write(struct.pack("<q", -10) + b"DUMPCUSTOM" + struct.pack("<ii", 1, 2))
            fh.write(struct.pack("<qqi", 1000 * k, n, 0) + struct.pack("<6i", 1, 1, 1, 1, 1, 1))
            fh.write(struct.pack("<6d", *box) + struct.pack("<ii", len(columns), 0) + struct.pack("<b", 1))
            fh.write(struct.pack("<d", 0.01 * k) + struct.pack("<i", len(colstr)) + colstr)
            fh.write(struct.pack("<ii", 1, data.size) + data.astype("<f8").tobytes())


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--particles", type=int, default=20000)
    ap.add_argument("--frames", type=int, default=20)
    ap.add_argument("--repeats", type=int, default=2)
    ap.add_argument("--numpy-frames", type=int, default=4, help="frames for the (slow) numpy path")
    ap.add_argument("--species", action="store_true", help="add the per-type partials")
    ap.add_argument("--spacing", type=float, default=0.5, help="node spacing (the width is 1)")
    args = ap.parse_args()

    import numba

    from postproc.cg import coarse_grain

    print(f"load average {os.getloadavg()}; numba threads available {numba.config.NUMBA_NUM_THREADS}")
    with tempfile.TemporaryDirectory() as tmp:
        dump = Path(tmp) / "frames.bin"
        write_dump(dump, args.particles, args.frames)
        small = Path(tmp) / "few.bin"
        write_dump(small, args.particles, args.numpy_frames)
        common = dict(coords="rz", axis=(23.0, 21.0), kernel="gaussian", width=1.0, spacing=args.spacing,
                      ranges=[(0.0, 20.0), (0.0, 60.0)], species="auto" if args.species else None)
        # compile once outside the timings
        coarse_grain([small], **common, frames="0:1000")

        def rate(path, frames, **kw):
            best = 0.0
            for _ in range(args.repeats):
                t0 = time.perf_counter()
                result = coarse_grain([path], **common, **kw)
                dt = time.perf_counter() - t0
                best = max(best, args.particles * frames / dt)
            return best, result

        rows = []
        for threads in (1, 2):
            numba.set_num_threads(threads)
            r, result = rate(dump, args.frames)
            rows.append((f"compiled, {threads} thread(s)", r))
        numba.set_num_threads(2)
        r_np, result_np = rate(small, args.numpy_frames, method="numpy")
        rows.append(("numpy (assign + bincount)", r_np))
        _, result_c = rate(small, args.numpy_frames)
        diff = np.nanmax(np.abs(result_c.fields["rho"] - result_np.fields["rho"])) / np.nanmax(result_np.fields["rho"])
    print(f"{args.particles} particles, {args.frames} frames, rz grid {result.grid.describe()}")
    for name, r in rows:
        print(f"  {name:32s} {r / 1e6:7.3f} M particle-frames/s")
    print(f"  compiled (2 threads) / numpy: {rows[1][1] / r_np:.1f}x;  max |rho_c - rho_np| / max rho = {diff:.1e}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
