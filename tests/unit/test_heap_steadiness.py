"""The heap's steadiness row (granflow.scenes.heap.steadiness): α's change across the averaging window, tested on
per-frame angles with a known drift and on frames without one."""
from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from granflow.scenes.heap.steadiness import PAPER_VARIATION, QUANTITY, alpha_change_check, change_across


def frames(drift: float, noise: float, n: int = 75, seed: int = 1) -> pd.DataFrame:
    """Per-frame α over a 1.5 s window: 25.7° + drift × (t − t_0)/(t_n − t_0) + white noise."""
    t = np.linspace(10.0, 11.5, n)
    rng = np.random.default_rng(seed)
    return pd.DataFrame({"t": t, "alpha_deg": 25.7 + drift * (t - t[0]) / (t[-1] - t[0]) + rng.normal(0, noise, n)})


def test_the_change_across_the_window_is_the_drift():
    change, se, n = change_across(frames(0.33, 0.0))
    assert n == 75 and change == pytest.approx(0.33, abs=1e-9) and se == pytest.approx(0.0, abs=1e-9)
    change, se, _ = change_across(frames(0.33, 0.1))
    assert abs(change - 0.33) < 3 * se and 0.01 < se < 0.1


def test_a_steady_window_reads_no_change_and_a_drifting_one_differs():
    steady = [change_across(frames(0.0, 0.1, seed=s)) for s in range(200)]
    z = np.array([c / se for c, se, _ in steady])
    assert abs(z.mean()) < 0.3 and 0.7 < z.std() < 1.3      # the error is the scatter of the estimate
    ok = alpha_change_check("mdot~33", frames(0.0, 0.05), {}, (0.25, 0.75))
    assert ok.quantity == QUANTITY and ok.paper_error == PAPER_VARIATION and ok.verdict.startswith("within")
    far = alpha_change_check("mdot~33", frames(1.0, 0.05), {"other range": frames(0.95, 0.05, seed=2)}, (0.25, 0.75))
    assert far.ours == pytest.approx(1.0, abs=0.05) and "other range" in far.variants
    assert not far.verdict.startswith("within")


def test_too_few_frames_or_none_is_not_measured():
    assert math.isnan(change_across(frames(0.1, 0.0, n=3))[0])
    row = alpha_change_check("mdot~33", None, {}, (0.25, 0.75), why_not="not analysed")
    assert math.isnan(row.ours) and row.note == "not analysed" and row.verdict == "not measured"
