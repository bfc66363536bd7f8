"""`granflow cg` on broken input (issue 41, defect 2): impossible boxes, timesteps repeated or going back,
a dump given twice, non-finite or impossible contacts, a gzip bomb, and inputs that are not dump files.

Each of these used to give numbers (or an unrelated error, or "does not exist"); each is now refused with
one line naming the file, the frame and what is wrong, or (timesteps, with a flag) left out and counted."""
from __future__ import annotations

import gzip
import json
import os
import shutil
import struct
import time
import tracemalloc
import zlib
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from granflow.cli import main as granflow
from postproc import dump_text
from postproc.dump import DumpError, read_dump

COLUMNS = ["id", "type", "x", "y", "z", "vx", "vy", "vz", "radius", "mass"]
BOX = [[0.0, 2.0], [0.0, 2.0], [0.0, 4.0]]
HEAVISIDE_Z = ("--coords", "z", "--kernel", "heaviside", "--spacing", 1, "--quiet")


def atoms(step: int, seed: int = 0) -> dict:
    """Eight spheres r = 0.4, m = 2 on a 2 x 2 x 2 lattice spread over z in [0, 4], seeded velocities."""
    rng = np.random.default_rng(seed * 1000 + step)
    g = np.stack(np.meshgrid([0.5, 1.5], [0.5, 1.5], [0.5, 2.5], indexing="ij"), -1).reshape(-1, 3)
    v = rng.normal(size=(8, 3))
    return {"id": np.arange(1, 9), "type": np.ones(8), "x": g[:, 0], "y": g[:, 1], "z": g[:, 2],
            "vx": v[:, 0], "vy": v[:, 1], "vz": v[:, 2], "radius": np.full(8, 0.4), "mass": np.full(8, 2.0)}


def write_dump(path, steps, boxes=None, seed=0, opener=open) -> Path:
    """A text custom dump of :func:`atoms` at ``steps``; ``boxes`` maps a step to its own box."""
    with opener(path, "wt") as fh:
        for step in steps:
            box = (boxes or {}).get(step, BOX)
            fh.write(f"ITEM: TIMESTEP\n{step}\nITEM: NUMBER OF ATOMS\n8\nITEM: BOX BOUNDS pp pp pp\n")
            fh.write("".join(f"{lo!r} {hi!r}\n" for lo, hi in box))
            fh.write("ITEM: ATOMS " + " ".join(COLUMNS) + "\n")
            data = atoms(step, seed)
            for i in range(8):
                fh.write(" ".join(repr(float(data[c][i])) for c in COLUMNS) + "\n")
    return Path(path)


def write_binary(path, steps, boxes=None) -> Path:
    """The same frames as a LAMMPS >= 2021 binary dump (revision 2, one chunk per frame)."""
    colstr = " ".join(COLUMNS).encode()
    with open(path, "wb") as fh:
        for step in steps:
            box = np.asarray((boxes or {}).get(step, BOX), float)
            fh.write(struct.pack("<q", -10) + b"DUMPCUSTOM" + struct.pack("<ii", 1, 2))
            fh.write(struct.pack("<qqi", step, 8, 0) + struct.pack("<6i", 0, 0, 0, 0, 0, 0))
            fh.write(struct.pack("<6d", *box.ravel()) + struct.pack("<iib", len(COLUMNS), 0, 0))
            fh.write(struct.pack("<i", len(colstr)) + colstr + struct.pack("<i", 1))
            values = np.column_stack([atoms(step)[c] for c in COLUMNS]).ravel()
            fh.write(struct.pack("<i", values.size) + values.astype("<f8").tobytes())
    return Path(path)


def write_contacts(path, frames, columns=("id1", "id2", "dx", "dy", "dz", "fx", "fy", "fz")) -> Path:
    """A text dump local: ``frames`` are (step, rows of the columns)."""
    with open(path, "w") as fh:
        for step, rows in frames:
            fh.write(f"ITEM: TIMESTEP\n{step}\nITEM: NUMBER OF ENTRIES\n{len(rows)}\nITEM: BOX BOUNDS pp pp pp\n")
            fh.write("".join(f"{lo!r} {hi!r}\n" for lo, hi in BOX))
            fh.write("ITEM: ENTRIES " + " ".join(columns) + "\n")
            fh.write("".join(" ".join(repr(float(v)) for v in row) + "\n" for row in rows))
    return Path(path)


