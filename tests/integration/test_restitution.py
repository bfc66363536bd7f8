"""The honest check of the damping convention: a two-particle and a particle-wall
collision in LAMMPS give the restitution coefficients our contact model predicts."""
import subprocess

import pytest

from granflow.contact import build_contact_model

pytestmark = pytest.mark.lammps

DECK = """
units lj
atom_style sphere
atom_modify map array
boundary f p p
newton off
comm_modify vel yes
region box block -5 5 -5 5 -5 5
create_box 1 box
create_atoms 1 single {xa} 0 0
{second}
set group all diameter {d}
set group all density {rho}
pair_style gran/hooke/history {kn} {kt} {xin} {xit} 0.0 1
pair_coeff * *
{wall}
fix nve all nve/sphere
velocity all set 0 0 0
group a id 1
velocity a set 1.0 0 0
{vb}
timestep {dt}
variable v1 equal vx[1]
run {n}
print "VX1 ${{v1}}"
{print2}
"""


def collide(lmp, tmp_path, scene, wall: bool):
    rung = scene["rungs"]["smoke"]
    model = build_contact_model(scene, rung)
    rho = scene["particles"]["density"]
    d = 1.0
    dt = model.stiffest.t_c / 200  # fine step: integration error << tolerance below
    deck = DECK.format(
        xa=-0.6 if not wall else 4.0, d=d, rho=rho, kn=model.k_n, kt=model.k_t, xin=model.xi_n, xit=model.xi_t,
        second="" if wall else "create_atoms 1 single 0.6 0 0",
        wall=(f"fix w all wall/gran hooke/history {model.k_n} {model.k_t} {model.xi_n} {model.xi_t} 0.0 1 "
              "xplane NULL 5.0") if wall else "",
        vb="" if wall else "group b id 2\nvelocity b set -1.0 0 0",
        dt=dt, n=int(2.0 / dt), print2="" if wall else 'variable v2 equal vx[2]\nprint "VX2 ${v2}"',
    )
    (tmp_path / "in.lmp").write_text(deck)
    out = subprocess.run([lmp, "-in", "in.lmp", "-log", "none"], cwd=tmp_path, capture_output=True,
                         text=True, timeout=60).stdout
    v = {l.split()[0]: float(l.split()[1]) for l in out.splitlines() if l.startswith(("VX1", "VX2"))}
    name = "1-wall" if wall else "1-1 pair"
    expected = next(c.e_n for c in model.contacts if c.name == name)
    if wall:
        return -v["VX1"] / 1.0, expected
    return (v["VX2"] - v["VX1"]) / 2.0, expected


def test_pair_restitution_matches_model(lmp, tmp_path, channel_scene):
    e, expected = collide(lmp, tmp_path, channel_scene, wall=False)
    # requested e_n = 0.82 for the d_p pair; dt = t_c/200 keeps the Verlet error below 1e-3
    assert expected == pytest.approx(channel_scene["contact"]["e_n"], rel=1e-9)
    assert e == pytest.approx(expected, abs=3e-3)


def test_wall_restitution_matches_model(lmp, tmp_path, channel_scene):
    e, expected = collide(lmp, tmp_path, channel_scene, wall=True)
    # the wall acts as infinite mass: m_eff = m, so e differs from the pair's (gran/hooke damping is m_eff*xi)
    assert e == pytest.approx(expected, abs=3e-3)
    assert expected < channel_scene["contact"]["e_n"]
