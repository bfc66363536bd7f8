"""Contact forces written by LAMMPS ``dump local``, and the branch-line quadrature of their stress.

The deck writes one entry per interacting pair with

.. code-block:: none

    compute ids all property/local patom1 patom2
    compute pl all pair/local dx dy dz fx fy fz p1 p2 p3
    dump contacts all local N contacts_001.dump c_ids[1] c_ids[2] c_pl[1] c_pl[2] c_pl[3] &
         c_pl[4] c_pl[5] c_pl[6] c_pl[7] c_pl[8] c_pl[9]
    dump_modify contacts colname 1 id1 colname 2 id2 colname 3 dx colname 4 dy colname 5 dz &
         colname 6 fnx colname 7 fny colname 8 fnz colname 9 ftx colname 10 fty colname 11 ftz

so that a frame reads

.. code-block:: none

    ITEM: TIMESTEP
    0
    ITEM: NUMBER OF ENTRIES
    1
    ITEM: BOX BOUNDS ff ff ff
    -1.0e-01 1.0e-01
    -1.0e-01 1.0e-01
    -1.0e-01 2.0e-01
    ITEM: ENTRIES id1 id2 dx dy dz fnx fny fnz ftx fty ftz
    1 2 -0.025 0 -0.005 -196.597 0 -39.3194 -0 -0 -0

with, for the pair ``id1 = i``, ``id2 = j``, the branch vector
:math:`\\mathbf r_{ij} = \\mathbf x_i - \\mathbf x_j` (``dx dy dz``) and the normal
and tangential forces on :math:`i` by :math:`j` (``fn*``, ``ft*``); the contact
force is :math:`\\mathbf f_{ij} = \\mathbf f^n_{ij} + \\mathbf f^t_{ij}`, and a
repulsive contact has :math:`\\mathbf f_{ij} \\cdot \\mathbf r_{ij} > 0`.

Other people's local dumps name their columns differently (``c_ids[1]``,
``c_pl[4]`` ... without ``dump_modify colname``) and may lack ``dx dy dz``:
:func:`read_contact_dump` takes ``roles`` mapping the names above to the file's
columns, and :meth:`ContactFrame.with_branch` rebuilds the branch vectors from
the particle positions (minimum image on periodic dimensions). Gzipped files
are recognised by content.
"""
from __future__ import annotations

import os
from dataclasses import dataclass, replace
from typing import Callable, Iterator, Mapping

import numpy as np

from .dump import dump_format, text_frames
from .frame import DumpError, ParticleFrame

__all__ = ["ContactFrame", "read_contact_dump", "branch_quadrature", "QUADRATURE_POINTS_PER_WIDTH", "ROLES"]

#: Gauss-Legendre points per kernel standard deviation of branch length (at least
#: two per contact; accuracy measured in :func:`branch_quadrature`).
QUADRATURE_POINTS_PER_WIDTH = 4.0

_FORCE_SETS = (("fnx", "fny", "fnz"), ("ftx", "fty", "ftz"))
_TOTAL_FORCE = ("fx", "fy", "fz")
_IDS = ("id1", "id2")
_BRANCH = ("dx", "dy", "dz")
#: Column roles :func:`read_contact_dump` knows.
ROLES = _IDS + _BRANCH + _TOTAL_FORCE + _FORCE_SETS[0] + _FORCE_SETS[1]
_WANT = "id1 id2, fx fy fz or fnx fny fnz (optionally ftx fty ftz), and optionally dx dy dz"


