"""Tests of postproc.dump against dumps written on the fly by LAMMPS."""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from postproc.dump import DumpError, count_frames, read_binary_dump, read_dump, read_text_dump

BIN = Path(sys.executable).parent
LMP = BIN / "lmp"
MPIRUN = BIN / "mpirun"

COLUMNS = "id type radius mass x y z vx vy vz omegax omegay omegaz"
NATOMS = 200
NFRAMES = 4  # steps 0, 100, 200, 300
# Non-zero lower bounds, so that MDAnalysis's shift of the box to the origin shows.
BOX = np.array([[-5.0, 5.0], [-4.0, 6.0], [1.0, 11.0]])

DECK = """\
units lj
atom_style sphere
boundary p p f
region box block {box}
create_box 1 box
create_atoms 1 random {natoms} 4711 NULL overlap 1.0 maxtry 100
set type 1 diameter 1.0 density 1.0
velocity all create 1.0 87287 loop geom
pair_style gran/hooke/history 2000.0 NULL 50.0 NULL 0.5 0
pair_coeff * *
comm_modify vel yes
neighbor 0.3 bin
fix 1 all nve/sphere
fix 2 all gravity 1.0 vector 0 0 -1
fix 3 all wall/gran hooke/history 2000.0 NULL 50.0 NULL 0.5 0 zplane {zlo} {zhi}
timestep 0.001
dump b all custom 100 dump.bin {cols}
dump t all custom 100 dump.txt {cols}
dump_modify t format float %20.15g
{extra}
run 300
"""

lammps = pytest.mark.lammps


def _run_lammps(workdir: Path, nproc: int = 1, extra: str = "") -> Path:
    if not LMP.exists():
        pytest.skip(f"no lmp executable at {LMP}")
    workdir.mkdir(parents=True, exist_ok=True)
    deck = DECK.format(
        box=" ".join(f"{v:g}" for v in BOX.ravel()),
        natoms=NATOMS,
        zlo=BOX[2, 0],
        zhi=BOX[2, 1],
        cols=COLUMNS,
        extra=extra,
    )
    (workdir / "in.deck").write_text(deck)
    cmd = [str(LMP), "-in", "in.deck", "-log", "log.lammps", "-screen", "none"]
    if nproc > 1:
        if not MPIRUN.exists():
            pytest.skip(f"no mpirun at {MPIRUN}")
        cmd = [str(MPIRUN), "-np", str(nproc), *cmd]
    proc = subprocess.run(cmd, cwd=workdir, capture_output=True, text=True, timeout=120)
    if proc.returncode != 0:
        log = (workdir / "log.lammps").read_text() if (workdir / "log.lammps").exists() else ""
        raise RuntimeError(f"{' '.join(cmd)} failed ({proc.returncode}):\n{proc.stderr}\n{log[-2000:]}")
    return workdir


@pytest.fixture(scope="module")
def serial_run(tmp_path_factory) -> Path:
    return _run_lammps(tmp_path_factory.mktemp("serial"))


@pytest.fixture(scope="module")
def mpi_run(tmp_path_factory) -> Path:
    # Two ranks -> two chunks per binary frame; units/time exercise the optional header fields.
    return _run_lammps(tmp_path_factory.mktemp("mpi"), nproc=2, extra="dump_modify b units yes time yes")


def _frame_offsets(path: Path) -> list[int]:
    """Byte offsets of the frames, found independently of the reader (magic string search)."""
    raw = path.read_bytes()
    offsets, pos = [], raw.find(b"DUMPCUSTOM")
    while pos >= 0:
        offsets.append(pos - 8)  # preceded by the int64 magic length
        pos = raw.find(b"DUMPCUSTOM", pos + 1)
    return offsets


def _assert_same_frames(a, b, rtol=1e-12):
    assert len(a) == len(b)
    for fa, fb in zip(a, b):
        assert fa.timestep == fb.timestep
        np.testing.assert_array_equal(fa.box, fb.box)
        assert fa.boundary == fb.boundary
        assert list(fa.columns) == list(fb.columns)
        for name in fa.columns:
            np.testing.assert_allclose(fa.columns[name], fb.columns[name], rtol=rtol, atol=0, err_msg=name)


# ----------------------------------------------------------------------------- (a), (d)


