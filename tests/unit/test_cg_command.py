"""`granflow cg` on hand-made dumps with known answers (through the command, not just the API)."""
from __future__ import annotations

import gzip
import json
import os
import shutil
import struct
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from granflow.cli import main as granflow

# --------------------------------------------------------------------------- writers


def _box(box):
    return np.asarray(box, dtype=float).reshape(3, 2)


def write_text(path, frames, columns, box, boundary=("pp", "pp", "pp"), units=None, opener=open):
    """A LAMMPS text custom dump; ``frames`` are (timestep, time or None, {column: array})."""
    box = _box(box)
    with opener(path, "wt") as fh:
        for k, (step, t, data) in enumerate(frames):
            if units and k == 0:
                fh.write(f"ITEM: UNITS\n{units}\n")
            if t is not None:
                fh.write(f"ITEM: TIME\n{t!r}\n")
            n = len(next(iter(data.values())))
            fh.write(f"ITEM: TIMESTEP\n{step}\nITEM: NUMBER OF ATOMS\n{n}\n")
            fh.write(f"ITEM: BOX BOUNDS {' '.join(boundary)}\n")
            for lo, hi in box:
                fh.write(f"{float(lo)!r} {float(hi)!r}\n")
            fh.write("ITEM: ATOMS " + " ".join(columns) + "\n")
            for i in range(n):
                fh.write(" ".join(repr(float(data[c][i])) for c in columns) + "\n")


def write_binary(path, frames, columns, box, units=None):
    """A LAMMPS >= 2021 binary custom dump (format revision 2), one chunk per frame."""
    box = _box(box)
    colstr = " ".join(columns).encode()
    with open(path, "wb") as fh:
        for k, (step, t, data) in enumerate(frames):
            n = len(next(iter(data.values())))
            fh.write(struct.pack("<q", -10) + b"DUMPCUSTOM" + struct.pack("<ii", 1, 2))
            fh.write(struct.pack("<qqi", step, n, 0) + struct.pack("<6i", 0, 0, 0, 0, 0, 0))
            fh.write(struct.pack("<6d", *box.ravel()))
            u = (units or "").encode() if k == 0 else b""
            fh.write(struct.pack("<ii", len(columns), len(u)) + u)
            fh.write(struct.pack("<b", 1 if t is not None else 0))
            if t is not None:
                fh.write(struct.pack("<d", t))
            fh.write(struct.pack("<i", len(colstr)) + colstr + struct.pack("<i", 1))
            values = np.column_stack([np.asarray(data[c], float) for c in columns]).ravel()
            fh.write(struct.pack("<i", values.size) + values.astype("<f8").tobytes())


def write_contacts(path, frames, box):
    """A text dump local of contacts: (timestep, rows of id1 id2 dx dy dz fx fy fz)."""
    box = _box(box)
    with open(path, "w") as fh:
        for step, rows in frames:
            fh.write(f"ITEM: TIMESTEP\n{step}\nITEM: NUMBER OF ENTRIES\n{len(rows)}\n")
            fh.write("ITEM: BOX BOUNDS pp pp pp\n" + "".join(f"{lo} {hi}\n" for lo, hi in box))
            fh.write("ITEM: ENTRIES id1 id2 dx dy dz fx fy fz\n")
            for row in rows:
                fh.write(" ".join(repr(float(v)) for v in row) + "\n")


COLUMNS = ["id", "type", "x", "y", "z", "vx", "vy", "vz", "radius", "mass"]


def particles(pos, vel=None, radius=0.4, mass=2.0, types=None, ids=None):
    pos = np.asarray(pos, float)
    n = len(pos)
    vel = np.zeros((n, 3)) if vel is None else np.asarray(vel, float)
    return {
        "id": np.arange(1, n + 1) if ids is None else ids,
        "type": np.ones(n) if types is None else types,
        "x": pos[:, 0], "y": pos[:, 1], "z": pos[:, 2],
        "vx": vel[:, 0], "vy": vel[:, 1], "vz": vel[:, 2],
        "radius": np.full(n, radius), "mass": np.full(n, mass),
    }


def cg(*args) -> int:
    return granflow(["cg", *map(str, args)])


def fields(out) -> pd.DataFrame:
    return pd.read_csv(Path(out) / "fields.csv")


def lattice(nx, ny, nz, a=1.0):
    g = np.stack(np.meshgrid(*(np.arange(n) + 0.5 for n in (nx, ny, nz)), indexing="ij"), -1).reshape(-1, 3)
    return g * a


# --------------------------------------------------------------------------- known answers


