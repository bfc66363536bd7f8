"""Standard errors of time-averaged fields allow for autocorrelation (postproc.blocks, postproc.fields)."""
import numpy as np
import pytest
from numpy.testing import assert_allclose

from postproc.autocorr import combined_error, statistical_inefficiency, weighted_mean_error
from postproc.autocorr import statistical_inefficiencies
from postproc.blocks import correlated_errors
from postproc.coordinates import XCoordinates
from postproc.fields import FieldAccumulator
from postproc.frame import ParticleFrame
from postproc.kernels import HeavisideBins

L = 2.0  # cubic box, one bin spanning it
LATTICE = np.stack(np.meshgrid(*[[0.5, 1.5]] * 3, indexing="ij"), axis=-1).reshape(-1, 3)  # 8 particles


def ar1(rng, n, a):
    """Stationary AR(1) series with unit innovations: mean 0, g = (1 + a) / (1 - a)."""
    e = rng.normal(size=n)
    x = np.empty(n)
    x[0] = e[0] / np.sqrt(1 - a**2)
    for i in range(1, n):
        x[i] = a * x[i - 1] + e[i]
    return x


def lattice_fields(vx, noise=None):
    """Fields of one bin over frames in which every lattice particle moves with ``vx[t]`` (+ its own noise)."""
    box = np.array([[0.0, L]] * 3)
    n = len(LATTICE)
    acc = FieldAccumulator(HeavisideBins([np.array([0.0, L])]), XCoordinates(walls=(0.0, L)), fields=("rho", "u"))
    acc.prepare()
    for t, v in enumerate(vx):
        velocity = np.zeros((n, 3))
        velocity[:, 0] = v + (0.0 if noise is None else noise[t])
        acc.accumulate(ParticleFrame(t, box, LATTICE, velocity, np.ones(n), np.full(n, 0.25)))
    return acc.conclude(), acc.block_errors


def test_batched_inefficiency_is_emcee_per_column():
    rng = np.random.default_rng(1)
    y = np.column_stack([ar1(rng, 100, a) for a in (0.0, 0.5, 0.9, 0.99)] + [np.full(100, 3.0)])
    ref = [statistical_inefficiency(col) for col in y.T]
    # one emcee call over all columns gives each column's own estimate
    assert_allclose(statistical_inefficiencies(y), ref, rtol=1e-12)


def test_correlated_errors_match_per_node_rule_with_nan_sub_blocks():
    rng = np.random.default_rng(2)
    y = np.column_stack([ar1(rng, 60, a) for a in (0.0, 0.3, 0.8, 0.95, 0.6, 0.2)])
    counts = np.full(60, 4.0)
    counts[-1] = 3.0  # a partial last sub-block
    block = np.array([0.05, 0.1, np.nan, 2.0, 0.1, 0.1])
    y[[5, 17], 4] = np.nan  # node held no mass in two sub-blocks
    y[3:, 5] = np.nan  # too few finite sub-blocks: the block error
    ref = [combined_error(weighted_mean_error(col * counts, counts), b)[0] for col, b in zip(y.T, block)]
    assert_allclose(correlated_errors(y, counts, block), ref, rtol=1e-10)
    assert correlated_errors(y, counts, block)[5] == block[5]


def test_correlated_frames_give_errors_that_cover_the_mean():
    rng = np.random.default_rng(3)
    a, n_frames, replicas = 0.95, 400, 100  # g = 39 frames: ~10 independent values per run
    z, floored = [], []
    for _ in range(replicas):
        table, blocks = lattice_fields(ar1(rng, n_frames, a))
        se, se_block = table["u_x_se"].iloc[0], blocks["u_x_se"].iloc[0]
        floored.append(se >= se_block)
        z.append(abs(table["u_x"].iloc[0]) / se)
    # 100 sub-blocks of 4 frames, true g ~ 10 sub-blocks: not reliable (n < 50 g), so the
    # block error is a floor, except where emcee's estimate of g from ~10 correlation times
    # comes out below n/50 = 2 and passes as reliable (5 % of 1000 replicas measured)
    assert np.mean(floored) >= 0.9
    # 2 se covers 95 % when se is right; estimates from ~10 correlation times are biased
    # low: over 2000 replicas 2 se covered 84 % (the block error alone 84 %). 100 replicas
    # scatter by ±3.7 %, so 0.75 is 2.4 sigma below what the rule gives
    assert np.mean(np.array(z) < 2) >= 0.75


def test_uncorrelated_frames_keep_the_block_error():
    rng = np.random.default_rng(4)
    ratios = []
    for _ in range(10):
        table, blocks = lattice_fields(rng.normal(size=256))
        ratios.append(table["u_x_se"].iloc[0] / blocks["u_x_se"].iloc[0])
    # g ~ 1: both estimate sigma / sqrt(256); the block error has 7 degrees of freedom
    # (±27 % each), so the median of 10 ratios lies well within a factor 1.5
    assert 1 / 1.5 < np.median(ratios) < 1.5


def test_constant_field_has_zero_error():
    table, blocks = lattice_fields(np.full(300, 1.5))
    # every sub-block gives the same value up to round-off of sums of O(1) numbers
    assert_allclose(table[["rho_se", "u_x_se", "u_y_se", "u_z_se"]].to_numpy(), 0.0, atol=1e-12)
    assert_allclose(blocks["u_x_se"], 0.0, atol=1e-12)
    assert_allclose(table["u_x"], 1.5, rtol=1e-12)


def test_block_errors_read_before_conclude_raise():
    acc = FieldAccumulator(HeavisideBins([np.array([0.0, L])]), XCoordinates(walls=(0.0, L)))
    with pytest.raises(RuntimeError, match=r"block_errors read before conclude\(\)"):
        acc.block_errors
