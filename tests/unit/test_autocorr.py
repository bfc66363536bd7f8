"""Errors of time averages that allow for autocorrelation (postproc.autocorr) and their two users:
the headline errors of the cost study (granflow.headline) and the steady rate (postproc.series)."""
import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy.signal import lfilter

from granflow import headline, registry
from postproc.autocorr import combined_error, mean_error, statistical_inefficiency, weighted_mean_error
from postproc.series import cumulative_rate, steady_rate, steady_rate_errors


def ar1(rng, a: float, shape, burn: int = 2000) -> np.ndarray:
    """Stationary AR(1) series x_k = a x_{k-1} + e_k (unit innovations) along the last axis.

    Its statistical inefficiency is g = (1 + a)/(1 - a) and its variance 1/(1 - a^2); the first
    ``burn`` samples (> 20 correlation times for a <= 0.99) are dropped so it starts stationary.
    """
    shape = (shape,) if np.isscalar(shape) else tuple(shape)
    e = rng.standard_normal(shape[:-1] + (shape[-1] + burn,))
    return lfilter([1.0], [1.0, -a], e, axis=-1)[..., burn:]


# --------------------------------------------------------------------------- statistical inefficiency
@pytest.mark.parametrize("a", [0.5, 0.9])
def test_ar1_statistical_inefficiency_matches_theory(a):
    # Sokal: var(g_hat) ~ 2 (2M + 1)/n g^2 with the window M ~ 5 g; for a = 0.9 (g = 19) and
    # n = 1e5 that is a 6 % standard deviation, so 15 % is 2.5 sigma
    x = ar1(np.random.default_rng(3), a, 100_000)
    assert statistical_inefficiency(x) == pytest.approx((1 + a) / (1 - a), rel=0.15)


def test_white_noise_has_unit_statistical_inefficiency():
    # clipped at 1 from below; the estimate of 1 + 2 sum rho_k over a window of ~5 lags scatters
    # by ~sqrt(2 * 11 / 2e4) = 3 %, so 1.3 is far above it
    g = statistical_inefficiency(np.random.default_rng(4).standard_normal(20_000))
    assert 1.0 <= g <= 1.3


def test_constant_short_and_non_finite_series():
    assert statistical_inefficiency(np.full(50, 2.5)) == 1.0
    e = mean_error(np.full(50, 2.5))
    assert e.g == 1.0 and e.se == 0.0 and e.mean == 2.5 and e.n == 50
    assert np.isnan(statistical_inefficiency([1.0, 2.0, 3.0]))
    e = mean_error([1.0, 2.0, np.nan, 3.0])  # three finite values: no g, so no error
    assert np.isnan(e.se) and np.isnan(e.g) and e.n == 3 and e.mean == 2.0 and not e.reliable
    # non-finite values are dropped, nothing else changes
    x = ar1(np.random.default_rng(5), 0.5, 500)
    y = np.insert(x, [10, 200], [np.nan, np.inf])
    assert mean_error(y) == mean_error(x)
    with pytest.raises(ValueError, match="1-D"):
        statistical_inefficiency(np.ones((10, 2)))


def test_mean_error_formula_and_reliability():
    x = ar1(np.random.default_rng(6), 0.9, 2000)
    e = mean_error(x)
    assert_allclose(e.se_naive, np.std(x, ddof=1) / np.sqrt(len(x)), rtol=1e-12)
    assert_allclose(e.se, e.se_naive * np.sqrt(e.g), rtol=1e-12)  # var of the mean = g sigma^2 / n
    assert_allclose(e.n_eff, len(x) / e.g, rtol=1e-12)
    assert e.reliable == (len(x) >= 50 * e.g)
    assert not mean_error(x[:300]).reliable  # 300 < 50 * 19


def test_correlation_aware_error_covers_the_mean_and_the_naive_error_does_not():
    """400 independent AR(1) series (a = 0.9, g = 19, n = 2000, true mean 0).

    A 2-sigma interval covers 95.4 % of the means if se is right; 400 replicas measure that to
    +-1.1 % (binomial sd), and the scatter of g_hat (+-40 % at n = 100 g, Sokal) widens the
    tails to about 93 % (0.92-0.955 over ten seeds).  The uncorrelated error is sqrt(19) too
    small: 2 se_naive = 0.46 sigma of the mean, which covers 35 %.
    """
    x = ar1(np.random.default_rng(7), 0.9, (400, 2000))
    errs = [mean_error(row) for row in x]
    mean = np.array([e.mean for e in errs])
    se = np.array([e.se for e in errs])
    se_naive = np.array([e.se_naive for e in errs])
    assert 0.90 <= np.mean(np.abs(mean) < 2 * se) <= 0.99
    assert np.mean(np.abs(mean) < 2 * se_naive) < 0.6
    assert np.median([e.g for e in errs]) == pytest.approx(19.0, rel=0.15)


