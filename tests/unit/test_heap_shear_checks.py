"""Known-answer tests of the heap's shear-rate rows (granflow.scenes.heap.shear_checks).

Synthetic collapses with a known γ̇(z): the paper's shape (γ̇ rising from the surface to a maximum 2.5 d̄
down, then falling smoothly to zero, Fan et al. 2013 Fig. 5b) and an exponential u(z), whose γ̇ is largest
at the surface. u_s falls linearly along the heap, δ and d̄ are constant, so γ̇ at a fixed depth falls with x.
"""
from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from granflow.scenes.heap.shear_checks import per_bin, scaled_shear, shear_checks

D_BAR, DELTA, L = 1.2e-3, 7.2e-3, 0.11                  # δ = 6 d̄
X_OVER_L = np.round(np.arange(0.02, 1.0, 0.04), 2)
ZT = np.arange(-2.95, 0.0, 0.1)                          # bin centres in z/δ (0.6 d̄ apart)
CASE = "mix~bi1-2/mdot~33"


def paper_shape(zt):
    """u/u_s whose derivative in z/δ is a bump peaking 2.5 d̄ (z/δ = −5/12) below the surface, ~1.2 × its
    value at the surface, falling smoothly to ~0 at z = −δ; u/u_s = 1 at z = 0."""
    peak = -2.5 * D_BAR / DELTA
    grid = np.linspace(-3.0, 0.0, 3001)
    slope = np.exp(-((grid - peak) / 0.45) ** 2)
    u = np.concatenate([[0.0], np.cumsum(0.5 * (slope[1:] + slope[:-1]) * np.diff(grid))])
    u = u / u[-1]
    return np.interp(zt, grid, u)


def exponential(zt, k=2.3):
    return np.exp(k * np.asarray(zt))


def profiles(shape, us_slope=1.0):
    sw, col = [], []
    for s in X_OVER_L:
        u_s = 0.2 * (1 - us_slope * s)
        sw.append({"case": CASE, "x": s * L, "x_over_L": s, "q": u_s * DELTA / 3, "u_s": u_s, "gamma_bar": u_s / DELTA,
                   "delta": DELTA, "delta_exp": DELTA, "delta_lin": DELTA, "delta_cut": DELTA, "delta_eq31": DELTA,
                   "d_bar": D_BAR, "q_star": 1.0, "usable": True, "c_s": 0.4})
        col += [{"case": CASE, "x": s * L, "zt": z, "ut": float(u), "wt": 0.0} for z, u in zip(ZT, shape(ZT))]
    return {"streamwise": pd.DataFrame(sw), "collapse": pd.DataFrame(col)}


def rows(shape, **kw):
    got = {c.quantity.split(":")[0]: c for c in shear_checks(profiles(shape, **kw))}
    assert len(got) == 2
    return got["γ̇(z)"], next(c for q, c in got.items() if q.startswith("γ̇ at"))


def test_the_derivative_reads_a_known_profile():
    z, s = scaled_shear(ZT, 3.0 * ZT + 1.0)
    assert np.allclose(s, 3.0)
    z, s = scaled_shear(ZT, exponential(ZT))
    inner = slice(1, -1)
    assert np.allclose(s[inner], 2.3 * exponential(z[inner]), rtol=0.01)
    z, s = scaled_shear(ZT, exponential(ZT), "midpoints")
    assert len(z) == len(ZT) - 1 and np.all(np.diff(z) > 0)


def test_the_papers_shape_peaks_below_the_top_and_passes():
    top, along = rows(paper_shape)
    assert top.ours > 1.05 and top.verdict == "within the paper's range"
    depth = per_bin(profiles(paper_shape)["collapse"], profiles(paper_shape)["streamwise"])["depth_max"]
    assert depth.median() == pytest.approx(2.5, abs=0.6)              # the collapse's bins are 0.6 d̄ apart
    assert along.ours < 0 and along.verdict == "within the paper's range"


def test_a_shear_rate_largest_at_the_surface_is_below_one():
    top, _ = rows(exponential)
    # γ̇ ∝ e^{2.3 z/δ}: the deeper largest is the first bin below 1 d̄ (z/δ = −0.25), the top's is the top
    # bin's one-sided difference, γ̇ half a bin below it (z/δ = −0.10)
    assert top.ours == pytest.approx(math.exp(-2.3 * 0.15), rel=0.02)
    assert top.ours < 1 and "within" not in top.verdict


def test_a_shear_rate_that_does_not_fall_along_the_heap_fails():
    _, along = rows(paper_shape, us_slope=-0.5)                        # u_s rising along x: γ̇ at a depth too
    assert along.ours > 0 and "within" not in along.verdict


def test_without_a_collapse_the_rows_say_why():
    p = profiles(paper_shape)
    p["collapse"] = p["collapse"].iloc[0:0]
    got = shear_checks(p)
    assert len(got) == 2 and all(math.isnan(c.ours) and c.note == "the record keeps no collapse" for c in got)
