#!/usr/bin/env python3
"""Independent reference numbers from a LAMMPS particle dump, no coarse-graining.

Meant as a check for ``granflow cg`` on the stock LAMMPS funnel example
(bench/stock_example/in.granregion.funnel), but works on any orthogonal-box
``dump custom`` with columns ``id x y z`` and ``radius`` or ``diameter``
(``mass``, or ``--density`` to compute it).  Text (optionally ``.gz``) and
binary (``.bin``) dumps are read by this file's own parsers (plain numpy and
struct), so nothing here shares code with ``src/postproc``.

Quantities, for the frames whose timestep lies in ``--steps LO HI``:

1. Mean mass density in a region (a cylinder about a vertical axis, or a box),
   averaged over the selected frames, three ways:

   * ``centre``  sum of masses of particles whose centres lie inside / V
   * ``zslab``   each sphere's mass weighted by the exact fraction of its volume
                 between the two horizontal planes (spherical caps); the
                 radial / x-y test is by centre                      -> / V
   * ``volume``  (cylinder only) each sphere's mass weighted by the fraction of
                 its volume inside the cylinder (slice-wise exact lens area of
                 two discs, integrated over height by Gauss-Legendre
                 quadrature in the angle; error < 1e-5 of a sphere) -> / V

   plus the solid fraction (same three ways, with sphere volumes) and the mean
   number of centres inside.

2. Mass flow rate through horizontal planes z = z0 (``--plane``, repeatable):
   for each pair of consecutive selected frames, the mass of particles (matched
   by id) whose centre went from z >= z0 to z < z0 (counted +, i.e. downward
   flow is positive) minus those going upward, divided by the time between the
   frames; reported as total crossed mass / total time, with the mean and
   standard error of the per-interval rates.  Particles that vanish between
   frames (lost through a fixed boundary) or appear (inserted) are not
   counted as crossings; those that vanish while above the plane are reported.

Time comes from ``ITEM: TIME`` / the binary time field (``dump_modify time
yes``) or from ``--dt`` x timestep.

Example (funnel, packed bed before the outlet opens, and the discharge)::

    python bench/stock_example/independent.py /tmp/stock_example/funnel_pour.dump \\
        --steps 150000 170000 --cylinder 25 25 2 13 19
    python bench/stock_example/independent.py /tmp/stock_example/funnel_pour.bin \\
        --steps 170000 270000 --cylinder 25 25 2 13 19 --plane 0 --plane 5 --plane 10
"""
from __future__ import annotations

import argparse
import gzip
import json
import math
import struct
import sys
from dataclasses import dataclass, field
from typing import Iterator

import numpy as np


# --------------------------------------------------------------------------- reading


@dataclass
class Frame:
    step: int
    time: float | None
    box: np.ndarray  # (3, 2)
    cols: dict[str, np.ndarray] = field(default_factory=dict)
    units: str | None = None


def _open_text(path: str):
    return gzip.open(path, "rt") if path.endswith(".gz") else open(path, "r")


def read_text(path: str, lo: int, hi: int) -> Iterator[Frame]:
    """Frames of a LAMMPS text dump (plain or .gz) with lo <= step <= hi."""
    units = None
    with _open_text(path) as fh:
        time = None
        step = None
        box = None
        n = None
        for line in fh:
            if not line.startswith("ITEM:"):
                raise ValueError(f"{path}: unexpected line {line[:60]!r}")
            item = line[5:].strip()
            if item == "UNITS":
                units = fh.readline().strip()
            elif item == "TIME":
                time = float(fh.readline())
            elif item == "TIMESTEP":
                step = int(fh.readline())
            elif item.startswith("NUMBER OF"):
                n = int(fh.readline())
            elif item.startswith("BOX BOUNDS"):
                if "xy" in item:
                    raise ValueError(f"{path}: triclinic boxes are not supported")
                box = np.array([fh.readline().split()[:2] for _ in range(3)], float)
            elif item.startswith("ATOMS"):
                names = item.split()[1:]
                lines = [fh.readline() for _ in range(n)]
                if lo <= step <= hi:
                    data = np.array(" ".join(lines).split(), float).reshape(n, len(names))
                    yield Frame(step, time, box, {k: data[:, i] for i, k in enumerate(names)}, units)
                time = None
            else:
                raise ValueError(f"{path}: unknown section ITEM: {item}")


