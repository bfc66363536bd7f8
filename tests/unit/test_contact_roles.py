"""Contact dumps from anyone: column roles, gzip, and branches rebuilt from positions."""
from __future__ import annotations

import gzip

import numpy as np
import pytest
from numpy.testing import assert_allclose

from postproc.contacts import ContactFrame, branch_quadrature, read_contact_dump
from postproc.dump import DumpError
from postproc.frame import DumpFrame, ParticleFrame

BOX = np.array([[0.0, 1.0], [0.0, 2.0], [0.0, 3.0]])


def local_dump(frames, names, time=True) -> str:
    """A LAMMPS text ``dump local``: ``frames`` are (step, rows)."""
    out = []
    for step, rows in frames:
        if time:
            out += ["ITEM: TIME", repr(step * 1e-4)]
        out += ["ITEM: TIMESTEP", str(step), "ITEM: NUMBER OF ENTRIES", str(len(rows)), "ITEM: BOX BOUNDS pp pp ff"]
        out += [f"{lo!r} {hi!r}" for lo, hi in BOX.tolist()]
        out += ["ITEM: ENTRIES " + " ".join(names)]
        out += [" ".join(repr(float(v)) for v in row) for row in rows]
    return "\n".join(out) + "\n"


# pair (1, 2) across the periodic x boundary, (2, 3) in the bulk, (3, 4) a listed neighbour without force
ROWS = [
    [1, 2, 9.0, 0.5, 1.2, 0.0, -1.0],
    [2, 3, 9.0, 0.0, 0.0, -2.0, 0.0],
    [3, 4, 9.0, 0.0, 0.0, 0.0, 0.0],
]
RAW_NAMES = ["c_ids[1]", "c_ids[2]", "c_pl[1]", "c_pl[2]", "c_pl[3]", "c_pl[4]", "c_pl[5]"]
ROLES = {"id1": "c_ids[1]", "id2": "c_ids[2]", "fx": "c_pl[3]", "fy": "c_pl[4]", "fz": "c_pl[5]"}


def particles(step=100, boundary="p p f"):
    """Particle frame (via from_dump) in which 1 and 2 touch across x = 0 = 1."""
    # by id: 1, 2, 3, 4
    pos = np.array([[0.02, 1.0, 1.0], [0.96, 1.0, 1.05], [0.96, 1.1, 1.05], [0.5, 0.5, 0.5]])
    ids = np.array([3.0, 1.0, 4.0, 2.0])  # unsorted on purpose
    pos = pos[[2, 0, 3, 1]]
    cols = {"id": ids, "x": pos[:, 0], "y": pos[:, 1], "z": pos[:, 2], "vx": np.zeros(4), "vy": np.zeros(4),
            "vz": np.zeros(4), "radius": np.full(4, 0.03), "mass": np.ones(4)}
    return ParticleFrame.from_dump(DumpFrame(step, BOX, boundary, cols))


def test_explicit_roles_read_raw_column_names(tmp_path):
    path = tmp_path / "local.dump"
    path.write_text(local_dump([(0, []), (100, ROWS)], RAW_NAMES))
    frames = list(read_contact_dump(path, roles=ROLES))
    assert [f.timestep for f in frames] == [0, 100]
    assert [f.time for f in frames] == [0.0, 0.01]
    first, second = frames
    assert len(first) == 0 and first.branch is None
    assert list(second.id_i) == [1, 2] and list(second.id_j) == [2, 3]  # the idle neighbour dropped
    assert_allclose(second.force, [[1.2, 0.0, -1.0], [0.0, -2.0, 0.0]])
    assert second.branch is None
    assert [f.timestep for f in read_contact_dump(path, roles=ROLES, select=lambda s: s > 0)] == [100]