@pytest.fixture
def lattice_dump(tmp_path):
    """4 x 4 x 16 simple cubic lattice, spacing 1, spheres r = 0.4, m = 2: rho = 2, phi = 4/3 pi 0.4^3."""
    pos = lattice(4, 4, 16)
    frames = [(step, 0.001 * step, particles(pos)) for step in (0, 100, 200, 300)]
    path = tmp_path / "lattice.dump"
    write_text(path, frames, COLUMNS, [0, 4, 0, 4, 0, 16], units="lj")
    return path


def test_uniform_lattice_gives_flat_known_density(lattice_dump, tmp_path):
    phi = 4.0 / 3.0 * np.pi * 0.4**3
    assert cg(lattice_dump, "--coords", "z", "--kernel", "heaviside", "--spacing", 1, "--out", tmp_path / "h") == 0
    table = fields(tmp_path / "h")
    assert list(table.columns[:2]) == ["z", "n"]
    np.testing.assert_allclose(table["rho"], 2.0, rtol=1e-12)
    np.testing.assert_allclose(table["phi"], phi, rtol=1e-12)
    np.testing.assert_allclose(table["rho_se"], 0.0, atol=1e-12)
    assert len(table) == 16

    assert cg(lattice_dump, "--coords", "xyz", "--kernel", "heaviside", "--spacing", 1, "--out", tmp_path / "b") == 0
    np.testing.assert_allclose(fields(tmp_path / "b")["rho"], 2.0, rtol=1e-12)

    # Gaussian along z: flat away from the ends (no boundary correction), where
    # the sum of Gaussians of width a on a lattice of spacing a is flat to ~1e-8
    # once the truncation is far out (its jump, exp(-c^2/2w^2), makes ripples)
    assert cg(lattice_dump, "--coords", "z", "--width", 1.0, "--cutoff", 6.0, "--spacing", 0.25,
              "--out", tmp_path / "g") == 0
    table = fields(tmp_path / "g")
    interior = table[(table.z > 6.2) & (table.z < 9.8)]
    np.testing.assert_allclose(interior["rho"], 2.0, rtol=1e-6)
    np.testing.assert_allclose(interior["phi"], phi, rtol=1e-6)
    for component in ("v_x", "v_y", "v_z", "sigmak_xx", "sigmak_xz", "pk"):
        np.testing.assert_allclose(interior[component], 0.0, atol=1e-12)
    meta = json.loads((tmp_path / "g" / "meta.json").read_text())
    assert meta["frames"]["count"] == 4 and meta["frames"]["first_time"] == 0.0
    assert meta["frames"]["last_time"] == pytest.approx(0.3)
    assert meta["units"].endswith("lj") and meta["kernel"]["cutoff"] == 6.0
    assert meta["inputs"][0]["sha256"] and meta["inputs"][0]["format"] == "text"
    assert (tmp_path / "g" / "fields.vtr").stat().st_size > 0


def rings(axis=(3.0, 4.0), radii=(0.5, 1.5, 2.5), layers=4, omega=2.0, t=0.0):
    """Particles on rings about a vertical axis, every 0.2 rad of arc, rotating rigidly at omega."""
    pos, vel = [], []
    for r in radii:
        n = int(round(2 * np.pi * r / 0.2))
        theta = 2 * np.pi * np.arange(n) / n + omega * t
        for z in np.arange(layers) + 0.5:
            x, y = axis[0] + r * np.cos(theta), axis[1] + r * np.sin(theta)
            pos.append(np.column_stack([x, y, np.full(n, z)]))
            vel.append(np.column_stack([-omega * (y - axis[1]), omega * (x - axis[0]), np.zeros(n)]))
    return np.concatenate(pos), np.concatenate(vel)


def test_rigid_rotation_about_an_off_origin_axis(tmp_path):
    frames = []
    for k, t in enumerate((0.0, 0.05, 0.1, 0.15)):
        pos, vel = rings(t=t)
        frames.append((k * 50, t, particles(pos, vel, radius=0.05, mass=1.0)))
    path = tmp_path / "rot.dump"
    write_text(path, frames, COLUMNS, [0, 7, 0, 8, 0, 4])
    out = tmp_path / "rz"
    assert cg(path, "--coords", "rz", "--axis", "3,4", "--kernel", "heaviside", "--spacing", "1",
              "--range", "0:3,0:4", "--out", out) == 0
    table = fields(out)
    assert list(table.columns[:2]) == ["r", "z"]
    np.testing.assert_allclose(table["v_t"], 2.0 * table["r"], rtol=1e-12)
    np.testing.assert_allclose(table["v_r"], 0.0, atol=1e-12)
    np.testing.assert_allclose(table["v_z"], 0.0, atol=1e-12)
    for c in ("rr", "tt", "zz", "rt", "rz", "tz"):
        np.testing.assert_allclose(table[f"sigmak_{c}"], 0.0, atol=1e-10)
    # mass per ring layer over the ring volume
    n_ring = np.array([round(2 * np.pi * r / 0.2) for r in (0.5, 1.5, 2.5)])
    expected = n_ring / (np.pi * (np.arange(1, 4) ** 2 - np.arange(3) ** 2))
    np.testing.assert_allclose(table.groupby("r")["rho"].mean().to_numpy(), expected, rtol=1e-12)

    assert cg(path, "--coords", "r", "--axis", "3,4", "--kernel", "heaviside", "--spacing", "1",
              "--range", "0:3", "--out", tmp_path / "r") == 0
    np.testing.assert_allclose(fields(tmp_path / "r")["v_t"], [1.0, 3.0, 5.0], rtol=1e-12)

    # the default axis is the box centre, (3.5, 4): radial velocities appear, and a warning says so
    assert cg(path, "--coords", "r", "--kernel", "heaviside", "--spacing", "1", "--range", "0:3",
              "--out", tmp_path / "default") == 0
    meta = json.loads((tmp_path / "default" / "meta.json").read_text())
    assert meta["coordinates"]["axis"] == [3.5, 4.0]
    assert any("axis not given" in w for w in meta["warnings"])


