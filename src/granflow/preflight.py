"""Checks run before LAMMPS starts; each refusal names quantity, value, limit and a passing value."""
from __future__ import annotations

import json
import math
from pathlib import Path

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


#: keys of a case's ``params.json`` the runner reads: dotted key -> (kind, required); kinds: ``pos`` a
#: finite number > 0, ``count`` an integer >= 0, ``count1`` an integer >= 1, ``bool``, ``dict``, ``str``
RECORD_KEYS = {
    "scene": ("str", False), "dt": ("pos", True), "t_segment": ("pos", True),
    "n_flow_segments": ("count", True), "n_average_segments": ("count", True),
    "protocol": ("dict", True), "guards": ("dict", True), "parameters": ("dict", True),
    "guards.report_overlap": ("pos", True), "protocol.average_unsteady": ("bool", False),
    "protocol.steady_window": ("pos", False), "protocol.steady_rel_tol": ("pos", False),
    "protocol.steady_fluct_tol": ("pos", False), "parameters.n_particles": ("count1", False),
    "parameters.n_segment": ("count1", False), "n_particles_estimate": ("pos", False),
}
#: the steady-state keys a record without a fixed schedule must have (the runner judges steadiness)
STEADY_KEYS = ("protocol.steady_window", "protocol.steady_rel_tol", "protocol.steady_fluct_tol")
_KINDS = {"pos": "a finite number > 0", "count": "a whole number >= 0", "count1": "a whole number >= 1",
          "bool": "true or false", "dict": "a mapping", "str": "a string"}


def _fits(kind: str, value) -> bool:
    number = isinstance(value, (int, float)) and not isinstance(value, bool)
    if kind == "pos":
        return number and math.isfinite(value) and value > 0
    if kind in ("count", "count1"):
        return number and float(value).is_integer() and value >= (kind == "count1")
    return isinstance(value, {"bool": bool, "dict": dict, "str": str}[kind])


def check_record(record, source: str = "params.json") -> dict:
    """Refuse a case record (``params.json``) the runner cannot run, naming the key that is wrong.

    ``granflow render`` writes the record; a hand edit that drops a key the runner reads, or gives
    it a value of the wrong kind (:data:`RECORD_KEYS`), raises :class:`PreflightError` (exit 2)
    before anything runs. Returns the record.
    """
    again = "; params.json is written by granflow render (or the workflow's render rule): render the case again"
    if not isinstance(record, dict):
        raise PreflightError(f"{source} is not a JSON object but {type(record).__name__}{again}")
    needed = {k for k, (_, required) in RECORD_KEYS.items() if required}
    if record.get("schedule") != "fixed":
        needed |= set(STEADY_KEYS)
    schedule = record.get("schedule")
    if schedule is not None and schedule != "fixed":
        raise PreflightError(f"{source}: key 'schedule' is {schedule!r}, allowed 'fixed' or absent{again}")
    for key, (kind, _) in RECORD_KEYS.items():
        head, _, tail = key.partition(".")
        holder = record if not tail else record.get(head)
        name = tail or head
        if not isinstance(holder, dict) or name not in holder:
            if key in needed:
                raise PreflightError(f"{source}: key {key!r} is missing; it must be {_KINDS[kind]}{again}")
            continue
        if not _fits(kind, holder[name]):
            raise PreflightError(f"{source}: key {key!r} is {holder[name]!r}, it must be {_KINDS[kind]}{again}")
    if schedule is None and record["n_flow_segments"] < 1:
        raise PreflightError(f"{source}: key 'n_flow_segments' is {record['n_flow_segments']!r}, it must be a "
                             f"whole number >= 1 (the runner judges steadiness after each flow segment){again}")
    return record


def read_record(case_dir) -> dict:
    """A case directory's ``params.json``, read and checked by :func:`check_record`."""
    path = Path(case_dir) / "params.json"
    try:
        record = json.loads(path.read_text())
    except UnicodeDecodeError as exc:
        raise PreflightError(f"{path} is not text: {exc.reason}") from None
    except ValueError as exc:
        raise PreflightError(f"{path} is not valid JSON ({exc}): render the case again") from None
    return check_record(record, str(path))
