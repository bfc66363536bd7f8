"""One universal scaled velocity profile (granflow.scenes.channel.collapse_checks), on folded profiles with a known
answer: eq. 3.1's shape at two speeds collapses; a linear rise to the plug does not."""
from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pandas as pd

from granflow.scenes.channel.analysis import velocity_scales
from granflow.scenes.channel.collapse_checks import Q_COLLAPSE, scaled_curve, scaled_profile_checks
from granflow.verdicts import verdict

X = np.r_[0.75, np.arange(2.0, 30.5, 1.0)]


def case(name, u, se=0.004, seed=0):
    """A folded profile of downward speed ``u`` (u_y = −u) with scaled-velocity errors ``se`` and that much
    noise on the scaled profile."""
    rng = np.random.default_rng(seed)
    slip, top = u[0], u.max()
    u = u + se * (top - slip) * rng.standard_normal(len(u)) * (np.arange(len(u)) > 0)
    folded = pd.DataFrame({"x": X, "u_y": -u, "u_y_se": 0.1, "u_scaled_se": se})
    return SimpleNamespace(name=name, why_not="", analysis=SimpleNamespace(folded=folded,
                                                                           scales=velocity_scales(folded)))


def eq31(u_slip, span, delta):
    return u_slip + span * (1.0 - np.exp(-3.0 * (X - X[0]) / delta))


def test_one_shape_at_two_speeds_collapses():
    a = case("W~60/phi~0.6", eq31(30.0, 15.0, 6.0), seed=1)
    b = case("W~60/phi~0.61", eq31(20.0, 8.0, 6.0), seed=2)   # the wall bin at 0.75 d_p does not scale with δ
    x, u, se = scaled_curve(a)
    assert x[0] > 0.3 / 6 and np.all(se == 0.004)            # the wall bin left out
    (row,) = scaled_profile_checks([a, b])
    assert row.quantity == Q_COLLAPSE and row.case == "sweep"
    words, _ = verdict(row.ours, row.error, row.paper_range, syst=row.syst, n_replicates=2)
    assert row.ours <= 2.5 * row.error and words.startswith(("within", "equal")), (row.ours, row.error, words)


def test_a_linear_rise_to_the_plug_does_not_collapse_on_the_exponential():
    a = case("a", eq31(30.0, 15.0, 6.0), seed=1)
    ramp = np.minimum(X - X[0], 9.0) / 9.0                    # straight to the plug at 9.75 d_p
    b = case("b", 20.0 + 8.0 * ramp, seed=2)
    (row,) = scaled_profile_checks([a, b])
    # exp against a ramp scaled to meet at x/δ = 1: they part by ~0.05-0.1 elsewhere
    assert row.ours > 0.03 and row.ours > 5 * row.error
    words, _ = verdict(row.ours, row.error, row.paper_range, syst=row.syst, n_replicates=2)
    assert words.startswith("differs"), words


def test_a_profile_without_its_own_scaled_error_gives_no_number():
    a = case("a", eq31(30.0, 15.0, 6.0))
    b = case("b", eq31(20.0, 8.0, 8.0))
    b.analysis.folded = b.analysis.folded.drop(columns=["u_scaled_se"])
    (row,) = scaled_profile_checks([a, b])
    assert math.isnan(row.ours) and "without: b" in row.note
    assert scaled_profile_checks([a]) == []
