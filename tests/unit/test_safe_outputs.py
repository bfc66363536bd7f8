"""Outputs never go through a link, and an earlier result stays whole until the new one is complete
(issue 41, defects 3 and 4): ``granflow cg`` and ``granflow render`` on links where their files go, and
``granflow cg --overwrite`` on a full disk (a write monkeypatched to fail with ENOSPC)."""
from __future__ import annotations

import errno
import os
import stat
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from granflow.cli import main as granflow
from postproc import cg_cli
from postproc.cg_output import OUTPUT_NAMES
from postproc.safe_write import OutputWriteError, StagedFiles, staged_files, write_text

HEAVISIDE_Z = ("--coords", "z", "--kernel", "heaviside", "--spacing", 1, "--quiet")
COLUMNS = ["id", "type", "x", "y", "z", "vx", "vy", "vz", "radius", "mass"]


@pytest.fixture
def dump(tmp_path) -> Path:
    """Four frames of eight spheres (r = 0.4, m = 2) in a 2 x 2 x 4 box, seeded velocities."""
    rng = np.random.default_rng(7)
    g = np.stack(np.meshgrid([0.5, 1.5], [0.5, 1.5], [0.5, 2.5], indexing="ij"), -1).reshape(-1, 3)
    path = tmp_path / "atoms.dump"
    with open(path, "w") as fh:
        for step in (0, 100, 200, 300):
            fh.write(f"ITEM: TIMESTEP\n{step}\nITEM: NUMBER OF ATOMS\n8\nITEM: BOX BOUNDS pp pp pp\n0 2\n0 2\n0 4\n")
            fh.write("ITEM: ATOMS " + " ".join(COLUMNS) + "\n")
            v = rng.normal(size=(8, 3))
            for i, (x, y, z) in enumerate(g):
                fh.write(f"{i + 1} 1 {x} {y} {z} {float(v[i, 0])!r} {float(v[i, 1])!r} {float(v[i, 2])!r} 0.4 2\n")
    return path


def cg(*args) -> int:
    return granflow(["cg", *map(str, args)])


def snapshot(folder: Path) -> dict[str, bytes]:
    """Every entry of ``folder`` (hidden ones too) with its bytes."""
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir())}


# --------------------------------------------------------------------------- links (defect 3)


@pytest.mark.parametrize("name", OUTPUT_NAMES)
@pytest.mark.parametrize("overwrite", [(), ("--overwrite",)], ids=["", "--overwrite"])
def test_cg_never_writes_through_a_link_where_an_output_goes(dump, tmp_path, capsys, name, overwrite):
    """Before: the file outside the output directory was written through the link, and a dangling link
    was followed (creating its target) even without --overwrite."""
    outside = tmp_path / "elsewhere"
    outside.mkdir()
    victim = outside / "precious.txt"
    victim.write_text("keep me\n")
    out = tmp_path / "out"
    out.mkdir()
    for target in (victim, outside / "not_yet"):
        link = out / name
        link.unlink(missing_ok=True)
        link.symlink_to(target)
        assert cg(dump, *HEAVISIDE_Z, "--out", out, *overwrite) == 2
        err = capsys.readouterr().err
        dangling = "" if target.exists() else ", which does not exist"
        assert err == (f"granflow: refused: --out {out}: {out / name} is a symbolic link to {target}{dangling}: "
                       f"granflow cg never writes through a link or over anything but its own regular files; "
                       f"remove it or choose another --out\n")
        assert victim.read_text() == "keep me\n" and not (outside / "not_yet").exists()
        assert sorted(p.name for p in out.iterdir()) == [name]


def test_cg_refuses_a_directory_where_an_output_goes(dump, tmp_path, capsys):
    out = tmp_path / "out"
    (out / "meta.json").mkdir(parents=True)
    assert cg(dump, *HEAVISIDE_Z, "--out", out, "--overwrite") == 2
    assert f"{out / 'meta.json'} is a directory, not a regular file" in capsys.readouterr().err


