"""The heap rows of the hard-case matrix, at smoke size: size ratio 3 at the highest feed
rate the feed zone delivers, and the paper's stiffer check (t_c = 0.1 ms). Each runs clean
or ends with a named status; an unsafe step is refused before LAMMPS starts."""
import re

import pytest

from granflow.deck import render_case
from granflow.preflight import PreflightError
from granflow.scenes.heap.parameters import feed_plan

pytestmark = pytest.mark.lammps


def test_size_ratio_3_at_the_highest_feed_rate(heap_scene, tmp_path, smoke_variant, run_smoke):
    """1/3 mm mix at 95 % of the largest rate the smoke feed zone delivers runs to its end:
    nothing is lost and the largest overlap stays under the guard. A falling 3 mm particle kicks
    resting 1 mm ones upward faster than it fell; with a fixed box top they left the box and the
    run stopped on lost atoms, so the top shrink-wraps and they fall back."""
    # a wider gap and feed zone, entered at rest: enough particles per insertion that the
    # few large ones of a 1/3 mm mix still resolve the rate
    # (0.3 s of filling: the first impacts on the bare base are the hardest)
    scene = smoke_variant(heap_scene, steady_depth=0.5, t_segment=0.1, t_average=0.05, dump_interval=0.025,
                  T=0.012, feed_width=0.02, feed_height=0.04, feed_speed=0.0)
    # the refusal of an impossible rate names the largest feasible one
    with pytest.raises(PreflightError, match=r"largest feasible rate ([0-9.e-]+) kg/s") as exc:
        feed_plan(scene, "smoke", dict(scene["case"], mixture="bi1-3", feed_rate=1.0))
    top = 0.95 * float(re.search(r"largest feasible rate ([0-9.e-]+) kg/s", str(exc.value)).group(1))
    status = run_smoke(scene, tmp_path, {"mixture": "bi1-3", "feed_rate": round(top, 5)})
    assert status["status"] == "completed", status["reason"]
    assert status["dangerous_builds"] == 0
    assert 0 < status["max_overlap"] < scene["guards"]["max_overlap"]
    logs = "".join(p.read_text() for p in (tmp_path / "run" / "logs").glob("*.log"))
    assert "Lost atoms" not in logs
    assert "boundary        f f fm" in (tmp_path / "init.lmp").read_text()


def test_paper_stiffness_check_runs_clean(heap_scene, tmp_path, smoke_variant, run_smoke):
    """t_c = 0.1 ms (the paper's check), step 0.05 t_c_min: small overlaps, nothing lost."""
    scene = smoke_variant(heap_scene, t_c=1.0e-4, steady_depth=0.5, t_segment=0.05, t_average=0.05,
                  dump_interval=0.025, thermo_interval=0.005)
    status = run_smoke(scene, tmp_path, {"mixture": "mono1.5", "feed_rate": 0.003})
    assert status["status"] == "completed", status["reason"]
    assert status["dangerous_builds"] == 0
    # 10x shorter contacts: overlaps ~10x smaller than the ~0.3 d of t_c = 1 ms
    assert status["max_overlap"] < 0.1


def test_stiff_contacts_with_a_soft_step_are_refused(heap_scene, smoke_variant):
    scene = smoke_variant(heap_scene, t_c=1.0e-4, dt=2.0e-5)
    with pytest.raises(PreflightError, match="too large"):
        render_case(scene, "smoke", "/nonexistent/never-written", {"feed_rate": 0.003})