#: atoms 1 and 2 sit at (0.5, 0.5, 0.5) and (1.5, 0.5, 0.5): a branch of -1 along x
PAIR = (1, 2, -1.0, 0.0, 0.0, -5.0, 0.0, 0.0)


def cg(*args) -> int:
    return granflow(["cg", *map(str, args)])


def refusal(capsys, *args) -> str:
    """The one line after 'granflow: refused: ' of a refused command (exit 2, no traceback, nothing written)."""
    assert cg(*args) == 2
    err = capsys.readouterr().err
    assert err.startswith("granflow: refused: ") and "Traceback" not in err, err
    assert err.count("\n") == 1, err
    out = Path(args[list(args).index("--out") + 1])
    assert not (out / "fields.csv").exists() and not (out / "meta.json").exists()
    return err[len("granflow: refused: "):].strip()


def fields(out) -> pd.DataFrame:
    return pd.read_csv(Path(out) / "fields.csv")


def meta(out) -> dict:
    return json.loads((Path(out) / "meta.json").read_text())


# --------------------------------------------------------------------------- boxes


@pytest.mark.parametrize("writer", [write_dump, write_binary], ids=["text", "binary"])
@pytest.mark.parametrize("step", [0, 200], ids=["first frame", "later frame"])
@pytest.mark.parametrize("box, said", [
    ([[0, 2], [0, 2], [0, float("nan")]], "box bound zhi = nan is not allowed: allowed a finite number"),
    ([[float("-inf"), 2], [0, 2], [0, 4]], "box bound xlo = -inf is not allowed: allowed a finite number"),
    ([[0, 2], [2, 0], [0, 4]], "box bounds ylo = 2, yhi = 0 are not allowed: allowed ylo < yhi (the box is "
                               "inverted or empty)"),
    ([[0, 2], [0, 2], [1, 1]], "box bounds zlo = 1, zhi = 1 are not allowed: allowed zlo < zhi"),
], ids=["nan", "-inf", "inverted", "empty"])
def test_an_impossible_box_is_refused_naming_the_file_the_step_and_the_bound(tmp_path, capsys, writer, step, box,
                                                                              said):
    """Before: exit 0 with every field empty or a negative count."""
    dump = writer(tmp_path / "atoms.dump", [0, 100, 200, 300], boxes={step: box})
    line = refusal(capsys, dump, *HEAVISIDE_Z, "--out", tmp_path / "o")
    assert line.startswith(f"{dump}: frame at step {step}: {said}"), line


def test_a_contact_frame_with_an_impossible_box_is_refused(tmp_path, capsys):
    dump = write_dump(tmp_path / "atoms.dump", [0, 100])
    local = write_contacts(tmp_path / "c.local", [(0, [PAIR]), (100, [PAIR])])
    text = local.read_text().replace("0.0 4.0", "0.0 nan", 1)
    local.write_text(text)
    line = refusal(capsys, dump, "--contacts", local, *HEAVISIDE_Z, "--out", tmp_path / "o")
    assert line == f"{local}: contact frame at step 0: box bound zhi = nan is not allowed: allowed a finite number"


# --------------------------------------------------------------------------- timesteps


@pytest.mark.parametrize("steps, said", [
    ([0, 100, 200, 100, 300], "frame at step 100 goes back from step 200"),
    ([0, 100, 100, 200], "frame at step 100 repeats step 100"),
])
def test_timesteps_repeated_or_going_back_are_refused(tmp_path, capsys, steps, said):
    """Before: accepted, the frames counted twice."""
    dump = write_dump(tmp_path / "atoms.dump", steps)
    line = refusal(capsys, dump, *HEAVISIDE_Z, "--out", tmp_path / "o")
    assert line.startswith(f"{dump}: {said}: timesteps must increase from frame to frame and from file to file")
    assert line.endswith("--drop-repeated-steps leaves such frames out and counts them")


