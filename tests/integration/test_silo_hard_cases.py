"""Hard silo cases stop with a named reason or run clean (demand 2 of SPEC.md)."""
import pytest


@pytest.mark.lammps
def test_small_orifice_clogs_with_a_named_reason(silo_scene, run_smoke):
    """R = 1.5 r_b (D/d about 2): an arch blocks the orifice; the runner says so and stops."""
    import tempfile
    from pathlib import Path

    with tempfile.TemporaryDirectory() as tmp:
        status = run_smoke(silo_scene, Path(tmp), {"R": 1.5})
    assert status["status"] == "clogged", status
    assert "arch blocks the orifice" in status["reason"]
    assert status["average_segments"] < 5  # stopped early, not run to the end


@pytest.mark.lammps
def test_paper_stiffness_runs_clean_at_smoke_size(silo_scene, smoke_variant, tmp_path, run_smoke):
    """Y = 120 GPa (the paper's k_n ~ 1e8 N/m, dt = t_c/50) on the smoke silo: no guard trips.

    Short: 0.02 s of discharge after a 0.03 s settle at ~1.6e6 steps/s... i.e. a few
    tens of thousands of steps of a few hundred particles.
    """
    scene = smoke_variant(silo_scene, Y_factor=1.0, t_discharge=0.01, t_segment=0.01, t_average=0.01,
                          dump_interval=0.005, contact_interval=0.005, thermo_interval=0.001,
                          evaporate_interval=0.001)
    scene["protocol"].update(t_settle_min=0.02, t_settle_max=0.02)
    status = run_smoke(scene, tmp_path, {"R": 3.5})
    assert status["status"] == "completed", status
    assert status["max_overlap"] < 0.01  # stiff: overlaps of a fraction of a per cent of d_min


def test_a_deep_deletion_plane_opens_the_floor_below_and_keeps_the_original_geometry_otherwise(silo_scene, smoke_variant,
                                                                                               tmp_path):
    """rungs.*.delete_depth: the floor becomes a plate (as thick as the rim's spheres) open below to R_c, and
    particles are deleted that far below the orifice; unset, the deck and parameters are the original ones."""
    from granflow.deck import render_case

    render_case(silo_scene, "smoke", tmp_path / "orig", {"R": 3.5})
    deep = smoke_variant(silo_scene, delete_depth=6.0)
    render_case(deep, "smoke", tmp_path / "deep", {"R": 3.5})
    orig_deck = (tmp_path / "orig" / "average.lmp").read_text()
    deep_deck = (tmp_path / "deep" / "average.lmp").read_text()
    assert "open union 2 main hole side in" in orig_deck and "basement" not in orig_deck
    assert "open union 3 main hole basement side in" in deep_deck
    import json

    orig = json.loads((tmp_path / "orig" / "params.json").read_text())["parameters"]
    rec = json.loads((tmp_path / "deep" / "params.json").read_text())
    deep_p = rec["parameters"]
    r_b = rec["r_b"]
    assert "z_plate" not in orig and orig["z_delete"] == pytest.approx(-1.05 * r_b)
    assert deep_p["z_delete"] == pytest.approx(-6.0 * r_b) and deep_p["z_lo"] < deep_p["z_delete"] - 3 * r_b
    assert deep_p["z_plate"] == pytest.approx(-2 * rec["rim"]["radius"])


@pytest.mark.lammps
def test_a_deep_deletion_plane_runs_and_conserves_mass(silo_scene, smoke_variant, tmp_path, run_smoke):
    """The plate geometry discharges: mass leaves only through the deletion plane, 6 r_b below the orifice."""
    import pandas as pd

    scene = smoke_variant(silo_scene, delete_depth=6.0, t_discharge=0.2, t_segment=0.1, t_average=0.2)
    status = run_smoke(scene, tmp_path, {"R": 3.5})
    assert status["status"] in ("completed", "steady"), status
    th = pd.read_csv(tmp_path / "run" / "thermo.csv")
    dis = th[th["stage"] == "average"]
    deleted = dis.groupby("segment")["v_mdel"].last().sum()
    assert deleted > 0
    m0 = th[th["stage"] == "average"]["v_mtot"].iloc[0] + dis[dis["segment"] == dis["segment"].min()]["v_mdel"].iloc[0]
    assert dis["v_mtot"].iloc[-1] + deleted == pytest.approx(m0, rel=1e-9)
