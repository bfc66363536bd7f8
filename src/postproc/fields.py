"""Time-averaged continuum fields from particle frames (after MercuryCG).

The fields are the third independent choice of a coarse-graining, with the
kernel (:mod:`postproc.kernels`) and the coordinates
(:mod:`postproc.coordinates`). :class:`FieldAccumulator` follows the analysis
lifecycle *prepare, accumulate one frame, conclude*.

Per frame only additive primitives are accumulated, and the fields are derived
once, from their averages over frames: the primitives, the formulas (species
partials included) and their conventions are in :mod:`postproc.fields_definitions`.

Components. With Cartesian coordinates
(:class:`~postproc.coordinates.CartesianCoordinates`, e.g.
:class:`~postproc.coordinates.XCoordinates`) vectors and tensors are Cartesian
(``u_x``, ``sigmak_xy``). With :class:`~postproc.coordinates.RZCoordinates` or
:class:`~postproc.coordinates.RCoordinates` every particle's vectors and tensors
are first expressed in the cylindrical basis at its own azimuth, so the columns
are ``u_r u_t u_z`` and ``<f>_rr _tt _zz _rt _rz _tz`` (``t`` for
:math:`\\theta`): exact for :math:`z` components and for the pressures, accurate
to :math:`O(w/r)` for the others within a few kernel widths :math:`w` of the axis
(see :class:`~postproc.coordinates.RZCoordinates`).

Volume fraction in slabs. By default (``volume="centre"``) each particle's
whole volume is deposited with the kernel at its centre. With Heaviside bins
along one Cartesian axis, ``volume="exact"`` instead splits each sphere's volume
exactly over the slabs :math:`[e_k, e_{k+1})` it overlaps (spherical caps,
:func:`postproc.overlap.sphere_slab_fraction`),

.. math::

    \\phi_k = \\overline{\\textstyle\\sum_i \\tfrac43\\pi r_i^3 f_{ik}} / V_k, \\qquad
    f_{ik} = F(e_{k+1} - x_i) - F(e_k - x_i), \\quad
    F(h) = \\tfrac14 (1 + \\hat h)^2 (2 - \\hat h), \\ \\hat h = \\operatorname{clip}(h / r_i, -1, 1),

which removes the spurious layering of :math:`\\phi` in slabs narrower than a
few diameters (near walls, say). Only the ``volume`` primitive changes
(:math:`\\phi` and the species :math:`\\phi_j`); parts of spheres beyond the
outer edges are lost.

Fluctuations about the frame's own mean. By default (``fluctuation="window"``) the
kinetic stress and the granular temperature are fluctuations about the *time-averaged*
velocity at a node, :math:`\\overline{F} - \\overline{P}\\,\\overline{P}/\\overline{\\rho}`: a
region moving as one body whose speed changes over the window (a channel's plug) then
counts that change as agitation. With ``fluctuation="frame"`` they are fluctuations about
each frame's own node velocity, averaged over the frames,
:math:`\\overline{F - P P/\\rho}` (and likewise for the spin), as a bin's
:math:`T = \\frac{1}{6N}\\sum_i m_i (\\mathbf v_i - \\mathbf v)^2 + \\ldots` over the
:math:`N` particles in the bin at one instant reads (Debnath et al. 2022, eqs. 2.1-2.4).
Only ``T``, ``sigmak``, ``sigma``, ``pk`` and ``p`` change; species partials stay about
the window's mean.

Contact stress from contacts (paper eq. 5). Given a
:class:`~postproc.contacts.ContactFrame` to :meth:`FieldAccumulator.accumulate`,
the contact stress is the line integral along the branch vectors, each pair once,

.. math::

    \\sigma^c_{ab}(\\mathbf r) = \\sum_{\\text{pairs}} f_{ij,a}\\, r_{ij,b}
    \\int_0^1 \\phi(\\mathbf r - \\mathbf x_i + s\\,\\mathbf r_{ij})\\,\\mathrm ds,
    \\qquad \\mathbf r_{ij} = \\mathbf x_i - \\mathbf x_j,

compressive positive (:math:`\\mathbf f_{ij}\\cdot\\mathbf r_{ij} > 0` for
repulsion; the paper's eq. 5 has the opposite sign and counts each pair twice
with a factor 1/2), symmetrised, with the :math:`s`-integral by Gauss-Legendre
points along the segment (:func:`postproc.contacts.branch_quadrature`), each
deposited with the accumulator's kernel and expressed in the basis at that point.
The paper resolves the contact stress with a narrower kernel (:math:`w = r_b/2`)
than the other fields (:math:`w = 2 r_b`): run a second accumulator with
``fields=("sigmac", "pc")`` and its own kernel, and pass it the same frames and
contacts; it deposits nothing per particle.

Standard errors allow for the correlation of consecutive frames. To bound
memory for long runs, frames are summed into at most ``16 n_blocks``
sub-blocks of equal length (adjacent sub-blocks merge pairwise when full, so
between ``8 n_blocks`` and ``16 n_blocks`` of them once that many frames were
accumulated; one frame each before). Every field :math:`f` is derived from
each sub-block's averaged primitives, exactly as from the average over all
frames, and ``<column>_se`` is the error of the time average of that series
:math:`f_i` with its statistical inefficiency :math:`g`
(:func:`postproc.autocorr.weighted_mean_error`,
:func:`postproc.blocks.correlated_errors`):

.. math::

    \\mathrm{se}_g(f) = \\sqrt{g\\,\\frac{n}{n-1}\\,
    \\frac{\\sum_i c_i^2 (f_i - \\bar f)^2}{(\\sum_i c_i)^2}}

(:math:`c_i` frames in sub-block :math:`i`, :math:`n` sub-blocks). While
:math:`g` is not reliable (:math:`n < 50\\,g`, emcee's criterion) the error is
the larger of :math:`\\mathrm{se}_g` and the block error
(:func:`postproc.autocorr.combined_error`), which is derived likewise from
``n_blocks`` contiguous blocks formed from whole sub-blocks (block lengths
equal to within one sub-block):

.. math::

    \\mathrm{se}_\\mathrm{block}(f) = \\frac{\\operatorname{std}_{\\mathrm{ddof}=1}(f_\\mathrm{block})}
    {\\sqrt{n_\\mathrm{blocks}}} ;

with fewer than four finite sub-blocks it is the block error alone. The block
error stays available as a cross-check (:attr:`FieldAccumulator.block_errors`).
A node whose field is NaN in some sub-blocks (it held no mass then) takes
:math:`\\mathrm{se}_g` from its finite sub-blocks.
"""
from __future__ import annotations

