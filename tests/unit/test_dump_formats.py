"""Dumps from anyone: format from content, time and units, column variants, truncation.

All dumps are written here by hand: text with a small writer, binary frames with
:mod:`struct` in the layout documented at the top of :mod:`postproc.dump`.
"""
from __future__ import annotations

import gzip
import pickle
import struct

import numpy as np
import pytest

from postproc.dump import (
    DumpError,
    MissingColumnsError,
    count_frames,
    dump_format,
    missing_particle_columns,
    particle_frames,
    peek_dump,
    read_binary_dump,
    read_dump,
    read_dumps,
    read_text_dump,
)
from postproc.frame import DumpFrame, ParticleFrame

BOX = np.array([[-1.0, 1.0], [0.0, 2.0], [0.5, 3.5]])
NAMES = ["id", "type", "radius", "mass", "x", "y", "z", "vx", "vy", "vz"]


# ----------------------------------------------------------------------------- writers


def make_frames(counts=(4, 4, 4), seed=1, names=NAMES):
    """Frames as dicts: ``step``, ``time``, ``data`` (atoms in shuffled order), ``names``."""
    rng = np.random.default_rng(seed)
    frames = []
    for k, n in enumerate(counts):
        ids = rng.permutation(np.arange(1, n + 1)).astype(float)
        cols = {"id": ids, "type": 1.0 + ids % 2, "radius": 0.01 * (1 + ids % 3), "mass": 1.0 + ids / 7,
                "diameter": 0.02 * (1 + ids % 3)}
        for c in ("x", "y", "z", "vx", "vy", "vz", "xs", "ys", "zs", "xu", "yu", "zu"):
            cols[c] = rng.uniform(0.0, 1.0, n)
        data = np.column_stack([cols[c] for c in names])
        frames.append({"step": 100 * k, "time": 0.025 * k, "data": data, "names": list(names)})
    return frames


def text_dump(frames, units="si", times=True, flags="pp pp ff") -> str:
    """A LAMMPS text custom dump; ``ITEM: UNITS`` in the first frame only, as LAMMPS writes it."""
    out = []
    for k, f in enumerate(frames):
        if units and k == 0:
            out += ["ITEM: UNITS", units]
        if times:
            out += ["ITEM: TIME", repr(f["time"])]
        out += ["ITEM: TIMESTEP", str(f["step"]), "ITEM: NUMBER OF ATOMS", str(len(f["data"])),
                f"ITEM: BOX BOUNDS {flags}"]
        out += [f"{float(lo)!r} {float(hi)!r}" for lo, hi in BOX]
        out += ["ITEM: ATOMS " + " ".join(f["names"])]
        out += [" ".join(repr(float(v)) for v in row) for row in f["data"]]
    return "\n".join(out) + "\n"


def binary_frame(f, units=b"", time=None, order="<", nchunk=1, boundary=(0, 0, 0, 0, 1, 1),
                 magic=b"DUMPCUSTOM") -> bytes:
    """One binary frame in the documented layout (revision 2, orthogonal box)."""
    data = np.asarray(f["data"], dtype=np.float64)
    natoms, size_one = data.shape
    colstr = " ".join(f["names"]).encode()
    out = struct.pack(order + "q", -len(magic)) + magic
    out += struct.pack(order + "iiqqi", 1, 2, f["step"], natoms, 0)
    out += struct.pack(order + "6i", *boundary)
    out += struct.pack(order + "6d", *BOX.ravel())
    out += struct.pack(order + "ii", size_one, len(units)) + units
    out += struct.pack(order + "b", 0 if time is None else 1)
    if time is not None:
        out += struct.pack(order + "d", time)
    out += struct.pack(order + "i", len(colstr)) + colstr
    parts = np.array_split(data, nchunk) if natoms else [data]
    out += struct.pack(order + "i", len(parts))
    for part in parts:
        out += struct.pack(order + "i", part.size) + part.astype(order + "f8").tobytes()
    return out


def binary_dump(frames, units=b"si", times=True, **kw) -> bytes:
    """Frames concatenated; the unit style in the first frame only, as LAMMPS writes it."""
    return b"".join(binary_frame(f, units=units if k == 0 else b"", time=f["time"] if times else None, **kw)
                    for k, f in enumerate(frames))


