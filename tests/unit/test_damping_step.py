"""The pre-run check of the damping-limited time step (issue 31): the limit is the stability
boundary of the integrator LAMMPS runs, a strongly damped contact is refused before anything
runs with a value that passes, and every shipped scene at every rung (and every contact law
its schema allows) still passes."""
import math

import numpy as np
import pytest
import yaml
from numpy.testing import assert_allclose

from granflow import registry
from granflow.scene_files import load_scene
from granflow.schema import PROJECT_ROOT
from granflow.contact import (build_contact_model, contact_time, oscillator, spin_oscillator,
                              verlet_damping_limit)
from granflow.deck import scene_parameters
from granflow.preflight import PreflightError

#: cases the rungs' parameters accept, tried in order (as tests/integration/test_contact_physics.py)
CASES = {"heap": [{"mixture": "bi1-2", "feed_rate": q} for q in (0.033, 0.02, 0.01, 0.005, 0.003, 0.002)],
         "silo": [{"R": 3.0}]}


def lammps_step(h: float, omega_0: float, rate: float) -> np.ndarray:
    """One step of ``fix nve/sphere`` for a linear spring-dashpot (unit mass), as a matrix on
    (x, v, a): half kick, drift, force with the velocity then held (the half-step one), half kick."""
    def step(x, v, a):
        v = v + 0.5 * h * a
        x = x + h * v
        a = -omega_0**2 * x - rate * v
        return x, v + 0.5 * h * a, a
    return np.column_stack([step(*e) for e in np.eye(3)])


def spectral_radius(m: np.ndarray) -> float:
    return float(max(abs(np.linalg.eigvals(m))))


@pytest.mark.parametrize("e_n", [1.0, 0.82, 0.1, 1e-3, 1e-6])
def test_limit_is_the_stability_boundary_of_velocity_verlet(e_n):
    """Just below the limit the step matrix has spectral radius <= 1, just above > 1: the
    boundary within 0.1 % (the margins), for the normal motion and the spin mode alike."""
    omega_0, zeta = oscillator(1.0, e_n)
    for omega, rate in [(omega_0, 2 * zeta * omega_0), spin_oscillator(omega_0, 2 * zeta * omega_0, 2 / 7, 0.5)]:
        h = verlet_damping_limit(omega, rate)
        assert spectral_radius(lammps_step(0.999 * h, omega, rate)) <= 1 + 1e-12
        assert spectral_radius(lammps_step(1.001 * h, omega, rate)) > 1
    # the docstring's form: 2/w0 (sqrt(1 + zeta^2) - zeta)
    assert_allclose(verlet_damping_limit(omega_0, 2 * zeta * omega_0),
                    2 / omega_0 * (math.sqrt(1 + zeta**2) - zeta), rtol=1e-12)


def test_oscillator_inverts_contact_time():
    """omega_0 and zeta recovered from t_c and e_n are those of k, m_eff and xi_n (to rounding)."""
    k, m, xi = 1e6, 0.3645, 180.0
    t_c, e = contact_time(k, m, xi)
    omega_0, zeta = oscillator(t_c, e)
    assert_allclose([omega_0, zeta], [math.sqrt(k / m), xi / (2 * math.sqrt(k / m))], rtol=1e-12)


def test_pure_dashpot_limit():
    """No spring (k_t = 0): the spin is a dashpot alone, stable below 2/rate."""
    assert_allclose(verlet_damping_limit(0.0, 4.0), 0.5, rtol=1e-12)
    assert verlet_damping_limit(0.0, 0.0) == math.inf


def _laws(name: str) -> list[str]:
    schema = yaml.safe_load((PROJECT_ROOT / "config" / "schema" / f"{name}.schema.yaml").read_text())
    return list(schema["properties"]["contact"]["properties"]["model"]["enum"])


def _shipped():
    for name in registry.names():
        scene = load_scene(PROJECT_ROOT / "config" / "scenes" / f"{name}.yaml")
        for rung in scene["rungs"]:
            for law in [None, *_laws(name)]:
                yield pytest.param(name, rung, law, id=f"{name}-{rung}-{law or 'file'}")


@pytest.mark.parametrize("name, rung, law", list(_shipped()))
def test_every_shipped_scene_and_rung_passes(name, rung, law):
    """The scene files as shipped (their e_n 0.8-0.88), at every rung and with every law its
    schema allows (the contact-physics cases of tests/integration), pass the time-step checks."""
    scene = load_scene(PROJECT_ROOT / "config" / "scenes" / f"{name}.yaml")
    if law:
        scene["rungs"][rung]["contact_model"] = law
    refusals = []
    for case in CASES.get(name, [None]):
        try:
            scene_parameters(scene, rung, case)
            return
        except PreflightError as exc:
            refusals.append(str(exc))
    assert not [r for r in refusals if "time step" in r], refusals
    pytest.fail(f"no case of {name} at {rung} renders: {refusals}")


def test_shipped_channel_keeps_a_wide_margin():
    """The channel's smoke step is less than a third of its damping limit (e_n = 0.82)."""
    scene = load_scene(PROJECT_ROOT / "config" / "scenes" / "channel.yaml")
    model = build_contact_model(scene, scene["rungs"]["smoke"])
    dt = scene["rungs"]["smoke"]["dt_fraction"] * model.stiffest.t_c
    assert dt < model.damping_limited.dt_max / 3


@pytest.mark.parametrize("name, rung, mode", [("chute", "smoke", "normal damping"),
                                              ("channel", "smoke", "tangential damping")])
def test_strong_damping_is_refused_with_a_value_that_passes(name, rung, mode):
    """e_n = 1e-6: the chute's 1-1 pair is unstable on its own at 0.08 t_c (the limit is
    0.0595 t_c); the channel's light 0.9-0.9 pair passes alone but the spin of a sphere among its
    neighbours does not (the run stopped on the overlap guard at flow step 577). The dt_fraction
    the message offers renders."""
    scene = load_scene(PROJECT_ROOT / "config" / "scenes" / f"{name}.yaml", ["contact.e_n=1e-6"])
    with pytest.raises(PreflightError) as exc:
        scene_parameters(scene, rung)
    message = str(exc.value)
    assert "is too large: limit 2/w0 x (sqrt(1 + zeta^2) - zeta) = " in message, message
    assert f"for the {mode}" in message and "a value that passes: dt = " in message, message
    fraction = float(message.rsplit("dt_fraction = ", 1)[1].rstrip(")"))
    scene["rungs"][rung]["dt_fraction"] = fraction
    scene_parameters(scene, rung)
