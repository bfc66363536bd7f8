"""The stiff-particle rows of the channel's hard-case matrix at smoke size (the others are in
test_hard_cases.py): k_n = 1e8 runs clean at its proper step, and a step made for softer
particles is refused before LAMMPS starts. Numbers are reported in the test output."""
import pytest

from granflow.contact import build_contact_model
from granflow.preflight import PreflightError
from granflow.scenes.channel.parameters import channel_parameters

pytestmark = pytest.mark.lammps


def test_stiff_particles_with_proper_step_run_clean(channel_scene, tmp_path, smoke_variant, run_smoke):
    # k_n = 1e8 at dt = 0.08 t_c: 30x more steps per time unit than k_n = 1e5,
    # so the run is shortened (settle 5, flow 1, average 0.5 time units)
    scene = smoke_variant(channel_scene, k_n=1e8, t_flow_max=1.0, t_segment=1.0, t_average=0.5,
                  dump_interval=0.25, thermo_interval=0.25)
    scene["protocol"]["settle_time"] = 5.0
    scene["protocol"]["fill_packing"] = 0.25
    # one rank: on two, beside the other test worker, three busy processes share two cores and the ranks spin
    # while waiting for each other (313 s instead of ~60; test_hard_cases.py runs the multi-rank case)
    status = run_smoke(scene, tmp_path, {"phi_mean": 0.60})
    assert status["status"] != "unstable", status["reason"]
    assert status["dangerous_builds"] == 0
    # stiff particles barely overlap: k_n 1000x stiffer than smoke's 1e5
    assert status["max_overlap"] < 1e-3


def test_stiff_particles_with_soft_step_refused(channel_scene, smoke_variant):
    soft = build_contact_model(channel_scene, dict(channel_scene["rungs"]["smoke"], k_n=1e6))
    scene = smoke_variant(channel_scene, k_n=1e8, dt=0.08 * soft.stiffest.t_c)
    with pytest.raises(PreflightError, match="too large"):
        channel_parameters(scene, "smoke")