@lammps
@pytest.mark.parametrize("run", ["serial_run", "mpi_run"])
def test_binary_matches_text(run, request):
    workdir = request.getfixturevalue(run)
    binary = list(read_binary_dump(workdir / "dump.bin"))
    text = list(read_text_dump(workdir / "dump.txt"))
    assert len(binary) == NFRAMES
    assert [f.timestep for f in binary] == [0, 100, 200, 300]
    _assert_same_frames(binary, text)
    for f in binary:
        assert list(f.columns) == COLUMNS.split()
        assert f.natoms == NATOMS
        np.testing.assert_array_equal(f.box, BOX)
        assert f.boundary == "p p f"
        np.testing.assert_array_equal(f.columns["id"], np.arange(1, NATOMS + 1))  # sorted by id
        assert all(a.dtype == np.float64 and a.flags.c_contiguous for a in f.columns.values())
    # the dynamics did something
    assert not np.allclose(binary[0].columns["z"], binary[-1].columns["z"])


@lammps
def test_mpi_file_has_two_chunks_per_frame(mpi_run):
    """Check the layout by hand: nchunk == 2 and the chunks hold natoms x 13 doubles."""
    path = mpi_run / "dump.bin"
    raw = path.read_bytes()
    offsets = _frame_offsets(path)
    assert len(offsets) == NFRAMES and offsets[0] == 0
    for k, off in enumerate(offsets):
        assert np.frombuffer(raw, "<i8", 1, off)[0] == -10
        endian, revision = np.frombuffer(raw, "<i4", 2, off + 18)
        assert (endian, revision) == (1, 2)
        step, natoms = np.frombuffer(raw, "<i8", 2, off + 26)
        assert (step, natoms) == (100 * k, NATOMS)
        pos = off + 26 + 16 + 4 + 24 + 48  # triclinic flag, boundary, 6 box doubles
        size_one, nunit = np.frombuffer(raw, "<i4", 2, pos)
        assert size_one == 13
        pos += 8
        # 'dump_modify units yes' writes the unit style in the first frame only
        assert raw[pos : pos + nunit] == (b"lj" if k == 0 else b"")
        pos += nunit
        assert raw[pos] == 1  # time flag
        time = np.frombuffer(raw, "<f8", 1, pos + 1)[0]
        assert time == pytest.approx(0.1 * k)
        pos += 9
        ncol = np.frombuffer(raw, "<i4", 1, pos)[0]
        assert raw[pos + 4 : pos + 4 + ncol].decode() == COLUMNS
        pos += 4 + ncol
        nchunk = np.frombuffer(raw, "<i4", 1, pos)[0]
        assert nchunk == 2
        pos += 4
        total = 0
        for _ in range(nchunk):
            n = np.frombuffer(raw, "<i4", 1, pos)[0]
            total += n
            pos += 4 + 8 * n
        assert total == NATOMS * 13
        assert pos == (offsets[k + 1] if k + 1 < NFRAMES else len(raw))


@lammps
def test_count_frames(serial_run, mpi_run):
    for workdir in (serial_run, mpi_run):
        assert count_frames(workdir / "dump.bin") == NFRAMES
        assert count_frames(workdir / "dump.txt") == NFRAMES


@lammps
def test_column_selection_and_dispatch(mpi_run):
    full = list(read_dump(mpi_run / "dump.bin"))
    sub = list(read_dump(mpi_run / "dump.bin", columns=["z", "x"]))
    sub_text = list(read_dump(mpi_run / "dump.txt", columns=["z", "x"]))
    for f, s, t in zip(full, sub, sub_text):
        assert list(s.columns) == ["z", "x"]
        np.testing.assert_array_equal(s.columns["x"], f.columns["x"])  # still sorted by id
        np.testing.assert_array_equal(s.columns["z"], f.columns["z"])
        np.testing.assert_allclose(t.columns["z"], s.columns["z"], rtol=1e-12)
    with pytest.raises(KeyError, match="nosuch"):
        next(read_dump(mpi_run / "dump.bin", columns=["nosuch"]))


# ----------------------------------------------------------------------------- (b)


