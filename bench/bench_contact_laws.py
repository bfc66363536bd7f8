"""What each contact law costs, run by hand (issue 27): Matom-step/s and CPU-seconds per simulated second.

  python bench/bench_contact_laws.py                     # heap (1/2 mm) and silo (7 sizes) at their validation rungs
  python bench/bench_contact_laws.py --steps 4000 --n 8000

For each scene the same dense bed (``--n`` spheres of the scene's species, equal volumes
for the heap, equal numbers for the silo, rained into a periodic box and settled under
gravity onto a granular floor) is stepped with each law of the scene's schema, its contact
commands written by the decks' own macros (``lammps_inputs/include/granular.lmp.j2``) from the
scene's parameters at the rung (``granflow.deck.scene_parameters``, with the rung's
``contact_model`` set to each law). Each law runs at its own time step (the rung's
``dt_fraction`` of its shortest contact): a law whose shortest contact is longer takes fewer
steps per simulated second. Reported per law: Matom-step/s (LAMMPS's loop time), the time
step, and CPU-seconds per simulated second per 1000 atoms. One rank; the laws alternate in
``--repeats`` rounds so that a drift of the machine falls on all of them alike.
"""
from __future__ import annotations

import argparse
import copy
import math
import re
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "src"))

from granflow.scene_files import load_scene  # noqa: E402
from granflow.contact import sphere_mass  # noqa: E402
from granflow.deck import environment, scene_parameters  # noqa: E402

CASES = {"heap": {"mixture": "bi1-2", "feed_rate": 0.033}, "silo": {"R": 6.0}}
LAWS = {"heap": ["hooke/history", "hooke/pair_time"], "silo": ["hooke/history", "hooke/pair_eq10"]}

DECK = """{% import "include/granular.lmp.j2" as gran with context %}
units           si
atom_style      sphere
boundary        p p f
newton          off
comm_modify     vel yes
region          box block 0 {{ L }} 0 {{ L }} {{ -dmax }} {{ H }} units box
create_box      {{ ntypes }} box
{{ variables }}
{% for t in types %}
region          r{{ t.type }} block 0 {{ L }} 0 {{ L }} {{ dmax }} {{ H - dmax }} units box
create_atoms    {{ t.type }} random {{ t.count }} {{ seed + t.type }} r{{ t.type }} overlap {{ t.d }} maxtry 200 units box
set             type {{ t.type }} diameter {{ t.d }}
{% endfor %}
set             group all density ${density}
{% for t in range(1, ntypes + 1) %}
group           t{{ t }} type {{ t }}
{% endfor %}
neighbor        ${skin} {{ nstyle }}
neigh_modify    delay 0 every 1 check yes
{{ gran.pair(contact) }}
{{ gran.wall(contact, "floor", "all", "wall/gran", "zplane 0.0 NULL") }}
fix             grav all gravity ${gravity} vector 0 0 -1
fix             nve all nve/sphere
timestep        ${dt}
thermo          1000
thermo_modify   lost ignore
run             {{ settle }}
run             {{ steps }}
"""


def deck(scene_name: str, law: str, n: int, steps: int) -> tuple[str, float, int]:
    scene = load_scene(ROOT / "config" / "scenes" / f"{scene_name}.yaml")
    scene = copy.deepcopy(scene)
    scene["rungs"]["validation"]["contact_model"] = law
    params, context = scene_parameters(scene, "validation", CASES[scene_name])
    prm = {p.name: p.value for p in params}
    rec = context["record"]
    rho = prm["density"]
    if scene_name == "heap":
        sp = [(s["type"], s["d"], s["volume_fraction"] / s["mean_volume"]) for s in rec["species"]]
    else:
        sp = [(s["type"], 2 * s["radius"], 1.0) for s in rec["species"]]
    weights = sum(w for _, _, w in sp)
    types = [{"type": t, "d": d, "count": max(1, round(n * w / weights))} for t, d, w in sp]
    vol = sum(t["count"] * math.pi * t["d"] ** 3 / 6 for t in types)
    dmax = max(t["d"] for t in types)
    L = 12 * dmax
    H = vol / 0.3 / L**2 + 3 * dmax  # a loose gas at 30 % that settles to a bed
    ntypes = max([len(types)] + [t for p in rec["contact_law"]["type_pairs"] for t in p["types"] if t != "wall"])
    text = environment().from_string(DECK).render(
        L=L, H=H, dmax=dmax, ntypes=ntypes, types=types, seed=4711, contact=context["contact"],
        variables="\n".join(f"variable {p.name} equal {p.value}" for p in params),
        nstyle="multi" if max(t["d"] for t in types) / min(t["d"] for t in types) >= 1.5 else "bin",
        settle=int(math.sqrt(2 * H / prm["gravity"]) * 1.5 / prm["dt"]), steps=steps)
    return text, float(prm["dt"]), sum(t["count"] for t in types)


def loop_rate(log: str) -> tuple[float, int, int]:
    """(loop seconds, steps, atoms) of the last run."""
    m = re.findall(r"Loop time of ([0-9.eE+-]+) on \d+ procs for (\d+) steps with (\d+) atoms", log)[-1]
    return float(m[0]), int(m[1]), int(m[2])


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, default=6000, help="spheres in the bed")
    ap.add_argument("--steps", type=int, default=3000, help="timed steps per run")
    ap.add_argument("--repeats", type=int, default=2, help="rounds over the laws")
    ap.add_argument("--scenes", default="heap,silo")
    a = ap.parse_args(argv)
    lmp = str(Path(sys.executable).parent / "lmp")
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for scene in a.scenes.split(","):
            runs = {law: [] for law in LAWS[scene]}
            for r in range(a.repeats):
                for law in (LAWS[scene] if r % 2 == 0 else LAWS[scene][::-1]):
                    text, dt, n = deck(scene, law, a.n, a.steps)
                    d = Path(tmp) / f"{scene}_{law.replace('/', '_')}_{r}"
                    d.mkdir()
                    (d / "in.lmp").write_text(text)
                    subprocess.run([lmp, "-in", "in.lmp", "-log", "log.lammps", "-screen", "none"], cwd=d,
                                   check=True, timeout=3600)
                    sec, steps, atoms = loop_rate((d / "log.lammps").read_text())
                    runs[law].append((atoms * steps / sec / 1e6, dt, atoms))
                    print(f"{scene} {law} round {r}: {runs[law][-1][0]:.3f} Matom-step/s, dt {dt:.4g} s", flush=True)
            for law, rs in runs.items():
                rate = sorted(x[0] for x in rs)[len(rs) // 2]
                dt, atoms = rs[0][1], rs[0][2]
                rows.append((scene, law, atoms, rate, dt, 1000 / dt / (rate * 1e6)))
    print("\n| scene | law | atoms | Matom-step/s (1 rank, median) | dt, s | CPU-s per simulated s per 1000 atoms |")
    print("|---|---|---:|---:|---:|---:|")
    for scene, law, atoms, rate, dt, cost in rows:
        print(f"| {scene} | {law} | {atoms} | {rate:.3f} | {dt:.4g} | {cost:.3g} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
