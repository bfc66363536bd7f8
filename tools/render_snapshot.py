#!/usr/bin/env python3
"""Render every scene's decks at every rung, or compare two such snapshots.

The scene redesign must not change what ``granflow render`` writes. This script
uses only the command line (``granflow scenes`` if it exists, else the names
given with ``--scenes``), so the same script runs before and after a change:

    python tools/render_snapshot.py render /tmp/before --scenes channel heap silo
    ... change the code ...
    python tools/render_snapshot.py render /tmp/after
    python tools/render_snapshot.py compare /tmp/before /tmp/after

For each scene and rung it renders the scene file's default case, plus every
sweep point of the campaign file (``config/config.yaml``) at the campaign's rung,
plus the base case of the campaign's error-versus-cost study.
``compare`` reports every file that differs, ignoring LAMMPS comment lines
(``#`` to the end of a line) and blank lines in decks and in what the
command printed; ``params.json`` is
compared as parsed JSON, data files byte for byte. Exit 1 if anything differs.
"""
from __future__ import annotations

import argparse
import itertools
import json
import re
import subprocess
import sys
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parents[1]
GRANFLOW = [sys.executable, "-m", "granflow.cli"]


def _scene_names(given: list[str] | None) -> list[str]:
    if given:
        return given
    out = subprocess.run([*GRANFLOW, "scenes"], capture_output=True, text=True, check=True).stdout
    return [line.split()[0] for line in out.splitlines() if line.strip() and not line.startswith(" ")]


def _render(scene: str, rung: str, out: Path, sets: list[str]) -> None:
    cmd = [*GRANFLOW, "render", scene, "--rung", rung, "--out", str(out)]
    for s in sets:
        cmd += ["--set", s]
    proc = subprocess.run(cmd, capture_output=True, text=True)
    out.parent.mkdir(parents=True, exist_ok=True)
    # the snapshot's own folder is not part of what is compared
    root = str(out.parent.parent)
    (out.parent / f"{out.name}.stdout").write_text((proc.stdout + proc.stderr).replace(root, "SNAPSHOT"))
    status = "ok" if proc.returncode == 0 else f"exit {proc.returncode}"
    print(f"{scene:8s} {rung:6s} {out.name}: {status}", flush=True)


def _sweep_points(sweep: dict) -> list[dict]:
    keys = list(sweep)
    return [dict(zip(keys, values)) for values in itertools.product(*(sweep[k] for k in keys))]


def render(dest: Path, scenes: list[str] | None) -> None:
    campaign = yaml.safe_load((ROOT / "config" / "config.yaml").read_text())
    for scene in _scene_names(scenes):
        scene_file = yaml.safe_load((ROOT / "config" / "scenes" / f"{scene}.yaml").read_text())
        for rung in scene_file["rungs"]:
            _render(scene, rung, dest / scene / f"{rung}~default", [])
        study = ((campaign.get("cost") or {}).get("scenes") or {}).get(scene)
        if study:
            sets = [f"{k}={json.dumps(v)}" for k, v in (study.get("set") or {}).items()]
            _render(scene, study["base_rung"], dest / scene / f"{study['base_rung']}~cost_base", sets)
        sc = campaign.get("scenes", {}).get(scene)
        if not sc:
            continue
        for i, point in enumerate(_sweep_points(sc.get("sweep") or {})):
            sets = [f"case.{k}={json.dumps(v)}" for k, v in point.items()]
            _render(scene, campaign["rung"], dest / scene / f"{campaign['rung']}~sweep{i}", sets)


def _deck_lines(path: Path) -> list[str]:
    lines = []
    for line in path.read_text().splitlines():
        line = re.sub(r"\s*#.*$", "", line).rstrip()
        if line:
            lines.append(line)
    return lines


def compare(a: Path, b: Path) -> int:
    files_a = {p.relative_to(a) for p in a.rglob("*") if p.is_file()}
    files_b = {p.relative_to(b) for p in b.rglob("*") if p.is_file()}
    bad = 0
    for rel in sorted(files_a ^ files_b):
        print(f"only in {'first' if rel in files_a else 'second'}: {rel}")
        bad += 1
    n = 0
    for rel in sorted(files_a & files_b):
        pa, pb = a / rel, b / rel
        n += 1
        if rel.suffix in (".lmp", ".stdout"):
            same = _deck_lines(pa) == _deck_lines(pb)
        elif rel.suffix == ".json":
            same = json.loads(pa.read_text()) == json.loads(pb.read_text())
        else:
            same = pa.read_bytes() == pb.read_bytes()
        if not same:
            print(f"differs: {rel}")
            bad += 1
    print(f"{n} files compared, {bad} differences")
    return 1 if bad else 0


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = ap.add_subparsers(dest="cmd", required=True)
    p = sub.add_parser("render", help="render every scene at every rung into DEST")
    p.add_argument("dest", type=Path)
    p.add_argument("--scenes", nargs="*", help="scene names (default: `granflow scenes`)")
    p = sub.add_parser("compare", help="compare two snapshots, comment lines aside")
    p.add_argument("a", type=Path)
    p.add_argument("b", type=Path)
    args = ap.parse_args()
    if args.cmd == "render":
        render(args.dest, args.scenes)
        return 0
    return compare(args.a, args.b)


if __name__ == "__main__":
    sys.exit(main())
