"""The silo's √R tested in the paper's form: v_c² a straight line in R, known answers."""
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