@dataclass
class ContactFrame:
    """Contacts of one frame: each pair once.

    Attributes
    ----------
    timestep : int
    box : ndarray, shape (3, 2)
    id_i, id_j : ndarray of int, shape (M,)
        Atom ids of the two particles of each contact.
    branch : ndarray, shape (M, 3), or None
        :math:`\\mathbf r_{ij} = \\mathbf x_i - \\mathbf x_j`, length units;
        ``None`` when the dump has no ``dx dy dz`` (fill it with :meth:`with_branch`).
    force : ndarray, shape (M, 3)
        :math:`\\mathbf f_{ij}`, the force on :math:`i` by :math:`j` (normal plus
        tangential), force units.
    n_duplicates : int
        Entries dropped because their unordered id pair was already listed.
    time : float or None
        Simulation time, when the dump has it (``ITEM: TIME``).
    """

    timestep: int
    box: np.ndarray
    id_i: np.ndarray
    id_j: np.ndarray
    branch: np.ndarray | None
    force: np.ndarray
    n_duplicates: int = 0
    time: float | None = None

    def __len__(self) -> int:
        return len(self.id_i)

    def _rows(self, frame: ParticleFrame, ids: np.ndarray, what: str) -> np.ndarray:
        """Rows of ``frame`` holding the particles ``ids`` (checks the step and the ids)."""
        if frame.timestep != self.timestep:
            raise ValueError(f"contacts of step {self.timestep} {what} a particle frame of step {frame.timestep}")
        if frame.id is None:
            raise ValueError(f"particle frame of step {frame.timestep} has no ids (dump the 'id' column)")
        frame_ids = np.asarray(frame.id)
        order = None if np.all(frame_ids[1:] > frame_ids[:-1]) else np.argsort(frame_ids, kind="stable")
        sorted_ids = frame_ids if order is None else frame_ids[order]
        where = np.clip(np.searchsorted(sorted_ids, ids), 0, max(len(sorted_ids) - 1, 0))
        found = sorted_ids[where] == ids if len(sorted_ids) else np.zeros(len(ids), bool)
        if not np.all(found):
            missing = np.unique(ids[~found])
            raise KeyError(f"contacts of step {self.timestep} name ids absent from the particle frame: "
                           f"{missing[:10].tolist()}")
        return where if order is None else order[where]

    def anchor(self, frame: ParticleFrame) -> np.ndarray:
        """Centres :math:`\\mathbf x_i` of the first particle of each contact, from ``frame``.

        Parameters
        ----------
        frame : ParticleFrame
            The particle frame of the same timestep, with ``id``.

        Returns
        -------
        ndarray, shape (M, 3)

        Raises
        ------
        ValueError
            If the timesteps differ or the frame has no ids.
        KeyError
            If a contact names an id absent from the frame.
        """
        if len(self) == 0:
            self._rows(frame, self.id_i[:0], "anchored on")  # same checks
            return np.zeros((0, 3))
        return np.asarray(frame.position, dtype=float)[self._rows(frame, self.id_i, "anchored on")]

    def with_branch(self, frame: ParticleFrame, boundary: str | None = None) -> "ContactFrame":
        """A copy whose branch vectors come from the particle positions of ``frame``.

        For dumps without ``dx dy dz`` (``compute pair/local`` without them):
        :math:`\\mathbf r_{ij} = \\mathbf x_i - \\mathbf x_j`, the particles found
        by id, minimum-imaged on the periodic dimensions,
        :math:`r_a \\leftarrow r_a - L_a \\operatorname{round}(r_a / L_a)`, with the
        box lengths :math:`L_a` of ``frame``. An existing branch is replaced.

        Parameters
        ----------
        frame : ParticleFrame
            The particle frame of the same timestep, with ``id``.
        boundary : str, optional
            LAMMPS boundary string (``"p p f"``); default ``frame.boundary``
            (filled by :meth:`ParticleFrame.from_dump`). When both are ``None``
            no dimension is treated as periodic.

        Returns
        -------
        ContactFrame
            With ``branch`` set, shape (M, 3); the other fields shared with ``self``.

        Raises
        ------
        ValueError
            If the timesteps differ, the frame has no ids or the boundary string
            does not have three dimensions.
        KeyError
            If a contact names an id absent from the frame.
        """
        boundary = frame.boundary if boundary is None else boundary
        periodic = np.zeros(3, dtype=bool)
        if boundary is not None:
            dims = boundary.split()
            if len(dims) != 3:
                raise ValueError(f"boundary {boundary!r} does not give three dimensions (e.g. 'p p f')")
            periodic = np.array([d == "p" for d in dims])
        position = np.asarray(frame.position, dtype=float)
        if len(self) == 0:
            self._rows(frame, self.id_i[:0], "take branches from")
            return replace(self, branch=np.zeros((0, 3)))
        branch = (position[self._rows(frame, self.id_i, "take branches from")]
                  - position[self._rows(frame, self.id_j, "take branches from")])
        if periodic.any():
            length = np.diff(np.asarray(frame.box, dtype=float), axis=1)[:, 0]
            p = np.flatnonzero(periodic)
            branch[:, p] -= length[p] * np.rint(branch[:, p] / length[p])
        return replace(self, branch=branch)

    def pair_tensors(self) -> np.ndarray:
        """Symmetric part of :math:`\\mathbf f_{ij} \\otimes \\mathbf r_{ij}`, xx yy zz xy xz yz, shape (M, 6).

        .. math::

            T_{ab} = \\tfrac12 (f_a r_b + f_b r_a)

        The antisymmetric part (the contact couple) is not represented by six
        components; the trace :math:`\\mathbf f \\cdot \\mathbf r` is exact.

        Raises
        ------
        ValueError
            If the frame has no branch vectors (see :meth:`with_branch`).
        """
        return sym_outer(self.force, _need_branch(self.branch))


