"""The hard-case matrix of the channel at smoke size: each case runs clean or ends
with a named status, never with garbage. Numbers are reported in the test output."""
import copy

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
    status = run_smoke(scene, tmp_path, {"phi_mean": 0.60}, nprocs=2)
    assert status["status"] != "unstable", status["reason"]
    assert status["dangerous_builds"] == 0
    # stiff particles barely overlap: k_n 1000x stiffer than smoke's 1e5
    assert status["max_overlap"] < 1e-3


def test_stiff_particles_with_soft_step_refused(channel_scene, smoke_variant):
    soft = build_contact_model(channel_scene, dict(channel_scene["rungs"]["smoke"], k_n=1e6))
    scene = smoke_variant(channel_scene, k_n=1e8, dt=0.08 * soft.stiffest.t_c)
    with pytest.raises(PreflightError, match="too large"):
        channel_parameters(scene, "smoke")


def test_near_jamming_is_labelled(channel_scene, tmp_path, run_smoke):
    status = run_smoke(channel_scene, tmp_path, {"phi_mean": 0.62})
    # W = 10 d_p at 0.62: the bed arrests (wall friction holds it)
    assert status["status"] == "jammed", status["reason"]
    assert status["average_segments"] == 0 and status["dumps"] == []
    assert status["dangerous_builds"] == 0


def test_below_steady_range_is_not_averaged(channel_scene, tmp_path, run_smoke):
    status = run_smoke(channel_scene, tmp_path, {"phi_mean": 0.57})
    assert status["status"] == "no_steady_state", status["reason"]
    assert "drift" in status["reason"]
    assert status["dumps"] == [], "a flow without steady state must not be averaged"


def test_guard_stops_a_runaway_with_a_named_reason(channel_scene, tmp_path, run_smoke):
    # an impossible overlap limit trips the overlap guard on the first check
    scene = copy.deepcopy(channel_scene)
    scene["guards"]["max_overlap"] = 1e-9
    status = run_smoke(scene, tmp_path, {"phi_mean": 0.60})
    assert status["status"] == "unstable"
    assert "overlap" in status["reason"] and "halt_overlap" in status["reason"]
    assert (tmp_path / "run" / "logs" / "init.log").exists(), "the log of a stopped run is kept"
