"""Contact dumps (postproc.contacts) and the contact stress along branch lines (paper eq. 5)."""
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose

from postproc.contacts import ContactFrame, branch_quadrature, read_contact_dump, sym_outer
from postproc.coordinates import RZCoordinates, XCoordinates
from postproc.dump import DumpError
from postproc.fields import FieldAccumulator
from postproc.frame import DumpFrame, ParticleFrame
from postproc.kernels import Gaussian

DATA = Path(__file__).resolve().parents[1] / "data"
TWO_PAIRS = DATA / "contacts_two_pairs.dump"
RZ = RZCoordinates()
CYL = ("rr", "tt", "zz", "rt", "rz", "tz")
XYZ = ("xx", "yy", "zz", "xy", "xz", "yz")


def particles(position, ids, timestep=0, box=None):
    position = np.asarray(position, dtype=float)
    n = len(position)
    box = np.array([[-1.0, 1.0], [-1.0, 1.0], [-1.0, 1.0]]) if box is None else box
    return ParticleFrame(timestep, box, position, np.zeros((n, 3)), np.ones(n), np.full(n, 0.01),
                         id=np.asarray(ids))


# --------------------------------------------------------------------------- reader


def test_reader_on_two_pairs_drops_the_duplicate_and_the_idle_neighbour():
    frames = list(read_contact_dump(TWO_PAIRS))
    assert [f.timestep for f in frames] == [0, 100]
    first, empty = frames
    # 4 entries: pairs (1,2) and (2,3), (1,2) again listed as (2,1), and (3,4) with no force
    assert len(first) == 2 and first.n_duplicates == 1
    assert_allclose(first.id_i, [1, 2]) and assert_allclose(first.id_j, [2, 3])
    assert_allclose(first.branch, [[-0.025, 0.0, -0.005], [0.0, 0.02, 0.021]])
    # f = fn + ft
    assert_allclose(first.force, [[-196.597, 0.0, -39.3194], [2.0, 34.4828, 36.2069]])
    assert_allclose(first.box, [[-0.1, 0.1], [-0.1, 0.1], [-0.1, 0.2]], rtol=1e-15)
    assert np.all(np.sum(first.force * first.branch, axis=1) > 0)  # repulsive
    assert len(empty) == 0 and empty.branch.shape == (0, 3)


def _replace(lines, index, new):
    return lines[:index] + [new] + lines[index + 1:]


@pytest.mark.parametrize(
    "edit, message",
    [
        # a frame cut short inside its entries
        (lambda lines: lines[:12], r"frame 0 at line 12 is truncated: expected 4 entry lines"),
        # a non-numeric entry (line 12)
        (lambda lines: _replace(lines, 11, "1 2 -0.025 0 x -196 0 -39 0 0 0\n"),
         r"frame 0 at line 10 is corrupted: entry lines 10-13 do not parse"),
        # entries without force columns
        (lambda lines: _replace(lines, 8, "ITEM: ENTRIES id1 id2 dx dy dz\n"), r"frame 0 at line 9 .*force columns"),
        # a third frame cut short in its header
        (lambda lines: lines + ["ITEM: TIMESTEP\n", "200\n", "ITEM: NUMBER OF ENTRIES\n"],
         r"frame 2 at line 25 is truncated"),
        # an entry line with a column missing (line 13)
        (lambda lines: _replace(lines, 12, "1 2 0 0 0 1 1 1 1 1\n"), r"frame 0 at line 10 is corrupted: entry lines 10-13"),
    ],
)
def test_reader_names_file_frame_and_line_on_malformed_input(tmp_path, edit, message):
    bad = tmp_path / "contacts_malformed.dump"
    bad.write_text("".join(edit(TWO_PAIRS.read_text().splitlines(keepends=True))))
    with pytest.raises(DumpError, match=message) as info:
        list(read_contact_dump(bad))
    assert str(bad) in str(info.value)