def test_the_same_dump_given_twice_is_refused_by_any_of_its_names(tmp_path, capsys):
    """Before: accepted, every frame counted twice (standard errors 31 % too small)."""
    dump = write_dump(tmp_path / "atoms.dump", [0, 100, 200, 300])
    out = tmp_path / "o"
    line = refusal(capsys, dump, dump, *HEAVISIDE_Z, "--out", out)
    assert line == (f"{dump} is given twice, as atom dump 1 and as atom dump 2: its frames would be counted twice; "
                    f"give each dump once")
    (tmp_path / "link.dump").symlink_to(dump)
    os.link(dump, tmp_path / "hard.dump")
    for other in (tmp_path / "link.dump", tmp_path / "hard.dump"):
        line = refusal(capsys, dump, other, *HEAVISIDE_Z, "--out", out)
        assert line.startswith(f"{other} is given twice, as atom dump 1 ({dump}, another name of the same file) "
                               f"and as atom dump 2"), line
    # a copy is another file: its first frame repeats a step already read
    shutil.copy(dump, tmp_path / "copy.dump")
    line = refusal(capsys, dump, tmp_path / "copy.dump", *HEAVISIDE_Z, "--out", out)
    assert line.startswith(f"{tmp_path / 'copy.dump'}: frame at step 0 goes back from step 300 of {dump}")
    local = write_contacts(tmp_path / "c.local", [(s, [PAIR]) for s in (0, 100, 200, 300)])
    line = refusal(capsys, dump, "--contacts", local, local, *HEAVISIDE_Z, "--out", out)
    assert line.startswith(f"{local} is given twice, as contact dump 1 and as contact dump 2")


def test_drop_repeated_steps_keeps_the_first_frame_of_a_step_and_counts_the_others(tmp_path, capsys):
    """A restarted run's dump overlapping the one before: its repeated frames are left out, the
    fields and their standard errors are those of the frames without repeats, exactly (same
    arithmetic on the same frames)."""
    first = write_dump(tmp_path / "run1.dump", [0, 100, 200, 300])
    again = write_dump(tmp_path / "run2.dump", [200, 300, 400, 500], seed=1)  # other values at 200, 300
    clean = write_dump(tmp_path / "clean.dump", [0, 100, 200, 300])
    with open(clean, "a") as fh:
        fh.write("".join(Path(write_dump(tmp_path / "tail.dump", [400, 500], seed=1)).read_text()))
    local = [write_contacts(tmp_path / f"c{k}.local", [(s, [PAIR]) for s in steps])
             for k, steps in ((1, [0, 100, 200, 300]), (2, [200, 300, 400, 500]))]
    line = refusal(capsys, first, again, *HEAVISIDE_Z, "--out", tmp_path / "o")
    assert line.startswith(f"{again}: frame at step 200 goes back from step 300 of {first}")
    line = refusal(capsys, first, again, "--contacts", *local, *HEAVISIDE_Z, "--out", tmp_path / "o")
    assert line.startswith(f"{local[1]}: contact frame at step 200 goes back from step 300 of {local[0]}")

    clean_local = write_contacts(tmp_path / "c.local", [(s, [PAIR]) for s in (0, 100, 200, 300, 400, 500)])
    assert cg(clean, "--contacts", clean_local, *HEAVISIDE_Z, "--out", tmp_path / "clean") == 0
    assert cg(first, again, "--contacts", *local, *HEAVISIDE_Z, "--drop-repeated-steps",
              "--out", tmp_path / "kept") == 0
    said = capsys.readouterr().out
    assert (f"--drop-repeated-steps: left out 2 atom frames (the first at step 200 of {again}, after step 300) "
            f"and 2 contact frames") in said
    pd.testing.assert_frame_equal(fields(tmp_path / "kept"), fields(tmp_path / "clean"), check_exact=True)
    frames = meta(tmp_path / "kept")["frames"]
    assert frames["count"] == 6 and frames["first_step"] == 0 and frames["last_step"] == 500
    assert frames["dropped_repeated_steps"] == {
        "atom_frames": {"frames": 2, "first": {"path": str(again), "step": 200, "after_step": 300}},
        "contact_frames": {"frames": 2, "first": {"path": str(local[1]), "step": 200, "after_step": 300}}}
    assert meta(tmp_path / "clean")["frames"]["dropped_repeated_steps"] is None


def test_a_copy_given_twice_with_the_flag_gives_the_fields_of_one(tmp_path):
    """The standard errors of a dump given twice were 31 % too small; with the flag they are those of one."""
    dump = write_dump(tmp_path / "atoms.dump", range(0, 1600, 100))
    shutil.copy(dump, tmp_path / "copy.dump")
    assert cg(dump, *HEAVISIDE_Z, "--out", tmp_path / "once") == 0
    assert cg(dump, tmp_path / "copy.dump", *HEAVISIDE_Z, "--drop-repeated-steps", "--out", tmp_path / "twice") == 0
    pd.testing.assert_frame_equal(fields(tmp_path / "twice"), fields(tmp_path / "once"), check_exact=True)
    assert meta(tmp_path / "twice")["frames"]["dropped_repeated_steps"]["atom_frames"]["frames"] == 16


