"""Time-averaged continuum fields from particle frames (after MercuryCG).

The fields are the third independent choice of a coarse-graining, with the
kernel (:mod:`postproc.kernels`) and the coordinates
(:mod:`postproc.coordinates`). :class:`FieldAccumulator` follows the analysis
lifecycle *prepare, accumulate one frame, conclude*.

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

Convention: because primitives are averaged first, fluctuations of the node's
mean velocity (and spin) *between frames* count as kinetic stress and as
temperature, exactly like fluctuations between particles within a frame.

Standard errors come from ``n_blocks`` contiguous blocks of frames (fewer if
there are fewer frames): every field is derived per block from the block's
averaged primitives and

.. math::

    \\mathrm{se}(f) = \\frac{\\operatorname{std}_{\\mathrm{ddof}=1}(f_\\mathrm{block})}
    {\\sqrt{n_\\mathrm{blocks}}} .

To bound memory for long runs, frames are summed into at most
``16 n_blocks`` sub-blocks of equal length (adjacent sub-blocks merge pairwise
when full); blocks are then formed from whole sub-blocks, so block lengths are
equal to within one sub-block (exactly equal to within one frame while fewer
than ``16 n_blocks`` frames were accumulated).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Iterable, Sequence

import numpy as np
import pandas as pd

from .coordinates import XCoordinates
from .frame import ParticleFrame
from .kernels import HeavisideBins, channel_bin_edges

#: Field names in output order.
FIELDS = ("n", "phi", "rho", "u", "Omega", "T", "sigmac", "sigmak", "sigma")

_VECTOR = ("x", "y", "z")
_TENSOR = ("xx", "yy", "zz", "xy", "xz", "yz")
_PAIRS = ((0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2))

#: Sub-blocks kept per requested block (memory bound, see module docstring).
_SUBBLOCKS_PER_BLOCK = 16


@dataclass(frozen=True)
class _Primitive:
    """An additive per-particle quantity: its width, the frame attribute it needs, its values."""

    width: int
    requires: str | None
    values: Callable[[ParticleFrame], np.ndarray]


def _outer_pairs(weight: np.ndarray, vec: np.ndarray) -> np.ndarray:
    return np.column_stack([weight * vec[:, a] * vec[:, b] for a, b in _PAIRS])


_PRIMITIVES: dict[str, _Primitive] = {
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
_FIELD_PRIMITIVES: dict[str, tuple[str, ...]] = {
    "n": ("number",),
    "phi": ("volume",),
    "rho": ("mass",),
    "u": ("mass", "momentum"),
    "Omega": ("inertia", "angular_momentum"),
    "T": ("number", *_KINETIC, "inertia", "angular_momentum", "spin_energy"),
    "sigmac": ("contact_stress",),
    "sigmak": _KINETIC,
    "sigma": (*_KINETIC, "contact_stress"),
}


def field_columns(field: str) -> list[str]:
    """Output column names of one field, e.g. ``u`` -> ``u_x, u_y, u_z``."""
    if field in ("u", "Omega"):
        return [f"{field}_{c}" for c in _VECTOR]
    if field in ("sigmac", "sigmak", "sigma"):
        return [f"{field}_{c}" for c in _TENSOR]
    return [field]


def _ratio(num: np.ndarray, den: np.ndarray) -> np.ndarray:
    """num / den, NaN where den is zero (empty nodes)."""
    return np.divide(num, den, out=np.full(np.broadcast(num, den).shape, np.nan), where=den > 0)


def _derive(mean: dict[str, np.ndarray], fields: Sequence[str], node_volumes) -> dict[str, np.ndarray]:
    """Fields from frame-averaged primitive densities (see module docstring)."""
    out: dict[str, np.ndarray] = {}
    if {"sigmak", "sigma", "T"} & set(fields):
        m, p = mean["mass"], mean["momentum"]
        pp = np.column_stack([p[:, a] * p[:, b] for a, b in _PAIRS])
        # no mass, no kinetic stress: 0, not NaN
        kinetic = mean["momentum_flux"] - np.divide(pp, m, out=np.zeros_like(pp), where=m > 0)
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
            spin = mean["angular_momentum"]
            i = mean["inertia"][:, 0]
            rotational = mean["spin_energy"][:, 0] - np.divide(
                np.sum(spin**2, axis=1), i, out=np.zeros_like(i), where=i > 0
            )
            translational = kinetic[:, :3].sum(axis=1)
            values = _ratio(translational + rotational, 6.0 * mean["number"][:, 0])
        elif field == "sigmac":
            values = mean["contact_stress"]
        elif field == "sigmak":
            values = kinetic
        elif field == "sigma":
            values = mean["contact_stress"] + kinetic
        values = values.reshape(len(values), -1)
        out.update({c: values[:, k] for k, c in enumerate(field_columns(field))})
    return out


class _BlockedSums:
    """Frame sums kept in at most ``capacity`` contiguous sub-blocks of equal length."""

    def __init__(self, capacity: int):
        self.capacity = capacity + capacity % 2
        self.sums: list[np.ndarray] = []
        self.counts: list[int] = []
        self.length = 1  # frames per full sub-block

    @property
    def n_frames(self) -> int:
        return int(sum(self.counts))

    def add(self, x: np.ndarray) -> None:
        if self.counts and self.counts[-1] < self.length:
            self.sums[-1] += x
            self.counts[-1] += 1
            return
        if len(self.sums) == self.capacity:  # all full: merge adjacent pairs
            self.sums = [a + b for a, b in zip(self.sums[::2], self.sums[1::2])]
            self.counts = [a + b for a, b in zip(self.counts[::2], self.counts[1::2])]
            self.length *= 2
        self.sums.append(np.array(x, dtype=float))
        self.counts.append(1)

    def total_mean(self) -> np.ndarray:
        return np.sum(self.sums, axis=0) / self.n_frames

    def block_means(self, n_blocks: int) -> list[np.ndarray]:
        """Means over ``min(n_blocks, n_subblocks)`` contiguous, nearly equal blocks."""
        counts = np.asarray(self.counts, dtype=float)
        nb = min(n_blocks, len(counts))
        middle = np.cumsum(counts) - 0.5 * counts
        label = np.floor(middle * nb / counts.sum()).astype(int)
        means = []
        for b in range(nb):
            members = np.flatnonzero(label == b)
            means.append(sum(self.sums[j] for j in members) / counts[members].sum())
        return means


class ConcludedResult:
    """The read side of the prepare / accumulate / conclude lifecycle.

    Subclasses set ``_result`` in ``conclude()`` and keep their per-frame sums in
    ``_sums`` (a :class:`_BlockedSums`, or None before ``prepare()``).
    """

    _result: pd.DataFrame | None = None
    _sums: "_BlockedSums | None" = None

    @property
    def result(self) -> pd.DataFrame:
        """The table returned by ``conclude()``."""
        if self._result is None:
            raise RuntimeError(f"{type(self).__name__}.result read before conclude()")
        return self._result

    @property
    def n_frames(self) -> int:
        """Frames accumulated since ``prepare()``."""
        return 0 if self._sums is None else self._sums.n_frames


class FieldAccumulator(ConcludedResult):
    """Time-averaged coarse-grained fields with block standard errors.

    Parameters
    ----------
    kernel : HeavisideBins or Gaussian
        How particles spread onto nodes (:mod:`postproc.kernels`).
    coordinates : XCoordinates or RZCoordinates
        Which coordinates the kernel resolves (:mod:`postproc.coordinates`).
    fields : sequence of str
        Any of :data:`FIELDS`: ``n`` (mean particle count per node), ``phi``
        (volume fraction), ``rho`` (mass density), ``u`` (velocity), ``Omega``
        (spin), ``T`` (granular temperature incl. rotation), ``sigmac``,
        ``sigmak``, ``sigma`` (contact, kinetic and total stress, compressive
        positive). Fields needing ``omega`` (``Omega``, ``T``) or
        ``contact_stress_volume`` (``sigmac``, ``sigma``) are omitted when the
        first frame lacks them (see :attr:`omitted_fields`).
    n_blocks : int
        Number of contiguous frame blocks for standard errors (at least 2).

    Examples
    --------
    .. code-block:: python

        acc = FieldAccumulator(HeavisideBins(channel_bin_edges((0, W))), XCoordinates((0, W)))
        acc.prepare()
        for frame in frames:
            acc.accumulate(frame)
        table = acc.conclude()
    """

    def __init__(self, kernel, coordinates, fields: Sequence[str] = FIELDS, n_blocks: int = 8):
        unknown = [f for f in fields if f not in FIELDS]
        if unknown:
            raise ValueError(f"unknown fields {unknown}; choose from {FIELDS}")
        if int(n_blocks) < 2:
            raise ValueError("n_blocks must be at least 2 for standard errors")
        self.kernel = kernel
        self.coordinates = coordinates
        self.requested_fields = tuple(f for f in FIELDS if f in fields)
        self.n_blocks = int(n_blocks)
        self._prepared = False
        self._reset()

    def _reset(self) -> None:
        self._sums: _BlockedSums | None = None
        self._fields: tuple[str, ...] | None = None
        self._omitted: dict[str, str] | None = None
        self._primitives: tuple[str, ...] = ()
        self._node_volumes: np.ndarray | None = None
        self._result: pd.DataFrame | None = None

    # lifecycle -----------------------------------------------------------------

    def prepare(self) -> None:
        """Start a new average (discarding any previous one)."""
        self._reset()
        self._sums = _BlockedSums(_SUBBLOCKS_PER_BLOCK * self.n_blocks)
        self._prepared = True

    def accumulate(self, frame: ParticleFrame) -> None:
        """Add one frame's primitive densities at every node."""
        if not self._prepared:
            raise RuntimeError("FieldAccumulator.accumulate() called before prepare()")
        if self._result is not None:
            raise RuntimeError("FieldAccumulator already concluded; call prepare() to start anew")
        if self._fields is None:
            self._resolve_fields(frame)
        missing = {
            _PRIMITIVES[p].requires
            for p in self._primitives
            if _PRIMITIVES[p].requires and getattr(frame, _PRIMITIVES[p].requires) is None
        }
        if missing:
            raise ValueError(
                f"frame at step {frame.timestep} lacks {sorted(missing)}, present in the first frame"
            )
        assignment = self.kernel.assign(self.coordinates.points(frame), self.coordinates, frame.box)
        values = np.column_stack([_PRIMITIVES[p].values(frame) for p in self._primitives])
        contributions = assignment.weight[:, None] * values[assignment.particle]
        n_nodes = self.kernel.n_nodes
        densities = np.column_stack(
            [
                np.bincount(assignment.node, weights=contributions[:, k], minlength=n_nodes)
                for k in range(contributions.shape[1])
            ]
        )
        self._sums.add(densities)

    def conclude(self) -> pd.DataFrame:
        """Derive the time-averaged fields and their standard errors.

        Returns
        -------
        pandas.DataFrame
            One row per node: node coordinate columns (``x, x_lo, x_hi`` for
            bins in ``x``), then the field columns (:func:`field_columns`),
            then ``<column>_se`` for each field column. Velocity, spin and
            temperature are NaN in nodes that never held mass.
        """
        if not self._prepared:
            raise RuntimeError("FieldAccumulator.conclude() called before prepare()")
        if self._sums is None or self._sums.n_frames == 0:
            raise RuntimeError("FieldAccumulator.conclude() called before any frame was accumulated")
        values = _derive(self._unpack(self._sums.total_mean()), self._fields, self._node_volumes)
        blocks = [
            _derive(self._unpack(mean), self._fields, self._node_volumes)
            for mean in self._sums.block_means(self.n_blocks)
        ]
        errors = {}
        for column in values:
            stack = np.array([b[column] for b in blocks])
            if len(blocks) < 2:
                errors[f"{column}_se"] = np.full(stack.shape[1], np.nan)
            else:
                errors[f"{column}_se"] = stack.std(axis=0, ddof=1) / np.sqrt(len(blocks))
        columns = {**self.kernel.node_columns(self.coordinates), **values, **errors}
        self._result = pd.DataFrame(columns)
        return self._result

    # results -------------------------------------------------------------------

    @property
    def fields(self) -> tuple[str, ...]:
        """Fields that will be computed (known after the first frame)."""
        if self._fields is None:
            raise RuntimeError("FieldAccumulator.fields read before the first frame was accumulated")
        return self._fields

    @property
    def omitted_fields(self) -> dict[str, str]:
        """Requested fields that the frames cannot provide, with the reason."""
        if self._omitted is None:
            raise RuntimeError(
                "FieldAccumulator.omitted_fields read before the first frame was accumulated"
            )
        return dict(self._omitted)

    # internals -----------------------------------------------------------------

    def _resolve_fields(self, frame: ParticleFrame) -> None:
        """Choose fields and primitives from what the first frame provides."""
        fields, omitted = [], {}
        for field in self.requested_fields:
            lacking = sorted(
                {
                    _PRIMITIVES[p].requires
                    for p in _FIELD_PRIMITIVES[field]
                    if _PRIMITIVES[p].requires and getattr(frame, _PRIMITIVES[p].requires) is None
                }
            )
            if lacking:
                omitted[field] = f"frames lack {', '.join(lacking)}"
            else:
                fields.append(field)
        self._fields, self._omitted = tuple(fields), omitted
        self._primitives = tuple(p for p in _PRIMITIVES if any(p in _FIELD_PRIMITIVES[f] for f in fields))
        self._node_volumes = self.kernel.node_volumes(self.coordinates, frame.box)

    def _unpack(self, stacked: np.ndarray) -> dict[str, np.ndarray]:
        """Split the (n_nodes, K) primitive array into named (n_nodes, width) arrays."""
        out, k = {}, 0
        for p in self._primitives:
            width = _PRIMITIVES[p].width
            out[p] = stacked[:, k : k + width]
            k += width
        return out


def profile_from_frames(
    frames: Iterable[ParticleFrame],
    W: float,
    bin_width: float = 1.0,
    wall_bin_width: float = 1.5,
    n_blocks: int = 8,
) -> pd.DataFrame:
    """Channel profiles across :math:`x` in Heaviside bins (Debnath et al. 2022).

    Walls at :math:`x = 0` and :math:`x = W`; bins from
    :func:`postproc.kernels.channel_bin_edges`. All available fields are
    computed.

    Parameters
    ----------
    frames : iterable of ParticleFrame
    W : float
        Channel width, length units.
    bin_width, wall_bin_width : float
        Interior and wall bin widths, length units.
    n_blocks : int
        Blocks for standard errors.

    Returns
    -------
    pandas.DataFrame
        See :meth:`FieldAccumulator.conclude`.
    """
    walls = (0.0, float(W))
    accumulator = FieldAccumulator(
        HeavisideBins(channel_bin_edges(walls, bin_width, wall_bin_width)),
        XCoordinates(walls=walls),
        n_blocks=n_blocks,
    )
    accumulator.prepare()
    for frame in frames:
        accumulator.accumulate(frame)
    return accumulator.conclude()
