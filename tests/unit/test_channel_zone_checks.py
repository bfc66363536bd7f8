"""The shear rate's shape in the channel's zones (granflow.scenes.channel.zone_checks), on profiles with a known
answer."""
from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest

from granflow.scenes.channel.zone_checks import MIN_BINS, log_shear_curvature, shear_orders


def analysis(x, gd, rel_se=0.01):
    return SimpleNamespace(folded=pd.DataFrame({"x": x}),
                           rheo=pd.DataFrame({"gamma_dot": gd, "gamma_dot_se": rel_se * np.abs(gd)}))


@pytest.mark.parametrize("c2", [-0.05, 0.0, 0.08])
def test_the_curvature_of_ln_shear_rate_is_read_back(c2):
    x = np.arange(0.75, 30.0, 1.0)
    gd = np.exp(1.0 - 0.4 * x + c2 * x**2 / 2)              # ln γ̇ = 1 - 0.4 x + c2 x²/2: curvature c2
    fit = log_shear_curvature(analysis(x, gd), 4.0, 12.0)
    assert math.isclose(fit["curvature"], c2, abs_tol=1e-9) and fit["n"] == 8
    assert fit["se"] > 0


def test_a_zone_of_too_few_bins_gives_no_curvature():
    x = np.arange(0.75, 30.0, 1.0)
    fit = log_shear_curvature(analysis(x, np.exp(-x)), 2.0, 2.0 + MIN_BINS - 1)
    assert math.isnan(fit["curvature"]) and fit["n"] == MIN_BINS - 1


def test_orders_below_the_wall_are_read_at_the_last_bin_before_the_edge():
    x = np.array([0.75, 2.0, 3.0, 4.0, 5.0, 6.0])
    gd = np.array([10.0, 1.0, 0.1, 0.01, 0.001, 0.0])
    r = shear_orders(analysis(x, gd), x_edge=4.5)           # the last bin before 4.5 is x = 4: 10 / 0.01
    assert math.isclose(r["orders"], 3.0) and r["x"] == 4.0
    assert math.isclose(shear_orders(analysis(x, gd), 4.5, +1)["orders"], 4.0)
    assert math.isclose(r["se"], math.hypot(0.01, 0.01) / math.log(10))
    assert math.isnan(shear_orders(analysis(x, gd), 6.5)["orders"])   # a zero shear rate has no order


def mu_analysis(x, I, mu):
    return SimpleNamespace(folded=pd.DataFrame({"x": x}),
                           rheo=pd.DataFrame({"I": I, "I_se": 0.01 * I, "mu": mu, "mu_se": np.full(len(x), 0.001)}))


def test_mu_linear_in_log_i_has_its_slope_and_no_change_of_slope():
    from granflow.scenes.channel.zone_checks import mu_log_i

    x = np.arange(1.0, 12.0)
    L = -1.0 - 0.25 * x                                       # log10 I from -1.25 to -3.75
    fit = mu_log_i(mu_analysis(x, 10**L, 0.35 + 0.04 * L), 0.0, 20.0)
    assert math.isclose(fit["slope"], 0.04, rel_tol=1e-9) and abs(fit["kappa"]) < 1e-9


def test_mu_flattening_at_low_i_as_b3_does_has_a_positive_change_of_slope():
    from granflow.scenes.channel.zone_checks import mu_log_i

    x = np.arange(1.0, 12.0)
    I = 10 ** (-1.0 - 0.25 * x)
    mu_s, mu_2, I_0 = 0.25, 0.6, 0.3                           # B3: μ = μ_s + (μ_2 − μ_s)/(1 + I_0/I)
    fit = mu_log_i(mu_analysis(x, I, mu_s + (mu_2 - mu_s) / (1 + I_0 / I)), 0.0, 20.0)
    assert fit["slope"] > 0 and fit["kappa"] > 1.0            # the slope dies away toward the lowest I


def test_a_rung_may_name_headlines_of_its_own():
    """The ladder's rung phi062 records the loose zone's width (paper 0 at φ̄ = 0.62) beside the ladder's headlines."""
    import granflow.ladder as lad
    from granflow.scenes.channel.zone_checks import Q_LOOSE_WIDTH
    from granflow.schema import PROJECT_ROOT

    ladder = lad.load_ladder(PROJECT_ROOT / "config" / "ladders" / "channel.yaml")
    rung = next(r for r in ladder["rungs"] if r["name"] == "phi062")
    assert any(Q_LOOSE_WIDTH.startswith(h) for h in rung["headlines"])
    assert lad.rung_sweep(ladder, rung)["phi_mean"] == [0.62]