# --------------------------------------------------------------------------- contacts


@pytest.mark.parametrize("column, value, allowed", [
    ("fx", float("nan"), "a finite number"),
    ("fz", float("-inf"), "a finite number"),
    ("dy", float("nan"), "a finite number"),
    ("dx", 1e200, "a branch component no longer than the box along x (2): a branch joins the centres of two "
                  "touching particles"),
    ("dz", -5.0, "a branch component no longer than the box along z (4)"),
    ("id2", float("nan"), "a finite number"),
])
def test_an_impossible_contact_is_refused_naming_the_frame_the_atoms_and_the_column(tmp_path, capsys, column, value,
                                                                                     allowed):
    """Before: a NaN force gave exit 0 with every contact stress NaN; a branch of 1e200 stopped on
    'deg must be a positive integer'."""
    dump = write_dump(tmp_path / "atoms.dump", [0, 100])
    names = ("id1", "id2", "dx", "dy", "dz", "fx", "fy", "fz")
    bad = list(PAIR)
    bad[names.index(column)] = value
    local = write_contacts(tmp_path / "c.local", [(0, [PAIR]), (100, [PAIR, PAIR[:1] + (3,) + PAIR[2:], bad])])
    line = refusal(capsys, dump, "--contacts", local, *HEAVISIDE_Z, "--out", tmp_path / "o")
    atoms_named = "atoms 1 and nan" if column == "id2" else "atoms 1 and 2"
    assert line.startswith(f"{local}: frame 1 at step 100 (line 11): entry 3, the contact of {atoms_named}: "
                           f"column {column} = {value:g} is not allowed: allowed {allowed}"), line


def test_a_contact_column_given_by_role_is_named_with_its_role(tmp_path, capsys):
    dump = write_dump(tmp_path / "atoms.dump", [0])
    names = ("c_ids[1]", "c_ids[2]", "c_pl[1]", "c_pl[2]", "c_pl[3]", "c_pl[4]", "c_pl[5]", "c_pl[6]")
    local = write_contacts(tmp_path / "c.local", [(0, [PAIR[:5] + (float("nan"),) + PAIR[6:]])], columns=names)
    roles = ",".join(f"{r}={c}" for r, c in zip(("id1", "id2", "dx", "dy", "dz", "fx", "fy", "fz"), names))
    line = refusal(capsys, dump, "--contacts", local, "--contact-columns", roles, *HEAVISIDE_Z, "--out", tmp_path / "o")
    assert "entry 1, the contact of atoms 1 and 2: column c_pl[4] (fx) = nan is not allowed" in line


# --------------------------------------------------------------------------- gzip bombs


def gzip_bomb(path, head: bytes, body: bytes, repeats: int, tail: bytes = b"\n") -> Path:
    """A gzip file of ``head``, ``repeats`` copies of ``body`` and ``tail``, compressed as it goes."""
    packer = zlib.compressobj(6, zlib.DEFLATED, 31)
    with open(path, "wb") as fh:
        fh.write(packer.compress(head))
        for _ in range(repeats):
            fh.write(packer.compress(body))
        fh.write(packer.compress(tail) + packer.flush())
    return Path(path)


def test_a_gzip_bomb_line_is_refused_at_once_in_little_memory(tmp_path, capsys):
    """Before: 2 MB expanding to one 2 GiB line was refused after 44 s and 4.4 GB of memory. Here 64 KB
    expand to a 64 MiB line (the same shape, 32 times smaller to build quickly): refused after reading
    MAX_LINE_BYTES (1 MiB) of it. Measured: 10 ms and 2.2 MB peak on the 2 GiB bomb; the bounds below
    (2 s, 8 MiB: the 1 MiB line, gzip's buffers and the frame's few objects) leave room for a slow,
    loaded machine without letting the whole line be read (64 MiB)."""
    bomb = gzip_bomb(tmp_path / "bomb.dump.gz", b"ITEM: TIMESTEP\n", b"0" * (1 << 20), 64)
    assert bomb.stat().st_size < 100_000
    tracemalloc.start()
    start = time.perf_counter()
    try:
        with pytest.raises(DumpError) as caught:
            list(read_dump(bomb))
        elapsed, peak = time.perf_counter() - start, tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert elapsed < 2.0 and peak < 8 << 20, (elapsed, peak)
    assert "line 2 (from byte 15) is longer than 1,048,576 bytes" in str(caught.value)
    line = refusal(capsys, bomb, *HEAVISIDE_Z, "--out", tmp_path / "o")
    assert line.startswith(f"{bomb}: frame 0 at line 2 is corrupted: line 2 (from byte 15) is longer than 1,048,576 "
                           f"bytes: a line of a LAMMPS dump holds one atom's values; this is not a dump")


