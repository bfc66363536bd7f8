"""Throughput of the silo's axisymmetric coarse-graining, compiled (numba) vs numpy. Run by hand.

  .venv/bin/python bench/bench_cg.py --frames 5

Synthetic but realistic silo data (Rubio-Largo, Maza & Hidalgo 2016): the seven
species of radius r_b (9/16 ... 1) in equal numbers (config/scenes/silo.yaml),
density 7520 kg/m^3, in a cylinder of radius R_c = 20 r_b and height 60 r_b at
volume fraction 0.55. The packing is random: uniform random centres, then
overlaps relaxed (each overlapping pair pushed apart along its branch vector,
walls enforced) until the largest overlap is below 1 % of r_b. Frames are that
packing jittered by 0.02 r_b, with a plug-like downward flow plus random
velocities. Contacts are the pairs within 1 % of r_b of touching (about three per
particle), repulsive normal forces from the hydrostatic pressure at their height
times an exponential force-chain factor, and tangential forces up to half of them.

Measured, best of a few repeats (the machine is shared: the load average is
printed): particle-frames/s of FieldAccumulator.accumulate for the silo fields
(phi, rho, u, sigmak, pk and their partials for the 7 species) with the paper's
kernel w = 2 r_b (cutoff 8 r_b) on nodes every r_b and every 2 r_b, compiled on 1
and 2 threads and numpy (Gaussian.assign + one bincount per primitive, the
reference); contact-frames/s for the contact stress (sigmac, pc) with w = r_b / 2
(cutoff 2 r_b) on nodes every r_b / 2; and the largest relative difference
between the two paths; and, at the paper's w = r_b/2 for the pressures on nodes every r_b/4, the
kinetic pressure time-averaged (rho, u, pk) and by its eq. 7 (postproc.fluctuation: two deposits
and an interpolation per frame). Figures are recorded, not asserted.

Measured 2026-11-25, commit 808686a (bench/results/bench_cg_2026-11-25.txt, load average 1.1-1.3
with the ladder runs paused): at r_b/4 nodes with w = r_b/2 the time-averaged kinetic fields run at
0.81 / 1.33 M particle-frames/s on 1 / 2 threads (the issue's 1.5 M: 89 %), eq. 7 at 0.40 / 0.64 M
(half: two deposits per frame).

From commit fbeb7f0 (2026-11-25): far from the axis the compiled path takes J from one polynomial in
b per row of epsilon (postproc.rz_tables), evaluated for a grid row's nodes 4 at a time, instead of
a table lookup per node; agreement with numpy 3e-9 (was 1e-8); tables built in ~12 ms per kernel
(was 3 ms). Against the code before, on the same frames, interleaved (bench/bench_cg_versions.py),
the machine busy with two LAMMPS runs (load average 1.8-3.5, so the second thread found no free
core): after/before 1.35x single-threaded for the kinetic fields at r_b/4 (1.060 vs 0.786 M
particle-frames/s, wall = CPU), 1.33x for eq. 7 (0.515 vs 0.387 M), by CPU time 1.34x for the bulk
fields at r_b and 1.13-1.15x for the contacts (fewer nodes per item). Scaled from the 2026-11-25
record (commit 808686a), about 1.09 / 1.7-1.8 M at r_b/4 on 1 / 2 threads on a quiet machine (the
range: the serial part of a frame, ~15 % single-threaded, is unchanged), eq. 7 about 0.53 / 0.85 M.

Each configuration's kernel is made once and shared by its passes (a new
accumulator per pass), as in an analysis over many frames: the compiled path's
tables are built once per kernel, on its first deposit, and that time is
printed apart. The thread counts take turns pass by pass; "cores used" is the
CPU time of the best pass over its wall time, which says whether the second
thread found a free core.

Measured 2026-11-24, commit cf47081, ``.venv/bin/python bench/bench_cg.py --frames 5`` in a quiet
window (load average 0.3 before, 0.9 after): nodes every 2 r_b, compiled 1.230 M particle-frames/s
on 1 thread and 2.020 M on 2, numpy 0.038 M (32.6x, 53.5x); nodes every r_b (the silo's own spacing)
0.518 / 0.901 M, numpy 0.008 M (61x, 107x); contacts 0.122 / 0.187 M contact-frames/s; agreement
1.1e-8 (densities), 1.5e-8 (derived fields). The code before (git HEAD c9758b7), with this bench,
right after: 1.082 / 1.955 M at 2 r_b, 0.396 / 0.736 M at r_b. With both cores busy with other work
(load average 2.5-3.2): this code 1.241 / 1.310 M at 2 r_b; the code before, with its own bench,
0.962 / 0.551 M (its threads wait for each other at every frame). The output of these runs was not
kept in the repository.

Repeated later on 2026-11-24 (still commit cf47081) on a quiet machine (load average 0.6), same
command, one run of each code right after the other: this code 0.647 / 1.158 M at r_b,
1.443 / 2.523 M at 2 r_b, numpy 0.012 / 0.057 M; the code before 0.569 / 1.047 M at r_b,
1.470 / 2.621 M at 2 r_b. So the issue's 1.5 M particle-frames/s on 2 cores is met at nodes every
2 r_b (by the code before as well), not at the silo's own r_b spacing, where each particle reaches
about 250 nodes with ~40 values each: bench/results/bench_cg_2026-11-24.txt and bench_cg_2026-11-24_before.txt.
"""
from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "src"))