def test_roles_that_cannot_be_inferred_are_explained(tmp_path):
    path = tmp_path / "local.dump"
    path.write_text(local_dump([(100, ROWS)], RAW_NAMES))
    with pytest.raises(DumpError) as err:
        list(read_contact_dump(path))
    msg = str(err.value)
    assert str(RAW_NAMES) in msg and "roles=" in msg and "dump_modify colname" in msg
    assert err.value.truncated is False and err.value.frame == 0
    with pytest.raises(DumpError, match=r"lack .*c_pl\[9\]"):  # a role pointing at an absent column
        list(read_contact_dump(path, roles={**ROLES, "fz": "c_pl[9]"}))
    with pytest.raises(ValueError, match="unknown contact roles"):
        read_contact_dump(path, roles={"i": "c_ids[1]"})
    with pytest.raises(ValueError, match="not both"):
        read_contact_dump(path, roles={"fx": "a", "fnx": "b"})


def test_normal_and_tangential_roles_are_summed_with_branch_columns(tmp_path):
    names = ["a", "b", "rx", "ry", "rz", "n1", "n2", "n3", "t1", "t2", "t3"]
    rows = [[1, 2, 0.1, 0.0, 0.0, 5.0, 0.0, 0.0, 0.0, 1.0, 0.0]]
    path = tmp_path / "fnft.dump"
    path.write_text(local_dump([(0, rows)], names))
    roles = {"id1": "a", "id2": "b", "dx": "rx", "dy": "ry", "dz": "rz", "fnx": "n1", "fny": "n2", "fnz": "n3",
             "ftx": "t1", "fty": "t2", "ftz": "t3"}
    frame = next(read_contact_dump(path, roles=roles))
    assert_allclose(frame.force, [[5.0, 1.0, 0.0]])
    assert_allclose(frame.branch, [[0.1, 0.0, 0.0]])


def test_gzipped_local_dump_is_recognised_by_content(tmp_path):
    names = ["id1", "id2", "dx", "dy", "dz", "fx", "fy", "fz"]
    rows = [[1, 2, 0.06, 0.0, -0.05, -1.0, 0.0, 0.25]]
    plain, packed = tmp_path / "plain.dump", tmp_path / "packed.dump"
    plain.write_text(local_dump([(100, rows)], names))
    packed.write_bytes(gzip.compress(plain.read_bytes()))
    a, b = next(read_contact_dump(plain)), next(read_contact_dump(packed))
    assert_allclose(a.branch, b.branch) and assert_allclose(a.force, b.force)
    assert a.time == b.time == 0.01


def test_branch_from_positions_with_minimum_image(tmp_path):
    path = tmp_path / "local.dump"
    path.write_text(local_dump([(100, ROWS)], RAW_NAMES))
    contacts = next(read_contact_dump(path, roles=ROLES))
    with pytest.raises(ValueError, match="with_branch"):
        contacts.pair_tensors()
    with pytest.raises(ValueError, match="with_branch"):
        branch_quadrature(np.zeros((2, 3)), contacts.branch, 0.1)
    frame = particles()
    assert frame.boundary == "p p f"
    filled = contacts.with_branch(frame)
    assert contacts.branch is None  # a copy
    # 1 at x = 0.02, 2 at x = 0.96: across the periodic x boundary the branch is +0.06, not -0.94
    assert_allclose(filled.branch, [[0.06, 0.0, -0.05], [0.0, -0.1, 0.0]], atol=1e-12)
    assert np.all(np.sum(filled.force * filled.branch, axis=1) > 0)  # repulsive, as the forces say
    assert filled.pair_tensors().shape == (2, 6)
    assert_allclose(filled.anchor(frame), [[0.02, 1.0, 1.0], [0.96, 1.0, 1.05]])
    # not periodic in x: the raw difference
    assert_allclose(contacts.with_branch(frame, boundary="f p f").branch[0], [-0.94, 0.0, -0.05], atol=1e-12)
    # the z dimension is not periodic even when the difference is large
    far = particles(boundary="p p f")
    far.position[far.id == 2, 2] += 2.0
    assert_allclose(contacts.with_branch(far).branch[0], [0.06, 0.0, -2.05], atol=1e-12)
    assert_allclose(contacts.with_branch(far, boundary="p p p").branch[0], [0.06, 0.0, 0.95], atol=1e-12)
    with pytest.raises(ValueError, match="step"):
        contacts.with_branch(particles(step=7))
    empty = ContactFrame(100, BOX, np.zeros(0, np.int64), np.zeros(0, np.int64), None, np.zeros((0, 3)))
    assert empty.with_branch(frame).branch.shape == (0, 3)