def assert_same(a, b):
    assert [f.timestep for f in a] == [f.timestep for f in b]
    for fa, fb in zip(a, b):
        np.testing.assert_array_equal(fa.box, fb.box)
        assert fa.boundary == fb.boundary
        assert (fa.time, fa.units) == (fb.time, fb.units)
        assert sorted(fa.columns) == sorted(fb.columns)
        for name in fa.columns:
            np.testing.assert_array_equal(fa.columns[name], fb.columns[name], err_msg=name)


# ----------------------------------------------------------------------------- format from content


def test_format_comes_from_content_not_name(tmp_path):
    frames = make_frames()
    binary = tmp_path / "frames.txt"
    binary.write_bytes(binary_dump(frames))
    text = tmp_path / "a.bin"
    text.write_text(text_dump(frames))
    assert dump_format(binary) == "binary" and dump_format(text) == "text"
    assert count_frames(binary) == count_frames(text) == 3
    from_binary, from_text = list(read_dump(binary)), list(read_dump(text))
    assert_same(from_binary, from_text)
    assert from_binary[0].boundary == "p p f"
    for f, raw in zip(from_binary, frames):
        np.testing.assert_array_equal(f.columns["id"], np.arange(1, 5))  # sorted by id
        order = np.argsort(raw["data"][:, 0])
        np.testing.assert_array_equal(f.columns["vy"], raw["data"][order, NAMES.index("vy")])
    # the text reader reads a text dump named .bin; the binary reader refuses a text dump clearly
    assert_same(list(read_text_dump(text)), from_text)
    with pytest.raises(DumpError, match="binary dump"):
        list(read_text_dump(binary))


def test_big_endian_binary_and_several_chunks(tmp_path):
    frames = make_frames(counts=(5, 7))
    little = tmp_path / "little"
    little.write_bytes(binary_dump(frames))
    big = tmp_path / "big"
    big.write_bytes(binary_dump(frames, order=">", nchunk=3))
    assert dump_format(big) == "binary"
    assert_same(list(read_dump(big)), list(read_dump(little)))


def test_gzipped_text_equals_plain_text(tmp_path):
    frames = make_frames()
    plain = tmp_path / "plain.dump"
    plain.write_text(text_dump(frames))
    packed = tmp_path / "packed.dump"  # no .gz in the name
    with gzip.open(packed, "wt") as fh:
        fh.write(text_dump(frames))
    assert dump_format(packed) == "gzip"
    assert count_frames(packed) == 3
    assert_same(list(read_dump(packed)), list(read_dump(plain)))
    assert peek_dump(packed).units == "si"


def test_empty_and_foreign_files(tmp_path):
    empty = tmp_path / "empty.txt"
    empty.write_bytes(b"")
    assert list(read_dump(empty)) == [] and count_frames(empty) == 0
    with pytest.raises(DumpError, match="no frame"):
        peek_dump(empty)
    foreign = tmp_path / "dump.bin"
    foreign.write_bytes(b"\x00\x01hello, not a dump")
    with pytest.raises(DumpError, match=r"dump\.bin is not a LAMMPS dump: .*first bytes: b'\\x00\\x01hello") as err:
        list(read_dump(foreign))
    assert err.value.path == str(foreign) and err.value.truncated is False
    with pytest.raises(DumpError, match="not a LAMMPS dump"):
        count_frames(foreign)


# ----------------------------------------------------------------------------- time and units


def test_time_and_units_through_both_formats(tmp_path):
    frames = make_frames()
    binary, text = tmp_path / "b", tmp_path / "t"
    binary.write_bytes(binary_dump(frames, units=b"si"))
    text.write_text(text_dump(frames, units="si"))
    for path in (binary, text):
        got = list(read_dump(path))
        assert [f.time for f in got] == [0.0, 0.025, 0.05]
        assert [f.units for f in got] == ["si"] * 3  # written once, carried on
        assert [ParticleFrame.from_dump(f).time for f in got] == [0.0, 0.025, 0.05]
        assert ParticleFrame.from_dump(got[0]).boundary == "p p f"
    # without them: None
    binary.write_bytes(binary_dump(frames, units=b"", times=False))
    text.write_text(text_dump(frames, units=None, times=False))
    for path in (binary, text):
        assert {(f.time, f.units) for f in read_dump(path)} == {(None, None)}