def read_binary(path: str, lo: int, hi: int) -> Iterator[Frame]:
    """Frames of a LAMMPS binary custom dump (format revision 2, orthogonal box)."""
    with open(path, "rb") as fh:
        buf = fh.read()
    pos = 0
    units = None

    def take(fmt):
        nonlocal pos
        vals = struct.unpack_from("<" + fmt, buf, pos)
        pos += struct.calcsize("<" + fmt)
        return vals

    while pos < len(buf):
        (mlen,) = take("q")
        if mlen >= 0:
            raise ValueError(f"{path}: pre-2021 binary dump (no magic string) at byte {pos - 8}")
        magic = buf[pos:pos - mlen]
        pos += -mlen
        if magic not in (b"DUMPCUSTOM", b"DUMPATOM"):
            raise ValueError(f"{path}: bad magic {magic!r}")
        _endian, revision = take("ii")
        if revision < 2:
            raise ValueError(f"{path}: binary revision {revision} has no column names")
        step, natoms = take("qq")
        (tri,) = take("i")
        if tri != 0:
            raise ValueError(f"{path}: triclinic boxes are not supported")
        take("6i")
        box = np.array(take("6d")).reshape(3, 2)
        (size_one,) = take("i")
        (ulen,) = take("i")
        if ulen > 0:
            units = buf[pos:pos + ulen].decode()
            pos += ulen
        (tflag,) = take("b")
        time = take("d")[0] if tflag else None
        (clen,) = take("i")
        names = buf[pos:pos + clen].decode().split()
        pos += clen
        (nchunk,) = take("i")
        chunks = []
        for _ in range(nchunk):
            (nv,) = take("i")
            if lo <= step <= hi:
                chunks.append(np.frombuffer(buf, "<f8", nv, pos))
            pos += 8 * nv
        if lo <= step <= hi:
            data = np.concatenate(chunks) if chunks else np.zeros(0)
            data = data.reshape(natoms, size_one)
            assert len(names) == size_one
            yield Frame(step, time, box, {k: data[:, i].copy() for i, k in enumerate(names)}, units)


def read_frames(path: str, lo: int, hi: int, density: float | None, dt: float | None) -> list[Frame]:
    with open(path, "rb") as fh:
        head = fh.read(18)
    binary = head[8:18] == b"DUMPCUSTOM" or head[8:16] == b"DUMPATOM"
    frames = list((read_binary if binary else read_text)(path, lo, hi))
    for fr in frames:
        c = fr.cols
        if "radius" not in c:
            if "diameter" not in c:
                raise SystemExit(f"{path}: need a radius or diameter column")
            c["radius"] = 0.5 * c["diameter"]
        if "mass" not in c:
            if density is None:
                raise SystemExit(f"{path}: no mass column; give --density")
            c["mass"] = density * 4.0 / 3.0 * math.pi * c["radius"] ** 3
        if fr.time is None:
            if dt is None:
                raise SystemExit(f"{path}: no TIME in the dump; give --dt")
            fr.time = fr.step * dt
        order = np.argsort(c["id"], kind="stable")
        for k in c:
            c[k] = c[k][order]
    return frames


# --------------------------------------------------------------------------- geometry


def cap_fraction(zc, a, zlo, zhi):
    """Exact fraction of a sphere (centre height zc, radius a) between zlo and zhi."""

    def below(h):  # fraction of the sphere below the plane z = h
        t = np.clip((h - zc) / a, -1.0, 1.0)
        return 0.25 * (t + 1.0) ** 2 * (2.0 - t)  # cap volume / sphere volume

    return below(zhi) - below(zlo)


def _lens_area(r1, r2, d):
    """Area of the intersection of two discs (radii r1, r2, centre distance d); arrays."""
    r1, r2, d = np.broadcast_arrays(r1, r2, d)
    out = np.zeros(r1.shape)
    inside = d <= np.abs(r1 - r2)
    out[inside] = math.pi * np.minimum(r1, r2)[inside] ** 2
    part = (~inside) & (d < r1 + r2) & (r1 > 0)
    if part.any():
        a, b, c = r1[part], r2[part], d[part]
        c1 = np.clip((c * c + a * a - b * b) / (2 * c * a), -1, 1)
        c2 = np.clip((c * c + b * b - a * a) / (2 * c * b), -1, 1)
        k = np.clip((-c + a + b) * (c + a - b) * (c - a + b) * (c + a + b), 0, None)
        out[part] = a * a * np.arccos(c1) + b * b * np.arccos(c2) - 0.5 * np.sqrt(k)
    return out


_GL_X, _GL_W = np.polynomial.legendre.leggauss(96)


