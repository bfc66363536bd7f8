"""Particle data of one output frame, the common currency of readers and fields.

A reader (:mod:`postproc.dump`) yields :class:`DumpFrame` objects holding the raw
named columns of a LAMMPS dump; :meth:`ParticleFrame.from_dump` turns them into
named physical arrays that kernels and fields consume.

The reader exceptions live here too (and are re-exported by :mod:`postproc.dump`),
because :meth:`ParticleFrame.from_dump` raises :class:`MissingColumnsError`.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Iterable, Sequence

import numpy as np

__all__ = ["DumpError", "MissingColumnsError", "DumpFrame", "ParticleFrame", "ImpossibleValues",
           "missing_particle_columns", "impossible_values"]


class DumpError(Exception):
    """A dump file is truncated, corrupted, in an unsupported format, or lacks columns.

    The message names the file, the 0-based frame index, the byte offset and
    what was wrong. The same facts are attributes, each ``None`` when unknown
    (``DumpError("message")`` alone is valid).

    Parameters
    ----------
    message : str
    path : str, optional
        The dump file.
    frame : int, optional
        0-based index of the bad or incomplete frame.
    byte : int, optional
        Byte offset at which that frame starts (for gzipped text dumps, in the
        decompressed stream).
    truncated : bool, optional
        ``True`` when the file ends inside the frame, ``False`` when the frame
        is corrupted or unusable.
    line : int, optional
        For text dumps, the 1-based line at which the problem was found.

    Attributes
    ----------
    path, frame, byte, truncated, line
        As given.
    """

    def __init__(self, message: str = "", *, path: str | None = None, frame: int | None = None,
                 byte: int | None = None, truncated: bool | None = None, line: int | None = None) -> None:
        super().__init__(message)
        self.path = path
        self.frame = frame
        self.byte = byte
        self.truncated = truncated
        self.line = line


class MissingColumnsError(DumpError, KeyError):
    """A dump frame lacks the columns a reader or :meth:`ParticleFrame.from_dump` needs.

    Subclasses both :class:`DumpError` and :class:`KeyError` (code catching
    either keeps working); unlike a :class:`KeyError` its ``str()`` is the plain
    message, not its ``repr``.

    Parameters
    ----------
    message : str
    missing : sequence of str, optional
        What is lacking (column names or alternatives such as ``"radius or diameter"``).
    available : sequence of str, optional
        The columns the frame has.
    **where
        ``path``, ``frame``, ``byte``, ``line``, as for :class:`DumpError`.

    Attributes
    ----------
    missing, available : list of str
    """

    def __init__(self, message: str = "", *, missing: Sequence[str] = (), available: Sequence[str] = (),
                 **where) -> None:
        where.setdefault("truncated", False)
        super().__init__(message, **where)
        self.missing = list(missing)
        self.available = list(available)

    def __str__(self) -> str:
        return str(self.args[0]) if self.args else ""


@dataclass
class DumpFrame:
    """One frame of a LAMMPS custom dump, as written.

    Attributes
    ----------
    timestep : int
        LAMMPS step number of the frame.
    box : ndarray, shape (3, 2)
        Lower and upper box bounds per dimension (orthogonal boxes only).
    boundary : str
        LAMMPS boundary string, e.g. ``"f p p"``.
    columns : dict of str -> ndarray, shape (N,)
        Per-atom columns by their dump names (``id``, ``x``, ``c_stress[1]`` ...),
        sorted by atom id.
    time : float or None
        Simulation time, when the dump has it (``dump_modify time yes``).
    units : str or None
        LAMMPS unit style (``"si"``, ``"lj"`` ...), when the dump has it
        (``dump_modify units yes``; LAMMPS writes it in the first frame only, the
        readers carry it to the later ones).
    """

    timestep: int
    box: np.ndarray
    boundary: str
    columns: dict[str, np.ndarray] = field(default_factory=dict)
    time: float | None = None
    units: str | None = None

    @property
    def natoms(self) -> int:
        """Number of atoms in the frame (the length of its columns; 0 without columns)."""
        return len(next(iter(self.columns.values()))) if self.columns else 0


#: Position column sets :meth:`ParticleFrame.from_dump` accepts, in order of preference;
#: the scaled ones (``s``) are converted with the box.
_POSITION_SETS = (("x", "y", "z"), ("xu", "yu", "zu"), ("xs", "ys", "zs"), ("xsu", "ysu", "zsu"))
_VELOCITY = ("vx", "vy", "vz")
_NEEDED = "x y z (or xu yu zu, xs ys zs), vx vy vz, radius or diameter, and mass or a density"


def missing_particle_columns(names: Iterable[str], density: float | None = None) -> list[str]:
    """What a dump with these columns lacks for :meth:`ParticleFrame.from_dump`.

    Lets a caller refuse a dump before reading its frames (e.g. from the column
    names of :func:`postproc.dump.peek_dump`).

    Parameters
    ----------
    names : iterable of str
        Column names of the dump.
    density : float, optional
        The particle density that :meth:`ParticleFrame.from_dump` would be given;
        with it the ``mass`` column is not needed.

    Returns
    -------
    list of str
        Empty when the columns suffice. Otherwise one entry per lacking item:
        column names (``"vz"``, or ``"z"`` when only part of a position set is
        present) or alternatives (``"x y z (or xu yu zu, xs ys zs)"``,
        ``"radius or diameter"``, ``"mass or a density"``).
    """
    have = set(names)
    lacking: list[str] = []
    if not any(have.issuperset(s) for s in _POSITION_SETS):
        partial = max(_POSITION_SETS, key=lambda s: sum(c in have for c in s))
        if any(c in have for c in partial):
            lacking.extend(c for c in partial if c not in have)
        else:
            lacking.append("x y z (or xu yu zu, xs ys zs)")
    lacking.extend(c for c in _VELOCITY if c not in have)
    if "radius" not in have and "diameter" not in have:
        lacking.append("radius or diameter")
    if "mass" not in have and density is None:
        lacking.append("mass or a density")
    return lacking


def _particle_columns(names: Iterable[str]) -> tuple[tuple[str, ...], tuple[str, ...]]:
    """The columns :meth:`ParticleFrame.from_dump` reads from a frame with these names.

    Returns ``(finite, positive)``: the position set it uses, ``vx vy vz`` and the
    spin columns (values that must be finite), and ``mass`` and ``radius`` (else
    ``diameter``), which must also be positive. Absent columns are left out.
    """
    have = set(names)
    finite: list[str] = list(next((s for s in _POSITION_SETS if have.issuperset(s)), ()))
    finite += [k for k in _VELOCITY if k in have]
    if have.issuperset(("omegax", "omegay", "omegaz")):
        finite += ["omegax", "omegay", "omegaz"]
    positive = [k for k in ("mass",) if k in have]
    positive += ["radius"] if "radius" in have else ["diameter"] if "diameter" in have else []
    return tuple(finite), tuple(positive)


def _all_possible(values: np.ndarray, positive: bool) -> bool:
    """Whether every value is finite (and > 0 if ``positive``), by one or two reductions.

    A NaN propagates through ``sum``, ``min`` and ``max``, an infinity through
    ``sum`` and ``max``; so a True answer is exact, and a False one is either
    right or a sum that overflowed, which the caller's element-wise pass clears.
    (``numpy.add.reduce`` runs at ~0.17 ns per value, as fast as
    ``numpy.isfinite(v).all()`` and without its temporary; a BLAS dot product,
    faster alone, stalls when its threads share the cores with a run.)
    """
    if positive:
        return bool(values.min() > 0) and math.isfinite(values.max())
    return math.isfinite(np.add.reduce(values))


@dataclass(frozen=True)
class ImpossibleValues:
    """Atoms of one frame holding values no particle can have (:func:`impossible_values`).

    Attributes
    ----------
    nonfinite : dict of str -> ndarray of bool, shape (N,)
        Per column the particle is built from (position, velocity, spin, mass,
        radius or diameter) that holds a NaN or an infinity, the rows holding one.
    nonpositive : dict of str -> ndarray of bool, shape (N,)
        Per ``mass``, ``radius`` or ``diameter`` column holding a finite value
        :math:`\\le 0`, the rows holding one.
    """

    nonfinite: dict[str, np.ndarray]
    nonpositive: dict[str, np.ndarray]

    @staticmethod
    def first(columns: dict[str, np.ndarray]) -> tuple[int, str, int]:
        """The first offending row of ``columns``, its column and the number of offending rows.

        Parameters
        ----------
        columns : dict of str to ndarray of bool, shape (N,)
            ``nonfinite`` or ``nonpositive``; at least one row must be True.

        Returns
        -------
        row : int
            The first offending row.
        column : str
            The first of that row's offending columns, in column order.
        count : int
            Rows offending in any column.

        Raises
        ------
        IndexError
            If no row offends.
        """
        rows = np.logical_or.reduce(list(columns.values()))
        k = int(np.flatnonzero(rows)[0])
        return k, next(c for c, bad in columns.items() if bad[k]), int(np.count_nonzero(rows))

    @property
    def nonfinite_rows(self) -> np.ndarray | None:
        """Rows with a non-finite value in any column (None when there is none)."""
        return np.logical_or.reduce(list(self.nonfinite.values())) if self.nonfinite else None


def impossible_values(frame: DumpFrame) -> ImpossibleValues | None:
    """Atoms of ``frame`` that no particle can be made of; ``None`` (the common case) when there is none.

    Checked are the columns :meth:`ParticleFrame.from_dump` would use: the
    position set it picks, ``vx vy vz``, ``omegax omegay omegaz`` when present
    (finite), ``mass`` and ``radius`` (else ``diameter``) (finite and
    :math:`> 0`). Columns that are absent are not checked (a ``density``
    stands in for the mass). Each column costs one or two reductions; the
    element-wise pass runs only on a frame that fails them. Measured on a binary
    dump with spins (13 columns checked, 50 000 atoms x 40 frames, 2 cores under
    load): 3.8 ns per atom on a frame in cache, about 4 % of the time of reading
    the frames with :func:`postproc.dump.read_dump` (which it does not change),
    and no measurable change of ``granflow cg`` as a whole (``rz`` Gaussian, one
    thread: 1.08 M particle-frames/s without the check, 1.09 M with it).

    Parameters
    ----------
    frame : DumpFrame

    Returns
    -------
    ImpossibleValues or None
    """
    c = frame.columns
    if not frame.natoms:
        return None
    finite, positive = _particle_columns(c)
    checks = [(k, False) for k in finite] + [(k, True) for k in positive]
    with np.errstate(over="ignore", invalid="ignore"):  # inf - inf and overflow are answers here
        suspect = [(k, pos) for k, pos in checks if not _all_possible(np.asarray(c[k], dtype=float), pos)]
    if not suspect:
        return None
    nonfinite, nonpositive = {}, {}
    for k, pos in suspect:
        values = np.asarray(c[k], dtype=float)
        bad = ~np.isfinite(values)
        if bad.any():
            nonfinite[k] = bad
        if pos:
            bad = (values <= 0) & np.isfinite(values)
            if bad.any():
                nonpositive[k] = bad
    if not nonfinite and not nonpositive:  # only a sum that overflowed
        return None
    return ImpossibleValues(nonfinite, nonpositive)


def _missing_message(step: int, lacking: Sequence[str], names: Sequence[str]) -> str:
    hint = " (pass density= to ParticleFrame.from_dump, or dump the mass column)" if "mass or a density" in lacking else ""
    return (f"dump frame at step {step} lacks {', '.join(lacking)}{hint}; ParticleFrame needs {_NEEDED}; "
            f"the frame has columns {list(names)}")


@dataclass
class ParticleFrame:
    """Physical per-particle arrays of one frame.

    The dump's units throughout (LAMMPS ``units``: m, kg, s in SI dumps; the
    reduced units of an ``lj`` dump); the dump's ``units`` is not read here.

    Attributes
    ----------
    timestep : int
    box : ndarray, shape (3, 2)
        Lower and upper box bounds per dimension, length units.
    position : ndarray, shape (N, 3)
        Particle centres, length units (m in SI dumps).
    velocity : ndarray, shape (N, 3)
        Velocities, length per time unit.
    mass : ndarray, shape (N,)
        Masses, mass units.
    radius : ndarray, shape (N,)
        Radii, length units.
    omega : ndarray, shape (N, 3) or None
        Angular velocity, radians per time unit, when the dump has spin columns.
    contact_stress_volume : ndarray, shape (N, 6) or None
        Per-particle contact stress times volume (force times length),
        :math:`\\tfrac12\\sum_j F_{ij} x_{ij}` in the order xx, yy, zz, xy, xz, yz,
        compressive positive (the negative of LAMMPS ``compute stress/atom NULL pair``).
    type : ndarray, shape (N,) or None
    id : ndarray of int, shape (N,) or None
        LAMMPS atom ids, when the dump has an ``id`` column (the readers sort
        atoms by id); :meth:`postproc.contacts.ContactFrame.anchor` finds contact
        partners by them.
    time : float or None
        Simulation time, when the dump has it.
    boundary : str or None
        LAMMPS boundary string (``"p p f"``), used for minimum images
        (:meth:`postproc.contacts.ContactFrame.with_branch`); ``None`` when unknown.
    """

    timestep: int
    box: np.ndarray
    position: np.ndarray
    velocity: np.ndarray
    mass: np.ndarray
    radius: np.ndarray
    omega: np.ndarray | None = None
    contact_stress_volume: np.ndarray | None = None
    type: np.ndarray | None = None
    id: np.ndarray | None = None
    time: float | None = None
    boundary: str | None = None

    @property
    def moment_of_inertia(self) -> np.ndarray:
        """Solid-sphere moment of inertia :math:`I_i = \\tfrac{2}{5} m_i r_i^2 = \\tfrac{1}{10} m_i d_i^2`."""
        return 0.4 * self.mass * self.radius**2

    @property
    def volume(self) -> np.ndarray:
        """Sphere volume :math:`\\tfrac{4}{3}\\pi r_i^3`."""
        r = self.radius
        return (4.0 / 3.0 * np.pi) * (r * r * r)

    @classmethod
    def from_dump(cls, frame: DumpFrame, stress_compute: str = "stress",
                  density: float | None = None) -> "ParticleFrame":
        """Build from a :class:`DumpFrame`.

        Parameters
        ----------
        frame : DumpFrame
        stress_compute : str, optional
            ID of the ``compute stress/atom NULL pair`` whose ``c_<id>[1..6]``
            columns give :attr:`contact_stress_volume`.
        density : float, optional
            Particle density (mass per volume in the dump's units), used for the
            mass :math:`\\rho \\tfrac43 \\pi r^3` when the dump has no ``mass``
            column (a ``mass`` column wins).

        Returns
        -------
        ParticleFrame

        Raises
        ------
        MissingColumnsError
            (a :class:`KeyError`) if a required column is absent; the message
            names the step, what is lacking, what is needed and the columns
            present (see :func:`missing_particle_columns`).

        Notes
        -----
        Positions from ``x y z``, else the unwrapped ``xu yu zu``, else the scaled
        ``xs ys zs`` (or ``xsu ysu zsu``) converted with the box,
        :math:`x = x_{lo} + s (x_{hi} - x_{lo})`; velocities ``vx vy vz``; the
        radius from ``radius``, else ``diameter / 2``; the mass from ``mass``,
        else from ``density``. Optional: ``omegax omegay omegaz``;
        ``c_<stress_compute>[1..6]``; ``type``; ``id`` (stored as int64).
        """
        c = frame.columns
        lacking = missing_particle_columns(c, density)
        if lacking:
            raise MissingColumnsError(_missing_message(frame.timestep, lacking, list(c)),
                                      missing=lacking, available=list(c))
        box = np.asarray(frame.box, dtype=float)
        names = next(s for s in _POSITION_SETS if all(k in c for k in s))
        pos = np.column_stack([c[k] for k in names])
        if names[0].startswith("xs"):
            pos = box[:, 0] + pos * (box[:, 1] - box[:, 0])
        vel = np.column_stack([c["vx"], c["vy"], c["vz"]])
        radius = np.asarray(c["radius"], dtype=float) if "radius" in c else 0.5 * np.asarray(c["diameter"], dtype=float)
        if "mass" in c:
            mass = np.asarray(c["mass"], dtype=float)
        else:
            mass = float(density) * (4.0 / 3.0 * np.pi) * radius**3
        omega = None
        if all(k in c for k in ("omegax", "omegay", "omegaz")):
            omega = np.column_stack([c["omegax"], c["omegay"], c["omegaz"]])
        stress_names = [f"c_{stress_compute}[{k}]" for k in range(1, 7)]
        stress = None
        if all(n in c for n in stress_names):
            # LAMMPS stress/atom is -(virial) in pressure*volume units; we store
            # the compressive-positive contact stress times volume.
            stress = -np.column_stack([c[n] for n in stress_names])
        return cls(
            timestep=frame.timestep,
            box=box,
            position=pos,
            velocity=vel,
            mass=mass,
            radius=radius,
            omega=omega,
            contact_stress_volume=stress,
            type=c.get("type"),
            id=None if "id" not in c else np.rint(np.asarray(c["id"], dtype=float)).astype(np.int64),
            time=getattr(frame, "time", None),
            boundary=getattr(frame, "boundary", None),
        )