def test_particle_frames_windows_on_dump_time_without_dt(tmp_path):
    path = tmp_path / "t"
    path.write_text(text_dump(make_frames(counts=(3, 3, 3, 3))))
    steps = [f.timestep for f in particle_frames([path], t_window=(0.02, 0.06))]
    assert steps == [100, 200]
    assert [f.timestep for f in particle_frames([path], dt=0.00025, t_window=(0.02, 0.06))] == [100, 200]


# ----------------------------------------------------------------------------- columns


def test_shuffled_columns_give_identical_arrays(tmp_path):
    frames = make_frames()
    perm = [7, 2, 9, 0, 5, 1, 8, 3, 6, 4]
    shuffled = [{**f, "data": f["data"][:, perm], "names": [NAMES[j] for j in perm]} for f in frames]
    a, b, c = tmp_path / "a", tmp_path / "b", tmp_path / "c"
    a.write_bytes(binary_dump(frames))
    b.write_bytes(binary_dump(shuffled))
    c.write_text(text_dump(shuffled))
    ref = [ParticleFrame.from_dump(f) for f in read_dump(a)]
    for path in (b, c):
        for p, q in zip(ref, (ParticleFrame.from_dump(f) for f in read_dump(path))):
            for name in ("position", "velocity", "mass", "radius", "id", "type"):
                np.testing.assert_array_equal(getattr(p, name), getattr(q, name), err_msg=name)
    picked = next(read_dump(c, columns=["vz", "id"]))
    assert list(picked.columns) == ["vz", "id"]


def test_diameter_density_and_position_variants():
    rng = np.random.default_rng(3)
    n = 6
    base = {k: rng.uniform(0, 1, n) for k in ("vx", "vy", "vz")}
    diameter = rng.uniform(0.01, 0.02, n)
    xs = rng.uniform(0, 1, (n, 3))
    frame = DumpFrame(5, BOX, "p p f", {**base, "diameter": diameter, "xs": xs[:, 0], "ys": xs[:, 1],
                                         "zs": xs[:, 2]}, time=1.5)
    p = ParticleFrame.from_dump(frame, density=2500.0)
    np.testing.assert_allclose(p.radius, diameter / 2, rtol=1e-15)
    np.testing.assert_allclose(p.mass, 2500.0 * np.pi / 6 * diameter**3, rtol=1e-14)
    np.testing.assert_allclose(p.position, BOX[:, 0] + xs * (BOX[:, 1] - BOX[:, 0]), rtol=1e-15)
    assert p.time == 1.5 and p.boundary == "p p f"
    # a mass column wins over the density; unwrapped positions are taken as they are
    xu = rng.uniform(-3, 3, (n, 3))
    mass = rng.uniform(1, 2, n)
    q = ParticleFrame.from_dump(DumpFrame(5, BOX, "p p f", {**base, "radius": diameter / 2, "mass": mass,
                                                          "xu": xu[:, 0], "yu": xu[:, 1], "zu": xu[:, 2]}),
                                density=1.0)
    np.testing.assert_array_equal(q.mass, mass)
    np.testing.assert_array_equal(q.position, xu)


def test_missing_velocity_column_is_diagnosed(tmp_path):
    names = [c for c in NAMES if c != "vy"]
    frames = make_frames(names=names)
    path = tmp_path / "novy"
    path.write_bytes(binary_dump(frames))
    first = peek_dump(path)
    assert missing_particle_columns(first.columns) == ["vy"]
    assert missing_particle_columns(["id", "xs", "ys", "zs", "vx", "vy", "vz", "diameter"]) == ["mass or a density"]
    assert missing_particle_columns(["id", "xs", "ys", "zs", "vx", "vy", "vz", "diameter"], density=2.0) == []
    assert missing_particle_columns(["x", "y", "vx"]) == ["z", "vy", "vz", "radius or diameter", "mass or a density"]
    assert missing_particle_columns(["id"])[0] == "x y z (or xu yu zu, xs ys zs)"
    with pytest.raises(MissingColumnsError) as err:
        ParticleFrame.from_dump(first)
    exc = err.value
    assert isinstance(exc, KeyError) and isinstance(exc, DumpError)
    msg = str(exc)
    assert msg.startswith("dump frame at step 0 lacks vy")  # plain, not quoted like a KeyError
    assert "needs x y z (or xu yu zu, xs ys zs), vx vy vz, radius or diameter, and mass or a density" in msg
    assert str(names) in msg
    assert exc.missing == ["vy"] and exc.available == names
    with pytest.raises(KeyError):  # old callers keep working
        ParticleFrame.from_dump(first)
    # a requested column that is absent: also a MissingColumnsError
    with pytest.raises(MissingColumnsError, match=r"frame 0 has no columns \['vy'\]"):
        next(read_dump(path, columns=["x", "vy"]))


