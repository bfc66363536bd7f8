"""The channel's rows across channel widths (granflow.scenes.channel.width_checks) on hand-made profiles
built with known W scalings: the rows recover the scalings they were built with, and pass or fail against
the paper as the built-in physics says they must."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import yaml

import granflow.scenes.channel.width_checks as wc
from granflow import coverage
from granflow.scenes.channel.analysis import analyse_profile
from granflow.scenes.channel.validation import ChannelCase

SE = 1e-3
#: the synthetic profiles' bin width, d_p
BIN = 0.1


def build_profile(W: float, u_slip: float, delta: float, sxx: float, phi: float = 0.62) -> pd.DataFrame:
    """An unfolded symmetric profile of width W: u of eq. 3.1 (u_max = 1.4 u_slip, δ0.95 = ``delta``),
    σ_xx = ``sxx`` everywhere, σ_xy from the weight, φ = ``phi`` everywhere (the wall's shear stress, the weight
    of a half channel, is then ∝ W)."""
    edges = np.arange(0.0, W + BIN / 2, BIN)   # fine bins: the wall bin's speed is the built slip to 1e-3
    x = 0.5 * (edges[:-1] + edges[1:])
    xw = np.minimum(x, W - x)
    u = u_slip * (1.0 + 0.4 * (1.0 - np.exp(-3.0 * xw / delta)))
    zero = np.zeros(len(x))
    phi = phi + zero
    df = pd.DataFrame(dict(x=x, x_lo=edges[:-1], x_hi=edges[1:], n=np.full(len(x), 100.0), phi=phi, rho=phi,
                           u_x=zero, u_y=-u, u_z=zero, sigma_xx=sxx + zero, sigma_yy=sxx + zero,
                           sigma_xy=np.sign(x - W / 2) * (W / 2 - xw) * 0.6))
    for col in [c for c in df.columns if c not in ("x", "x_lo", "x_hi")]:
        df[f"{col}_se"] = 1e-2 if col == "u_y" else SE
    return df


def make_case(tmp_path: Path, W: float, phi_mean: float, profile: pd.DataFrame) -> ChannelCase:
    name = f"W~{W:g}/phi~{phi_mean:g}"
    path = tmp_path / name.replace("/", "_")
    path.mkdir(parents=True)
    record = {"parameters": {"W": W, "phi_mean": phi_mean, "n_particles": 1000}}
    return ChannelCase(name, path, record, {}, {}, "", analyse_profile(profile, W))


def paper_like(tmp_path, W, phi_mean=0.61, u_exponent=0.5, sxx_exponent=1.0):
    """u_slip ∝ W^u_exponent, δ0.95 ∝ W, σ_xx ∝ W^sxx_exponent: the paper's scalings at the defaults."""
    return make_case(tmp_path, W, phi_mean, build_profile(W, u_slip=10.0 * (W / 100.0) ** u_exponent,
                                                          delta=0.1 * W, sxx=0.8 * W ** sxx_exponent))


def rows(cases):
    return {c.quantity: c for c in wc.width_checks(cases)}


def test_widths_built_on_the_papers_scalings_pass(tmp_path):
    checks = rows([paper_like(tmp_path, 100.0), paper_like(tmp_path, 150.0)])
    assert set(checks) == set(wc.QUANTITIES)
    # u ∝ √W and δ0.95 ∝ W: u_slip (read at the wall bin's centre, 0.05 d_p: 0.2 % above the slip) and u_max scale by √1.5
    assert checks[wc.Q_USLIP_W].ours == pytest.approx(math.sqrt(1.5), rel=5e-3)
    assert checks[wc.Q_UMAX_W].ours == pytest.approx(math.sqrt(1.5), rel=5e-3)
    assert checks[wc.Q_SQRT_W].ours == pytest.approx(0.5, abs=0.02)
    # l_s from eq. 3.1: u_slip δ/(3 (u_max − u_slip)) ∝ δ ∝ W, so (l_s/W) is the same at both widths
    assert checks[wc.Q_SLIP_LENGTH].ours == pytest.approx(1.0, abs=0.03)
    assert checks[wc.Q_SXX_W].ours == pytest.approx(1.0, rel=1e-6)
    assert checks[wc.Q_SXX_RISE].ours == pytest.approx(1.5, rel=1e-6)
    assert checks[wc.Q_MU_WALL_W].ours == pytest.approx(0.0, abs=0.02)
    for q in wc.QUANTITIES:
        c = checks[q]
        assert c.kind == "comparison", q
        assert not c.verdict.startswith(("differs", "one sample: off")), (q, c.verdict)


def test_the_scalings_broken_fail(tmp_path):
    # u independent of W, σ_xx independent of W: speeds do not rise, σ_xx/W falls, μ_wall rises with W
    checks = rows([paper_like(tmp_path, 100.0, u_exponent=0.0, sxx_exponent=0.0),
                   paper_like(tmp_path, 150.0, u_exponent=0.0, sxx_exponent=0.0)])
    assert checks[wc.Q_USLIP_W].ours == pytest.approx(1.0, abs=3e-3)
    assert checks[wc.Q_SXX_W].ours == pytest.approx(100.0 / 150.0, rel=1e-6)
    assert checks[wc.Q_SXX_W].verdict.startswith("one sample: off")
    assert checks[wc.Q_SXX_RISE].ours == pytest.approx(1.0, rel=1e-6)       # σ_xx does not rise: on the bound
    assert checks[wc.Q_MU_WALL_W].ours > 0.05
    assert checks[wc.Q_MU_WALL_W].verdict.startswith("one sample: off")
    assert checks[wc.Q_SQRT_W].ours == pytest.approx(0.0, abs=0.02)
    assert checks[wc.Q_SQRT_W].verdict.startswith("one sample: off")


