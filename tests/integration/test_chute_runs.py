"""The chute at the smoke rung through render + run + analyse (LAMMPS, one rank each).

Three angles on an 8 x 6 d bed of depth ~10 d (k_n = 2e4, softened 10x from the
paper): 24 deg flows steadily, 15 deg stops (below theta_stop ~ 20 deg of the paper,
higher still for thin beds), 35 deg keeps accelerating (above the paper's ~26 deg).
"""
import copy

import pandas as pd
import pytest

from granflow.scene_files import load_scene
from granflow.deck import render_case
from granflow.runner import run_case
from granflow.scenes.chute import SCENE

pytestmark = pytest.mark.lammps


@pytest.fixture(scope="module")
def chute(root):
    scene = load_scene(root / "config" / "scenes" / "chute.yaml")
    # ~500 mobile particles: u_cm fluctuates by ~7 % in steady flow (measured at 24 deg), so the
    # smoke bed is judged with 10 % / 5 % instead of the demo's 5 % / 3 % (fluctuation / drift)
    scene["protocol"].update(steady_fluct_tol=0.10, steady_rel_tol=0.05)
    return scene


def run(scene, tmp_path, theta, **knobs):
    scene = copy.deepcopy(scene)
    scene["rungs"]["smoke"].update(knobs)
    case_dir = tmp_path / f"theta~{theta:g}"
    record = render_case(scene, "smoke", case_dir, {"theta_deg": theta})
    status = run_case(case_dir, 1)
    return case_dir, record, status


def verdict(case_dir, record, status):
    """The status the runner wrote: the scene's flow verdict (steady, arrested, accelerating)."""
    return status["status"]


def test_steady_flow_at_24_degrees(chute, tmp_path):
    case_dir, record, status = run(chute, tmp_path, 24.0)
    assert verdict(case_dir, record, status) == "steady", status["reason"]
    assert status["dangerous_builds"] == 0
    tables, s = SCENE.analyse(case_dir)
    n = record["parameters"]["n_particles"]
    # particles conserved: every thermo row counts all of them (a lost atom is a LAMMPS error)
    assert s["atoms_min"] == s["atoms_max"] == n
    profile = tables["profile"]
    # every mobile particle is in the profile: sum of n over bins = dumped particles per frame
    assert 0 < profile["n"].sum() < n
    assert s["max_overlap"] < record["guards"]["max_overlap"]
    # stress ratio in the bulk: the paper's exact result is tan(theta). With 10 time units of
    # averaging in a 6 x 8 d bed the bin scatter is ~5 % (measured 0.441 +- 0.020 vs 0.445)
    # allow 3 standard errors (+0.01) and never more than 12 %.
    tol = min(3 * s["stress_ratio_se"] + 0.01, 0.12 * s["tan_theta"])
    assert abs(s["stress_ratio"] - s["tan_theta"]) < tol, (s["stress_ratio"], s["stress_ratio_se"])
    # sigma_zz is the weight above: measured 4.7 % rms in the bulk of this smoke case; the
    # Heaviside binning and 21 frames leave a few per cent, 15 % flags a broken balance
    assert s["weight_residual"] < 0.15
    # the Bagnold form fits the bulk velocity, but only roughly in this 10 d bed near theta_stop
    # (measured R^2 = 0.92 with the two-layer base; the paper finds Bagnold in thicker beds, and
    # thin beds nearer a linear profile): R^2 > 0.85 still tells a shear flow from a plug or a mess
    assert s["bagnold_A"] > 0 and s["bagnold_r2"] > 0.85
    # the bed is a dense flow: bulk phi between the paper's ~0.52 (steep) and random close packing
    assert 0.50 < s["phi_bulk"] < 0.64
    assert "smoke" in s["provenance"] and "steady" in s["provenance"]


def test_low_angle_arrests(chute, tmp_path):
    case_dir, record, status = run(chute, tmp_path, 15.0, t_flow_max=100.0)
    assert verdict(case_dir, record, status) == "arrested", status["reason"]
    tables, s = SCENE.analyse(case_dir)
    assert tables == {} and s["status"] == status["status"]


def test_high_angle_accelerates(chute, tmp_path):
    case_dir, record, status = run(chute, tmp_path, 35.0, t_flow_max=60.0)
    assert verdict(case_dir, record, status) == "accelerating", status["reason"]
    thermo = pd.read_csv(case_dir / "run" / "thermo.csv")
    # no steady state: the downslope speed at the end exceeds that at mid-run
    u = thermo["v_ucm"].to_numpy()
    assert u[-1] > u[len(u) // 2] > 0