def test_peek_dump_reads_only_the_first_frame(tmp_path):
    frames = make_frames()
    raw = binary_dump(frames)
    second = len(binary_frame(frames[0], units=b"si", time=0.0))
    path = tmp_path / "peek"
    path.write_bytes(raw[:second] + b"\xff" * 40)  # garbage after the first frame
    frame = peek_dump(path)
    assert frame.timestep == 0 and frame.natoms == 4 and frame.units == "si"
    with pytest.raises(DumpError, match="frame 1"):
        list(read_dump(path))


def test_atom_count_changes_between_frames(tmp_path):
    frames = make_frames(counts=(3, 5, 0, 2))
    binary, text = tmp_path / "b", tmp_path / "t"
    binary.write_bytes(binary_dump(frames, nchunk=2))
    text.write_text(text_dump(frames))
    for path in (binary, text):
        got = list(read_dump(path))
        assert [f.natoms for f in got] == [3, 5, 0, 2]
        assert [len(ParticleFrame.from_dump(f).mass) for f in got] == [3, 5, 0, 2]
        np.testing.assert_array_equal(got[1].columns["id"], np.arange(1, 6))


# ----------------------------------------------------------------------------- select, several files


def test_select_skips_frames(tmp_path):
    frames = make_frames(counts=(3, 3, 3, 3))
    binary, text = tmp_path / "b", tmp_path / "t"
    binary.write_bytes(binary_dump(frames))
    lines = text_dump(frames).splitlines(keepends=True)
    # frame 1's atom lines are not numbers: only a reader that parses them fails
    start = lines.index("100\n") + 8
    lines[start : start + 3] = ["1 garbage\n"] * 3
    text.write_text("".join(lines))
    with pytest.raises(DumpError, match="frame 1 .*do not parse"):
        list(read_dump(text))
    seen = []

    def select(step):
        seen.append(step)
        return step != 100

    for path in (binary, text):
        seen.clear()
        got = list(read_dump(path, ["x"], select=select))
        assert [f.timestep for f in got] == [0, 200, 300] and seen == [0, 100, 200, 300]
        assert [f.time for f in got] == [0.0, 0.025 * 2, 0.025 * 3] and list(got[0].columns) == ["x"]
    assert [f.timestep for f in read_binary_dump(binary, select=lambda s: s >= 200)] == [200, 300]
    assert [f.timestep for f in read_text_dump(text, select=lambda s: s == 0)] == [0]


def test_read_dumps_chains_files_of_any_kind(tmp_path):
    a, b = tmp_path / "a", tmp_path / "b"
    a.write_bytes(binary_dump(make_frames(counts=(2, 2))))
    later = [{**f, "step": f["step"] + 1000} for f in make_frames(counts=(2, 2))]
    with gzip.open(b, "wt") as fh:
        fh.write(text_dump(later))
    assert [f.timestep for f in read_dumps([a, b])] == [0, 100, 1000, 1100]
    assert [f.timestep for f in read_dumps([a, b], select=lambda s: s % 1000 == 0)] == [0, 1000]


# ----------------------------------------------------------------------------- truncation and corruption


