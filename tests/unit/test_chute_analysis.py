"""Chute analysis on synthetic frames: Bagnold fit, stress ratio, weight check, verdicts."""
import math

import numpy as np
import pandas as pd
from numpy.testing import assert_allclose

from granflow.scenes.chute import SCENE
from granflow.scenes.chute.analysis import (
    bagnold_shape,
    fit_bagnold,
    height_profile,
    profile_checks,
    stress_ratio,
    weight_above,
)
from postproc.frame import DumpFrame, ParticleFrame
from postproc.steady import SteadyState

THETA = 24.0
LX, LY, N_LAYERS, PER_LAYER = 6.0, 5.0, 12, 20


def column_frame(theta=THETA, seed=1, u_of_z=None):
    """A hydrostatic column: PER_LAYER particles at each layer z = k + 1/2 (random x, y), with the
    per-atom LAMMPS stress (tension positive, times volume) that makes each unit bin carry
    sigma_zz = weight of the material above its centre and sigma_xz = -tan(theta) sigma_zz
    (compressive positive); velocities u_of_z(z) along x (default at rest)."""
    rng = np.random.default_rng(seed)
    z = np.repeat(np.arange(N_LAYERS) + 0.5, PER_LAYER)
    n = len(z)
    mass = np.ones(n)
    area = LX * LY
    # weight above bin centre k per area: g cos(theta) m PER_LAYER / area x (N_LAYERS - k - 1/2)
    k = np.floor(z)
    weight = math.cos(math.radians(theta)) * PER_LAYER / area * (N_LAYERS - k - 0.5)
    sigma_v = weight * area * 1.0 / PER_LAYER  # each particle carries V_bin/n of its bin's stress
    ux = np.zeros(n) if u_of_z is None else u_of_z(z)
    cols = {"id": np.arange(1, n + 1, dtype=float), "type": np.ones(n), "radius": np.full(n, 0.5),
            "mass": mass, "x": rng.uniform(0, LX, n), "y": rng.uniform(0, LY, n), "z": z,
            "vx": ux, "vy": np.zeros(n), "vz": np.zeros(n)}
    stress = [0.0 * z, 0.0 * z, -sigma_v, 0.0 * z, math.tan(math.radians(theta)) * sigma_v, 0.0 * z]
    cols.update({f"c_stress[{i + 1}]": s for i, s in enumerate(stress)})
    box = np.array([[0.0, LX], [0.0, LY], [0.0, N_LAYERS + 2.0]])
    return ParticleFrame.from_dump(DumpFrame(0, box, "p p f", cols))


def test_bagnold_amplitude_is_recovered():
    h, A = 15.0, 0.17
    z = np.linspace(2.0, 12.0, 11)
    exact = fit_bagnold(z, A * bagnold_shape(z, h), h)
    assert_allclose(exact["A"], A, rtol=1e-12)  # a noise-free profile: exact up to rounding
    assert_allclose(exact["r2"], 1.0, atol=1e-12)
    rng = np.random.default_rng(7)
    noisy = A * bagnold_shape(z, h) * (1 + 0.01 * rng.standard_normal(len(z)))
    fit = fit_bagnold(z, noisy, h)
    # 1 % noise on 11 points: the amplitude's relative error is ~0.01/sqrt(11) = 0.3 %; 1.5 % is 5 sigma
    assert_allclose(fit["A"], A, rtol=0.015)
    assert fit["r2"] > 0.99 and fit["rel_rms"] < 0.02


def test_stress_ratio_and_weight_of_a_hydrostatic_column():
    profile = height_profile([column_frame()], bin_width=1.0, z_max=N_LAYERS + 2.0, n_blocks=2)
    inside = profile["z"] < N_LAYERS
    # sigma_xz/sigma_zz = -tan(theta) per particle, so exactly tan(theta) per bin (rounding only)
    assert_allclose(stress_ratio(profile)[inside], math.tan(math.radians(THETA)), rtol=1e-12)
    # the column's normal stress is the weight above each bin centre, exactly by construction
    assert_allclose(profile["sigma_zz"][inside], weight_above(profile, THETA)[inside], rtol=1e-12)
    checks = profile_checks(profile, THETA, z_base=0.0, margin=2.0)
    assert checks["n_bulk_bins"] >= 6
    assert_allclose(checks["stress_ratio"], math.tan(math.radians(THETA)), rtol=1e-12)
    assert checks["weight_residual"] < 1e-12
    assert_allclose(checks["stress_ratio_error"], 0.0, atol=1e-12)
    # packing of the layers: PER_LAYER spheres of volume pi/6 per unit slab of area LX LY
    assert_allclose(checks["phi_bulk"], PER_LAYER * math.pi / 6 / (LX * LY), rtol=1e-12)