def test_two_overlapping_spheres_give_the_analytic_contact_stress(tmp_path):
    box = [0, 4, 0, 2, 0, 2]
    pos = np.array([[2.45, 1.0, 1.0], [1.55, 1.0, 1.0]])
    frames = [(step, None, particles(pos, radius=0.5, mass=1.0)) for step in (0, 10)]
    atoms, local = tmp_path / "pair.dump", tmp_path / "pair.local"
    write_text(atoms, frames, COLUMNS, box)
    f, dx = 50.0, 0.9  # repulsive force on 1 by 2 along the branch x1 - x2
    write_contacts(local, [(0, [(1, 2, dx, 0, 0, f, 0, 0)]), (10, [(1, 2, dx, 0, 0, f, 0, 0)])], box)
    volume = 4.0 * 2.0 * 2.0
    assert cg(atoms, "--contacts", local, "--coords", "x", "--kernel", "heaviside", "--spacing", 4,
              "--range", "0:4", "--out", tmp_path / "one") == 0
    table = fields(tmp_path / "one")
    assert table["sigmac_xx"].iloc[0] == pytest.approx(f * dx / volume, rel=1e-12)
    assert table["pc"].iloc[0] == pytest.approx(f * dx / volume / 3, rel=1e-12)
    for c in ("yy", "zz", "xy", "xz", "yz"):
        assert table[f"sigmac_{c}"].iloc[0] == pytest.approx(0.0, abs=1e-12)

    # Gaussian nodes: the contact stress integrates to f dx over the box (to the
    # grid's quadrature error of a kernel cut off at 3 widths, ~1e-6)
    assert cg(atoms, "--contacts", local, "--coords", "x", "--width", 0.5, "--spacing", 0.05,
              "--out", tmp_path / "g") == 0
    table = fields(tmp_path / "g")
    assert (table["sigmac_xx"].sum() * 0.05 * 2.0 * 2.0) == pytest.approx(f * dx, rel=1e-5)


def random_frames(n=60, steps=(0, 100, 200, 300, 400), seed=3):
    rng = np.random.default_rng(seed)
    out = []
    for step in steps:
        pos = rng.uniform([0, 0, 0], [5, 5, 10], size=(n, 3))
        vel = rng.normal(size=(n, 3)) + [0, 0, -1]
        data = particles(pos, vel, radius=0.3, mass=1.5, types=rng.integers(1, 3, n))
        order = rng.permutation(n)  # atoms unsorted, as MPI runs write them
        out.append((step, 0.01 * step, {k: np.asarray(v)[order] for k, v in data.items()}))
    return out


def test_shuffled_columns_binary_and_gzip_give_identical_fields(tmp_path):
    frames = random_frames()
    box = [0, 5, 0, 5, 0, 10]
    write_text(tmp_path / "a.dump", frames, COLUMNS, box)
    shuffled = ["vz", "mass", "x", "type", "id", "vy", "radius", "z", "vx", "y"]
    write_text(tmp_path / "b.dump", frames, shuffled, box)
    write_binary(tmp_path / "c.data", frames, COLUMNS, box)  # binary, told by content not name
    write_text(tmp_path / "d.dump.gz", frames, shuffled, box, opener=gzip.open)
    tables = []
    for name in ("a.dump", "b.dump", "c.data", "d.dump.gz"):
        out = tmp_path / f"out_{name}"
        assert cg(tmp_path / name, "--coords", "xz", "--width", 0.5, "--spacing", "0.5,1", "--species",
                  "--out", out) == 0
        tables.append(fields(out))
    for other in tables[1:]:
        pd.testing.assert_frame_equal(tables[0], other, check_exact=True)
    assert {"rho_s1", "rho_s2", "v_x", "v_z", "sigmak_xz"} <= set(tables[0].columns)
    np.testing.assert_allclose(tables[0]["rho_s1"] + tables[0]["rho_s2"], tables[0]["rho"], rtol=1e-12)
    meta = json.loads((tmp_path / "out_c.data" / "meta.json").read_text())
    assert meta["inputs"][0]["format"] == "binary"


