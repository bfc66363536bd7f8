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
