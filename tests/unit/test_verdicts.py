"""Verdict words (granflow.verdicts.verdict) beyond a bound about zero."""
from __future__ import annotations

import pytest


def test_beyond_a_bound_about_zero_the_verdict_says_how_far_past_it():
    """|x| < 0.01 (the channel's u_cm change): 0.034 ± 0.007 lies 0.024 past the bound, not '+240 %' of it."""
    from granflow.verdicts import verdict

    words, rel = verdict(0.034, 0.007, (-0.01, 0.01), n_replicates=2)
    assert words.startswith("differs by +0.024 (3 σ") and words.endswith("past the paper's bound 0.01"), words
    assert rel == pytest.approx(2.4)                       # the difference column keeps its relative reading
    words, _ = verdict(1.2, 0.01, (1.0, 1.1), n_replicates=2)
    assert words.startswith("differs by +9.1 %"), words    # a range away from zero: relative as before
