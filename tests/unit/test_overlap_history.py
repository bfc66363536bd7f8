"""How a run's largest overlap reached the overlap guard (granflow.runner.overlap_history), told apart on
thermo series with a known history: one impact, a contact loaded ever harder, and neither."""
from __future__ import annotations

import numpy as np
import pandas as pd

from granflow.runner import overlap_history


def thermo(overlap) -> pd.DataFrame:
    return pd.DataFrame({"Time": np.arange(len(overlap)) * 5.0, "v_overlap": overlap})


def test_a_steady_rise_names_a_contact_loaded_ever_harder():
    # a particle pressed into a gap: 0.001 → 0.05 d over the run, with noise (the chute's seed 6620117 at 25°)
    rng = np.random.default_rng(1)
    ov = np.linspace(0.001, 0.0501, 60) + rng.normal(0, 3e-4, 60)
    ov[0], ov[-1] = 0.001, 0.0501
    text = overlap_history(thermo(ov))
    assert "rose steadily, 0.001 → 0.0501 d_min over t = 0-295" in text and "wedged" in text


def test_a_jump_in_the_last_interval_names_an_impact():
    ov = np.full(40, 0.004)
    ov[-1] = 0.06
    text = overlap_history(thermo(ov))
    assert text.startswith("the largest overlap jumped 0.004 → 0.06 d_min") and "impact" in text


def test_neither_gives_the_numbers_and_no_cause():
    ov = np.r_[np.full(20, 0.03), np.full(20, 0.02), [0.035, 0.051]]       # high from the start, then a rise
    text = overlap_history(thermo(ov))
    assert "0.035 → 0.051" in text and "impact" not in text and "wedged" not in text
    assert overlap_history(thermo([0.01, 0.02])) == ""                      # too few samples
    assert overlap_history(pd.DataFrame({"Time": [0, 1, 2]})) == ""         # no overlap column