def test_anchor_finds_the_first_particle_by_id():
    contacts = next(read_contact_dump(TWO_PAIRS))
    position = np.arange(12.0).reshape(4, 3)
    frame = particles(position, [4, 2, 3, 1])  # unsorted ids
    assert_allclose(contacts.anchor(frame), position[[3, 1]])
    with pytest.raises(KeyError, match=r"\[2\]"):
        contacts.anchor(particles(position[:1], [1]))
    with pytest.raises(ValueError, match="step"):
        contacts.anchor(particles(position, [1, 2, 3, 4], timestep=7))
    with pytest.raises(ValueError, match="no ids"):
        contacts.anchor(ParticleFrame(0, np.zeros((3, 2)), position, position, np.ones(4), np.ones(4)))


def test_particle_frame_takes_ids_from_the_dump():
    columns = {k: np.array([1.0, 2.0]) for k in ("x", "y", "z", "vx", "vy", "vz", "mass", "radius")}
    frame = ParticleFrame.from_dump(DumpFrame(3, np.zeros((3, 2)), "f f f", {**columns, "id": np.array([5.0, 9.0])}))
    assert frame.id.dtype == np.int64 and list(frame.id) == [5, 9]
    assert ParticleFrame.from_dump(DumpFrame(3, np.zeros((3, 2)), "f f f", columns)).id is None


# --------------------------------------------------------------------------- stress


def one_pair(x_i):
    """The measured pair of the deck notes: spheres of d = 0.03 and 0.025 overlapping by 0.002."""
    branch, force = np.array([[-0.025, 0.0, -0.005]]), np.array([[-196.597, 0.0, -39.3194]])
    x_j = x_i - branch[0]
    frame = particles([x_i, x_j], [1, 2])
    return frame, ContactFrame(0, frame.box, np.array([1]), np.array([2]), branch, force)


def test_one_pair_volume_integral_is_f_outer_r():
    """int sigma^c dV = f (x) r and int p^c dV = f.r / 3 (the kernel line integral has unit volume)."""
    r_b = 1 / 64
    frame, contacts = one_pair(np.array([0.05, 0.0, 0.0]))  # in the y = 0 plane: theta = 0 along the branch
    kernel = Gaussian.paper(r_b / 2, ([0.0, 1.0], [0.0, 1.0]))
    h = kernel.width / 8
    kernel = Gaussian.paper(r_b / 2, (np.arange(0.0, 0.11, h), np.arange(-0.045, 0.05, h)))
    acc = FieldAccumulator(kernel, RZ, fields=("sigmac", "pc"), n_blocks=2)
    acc.prepare()
    acc.accumulate(frame, contacts)
    table = acc.conclude()
    volumes = kernel.node_volumes(RZ, frame.box)
    integral = (table[[f"sigmac_{c}" for c in CYL]].to_numpy() * volumes[:, None]).sum(axis=0)
    # all quadrature points have azimuth 0, so (r, t, z) = (x, y, z) there; each point's
    # kernel integrates to one within the grid's quadrature error, measured ~2e-5 at
    # h = sigma / 8 four sigma off the axis (tests/unit/test_cg_rz.py): rtol 1e-4
    expected = contacts.pair_tensors()[0]
    assert_allclose(integral, expected, rtol=1e-4, atol=1e-4 * np.abs(expected).max())
    f_dot_r = float(contacts.force[0] @ contacts.branch[0])
    assert f_dot_r > 0  # compressive positive
    assert_allclose(np.sum(table["pc"] * volumes), f_dot_r / 3, rtol=1e-4)


def test_one_pair_in_cartesian_coordinates_and_numpy_path():
    frame, contacts = one_pair(np.array([0.0, 0.013, 0.02]))
    # sigma = 0.011: a 1D Gaussian in x integrated over y and z (area 4)
    w = 1 / 128
    kernel = Gaussian.paper(w, np.arange(-0.08, 0.08, w / 8))
    acc = FieldAccumulator(kernel, XCoordinates(), fields=("sigmac", "pc"), n_blocks=2)
    acc.prepare()
    acc.accumulate(frame, contacts)
    table = acc.conclude()
    volumes = kernel.node_volumes(XCoordinates(), frame.box)
    integral = (table[[f"sigmac_{c}" for c in XYZ]].to_numpy() * volumes[:, None]).sum(axis=0)
    # midpoint rule of a 1D Gaussian at h = sigma / 11: exponentially small error but for
    # the truncation step (e^-4 of the peak), ~1e-6 relative
    assert_allclose(integral, sym_outer(contacts.force, contacts.branch)[0], rtol=1e-5, atol=1e-5)