def test_cg_overwrite_replaces_a_hard_link_without_writing_through_it(dump, tmp_path):
    """An output name that is a hard link to another file: the new output is a new file; the other name
    keeps its bytes (the old code wrote into the shared inode)."""
    out = tmp_path / "out"
    assert cg(dump, *HEAVISIDE_Z, "--out", out) == 0
    os.link(out / "fields.csv", tmp_path / "shared.csv")
    before = (tmp_path / "shared.csv").read_bytes()
    assert cg(dump, *HEAVISIDE_Z, "--width", 1, "--kernel", "gaussian", "--out", out, "--overwrite") == 0
    assert (tmp_path / "shared.csv").read_bytes() == before
    assert (out / "fields.csv").read_bytes() != before and (out / "fields.csv").stat().st_nlink == 1


def test_render_never_writes_through_a_link_where_a_file_goes(tmp_path, capsys):
    """Before: render wrote a deck through a link in --out into a file outside it (and created a
    dangling link's target). Now each file is written under a temporary name and moved into place,
    which replaces the link itself."""
    outside = tmp_path / "elsewhere"
    outside.mkdir()
    victim = outside / "precious.txt"
    victim.write_text("keep me\n")
    out = tmp_path / "case"
    out.mkdir()
    (out / "init.lmp").symlink_to(victim)
    (out / "params.json").symlink_to(outside / "not_yet")
    render = ["render", "channel", "--rung", "smoke", "--out", str(out)]
    assert granflow(render) == 2  # a directory granflow did not render into: refused without --force
    assert "not empty" in capsys.readouterr().err
    assert victim.read_text() == "keep me\n" and not (outside / "not_yet").exists()
    assert granflow([*render, "--force"]) == 0
    assert victim.read_text() == "keep me\n" and not (outside / "not_yet").exists()
    for name in ("init.lmp", "flow.lmp", "average.lmp", "params.json"):
        mode = os.lstat(out / name).st_mode
        assert stat.S_ISREG(mode) and mode & 0o777 == 0o666 & ~_umask(), name
    assert not [p for p in out.iterdir() if p.name.startswith(".")]


def _umask() -> int:
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


# --------------------------------------------------------------------------- a full disk (defect 4)


def enospc(*args, **kwargs):
    raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))


def test_overwrite_on_a_full_disk_keeps_the_earlier_result(dump, tmp_path, capsys, monkeypatch):
    """Before: the old fields.csv was gone, a truncated new one sat beside the old meta.json, and the
    message said "refused" (exit 2). Now the earlier fields.csv, meta.json and fields.vtr stay byte for
    byte, no temporary file is left, and one line names the file (exit 1, documented in --help)."""
    out = tmp_path / "out"
    assert cg(dump, *HEAVISIDE_Z, "--out", out) == 0
    capsys.readouterr()
    earlier = snapshot(out)
    assert sorted(earlier) == sorted(OUTPUT_NAMES)
    new = ("--kernel", "gaussian", "--width", 1)  # another result, so a mix of old and new would show

    def half_then_enospc(self, path, *args, **kwargs):
        Path(path).write_text("z,n\n0.5,")  # a truncated table, then the disk is full
        enospc()

    with monkeypatch.context() as m:
        m.setattr(pd.DataFrame, "to_csv", half_then_enospc)
        assert cg(dump, *HEAVISIDE_Z, *new, "--out", out, "--overwrite") == cg_cli.EXIT_NOT_WRITTEN == 1
    err = capsys.readouterr().err
    assert err == (f"granflow: could not write {out / 'fields.csv'}: No space left on device (ENOSPC); nothing "
                   f"was moved into place: the earlier files in {out} are unchanged\n")
    assert "refused" not in err and snapshot(out) == earlier

    # the disk fills on the last file, after fields.csv and fields.vtr are complete: still all old
    real_write_text = Path.write_text

    def meta_fails(self, *args, **kwargs):
        if self.name.startswith(".meta.json."):
            enospc()
        return real_write_text(self, *args, **kwargs)

    with monkeypatch.context() as m:
        m.setattr(Path, "write_text", meta_fails)
        assert cg(dump, *HEAVISIDE_Z, *new, "--out", out, "--overwrite") == 1
    assert f"could not write {out / 'meta.json'}: No space left on device" in capsys.readouterr().err
    assert snapshot(out) == earlier

    # room again: the new result replaces the old one whole
    assert cg(dump, *HEAVISIDE_Z, *new, "--out", out, "--overwrite") == 0
    now = snapshot(out)
    assert sorted(now) == sorted(OUTPUT_NAMES)
    assert all(now[name] != earlier[name] for name in OUTPUT_NAMES)
    assert "Exit status: 0\ndone, 2 refused (nothing written), 1 the outputs could not be written" in cg_cli.EPILOG


