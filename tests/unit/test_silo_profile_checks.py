"""Known answers for the silo's checks from the record's profiles (granflow.scenes.silo.profile_checks).

Each check is fed small synthetic profiles whose answer is known: curves that collapse and curves
apart by a known offset; a contact pressure the same at every R and one proportional to R; a kinetic
pressure a fixed fraction of the contact pressure; an exact exponential and a known curvature; the
same h_c for every size and one that moves; partial pressures growing and falling with size;
φ_s ∝ r_s³ and ∝ r_s²; h_c the same at two kernel widths and shifted. One of each must fail.
"""
from __future__ import annotations

import math

import numpy as np
import pandas as pd
from numpy.testing import assert_allclose

from granflow.scenes.silo.profile_checks import (collapse_spread, contact_independence_check, decay_curvature,
                                                 kinetic_contact_checks, kinetic_growth_checks,
                                                 orifice_collapse_checks, profile_checks)
from granflow.scenes.silo.species_checks import (kernel_width_check, partial_size_check, species_hc_check,
                                                 volume_fraction_check)

RS = (6.0, 7.5, 9.0, 10.5, 12.0)
RADII = np.linspace(0.5625, 1.0, 7)


def test_collapse_spread_is_zero_on_one_curve_and_the_offset_otherwise():
    rng = np.random.default_rng(1)
    x = np.linspace(0, 1, 21)
    grid = np.linspace(0.1, 0.8, 8)
    se = np.full_like(x, 0.01)
    same = [(x, 1 - 0.3 * x ** 2 + se * rng.standard_normal(x.size), se) for _ in RS]
    f = collapse_spread(same, grid)
    # noise only: the spread beyond the errors is within 2 of its errors of 0, χ²/ν near 1 (ν = 32: ± 0.25)
    assert f["s"] <= 2 * f["s_se"] and abs(f["chi2"] - 1) < 0.75
    # exact curves two apart by ±0.05 about their mean (no noise): rms distance 0.05 recovered
    tiny = np.full_like(x, 1e-6)
    apart = [(x, 1 - 0.3 * x ** 2 + d, tiny) for d in (-0.05, 0.05)]
    assert_allclose(collapse_spread(apart, grid)["s"], 0.05, rtol=1e-6)


def plane(offsets) -> pd.DataFrame:
    """Plane-crossing bins (r_b/2) at three slabs: φ flat inside, v ∝ √(1−(r/R)²), scaled by 1 + offset·r/R."""
    rows = []
    for R, off in zip(RS, offsets):
        r = (np.arange(int(1.5 * R / 0.5)) + 0.5) * 0.5 / R
        inside = r < 1
        for slab in (0.25, 0.5, 1.0):
            rows.append(pd.DataFrame({"case": f"R~{R:g}", "R_over_rb": R, "slab_half": slab, "r_over_R": r,
                                      "vz": np.where(inside, -2 * np.sqrt(np.clip(1 - r ** 2, 0, None)) * (1 + off * r),
                                                     np.nan),
                                      "vz_se": 0.005, "phi": np.where(inside, 0.5 * (1 + off * r), 0.0),
                                      "phi_se": 0.005, "n": np.where(inside, 100, 0)}))
    return pd.concat(rows, ignore_index=True)


def test_orifice_collapse_passes_on_one_shape_and_fails_on_shapes_that_move_with_R():
    good = orifice_collapse_checks(plane([0.0] * 5), None)
    assert [c.kind for c in good] == ["comparison", "comparison"]
    for c in good:
        # linear interpolation of √(1−(r/R)²) between bins r_b/2 apart (up to 0.083 R) errs by up to
        # h²|y''|/8 ≈ 0.003 at r ≤ 0.8R, differently for each R: that much spread is the method's
        assert_allclose(c.ours, 0.0, atol=3e-3)
        assert c.verdict == "equal" or c.verdict.startswith("within")
    bad = orifice_collapse_checks(plane([-0.2, -0.1, 0.0, 0.1, 0.2]), None)
    for c in bad:  # the profiles tilt by ±20 % at the rim: a spread of several per cent, many errors off
        assert c.ours > 0.02 and c.verdict.startswith("one sample: off by")


def axis_tables(pc_scale, ratio=1e-3):
    """Contact pressure on the axis 0 → 30 r_b (a rise to a plateau), scaled by pc_scale(R); p^k = ratio·p^c."""
    contact, kinetic = [], []
    for R in RS:
        z = np.arange(-2, 30.01, 0.5) / R
        pc = pc_scale(R) * 5000 * np.clip(z * R / 10, 0, 1)
        contact.append(pd.DataFrame({"case": f"R~{R:g}", "R_over_rb": R, "z_over_R": z, "pc": pc, "pc_se": 0.02 * pc + 1}))
        zk = np.arange(-2, 30.01, 1.0) / R
        pk = ratio * pc_scale(R) * 5000 * np.clip(zk * R / 10, 0, 1)
        kinetic.append(pd.DataFrame({"case": f"R~{R:g}", "R_over_rb": R, "z_over_R": zk, "pk": pk, "pk_se": 0.02 * pk + 1e-9}))
    return pd.concat(contact, ignore_index=True), pd.concat(kinetic, ignore_index=True)


def test_contact_pressure_independent_of_R_and_one_proportional_to_R():
    same, _ = axis_tables(lambda R: 1.0)
    c = contact_independence_check(same)
    assert_allclose(c.ours, 0.0, atol=1e-9)
    assert c.verdict == "equal" or c.verdict.startswith("within error")
    grows, _ = axis_tables(lambda R: R / 6)
    c = contact_independence_check(grows)
    assert_allclose(c.ours, 1.0, rtol=1e-9)
    assert c.verdict.startswith("one sample: off by")


