"""Bond order, layering and the channel plug's structure on configurations with known answers."""
import numpy as np
import pandas as pd
import pytest

from granflow.scenes.channel.analysis.plug import drift, plug_structure
from postproc.frame import ParticleFrame
from postproc.structure import Q6_FCC, bond_order, layering


def fcc(n: int, a: float = np.sqrt(2.0)) -> tuple[np.ndarray, np.ndarray]:
    """An n x n x n fcc block of cubic cell a (nearest neighbours at a/√2 = 1) and its periodic box."""
    basis = np.array([[0, 0, 0], [0.5, 0.5, 0], [0.5, 0, 0.5], [0, 0.5, 0.5]])
    cells = np.array([[i, j, k] for i in range(n) for j in range(n) for k in range(n)], dtype=float)
    pos = ((cells[:, None, :] + basis[None]) * a).reshape(-1, 3) + 0.1
    return pos, np.array([[0.0, n * a]] * 3)


def rotation(seed: int) -> np.ndarray:
    q, _ = np.linalg.qr(np.random.default_rng(seed).normal(size=(3, 3)))
    return q


def test_fcc_has_the_lattice_q6_and_every_particle_crystal_like():
    pos, box = fcc(4)
    bo = bond_order(pos, box, (True, True, True), cutoff=1.3)
    assert np.all(bo.n_neighbours == 12)
    assert np.allclose(bo.q, Q6_FCC, atol=2e-4)
    assert bo.crystal_like().all()


def test_q6_does_not_depend_on_the_lattice_orientation_or_on_walls():
    pos, box = fcc(6)
    centre = pos.mean(axis=0)
    turned = (pos - centre) @ rotation(3).T + 20.0
    wide = np.array([[0.0, 40.0]] * 3)
    bo = bond_order(turned, wide, (False, False, False), cutoff=1.3)
    inner = np.linalg.norm(turned - turned.mean(axis=0), axis=1) < 3.0
    assert inner.sum() > 20
    assert np.allclose(bo.q[inner], Q6_FCC, atol=2e-4)
    assert bo.crystal_like()[inner].all()


def test_random_points_are_not_crystal_like():
    rng = np.random.default_rng(1)
    L = 12.0
    pos = rng.uniform(0, L, size=(int(1.2 * L**3), 3))   # as many centres per volume as φ ≈ 0.63
    bo = bond_order(pos, np.array([[0.0, L]] * 3), (True, True, True), cutoff=1.3)
    assert bo.crystal_like().mean() < 0.02
    assert np.nanmean(bo.q) < 0.45