@lammps
@pytest.mark.filterwarnings("ignore::UserWarning")
@pytest.mark.filterwarnings("ignore::DeprecationWarning")
def test_against_mdanalysis(mpi_run):
    """MDAnalysis's LAMMPSDUMP reader on the text dump vs ours on the binary dump.

    What MDAnalysis 2.x does with an unscaled ``x y z`` dump (checked in its
    ``DumpReader._read_next_timestep``): positions are parsed as float32, sorted
    by ``id``, translated so that the box lower corner is the origin
    (``positions -= (xlo, ylo, zlo)``); no unit conversion (``units`` are None)
    and no (re)wrapping. So we compare ``ours - lo`` at float32 precision.
    """
    mda = pytest.importorskip("MDAnalysis")
    u = mda.Universe(str(mpi_run / "dump.txt"), format="LAMMPSDUMP", atom_style="id type x y z")
    ours = list(read_binary_dump(mpi_run / "dump.bin", columns=["id", "x", "y", "z"]))
    assert u.trajectory.n_frames == len(ours)
    assert u.atoms.n_atoms == NATOMS
    np.testing.assert_array_equal(u.atoms.ids, ours[0].columns["id"])
    for ts, f in zip(u.trajectory, ours):
        assert ts.data["step"] == f.timestep
        np.testing.assert_allclose(ts.dimensions[:3], f.box[:, 1] - f.box[:, 0])
        xyz = np.column_stack([f.columns[c] for c in "xyz"])
        assert ts.positions.dtype == np.float32
        np.testing.assert_allclose(ts.positions, xyz - f.box[:, 0], rtol=0, atol=2e-6)
        # the shift is real: without it the comparison fails
        assert not np.allclose(ts.positions, xyz, atol=1e-3)


# ----------------------------------------------------------------------------- (c)


@lammps
def test_truncated_in_frame_data(serial_run, tmp_path):
    src = serial_run / "dump.bin"
    offsets = _frame_offsets(src)
    bad = tmp_path / "cut.bin"
    cut = offsets[2] + 400  # past the ~190-byte header, inside frame 2's doubles
    bad.write_bytes(src.read_bytes()[:cut])
    frames = []
    with pytest.raises(DumpError) as err:
        for f in read_binary_dump(bad):
            frames.append(f)
    msg = str(err.value)
    assert str(bad) in msg and "frame 2" in msg and f"byte {offsets[2]}" in msg and "truncated" in msg
    assert [f.timestep for f in frames] == [0, 100]  # earlier frames are delivered
    with pytest.raises(DumpError, match="frame 2"):
        count_frames(bad)


@lammps
def test_truncated_in_header(serial_run, tmp_path):
    src = serial_run / "dump.bin"
    offsets = _frame_offsets(src)
    bad = tmp_path / "cuthead.bin"
    bad.write_bytes(src.read_bytes()[: offsets[3] + 30])
    with pytest.raises(DumpError, match=r"cuthead\.bin: frame 3 .*truncated"):
        list(read_dump(bad))


@lammps
def test_corrupted_magic(serial_run, tmp_path):
    src = serial_run / "dump.bin"
    offsets = _frame_offsets(src)
    raw = bytearray(src.read_bytes())
    raw[offsets[2] + 8 : offsets[2] + 18] = b"NOTADUMP!!"
    bad = tmp_path / "magic.bin"
    bad.write_bytes(bytes(raw))
    with pytest.raises(DumpError) as err:
        list(read_binary_dump(bad))
    msg = str(err.value)
    assert str(bad) in msg and "frame 2" in msg and "magic" in msg
    with pytest.raises(DumpError, match="frame 2"):
        count_frames(bad)


@lammps
def test_truncated_text(serial_run, tmp_path):
    lines = (serial_run / "dump.txt").read_text().splitlines(keepends=True)
    bad = tmp_path / "cut.txt"
    bad.write_text("".join(lines[: 2 * (NATOMS + 9) + 50]))  # 50 lines into frame 2
    with pytest.raises(DumpError, match=r"cut\.txt: frame 2 .*truncated"):
        list(read_text_dump(bad))


# ----------------------------------------------------------------------------- no lmp needed


def test_empty_and_garbage_files(tmp_path):
    empty = tmp_path / "empty.bin"
    empty.write_bytes(b"")
    assert list(read_binary_dump(empty)) == []
    assert count_frames(empty) == 0
    old = tmp_path / "old.bin"
    old.write_bytes(np.array([100, 5], dtype="<i8").tobytes())  # pre-2021 layout starts with ntimestep
    with pytest.raises(DumpError, match=r"old\.bin: frame 0 at byte 0 .*magic"):
        list(read_binary_dump(old))
