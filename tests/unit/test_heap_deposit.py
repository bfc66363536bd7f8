"""The deposit's segregation contrast: a deposit with a known c_s(x) gives the known contrast."""
import numpy as np
import pandas as pd
import pytest

from granflow.scenes.heap.analysis.deposit import deposit_contrast


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


def test_fed_particles_rest_position_and_flight_from_known_paths():
    """A small particle fed at frame 2 flies 1 cm a frame 10 mm above a flat surface for 4 frames, then
    rolls 5 mm a frame on it; a large one rolls 2 mm a frame on the surface; one fed at frame 8 (too late
    to follow) and one present from the start are not counted."""
    import granflow.scenes.heap.analysis as hp
    from postproc.frame import ParticleFrame

    geometry = hp.HeapGeometry(W=0.12, T=0.01, theta_deg=24.0, x_feed=0.02)
    x_lab = np.linspace(0.005, 0.115, 12)
    n_f = 11
    z_s = np.zeros((n_f, len(x_lab)))
    z_s[:, 0] = np.nan                                      # a column without a surface is skipped

    def path(f):
        rows = [(1, 2, 0.05, -0.01)]                        # in the bed from the start
        if f >= 2:
            k = f - 2
            x10 = 0.01 + 0.01 * min(k, 4) + 0.005 * max(k - 4, 0)
            rows.append((10, 1, x10, 0.01 if k < 4 else 0.0))
            rows.append((11, 2, 0.01 + 0.002 * k, 0.0))
        if f >= 8:
            rows.append((12, 1, 0.01, 0.05))
        ids, kinds, xs, zs = (np.array(c) for c in zip(*rows))
        pos = np.column_stack([xs, np.full(len(xs), 0.005), zs])
        return ParticleFrame(timestep=f, box=np.zeros((3, 2)), position=pos, velocity=np.zeros_like(pos),
                             mass=np.ones(len(xs)), radius=np.full(len(xs), 5e-4), type=kinds, id=ids)

    t = hp.fed_travel([path(f) for f in range(n_f)], x_lab, z_s, geometry, 2, d_above=2e-3)
    assert t["travel_n_1"] == 1 and t["travel_n_2"] == 1
    assert t["travel_flight_1"] == pytest.approx(0.035)          # 3 whole steps above, one half
    assert t["travel_flight_share_1"] == pytest.approx(0.035 / 0.06)
    assert t["travel_rest_x_over_L_1"] == pytest.approx(0.5)     # x = 0.07 on a 0.1 m flowing length
    assert t["travel_flight_2"] == 0.0 and t["travel_flight_share_2"] == 0.0
    assert t["travel_rest_x_over_L_2"] == pytest.approx(0.06)
    # nobody fed: counts 0, means NaN
    still = hp.fed_travel([path(0)] * 5, x_lab, z_s[:5], geometry, 2, d_above=2e-3)
    assert still["travel_n_1"] == 0 and np.isnan(still["travel_rest_x_over_L_1"])