def test_diameter_and_density_stand_in_for_radius_and_mass(tmp_path):
    frames = random_frames()
    box = [0, 5, 0, 5, 0, 10]
    write_text(tmp_path / "a.dump", frames, COLUMNS, box)
    density = 1.5 / (4.0 / 3.0 * np.pi * 0.3**3)
    alt = [(s, t, {**{k: v for k, v in d.items() if k not in ("radius", "mass")}, "diameter": 2 * d["radius"]})
           for s, t, d in frames]
    write_text(tmp_path / "b.dump", alt, ["id", "type", "x", "y", "z", "vx", "vy", "vz", "diameter"], box)
    for name in ("a", "b"):
        extra = ["--density", density] if name == "b" else []
        assert cg(tmp_path / f"{name}.dump", "--coords", "z", "--kernel", "lucy", "--width", 1.0,
                  "--spacing", 0.5, *extra, "--out", tmp_path / name) == 0
    a, b = fields(tmp_path / "a"), fields(tmp_path / "b")
    np.testing.assert_allclose(b["rho"], a["rho"], rtol=1e-12)
    np.testing.assert_allclose(b["phi"], a["phi"], rtol=1e-12)


def test_frames_selection_and_block_errors(tmp_path):
    frames = random_frames()
    write_text(tmp_path / "a.dump", frames, COLUMNS, [0, 5, 0, 5, 0, 10])
    assert cg(tmp_path / "a.dump", "--coords", "z", "--kernel", "heaviside", "--spacing", 2,
              "--frames", "100:300", "--out", tmp_path / "sel") == 0
    meta = json.loads((tmp_path / "sel" / "meta.json").read_text())
    assert meta["frames"]["count"] == 3
    assert (meta["frames"]["first_step"], meta["frames"]["last_step"]) == (100, 300)
    table = fields(tmp_path / "sel")
    # Heaviside bins: the mass density is the mean over frames of the bin mass / volume
    expected = np.zeros(5)
    for step, _, d in frames[1:4]:
        expected += np.bincount((d["z"] // 2).astype(int), weights=d["mass"], minlength=5) / (5 * 5 * 2)
    np.testing.assert_allclose(table["rho"], expected / 3, rtol=1e-12)
    assert (table["rho_se"] > 0).all()


# --------------------------------------------------------------------------- refusals


def refused(capsys, *args) -> str:
    assert cg(*args) == 2
    err = capsys.readouterr().err
    assert "refused" in err and "Traceback" not in err
    return err


def test_refusals_before_reading(lattice_dump, tmp_path, capsys):
    out = tmp_path / "never"
    err = refused(capsys, lattice_dump, "--coords", "rz", "--axis", "9,2", "--width", 1, "--spacing", 1, "--out", out)
    assert "--axis 9,2" in err and "outside the box" in err
    err = refused(capsys, lattice_dump, "--coords", "z", "--width", 0.1, "--spacing", 1, "--out", out)
    assert "--width 0.1" in err and "0.4" in err
    err = refused(capsys, lattice_dump, "--coords", "xyz", "--width", 1, "--spacing", 0.01, "--out", out)
    assert "nodes" in err and "--max-nodes" in err
    err = refused(capsys, lattice_dump, "--coords", "z", "--kernel", "gaussian", "--spacing", 1, "--out", out)
    assert "--width is required" in err
    err = refused(capsys, lattice_dump, "--coords", "xz", "--kernel", "heaviside", "--spacing", "1,1,1", "--out", out)
    assert "--spacing" in err and "x, z" in err
    assert not out.exists()


def test_missing_columns_are_listed(tmp_path, capsys):
    frames = [(0, None, {k: v for k, v in particles(lattice(2, 2, 2)).items() if k not in ("vx", "vy", "vz")})]
    write_text(tmp_path / "novel.dump", frames, ["id", "x", "y", "z", "radius", "mass"], [0, 2, 0, 2, 0, 2])
    err = refused(capsys, tmp_path / "novel.dump", "--coords", "z", "--kernel", "heaviside", "--spacing", 1,
                  "--out", tmp_path / "o")
    assert "vx" in err and "id x y z radius mass" in err


def test_truncated_dump_names_frame_and_byte_and_keeps_complete_frames_on_request(tmp_path, capsys):
    frames = random_frames()
    full = tmp_path / "full.bin"
    write_binary(full, frames, COLUMNS, [0, 5, 0, 5, 0, 10])
    cut = tmp_path / "cut.bin"
    data = full.read_bytes()
    cut.write_bytes(data[: len(data) - 100])
    err = refused(capsys, cut, "--coords", "z", "--kernel", "heaviside", "--spacing", 2, "--out", tmp_path / "o")
    assert "frame 4" in err and "byte" in err and "--allow-truncated" in err
    assert not (tmp_path / "o").exists()
    assert cg(cut, "--coords", "z", "--kernel", "heaviside", "--spacing", 2, "--allow-truncated",
              "--out", tmp_path / "kept") == 0
    meta = json.loads((tmp_path / "kept" / "meta.json").read_text())
    assert meta["frames"]["count"] == 4 and meta["frames"]["truncated"]
    # the same as the first four frames of the intact file
    assert cg(full, "--coords", "z", "--kernel", "heaviside", "--spacing", 2, "--frames", "0:300",
              "--out", tmp_path / "four") == 0
    pd.testing.assert_frame_equal(fields(tmp_path / "kept"), fields(tmp_path / "four"), check_exact=True)


def test_contact_frames_without_atom_frames_are_refused_by_timestep(tmp_path, capsys):
    box = [0, 4, 0, 2, 0, 2]
    pos = np.array([[2.45, 1.0, 1.0], [1.55, 1.0, 1.0]])
    write_text(tmp_path / "a.dump", [(s, None, particles(pos, radius=0.5)) for s in (0, 10)], COLUMNS, box)
    row = [(1, 2, 0.9, 0, 0, 50.0, 0, 0)]
    write_contacts(tmp_path / "c.local", [(0, row), (5, row), (10, row)], box)
    err = refused(capsys, tmp_path / "a.dump", "--contacts", tmp_path / "c.local", "--coords", "x",
                  "--kernel", "heaviside", "--spacing", 4, "--out", tmp_path / "o")
    assert "step 5" in err


def test_rerun_does_not_overwrite(lattice_dump, tmp_path, capsys):
    args = [lattice_dump, "--coords", "z", "--kernel", "heaviside", "--spacing", 1, "--out", tmp_path / "o"]
    assert cg(*args) == 0
    err = refused(capsys, *args)
    assert "already holds" in err and "--overwrite" in err
    assert cg(*args, "--overwrite") == 0


def test_sparse_grid_warns_with_counts(lattice_dump, tmp_path):
    assert cg(lattice_dump, "--coords", "z", "--kernel", "heaviside", "--spacing", 1, "--range", "20:30",
              "--out", tmp_path / "o") == 0
    meta = json.loads((tmp_path / "o" / "meta.json").read_text())
    assert any("0 of 1024 particle-frames" in w for w in meta["warnings"])


def test_vtk_file_holds_the_grid_and_arrays(lattice_dump, tmp_path):
    assert cg(lattice_dump, "--coords", "xz", "--kernel", "heaviside", "--spacing", "1,2",
              "--out", tmp_path / "o") == 0
    head = (tmp_path / "o" / "fields.vtr").read_bytes()[:4000].decode("latin-1")
    assert 'type="RectilinearGrid"' in head
    assert 'WholeExtent="0 3 0 0 0 7"' in head
    assert 'Name="rho"' in head and 'Name="v_z"' in head


def test_help_has_an_example():
    exe = shutil.which("granflow") or str(Path(sys.executable).with_name("granflow"))
    text = subprocess.run([exe, "cg", "--help"], capture_output=True, text=True, check=True).stdout
    assert "example" in text and "--coords" in text and "--frames" in text


# --------------------------------------------------------------------------- a dump granflow did not write

STOCK = Path(__file__).resolve().parents[1] / "data" / "stock_example"
ROLES = ("id1=c_ids[1],id2=c_ids[2],dx=c_pl[1],dy=c_pl[2],dz=c_pl[3],fnx=c_pl[4],fny=c_pl[5],fnz=c_pl[6],"
         "ftx=c_pl[7],fty=c_pl[8],ftz=c_pl[9]")


def test_stock_lammps_funnel_against_independent_counts(tmp_path):
    """The stock LAMMPS funnel example (tests/data/stock_example): our fields against plain counts."""
    reference = json.loads((STOCK / "independent_pipe.json").read_text())["density"]
    atoms, local = STOCK / "funnel_pour.dump", STOCK / "funnel_pour_contacts.dump"
    # mass density in the outlet pipe (r < 2 about x = y = 25, 0 < z < 10): one bin
    assert cg(atoms, "--coords", "rz", "--axis", "25,25", "--kernel", "heaviside", "--spacing", "2,10",
              "--range", "0:2,0:10", "--frames", "240000:242000", "--out", tmp_path / "pipe") == 0
    pipe = fields(tmp_path / "pipe")
    assert pipe["rho"].iloc[0] == pytest.approx(reference["rho_centre"]["mean"], rel=1e-9)
    assert pipe["v_z"].iloc[0] < 0  # draining
    meta = json.loads((tmp_path / "pipe" / "meta.json").read_text())
    assert meta["units"].endswith("si") and meta["frames"]["count"] == 3
    assert meta["frames"]["first_time"] == pytest.approx(25.3131619217964)

    # contact stress with the column roles given: its trace over the whole box is
    # sum(f . r) / V per frame, counted straight from the local dump
    assert cg(atoms, "--coords", "z", "--kernel", "heaviside", "--spacing", 70, "--range=-20:50",
              "--contacts", local, "--contact-columns", ROLES, "--frames", "240000:242000",
              "--out", tmp_path / "box") == 0
    box = fields(tmp_path / "box")
    work, frames = 0.0, 0
    lines = local.read_text().splitlines()
    for k, line in enumerate(lines):
        if line.startswith("ITEM: TIMESTEP") and int(lines[k + 1]) >= 240000:
            n = int(lines[k + 3])
            rows = np.loadtxt(lines[k + 9: k + 9 + n], ndmin=2)
            work += np.sum((rows[:, 6:9] + rows[:, 9:12]) * rows[:, 3:6])
            frames += 1
    assert frames == 3
    volume = 30.0 * 30.0 * 70.0
    trace = box[["sigmac_xx", "sigmac_yy", "sigmac_zz"]].sum(axis=1).iloc[0]
    assert trace == pytest.approx(work / frames / volume, rel=1e-9)
    assert box["pc"].iloc[0] > 0  # compressive


def test_exact_volume_splits_spheres_over_slabs(tmp_path):
    """One sphere centred on a bin edge: half its volume in each slab (centre counting puts all in one)."""
    pos = np.array([[1.0, 1.0, 1.0]])
    write_text(tmp_path / "one.dump", [(0, None, particles(pos, radius=0.5))], COLUMNS, [0, 2, 0, 2, 0, 2])
    half = 0.5 * (4.0 / 3.0 * np.pi * 0.125) / (2.0 * 2.0 * 1.0)
    assert cg(tmp_path / "one.dump", "--coords", "z", "--kernel", "heaviside", "--spacing", 1,
              "--exact-volume", "--out", tmp_path / "exact") == 0
    np.testing.assert_allclose(fields(tmp_path / "exact")["phi"], [half, half], rtol=1e-12)
    assert cg(tmp_path / "one.dump", "--coords", "z", "--kernel", "heaviside", "--spacing", 1,
              "--out", tmp_path / "centre") == 0
    np.testing.assert_allclose(fields(tmp_path / "centre")["phi"], [0.0, 2 * half], rtol=1e-12)


# --------------------------------------------------------------------------- impossible particles


def refusal(capsys, *args) -> str:
    """The one line after 'granflow: refused: ' of a refused command (exit 2, no traceback)."""
    assert cg(*args) == 2
    err = capsys.readouterr().err
    assert err.startswith("granflow: refused: ") and "Traceback" not in err, err
    assert err.count("\n") == 1, err
    return err[len("granflow: refused: "):].strip()


def impossible_dump(path, column, value, step=200, atom=7, writer=write_text, columns=COLUMNS):
    """Frames 0, 100, 200 of a 2 x 2 x 4 lattice; at ``step`` atom id ``atom`` has ``column`` = ``value``.

    Atoms are written in reverse id order: the reader sorts them, the message names the id."""
    frames = []
    for s in (0, 100, 200):
        data = {k: np.asarray(v, dtype=float)[::-1].copy() for k, v in particles(lattice(2, 2, 4)).items()}
        if "diameter" in columns:
            data["diameter"] = 2.0 * data.pop("radius")
        if s == step:
            data[column][data["id"] == atom] = value
        frames.append((s, None, data))
    writer(path, frames, columns, [0, 2, 0, 2, 0, 4])
    return path


HEAVISIDE_Z = ("--coords", "z", "--kernel", "heaviside", "--spacing", 1)


@pytest.mark.parametrize("column, value, allowed", [
    ("mass", -1.0, "a positive finite number"),
    ("mass", 0.0, "a positive finite number"),
    ("radius", 0.0, "a positive finite number"),
    ("radius", -0.4, "a positive finite number"),
    ("mass", np.nan, "a finite number"),
    ("radius", np.inf, "a finite number"),
    ("x", np.nan, "a finite number"),
    ("z", np.inf, "a finite number"),
    ("vy", -np.inf, "a finite number"),
    ("vz", np.nan, "a finite number"),
])
@pytest.mark.parametrize("writer", [write_text, write_binary], ids=["text", "binary"])
def test_impossible_particles_are_refused_naming_file_step_atom_and_column(tmp_path, capsys, column, value,
                                                                           allowed, writer):
    dump = impossible_dump(tmp_path / "bad.dump", column, value, writer=writer)
    out = tmp_path / "o"
    line = refusal(capsys, dump, *HEAVISIDE_Z, "--out", out)
    assert line.startswith(f"{dump}: frame at step 200, atom id 7: column {column} = {value:g} is not allowed: "
                           f"allowed {allowed}"), line
    assert ("--drop-nonfinite" in line) == (allowed == "a finite number")
    assert not out.exists()  # nothing written


def test_diameter_and_atoms_without_ids_are_named(tmp_path, capsys):
    dump = impossible_dump(tmp_path / "d.dump", "diameter", -0.8, step=0, atom=3,
                           columns=[c if c != "radius" else "diameter" for c in COLUMNS])
    line = refusal(capsys, dump, *HEAVISIDE_Z, "--out", tmp_path / "o")
    assert "frame at step 0, atom id 3: column diameter = -0.8 is not allowed" in line
    # no id column: the atom is named by its place in the frame (atoms 16..1 written in reverse: id 3 is 14th)
    dump = impossible_dump(tmp_path / "noid.dump", "vx", np.nan, step=100, atom=3, columns=COLUMNS[1:])
    line = refusal(capsys, dump, *HEAVISIDE_Z, "--out", tmp_path / "o")
    assert "frame at step 100, atom 14 of the frame (the dump has no id column): column vx = nan" in line


def test_several_bad_atoms_are_counted_and_mass_below_zero_beats_drop_nonfinite(tmp_path, capsys):
    frames = [(0, None, particles(lattice(2, 2, 4)))]
    frames[0][2]["mass"] = np.where(np.arange(16) % 4 == 1, -2.0, 2.0)  # ids 2, 6, 10, 14
    frames[0][2]["vx"] = np.full(16, np.nan)
    write_text(tmp_path / "m.dump", frames, COLUMNS, [0, 2, 0, 2, 0, 4])
    line = refusal(capsys, tmp_path / "m.dump", *HEAVISIDE_Z, "--drop-nonfinite", "--out", tmp_path / "o")
    assert "atom id 2: column mass = -2 is not allowed" in line and "(4 atoms of this frame" in line
    assert not (tmp_path / "o").exists()


def test_drop_nonfinite_leaves_the_atoms_out_and_counts_them(tmp_path, capsys):
    """The fields with --drop-nonfinite are those of the dump without the bad atoms, exactly."""
    frames = random_frames()
    bad = {0: [("x", 3, np.nan)], 200: [("vz", 5, np.inf), ("z", 5, np.nan), ("mass", 9, np.nan)],
           400: [("radius", 11, -np.inf)]}
    dirty, clean = [], []
    for step, t, data in frames:
        data = {k: np.asarray(v, dtype=float).copy() for k, v in data.items()}
        drop = np.zeros(len(data["id"]), bool)
        for column, atom, value in bad.get(step, []):
            data[column][data["id"] == atom] = value
            drop |= data["id"] == atom
        dirty.append((step, t, data))
        clean.append((step, t, {k: v[~drop] for k, v in data.items()}))
    write_binary(tmp_path / "dirty.bin", dirty, COLUMNS, [0, 5, 0, 5, 0, 10])
    write_binary(tmp_path / "clean.bin", clean, COLUMNS, [0, 5, 0, 5, 0, 10])
    args = ("--coords", "z", "--width", 0.5, "--spacing", 0.5, "--quiet")
    line = refusal(capsys, tmp_path / "dirty.bin", *args, "--out", tmp_path / "o")
    assert "frame at step 0, atom id 3: column x = nan" in line
    assert cg(tmp_path / "dirty.bin", *args, "--drop-nonfinite", "--out", tmp_path / "dropped") == 0
    out = capsys.readouterr().out
    assert ("--drop-nonfinite: left out 4 atom-frames with a NaN or infinite value, in 3 of 5 frames "
            "(the first at step 0; by column: x 1, z 1, vz 1, mass 1, radius 1)") in out
    meta = json.loads((tmp_path / "dropped" / "meta.json").read_text())
    assert meta["frames"]["dropped_nonfinite"] == {"atom_frames": 4, "frames": 3, "first_step": 0,
                                                   "columns": {"x": 1, "z": 1, "vz": 1, "radius": 1, "mass": 1}}
    assert meta["frames"]["particle_frames"] == 5 * 60 - 4
    assert cg(tmp_path / "clean.bin", *args, "--out", tmp_path / "clean") == 0
    pd.testing.assert_frame_equal(fields(tmp_path / "dropped"), fields(tmp_path / "clean"), check_exact=True)
    # on a clean dump the option reports that nothing was left out; without it the record says null
    assert cg(tmp_path / "clean.bin", *args, "--drop-nonfinite", "--out", tmp_path / "none") == 0
    assert "left out no atom" in capsys.readouterr().out
    assert json.loads((tmp_path / "none" / "meta.json").read_text())["frames"]["dropped_nonfinite"]["atom_frames"] == 0
    assert json.loads((tmp_path / "clean" / "meta.json").read_text())["frames"]["dropped_nonfinite"] is None


def test_impossible_values_fast_pass_has_no_false_alarm():
    """Huge finite positions overflow the fast pass's sum; the element-wise pass clears them."""
    from postproc.frame import DumpFrame, impossible_values

    data = {k: np.asarray(v, dtype=float) for k, v in particles(lattice(1, 1, 3)).items()}
    data["x"] = np.full(3, 1e308)
    frame = DumpFrame(timestep=0, box=np.zeros((3, 2)), boundary="p p p", columns=data)
    assert impossible_values(frame) is None
    data["vy"][1] = np.nan
    data["mass"][2] = 0.0
    found = impossible_values(frame)
    assert list(found.nonfinite) == ["vy"] and list(found.nonpositive) == ["mass"]
    assert found.first(found.nonfinite) == (1, "vy", 1) and found.first(found.nonpositive) == (2, "mass", 1)
    # columns the particle is not built from (an unwrapped copy beside x y z, a stress) are not checked
    frame.columns["xu"] = np.full(3, np.nan)
    frame.columns["c_stress[1]"] = np.full(3, np.inf)
    assert list(impossible_values(frame).nonfinite) == ["vy"]


# --------------------------------------------------------------------------- never over its own input


def test_outputs_never_replace_an_input(lattice_dump, tmp_path, capsys):
    folder = lattice_dump.parent
    before = lattice_dump.read_bytes()
    # --out the folder holding the input: allowed (the input's name is not an output's) and left alone
    assert cg(lattice_dump, *HEAVISIDE_Z, "--out", folder, "--quiet") == 0
    assert cg(lattice_dump, *HEAVISIDE_Z, "--out", folder, "--quiet", "--overwrite") == 0
    assert lattice_dump.read_bytes() == before
    # an input named like an output, in the --out folder: refused, with or without --overwrite
    named = folder / "meta.json"
    named.write_bytes(before)
    for extra in ((), ("--overwrite",)):
        line = refusal(capsys, named, *HEAVISIDE_Z, "--out", folder, *extra)
        assert line == (f"--out {folder} would write {named} over the input {named}: granflow cg never "
                        f"writes over its input; choose another --out")
        assert named.read_bytes() == before
    # --out the input file itself
    line = refusal(capsys, lattice_dump, *HEAVISIDE_Z, "--out", lattice_dump, "--overwrite")
    assert line.startswith(f"--out {lattice_dump} is the input {lattice_dump}")
    # an output that is a link to the input (symbolic or hard), and a contact file
    (tmp_path / "sym").mkdir()
    (tmp_path / "sym" / "fields.vtr").symlink_to(lattice_dump)
    line = refusal(capsys, lattice_dump, *HEAVISIDE_Z, "--out", tmp_path / "sym", "--overwrite")
    assert f"over the input {lattice_dump}" in line
    (tmp_path / "hard").mkdir()
    os.link(lattice_dump, tmp_path / "hard" / "fields.csv")
    line = refusal(capsys, lattice_dump, *HEAVISIDE_Z, "--out", tmp_path / "hard", "--overwrite")
    assert f"would write {tmp_path / 'hard' / 'fields.csv'} over the input {lattice_dump}" in line
    contacts = folder / "fields.csv"
    write_contacts(contacts, [(s, []) for s in (0, 100, 200, 300)], [0, 4, 0, 4, 0, 16])
    line = refusal(capsys, lattice_dump, "--contacts", contacts, *HEAVISIDE_Z, "--out", folder, "--overwrite")
    assert f"over the input {contacts}" in line
    assert lattice_dump.read_bytes() == before and named.read_bytes() == before


def test_write_result_refuses_to_replace_an_input(lattice_dump, tmp_path):
    from postproc.cg import CGInputError, coarse_grain, write_result

    result = coarse_grain([lattice_dump], "z", kernel="heaviside", spacing=1.0)
    before = lattice_dump.read_bytes()
    (tmp_path / "out").mkdir()
    (tmp_path / "out" / "fields.csv").symlink_to(lattice_dump)
    with pytest.raises(CGInputError, match="over the input"):
        write_result(result, tmp_path / "out")
    assert lattice_dump.read_bytes() == before and not (tmp_path / "out" / "meta.json").exists()