def test_a_speed_that_rises_more_than_the_papers_factor_fails(tmp_path):
    # u ∝ W^2 over 60 → 150 d_p: a factor 6.25, above the paper's 3
    checks = rows([paper_like(tmp_path, 60.0, u_exponent=2.0), paper_like(tmp_path, 150.0, u_exponent=2.0)])
    assert checks[wc.Q_USLIP_W].ours == pytest.approx(6.25, rel=1e-2)
    assert checks[wc.Q_USLIP_W].paper_range == (1.0, wc.SPEED_FACTOR_60_150)
    assert checks[wc.Q_USLIP_W].verdict.startswith("one sample: off")


def test_a_pair_with_the_narrow_width_below_100_judges_no_scaling(tmp_path):
    checks = rows([paper_like(tmp_path, 60.0), paper_like(tmp_path, 100.0)])
    # the paper's δ0.95 ∝ W and l_s ∝ W hold from W = 100 d_p: at 60 they are readings, and u ∝ √W is not read
    # and σ_xx/W 'varies very little for W > 60 d_p': at 60 a reading too
    assert checks[wc.Q_DELTA_W].kind == checks[wc.Q_SLIP_LENGTH].kind == checks[wc.Q_SXX_W].kind == "diagnostic"
    assert wc.Q_SQRT_W not in checks
    # σ_xx's rise, μ_wall's independence and the speeds' rise the paper states at every width
    assert checks[wc.Q_SXX_RISE].kind == checks[wc.Q_MU_WALL_W].kind == checks[wc.Q_USLIP_W].kind == "comparison"


def test_sigma_xx_that_falls_with_width_fails_its_rise(tmp_path):
    # σ_xx ∝ W^-0.5: the wider channel's plateau is lower, against 'a significant increase as W is increased'
    checks = rows([paper_like(tmp_path, 60.0, sxx_exponent=-0.5), paper_like(tmp_path, 100.0, sxx_exponent=-0.5)])
    assert checks[wc.Q_SXX_RISE].ours == pytest.approx((100.0 / 60.0) ** -0.5, rel=1e-6)
    assert checks[wc.Q_SXX_RISE].verdict.startswith("one sample: off")


def test_pairs_are_taken_at_each_phi_bar_and_need_two_widths(tmp_path):
    a, b = paper_like(tmp_path, 60.0, 0.60), paper_like(tmp_path, 100.0, 0.60)
    c, d = paper_like(tmp_path, 60.0, 0.61), paper_like(tmp_path, 100.0, 0.61)
    e = paper_like(tmp_path, 80.0, 0.62)
    pairs = wc.width_pairs([a, b, c, d, e])
    assert [(n.name, w.name) for n, w in pairs] == [(a.name, b.name), (c.name, d.name)]
    assert wc.width_checks([a, c, e]) == []
    b.why_not = "not steady"
    assert [(n.name, w.name) for n, w in wc.width_pairs([a, b])] == []


def test_every_row_names_a_result_of_the_paper():
    # the rows wait in paper_results_pending.yaml, each under an id of paper_results.yaml, until the record holds
    # two widths (tests/unit/test_coverage.py requires every compared_by row to be a row of checks.csv)
    ids = {e["id"] for e in coverage.load(coverage.paper_results_path("channel"))["results"]}
    pending = yaml.safe_load(Path(wc.__file__).with_name("paper_results_pending.yaml").read_text())["compared_by"]
    assert set(pending) <= ids
    assert {q for qs in pending.values() for q in qs} == set(wc.QUANTITIES)


def test_the_speeds_measurement_choices_enter_the_ratios_syst(tmp_path):
    narrow, wide = paper_like(tmp_path, 100.0), paper_like(tmp_path, 150.0)
    # the same choice read on both widths: the wall bin read at 1 d_p moves u_slip by +4 % at W = 150, +1 % at 100
    narrow.variants = {"u_slip": {"wall bin 1 d_p": narrow.analysis.scales.u_slip * 1.01,
                                  "window first half": (narrow.analysis.scales.u_slip, 0.01)}}
    wide.variants = {"u_slip": {"wall bin 1 d_p": wide.analysis.scales.u_slip * 1.04,
                                "window first half": (wide.analysis.scales.u_slip, 0.01),
                                "only here": 1.0}}
    assert set(wc.variant_ratios(wide, narrow, "u_slip")) == {"wall bin 1 d_p", "window first half"}
    checks = rows([narrow, wide])
    central = checks[wc.Q_USLIP_W].ours
    assert checks[wc.Q_USLIP_W].syst == pytest.approx(central * (1.04 / 1.01 - 1.0), rel=1e-6)
    assert "wall bin 1 d_p" in checks[wc.Q_USLIP_W].variants and "only here" not in checks[wc.Q_USLIP_W].variants
    assert math.isnan(checks[wc.Q_UMAX_W].syst)                                # no u_max variants given
