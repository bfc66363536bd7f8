"""Checks run before LAMMPS starts; each refusal names quantity, value, limit and a passing value."""
from __future__ import annotations

from .contact import ContactModel


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