def cylinder_fraction(rho, zc, a, R, zlo, zhi):
    """Fraction of each sphere's volume inside the cylinder rho<R, zlo<z<zhi.

    Integrates the slice-wise lens area over height with z = zc + a sin(theta)
    (which removes the square-root end points); only spheres that straddle the
    boundary are integrated, the others are 0 or 1 exactly.
    """
    frac = np.zeros(len(rho))
    full = (rho + a <= R) & (zc - a >= zlo) & (zc + a <= zhi)
    frac[full] = 1.0
    cut = ~full & (rho - a < R) & (zc + a > zlo) & (zc - a < zhi)
    if cut.any():
        r, z, s = rho[cut], zc[cut], a[cut]
        th1 = np.arcsin(np.clip((zlo - z) / s, -1, 1))
        th2 = np.arcsin(np.clip((zhi - z) / s, -1, 1))
        half = 0.5 * (th2 - th1)
        th = 0.5 * (th2 + th1)[:, None] + half[:, None] * _GL_X[None, :]
        slice_r = s[:, None] * np.cos(th)
        area = _lens_area(slice_r, R, r[:, None])
        vol = (area * (s[:, None] * np.cos(th)) * _GL_W[None, :]).sum(1) * half
        frac[cut] = vol / (4.0 / 3.0 * math.pi * s ** 3)
    return frac


# --------------------------------------------------------------------------- quantities


def density(frames: list[Frame], args) -> dict:
    rows = {k: [] for k in ("n_centre", "rho_centre", "rho_zslab", "rho_volume",
                            "phi_centre", "phi_zslab", "phi_volume")}
    if args.cylinder:
        xc, yc, R, zlo, zhi = args.cylinder
        V = math.pi * R * R * (zhi - zlo)
        desc = f"cylinder axis z through (x,y)=({xc:g},{yc:g}), r<{R:g}, {zlo:g}<z<{zhi:g}"
    else:
        xlo, xhi, ylo, yhi, zlo, zhi = args.box
        V = (xhi - xlo) * (yhi - ylo) * (zhi - zlo)
        desc = f"box {xlo:g}<x<{xhi:g}, {ylo:g}<y<{yhi:g}, {zlo:g}<z<{zhi:g}"
    for fr in frames:
        c = fr.cols
        x, y, z, a, m = c["x"], c["y"], c["z"], c["radius"], c["mass"]
        vs = 4.0 / 3.0 * math.pi * a ** 3
        if args.cylinder:
            rho = np.hypot(x - xc, y - yc)
            lateral = rho < R
        else:
            lateral = (x >= xlo) & (x < xhi) & (y >= ylo) & (y < yhi)
        inside = lateral & (z >= zlo) & (z < zhi)
        fz = np.where(lateral, cap_fraction(z, a, zlo, zhi), 0.0)
        rows["n_centre"].append(inside.sum())
        rows["rho_centre"].append(m[inside].sum() / V)
        rows["rho_zslab"].append((m * fz).sum() / V)
        rows["phi_centre"].append(vs[inside].sum() / V)
        rows["phi_zslab"].append((vs * fz).sum() / V)
        if args.cylinder:
            fv = cylinder_fraction(rho, z, a, R, zlo, zhi)
            rows["rho_volume"].append((m * fv).sum() / V)
            rows["phi_volume"].append((vs * fv).sum() / V)
    out = {"region": desc, "volume": V, "nframes": len(frames)}
    for k, v in rows.items():
        if v:
            v = np.asarray(v, float)
            out[k] = {"mean": float(v.mean()),
                      "sem": float(v.std(ddof=1) / math.sqrt(len(v))) if len(v) > 1 else float("nan")}
    return out


def flux(frames: list[Frame], z0: float) -> dict:
    masses, dts, counts = [], [], [0, 0]
    vanished_above = 0
    max_dz = 0.0
    for f0, f1 in zip(frames[:-1], frames[1:]):
        c0, c1 = f0.cols, f1.cols
        _, i0, i1 = np.intersect1d(c0["id"], c1["id"], assume_unique=True, return_indices=True)
        za, zb = c0["z"][i0], c1["z"][i1]
        down = (za >= z0) & (zb < z0)
        up = (za < z0) & (zb >= z0)
        m = c0["mass"][i0]
        masses.append(m[down].sum() - m[up].sum())
        counts[0] += int(down.sum())
        counts[1] += int(up.sum())
        if (down | up).any():
            max_dz = max(max_dz, float(np.abs(zb - za)[down | up].max()))
        gone = np.setdiff1d(np.arange(len(c0["id"])), i0)
        vanished_above += int((c0["z"][gone] >= z0).sum())
        dts.append(f1.time - f0.time)
    masses, dts = np.asarray(masses), np.asarray(dts)
    rates = masses / dts
    return {
        "plane_z": z0,
        "intervals": len(dts),
        "crossed_mass": float(masses.sum()),
        "total_time": float(dts.sum()),
        "rate": float(masses.sum() / dts.sum()) if len(dts) else float("nan"),
        "rate_mean": float(rates.mean()) if len(rates) else float("nan"),
        "rate_sem": float(rates.std(ddof=1) / math.sqrt(len(rates))) if len(rates) > 1 else float("nan"),
        "n_down": counts[0],
        "n_up": counts[1],
        "max_abs_dz_crossing": max_dz,
        "vanished_above_plane": vanished_above,
    }


# --------------------------------------------------------------------------- CLI