import warnings
from dataclasses import replace
from typing import Callable, Sequence

import numpy as np
import pandas as pd

from .blocks import SUBBLOCKS_PER_BLOCK, ConcludedResult, BlockedSums, time_average_errors
from .contacts import ContactFrame, branch_quadrature
from .fields_definitions import (ALL_FIELDS, FIELD_PRIMITIVES, FIELDS, FLUCTUATIONS, FRAME_WIDTHS,  # noqa: F401
                                 PRESSURES, PRIMITIVES, SPECIES_FIELDS, SPECIES_PRIMITIVES, VECTOR, derive,
                                 field_columns, kinetic_stress, species_columns, spin_fluctuation)
from .frame import ParticleFrame
from .kernels import HeavisideBins
from .overlap import slab_pairs

#: Below this fraction of the particles' kernel weight on the grid, :meth:`FieldAccumulator.conclude`
#: warns (:class:`SparseGridWarning`): the axis or the range probably misses the material.
SPARSE_GRID_FRACTION = 0.01


class SparseGridWarning(UserWarning):
    """The grid holds (almost) none of the particles' weight: a wrong axis or range, most likely."""


class FieldAccumulator(ConcludedResult):
    """Time-averaged coarse-grained fields with correlation-aware standard errors.

    Parameters
    ----------
    kernel : HeavisideBins, Gaussian or Lucy
        How particles spread onto nodes (:mod:`postproc.kernels`).
    coordinates : CartesianCoordinates, XCoordinates, RCoordinates or RZCoordinates
        Which coordinates the kernel resolves (:mod:`postproc.coordinates`); also
        the basis of vector and tensor components (module docstring).
    fields : sequence of str
        Any of :data:`ALL_FIELDS`: ``n`` (mean particle count per node), ``phi``
        (volume fraction), ``rho`` (mass density), ``u`` (velocity), ``Omega``
        (spin), ``T`` (granular temperature incl. rotation), ``sigmac``,
        ``sigmak``, ``sigma`` (contact, kinetic and total stress, compressive
        positive), ``pk``, ``pc``, ``p`` (their pressures, a third of the
        traces). Fields needing ``omega`` (``Omega``, ``T``) or a contact stress
        (``sigmac``, ``sigma``, ``pc``, ``p``: from contacts, or else from
        ``contact_stress_volume``) are omitted when the first frame lacks them
        (see :attr:`omitted_fields`). Default :data:`FIELDS`.
    n_blocks : int
        Number of contiguous frame blocks of the block error (at least 2), which
        the standard errors never fall below while the autocorrelation estimate is
        not reliable; frames are kept in ``16 n_blocks`` sub-blocks (module docstring).
    species : sequence of int, optional
        Particle type ids; adds the per-species partials of :data:`SPECIES_FIELDS`
        (module docstring). Every particle's type must be listed.
    method : {"auto", "compiled", "numpy"}
        Deposit path of a :class:`~postproc.kernels.Gaussian` kernel (``numpy``
        is the reference; Heaviside bins and Lucy always use numpy).
    volume : {"centre", "exact"}
        How particle volumes (``phi`` and the species ``phi``) are deposited:
        ``centre``, the whole sphere with the kernel at its centre; ``exact``,
        each sphere split exactly over the slabs it overlaps (module docstring),
        only with :class:`~postproc.kernels.HeavisideBins` on a one-axis
        Cartesian coordinate system.

    Examples
    --------
    .. code-block:: python

        acc = FieldAccumulator(HeavisideBins(channel_bin_edges((0, W))), XCoordinates((0, W)))
        acc.prepare()
        for frame in frames:
            acc.accumulate(frame)
        table = acc.conclude()

    The silo (Rubio-Largo et al. 2016): bulk fields with :math:`w = 2 r_b` and
    the contact stress with :math:`w = r_b / 2`, from the same frames:

    .. code-block:: python

        rz = RZCoordinates()
        bulk = FieldAccumulator(Gaussian.paper(2 * r_b, (r_nodes, z_nodes)), rz,
                                fields=("phi", "rho", "u", "sigmak", "pk"), species=range(1, 8))
        contact = FieldAccumulator(Gaussian.paper(r_b / 2, (r_fine, z_fine)), rz,
                                   fields=("sigmac", "pc"))
        for acc in (bulk, contact):
            acc.prepare()
        for frame, contacts in zip(frames, contact_frames):
            bulk.accumulate(frame)
            contact.accumulate(frame, contacts)
    """

    def __init__(self, kernel, coordinates, fields: Sequence[str] = FIELDS, n_blocks: int = 8,
                 species: Sequence[int] | None = None, method: str = "auto", volume: str = "centre",
                 fluctuation: str = "window"):
        unknown = [f for f in fields if f not in ALL_FIELDS]
        if unknown:
            raise ValueError(f"unknown fields {unknown}; choose from {ALL_FIELDS}")
        if int(n_blocks) < 2:
            raise ValueError("n_blocks must be at least 2 for standard errors")
        if method not in ("auto", "compiled", "numpy"):
            raise ValueError(f"method must be 'auto', 'compiled' or 'numpy', not {method!r}")
        self.kernel = kernel
        self.coordinates = coordinates
        self.requested_fields = tuple(f for f in ALL_FIELDS if f in fields)
        self.n_blocks = int(n_blocks)
        self.species = None if species is None else tuple(int(t) for t in species)
        if self.species is not None and (not self.species or len(set(self.species)) != len(self.species)):
            raise ValueError(f"species must be distinct type ids, got {species!r}")
        self.method = method
        if volume not in ("centre", "exact"):
            raise ValueError(f"volume must be 'centre' or 'exact', not {volume!r}")
        if volume == "exact" and not (
            isinstance(kernel, HeavisideBins) and getattr(coordinates, "cartesian", False)
            and len(coordinates.names) == 1
        ):
            raise ValueError(
                "volume='exact' is supported only with HeavisideBins on a one-axis Cartesian coordinate "
                f"system (e.g. XCoordinates); got {type(kernel).__name__} on "
                f"{type(coordinates).__name__} {tuple(coordinates.names)}"
            )
        self.volume = volume
        if fluctuation not in FLUCTUATIONS:
            raise ValueError(f"fluctuation must be one of {FLUCTUATIONS}, not {fluctuation!r}")
        self.fluctuation = fluctuation
        self._prepared = False
        self._reset()

    def _reset(self) -> None:
        self._sums: BlockedSums | None = None
        self._n_particles = 0
        self.coverage: float | None = None
        self._fields: tuple[str, ...] | None = None
        self._omitted: dict[str, str] | None = None
        self._primitives: tuple[str, ...] = ()
        self._species_primitives: tuple[str, ...] = ()
        self._contact_source: str | None = None  # "contacts", "per_atom" or None
        self._frame_parts: tuple[str, ...] = ()  # frame-referenced fluctuations, appended last
        self._node_volumes: np.ndarray | None = None
        self._result: pd.DataFrame | None = None
        self._block_errors: pd.DataFrame | None = None

    @property
    def components(self) -> tuple[str, ...]:
        """Names of the vector components (``x y z`` or ``r t z``)."""
        return tuple(getattr(self.coordinates, "components", VECTOR))

    # lifecycle -----------------------------------------------------------------

    def prepare(self) -> None:
        """Start a new average (discarding any previous one)."""
        self._reset()
        self._sums = BlockedSums(SUBBLOCKS_PER_BLOCK * self.n_blocks)
        self._prepared = True

    def accumulate(self, frame: ParticleFrame, contacts: ContactFrame | None = None) -> None:
        """Add one frame's primitive densities at every node.

        Parameters
        ----------
        frame : ParticleFrame
        contacts : ContactFrame, optional
            The frame's contacts (same timestep); when given, the contact stress
            comes from them (module docstring), else from the frame's
            ``contact_stress_volume``. The choice made on the first frame holds
            for the whole average.

        Raises
        ------
        RuntimeError
            Before :meth:`prepare`, or after :meth:`conclude`.
        ValueError
            If the frame lacks what the first frame had (spins, per-atom stress,
            contacts, types), has a type not in ``species``, or its contacts do not
            match it (another step, no ids).
        KeyError
            If a contact names an id absent from the frame.
        """
        if not self._prepared:
            raise RuntimeError("FieldAccumulator.accumulate() called before prepare()")
        if self._result is not None:
            raise RuntimeError("FieldAccumulator already concluded; call prepare() to start anew")
        if self._fields is None:
            self._resolve_fields(frame, contacts)
        self._check_frame(frame, contacts)
        local = self._local_frame(frame)
        parts = []
        particle_primitives = [p for p in self._primitives if self._per_particle(p)]
        if particle_primitives:
            totals, by_species = self._deposit_particles(local, particle_primitives)
            parts.append(totals)
        if self._contact_source == "contacts" and "contact_stress" in self._primitives:
            parts.append(self._contact_density(frame, contacts))
        if self._species_primitives:
            parts.append(by_species)
        if self._frame_parts:
            parts.append(self._frame_fluctuations(totals, particle_primitives))
        self._sums.add(np.column_stack(parts))
        self._n_particles += len(frame.mass)

    def conclude(self) -> pd.DataFrame:
        """Derive the time-averaged fields and their standard errors.

        Returns
        -------
        pandas.DataFrame
            One row per node: node coordinate columns (``x, x_lo, x_hi`` for
            bins in ``x``), then the field columns (:func:`field_columns`),
            then the species partials (:func:`species_columns`), then
            ``<column>_se`` for each of these: the standard error of the time
            average allowing for autocorrelation, at least the block error
            while the autocorrelation estimate is not reliable (module
            docstring; the block errors alone are in :attr:`block_errors`).
            Velocity, spin and temperature are NaN in nodes that never held
            mass.

        Raises
        ------
        RuntimeError
            Before :meth:`prepare`, or before any frame was accumulated.
        """
        if not self._prepared:
            raise RuntimeError("FieldAccumulator.conclude() called before prepare()")
        if self._sums is None or self._sums.n_frames == 0:
            raise RuntimeError("FieldAccumulator.conclude() called before any frame was accumulated")
        mean = self._sums.total_mean()
        self._check_coverage(mean)
        values = self._derive(mean)
        se, se_block = time_average_errors(self._sums, self._derive, list(values), self.n_blocks)
        nodes = self.kernel.node_columns(self.coordinates)
        errors = {f"{column}_se": se[column] for column in values}
        self._block_errors = pd.DataFrame({**nodes, **{f"{c}_se": se_block[c] for c in values}})
        self._result = pd.DataFrame({**nodes, **values, **errors})
        return self._result

    def errors_of(self, fn: Callable[[dict], dict], names: Sequence[str]) -> tuple[dict, dict]:
        """Quantities derived from the averaged fields across nodes (a gradient, a difference of two nodes), with
        correlation-aware standard errors as the fields' own: ``fn`` is applied to the whole average and to each
        block and sub-block, so what moves every node at once (a whole profile's change of speed) leaves a
        gradient's error alone, where propagating the nodes' errors as independent would count it.

        Parameters
        ----------
        fn : callable
            The fields of one average (``{column: (n_nodes,) array}``, the result's columns) to
            ``{name: array}``.
        names : sequence of str
            The keys of ``fn``'s output to give errors for.

        Returns
        -------
        values, se : dict of str to ndarray

        Raises
        ------
        RuntimeError
            Before :meth:`conclude`.
        """
        if self._result is None:
            raise RuntimeError("FieldAccumulator.errors_of() called before conclude()")

        def derived(stacked: np.ndarray) -> dict:
            return fn(self._derive(stacked))

        se, _ = time_average_errors(self._sums, derived, list(names), self.n_blocks)
        return derived(self._sums.total_mean()), se

    @property
    def block_errors(self) -> pd.DataFrame:
        """The block errors, the cross-check of ``<column>_se`` (module docstring).

        Same rows and columns as :attr:`result` without the field values: node
        coordinates, then ``<column>_se`` holding
        :math:`\\operatorname{std}_{\\mathrm{ddof}=1}(f_\\mathrm{block})/\\sqrt{n_\\mathrm{blocks}}`
        (NaN with fewer than two blocks). Kept out of :attr:`result` so that every
        column of the result not ending in ``_se`` is a field.
        """
        if self._block_errors is None:
            raise RuntimeError("FieldAccumulator.block_errors read before conclude()")
        return self._block_errors

    def _check_coverage(self, mean: np.ndarray) -> None:
        """Set :attr:`coverage` and warn when the grid holds almost none of the particles.

        ``coverage`` is the mean number of particles on the grid,
        :math:`\\sum_n \\bar n_n V_n` (kernel weight inside the grid), over the
        mean number per frame; None when the ``number`` primitive is not
        accumulated (fields ``n`` or ``T``) or the frames hold no particles.
        """
        if "number" not in self._primitives or self._n_particles == 0:
            return
        totals, _ = self._unpack(mean)
        on_grid = float(np.sum(totals["number"][:, 0] * self._node_volumes))
        per_frame = self._n_particles / self._sums.n_frames
        self.coverage = on_grid / per_frame
        if self.coverage < SPARSE_GRID_FRACTION:
            warnings.warn(SparseGridWarning(
                f"the grid holds {on_grid:.3g} of the {per_frame:.3g} particles per frame "
                f"({100 * self.coverage:.2g} % of their kernel weight): check the axis of the coordinates "
                f"and the grid's range"), stacklevel=3)

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

    def _per_particle(self, primitive: str) -> bool:
        """Deposited from particles (all but the contact stress taken from contacts)."""
        return not (primitive == "contact_stress" and self._contact_source == "contacts")

    def _resolve_fields(self, frame: ParticleFrame, contacts: ContactFrame | None) -> None:
        """Choose fields and primitives from what the first frame provides."""
        if contacts is not None:
            self._contact_source = "contacts"
        elif frame.contact_stress_volume is not None:
            self._contact_source = "per_atom"
        fields, omitted = [], {}
        for field in self.requested_fields:
            lacking = set()
            for p in FIELD_PRIMITIVES[field]:
                if p == "contact_stress":
                    if self._contact_source is None:
                        lacking.add("contacts or contact_stress_volume")
                elif PRIMITIVES[p].requires and getattr(frame, PRIMITIVES[p].requires) is None:
                    lacking.add(PRIMITIVES[p].requires)
            if lacking:
                omitted[field] = f"frames lack {', '.join(sorted(lacking))}"
            else:
                fields.append(field)
        self._fields, self._omitted = tuple(fields), omitted
        self._primitives = tuple(p for p in PRIMITIVES if any(p in FIELD_PRIMITIVES[f] for f in fields))
        if self.species is not None:
            wanted = {p for f in fields if f in SPECIES_PRIMITIVES for p in SPECIES_PRIMITIVES[f]}
            self._species_primitives = tuple(p for p in PRIMITIVES if p in wanted)
            # the totals of a species primitive are the sums over the species
            self._primitives = tuple(p for p in PRIMITIVES if p in self._primitives or p in wanted)
        self._node_volumes = self.kernel.node_volumes(self.coordinates, frame.box)
        if self.fluctuation == "frame" and {"T", "sigmak", "sigma", "pk", "p"} & set(fields):
            self._frame_parts = ("frame_kinetic",) + (("frame_spin",) if "T" in fields else ())

    def _frame_fluctuations(self, totals: np.ndarray, primitives: Sequence[str]) -> np.ndarray:
        """This frame's kinetic stress density about its own node velocity, :math:`F - PP/\\rho` (6
        columns), and, for T, its spin energy about its own node spin, :math:`E - L^2/I` (1 column)."""
        mean, k = {}, 0
        for p in primitives:
            width = PRIMITIVES[p].width
            mean[p] = totals[:, k : k + width]
            k += width
        out = [kinetic_stress(mean["mass"], mean["momentum"], mean["momentum_flux"])]
        if "frame_spin" in self._frame_parts:
            out.append(spin_fluctuation(mean["inertia"], mean["angular_momentum"], mean["spin_energy"])[:, None])
        return np.column_stack(out)

    def _check_frame(self, frame: ParticleFrame, contacts: ContactFrame | None) -> None:
        missing = {
            PRIMITIVES[p].requires
            for p in self._primitives
            if self._per_particle(p) and PRIMITIVES[p].requires
            and getattr(frame, PRIMITIVES[p].requires) is None
        }
        if missing:
            raise ValueError(
                f"frame at step {frame.timestep} lacks {sorted(missing)}, present in the first frame"
            )
        if self._contact_source == "contacts" and "contact_stress" in self._primitives and contacts is None:
            raise ValueError(f"frame at step {frame.timestep} comes without contacts, the first frame had them")
        if self.species is not None and frame.type is None:
            raise ValueError(f"frame at step {frame.timestep} has no particle types; species need them")

    def _local_frame(self, frame: ParticleFrame) -> ParticleFrame:
        """The frame with vectors and tensors in the coordinates' basis at each particle."""
        if self.coordinates.cartesian:
            return frame
        c = self.coordinates
        return replace(
            frame,
            velocity=c.local_vectors(frame.position, frame.velocity),
            omega=None if frame.omega is None else c.local_vectors(frame.position, frame.omega),
            contact_stress_volume=None if frame.contact_stress_volume is None
            else c.local_tensors(frame.position, frame.contact_stress_volume),
        )

    def _deposit(self, points, values, box, groups=None, n_groups: int = 1) -> np.ndarray:
        return self.kernel.deposit(points, values, self.coordinates, box, groups, n_groups, method=self.method)

    def _species_index(self, frame: ParticleFrame) -> np.ndarray:
        types = np.rint(np.asarray(frame.type, dtype=float)).astype(np.int64)
        ids = np.asarray(self.species)
        order = np.argsort(ids)
        where = np.clip(np.searchsorted(ids[order], types), 0, len(ids) - 1)
        known = ids[order][where] == types
        if not np.all(known):
            raise ValueError(f"frame at step {frame.timestep} has particle types "
                             f"{np.unique(types[~known]).tolist()} not among species {list(self.species)}")
        return order[where]

    def _deposit_particles(self, frame: ParticleFrame, primitives: Sequence[str]):
        """Total densities (n_nodes, K) and per-species ones flattened to (n_nodes, S K_s)."""
        values = np.empty((len(frame.mass), sum(PRIMITIVES[p].width for p in primitives)))
        k = 0
        for p in primitives:
            width = PRIMITIVES[p].width
            values[:, k : k + width] = PRIMITIVES[p].values(frame)
            k += width
        points = self.coordinates.points(frame)
        exact = self.volume == "exact" and "volume" in primitives
        if exact:
            k_volume = sum(PRIMITIVES[p].width for p in primitives[: list(primitives).index("volume")])
        if self.species is None:
            dens = self._deposit(points, values, frame.box)
            if exact:
                dens[:, :, k_volume] = self._exact_volume(frame, points)
            return dens[0], None
        n_species = len(self.species)
        groups = self._species_index(frame)
        dens = self._deposit(points, values, frame.box, groups, n_species)
        if exact:
            dens[:, :, k_volume] = self._exact_volume(frame, points, groups, n_species)
        columns, k = [], 0
        for p in primitives:
            width = PRIMITIVES[p].width
            if p in self._species_primitives:
                columns.extend(range(k, k + width))
            k += width
        by_species = dens[:, :, columns].transpose(1, 0, 2).reshape(dens.shape[1], -1)
        return dens.sum(axis=0), by_species

    def _exact_volume(self, frame: ParticleFrame, points, groups=None, n_groups: int = 1) -> np.ndarray:
        """Sphere volumes split exactly over the slabs, per slab volume, shape (n_groups, n_slabs)."""
        (edges,) = self.kernel.edges
        particle, slab, fraction = slab_pairs(np.asarray(points, float)[:, 0], frame.radius, edges)
        n_slabs = len(edges) - 1
        index = slab if groups is None else groups[particle] * n_slabs + slab
        volumes = self.kernel.node_volumes(self.coordinates, frame.box)  # this frame's, as the bins' weights
        weight = fraction * frame.volume[particle] / volumes[slab]
        return np.bincount(index, weights=weight, minlength=n_groups * n_slabs).reshape(n_groups, n_slabs)

    def _contact_density(self, frame: ParticleFrame, contacts: ContactFrame) -> np.ndarray:
        """Contact stress density (n_nodes, 6) from the branch-line quadrature."""
        x_i = contacts.anchor(frame)
        points, which, weight = branch_quadrature(x_i, contacts.branch, _kernel_width(self.kernel))
        values = weight[:, None] * self.coordinates.local_tensors(points, contacts.pair_tensors()[which])
        return self._deposit(self.coordinates.map(points), values, frame.box)[0]

    def _derive(self, stacked: np.ndarray) -> dict[str, np.ndarray]:
        totals, species = self._unpack(stacked)
        return derive(totals, self._fields, self._node_volumes, self.components, species,
                       self.species or ())

    def _unpack(self, stacked: np.ndarray):
        """Split the (n_nodes, K) primitive array into named (n_nodes, width) arrays.

        Returns the totals and, with species, one such dict per species.
        """
        out, k = {}, 0
        order = [p for p in self._primitives if self._per_particle(p)]
        order += [p for p in self._primitives if not self._per_particle(p)]
        for p in order:
            width = PRIMITIVES[p].width
            out[p] = stacked[:, k : k + width]
            k += width
        species = []
        for _ in self.species or ():
            sp = {}
            for p in self._species_primitives:
                width = PRIMITIVES[p].width
                sp[p] = stacked[:, k : k + width]
                k += width
            species.append(sp)
        for p in self._frame_parts:
            width = FRAME_WIDTHS[p]
            out[p] = stacked[:, k : k + width]
            k += width
        return out, species


def _kernel_width(kernel) -> float:
    """Length scale the branch quadrature must resolve: the kernel's width or the narrowest bin."""
    if hasattr(kernel, "width"):
        return float(kernel.width)
    return float(min(np.min(np.diff(e)) for e in kernel.edges))
