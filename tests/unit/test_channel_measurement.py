"""The channel's measurement variants and its steadiness/plug checks, on hand-made particles and case files."""
import json
import math

import numpy as np
import pandas as pd
import pytest

import granflow.headline as headline
import granflow.scenes.channel.validation as chv
from granflow.scenes.channel.analysis import analyse_profile
from granflow.scenes.channel.measurement import HEADLINES, headline_variants
from granflow.scenes.channel.pipeline import channel_blocks, channel_profile

W, H, B = 20.0, 12.0, 5.0


def speed(x):
    """A plug flow: 1 at the walls, rising over 5 d_p to 1.4 in the middle."""
    d = np.minimum(x, W - x)
    return 1.0 + 0.4 * (1.0 - np.exp(-3.0 * d / 5.0))


def write_case(tmp_path, n_frames=20, seed=0):
    """Particles on a jittered grid moving down at speed(x): dump, params.json and status.json."""
    rng = np.random.default_rng(seed)
    gx, gy, gz = np.meshgrid(np.arange(0.5, W, 1.0), np.arange(0.5, H, 1.0), np.arange(0.5, B, 1.0), indexing="ij")
    base = np.column_stack([gx.ravel(), gy.ravel(), gz.ravel()])
    n = len(base)
    dt, every = 1e-3, 1000
    lines = []
    for k in range(n_frames):
        pos = base + rng.uniform(-0.05, 0.05, base.shape)
        vel = np.zeros_like(pos)
        vel[:, 1] = -speed(pos[:, 0]) * (1.0 + rng.normal(0, 0.01, n))
        lines += [f"ITEM: TIMESTEP\n{k * every}\nITEM: NUMBER OF ATOMS\n{n}\nITEM: BOX BOUNDS ff pp pp\n"
                  f"0.0 {W}\n0.0 {H}\n0.0 {B}\nITEM: ATOMS id type radius mass x y z vx vy vz\n"]
        lines += [f"{i + 1} 1 0.5 1.0 {p[0]} {p[1]} {p[2]} {v[0]} {v[1]} {v[2]}\n" for i, (p, v) in enumerate(zip(pos, vel))]
    case = tmp_path / "case"
    (case / "run").mkdir(parents=True)
    (case / "run" / "dump_001.txt").write_text("".join(lines))
    record = {"scene": "channel", "rung": "validation", "dt": dt, "density": 6.0 / math.pi,
              "parameters": {"W": W, "phi_mean": 0.6, "n_particles": n},
              "rung_knobs": {"bin_width": 1.0, "wall_bin_width": 1.5, "t_average": (n_frames - 1) * every * dt}}
    (case / "params.json").write_text(json.dumps(record))
    (case / "run" / "status.json").write_text(json.dumps({"status": "steady", "dumps": ["dump_001.txt"]}))
    return case, record


def test_variants_of_a_prescribed_flow_agree_and_the_halves_are_subsets(tmp_path):
    case, record = write_case(tmp_path)
    central = analyse_profile(channel_profile(case)[0], W)
    assert central.scales.ratio == pytest.approx(speed(W / 2) / speed(0.75), rel=0.02)
    v = headline_variants(case, record, central)
    assert set(v) == set(HEADLINES)
    assert set(v["ratio"]) == {"bins 0.5 d_p", "bins 2 d_p", "u_max = centre bin", "u_max = mean over the plug",
                               "wall bin 1 d_p", "wall bin 2 d_p", "window first half", "window second half"}
    # where the wall's speed is read, a known answer: centres lie on layers x = 0.5, 1.5, ... (± 0.05);
    # a 1 d_p wall bin holds the first layer, a 2 d_p one the first two
    assert v["ratio"]["wall bin 1 d_p"] == pytest.approx(speed(W / 2) / speed(0.5), rel=0.01)
    assert v["ratio"]["wall bin 2 d_p"] == pytest.approx(speed(W / 2) / (0.5 * (speed(0.5) + speed(1.5))), rel=0.01)
    assert v["ratio"]["wall bin 2 d_p"] < central.scales.ratio - 0.02   # the choice moves the ratio
    # the wall bin is the paper's in every variant: u_slip does not move, nor does u_max of a smooth profile
    for name in ("bins 0.5 d_p", "bins 2 d_p", "u_max = centre bin"):
        assert v["ratio"][name] == pytest.approx(central.scales.ratio, rel=0.01), name
    # each half is a subset: a value with its own error
    value, se = v["ratio"]["window first half"]
    assert math.isfinite(se) and value == pytest.approx(central.scales.ratio, rel=0.01)