def test_bagnold_profile_through_the_accumulator():
    A, h = 0.1, float(N_LAYERS)
    frame = column_frame(u_of_z=lambda z: A * bagnold_shape(z, h))
    profile = height_profile([frame], bin_width=1.0, z_max=N_LAYERS + 2.0, n_blocks=2)
    checks = profile_checks(profile, THETA, z_base=0.0, margin=2.0)
    # the surface (phi = phi_bulk/2) lies within a bin of the top layer's edge, so the fitted A
    # carries the error of h: |dA/A| ~ (3/2) dh/h x (bulk weighting) < 10 % for dh <= 1
    assert_allclose(checks["bagnold_A"], A, rtol=0.10)
    assert checks["bagnold_r2"] > 0.98


def _steady(status, mean, slope):
    return SteadyState(status, float("nan"), mean, 0.1, slope, "synthetic")


def _ramp(u0, rise, noise, seed=3):
    """u_cm(t) over 100 time units: a linear ramp from u0 by ``rise`` per 50 time units, plus noise."""
    t = np.linspace(0.0, 100.0, 201)
    u = u0 + rise * t / 50.0 + noise * np.random.default_rng(seed).normal(size=t.size)
    return pd.DataFrame({"Time": t, "v_ucm": u})


def test_flow_verdicts():
    record = {"protocol": {"arrest_speed": 0.01, "steady_rel_tol": 0.03, "steady_fluct_tol": 0.05,
                           "steady_window": 50.0}}
    flat = _ramp(2.0, 0.0, 0.01)
    assert SCENE.flow_verdict(_steady("jammed", 1e-5, 0.0), flat, record).status == "arrested"
    # a creeping bed (mean speed below arrest_speed) is arrested
    assert SCENE.flow_verdict(_steady("no_steady_state", 5e-3, 1e-6), _ramp(5e-3, 0, 1e-3), record).status \
        == "arrested"
    # a doubling over the last window with 1 % scatter about the trend is an acceleration (the
    # scatter is measured about the line, so the ramp itself is not counted as fluctuation)
    assert SCENE.flow_verdict(_steady("no_steady_state", 3.0, 0.04), _ramp(1.0, 1.0, 0.02), record).status \
        == "accelerating"
    # a 10 % rise per window is still a trend when the scatter is 1 %
    assert SCENE.flow_verdict(_steady("no_steady_state", 2.0, 0.004), _ramp(2.0, 0.2, 0.02), record).status \
        == "accelerating"
    # the same rise inside 8 % noise (above the 5 % tolerance) is the noise of a small bed
    assert SCENE.flow_verdict(_steady("no_steady_state", 2.0, 0.004), _ramp(2.0, 0.2, 0.16), record).status \
        == "no_steady_state"
    # a 2 % rise per window is within the drift tolerance: not accelerating
    assert SCENE.flow_verdict(_steady("no_steady_state", 2.0, 0.001), _ramp(2.0, 0.04, 0.01), record).status \
        == "no_steady_state"
    assert SCENE.flow_verdict(_steady("steady", 2.0, 0.0), flat, record).status == "steady"


def test_table_brackets_the_flowing_range():
    """The sweep's statuses bracket the flowing range on every row (NaN where a regime is missing)."""
    import math

    from granflow.scenes.chute import SCENE

    rows = [{"theta": t, "status": s} for t, s in ((30, "accelerating"), (18, "arrested"), (22, "steady"),
                                                    (25, "steady"), (20, "arrested"))]
    table = SCENE.table(rows)
    assert list(table["theta"]) == [18, 20, 22, 25, 30]
    row = table.iloc[0]
    assert (row["theta_arrested_max"], row["theta_steady_min"], row["theta_steady_max"],
            row["theta_accelerating_min"]) == (20, 22, 25, 30)
    only_steady = SCENE.table([{"theta": 24, "status": "steady"}]).iloc[0]
    assert math.isnan(only_steady["theta_arrested_max"]) and only_steady["theta_steady_min"] == 24
