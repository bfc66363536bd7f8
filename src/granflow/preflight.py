"""Checks run before LAMMPS starts; each refusal names quantity, value, limit and a passing value."""
from __future__ import annotations

import math

from .contact import ContactModel

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
    """
    stiff = model.stiffest
    limit = max_fraction * stiff.t_c
    if dt > limit:
        raise PreflightError(
            f"time step dt = {dt:.4g} is too large: limit {max_fraction:g} x t_c = {limit:.4g} "
            f"for the stiffest contact ({stiff.name}, t_c = {stiff.t_c:.4g} at k_n = {model.k_n:.3g}); "
            f"a value that passes: dt = {0.8 * limit:.4g} (dt_fraction = {0.8 * max_fraction:g})"
        )


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