def test_blocks_of_a_steady_flow_have_no_drift(tmp_path):
    case, record = write_case(tmp_path, n_frames=24, seed=1)
    blocks = channel_blocks(case, record, record["rung_knobs"]["t_average"])
    assert len(blocks) == 8 and blocks["ratio"].notna().all()
    from granflow.scenes.channel.analysis.plug import drift
    change, se = drift(blocks)
    assert abs(change) < 3 * se + 1e-3


def _case_with(tmp_path, scalars_extra):
    case, record = write_case(tmp_path, n_frames=6)
    record["rung_knobs"].update({"W": W, "B": B, "H": H, "k_n": 1e6, "t_flow_max": 1000.0})
    record["protocol"] = {"steady_rel_tol": 0.02, "steady_fluct_tol": 0.05, "steady_window": 100.0}
    record["parameters"]["t_c_min"] = 0.01
    (case / "params.json").write_text(json.dumps(record))
    profile, _ = channel_profile(case)
    (case / "analysis").mkdir()
    profile.to_csv(case / "analysis" / "profile.csv", index=False)
    scalars = {"status": "steady", "ratio": 1.3, "u_slip": 1.0, "u_max": 1.3, "fit_exponent": 3.0, "fit_r2": 1,
               "fit_r2_a3": 1, "delta_095": 5.0, "delta_095_over_W": 0.25, "momentum_steady_residual": 0.0,
               "momentum_residual": 0.0, "weight": 1.0, "x_dense_plug": 6.0, **scalars_extra}
    (case / "analysis" / "scalars.json").write_text(json.dumps(scalars))
    return case


@pytest.fixture
def no_time_errors(monkeypatch):
    monkeypatch.setattr(headline, "measure_with_errors", lambda *a, **k: {})


def test_a_frozen_plug_and_a_steady_ratio_are_said_so(tmp_path, no_time_errors):
    case = _case_with(tmp_path, {"ratio_drift": 0.002, "ratio_drift_se": 0.004, "ratio_block_sd": 0.01,
                                 "n_blocks": 8, "plug_nonaffine_rms": 0.12, "plug_q6": 0.41, "shear_q6": 0.39,
                                 "plug_crystal_fraction": 0.01, "shear_crystal_fraction": 0.0,
                                 "plug_layering": 0.05, "plug_layering_random": 0.03})
    checks = chv.validation(tmp_path, {"c": case}).checks
    drift = next(c for c in checks if c.quantity.startswith("drift of u_max/u_slip"))
    assert drift.paper_range == (0.0, 0.0) and drift.verdict.startswith("within error")
    plug = next(c for c in checks if c.quantity.startswith("plug: rms non-affine"))
    assert plug.ours == 0.12 and "one frozen configuration" in plug.note
    # the headlines carry a systematic error from the same dumps
    ratio = next(c for c in checks if c.quantity == "u_max/u_slip")
    assert math.isfinite(ratio.syst) and "bins 0.5 d_p" in ratio.variants and "window first half" in ratio.variants


def test_a_record_analysed_before_the_blocks_says_to_rerun(tmp_path, no_time_errors):
    checks = chv.validation(tmp_path, {"c": _case_with(tmp_path, {})}).checks
    drift = next(c for c in checks if c.quantity.startswith("drift of u_max/u_slip"))
    assert drift.verdict == "not measured" and "rerun analyse" in drift.note