def _need_branch(branch):
    if branch is None:
        raise ValueError("the contacts have no branch vectors (the dump has no dx dy dz): "
                         "fill them with ContactFrame.with_branch(particle_frame)")
    return branch


def sym_outer(f: np.ndarray, r: np.ndarray) -> np.ndarray:
    """:math:`\\tfrac12(f_a r_b + f_b r_a)` in the order xx yy zz xy xz yz, shape (M, 6).

    Parameters
    ----------
    f : array_like, shape (M, 3)
        Contact forces, the dump's force unit.
    r : array_like, shape (M, 3)
        Branch vectors, the dump's length unit.

    Returns
    -------
    ndarray, shape (M, 6)
        Force times length (stress times volume).
    """
    f, r = np.asarray(f, dtype=float), np.asarray(r, dtype=float)
    return np.column_stack([
        f[:, 0] * r[:, 0],
        f[:, 1] * r[:, 1],
        f[:, 2] * r[:, 2],
        0.5 * (f[:, 0] * r[:, 1] + f[:, 1] * r[:, 0]),
        0.5 * (f[:, 0] * r[:, 2] + f[:, 2] * r[:, 0]),
        0.5 * (f[:, 1] * r[:, 2] + f[:, 2] * r[:, 1]),
    ])


def branch_quadrature(x_i: np.ndarray, branch: np.ndarray, width: float):
    """Gauss-Legendre points along each branch line, for the contact stress (paper eq. 5).

    .. math::

        \\int_0^1 \\phi(\\mathbf r - \\mathbf x_i + s\\,\\mathbf r_{ij})\\,\\mathrm ds
        \\approx \\sum_q \\omega_q\\, \\phi(\\mathbf r - \\mathbf p_q),
        \\quad \\mathbf p_q = \\mathbf x_i - s_q \\mathbf r_{ij},

    from :math:`\\mathbf x_i` (:math:`s = 0`) to :math:`\\mathbf x_j` (:math:`s = 1`),
    with :math:`n = \\max(2, \\lceil 4 |\\mathbf r_{ij}| / \\sigma \\rceil)` points
    (:data:`QUADRATURE_POINTS_PER_WIDTH`) for a kernel of standard deviation
    :math:`\\sigma`. The weights sum to one for every contact, so the volume
    integral of the contact stress is exact whatever :math:`n`. Locally the error is set by the kinks of the truncated,
    azimuthally averaged kernel (square-root kinks where the line crosses a node's
    truncation sphere, and near the axis where a node's ring closes), for which
    Gauss-Legendre converges only as :math:`n^{-3/2}`: measured against 64 points
    per :math:`\\sigma`, for branches of 1.5-3 :math:`\\sigma` on the paper's kernel, the
    largest nodal error is 0.1 % of the field's maximum 14 :math:`\\sigma` from the axis
    and 2 % within 4 :math:`\\sigma` of it (0.3 % median); time averages over many
    contacts blur these further.

    Parameters
    ----------
    x_i : ndarray, shape (M, 3)
        Centre :math:`\\mathbf x_i` of the first particle of each contact, length units.
    branch : ndarray, shape (M, 3)
        :math:`\\mathbf r_{ij}`, length units.
    width : float
        Standard deviation :math:`\\sigma` of the kernel, length units.

    Returns
    -------
    points : ndarray, shape (P, 3)
        :math:`\\mathbf p_q`, length units.
    contact : ndarray of int, shape (P,)
        Contact of each point.
    weight : ndarray, shape (P,)
        :math:`\\omega_q`, summing to one per contact.

    Raises
    ------
    ValueError
        If ``branch`` is None (see :meth:`ContactFrame.with_branch`).
    """
    branch = _need_branch(branch)
    x_i, branch = np.asarray(x_i, dtype=float).reshape(-1, 3), np.asarray(branch, dtype=float).reshape(-1, 3)
    length = np.linalg.norm(branch, axis=1)
    n = np.maximum(2, np.ceil(QUADRATURE_POINTS_PER_WIDTH * length / width)).astype(int)
    points, contact, weight = [], [], []
    for k in np.unique(n):  # a few distinct point counts: vectorised per count
        members = np.flatnonzero(n == k)
        t, w = np.polynomial.legendre.leggauss(int(k))
        s, w = 0.5 * (t + 1.0), 0.5 * w
        points.append((x_i[members, None, :] - s[None, :, None] * branch[members, None, :]).reshape(-1, 3))
        contact.append(np.repeat(members, k))
        weight.append(np.tile(w, len(members)))
    if not points:
        return np.zeros((0, 3)), np.zeros(0, dtype=int), np.zeros(0)
    return np.concatenate(points), np.concatenate(contact), np.concatenate(weight)


