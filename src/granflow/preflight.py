"""Checks run before LAMMPS starts; each refusal names quantity, value, limit and a passing value."""
from __future__ import annotations

import math

from .contact import SPIN_NEIGHBOURS, ContactModel

#: densest packing assumed when sizing neighbour lists (random close packing)
PHI_RCP = 0.64
#: LAMMPS's neighbour-list defaults (neigh_modify one / page)
LAMMPS_ONE, LAMMPS_PAGE = 2000, 100000


class PreflightError(ValueError):
    """A case that would run unsafely; the message says what would pass."""


def check_time_step(dt: float, model: ContactModel, max_fraction: float) -> None:
    """Refuse a time step that does not resolve the shortest contact.

    A linear spring-dashpot contact lasts :math:`t_c`; velocity Verlet needs
    many steps per contact to integrate the half-period of the spring
    accurately and to keep the energy error of a collision small. Ten steps per
    contact (``max_fraction = 0.1``) is the customary upper limit in DEM
    (errors in the restitution coefficient of a few per cent at ``t_c/10``, and
    rapid growth beyond); finer fractions cost proportionally more. The limit
    applies to the stiffest contact of the case: the smallest particle pair or a
    small particle against a wall.

    A strongly damped contact needs a shorter step still: velocity Verlet, damping
    with the half-step velocity as LAMMPS does, is stable only for

    .. math::

        dt < \\frac{2}{\\omega_0}\\left(\\sqrt{1 + \\zeta^2} - \\zeta\\right)

    (:func:`granflow.contact.verlet_damping_limit`), below ``0.1 t_c`` for a normal contact
    of :math:`e_n` below about :math:`3 \\times 10^{-4}`. The tangential dashpot damps the
    spin of a sphere among its neighbours more strongly still
    (:func:`granflow.contact.spin_oscillator`): the channel at :math:`e_n = 10^{-3}`,
    ``xi_t/xi_n = 0.5`` and ``dt = 0.08 t_c`` stopped on the overlap guard within 700
    steps. Every contact of the case is checked for both.
    """
    stiff = model.stiffest
    limit = max_fraction * stiff.t_c
    if dt > limit:
        raise PreflightError(
            f"time step dt = {dt:.4g} is too large: limit {max_fraction:g} x t_c = {limit:.4g} "
            f"for the stiffest contact ({stiff.name}, t_c = {stiff.t_c:.4g} at k_n = {model.k_n:.3g}); "
            f"a value that passes: dt = {0.8 * limit:.4g} (dt_fraction = {0.8 * max_fraction:g})"
        )
    damped = model.damping_limited
    if dt > damped.dt_max:
        passes = 0.8 * damped.dt_max
        fraction = f" (dt_fraction = {passes / stiff.t_c:.3g})" if math.isfinite(stiff.t_c) else ""
        motion = ("normal damping" if damped.mode == "normal" else
                  f"tangential damping (a sphere spinning against {SPIN_NEIGHBOURS} resting neighbours)")
        raise PreflightError(
            f"time step dt = {dt:.4g} is too large: limit 2/w0 x (sqrt(1 + zeta^2) - zeta) = {damped.dt_max:.4g} "
            f"for the {motion} of the {damped.contact.name} contact (e_n = {damped.contact.e_n:.3g}, damping "
            f"ratio zeta = {damped.zeta:.3g}), beyond which velocity Verlet is unstable; a value that passes: "
            f"dt = {passes:.4g}{fraction}"
        )


#: fewest particles per MPI rank `granflow run --np` accepts. A rank owns a box of the domain
#: and copies in a shell of ghost particles one cutoff (d_max + skin, ~1.1-1.3 d) deep on every
#: side; a box of 100 particles at phi = 0.6 is ~4.4 d wide and its shell holds ~2.6 ghosts per
#: owned particle, so below this a rank mostly communicates and more ranks make a run slower.
#: A floor against mistakes, not the efficient count: the planner gives a rank 10,000
#: (granflow.resources.PARTICLES_PER_RANK), and the 2k-particle demo channel still gained
#: (0.70 efficiency) on 2 ranks, ~1,000 per rank.
MIN_PARTICLES_PER_RANK = 100


def check_ranks(record: dict, nprocs: int) -> None:
    """Refuse more MPI ranks than a case has particles for (:data:`MIN_PARTICLES_PER_RANK` each).

    ``record`` is the case's ``params.json``: its ``parameters.n_particles`` (the count built),
    else ``n_particles_estimate`` (a heap's count at the end of its filling); a record with
    neither is not checked.
    """
    particles = record.get("parameters", {}).get("n_particles", record.get("n_particles_estimate"))
    if not isinstance(particles, (int, float)) or particles <= 0:
        return
    allowed = max(1, int(particles // MIN_PARTICLES_PER_RANK))
    if nprocs > allowed:
        raise PreflightError(
            f"--np {nprocs} is not allowed: the case has {int(particles):,} particles, "
            f"{particles / nprocs:.3g} per rank; allowed at most {allowed} ranks "
            f"(at least {MIN_PARTICLES_PER_RANK} particles per rank)")


def neighbor_settings(diameters: list[float], skin: float, dt: float, v_max: float) -> dict:
    """Neighbour-list settings safe for the size ratio, or a refusal.

    Two things can go wrong with polydisperse granular lists:

    * a particle moves more than ``skin/2`` between checks and a contact is
      missed: LAMMPS checks every step (``every 1 check yes``), so the skin must
      exceed twice the largest displacement in one step, ``2 v_max dt``;
    * a large particle has more neighbours than ``neigh_modify one`` allows.
      The count is bounded by filling the shell of radius
      :math:`(d_{max}+d_{min})/2 + skin` with the smallest spheres at random
      close packing; twice that bound is used, never less than LAMMPS's defaults.

    Parameters
    ----------
    v_max : float
        Largest particle speed expected (the caller's estimate, e.g. free fall).
    """
    d_min, d_max = min(diameters), max(diameters)
    step = v_max * dt
    if skin < 2.0 * step:
        raise PreflightError(
            f"neighbour skin = {skin:g} is too small: a particle at the expected top speed {v_max:.3g} "
            f"moves {step:.3g} per step, limit skin >= 2 x that = {2 * step:.3g}; "
            f"a value that passes: skin = {max(0.3, 3 * step):.3g}")
    shell = (0.5 * (d_max + d_min) + skin) ** 3 / (0.5 * d_min) ** 3
    bound = int(math.ceil(2.0 * PHI_RCP * shell))
    one = max(LAMMPS_ONE, bound)
    if one > 200000:
        raise PreflightError(
            f"size ratio d_max/d_min = {d_max / d_min:.3g} needs neighbour lists of {one} per particle, "
            f"limit 200000; a size ratio that passes: <= {((200000 / (2 * PHI_RCP)) ** (1 / 3) - 1):.3g}")
    return {"neigh_one": one, "neigh_page": max(LAMMPS_PAGE, 10 * one), "size_ratio": d_max / d_min}