def test_compiled_and_numpy_contact_stress_agree():
    rng = np.random.default_rng(1)
    n = 60
    position = np.column_stack([rng.uniform(-0.05, 0.05, (n, 2)), rng.uniform(0.0, 0.1, n)])
    frame = particles(position, np.arange(1, n + 1))
    pairs = np.array([(i, j) for i in range(n) for j in range(i + 1, n)
                      if np.linalg.norm(position[i] - position[j]) < 0.03])
    branch = position[pairs[:, 0]] - position[pairs[:, 1]]
    force = 100 * branch / np.linalg.norm(branch, axis=1)[:, None] + rng.normal(size=branch.shape)
    contacts = ContactFrame(0, frame.box, pairs[:, 0] + 1, pairs[:, 1] + 1, branch, force)
    kernel = Gaussian.paper(1 / 128, (np.arange(0.0, 0.09, 1 / 256), np.arange(-0.03, 0.13, 1 / 256)))
    tables = []
    for method in ("compiled", "numpy"):
        acc = FieldAccumulator(kernel, RZ, fields=("sigmac", "pc"), n_blocks=2, method=method)
        acc.prepare()
        acc.accumulate(frame, contacts)
        tables.append(acc.conclude())
    cols = [f"sigmac_{c}" for c in CYL] + ["pc"]
    a, b = (t[cols].to_numpy() for t in tables)
    # the same kernel weights to ~1e-8 of the weight sum (test_cg_rz)
    assert_allclose(a, b, rtol=0, atol=1e-6 * np.abs(b).max())


def test_vertical_stress_balance_of_a_column_under_gravity():
    """A chain of N equal spheres on the axis, each contact carrying the weight above it.

    Across a horizontal plane at height z the coarse-grained sigma^c_zz integrates
    to the force transmitted through the chain there, smoothed along z by the
    kernel's z-marginal. That staircase is linear in z plus steps of m g at the
    particle centres, antisymmetric about each contact point: so at a contact point
    the plane integral is exactly the weight of the particles above it, and at a
    centre the weight above with that particle counted half, wherever the kernel
    (cutoff 2a) does not reach the ends of the chain.
    """
    N, a, m, g = 10, 0.01, 0.3, 10.0
    z_centre = (2 * np.arange(N) + 1) * a
    frame = particles(np.column_stack([np.zeros(N), np.zeros(N), z_centre]), np.arange(1, N + 1), timestep=5,
                      box=np.array([[-a, a], [-a, a], [0.0, 2 * N * a]]))
    above = (N - 1 - np.arange(N - 1)) * m * g  # weight above contact k (between k and k + 1)
    contacts = ContactFrame(5, frame.box, np.arange(2, N + 1), np.arange(1, N),  # i the upper one
                            np.tile([0.0, 0.0, 2 * a], (N - 1, 1)),  # r_ij = x_i - x_j: up
                            np.column_stack([np.zeros(N - 1), np.zeros(N - 1), above]))  # on i by j: up
    hr, hz = a / 16, a / 8
    kernel = Gaussian.paper(a / 2, (np.arange(0.0, 2.5 * a, hr), np.arange(0.0, 2 * N * a + hz / 2, hz)))
    acc = FieldAccumulator(kernel, RZ, fields=("sigmac", "pc"), n_blocks=2)
    acc.prepare()
    acc.accumulate(frame, contacts)
    table = acc.conclude()
    ring_areas = kernel.node_volumes(RZ, frame.box) / hz
    plane = (table["sigmac_zz"] * ring_areas).groupby(np.rint(table["z"] / hz).astype(int)).sum()
    interior = range(2, N - 3)
    at_contacts = np.array([plane[int(round(2 * (k + 1) * a / hz))] for k in interior])
    at_centres = np.array([plane[int(round((2 * k + 1) * a / hz))] for k in interior])
    # the branch quadrature (12 points on a line of 2.8 sigma) integrates the kernel's
    # z-marginal, which has kinks at |dz| = c, to ~1e-3 (measured 0.08-0.9e-3 with the
    # radial sum at hr = sigma / 11 to sigma / 23); 3e-3 covers both
    assert_allclose(at_contacts, above[list(interior)], rtol=3e-3)
    weight_at_centres = np.array([above[k] + 0.5 * m * g for k in interior])
    assert_allclose(at_centres, weight_at_centres, rtol=3e-3)
    # no shear and no radial stress on the axis of a vertical chain
    assert_allclose(table[["sigmac_rz", "sigmac_tz", "sigmac_rt"]].to_numpy(), 0.0, atol=1e-12 * above.max())