def read_contact_dump(path: str | os.PathLike, roles: Mapping[str, str] | None = None, *,
                      select: Callable[[int], bool] | None = None) -> Iterator[ContactFrame]:
    """Read a LAMMPS text ``dump local`` of contacts (plain or gzipped) frame by frame.

    Each frame's entry lines are parsed at once by :func:`numpy.loadtxt` (C
    parser). Gzip is recognised by content (:func:`postproc.dump.dump_format`)
    and streamed. Columns are found by their role: ``id1 id2``, the force as
    ``fx fy fz`` or as ``fnx fny fnz`` with optional ``ftx fty ftz`` (summed;
    preferred when both are present) and, optionally, the branch ``dx dy dz``;
    other columns are ignored. Without ``dx dy dz`` the frames have
    ``branch = None``; fill it with :meth:`ContactFrame.with_branch`.
    Zero-entry frames give empty contact frames.

    Two clean-ups, both counted or documented rather than silent errors:

    - an unordered id pair listed more than once (which MPI runs can produce
      when both ranks own the pair) is kept once, the first entry, and the
      others counted in :attr:`ContactFrame.n_duplicates`;
    - entries whose force is exactly zero (neighbours in the list that do not
      touch) are dropped: they carry no stress.

    Parameters
    ----------
    path : str or os.PathLike
    roles : mapping of str to str, optional
        Column name in the file for each role (``id1 id2 dx dy dz fx fy fz fnx
        fny fnz ftx fty ftz``), e.g. ``{"id1": "c_ids[1]", "id2": "c_ids[2]",
        "fx": "c_pl[4]", "fy": "c_pl[5]", "fz": "c_pl[6]"}`` for a dump without
        ``dump_modify colname``. Roles not given are looked up under their own
        names. Give either ``fx fy fz`` or ``fn*`` roles, not both.
    select : callable, optional
        ``select(timestep) -> bool``; the entries of the frames for which it is
        false are not parsed, and those frames are not yielded.

    Yields
    ------
    ContactFrame

    Raises
    ------
    ValueError
        At the call, for unknown roles, or both force kinds given.
    DumpError
        If a frame is truncated or malformed, the file is binary, or the header's
        columns do not provide the roles (the message lists the columns and how to
        name them); the message names the file, the 0-based frame index, the line
        and the byte at which the frame starts. Also for an entry with a NaN or
        infinite id, force or branch value, or a branch component longer than the
        box (a branch joins two touching particles), naming the entry, its two
        atom ids and the column.
    """
    roles = dict(roles or {})
    unknown = sorted(set(roles) - set(ROLES))
    if unknown:
        raise ValueError(f"unknown contact roles {unknown}; the roles are {' '.join(ROLES)}")
    if any(r in roles for r in _TOTAL_FORCE) and any(r in roles for r in _FORCE_SETS[0] + _FORCE_SETS[1]):
        raise ValueError("give the force either as fx fy fz or as fnx fny fnz (ftx fty ftz) roles, not both")
    return _read_contacts(os.fspath(path), roles, select)