def test_weighted_mean_error_of_sub_block_sums():
    rng = np.random.default_rng(8)
    # equal counts: exactly mean_error of the sub-block means
    y = ar1(rng, 0.7, 300)
    w, e = weighted_mean_error(5 * y, np.full(300, 5)), mean_error(y)
    assert_allclose([w.mean, w.se, w.g, w.se_naive], [e.mean, e.se, e.g, e.se_naive], rtol=1e-9)
    assert (w.n, w.reliable) == (e.n, e.reliable)
    # frames of an AR(1) series (g = 199 frames) kept as sums of sub-blocks of 10-30 frames: the
    # mean is the frame mean, and the error agrees with the one from the frames themselves
    # (each estimate of g scatters by ~10 % at n = 2e5 frames, 1000 g)
    frames = ar1(rng, 0.99, 200_000)
    counts = rng.integers(10, 31, size=20_000)
    counts = counts[np.cumsum(counts) <= len(frames)]
    edges = np.r_[0, np.cumsum(counts)]
    frames = frames[:edges[-1]]
    sums = np.add.reduceat(frames, edges[:-1])
    w, f = weighted_mean_error(sums, counts), mean_error(frames)
    assert_allclose(w.mean, frames.mean(), rtol=1e-10)
    assert w.se == pytest.approx(f.se, rel=0.25)
    assert w.g > 3 and w.se_naive < 0.6 * w.se  # the sub-block means are themselves correlated
    # empty sub-blocks are dropped
    assert weighted_mean_error(np.r_[sums, 0.0], np.r_[counts, 0]) == w


# --------------------------------------------------------------------------- headline errors
class FakeScene:
    """A scene whose headline observable is the time average of a known correlated signal.

    The signal is an AR(1) series at K samples over the window
    [0, K dt]; ``observables`` averages it over ``block`` (or the whole window), or gives NaN
    for blocks shorter than ``shortest`` (as a scene's analysis does for too few frames).
    """

    headline = [("u", "mean velocity"), ("c", "a constant")]

    def __init__(self, signal, dt, shortest=0.0):
        self.signal, self.dt, self.shortest = signal, dt, shortest
        self.t = (np.arange(len(signal)) + 0.5) * dt
        self.calls = 0

    def observables(self, case_dir, record, t_average, block=None):
        self.calls += 1
        lo, hi = block or (0.0, len(self.signal) * self.dt)
        if hi - lo < self.shortest:
            return {"u": float("nan"), "c": float("nan")}, (lo, hi)
        sel = (self.t >= lo) & (self.t < hi)
        return {"u": float(self.signal[sel].mean()), "c": 3.0}, (lo, hi)


def test_headline_error_uses_the_statistical_inefficiency_of_the_sub_windows(monkeypatch, tmp_path):
    a, K, dt, n_series = 0.98, 40_000, 0.01, 800
    scene = FakeScene(ar1(np.random.default_rng(9), a, K), dt)
    monkeypatch.setattr(registry, "get", lambda name: scene)
    out = headline.measure_with_errors("fake", tmp_path, {}, t_average=K * dt, n_blocks=4, n_series=n_series)
    assert scene.calls == 1 + 4 + n_series and out["window"] == [0.0, K * dt]
    u = out["u"]
    assert u["se_method"] == "autocorrelation" and u["n_series"] == n_series and u["n_blocks"] == 4
    assert_allclose(u["x"], scene.signal.mean(), rtol=1e-12)
    # se is mean_error of the sub-window means, g included
    sub = scene.signal.reshape(n_series, -1).mean(axis=1)
    e = mean_error(sub)
    assert_allclose([u["se"], u["g"]], [e.se, e.g], rtol=1e-12)
    # sub-windows of 50 samples against a correlation time of 99: the means of neighbours are
    # correlated, g = 2.70 in theory (the sum of their exact correlations); estimated 1.7-2.9
    # over 20 seeds (biased low: the estimate of the autocorrelation is, on 800 values)
    assert 1.5 < u["g"] < 4.0 and u["se"] > 1.2 * e.se_naive
    # and se is the standard deviation of the mean of the signal: var = g_x sigma_x^2 / K with
    # g_x = 99 and sigma_x^2 = 1/(1 - a^2); se / that = 0.80-1.29 over 20 seeds
    true_sd = np.sqrt((1 + a) / (1 - a) / (1 - a * a) / K)
    assert u["se"] == pytest.approx(true_sd, rel=0.3)
    # the block error of 4 blocks is the cross-check
    blocks = scene.signal.reshape(4, -1).mean(axis=1)
    assert_allclose(u["se_block"], np.std(blocks, ddof=1) / 2, rtol=1e-12)
    c = out["c"]
    assert c["se"] == 0.0 and c["g"] == 1.0 and c["label"] == "a constant"


