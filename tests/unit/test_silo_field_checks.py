"""Known answers for the silo's steady-rate and monotonic-field checks (granflow.scenes.silo.field_checks).

A constant rate with noise reads no change, a rate falling by a known 6 % across its window reads
that change and fails against the paper's constant; axis profiles that approach the orifice
monotonically read ρ = 1, one with a bump against the trend reads less and names the bump's size.
"""
from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pandas as pd
from numpy.testing import assert_allclose

from granflow.scenes.silo.field_checks import (largest_reversal, monotonic_checks, rate_drift,
                                               steady_rate_check)
from granflow.verdicts import verdict


def _flow(drift: float, noise: float, rng) -> pd.DataFrame:
    t = np.arange(0.025, 4.0, 0.05)
    W = 1.0 * (1 + drift * (t - 2.0) / 2.0) + noise * rng.standard_normal(t.size)
    return pd.DataFrame(dict(t=t, t_lo=t - 0.025, t_hi=t + 0.025, W_f=W, W_f_se=np.full(t.size, noise)))


def test_rate_drift_reads_a_known_change_and_none_on_a_constant():
    rng = np.random.default_rng(3)
    flat = _flow(0.0, 0.01, rng)
    d = rate_drift(flat["t"], flat["W_f"], flat["W_f_se"], 1.0, 3.0)
    assert abs(d["drift"]) < 2.5 * d["drift_se"] and 0.5 < d["chi2"] < 1.6
    # exact line: falls by 6 % of its mean over the 2 s window
    line = _flow(-0.06, 1e-9, rng)
    d = rate_drift(line["t"], line["W_f"], np.full(len(line), 1e-3), 1.0, 3.0)
    assert_allclose(d["drift"], -0.06, rtol=1e-6)
    assert d["n"] == 40
    # fewer than three samples: NaN
    assert math.isnan(rate_drift([1, 2], [1, 1], [0.1, 0.1], 0, 3)["drift"])


def _case(flow, steady=True):
    scalars = dict(t_start=1.0, t_end=3.0, window=0.05, status="steady" if steady else "jammed")
    return SimpleNamespace(name="R~9", steady=steady, flow=flow, record=dict(r_b=0.001, gravity=9.81),
                           why_not="not measured: case jammed", get=lambda k: float(scalars[k]))


def test_steady_rate_check_passes_a_constant_rate_and_fails_a_falling_one():
    rng = np.random.default_rng(5)
    ok = steady_rate_check(_case(_flow(0.0, 0.01, rng)))
    words, _ = verdict(ok.ours, ok.error, ok.paper_range)
    assert words.startswith("within error"), words
    bad = steady_rate_check(_case(_flow(-0.06, 0.003, rng)))
    assert_allclose(bad.ours, -0.06, atol=0.01)
    words, _ = verdict(bad.ours, bad.error, bad.paper_range, n_replicates=2)
    assert words.startswith("differs"), words
    assert "50%" in bad.note   # the 2 s window of a 4 s discharge
    assert math.isnan(steady_rate_check(_case(_flow(0.0, 0.01, rng), steady=False)).ours)


def test_largest_reversal_is_zero_on_a_rise_and_the_bump_otherwise():
    z = np.linspace(0, 2, 11)
    se = np.full(z.size, 0.01)
    assert largest_reversal(z, z ** 2, se)["reversal"] == 0.0
    bumped = z.copy()
    bumped[4] += 0.5          # 0.9 at z = 0.8, then 1.0 at z = 1.0: the largest fall after it is to z = 1.0 (0.4 + ...)
    r = largest_reversal(z, bumped, se)
    assert_allclose(r["reversal"], bumped[4] - z[5])
    assert_allclose(r["reversal_se"], math.hypot(0.01, 0.01))


def _kinetic(phi, uz, case="R~12"):
    z = np.linspace(0, 2.5, len(phi))
    return pd.DataFrame(dict(case=case, R_over_rb=12.0, z_over_R=z, pk=1.0, pk_se=0.1, phi=phi,
                             phi_se=0.002, u_z=uz, u_z_se=0.001))


def test_monotonic_checks_read_one_for_monotonic_fields_and_less_for_a_bump():
    z = np.linspace(0, 2.5, 26)
    phi = 0.6 - 0.1 * np.exp(-z)          # falls towards the orifice
    uz = -0.5 * np.exp(-z)                # downward speed grows towards the orifice
    rows = monotonic_checks(_kinetic(phi, uz))
    assert [c.quantity.split(" ")[0] for c in rows] == ["φ", "v_z"]
    assert all(c.ours == 1.0 and c.case == "R~12" for c in rows)
    bump = phi.copy()
    bump[3] += 0.05                        # a dense layer above the orifice: against the trend
    rows = monotonic_checks(_kinetic(bump, uz))
    assert rows[0].ours < 1.0 and f"{bump[3] - bump[4]:.3g} ± " in rows[0].note
    # two cases: one row each per field; a profile without the columns: NaN rows
    both = pd.concat([_kinetic(phi, uz, "R~6"), _kinetic(phi, uz, "R~12")])
    assert [c.case for c in monotonic_checks(both)] == ["R~6", "R~12", "R~6", "R~12"]
    assert all(math.isnan(c.ours) for c in monotonic_checks(_kinetic(phi, uz).drop(columns=["phi", "u_z"])))


def test_the_axis_span_stops_below_the_free_surface():
    """A φ that falls again near the top of the span, where the surface passes while the silo empties (R = 12,
    surface at 1.75 R): the nodes within 6 r_b of it are left out, and the rest reads monotonic."""
    z = np.linspace(0, 2.5, 31)
    phi = np.where(z < 1.3, 0.6 - 0.25 * np.exp(-3 * z), 0.6 - 0.25 * np.exp(-3.9) - 0.2 * (z - 1.3))
    kin = _kinetic(phi, -0.5 * np.exp(-z)).assign(z_surface_over_R=1.75)
    rows = monotonic_checks(kin)
    assert rows[0].ours == 1.0 and "up to 1.25R" in rows[0].note and "(1.75R)" in rows[0].note
    # the margin's choice is the systematic error: 4 r_b below the surface reaches 1.42R, into the fall
    assert "4 r_b below the surface" in rows[0].variants and "span 0-1.5R: 1" in rows[0].variants
    assert rows[0].syst > 0.0
    assert monotonic_checks(kin.drop(columns=["z_surface_over_R"]))[0].ours < 0.5     # the whole 2R span reads the fall
