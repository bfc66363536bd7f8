"""Known-answer tests of the heap's profile checks (granflow.scenes.heap.profile_checks).

A synthetic heap built as the paper describes it (Fan et al. 2013, §3.2-3.3): u(x, z) = u(0, z)(1 − x/L)
with an exponential u(0, z) ∝ e^{k z/δ} (k = 2.3) and a constant δ, so q and u_s fall linearly to 0 at
x = L, u/u_s collapses on z/δ at every x, and w/v_r' follows eq. 3.6 exactly; a surface that is a plane.
Each check must then read the paper's value; one heap that breaks a law must fail its check.
"""
from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from granflow.scenes.heap.analysis import normal_velocity_exponential
from granflow.scenes.heap.profile_checks import (
    curvature,
    end_over_start,
    line_zero,
    profile_checks,
    relative_slope,
)

K = 2.3
L = 0.11
X_OVER_L = np.round(np.arange(0.02, 1.0, 0.04), 2)
ZT = np.arange(-2.95, 0.0, 0.1)   # bin centres in z/δ down to the record's −3


def heap(rate: float, *, delta=lambda s: 7e-3 + 0 * s, u_s0=0.2, creep=0.002, w_offset=0.0, us_power=1.0):
    """streamwise, collapse and surface profiles of one case at ``rate`` g/s (the docstring's heap).

    ``us_power`` ≠ 1 makes u_s ∝ (1 − x/L)^p (not linear); ``w_offset`` shifts w/v_r' off eq. 3.6.
    The tail below z = −δ is ``creep`` u_s (a creeping bed under a layer ending where u = 0.1 u_s is
    replaced by a constant to know the deep answer exactly).
    """
    case = f"mix~bi1-2/mdot~{rate:g}"
    scale = rate / 20.0
    sw, col = [], []
    for s in X_OVER_L:
        d = float(delta(s)) * scale ** 0.25
        u_s = u_s0 * scale ** 0.75 * (1 - s) ** us_power
        q0 = u_s0 * scale ** 0.75 * d * (1 - math.exp(-K)) / K
        q = q0 * (1 - s)
        gamma = 0.9 * u_s / d
        sw.append({"case": case, "x": s * L, "x_over_L": s, "q": q, "u_s": u_s, "gamma_bar": gamma, "delta": d,
                   "delta_exp": d * 1.02, "delta_lin": d * 0.97, "delta_cut": d,
                   "delta_eq31": d, "d_bar": 1.2e-3, "q_star": q / (1.2e-3 * math.sqrt(9.81 * 1.2e-3)),
                   "usable": True, "c_s": 0.4})
        for zt in ZT:
            ut = math.exp(K * zt) if zt >= -1 else creep
            col.append({"case": case, "x": s * L, "zt": zt, "ut": ut,
                        "wt": float(normal_velocity_exponential(zt, K)) + w_offset if zt >= -1 else -1.0})
    x_lab = np.linspace(0.0022, 0.1178, 27)
    z = 0.08 - 0.45 * x_lab
    surf = pd.DataFrame({"case": case, "x_lab": x_lab, "z_s_mean": z, "z_s_std": 4e-4, "z_s_fit": z,
                         "in_fit": (x_lab > 0.024) & (x_lab < 0.115)})
    return pd.DataFrame(sw), pd.DataFrame(col), surf


def profiles(*cases):
    return {"streamwise": pd.concat([c[0] for c in cases]), "collapse": pd.concat([c[1] for c in cases]),
            "surface_at_window_start": pd.concat([c[2] for c in cases])}


def by_quantity(checks, start, case="mix~bi1-2/mdot~20"):
    got = [c for c in checks if c.quantity.startswith(start) and c.case in (case, "sweep")]
    assert got, start
    return got[0]


@pytest.fixture(scope="module")
def paper_heap():
    # δ grows with the feed rate (as δ ∝ rate^0.25) and u_s δ/q_0 does not change: the paper's heap
    return profile_checks(profiles(heap(20), heap(33)))


def test_the_fits_read_known_lines():
    s = np.linspace(0.2, 0.9, 18)
    assert line_zero(s, 3 * (1 - s))[0] == pytest.approx(1.0, abs=1e-12)
    assert curvature(s, 3 * (1 - s))[0] == pytest.approx(0.0, abs=1e-12)
    # y = (1 − s)²: slope −2(1 − s) goes from −1.6 to −0.2 across the range, −0.9 in its middle: κ = −1.4/0.9
    assert curvature(s, (1 - s) ** 2)[0] == pytest.approx(-1.4 / 0.9, rel=1e-9)
    assert end_over_start(s, 2 - s)[0] == pytest.approx(0.5, rel=1e-12)
    assert relative_slope(s, 2 - s)[0] == pytest.approx(-1 / (2 - s.mean()), rel=1e-12)