def test_kinetic_over_contact_reads_the_ratio_and_fails_at_a_tenth():
    contact, kinetic = axis_tables(lambda R: 1.0, ratio=1e-3)
    checks = kinetic_contact_checks(kinetic, contact)
    assert len(checks) == len(RS)
    for c in checks:  # the same ratio at every height (the mean-p^c variant counts the rise below 10 r_b)
        assert_allclose(c.ours, -3.0, atol=1e-9)
        assert c.verdict == "within the paper's range"
    contact, kinetic = axis_tables(lambda R: 1.0, ratio=0.1)
    for c in kinetic_contact_checks(kinetic, contact):
        assert_allclose(c.ours, -1.0, atol=1e-9)
        assert c.verdict.startswith("one sample: off by")


def test_decay_curvature_is_zero_for_an_exponential_and_known_for_a_parabola():
    z = np.linspace(-0.5, 3, 36)
    pk = 100 * np.exp(-1.5 * z)
    f = decay_curvature(z, pk, 0.01 * pk, 1.0, 2.5)
    assert_allclose([f["kappa"], f["rate"]], [0.0, 1.5], atol=1e-9)
    # ln p = -2 z + 0.3 z²: λ = 2 − 0.6 z, κ = (λ(1) − λ(2.5))/λ(1.75) = 0.9/0.95
    pk = np.exp(-2 * z + 0.3 * z ** 2)
    assert_allclose(decay_curvature(z, pk, 0.01 * pk, 1.0, 2.5)["kappa"], 0.9 / 0.95, rtol=1e-9)
    kin = pd.DataFrame({"case": "R~9", "R_over_rb": 9.0, "z_over_R": z, "pk": pk, "pk_se": 0.01 * pk})
    (c,) = kinetic_growth_checks(kin)
    assert c.verdict.startswith("one sample: off by")


def partial(shift=0.0, grow=True):
    """Seven species' kinetic-pressure bumps at h_c/R = 0.45 (+ shift × species index), φ_s ∝ r_s³."""
    z = np.arange(-4, 40) / 9.0
    out = {"case": "R~9", "R_over_rb": 9.0, "z": z * 9 / 64, "z_over_R": z}
    for s in range(1, 8):
        amp = s if grow else 8 - s
        bump = amp * np.exp(-((z - 0.45 - shift * (s - 4)) / 0.5) ** 2) + 1e-3
        out[f"pk_s{s}"], out[f"pk_s{s}_se"], out[f"phi_s{s}"] = bump, 0.01 * bump, 0.08 * RADII[s - 1] ** 3
    return pd.DataFrame(out)


def test_species_hc_the_same_for_every_size_and_moving_with_size():
    c = species_hc_check(partial())
    assert_allclose(c.ours, 0.0, atol=0.01)
    assert c.verdict.startswith("within error") or c.verdict == "equal"
    # h_c moves by 0.05 R per size: 0.3 R over the six steps, two thirds of the mean 0.45 R
    c = species_hc_check(partial(shift=0.05))
    assert_allclose(c.ours, 0.3 / 0.45, rtol=0.05)
    assert c.verdict.startswith("one sample: off by")


def test_partial_pressure_larger_for_bigger_particles_and_the_reverse():
    c = partial_size_check("R~9", partial(), 0.45)
    assert_allclose(c.ours, 7.0, rtol=1e-3)
    assert c.verdict == "within the paper's range"
    c = partial_size_check("R~9", partial(grow=False), 0.45)
    assert_allclose(c.ours, 1 / 7, rtol=1e-3)
    assert c.verdict.startswith("one sample: off by")


def test_volume_fractions_cubic_and_quadratic_in_the_radius():
    def scattered(power):
        g = partial()
        for s in range(1, 8):  # a little scatter, so the fit has an error
            g[f"phi_s{s}"] = 0.08 * RADII[s - 1] ** power * (1 + 0.01 * (-1) ** s)
        return g

    c = volume_fraction_check("R~9", scattered(3), RADII)
    # ±1 % alternating scatter moves the slope by far less than 0.05
    assert abs(c.ours - 3.0) < 0.05 and (c.verdict == "equal" or c.verdict.startswith("within"))
    c = volume_fraction_check("R~9", scattered(2), RADII)
    assert abs(c.ours - 2.0) < 0.05 and c.verdict.startswith("one sample: off by")


def test_kernel_width_same_h_c_and_a_shifted_one():
    sweep = pd.DataFrame({"case": [f"R~{R:g}" for R in RS], "R_over_rb": RS, "h_c_over_R": 0.45,
                          "h_c_over_R_se": 0.01, "h_c_over_R_fine": 0.45, "h_c_over_R_eq7": 0.45,
                          "h_c_over_R_eq7_se": 0.02})
    c = kernel_width_check(sweep)
    assert_allclose([c.ours, c.error], [0.0, math.sqrt(0.02 ** 2 + 0.01 ** 2) / math.sqrt(5)], rtol=1e-9, atol=1e-12)
    assert c.verdict == "equal"
    sweep["h_c_over_R_fine"] = sweep["h_c_over_R_eq7"] = 0.60
    c = kernel_width_check(sweep)
    assert_allclose(c.ours, 0.15, rtol=1e-9)
    assert c.verdict.startswith("one sample: off by")


def test_no_profiles_give_not_measured_checks():
    checks = profile_checks({})
    assert checks and all(c.verdict == "not measured" or c.kind != "comparison" for c in checks)
