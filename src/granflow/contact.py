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


#: The contact laws a scene file may name (``contact.model``, or a rung's ``contact_model``), and
#: what each one is. Every law writes the walls with LAMMPS's ``granular`` wall syntax
#: (``wall/gran granular hooke ... tangential linear_history``): the classic
#: ``wall/gran hooke/history`` of the pinned LAMMPS (22 Jul 2025) gains energy when its
#: tangential damping is zero (a sliding sphere never settles into rolling; fixed upstream in 2026).
CONTACT_LAWS = {
    "hooke/history": "one linear spring k_n and one damping rate xi_n for every pair and wall "
                     "(LAMMPS pair gran/hooke/history; the cheapest): each pair's t_c and e_n follow "
                     "from its reduced mass",
    "hooke/pair_time": "a linear spring per type pair with the same contact time t_c and restitution e_n "
                       "for every pair and wall (k_n proportional to m_eff; Fan et al. 2013): LAMMPS pair "
                       "granular, damping coeff_restitution",
    "hooke/pair_eq10": "a linear spring per type pair whose k_n follows the silo paper's eq. 10 from the "
                       "pair's R_eff and m_eff, damping for e_n (eq. 11; Rubio-Largo et al. 2016): LAMMPS "
                       "pair granular, damping coeff_restitution",
}
#: the law of a ContactModel with one spring for all pairs
SINGLE_LAW = "hooke/history"


@dataclass(frozen=True)
class TypePair:
    r"""LAMMPS coefficients of one atom-type pair, or of one type against every wall (``j is None``).

    ``k_n``, ``k_t`` in force/length; the damping is LAMMPS's ``coeff_restitution``:
    :math:`\eta_n = \sqrt{4 m_{eff} k_n/(1 + \pi^2/\ln^2 e_n)}` from each contact's own
    reduced mass, so every contact of the pair has restitution ``e_n`` exactly;
    ``t_c`` is the contact time at the pair's mean reduced mass ``m_eff``.
    """

    i: int
    j: int | None
    k_n: float
    e_n: float
    k_t: float
    m_eff: float

    @property
    def t_c(self) -> float:
        return restitution_contact_time(self.k_n, self.m_eff, self.e_n)

    @property
    def key(self) -> str:
        """The suffix of this pair's deck variables: ``1_2`` for types 1-2, ``w1`` for type 1-wall."""
        return f"w{self.i}" if self.j is None else f"{self.i}_{self.j}"


#: resting neighbours of one sphere, for the spin mode of the damping check
#: (:func:`spin_oscillator`): 6, the coordination of a packing at rest (isostatic: twice the
#: dimension); flowing beds have 4-6, so it errs on the safe side. Measured on the channel's smoke
#: case (dt = 0.08 and 0.1 t_c, e_n from 1e-6 to 0.03, xi_t/xi_n 0.25 and 0.5): the runs that
#: stopped on the overlap guard within 700 steps needed at most 1.31 x the frequency and damping of
#: one sphere's tangential contact to be unstable, those that ran needed 1.42 or more; 6 neighbours
#: give 1.46 (5 would give 1.34).
SPIN_NEIGHBOURS = 6


@dataclass(frozen=True)
class DampingLimit:
    """The largest stable step ``dt_max`` of one damped motion (``mode`` ``normal`` or ``spin``) of a
    contact, and its damping ratio ``zeta``."""

    contact: Contact
    mode: str
    dt_max: float
    zeta: float