def test_truncated_binary(tmp_path):
    frames = make_frames()
    raw = binary_dump(frames)
    starts = [0]
    for k, f in enumerate(frames):
        starts.append(starts[-1] + len(binary_frame(f, units=b"si" if k == 0 else b"", time=f["time"])))
    assert starts[-1] == len(raw)
    for cut, frame in [(starts[2] + len(raw[starts[2]:]) - 20, 2), (starts[1] + 30, 1), (starts[2] + 3, 2)]:
        path = tmp_path / f"cut{cut}.txt"
        path.write_bytes(raw[:cut])
        got = []
        with pytest.raises(DumpError) as err:
            for f in read_dump(path):
                got.append(f.timestep)
        exc = err.value
        assert got == [100 * k for k in range(frame)]  # the complete frames first
        assert (exc.truncated, exc.frame, exc.byte, exc.path) == (True, frame, starts[frame], str(path))
        msg = str(exc)
        assert f"frame {frame} at byte {starts[frame]} is truncated" in msg and f"ends at byte {cut}" in msg
        with pytest.raises(DumpError, match=f"frame {frame}"):
            count_frames(path)


def test_corrupted_binary_is_not_truncated(tmp_path):
    frames = make_frames()
    raw = bytearray(binary_dump(frames))
    first = len(binary_frame(frames[0], units=b"si", time=0.0))
    raw[first + 8 : first + 18] = b"NOTADUMP!!"
    path = tmp_path / "bad"
    path.write_bytes(bytes(raw))
    with pytest.raises(DumpError, match="magic") as err:
        list(read_dump(path))
    assert (err.value.truncated, err.value.frame, err.value.byte) == (False, 1, first)


@pytest.mark.parametrize("packed", [False, True])
def test_truncated_text(tmp_path, packed):
    frames = make_frames()
    full = text_dump(frames).encode()
    # frame 1 starts at its 'ITEM: TIME' line
    start = full.index(b"ITEM: TIME", full.index(b"ITEM: TIMESTEP") + 1)
    start_line = full[:start].count(b"\n") + 1
    inside = full.index(b"\n", full.index(b"ITEM: ATOMS", start)) + 30  # in the middle of the first atom line
    path = tmp_path / "cut.dump"
    cases = [inside, full.index(b"ITEM: NUMBER", start)]
    for cut in cases:
        if packed:
            with gzip.open(path, "wb") as fh:
                fh.write(full[:cut])
        else:
            path.write_bytes(full[:cut])
        got = []
        with pytest.raises(DumpError) as err:
            for f in read_dump(path):
                got.append(f.timestep)
        exc = err.value
        assert got == [0]
        assert (exc.truncated, exc.frame, exc.byte) == (True, 1, start)
        msg = str(exc)
        assert "frame 1 at line" in msg and "is truncated" in msg
        assert f"the frame starts at line {start_line}, byte {start}" in msg
        head = full[:cut]
        end_line = head.count(b"\n") + (not head.endswith(b"\n"))
        assert f"the file ends at line {end_line}, byte {cut}" in msg
        assert ("decompressed" in msg) == packed


def test_cut_gzip_stream(tmp_path):
    frames = make_frames(counts=(200, 200, 200))
    packed = gzip.compress(text_dump(frames).encode())
    path = tmp_path / "cut"
    path.write_bytes(packed[: len(packed) // 2])
    with pytest.raises(DumpError, match="compressed stream ends early") as err:
        list(read_dump(path))
    assert err.value.truncated is True and "decompressed" in str(err.value)
    with pytest.raises(DumpError, match="truncated"):
        count_frames(path)


def test_corrupted_text_is_not_truncated(tmp_path):
    lines = text_dump(make_frames()).splitlines(keepends=True)
    lines[lines.index("ITEM: TIMESTEP\n", 5) + 1] = "one hundred\n"
    path = tmp_path / "bad"
    path.write_text("".join(lines))
    with pytest.raises(DumpError, match="frame 1 at line .* is corrupted") as err:
        list(read_dump(path))
    assert err.value.truncated is False and err.value.frame == 1


def test_dump_error_attributes():
    plain = DumpError("msg")
    assert str(plain) == "msg" and (plain.path, plain.frame, plain.byte, plain.truncated) == (None,) * 4
    exc = DumpError("cut", path="p", frame=2, byte=10, truncated=True)
    back = pickle.loads(pickle.dumps(exc))
    assert (str(back), back.path, back.frame, back.byte, back.truncated) == ("cut", "p", 2, 10, True)
    missing = pickle.loads(pickle.dumps(MissingColumnsError("lacks vx", missing=["vx"], available=["x"])))
    assert str(missing) == "lacks vx" and missing.missing == ["vx"]