def test_headline_error_falls_back_to_blocks_when_sub_windows_are_too_short(monkeypatch, tmp_path):
    scene = FakeScene(ar1(np.random.default_rng(10), 0.5, 4000), 0.01, shortest=5.0)
    monkeypatch.setattr(registry, "get", lambda name: scene)
    out = headline.measure_with_errors("fake", tmp_path, {}, t_average=40.0, n_blocks=4, n_series=16)
    u = out["u"]  # 2.5 s sub-windows give NaN, 10 s blocks do not
    assert u["se_method"] == "block" and u["n_series"] == 0 and np.isnan(u["g"]) and not u["reliable"]
    assert u["se"] == u["se_block"] and np.isfinite(u["se"]) and u["n_blocks"] == 4


# --------------------------------------------------------------------------- steady rate
def correlated_counter(rng, W0=2.0, dt=0.01, n=10_000, a=0.99, amplitude=0.5):
    """A cumulative series whose rate is W0 plus AR(1) noise (a = 0.99: g = 199 samples, 2 s)."""
    u = ar1(rng, a, n) * np.sqrt(1 - a * a) * amplitude
    t = np.arange(n) * dt
    return t, np.cumsum((W0 + u) * dt)


def test_steady_rate_error_covers_a_rate_with_correlated_noise():
    """Rate noise correlated over 2 s, 64 sub-windows of 1.56 s: neighbouring slopes are correlated.

    Over 200 replicas a 2-sigma interval of se covers the true rate 88 % of the time (below 95 %:
    g of 64 slopes, n_eff ~ 40, is estimated short of its window), while the error of a counting
    process (independent increments, cumulative_rate) covers 10 %.  Limits: 4 binomial sd.
    """
    z, z_counting, ratio = [], [], []
    for seed in range(200):
        t, m = correlated_counter(np.random.default_rng(seed))
        r = steady_rate_errors(t, m, t[0], t[-1], n_series=64)
        W, W_se = cumulative_rate(t, m)
        z.append((r["rate"] - 2.0) / r["se"])
        z_counting.append((W - 2.0) / W_se)
        ratio.append(r["se"] / r["se_naive"])
    assert np.mean(np.abs(z) < 2) >= 0.80
    assert np.mean(np.abs(z_counting) < 2) < 0.3
    assert np.mean(ratio) > 1.1  # g > 1: the slopes of neighbouring sub-windows are correlated
    # one fixed series: the error covers the true rate and exceeds the uncorrelated one
    t, m = correlated_counter(np.random.default_rng(11))
    r = steady_rate_errors(t, m, t[0], t[-1], n_series=64)
    assert abs(r["rate"] - 2.0) < 2 * r["se"] and r["se"] > r["se_naive"]
    # 64 slopes do not make g reliable (n < 50 g): the error is the larger of the two
    assert r["se_method"] == "max(autocorrelation, block)" and r["se"] >= r["se_block"]


def test_combined_error_trusts_g_only_when_the_series_resolves_it():
    rng = np.random.default_rng(5)
    long = mean_error(ar1(rng, 0.5, 20_000))          # g = 3, n = 20000 >= 150: reliable
    assert long.reliable and combined_error(long, long.se) == (long.se, "autocorrelation")
    # blocks implying a far larger inefficiency (g_b = 400 x 3 = 1200, 50 g_b > n) overrule it
    assert combined_error(long, 20 * long.se) == (20 * long.se, "max(autocorrelation, block)")
    short = mean_error(ar1(rng, 0.5, 40))             # 40 < 50 g: not reliable
    assert not short.reliable
    assert combined_error(short, 10 * short.se) == (10 * short.se, "max(autocorrelation, block)")
    assert combined_error(short, 0.1 * short.se) == (short.se, "max(autocorrelation, block)")
    too_few = mean_error([1.0, 2.0, 3.0])
    assert combined_error(too_few, 0.7) == (0.7, "block")


def test_steady_rate_keeps_its_callers_and_its_block_error():
    t, m = correlated_counter(np.random.default_rng(12), n=2000)
    r = steady_rate_errors(t, m, 1.0, 15.0, n_blocks=4, n_series=16)
    assert steady_rate(t, m, 1.0, 15.0) == (r["rate"], r["se"])
    # the block error is the former one: std of the 4 block slopes / 2
    edges = np.linspace(1.0, 15.0, 5)
    slopes = [np.polyfit(t[(t >= lo) & (t <= hi)], m[(t >= lo) & (t <= hi)], 1)[0]
              for lo, hi in zip(edges[:-1], edges[1:])]
    assert_allclose(r["se_block"], np.std(slopes, ddof=1) / 2, rtol=1e-9)
    assert r["n"] == 16 and r["n_blocks"] == 4
    assert steady_rate(t, m, 1.0, 15.0, n_series=0) == (r["rate"], r["se_block"])  # the former error
    # 9 samples: 3 sub-windows of 3, too few for g, so the block error is the error
    r = steady_rate_errors(t, m, t[100], t[108])
    assert r["se_method"] == "block" and r["se"] == r["se_block"] and r["n_blocks"] == 3
