"""Benchmarks of the channel scene, run by hand (results are recorded in notes, not asserted).

  python bench/bench_channel.py throughput   # LAMMPS Matom-step/s, demo channel, 2 MPI ranks
  python bench/bench_channel.py campaign     # wall time of the default campaign from scratch

Figures are ratios or rates measured in one run: the machines are shared and noisy.
"""
from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "src"))
BIN = Path(sys.executable).parent


def throughput(rung: str, np_: int, t_flow: float) -> dict:
    from granflow.scene_files import load_scene
    from granflow.deck import render_case
    from granflow.runner import CaseRunner, performance

    scene = load_scene(ROOT / "config" / "scenes" / "channel.yaml",
                       [f"rungs.{rung}.t_segment={t_flow}", f"rungs.{rung}.t_flow_max={t_flow}",
                        f"rungs.{rung}.t_average={t_flow}", f"rungs.{rung}.dump_interval={t_flow / 10}"])
    with tempfile.TemporaryDirectory() as tmp:
        rec = render_case(scene, rung, tmp, {"phi_mean": 0.58})
        runner = CaseRunner(tmp, np_)
        t0 = time.time()
        runner.run()
        wall = time.time() - t0
        out = {}
        for name in ("init", "flow_001", "average_001"):
            perf = performance((Path(tmp) / "run" / "logs" / f"{name}.log").read_text())
            out[name] = max(perf) if perf else None
    return {"rung": rung, "ranks": np_, "particles": rec["parameters"]["n_particles"],
            "matom_step_per_s": out, "wall_s": round(wall, 1)}


def campaign() -> dict:
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.time()
        proc = subprocess.run([str(BIN / "snakemake"), "--snakefile", str(ROOT / "Snakefile"),
                               "--directory", tmp, "--cores", "2",
                               "--config", f"results_dir={tmp}/results"], capture_output=True, text=True)
        return {"exit": proc.returncode, "wall_s": round(time.time() - t0, 1)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("what", choices=["throughput", "campaign"], nargs="?", default="throughput")
    ap.add_argument("--rung", default="demo")
    ap.add_argument("--np", type=int, default=2, help="MPI ranks (default 2)")
    ap.add_argument("--t-flow", type=float, default=10.0, help="flow and averaging time of the throughput run")
    args = ap.parse_args()
    result = throughput(args.rung, args.np, args.t_flow) if args.what == "throughput" else campaign()
    print(json.dumps(result, indent=2))


if __name__ == "__main__":
    main()
