"""Linear spring-dashpot contact parameters, computed once in Python.

The model is LAMMPS ``gran/hooke/history`` (Silbert et al. 2001 form): the
normal force is :math:`F_n = k_n \\delta - m_{eff} \\xi_n v_n`, so the damping
coefficient :math:`\\xi_n` has units of 1/time and multiplies the reduced mass of
each contact. For a contact of reduced mass :math:`m_{eff}`

.. math::

    t_c = \\frac{\\pi}{\\sqrt{k_n/m_{eff} - \\xi_n^2/4}}, \\qquad e_n = \\exp(-\\xi_n t_c / 2).

:math:`\\xi_n` is fixed by the requested :math:`e_n` for the reference pair of two
:math:`d_p` particles; every other pair (and each particle-wall contact, where the
wall has infinite mass so :math:`m_{eff} = m_i`) then has its own :math:`t_c` and
:math:`e_n`, which this module reports. Units: lengths in :math:`d_p`, masses in
:math:`m_p` (the mass of a :math:`d_p` sphere), time in :math:`\\sqrt{d_p/g}`.
With these units :math:`k_n = 10^6`, :math:`e_n = 0.82` gives :math:`\\xi_n \\approx 180`,
the pair of values of Debnath et al. (2022), Appendix A.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field


@dataclass(frozen=True)
class Contact:
    """One contact kind (particle-particle pair or particle-wall)."""

    name: str
    m_eff: float
    t_c: float
    e_n: float


@dataclass
class ContactModel:
    """Derived contact parameters of a scene at one rung.

    Attributes
    ----------
    k_n, k_t : float
        Normal and tangential stiffness (force/length).
    xi_n, xi_t : float
        Normal and tangential damping rates (1/time), multiplied by m_eff in LAMMPS.
    friction, wall_friction : float
    contacts : list of Contact
        Every species pair and every species-wall contact.
    """

    k_n: float
    k_t: float
    xi_n: float
    xi_t: float
    friction: float
    wall_friction: float
    contacts: list[Contact] = field(default_factory=list)

    @property
    def stiffest(self) -> Contact:
        """The contact with the shortest duration, which limits the time step."""
        return min(self.contacts, key=lambda c: c.t_c)


def sphere_mass(d: float, density: float) -> float:
    """Mass :math:`m = \\rho \\pi d^3 / 6` of a sphere of diameter ``d``."""
    return density * math.pi * d**3 / 6.0


def damping_for_restitution(k_n: float, m_eff: float, e_n: float) -> float:
    """Damping rate :math:`\\xi_n` giving restitution ``e_n`` for reduced mass ``m_eff``.

    .. math::

        t_c = \\sqrt{\\frac{m_{eff}(\\pi^2 + \\ln^2 e_n)}{k_n}}, \\qquad \\xi_n = -\\frac{2 \\ln e_n}{t_c}
    """
    ln_e = math.log(e_n)
    t_c = math.sqrt(m_eff * (math.pi**2 + ln_e**2) / k_n)
    return -2.0 * ln_e / t_c


def contact_time(k_n: float, m_eff: float, xi_n: float) -> tuple[float, float]:
    """Duration and restitution of a linear damped contact.

    Returns
    -------
    t_c, e_n : float
        ``t_c = inf`` and ``e_n = 0`` if the contact is overdamped.
    """
    w2 = k_n / m_eff - xi_n**2 / 4.0
    if w2 <= 0:
        return math.inf, 0.0
    t_c = math.pi / math.sqrt(w2)
    return t_c, math.exp(-xi_n * t_c / 2.0)


def _contacts(diameters, masses, k_n: float, xi_n: float, walls: bool) -> list[Contact]:
    """Every pair of the given particle sizes, and each size against a wall."""
    out = []
    for i, (di, mi) in enumerate(zip(diameters, masses)):
        for dj, mj in list(zip(diameters, masses))[i:]:
            m_eff = mi * mj / (mi + mj)
            out.append(Contact(f"{di:g}-{dj:g} pair", m_eff, *contact_time(k_n, m_eff, xi_n)))
        if walls:
            out.append(Contact(f"{di:g}-wall", mi, *contact_time(k_n, mi, xi_n)))
    return out


def _model(contact: dict, k_n: float, xi_n: float, contacts: list[Contact]) -> ContactModel:
    """The ContactModel of a scene's ``contact`` block at stiffness k_n and damping xi_n."""
    return ContactModel(k_n=k_n, k_t=contact["kt_over_kn"] * k_n, xi_n=xi_n,
                        xi_t=contact["xi_t_over_xi_n"] * xi_n, friction=contact["friction"],
                        wall_friction=contact["wall_friction"], contacts=contacts)


def build_contact_model(scene: dict, rung: dict) -> ContactModel:
    """Contact parameters of a scene at a rung (see module docstring)."""
    p, c = scene["particles"], scene["contact"]
    diameters = p["diameters"] if scene["effects"].get("polydisperse", True) else [1.0]
    k_n = float(rung["k_n"])
    m_ref = sphere_mass(1.0, p["density"]) / 2.0
    xi_n = damping_for_restitution(k_n, m_ref, c["e_n"])
    masses = [sphere_mass(d, p["density"]) for d in diameters]
    return _model(c, k_n, xi_n, _contacts(diameters, masses, k_n, xi_n, bool(scene["effects"].get("walls"))))


def contact_model_for_time(contact: dict, density: float, t_c: float, d_ref: float,
                           diameters: list[float], walls: bool = True) -> ContactModel:
    r"""One linear spring-dashpot for all pairs, set by the contact time of a reference pair.

    The heap paper fixes the collision time :math:`t_c` and restitution :math:`e`
    instead of the stiffness. For the pair of two spheres of diameter ``d_ref``
    (reduced mass :math:`m_{ref}`) this gives

    .. math::

        \xi_n = -\frac{2 \ln e}{t_c}, \qquad
        k_n = m_{ref}\left(\frac{\pi^2}{t_c^2} + \frac{\xi_n^2}{4}\right),

    where :math:`\xi_n` is LAMMPS's damping rate (force :math:`m_{eff}\xi_n v_n`),
    twice the paper's :math:`\gamma_n` (force :math:`2\gamma_n m_{eff} v_n`). With one
    :math:`k_n` for all pairs (``gran/hooke/history``) every other pair and each
    particle-wall contact has its own :math:`t_c` and :math:`e`; they are listed
    for ``diameters`` (pass the extremes of the size distribution).
    """
    m_ref = sphere_mass(d_ref, density) / 2.0
    xi_n = -2.0 * math.log(contact["e_n"]) / t_c
    k_n = m_ref * (math.pi**2 / t_c**2 + xi_n**2 / 4.0)
    masses = [sphere_mass(d, density) for d in diameters]
    return _model(contact, k_n, xi_n, _contacts(diameters, masses, k_n, xi_n, walls))