@pytest.mark.parametrize("start, expected", [
    ("q(x): zero", 1.0), ("q(x): relative curvature", 0.0), ("u_s(x): relative curvature", 0.0),
    ("γ̄(x): its straight line", float("nan")), ("δ/δ_3.1", 1.0), ("u_s δ/(2 q_0): zero", 1.0),
    ("γ̄ δ/u_s", 0.9), ("u/u_s on z/δ: relative slope", 0.0), ("u/u_s below the layer", 0.002),
    ("w/v_r' − eq. 3.6", 0.0),
    # the bottom window −1.1 ≤ z/δ ≤ −0.9 holds the bins at −1.05 (the bed, −1) and −0.95 (eq. 3.6)
    ("w/v_r' at the bottom", 0.5 * (-1.0 + float(normal_velocity_exponential(-0.95, K)))),
    ("free surface from the plane", 0.0), ("free surface from one straight line", 0.0),
    ("δ at the higher feed rate", (33 / 20) ** 0.25), ("u/u_s on z/δ across feed rates", 1.0),
    # u_s ∝ rate^0.75, δ ∝ rate^0.25, q_0 ∝ u_s δ: u_s δ/q_0 is the same at both rates
    ("u_s δ/(2 q_0) across feed rates", 1.0),
])
def test_the_paper_heap_reads_its_known_values(paper_heap, start, expected):
    c = by_quantity(paper_heap, start)
    if math.isnan(expected):
        return
    # exact synthetic data: only round-off; the w rows interpolate nothing (eq. 3.6 at the bins' centres)
    assert c.ours == pytest.approx(expected, rel=1e-6, abs=1e-9), (c.quantity, c.ours)


def test_the_kinds_are_right(paper_heap):
    assert all(c.kind == "comparison" for c in paper_heap if not c.quantity.startswith(("γ̄ δ/u_s", "δ/d̄ ∝")))
    assert by_quantity(paper_heap, "γ̄ δ/u_s").kind == "consistency"
    assert by_quantity(paper_heap, "δ/d̄ ∝ q*^a across").kind == "diagnostic"   # two feed rates: 1.65x


def test_a_linear_heap_keeps_its_shear_rate(paper_heap):
    # constant δ and u_s ∝ (1 − x/L): γ̄ = 0.9 u_s/δ falls exactly to 0 at the end wall
    assert by_quantity(paper_heap, "γ̄(x)").ours == pytest.approx(0.0, abs=1e-9)
    # the creep speed is creep × u_s in mm/s: known, the mean of 0.002 u_s(x) over the bins
    sw = heap(20)[0]
    inside = sw[(sw["x_over_L"] >= 0.2) & (sw["x_over_L"] <= 0.9)]
    assert by_quantity(paper_heap, "u below").ours == pytest.approx(1e3 * 0.002 * inside["u_s"].mean(), rel=1e-9)


def test_a_heap_that_breaks_the_laws_fails():
    # u_s ∝ (1 − x/L)² (curved), w off eq. 3.6 by 0.2, δ thinning fastest at the feed (as √(x/L): no steeper end),
    # a surface with a 3 mm bump and a deep tail at 0.05 u_s: each check must see it
    bad = heap(20, us_power=2.0, w_offset=0.2, creep=0.05, delta=lambda s: 8e-3 * (1 - 0.5 * np.sqrt(s)))
    bad[2].loc[12, "z_s_mean"] += 3e-3
    noise = np.random.default_rng(3).normal(0, 1e-3, len(bad[0]))   # a little scatter: finite errors
    bad[0]["u_s"] *= 1 + noise
    checks = profile_checks(profiles(bad))
    kappa = by_quantity(checks, "u_s(x): relative curvature")
    assert kappa.ours < -1.0 and "off by" in kappa.verdict
    assert "off by" in by_quantity(checks, "w/v_r' − eq. 3.6").verdict
    assert by_quantity(checks, "u/u_s below the layer").verdict.startswith("one sample: off by")
    assert by_quantity(checks, "free surface from the plane").ours == pytest.approx(3.0, rel=1e-6)
    assert by_quantity(checks, "free surface from the plane").verdict.startswith("one sample: off by")
    # the ratio of the two least-squares slopes of 8 mm (1 − ½√s), computed here on the same bins
    def fitted_slope(lo, hi):
        s = X_OVER_L[(X_OVER_L >= lo - 1e-9) & (X_OVER_L <= hi + 1e-9)]
        return np.polyfit(s, 8e-3 * (1 - 0.5 * np.sqrt(s)), 1)[0]

    ratio = by_quantity(checks, "δ(x): slope near the end")
    assert ratio.ours == pytest.approx(fitted_slope(0.7, 0.95) / fitted_slope(0.2, 0.7), rel=1e-6)
    assert ratio.ours < 1 and "off by" in ratio.verdict
    # one feed rate: the rows across feed rates say so
    assert "needs two feed rates" in by_quantity(checks, "δ at the higher feed rate").note


def test_the_scene_and_the_record_use_the_same_checks():
    from granflow.scenes.heap import SCENE

    from granflow.scenes.heap.shear_checks import shear_checks

    got = SCENE.profile_checks(profiles(heap(20), heap(33)))
    want = profile_checks(profiles(heap(20), heap(33))) + shear_checks(profiles(heap(20), heap(33)))
    assert [c.quantity for c in got] == [c.quantity for c in want]