def test_the_global_q6_is_fccs_for_a_turned_lattice_and_small_without_common_order():
    pos, box = fcc(6)
    turned = (pos - pos.mean(axis=0)) @ rotation(5).T + 20.0
    bo = bond_order(turned, np.array([[0.0, 40.0]] * 3), (False, False, False), cutoff=1.3)
    inner = np.linalg.norm(turned - turned.mean(axis=0), axis=1) < 3.0
    assert bo.global_q(inner) == pytest.approx(Q6_FCC, abs=2e-4)        # every bond of the set shares the lattice
    rng = np.random.default_rng(2)
    L = 12.0
    pos = rng.uniform(0, L, size=(int(1.2 * L**3), 3))
    bo = bond_order(pos, np.array([[0.0, L]] * 3), (True, True, True), cutoff=1.3)
    n_bonds = len(bo.pairs)
    assert bo.global_q() < 5.0 / np.sqrt(n_bonds)                     # ~ 1/√N_b: no common orientation
    # each grain its own turned fcc: the local q6 stays the lattice's, the global Q6 falls
    grains = []
    for k in range(8):
        p, _ = fcc(3)
        grains.append((p - p.mean(axis=0)) @ rotation(10 + k).T + 12.0 * np.array([k % 2, (k // 2) % 2, k // 4]))
    pos = np.concatenate(grains) + 6.0
    bo = bond_order(pos, np.array([[0.0, 40.0]] * 3), (False, False, False), cutoff=1.3)
    assert bo.global_q() < 0.5 * Q6_FCC and np.nanmedian(bo.q) > 0.5
    assert np.isnan(bond_order(np.array([[0.0, 0, 0], [5.0, 0, 0]]), np.array([[-1.0, 9.0]] * 3),
                               (False,) * 3, 1.3).global_q())


def test_periodic_pairs_cross_the_boundary():
    pos = np.array([[0.2, 5.0, 5.0], [9.9, 5.0, 5.0]])
    box = np.array([[0.0, 10.0]] * 3)
    assert bond_order(pos, box, (True, False, False), 1.0).n_neighbours.tolist() == [1, 1]
    assert bond_order(pos, box, (False, False, False), 1.0).n_neighbours.tolist() == [0, 0]


def test_layering_finds_layers_and_not_noise():
    rng = np.random.default_rng(2)
    z = np.repeat(np.arange(5) + 0.5, 200) + rng.normal(0, 0.05, 1000)
    s, spacing = layering(z, 5.0, (0.8, 1.2))
    assert s > 0.9 and spacing == pytest.approx(1.0)
    s, _ = layering(rng.uniform(0, 5.0, 1000), 5.0, (0.8, 1.2))
    assert s < 4.0 / np.sqrt(1000)


def _frame(t: float, pos: np.ndarray, box: np.ndarray) -> ParticleFrame:
    n = len(pos)
    return ParticleFrame(timestep=int(t), box=box, position=pos.copy(), velocity=np.zeros((n, 3)),
                         mass=np.ones(n), radius=np.full(n, 0.5), id=np.arange(1, n + 1), time=t)


def _channel_plug(seed: int, W: float = 20.0, H: float = 12.0, B: float = 5.0):
    rng = np.random.default_rng(seed)
    n = 1500
    pos = np.column_stack([rng.uniform(0, W, n), rng.uniform(0, H, n), rng.uniform(0, B, n)])
    return pos, np.array([[0.0, W], [0.0, H], [0.0, B]])


def test_a_rigid_plug_sliding_through_the_periodic_cell_has_no_nonaffine_displacement():
    pos, box = _channel_plug(4)
    H = box[1, 1]
    frames = []
    for k in range(30):
        p = pos.copy()
        p[:, 1] = np.mod(p[:, 1] + 7.3 * k, H)   # 7.3 d_p per frame: more than half the height
        frames.append(_frame(2.0 * k, p, box))
    s = plug_structure(frames, W=20.0, plug_edge=6.0)
    assert s.summary["nonaffine_rms_plug"] < 1e-9
    assert s.summary["n_tracked"] > 300
    assert s.frames["t"].iloc[-1] == pytest.approx(58.0)


def test_a_diffusing_plug_gathers_the_random_walk_displacement():
    pos, box = _channel_plug(5)
    rng = np.random.default_rng(6)
    sigma, steps = 0.05, 40
    frames = [_frame(0.0, pos, box)]
    p = pos.copy()
    for k in range(1, steps + 1):
        p = p + rng.normal(0, sigma, p.shape)
        p[:, 1:] = np.mod(p[:, 1:], [box[1, 1], box[2, 1]])
        frames.append(_frame(float(k), p, box))
    rms = plug_structure(frames, W=20.0, plug_edge=6.0).summary["nonaffine_rms_plug"]
    assert rms == pytest.approx(sigma * np.sqrt(3 * steps), rel=0.1)


def test_no_plug_says_so():
    pos, box = _channel_plug(7)
    s = plug_structure([_frame(0.0, pos, box)], W=20.0, plug_edge=float("nan"))
    assert s.frames.empty and s.summary["why"] == "no plug"


def test_drift_of_a_straight_line_is_its_rise_over_the_window():
    t = np.arange(8) * 10.0 + 5.0
    blocks = pd.DataFrame({"t_mid": t, "ratio": 1.3 + 0.001 * t})
    d, se = drift(blocks)
    assert d == pytest.approx(0.07) and se == pytest.approx(0.0, abs=1e-9)
    rng = np.random.default_rng(8)
    flat = pd.DataFrame({"t_mid": t, "ratio": 1.3 + rng.normal(0, 0.01, len(t))})
    d, se = drift(flat)
    assert abs(d) < 3 * se


def test_a_sheared_plug_carried_by_its_mean_flow_has_no_nonaffine_displacement():
    pos, box = _channel_plug(9)
    H, W = box[1, 1], 20.0

    def u(x):  # a shear across the whole plug, faster than half the cell per frame in the middle
        v = np.zeros((len(x), 3))
        v[:, 1] = -(20.0 + 0.5 * np.minimum(x, W - x))
        return v

    frames, p = [], pos.copy()
    for k in range(25):
        frames.append(_frame(2.0 * k, p, box))
        p = p + u(p[:, 0]) * 2.0
        p[:, 1] = np.mod(p[:, 1], H)
    carried = plug_structure(frames, W=W, plug_edge=4.0, mean_velocity=u).summary["nonaffine_rms_plug"]
    rigid = plug_structure(frames, W=W, plug_edge=4.0).summary["nonaffine_rms_plug"]
    assert carried < 1e-9
    assert rigid > 1.0   # taking away only a rigid shift counts the shear as rearrangement


def test_the_plugs_global_q6_tells_a_crystal_plug_from_a_random_one():
    # a channel 20 d_p wide filled with an fcc lattice (periodic in y and z: 20 x 8√2·... cells fit exactly)
    a = np.sqrt(2.0)
    pos, _ = fcc(8, a)                                   # 8 cells of a = √2: 11.3 d_p per side
    box = np.array([[0.0, 8 * a]] * 3)
    W = float(box[0, 1])
    crystal = plug_structure([_frame(0.0, pos, box)], W=W, plug_edge=2.0).summary
    assert crystal["Q6_plug"] == pytest.approx(0.5745, abs=2e-3)
    assert crystal["Q6_plug_cut1.2"] == pytest.approx(0.5745, abs=2e-3)
    rpos, rbox = _channel_plug(9)
    frames = [_frame(float(k), rpos + 0.0, rbox) for k in range(3)]
    loose = plug_structure(frames, W=20.0, plug_edge=6.0).summary
    assert loose["Q6_plug"] < 0.1 and loose["Q6_plug_se"] == pytest.approx(0.0, abs=1e-12)