def test_a_full_disk_on_a_first_run_leaves_no_partial_file(dump, tmp_path, capsys, monkeypatch):
    out = tmp_path / "out"
    monkeypatch.setattr(pd.DataFrame, "to_csv", lambda self, path, *a, **k: enospc())
    assert cg(dump, *HEAVISIDE_Z, "--out", out) == 1
    assert "could not write" in capsys.readouterr().err
    assert list(out.iterdir()) == []


# --------------------------------------------------------------------------- the staging itself


def test_staged_files_move_into_place_together_or_not_at_all(tmp_path):
    folder = tmp_path / "f"
    folder.mkdir()
    (folder / "a.txt").write_text("old a")
    (folder / "b.txt").write_text("old b")
    for failure in (ValueError("a bug"), KeyboardInterrupt()):
        with pytest.raises(type(failure)):
            with staged_files(folder) as files:
                files.write("a.txt", lambda p: p.write_text("new a"))
                raise failure
        assert snapshot(folder) == {"a.txt": b"old a", "b.txt": b"old b"}
    with staged_files(folder) as files:
        assert files.write("a.txt", lambda p: p.write_text("new a")) == folder / "a.txt"
        files.write("b.txt", lambda p: p.write_text("new b"))
        assert snapshot(folder) == {"a.txt": b"old a", "b.txt": b"old b", **{
            p.name: p.read_bytes() for p in folder.iterdir() if p.name.startswith(".")}}
    assert snapshot(folder) == {"a.txt": b"new a", "b.txt": b"new b"}
    with pytest.raises(ValueError, match="without a directory part"):
        StagedFiles(folder).write("../escape.txt", lambda p: p.write_text("x"))


def test_write_text_on_a_full_disk_names_the_file_and_keeps_the_old_one(tmp_path, monkeypatch):
    path = tmp_path / "params.json"
    path.write_text("old")
    monkeypatch.setattr(Path, "write_text", lambda self, *a, **k: enospc())
    with pytest.raises(OutputWriteError) as caught:
        write_text(path, "new")
    assert caught.value.errno == errno.ENOSPC and caught.value.filename == str(path)
    assert str(caught.value).startswith(f"could not write {path}: No space left on device (ENOSPC)")
    assert path.read_bytes() == b"old" and sorted(p.name for p in tmp_path.iterdir()) == ["params.json"]


def test_render_on_a_full_disk_says_stopped_not_refused(tmp_path, capsys, monkeypatch):
    """Before: ``granflow render`` on a full disk said "refused" (exit 2), which tells the user their input
    was wrong. Now a full disk (ENOSPC) ends it with exit 1, one line "stopped: could not write <file>: No
    space left on device ...", no traceback, and the earlier deck of that name unchanged; a mistake of the
    user's (a missing --config file) is still refused with exit 2."""
    out = tmp_path / "case"
    render = ["render", "channel", "--rung", "smoke", "--out", str(out)]
    assert granflow(render) == 0
    capsys.readouterr()
    earlier = (out / "flow.lmp").read_bytes()
    real = Path.write_text

    def flow_fails(self, *args, **kwargs):
        if self.name.startswith(".flow.lmp."):
            enospc()
        return real(self, *args, **kwargs)

    with monkeypatch.context() as m:
        m.setattr(Path, "write_text", flow_fails)
        assert granflow([*render, "--force"]) == 1
    err = capsys.readouterr().err
    assert err.startswith(f"granflow: stopped: could not write {out / 'flow.lmp'}: No space left on device (ENOSPC)")
    assert "refused" not in err and "Traceback" not in err and err.count("\n") == 1
    assert (out / "flow.lmp").read_bytes() == earlier
    assert not [p for p in out.iterdir() if p.name.startswith(".")]
    assert granflow([*render, "--force", "--config", str(tmp_path / "missing.yaml")]) == 2
    assert "refused" in capsys.readouterr().err
