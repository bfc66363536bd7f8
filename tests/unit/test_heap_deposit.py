"""The deposit's segregation contrast: a deposit with a known c_s(x) gives the known contrast."""
import numpy as np
import pandas as pd
import pytest

from granflow.scenes.heap.analysis.layer import deposit_contrast


def _deposit():
    # 10 columns over 0.02-0.12 m: small-rich upstream (c_s 0.8) and poor downstream (0.2), but the
    # downstream columns hold fewer, larger particles: counts and volumes weight the halves differently
    x = np.linspace(0.025, 0.115, 10)
    c = np.where(x < 0.07, 0.8, 0.2)
    n = np.where(x < 0.07, 100, 40)
    c[2], n[2] = 0.5, 300            # one crowded upstream column of mixed material
    volume = np.where(x < 0.07, 1.0, 2.0)
    volume[2] = 1.0
    return pd.DataFrame({"x_lab": x, "c_s": c, "n": n, "volume": volume})


def test_number_and_volume_weights_give_their_known_contrasts():
    dep = _deposit()
    up = dep[dep["x_lab"] < 0.07]
    by_n = deposit_contrast(dep, 0.02, 0.12, "n")
    assert by_n["upstream"] == pytest.approx(np.sum(up["c_s"] * up["n"]) / up["n"].sum())
    assert by_n["downstream"] == pytest.approx(0.2)
    by_v = deposit_contrast(dep, 0.02, 0.12, "volume")
    assert by_v["upstream"] == pytest.approx((4 * 0.8 + 0.5) / 5)
    assert by_v["contrast"] == pytest.approx((4 * 0.8 + 0.5) / 5 - 0.2)
    assert by_n["n"] == by_v["n"] == int(dep["n"].sum())


def test_the_range_leaves_out_the_pool_and_empty_columns_count_nothing():
    dep = _deposit()
    dep.loc[9, ["c_s"]] = 1.0                    # a pool of small particles against the end wall
    dep.loc[0, ["n", "volume"]] = 0              # an empty column
    whole = deposit_contrast(dep, 0.02, 0.12, "volume")
    without = deposit_contrast(dep, 0.02, 0.11, "volume")
    assert whole["downstream"] > without["downstream"]
    assert without["n"] == int(dep["n"].iloc[1:9].sum())


def test_species_flux_above_the_surface_from_a_known_profile():
    """Species 1 sits half above the surface, species 2 all below; u = 1 everywhere: shares 1/2 and 0."""
    import granflow.scenes.heap.analysis as hp

    z_lo = np.array([-2e-3, -1e-3, 0.0, 1e-3])
    rows = pd.DataFrame({"x": 0.05, "z": z_lo + 5e-4, "z_lo": z_lo, "z_hi": z_lo + 1e-3, "u": 1.0,
                         "phi_1": [0.0, 0.3, 0.2, 0.1], "phi_2": [0.5, 0.3, 0.0, 0.0]})
    f = hp.species_flux_above(rows, 2)
    assert f["flux_above_surface_1"] == pytest.approx(0.5) and f["flux_above_surface_2"] == 0.0
    g = hp.species_flux_above(rows, 2, z_above=1e-3, name="flux_above_d_max")
    assert g["flux_above_d_max_1"] == pytest.approx(1 / 6)
    still = rows.assign(u=0.0)
    assert np.isnan(hp.species_flux_above(still, 2)["flux_above_surface_1"])