def _read_contacts(path: str, roles: dict[str, str], select) -> Iterator[ContactFrame]:
    if dump_format(path) == "binary":
        raise DumpError(f"{path} is a binary dump; contact (dump local) files are read as text, plain or gzipped",
                        path=path, frame=0, byte=0, truncated=False)

    def refuse(names: list[str]) -> str | None:
        columns = _column_indices(names, roles)
        return columns if isinstance(columns, str) else None

    for block in text_frames(path, "ENTRIES", "entry", check_names=refuse, select=select):
        columns = _column_indices(block.names, roles)
        why = _impossible_entries(block.data, block.names, block.box, columns, roles)
        if why:
            raise DumpError(f"{path}: frame {block.frame} at step {block.timestep} (line {block.line}): {why}",
                            path=path, frame=block.frame, byte=block.byte, truncated=False, line=block.line)
        yield _contact_frame(block.timestep, block.box, block.data, columns, time=block.time)


def _impossible_entries(data: np.ndarray, names: list[str], box: np.ndarray, columns: dict,
                        roles: Mapping[str, str]) -> str | None:
    """Why a frame's entries cannot be contacts (a non-finite id, force or branch value, or a branch
    component longer than the box), naming the entry, its two atoms and the column; None if they can."""
    used = list(columns["ids"]) + list(columns["branch"] or []) + [j for f in columns["forces"] for j in f]
    values = data[:, used]
    role_of = {column: role for role, column in roles.items()}

    def entry(row: int, k: int, allowed: str, count: int) -> str:
        i, j = (data[row, c] for c in columns["ids"])
        atoms = (f"atoms {int(i)} and {int(j)}" if np.isfinite([i, j]).all() else f"atoms {i:g} and {j:g}")
        name = names[used[k]]
        role = f" ({role_of[name]})" if name in role_of and role_of[name] != name else ""
        others = f" ({count} entries of this frame have such values)" if count > 1 else ""
        return (f"entry {row + 1}, the contact of {atoms}: column {name}{role} = {data[row, used[k]]:g} is not "
                f"allowed: allowed {allowed}{others}")

    bad = ~np.isfinite(values)
    if bad.any():
        row, k = np.argwhere(bad)[0]
        return entry(int(row), int(k), "a finite number", int(bad.any(axis=1).sum()))
    if columns["branch"] is None or not np.isfinite(box).all():
        return None
    length = np.abs(np.diff(np.asarray(box, dtype=float), axis=1)[:, 0])
    n_ids = len(columns["ids"])
    too_long = np.abs(values[:, n_ids:n_ids + 3]) > length
    if not too_long.any():
        return None
    row, k = np.argwhere(too_long)[0]
    return entry(int(row), n_ids + int(k), f"a branch component no longer than the box along {'xyz'[k]} "
                 f"({length[k]:g}): a branch joins the centres of two touching particles",
                 int(too_long.any(axis=1).sum()))


