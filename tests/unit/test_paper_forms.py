"""Scaling claims tested in the papers' own form, across runs: the silo's v_c² linear in R, the heap's q* exponent across feed rates."""
import math

import numpy as np
import pandas as pd
import pytest

from granflow.scenes.silo.linearity import GRAVITY, linearity_checks
from granflow.scenes.silo.analysis import scaling_exponent

R_B = 0.015625
R = np.array([6.0, 7.5, 9.0, 10.5, 12.0])


def sweep(v, se=0.003):
    return pd.DataFrame({"R_over_rb": R, "v_c_plane": v, "v_c_plane_se": np.full(len(R), se), "D": 2 * R * R_B})


def test_beverloo_law_is_straight_and_its_offset_recovered():
    gamma, r0 = 1.4, 2.4
    v = np.sqrt(2 * gamma * GRAVITY * (R - r0) * R_B)
    kappa, offset = linearity_checks(sweep(v))
    assert kappa.ours == pytest.approx(0.0, abs=1e-9) and kappa.kind == "comparison"
    assert kappa.verdict in ("equal", "within error (0.0 σ)")
    assert offset.ours == pytest.approx(r0, rel=1e-9) and offset.kind == "diagnostic"
    assert "γ = c1/(2g r_b) = 1.4 " in kappa.note
    # the same data read as a pure power law: far from 1/2, the reason the power law carries no verdict
    assert 0.58 < scaling_exponent(R, v, np.full(len(R), 0.003))["exponent"] < 0.72   # 0.70 here


def test_a_curved_v_squared_is_seen():
    # v ∝ R^0.8: v² ∝ R^1.6, convex: positive curvature well beyond its error
    v = 0.3 * R ** 0.8
    kappa, _ = linearity_checks(sweep(v, se=0.002))
    assert kappa.ours > 0.1 and kappa.ours > 5 * kappa.error
    assert kappa.verdict.startswith("one sample: off by")


def test_too_few_orifices_say_so():
    kappa, offset = linearity_checks(sweep(np.sqrt(R))[:3])
    assert math.isnan(kappa.ours) and "needs 4 orifices" in kappa.note
    assert linearity_checks(None)[0].verdict == "not measured"


# -- the heap's q* exponent across feed rates (the same idea: the paper's form, across runs) ---------
from granflow.scenes.heap.qstar import across_feed_rates, feed_rate_of  # noqa: E402


def _streamwise(rates, a=0.22, thinning=-0.8, noise=0.0, seed=0):
    """δ/d̄ = e^{c_j} q*^a at bins x/L; q* falls along the heap and δ thins toward the end (c_j)."""
    rng = np.random.default_rng(seed)
    rows = []
    for rate in rates:
        for x in np.round(np.arange(0.02, 1.0, 0.04), 2):
            q = rate * (1.0 - x) * 0.15
            c = thinning * x
            rows.append({"case": f"mix~bi1-2/mdot~{rate:g}", "x_over_L": x, "q_star": q, "d_bar": 1.2e-3,
                         "delta": 1.2e-3 * math.exp(c + rng.normal(0, noise)) * q ** a, "usable": True})
    return pd.DataFrame(rows)


def test_qstar_across_feed_rates_recovers_the_exponent_not_the_thinning():
    (check,) = across_feed_rates(_streamwise([10, 33, 120]))
    assert check.ours == pytest.approx(0.22, abs=1e-9) and check.kind == "comparison"
    assert check.verdict.startswith(("within", "equal", "one sample"))
    # pooled over x inside the cases the thinning would be read as part of the exponent
    df = _streamwise([10, 33, 120])
    df = df[df["x_over_L"] >= 0.2]
    naive = np.polyfit(np.log(df["q_star"]), np.log(df["delta"] / df["d_bar"]), 1)[0]
    assert naive > 0.3


def test_qstar_two_close_rates_are_a_diagnostic():
    (check,) = across_feed_rates(_streamwise([20, 33], noise=0.03))
    assert check.kind == "diagnostic" and "no verdict" in check.verdict and "span 1.6x" in check.note
    assert feed_rate_of("mix~bi1-2/mdot~33") == 33.0 and math.isnan(feed_rate_of("R~6"))


def test_feed_rates_meet_at_the_same_x_over_L_whatever_digits_each_side_keeps():
    # the record keeps its profiles at 6 digits, a run gives every digit: a case of each must meet at every bin
    from granflow.schema import PROJECT_ROOT
    from granflow.scenes.heap.profile_checks import feed_rate_checks

    where = PROJECT_ROOT / "validation" / "heap" / "profiles"
    sw, col = pd.read_csv(where / "streamwise.csv"), pd.read_csv(where / "collapse.csv")
    low = sw["case"] == sorted(sw["case"].unique(), key=feed_rate_of)[0]
    digits = sw.assign(x_over_L=np.where(low, sw["x_over_L"] + 3e-7, sw["x_over_L"]))   # beyond the 6th digit
    kept, run = feed_rate_checks(sw, col), feed_rate_checks(digits, col)
    assert [c.quantity for c in run] == [c.quantity for c in kept] and len(run) == 3
    for a, b in zip(kept, run):
        assert math.isfinite(a.ours) and b.ours == pytest.approx(a.ours, rel=1e-9) and b.note == a.note


def test_feed_rates_whose_bins_lie_apart_are_read_at_the_wider_bins():
    # a wider feed zone gives the higher rate a shorter flowing length: its bins lie at other x/L. δ linear in x/L
    # and 1.3× at the higher rate: read at the wider bins (the other's linear between neighbours) every shared
    # bin gives 1.3, and so does the other grid (the syst variant)
    from granflow.scenes.heap.profile_checks import feed_rate_checks

    def case(rate, xs, scale):
        return pd.DataFrame({"case": f"mix~bi1-2/mdot~{rate:g}", "x_over_L": xs, "x": 0.2 * xs, "q": 1e-3 * (1 - xs),
                             "u_s": 0.2 * (1 - xs), "delta": scale * 4e-3 * (1.5 - xs), "usable": True})

    fine, wide = np.arange(0.01, 1.0, 0.0189), np.arange(0.012, 1.0, 0.0244)
    sw = pd.concat([case(10, fine, 1.0), case(120, wide, 1.3)], ignore_index=True)
    col = pd.DataFrame(columns=["case", "x", "zt", "ut", "wt"])
    delta, _, us = feed_rate_checks(sw, col)
    assert delta.ours == pytest.approx(1.3, rel=1e-9) and delta.error == pytest.approx(0.0, abs=1e-9)
    assert "different x/L" in delta.note and "read at 10 g/s's x/L bins: 1.3" in delta.variants
    n_wide = int(np.sum((wide >= 0.2 - 1e-9) & (wide <= 0.9 + 1e-9)))
    assert f"mean over the {n_wide} x/L bins" in delta.note
    assert us.ours == pytest.approx(1.3, rel=1e-9)   # u_s and q alike at both rates: only δ differs