import numba  # noqa: E402
from scipy.spatial import cKDTree  # noqa: E402

from postproc.contacts import ContactFrame  # noqa: E402
from postproc.coordinates import RZCoordinates  # noqa: E402
from postproc.fields import FieldAccumulator  # noqa: E402
from postproc.frame import ParticleFrame  # noqa: E402
from postproc.kernels import Gaussian  # noqa: E402

R_B = 1.0 / 64.0  # largest radius, m
RADIUS_FRACTIONS = np.linspace(9.0 / 16.0, 1.0, 7)  # the scene's 7 radii / r_b
DENSITY = 7520.0  # kg/m^3
R_C, HEIGHT, PHI = 20 * R_B, 60 * R_B, 0.55
GRAVITY = 10.0
BULK_FIELDS = ("phi", "rho", "u", "sigmak", "pk")
CONTACT_FIELDS = ("sigmac", "pc")


# --------------------------------------------------------------------------- data


def _into_cylinder(position: np.ndarray, radius: np.ndarray) -> None:
    """Move centres inside the walls: r <= R_c - a, a <= z <= H - a."""
    r = np.hypot(position[:, 0], position[:, 1])
    r_max = R_C - radius
    scale = np.where(r > r_max, r_max / np.maximum(r, 1e-300), 1.0)
    position[:, :2] *= scale[:, None]
    position[:, 2] = np.clip(position[:, 2], radius, HEIGHT - radius)


