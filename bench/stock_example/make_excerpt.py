#!/usr/bin/env python3
"""Cut the small test excerpt tests/data/stock_example/ out of a full run.

Usage: python bench/stock_example/make_excerpt.py [RUNDIR] [OUTDIR]
       (defaults /tmp/stock_example and tests/data/stock_example)

From RUNDIR/funnel_pour.dump and RUNDIR/funnel_pour_contacts.dump (written by
run.sh) it keeps

* the first frame (step 0: 0 atoms / 0 entries, the only frame that carries
  ITEM: UNITS) verbatim, and
* the frames at STEPS (consecutive, during steady discharge), restricted to
  the particles whose id is in KEEP = ids with z < ZCUT in any of those
  frames (outlet pipe, cone bottom and falling stream); contacts are kept
  when both ids are in KEEP.

Header lines, column order and row order are LAMMPS's own; only the
NUMBER OF ATOMS / ENTRIES counts and the local dump's ``index`` column
(renumbered 1..n) change. Because the selection is by id, the atom count
changes between the excerpt frames only where LAMMPS lost atoms through
the bottom of the box.
"""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

STEPS = (240000, 241000, 242000)
ZCUT = 14.0


def blocks(path):
    """(header lines, column line, row lines, step) per frame, verbatim."""
    with open(path) as fh:
        lines = fh.readlines()
    i = 0
    while i < len(lines):
        head = []
        while not (lines[i].startswith("ITEM: ATOMS") or lines[i].startswith("ITEM: ENTRIES")):
            head.append(lines[i])
            i += 1
        step = int(head[head.index("ITEM: TIMESTEP\n") + 1])
        n = int(next(head[k + 1] for k, ln in enumerate(head) if ln.startswith("ITEM: NUMBER OF")))
        cols = lines[i]
        rows = lines[i + 1:i + 1 + n]
        i += 1 + n
        yield head, cols, rows, step


def write(fh, head, cols, rows):
    for k, ln in enumerate(head):
        if k and head[k - 1].startswith("ITEM: NUMBER OF"):
            ln = f"{len(rows)}\n"
        fh.write(ln)
    fh.write(cols)
    fh.writelines(rows)


def main(argv):
    run = Path(argv[1] if len(argv) > 1 else "/tmp/stock_example")
    out = Path(argv[2] if len(argv) > 2 else "tests/data/stock_example")
    out.mkdir(parents=True, exist_ok=True)

    atoms = {b[3]: b for k, b in enumerate(blocks(run / "funnel_pour.dump")) if k == 0 or b[3] in STEPS}
    first = min(atoms)
    keep = set()
    for s in STEPS:
        names = atoms[s][1].split()[2:]
        iid, iz = names.index("id"), names.index("z")
        for r in atoms[s][2]:
            f = r.split()
            if float(f[iz]) < ZCUT:
                keep.add(int(f[iid]))
    with open(out / "funnel_pour.dump", "w") as fh:
        write(fh, *atoms[first][:3])
        for s in STEPS:
            head, cols, rows, _ = atoms[s]
            names = cols.split()[2:]
            iid = names.index("id")
            write(fh, head, cols, [r for r in rows if int(r.split()[iid]) in keep])

    loc = {b[3]: b for k, b in enumerate(blocks(run / "funnel_pour_contacts.dump")) if k == 0 or b[3] in STEPS}
    with open(out / "funnel_pour_contacts.dump", "w") as fh:
        write(fh, *loc[first][:3])
        for s in STEPS:
            head, cols, rows, _ = loc[s]
            kept = []
            for r in rows:
                f = r.split()
                if int(f[1]) in keep and int(f[2]) in keep:
                    f[0] = str(len(kept) + 1)
                    kept.append(" ".join(f) + "\n")
            write(fh, head, cols, kept)
    print(f"kept {len(keep)} ids; wrote {out}/funnel_pour.dump and funnel_pour_contacts.dump")


if __name__ == "__main__":
    main(sys.argv)
