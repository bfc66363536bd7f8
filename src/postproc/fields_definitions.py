"""What each coarse-grained field is: the primitives accumulated per frame, the fields derived from their averages.

:class:`~postproc.fields.FieldAccumulator` deposits the primitives of
:data:`PRIMITIVES` that its fields need (:data:`FIELD_PRIMITIVES`,
:data:`SPECIES_PRIMITIVES`) and, after averaging them over frames, :func:`derive`
turns them into the fields, in the columns that :func:`field_columns` and
:func:`species_columns` name. :mod:`postproc.fields` re-exports the public names.

Per frame only additive primitives are accumulated, as kernel-weighted
densities :math:`\\langle q \\rangle_n = \\sum_i w_{in} q_i` at every node
:math:`n` (for Heaviside bins :math:`w_{in} = 1/V_n`, so these are bin sums over
the bin volume):

=====================  =================================================
primitive              :math:`q_i`
=====================  =================================================
``number``             :math:`1`
``volume``             :math:`\\tfrac43 \\pi r_i^3`
``mass``               :math:`m_i`
``momentum``           :math:`m_i v_{i,a}`
``momentum_flux``      :math:`m_i v_{i,a} v_{i,b}` (xx yy zz xy xz yz)
``inertia``            :math:`I_i = \\tfrac{1}{10} m_i d_i^2`
``angular_momentum``   :math:`I_i \\Omega_{i,a}`
``spin_energy``        :math:`I_i |\\boldsymbol\\Omega_i|^2`
``contact_stress``     contact stress times volume (compressive positive)
=====================  =================================================

They are averaged over frames (overbar) and the fields derived **once**, from
the averages (Debnath et al. 2022, eqs 2.1-2.4):

.. math::

    n = \\overline{\\textstyle\\sum_i w_i}\\, V_n, \\quad
    \\phi = \\overline{\\textstyle\\sum_i w_i \\tfrac43\\pi r_i^3}, \\quad
    \\rho = \\overline{\\textstyle\\sum_i w_i m_i},

.. math::

    \\mathbf{u} = \\frac{\\overline{\\sum_i w_i m_i \\mathbf{v}_i}}{\\rho}, \\quad
    \\boldsymbol{\\Omega} = \\frac{\\overline{\\sum_i w_i I_i \\boldsymbol\\Omega_i}}
    {\\overline{\\sum_i w_i I_i}},

.. math::

    \\sigma^k_{ab} = \\overline{\\textstyle\\sum_i w_i m_i v_{i,a} v_{i,b}} - \\rho\\, u_a u_b,
    \\quad
    \\sigma^c_{ab} = \\overline{\\textstyle\\sum_i w_i \\sigma^{c}_{i,ab} V_i},
    \\quad \\sigma = \\sigma^c + \\sigma^k,

.. math::

    T = \\frac{\\operatorname{tr}\\sigma^k
    + \\overline{\\sum_i w_i I_i |\\boldsymbol\\Omega_i|^2}
    - |\\overline{\\sum_i w_i I_i \\boldsymbol\\Omega_i}|^2 / \\overline{\\sum_i w_i I_i}}
    {6\\, \\overline{\\sum_i w_i}},

which for a single frame and Heaviside bins are
:math:`T = \\frac{1}{6N}\\sum_i [m_i (\\mathbf v_i - \\mathbf u)^2 +
I_i(\\boldsymbol\\Omega_i - \\boldsymbol\\Omega)^2]` and
:math:`\\sigma = \\frac1V \\sum_i [\\sigma^c_i V_i + m_i (\\mathbf v_i - \\mathbf u)
(\\mathbf v_i - \\mathbf u)]`.

Pressures are a third of the traces (compressive positive, like the stresses;
the silo paper calls the trace itself the pressure, we divide by three):

.. math::

    p^k = \\tfrac13 \\operatorname{tr}\\sigma^k, \\quad
    p^c = \\tfrac13 \\operatorname{tr}\\sigma^c, \\quad p = p^k + p^c
    \\qquad (\\texttt{pk, pc, p}).

Convention: because primitives are averaged first, fluctuations of the node's
mean velocity (and spin) *between frames* count as kinetic stress and as
temperature, exactly like fluctuations between particles within a frame.

Species (Rubio-Largo et al. 2016, eqs 2 and 8). Given ``species`` (type ids),
mass, volume, momentum and momentum flux are also accumulated per species
:math:`j` (each particle deposits into its own species' arrays only; the totals
are their sums), and after averaging

.. math::

    \\rho_j = \\overline{\\textstyle\\sum_{i \\in j} w_i m_i}, \\quad
    \\phi_j = \\overline{\\textstyle\\sum_{i \\in j} w_i \\tfrac43\\pi r_i^3},

.. math::

    s^j_{ab} = \\overline{\\textstyle\\sum_{i\\in j} w_i m_i v'_{ia} v'_{ib}}
    = F^j_{ab} - V_a P^j_b - P^j_a V_b + \\rho_j V_a V_b, \\quad
    \\mathbf v'_i = \\mathbf v_i - \\mathbf V,

with :math:`\\mathbf V = \\mathbf u` the *total* velocity field and
:math:`F^j, \\mathbf P^j` the species' momentum flux and momentum densities;
:math:`\\sum_j s^j = \\sigma^k` exactly. Columns ``rho_s<id>``, ``phi_s<id>``,
``sigmak_s<id>_<comp>`` and ``pk_s<id>`` (:math:`\\tfrac13\\operatorname{tr} s^j`),
each present when its total field is requested.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Sequence

import numpy as np

from .frame import ParticleFrame

#: Field names in output order (the default set).
FIELDS = ("n", "phi", "rho", "u", "Omega", "T", "sigmac", "sigmak", "sigma")
#: Pressures, a third of the stress traces (compressive positive).
PRESSURES = ("pk", "pc", "p")
#: Every field an accumulator can compute, in output order.
ALL_FIELDS = FIELDS + PRESSURES
#: Fields with per-species partials when ``species`` is given.
SPECIES_FIELDS = ("phi", "rho", "sigmak", "pk")

VECTOR = ("x", "y", "z")
_PAIRS = ((0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2))


@dataclass(frozen=True)
class _Primitive:
    """An additive per-particle quantity: its width, the frame attribute it needs, its values."""

    width: int
    requires: str | None
    values: Callable[[ParticleFrame], np.ndarray]


def _outer_pairs(weight: np.ndarray, vec: np.ndarray) -> np.ndarray:
    out = np.empty((len(vec), len(_PAIRS)))
    wv = weight[:, None] * vec
    for k, (a, b) in enumerate(_PAIRS):
        np.multiply(wv[:, a], vec[:, b], out=out[:, k])
    return out


PRIMITIVES: dict[str, _Primitive] = {
    "number": _Primitive(1, None, lambda f: np.ones((len(f.mass), 1))),
    "volume": _Primitive(1, None, lambda f: f.volume[:, None]),
    "mass": _Primitive(1, None, lambda f: np.asarray(f.mass, float)[:, None]),
    "momentum": _Primitive(3, None, lambda f: f.mass[:, None] * f.velocity),
    "momentum_flux": _Primitive(6, None, lambda f: _outer_pairs(f.mass, f.velocity)),
    "inertia": _Primitive(1, "omega", lambda f: f.moment_of_inertia[:, None]),
    "angular_momentum": _Primitive(3, "omega", lambda f: f.moment_of_inertia[:, None] * f.omega),
    "spin_energy": _Primitive(
        1, "omega", lambda f: (f.moment_of_inertia * np.sum(f.omega**2, axis=1))[:, None]
    ),
    "contact_stress": _Primitive(
        6, "contact_stress_volume", lambda f: np.asarray(f.contact_stress_volume, float)
    ),
}

_KINETIC = ("mass", "momentum", "momentum_flux")
FIELD_PRIMITIVES: dict[str, tuple[str, ...]] = {
    "n": ("number",),
    "phi": ("volume",),
    "rho": ("mass",),
    "u": ("mass", "momentum"),
    "Omega": ("inertia", "angular_momentum"),
    "T": ("number", *_KINETIC, "inertia", "angular_momentum", "spin_energy"),
    "sigmac": ("contact_stress",),
    "sigmak": _KINETIC,
    "sigma": (*_KINETIC, "contact_stress"),
    "pk": _KINETIC,
    "pc": ("contact_stress",),
    "p": (*_KINETIC, "contact_stress"),
}
#: Per-species primitives of the partial fields.
SPECIES_PRIMITIVES: dict[str, tuple[str, ...]] = {
    "phi": ("volume",),
    "rho": ("mass",),
    "sigmak": _KINETIC,
    "pk": _KINETIC,
}


def field_columns(field: str, components: Sequence[str] = VECTOR) -> list[str]:
    """Output column names of one field, e.g. ``u`` -> ``u_x, u_y, u_z``.

    ``components`` names the basis (``("r", "t", "z")`` for ``rz`` fields).

    Parameters
    ----------
    field : str
        One of :data:`ALL_FIELDS`.
    components : sequence of str
        Names of the three components.

    Returns
    -------
    list of str
        Three columns for a vector (``u``, ``Omega``), six for a stress in the
        order xx yy zz xy xz yz, else the field's own name.
    """
    if field in ("u", "Omega"):
        return [f"{field}_{c}" for c in components]
    if field in ("sigmac", "sigmak", "sigma"):
        return [f"{field}_{components[a]}{components[b]}" for a, b in _PAIRS]
    return [field]


def species_columns(field: str, species_id: int, components: Sequence[str] = VECTOR) -> list[str]:
    """Columns of a species partial, e.g. ``("sigmak", 3)`` -> ``sigmak_s3_xx ...``.

    Parameters
    ----------
    field : str
        One of :data:`SPECIES_FIELDS`.
    species_id : int
        The particle type id.
    components : sequence of str
        Names of the three components.

    Returns
    -------
    list of str
        Six columns for ``sigmak``, else ``<field>_s<id>``.
    """
    if field == "sigmak":
        return [f"sigmak_s{species_id}_{components[a]}{components[b]}" for a, b in _PAIRS]
    return [f"{field}_s{species_id}"]


def _ratio(num: np.ndarray, den: np.ndarray) -> np.ndarray:
    """num / den, NaN where den is zero (empty nodes)."""
    return np.divide(num, den, out=np.full(np.broadcast(num, den).shape, np.nan), where=den > 0)


def kinetic_stress(mass: np.ndarray, momentum: np.ndarray, flux: np.ndarray) -> np.ndarray:
    """:math:`F_{ab} - P_a P_b / \\rho`, zero (not NaN) where there is no mass.

    Parameters
    ----------
    mass : ndarray, shape (n, 1)
        Mass density :math:`\\rho`.
    momentum : ndarray, shape (n, 3)
        Momentum density :math:`P`.
    flux : ndarray, shape (n, 6)
        Momentum flux density :math:`F` (xx yy zz xy xz yz).

    Returns
    -------
    ndarray, shape (n, 6)
    """
    pp = np.column_stack([momentum[:, a] * momentum[:, b] for a, b in _PAIRS])
    return flux - np.divide(pp, mass, out=np.zeros_like(pp), where=mass > 0)



def spin_fluctuation(inertia: np.ndarray, angular_momentum: np.ndarray, spin_energy: np.ndarray) -> np.ndarray:
    """:math:`E - |L|^2 / I` (the spin's energy about the node's mean spin, times 2), zero where I = 0.

    Parameters
    ----------
    inertia : ndarray, shape (n, 1)
        Moment-of-inertia density :math:`I`.
    angular_momentum : ndarray, shape (n, 3)
        Angular momentum density :math:`L`.
    spin_energy : ndarray, shape (n, 1)
        :math:`\\sum_i I_i \\omega_i^2` density :math:`E`.

    Returns
    -------
    ndarray, shape (n,)
    """
    i = inertia[:, 0]
    return spin_energy[:, 0] - np.divide(np.sum(angular_momentum**2, axis=1), i, out=np.zeros_like(i), where=i > 0)


#: how the kinetic stress and T reference the velocity (postproc.fields, "Fluctuations about the frame's
#: own mean"): about the window's time-averaged node velocity, or each frame's own
FLUCTUATIONS = ("window", "frame")
#: the columns a frame-referenced fluctuation adds to the sums
FRAME_WIDTHS = {"frame_kinetic": 6, "frame_spin": 1}


def _trace3(tensor: np.ndarray) -> np.ndarray:
    """A third of the trace of (n, 6) tensors."""
    return tensor[:, :3].sum(axis=1) / 3.0


def derive(mean: dict[str, np.ndarray], fields: Sequence[str], node_volumes,
            components: Sequence[str] = VECTOR, species: Sequence[dict[str, np.ndarray]] = (),
            species_ids: Sequence[int] = ()) -> dict[str, np.ndarray]:
    """Fields from frame-averaged primitive densities (see module docstring).

    Units follow the dump's: with its length, mass and time units L, M and τ,
    ``n`` is a count, ``phi`` dimensionless, ``rho`` M/L^3, ``u`` L/τ, ``Omega``
    1/τ (the dump's angular velocity), ``T`` M L^2/τ^2 (an energy per
    particle), stresses and pressures M/(L τ^2).

    Parameters
    ----------
    mean : dict of str to ndarray, shape (n_nodes, width)
        The averaged densities :math:`\\overline{\\sum_i w_{in} q_i}` of the
        primitives the fields need, by name (:data:`PRIMITIVES`; width 1, 3 or
        6), components in the basis of ``components``.
    fields : sequence of str
        Fields to derive, from :data:`ALL_FIELDS` (the callers check the names).
    node_volumes : ndarray, shape (n_nodes,)
        Volume attributed to each node, for ``n``.
    components : sequence of str
        Names of the three vector components.
    species : sequence of dict of str to ndarray
        Per species, its averaged primitive densities (as ``mean``).
    species_ids : sequence of int
        The type id of each entry of ``species``.

    Returns
    -------
    dict of str to ndarray, shape (n_nodes,)
        One array per column (:func:`field_columns`, :func:`species_columns`).
    """
    out: dict[str, np.ndarray] = {}
    if "frame_kinetic" in mean:                 # fluctuations about each frame's own mean, averaged
        kinetic = mean["frame_kinetic"]
    elif {"sigmak", "sigma", "T", "pk", "p"} & set(fields):
        kinetic = kinetic_stress(mean["mass"], mean["momentum"], mean["momentum_flux"])
    for field in fields:
        if field == "n":
            values = mean["number"][:, 0] * node_volumes
        elif field == "phi":
            values = mean["volume"][:, 0]
        elif field == "rho":
            values = mean["mass"][:, 0]
        elif field == "u":
            values = _ratio(mean["momentum"], mean["mass"])
        elif field == "Omega":
            values = _ratio(mean["angular_momentum"], mean["inertia"])
        elif field == "T":
            if "frame_spin" in mean:
                rotational = mean["frame_spin"][:, 0]
            else:
                rotational = spin_fluctuation(mean["inertia"], mean["angular_momentum"], mean["spin_energy"])
            translational = kinetic[:, :3].sum(axis=1)
            values = _ratio(translational + rotational, 6.0 * mean["number"][:, 0])
        elif field == "sigmac":
            values = mean["contact_stress"]
        elif field == "sigmak":
            values = kinetic
        elif field == "sigma":
            values = mean["contact_stress"] + kinetic
        elif field == "pk":
            values = _trace3(kinetic)
        elif field == "pc":
            values = _trace3(mean["contact_stress"])
        elif field == "p":
            values = _trace3(kinetic) + _trace3(mean["contact_stress"])
        values = values.reshape(len(values), -1)
        out.update({c: values[:, k] for k, c in enumerate(field_columns(field, components))})
    if species:
        out.update(_derive_species(mean, fields, components, species, species_ids))
    return out


def _derive_species(mean, fields, components, species, species_ids) -> dict[str, np.ndarray]:
    """Per-species partial fields (module docstring, eqs 2 and 8 of Rubio-Largo et al.)."""
    out: dict[str, np.ndarray] = {}
    partial = [f for f in SPECIES_FIELDS if f in fields]
    if {"sigmak", "pk"} & set(partial):
        m = mean["mass"]
        velocity = np.divide(mean["momentum"], m, out=np.zeros_like(mean["momentum"]), where=m > 0)
    for field in partial:
        for sid, sp in zip(species_ids, species):
            if field == "phi":
                values = sp["volume"][:, 0]
            elif field == "rho":
                values = sp["mass"][:, 0]
            else:
                p, ms = sp["momentum"], sp["mass"][:, 0]
                values = np.column_stack([
                    sp["momentum_flux"][:, k] - velocity[:, a] * p[:, b] - p[:, a] * velocity[:, b]
                    + ms * velocity[:, a] * velocity[:, b]
                    for k, (a, b) in enumerate(_PAIRS)
                ])
                if field == "pk":
                    values = _trace3(values)
            values = values.reshape(len(values), -1)
            out.update({c: values[:, k] for k, c in enumerate(species_columns(field, sid, components))})
    return out