def random_packing(rng: np.random.Generator, max_overlap: float = 0.01 * R_B):
    """Random centres in the silo, relaxed until no overlap exceeds ``max_overlap``.

    Returns positions (N, 3), radii (N,) and species index (N,) in [0, 7).
    """
    mean_volume = 4.0 / 3.0 * np.pi * np.mean(RADIUS_FRACTIONS**3) * R_B**3
    n = int(PHI * np.pi * R_C**2 * HEIGHT / mean_volume)
    n -= n % 7
    species = rng.permutation(np.repeat(np.arange(7), n // 7))
    radius = RADIUS_FRACTIONS[species] * R_B
    rad, theta = (R_C - radius) * np.sqrt(rng.uniform(size=n)), rng.uniform(0.0, 2 * np.pi, n)
    position = np.column_stack([rad * np.cos(theta), rad * np.sin(theta), rng.uniform(radius, HEIGHT - radius)])
    for _ in range(5000):
        pairs = cKDTree(position).query_pairs(2 * R_B, output_type="ndarray")
        branch = position[pairs[:, 0]] - position[pairs[:, 1]]
        distance = np.linalg.norm(branch, axis=1)
        overlap = radius[pairs[:, 0]] + radius[pairs[:, 1]] - distance
        hit = overlap > 0
        if not hit.any() or overlap[hit].max() < max_overlap:
            break
        push = 0.51 * (overlap[hit] / distance[hit])[:, None] * branch[hit]  # half each, slightly more
        shift = np.zeros_like(position)
        np.add.at(shift, pairs[hit, 0], push)
        np.add.at(shift, pairs[hit, 1], -push)
        position += shift
        _into_cylinder(position, radius)
    return position, radius, species


def make_frames(rng, position, radius, species, n_frames: int) -> list[ParticleFrame]:
    """The packing jittered by 0.02 r_b, plug-like flow of 0.1 m/s plus 0.02 m/s fluctuations."""
    n = len(radius)
    mass = DENSITY * 4.0 / 3.0 * np.pi * radius**3
    box = np.array([[-R_C, R_C], [-R_C, R_C], [0.0, HEIGHT]])
    frames = []
    for k in range(n_frames):
        pos = position + rng.normal(scale=0.02 * R_B, size=position.shape)
        _into_cylinder(pos, radius)
        r = np.hypot(pos[:, 0], pos[:, 1])
        velocity = rng.normal(scale=0.02, size=(n, 3))
        velocity[:, 2] -= 0.1 * (1.0 - 0.5 * (r / R_C) ** 2)
        frames.append(ParticleFrame(k, box, pos, velocity, mass, radius, type=species + 1, id=np.arange(1, n + 1)))
    return frames


def make_contacts(rng, frame: ParticleFrame, gap: float = 0.01 * R_B) -> ContactFrame:
    """Pairs within ``gap`` of touching; forces from the hydrostatic pressure at their height."""
    pos, radius = frame.position, frame.radius
    pairs = cKDTree(pos).query_pairs(2 * R_B + gap, output_type="ndarray")
    branch = pos[pairs[:, 0]] - pos[pairs[:, 1]]
    distance = np.linalg.norm(branch, axis=1)
    touching = distance < radius[pairs[:, 0]] + radius[pairs[:, 1]] + gap
    pairs, branch, distance = pairs[touching], branch[touching], distance[touching]
    normal = branch / distance[:, None]
    height = 0.5 * (pos[pairs[:, 0], 2] + pos[pairs[:, 1], 2])
    pressure = DENSITY * PHI * GRAVITY * (HEIGHT - height)
    f_n = pressure * (radius[pairs[:, 0]] + radius[pairs[:, 1]]) ** 2 * rng.exponential(size=len(pairs))
    tangent = np.cross(normal, rng.normal(size=normal.shape))
    tangent /= np.linalg.norm(tangent, axis=1)[:, None]
    force = f_n[:, None] * (normal + rng.uniform(0.0, 0.5, len(pairs))[:, None] * tangent)
    return ContactFrame(frame.timestep, frame.box, frame.id[pairs[:, 0]], frame.id[pairs[:, 1]], branch, force)


# --------------------------------------------------------------------------- timing


def grid(spacing: float):
    return np.arange(0.0, R_C + 0.5 * spacing, spacing), np.arange(0.0, HEIGHT + 0.5 * spacing, spacing)


def bulk_kernel(spacing: float) -> Gaussian:
    return Gaussian.paper(2 * R_B, grid(spacing))


def contact_kernel(spacing: float) -> Gaussian:
    return Gaussian.paper(R_B / 2, grid(spacing))


def bulk_accumulator(kernel: Gaussian, method: str) -> FieldAccumulator:
    return FieldAccumulator(kernel, RZCoordinates(), fields=BULK_FIELDS, species=range(1, 8), method=method)


def contact_accumulator(kernel: Gaussian, method: str) -> FieldAccumulator:
    return FieldAccumulator(kernel, RZCoordinates(), fields=CONTACT_FIELDS, method=method)


def kinetic_accumulator(kernel: Gaussian, method: str) -> FieldAccumulator:
    """The kinetic pressure at the paper's w = r_b/2 (its figs 8-12), time-averaged form."""
    return FieldAccumulator(kernel, RZCoordinates(), fields=("rho", "u", "pk"), method=method)


def eq7_accumulator(kernel: Gaussian, method: str):
    """The paper's eq. 7 (fluctuations about each frame's local mean): two deposits per frame."""
    from postproc.fluctuation import FluctuationAccumulator

    return FluctuationAccumulator(kernel, RZCoordinates(), fields=("rho", "pk"), method=method)


def one_pass(make, frames, contacts):
    """Wall and CPU time (all threads) of accumulating all frames into a new accumulator, and its table."""
    acc = make()
    acc.prepare()
    w0, c0 = time.perf_counter(), time.process_time()
    for k, frame in enumerate(frames):
        if contacts is None:
            acc.accumulate(frame)
        else:
            acc.accumulate(frame, contacts[k])
    wall, cpu = time.perf_counter() - w0, time.process_time() - c0
    return wall, cpu, acc.conclude()


def best_passes(make, frames, contacts, repeats: int, threads=(None,)):
    """Per thread count: the best wall time over ``repeats`` passes, its CPU time, and the last table.

    The thread counts take turns, pass by pass, so that a burst of load from
    other processes hits them alike.
    """
    best = {t: (np.inf, np.nan, None) for t in threads}
    for _ in range(repeats):
        for t in threads:
            if t is not None:
                numba.set_num_threads(t)
            wall, cpu, table = one_pass(make, frames, contacts)
            if wall < best[t][0]:
                best[t] = (wall, cpu, table)
    return best


def max_relative_difference(a, b, columns) -> float:
    """Largest |a - b| / max |b| over ``columns`` (NaN-free nodes)."""
    worst = 0.0
    for c in columns:
        x, y = a[c].to_numpy(), b[c].to_numpy()
        ok = np.isfinite(x) & np.isfinite(y)
        scale = np.max(np.abs(y[ok])) if ok.any() else 0.0
        if scale > 0:
            worst = max(worst, float(np.max(np.abs(x[ok] - y[ok])) / scale))
    return worst


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=5, help="frames per pass")
    parser.add_argument("--repeats", type=int, default=5, help="passes of the compiled path (best is kept)")
    parser.add_argument("--numpy-repeats", type=int, default=2, help="passes of the numpy path")
    parser.add_argument("--seed", type=int, default=2016)
    args = parser.parse_args(argv)

    rng = np.random.default_rng(args.seed)
    t0 = time.perf_counter()
    position, radius, species = random_packing(rng)
    frames = make_frames(rng, position, radius, species, args.frames)
    contacts = [make_contacts(rng, f) for f in frames]
    n, m = len(radius), int(np.mean([len(c) for c in contacts]))
    phi = np.sum(4 / 3 * np.pi * radius**3) / (np.pi * R_C**2 * HEIGHT)
    print(f"data: {n} particles (phi = {phi:.3f}), {m} contacts per frame ({2 * m / n:.2f} per particle), "
          f"{args.frames} frames; built in {time.perf_counter() - t0:.1f} s")
    print(f"machine: {os.cpu_count()} cores, numba {numba.__version__} ({numba.config.NUMBA_NUM_THREADS} threads), "
          f"load average before {os.getloadavg()[0]:.2f}")

    # compile (or load the cache) outside the timings; the kernels, and so the compiled path's
    # tables (built once per kernel, on its first deposit), are reused by every pass
    threads = [t for t in (1, 2) if t <= numba.config.NUMBA_NUM_THREADS]
    configurations = []
    for label, make_kernel, make_acc, spacing, cts, unit in (
        ("bulk, w = 2 r_b", bulk_kernel, bulk_accumulator, R_B, None, n),
        ("bulk, w = 2 r_b", bulk_kernel, bulk_accumulator, 2 * R_B, None, n),
        ("contacts, w = r_b/2", contact_kernel, contact_accumulator, R_B / 2, contacts, m),
        ("kinetic, w = r_b/2", contact_kernel, kinetic_accumulator, R_B / 4, None, n),
        ("kinetic eq. 7, w = r_b/2", contact_kernel, eq7_accumulator, R_B / 4, None, n),
    ):
        kernel = make_kernel(spacing)
        t0 = time.perf_counter()
        _ = kernel.rz_tables  # the property builds them
        build = time.perf_counter() - t0
        best_passes(lambda: make_acc(kernel, "compiled"), frames[:1], None if cts is None else cts[:1], 1,
                    threads)
        configurations.append((label, kernel, make_acc, spacing, cts, unit, build))

    rows, agreement = [], []
    for label, kernel, make_acc, spacing, cts, unit, build in configurations:
        reference = best_passes(lambda: make_acc(kernel, "numpy"), frames, cts, args.numpy_repeats)[None]
        reference_time, reference_cpu, reference_table = reference
        nodes = len(grid(spacing)[0]) * len(grid(spacing)[1])
        rows.append((label, spacing / R_B, nodes, "numpy", 1, unit * args.frames / reference_time, 1.0,
                     reference_cpu / reference_time))
        compiled = best_passes(lambda: make_acc(kernel, "compiled"), frames, cts, args.repeats, threads)
        for t in threads:
            elapsed, cpu, table = compiled[t]
            rows.append((label, spacing / R_B, nodes, "compiled", t, unit * args.frames / elapsed,
                         reference_time / elapsed, cpu / elapsed))
        numba.set_num_threads(max(threads))
        values = [c for c in reference_table.columns if not c.endswith("_se") and c not in ("r", "z")]
        densities = [c for c in values if c.startswith(("phi", "rho"))]
        derived = [c for c in values if c not in densities]
        agreement.append((label, spacing / R_B, max_relative_difference(table, reference_table, densities),
                          max_relative_difference(table, reference_table, derived), build))

    print()
    print(f"{'fields':22s} {'nodes':>14s} {'path':>9s} {'threads':>7s} {'items-frames/s':>15s} {'vs numpy':>9s} "
          f"{'cores used':>10s}")
    for label, spacing, nodes, path, t, rate, ratio, cores in rows:
        unit = "contact" if label.startswith("contacts") else "particle"
        print(f"{label:22s} {f'{spacing:g} r_b ({nodes})':>14s} {path:>9s} {t:7d} "
              f"{rate / 1e6:9.3f} M {unit[0]}  {ratio:8.1f}x {cores:10.2f}")
    print("(cores used: CPU time of the best pass over its wall time; below the thread count when other")
    print(" processes held the cores)")
    print()
    print("agreement, compiled vs numpy: max |difference| / max |numpy| over nodes")
    for label, spacing, dens, der, build in agreement:
        print(f"  {label:22s} nodes {spacing:g} r_b: densities {dens:.1e}, derived fields {der:.1e}"
              f" (tables built once per kernel in {build * 1e3:.0f} ms, not in the passes)")
    print(f"load average after {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