@dataclass
class ContactModel:
    r"""Derived contact parameters of a scene at one rung.

    Attributes
    ----------
    k_n, k_t : float
        Normal and tangential stiffness (force/length). For a per-pair law, the smallest
        type pair's, for the record (the decks' overlap guard divides by each type's own k_n).
    xi_n, xi_t : float
        Normal and tangential damping rates (1/time), multiplied by m_eff in LAMMPS
        (single law; a per-pair law damps each pair for its ``e_n``).
    friction, wall_friction : float
    contacts : list of Contact
        Every species pair and every species-wall contact.
    law : str
        A key of :data:`CONTACT_LAWS`.
    type_pairs : list of TypePair
        A per-pair law's coefficients: every type pair ``i <= j`` and every type against the walls.
    xi_t_ratio : float
        Tangential over normal damping (LAMMPS granular ``linear_history``'s :math:`x_{\gamma,t}`).
    """

    k_n: float
    k_t: float
    xi_n: float
    xi_t: float
    friction: float
    wall_friction: float
    contacts: list[Contact] = field(default_factory=list)
    law: str = SINGLE_LAW
    type_pairs: list[TypePair] = field(default_factory=list)
    xi_t_ratio: float = 0.0

    @property
    def stiffest(self) -> Contact:
        """The contact with the shortest duration, which limits the time step."""
        return min(self.contacts, key=lambda c: c.t_c)

    @property
    def damping_limited(self) -> DampingLimit:
        r"""The damped motion that allows the shortest stable step, over every contact.

        Each contact gives two (see :func:`verlet_damping_limit`): its normal spring-dashpot,
        :func:`oscillator` of its ``t_c`` and ``e_n``, and the spin of a sphere against
        :data:`SPIN_NEIGHBOURS` such contacts (:func:`spin_oscillator`). An overdamped contact
        (``t_c = inf``, possible only with one damping rate for every pair) takes
        :math:`\omega_0 = \sqrt{k_n/m_{eff}}` and the rate :math:`\xi_n`.
        """
        limits = []
        for c in self.contacts:
            if math.isfinite(c.t_c) and c.e_n > 0:
                omega_0, zeta = oscillator(c.t_c, c.e_n)
                rate = 2.0 * zeta * omega_0
            else:
                omega_0, rate = math.sqrt(self.k_n / c.m_eff), self.xi_n
            omega_s, rate_s = spin_oscillator(omega_0, rate, self.k_t / self.k_n, self.xi_t_ratio)
            for mode, omega, r in (("normal", omega_0, rate), ("spin", omega_s, rate_s)):
                zeta = r / (2.0 * omega) if omega > 0 else math.inf
                limits.append(DampingLimit(c, mode, verlet_damping_limit(omega, r), zeta))
        return min(limits, key=lambda lim: lim.dt_max)

    @property
    def pair_style(self) -> str:
        """The LAMMPS pair style of the law (the cost model prices it)."""
        return "gran/hooke/history" if self.law == SINGLE_LAW else "granular"

    @property
    def per_pair(self) -> bool:
        return self.law != SINGLE_LAW

    def record(self) -> dict:
        """What params.json says of the law: its name, pair style, meaning and every type pair."""
        return {"law": self.law, "pair_style": self.pair_style, "description": CONTACT_LAWS[self.law],
                "xi_t_over_xi_n": self.xi_t_ratio,
                "type_pairs": [{"types": [p.i, "wall" if p.j is None else p.j], "k_n": p.k_n, "k_t": p.k_t,
                                "e_n": p.e_n, "m_eff_mean": p.m_eff, "t_c_mean": p.t_c}
                               for p in self.type_pairs]}


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


def restitution_contact_time(k_n: float, m_eff: float, e_n: float) -> float:
    r"""Duration of a linear contact damped for restitution ``e_n`` (LAMMPS ``coeff_restitution``).

    .. math::

        t_c = \sqrt{\frac{m_{eff}(\pi^2 + \ln^2 e_n)}{k_n}}
    """
    return math.sqrt(m_eff * (math.pi**2 + math.log(e_n) ** 2) / k_n)


