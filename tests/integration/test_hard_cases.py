"""The hard-case matrix of the channel at smoke size: each case runs clean or ends
with a named status, never with garbage. Numbers are reported in the test output.
Its stiff-particle rows are in test_hard_cases_stiff.py (one long run: a file of its own, so
that the two xdist workers of `make test` share the load)."""
import copy

import pytest

pytestmark = pytest.mark.lammps


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
    # an impossible overlap limit trips the overlap guard on the first check; on 2 MPI ranks (the suite's
    # multi-rank run: the halt's reduction over ranks, the decomposition; it stops within seconds, so
    # its ranks never wait long on a core the other test worker holds)
    scene = copy.deepcopy(channel_scene)
    scene["guards"]["max_overlap"] = 1e-9
    status = run_smoke(scene, tmp_path, {"phi_mean": 0.60}, nprocs=2)
    assert status["nprocs"] == 2
    assert status["status"] == "unstable"
    assert "overlap" in status["reason"] and "halt_overlap" in status["reason"]
    assert (tmp_path / "run" / "logs" / "init.log").exists(), "the log of a stopped run is kept"
