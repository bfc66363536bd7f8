"""Particle data of one output frame, the common currency of readers and fields.

A reader (:mod:`postproc.dump`) yields :class:`DumpFrame` objects holding the raw
named columns of a LAMMPS dump; :meth:`ParticleFrame.from_dump` turns them into
named physical arrays that kernels and fields consume.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


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
    """

    timestep: int
    box: np.ndarray
    boundary: str
    columns: dict[str, np.ndarray] = field(default_factory=dict)

    @property
    def natoms(self) -> int:
        return len(next(iter(self.columns.values()))) if self.columns else 0


@dataclass
class ParticleFrame:
    """Physical per-particle arrays of one frame.

    Attributes
    ----------
    timestep : int
    box : ndarray, shape (3, 2)
    position : ndarray, shape (N, 3)
    velocity : ndarray, shape (N, 3)
    mass : ndarray, shape (N,)
    radius : ndarray, shape (N,)
    omega : ndarray, shape (N, 3) or None
        Angular velocity, when the dump has spin columns.
    contact_stress_volume : ndarray, shape (N, 6) or None
        Per-particle contact stress times volume,
        :math:`\\tfrac12\\sum_j F_{ij} x_{ij}` in the order xx, yy, zz, xy, xz, yz,
        compressive positive (the negative of LAMMPS ``compute stress/atom NULL pair``).
    type : ndarray, shape (N,) or None
    id : ndarray of int, shape (N,) or None
        LAMMPS atom ids, when the dump has an ``id`` column (the readers sort
        atoms by id); :meth:`postproc.contacts.ContactFrame.anchor` finds contact
        partners by them.
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

    @property
    def moment_of_inertia(self) -> np.ndarray:
        """Solid-sphere moment of inertia :math:`I_i = \\tfrac{2}{5} m_i r_i^2 = \\tfrac{1}{10} m_i d_i^2`."""
        return 0.4 * self.mass * self.radius**2

    @property
    def volume(self) -> np.ndarray:
        """Sphere volume :math:`\\tfrac{4}{3}\\pi r_i^3`."""
        return 4.0 / 3.0 * np.pi * self.radius**3

    @classmethod
    def from_dump(cls, frame: DumpFrame, stress_compute: str = "stress") -> "ParticleFrame":
        """Build from a :class:`DumpFrame`.

        Required columns: ``x y z vx vy vz mass radius``. Optional: ``omegax omegay
        omegaz``; ``c_<stress_compute>[1..6]`` from ``compute stress/atom NULL pair``;
        ``type``; ``id`` (stored as int64).
        """
        c = frame.columns
        missing = [k for k in ("x", "y", "z", "vx", "vy", "vz", "mass", "radius") if k not in c]
        if missing:
            raise KeyError(f"dump frame at step {frame.timestep} lacks columns {missing}")
        pos = np.column_stack([c["x"], c["y"], c["z"]])
        vel = np.column_stack([c["vx"], c["vy"], c["vz"]])
        omega = None
        if all(k in c for k in ("omegax", "omegay", "omegaz")):
            omega = np.column_stack([c["omegax"], c["omegay"], c["omegaz"]])
        names = [f"c_{stress_compute}[{k}]" for k in range(1, 7)]
        stress = None
        if all(n in c for n in names):
            # LAMMPS stress/atom is -(virial) in pressure*volume units; we store
            # the compressive-positive contact stress times volume.
            stress = -np.column_stack([c[n] for n in names])
        return cls(
            timestep=frame.timestep,
            box=np.asarray(frame.box, dtype=float),
            position=pos,
            velocity=vel,
            mass=np.asarray(c["mass"], dtype=float),
            radius=np.asarray(c["radius"], dtype=float),
            omega=omega,
            contact_stress_volume=stress,
            type=c.get("type"),
            id=None if "id" not in c else np.rint(np.asarray(c["id"], dtype=float)).astype(np.int64),
        )