def oscillator(t_c: float, e_n: float) -> tuple[float, float]:
    r"""Undamped angular frequency :math:`\omega_0` (1/time) and damping ratio :math:`\zeta` of a
    linear spring-dashpot contact that lasts ``t_c`` and has restitution ``e_n`` (underdamped).

    From :math:`t_c = \pi / (\omega_0\sqrt{1 - \zeta^2})` and
    :math:`e_n = \exp(-\zeta\omega_0 t_c)`:

    .. math::

        \zeta = \frac{-\ln e_n}{\sqrt{\pi^2 + \ln^2 e_n}}, \qquad
        \omega_0 = \frac{\sqrt{\pi^2 + \ln^2 e_n}}{t_c}

    Both laws of this module fit: one damping rate :math:`\xi_n` for every pair
    (:math:`\omega_0 = \sqrt{k_n/m_{eff}}`, :math:`\zeta = \xi_n / (2\omega_0)`) and
    ``coeff_restitution`` (:math:`\zeta` the same for every contact of restitution ``e_n``).
    """
    root = math.sqrt(math.pi**2 + math.log(e_n) ** 2)
    return root / t_c, -math.log(e_n) / root


def verlet_damping_limit(omega_0: float, rate: float) -> float:
    r"""Largest time step at which LAMMPS's velocity Verlet integrates a damped contact stably.

    A contact of reduced mass :math:`m_{eff}`, stiffness :math:`k` and damping :math:`\gamma`
    (force :math:`-k\delta - \gamma v`; :math:`\omega_0 = \sqrt{k/m_{eff}}`, the rate
    ``rate`` :math:`= \gamma/m_{eff} = 2\zeta\omega_0`, :math:`\zeta = \gamma / (2\sqrt{k m_{eff}})`)
    is integrated by ``fix nve/sphere`` as :math:`v_{n+1/2} = v_{n-1/2} + h a_n`,
    :math:`\delta_{n+1} = \delta_n + h v_{n+1/2}`, the pair style damping with the half-step
    velocity it sees when forces are computed:
    :math:`a_n = -\omega_0^2 \delta_n - 2\zeta\omega_0 v_{n-1/2}`. One step maps
    :math:`(\delta, v)` by a matrix of determinant :math:`1 - 2\zeta\omega_0 h` and trace
    :math:`2 - \omega_0^2 h^2 - 2\zeta\omega_0 h`; both eigenvalues stay inside the unit circle
    (Jury's conditions) exactly when :math:`\omega_0^2 h^2 + 4\zeta\omega_0 h < 4`, i.e.

    .. math::

        h < \frac{2}{\omega_0}\left(\sqrt{1 + \zeta^2} - \zeta\right)
          = \frac{2}{\sqrt{\omega_0^2 + (\gamma/2m_{eff})^2} + \gamma/2m_{eff}}

    (the other condition, :math:`h < 1/(\zeta\omega_0)`, is always weaker; the second form also
    holds for a pure dashpot, :math:`\omega_0 = 0`). Undamped this is the familiar
    :math:`2/\omega_0`, far above :math:`0.1\,t_c`; as :math:`e_n \to 0` (:math:`\zeta \to 1`) it
    falls below it: :math:`0.1\,t_c` at :math:`e_n \approx 3 \times 10^{-4}`,
    :math:`0.059\,t_c` at :math:`e_n = 10^{-6}`.
    """
    half = 0.5 * rate
    denominator = math.sqrt(omega_0**2 + half**2) + half
    return 2.0 / denominator if denominator > 0 else math.inf


def spin_oscillator(omega_0: float, rate: float, kt_over_kn: float, xi_t_ratio: float,
                    neighbours: int = SPIN_NEIGHBOURS) -> tuple[float, float]:
    r"""Angular frequency and damping rate (1/time) of a sphere spinning against ``neighbours``
    resting contacts of the kind whose normal motion has ``omega_0`` and damping rate ``rate``.

    The tangential spring :math:`k_t` and dashpot :math:`\gamma_t = x_t \gamma_n` (both laws:
    ``xi_t = x_t xi_n``, or ``linear_history``'s :math:`x_{\gamma,t}` times
    :math:`\eta_n = m_{eff}\,` ``rate``) act at the lever :math:`R` of a sphere of mass
    :math:`m = 2 m_{eff}` and moment of inertia :math:`I = \tfrac{2}{5} m R^2`; with its
    :math:`Z` neighbours at rest, :math:`I\ddot\theta = -Z R^2 (k_t \theta + \gamma_t \dot\theta)`:

    .. math::

        \omega_s = \omega_0 \sqrt{\tfrac{5}{4} Z \frac{k_t}{k_n}}, \qquad
        \frac{\gamma_s}{I} = \tfrac{5}{4} Z x_t \frac{\gamma_n}{m_{eff}}

    With :math:`k_t/k_n = 2/7` and :math:`Z = 6` the spin is 1.46 times as fast as the normal
    motion and, at :math:`x_t = 1/2`, 2.6 times as damped (damping ratio): with strong damping it,
    not the normal contact, limits the step.
    """
    return omega_0 * math.sqrt(1.25 * neighbours * kt_over_kn), 1.25 * neighbours * xi_t_ratio * rate