def main(argv=None) -> int:
    p = argparse.ArgumentParser(
        description="Independent (no coarse-graining) mass density in a region and mass flow "
                    "rate through horizontal planes, straight from a LAMMPS dump.",
        epilog="Example" + __doc__.split("Example", 1)[1],
        formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("dump", help="LAMMPS dump: text, text.gz, or binary (.bin)")
    p.add_argument("--steps", nargs=2, type=int, metavar=("LO", "HI"), default=(0, 2**62),
                   help="use frames with LO <= timestep <= HI (default: all)")
    g = p.add_mutually_exclusive_group()
    g.add_argument("--cylinder", nargs=5, type=float, metavar=("XC", "YC", "R", "ZLO", "ZHI"),
                   help="density region: vertical cylinder (default 25 25 2 13 19, inside the "
                        "funnel's packed bed)")
    g.add_argument("--box", nargs=6, type=float, metavar=("XLO", "XHI", "YLO", "YHI", "ZLO", "ZHI"),
                   help="density region: box instead of a cylinder")
    p.add_argument("--plane", type=float, action="append",
                   help="height z0 of a horizontal plane for the mass flow rate (repeatable; "
                        "default 0 = outlet exit of the funnel)")
    p.add_argument("--density", type=float, help="particle material density, if the dump has no mass column")
    p.add_argument("--dt", type=float, help="timestep, if the dump has no TIME item")
    p.add_argument("--json", metavar="FILE", help="also write the numbers as JSON")
    args = p.parse_args(argv)
    if not args.cylinder and not args.box:
        args.cylinder = [25.0, 25.0, 2.0, 13.0, 19.0]
    planes = args.plane if args.plane else [0.0]

    frames = read_frames(args.dump, args.steps[0], args.steps[1], args.density, args.dt)
    if not frames:
        print("no frames in that step range", file=sys.stderr)
        return 1
    units = next((f.units for f in frames if f.units), None) or "?"
    ns = [len(f.cols["id"]) for f in frames]
    gaps = np.diff([f.step for f in frames])
    if len(gaps) and gaps.max() > 1.01 * gaps.min():
        print(f"warning: frame spacing is not uniform ({gaps.min()}..{gaps.max()} steps); the flux "
              "counts crossings only between consecutive frames, check --steps", file=sys.stderr)
    dens = density(frames, args)
    fluxes = [flux(frames, z0) for z0 in planes]

    mu, lu, tu = ("kg/m^3", "kg/s", "s") if units == "si" else ("mass/length^3", "mass/time", "time")
    print(f"dump            {args.dump}")
    print(f"units           {units}")
    print(f"frames          {len(frames)}: steps {frames[0].step}..{frames[-1].step}, "
          f"t = {frames[0].time:.6g}..{frames[-1].time:.6g} {tu}, atoms/frame {min(ns)}..{max(ns)}")
    print(f"density region  {dens['region']}  (V = {dens['volume']:.6g})")
    print()
    print(f"{'quantity':<38} {'mean':>14} {'s.e.m.':>12}  units")
    print("-" * 76)

    def row(name, d, u):
        if d:
            print(f"{name:<38} {d['mean']:>14.6g} {d['sem']:>12.3g}  {u}")

    row("particles with centre inside", dens["n_centre"], "-")
    row("mass density, centres", dens["rho_centre"], mu)
    row("mass density, exact z-slab fraction", dens["rho_zslab"], mu)
    row("mass density, exact volume fraction", dens.get("rho_volume"), mu)
    row("solid fraction, centres", dens["phi_centre"], "-")
    row("solid fraction, exact z-slab fraction", dens["phi_zslab"], "-")
    row("solid fraction, exact volume fraction", dens.get("phi_volume"), "-")
    for fl in fluxes:
        print(f"{'mass flow rate down through z=' + format(fl['plane_z'], 'g'):<38} "
              f"{fl['rate']:>14.6g} {fl['rate_sem']:>12.3g}  {lu}")
    print()
    for fl in fluxes:
        print(f"plane z={fl['plane_z']:g}: {fl['intervals']} intervals, {fl['total_time']:.6g} {tu}; "
              f"crossed mass {fl['crossed_mass']:.6g} (down {fl['n_down']}, up {fl['n_up']} particles); "
              f"mean of per-interval rates {fl['rate_mean']:.6g}; max |dz| of a crossing "
              f"{fl['max_abs_dz_crossing']:.3g}; vanished above plane {fl['vanished_above_plane']}")
    if args.json:
        with open(args.json, "w") as fh:
            json.dump({"dump": args.dump, "units": units, "steps": [frames[0].step, frames[-1].step],
                       "times": [frames[0].time, frames[-1].time], "nframes": len(frames),
                       "density": dens, "flux": fluxes}, fh, indent=1, default=float)
    return 0


if __name__ == "__main__":
    sys.exit(main())