def test_contact_only_accumulator_needs_contacts_on_every_frame():
    frame, contacts = one_pair(np.array([0.05, 0.0, 0.0]))
    kernel = Gaussian.paper(1 / 128, (np.arange(0.0, 0.1, 1 / 256), np.arange(-0.03, 0.03, 1 / 256)))
    acc = FieldAccumulator(kernel, RZ, fields=("sigmac", "pc", "p"), n_blocks=2)
    acc.prepare()
    acc.accumulate(frame, contacts)
    assert acc.fields == ("sigmac", "pc", "p")  # p needs only the (zero) kinetic part besides
    with pytest.raises(ValueError, match="without contacts"):
        acc.accumulate(frame)
    # without contacts or per-atom stress the contact fields are omitted
    acc = FieldAccumulator(kernel, RZ, fields=("rho", "sigmac", "pc"), n_blocks=2)
    acc.prepare()
    acc.accumulate(frame)
    assert set(acc.omitted_fields) == {"sigmac", "pc"}


def test_branch_quadrature_weights_and_accuracy_off_the_axis():
    rng = np.random.default_rng(2)
    x_i, branch = rng.normal(size=(5, 3)), rng.normal(size=(5, 3))
    points, contact, weight = branch_quadrature(x_i, branch, 0.3)
    assert_allclose(np.bincount(contact, weight), 1.0, rtol=1e-14)  # exact volume integrals
    # points lie on the segments from x_i to x_j = x_i - r_ij
    s = np.einsum("pk,pk->p", x_i[contact] - points, branch[contact]) / np.sum(branch[contact] ** 2, axis=1)
    assert np.all((s > 0) & (s < 1))
    # a contact 10 sigma off the axis: the field against a 16x finer rule, within 2e-3 of
    # its maximum (measured 1e-3, see branch_quadrature)
    r_b = 1 / 64
    kernel = Gaussian.paper(r_b / 2, (np.arange(0.0, 0.25, r_b / 4), np.arange(-0.05, 0.05, r_b / 4)))
    x0, br = np.array([[10 * r_b, 0.0, 0.0]]), np.array([[0.012, 0.015, 0.021]])
    T = sym_outer(np.array([[1.0, -2.0, 3.0]]), br)
    import postproc.contacts as contacts_module

    def field(points_per_width):
        old = contacts_module.QUADRATURE_POINTS_PER_WIDTH
        contacts_module.QUADRATURE_POINTS_PER_WIDTH = points_per_width
        try:
            p, which, wq = branch_quadrature(x0, br, kernel.width)
        finally:
            contacts_module.QUADRATURE_POINTS_PER_WIDTH = old
        return kernel.deposit(RZ.map(p), wq[:, None] * RZ.local_tensors(p, T[which]), RZ, None)[0]

    reference, default = field(64.0), field(contacts_module.QUADRATURE_POINTS_PER_WIDTH)
    assert np.abs(default - reference).max() < 2e-3 * np.abs(reference).max()