def contact_law(contact: dict, rung: dict) -> str:
    """The law a rung uses: its ``contact_model`` if it names one, else the scene's ``contact.model``."""
    return rung.get("contact_model") or contact["model"]


def per_pair_model(contact: dict, law: str, type_pairs: list[TypePair], contacts: list[Contact]) -> ContactModel:
    """The ContactModel of a per-pair law: ``type_pairs`` carry the coefficients, ``contacts`` every
    contact whose t_c and e_n the record lists (and whose shortest t_c limits the time step).

    ``k_n``/``k_t`` are the smallest type pair's (see :class:`ContactModel`); ``xi_n`` is the
    damping rate of the reference contact of the single law, kept for the record only.
    """
    if law not in CONTACT_LAWS or law == SINGLE_LAW:
        raise ValueError(f"contact law {law!r} is not a per-pair law: allowed "
                         f"{sorted(k for k in CONTACT_LAWS if k != SINGLE_LAW)}")
    soft = min((p for p in type_pairs if p.j is not None), key=lambda p: p.k_n)
    ratio = contact["xi_t_over_xi_n"]
    return ContactModel(k_n=soft.k_n, k_t=soft.k_t, xi_n=0.0, xi_t=0.0, friction=contact["friction"],
                        wall_friction=contact["wall_friction"], contacts=contacts, law=law,
                        type_pairs=type_pairs, xi_t_ratio=ratio)


def restitution_contacts(pairs: list[tuple[str, float, float, float]]) -> list[Contact]:
    """Contacts ``(name, k_n, m_eff, e_n)`` of a per-pair law: each keeps ``e_n`` exactly and lasts
    :func:`restitution_contact_time`."""
    return [Contact(name, m_eff, restitution_contact_time(k_n, m_eff, e_n), e_n) for name, k_n, m_eff, e_n in pairs]


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


def contact_block_model(contact: dict, k_n: float, xi_n: float, contacts: list[Contact]) -> ContactModel:
    """The ContactModel of a scene's ``contact`` block at stiffness k_n and damping xi_n."""
    return ContactModel(k_n=k_n, k_t=contact["kt_over_kn"] * k_n, xi_n=xi_n,
                        xi_t=contact["xi_t_over_xi_n"] * xi_n, friction=contact["friction"],
                        wall_friction=contact["wall_friction"], contacts=contacts,
                        xi_t_ratio=contact["xi_t_over_xi_n"])


def build_contact_model(scene: dict, rung: dict) -> ContactModel:
    """Contact parameters of a scene at a rung (see module docstring)."""
    p, c = scene["particles"], scene["contact"]
    diameters = p["diameters"] if scene["effects"].get("polydisperse", True) else [1.0]
    k_n = float(rung["k_n"])
    m_ref = sphere_mass(1.0, p["density"]) / 2.0
    xi_n = damping_for_restitution(k_n, m_ref, c["e_n"])
    masses = [sphere_mass(d, p["density"]) for d in diameters]
    return contact_block_model(c, k_n, xi_n,
                               _contacts(diameters, masses, k_n, xi_n, bool(scene["effects"].get("walls"))))


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
    return contact_block_model(contact, k_n, xi_n, _contacts(diameters, masses, k_n, xi_n, walls))