def test_a_gzip_stream_expanding_more_than_a_dump_can_is_refused(tmp_path, capsys, monkeypatch):
    """Short lines, a frame declaring 10^9 atoms, 1000:1 compression: refused once the stream has expanded
    more than MAX_GZIP_RATIO (200) times, checked from GZIP_RATIO_FLOOR decompressed bytes on (lowered
    here from 16 MiB to 1 MiB to keep the test small)."""
    monkeypatch.setattr(dump_text, "GZIP_RATIO_FLOOR", 1 << 20)
    head = (b"ITEM: TIMESTEP\n0\nITEM: NUMBER OF ATOMS\n1000000000\nITEM: BOX BOUNDS pp pp pp\n0 2\n0 2\n0 4\n"
            b"ITEM: ATOMS " + " ".join(COLUMNS).encode() + b"\n")
    bomb = gzip_bomb(tmp_path / "lines.dump.gz", head, b"1 1 1 1 1 0 0 0 0.4 2\n" * 1000, 200)
    line = refusal(capsys, bomb, *HEAVISIDE_Z, "--out", tmp_path / "o")
    assert "more than 200 times: a gzipped LAMMPS dump expands 3 to 40 times; this is not a dump" in line, line


def test_a_gzipped_dump_of_empty_frames_expands_within_the_bound(tmp_path, monkeypatch):
    """The most a real dump expands that we know of (frames without atoms, about 40 times) reads."""
    monkeypatch.setattr(dump_text, "GZIP_RATIO_FLOOR", 1 << 20)
    frame = ("ITEM: TIMESTEP\n{}\nITEM: NUMBER OF ATOMS\n0\nITEM: BOX BOUNDS pp pp pp\n0 2\n0 2\n0 4\n"
             "ITEM: ATOMS " + " ".join(COLUMNS) + "\n")
    path = tmp_path / "empty_frames.dump.gz"
    with gzip.open(path, "wt") as fh:
        fh.write("".join(frame.format(step) for step in range(20_000)))
    assert sum(1 for _ in read_dump(path)) == 20_000


# --------------------------------------------------------------------------- what an input is


def test_an_input_that_is_not_a_dump_file_is_named_for_what_it_is(tmp_path, capsys):
    """Before: an empty file, a directory, a FIFO or /dev/zero were all refused as 'does not exist'."""
    good = write_dump(tmp_path / "atoms.dump", [0])
    out = tmp_path / "o"
    (tmp_path / "empty.dump").touch()
    (tmp_path / "folder").mkdir()
    os.mkfifo(tmp_path / "pipe")
    (tmp_path / "dangling").symlink_to(tmp_path / "gone.dump")
    cases = {
        tmp_path / "absent.dump": "does not exist",
        tmp_path / "dangling": f"is a symbolic link to {tmp_path / 'gone.dump'}, which does not exist",
        tmp_path / "empty.dump": "is empty (0 bytes): it holds no frame",
        tmp_path / "folder": "is a directory, not a regular file: granflow cg reads each dump more than once",
        tmp_path / "pipe": "is a FIFO (named pipe), not a regular file",
    }
    if os.path.exists("/dev/zero"):
        cases[Path("/dev/zero")] = "is a character device, not a regular file"
    for path, said in cases.items():
        assert refusal(capsys, path, *HEAVISIDE_Z, "--out", out).startswith(f"dump file {path} {said}")
        line = refusal(capsys, good, "--contacts", path, *HEAVISIDE_Z, "--out", out)
        assert line.startswith(f"contact dump file {path} {said}")


@pytest.mark.skipif(os.geteuid() == 0, reason="root reads any file")
def test_an_unreadable_input_is_named(tmp_path, capsys):
    dump = write_dump(tmp_path / "atoms.dump", [0])
    dump.chmod(0)
    line = refusal(capsys, dump, *HEAVISIDE_Z, "--out", tmp_path / "o")
    assert line == f"dump file {dump} cannot be read: permission denied"