def _column_indices(names: list[str], roles: Mapping[str, str] | None = None):
    """Indices of the id, branch and force columns, or an error message."""
    roles = roles or {}
    index = {name: k for k, name in enumerate(names)}

    def col(role: str) -> str:
        return roles.get(role, role)

    def have(group) -> bool:
        return all(col(r) in index for r in group)

    missing = [col(r) for r in _IDS if col(r) not in index]
    if any(r in roles for r in _TOTAL_FORCE):
        candidates = [_TOTAL_FORCE]
    elif any(r in roles for r in _FORCE_SETS[0] + _FORCE_SETS[1]):
        candidates = [_FORCE_SETS[0]]
    else:
        candidates = [_FORCE_SETS[0], _TOTAL_FORCE]
    force_sets = [s for s in candidates if have(s)]
    if not force_sets:
        missing.append("the force columns " + " or ".join(" ".join(col(r) for r in s) for s in candidates))
    branch_given = [r for r in _BRANCH if r in roles]
    if (branch_given or any(col(r) in index for r in _BRANCH)) and not have(_BRANCH):
        missing.extend(col(r) for r in _BRANCH if col(r) not in index)
    if any(r in roles for r in _FORCE_SETS[1]) and not have(_FORCE_SETS[1]):
        missing.extend(col(r) for r in _FORCE_SETS[1] if col(r) not in index)
    if missing:
        return (f"entry columns {names} lack {', '.join(missing)} (need {_WANT}); name the columns with "
                "dump_modify colname, or pass roles to read_contact_dump, e.g. roles={'id1': 'c_ids[1]', "
                "'id2': 'c_ids[2]', 'fx': 'c_pl[4]', 'fy': 'c_pl[5]', 'fz': 'c_pl[6]'}")
    forces = [[index[col(r)] for r in force_sets[0]]]
    if force_sets[0] == _FORCE_SETS[0] and have(_FORCE_SETS[1]):
        forces.append([index[col(r)] for r in _FORCE_SETS[1]])
    return {
        "ids": [index[col(r)] for r in _IDS],
        "branch": [index[col(r)] for r in _BRANCH] if have(_BRANCH) else None,
        "forces": forces,
    }


def _contact_frame(timestep: int, box: np.ndarray, data: np.ndarray, columns: dict,
                   time: float | None = None) -> ContactFrame:
    ids = np.rint(data[:, columns["ids"]]).astype(np.int64)
    branch = None if columns["branch"] is None else data[:, columns["branch"]]
    force = sum(data[:, f] for f in columns["forces"])
    touching = np.any(force != 0.0, axis=1)
    ids, force = ids[touching], force[touching]
    branch = None if branch is None else branch[touching]
    pair = np.sort(ids, axis=1)
    n_duplicates = 0
    if len(pair) > 1:
        _, first = np.unique(pair, axis=0, return_index=True)
        keep = np.sort(first)
        n_duplicates = len(pair) - len(keep)
        ids, force = ids[keep], force[keep]
        branch = None if branch is None else branch[keep]
    return ContactFrame(
        timestep=timestep,
        box=box,
        id_i=np.ascontiguousarray(ids[:, 0]),
        id_j=np.ascontiguousarray(ids[:, 1]),
        branch=None if branch is None else np.ascontiguousarray(branch),
        force=np.ascontiguousarray(force),
        n_duplicates=n_duplicates,
        time=time,
    )
