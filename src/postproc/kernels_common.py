"""What every coarse-graining kernel is built on: grid axes, the sparse assignment, the reference deposit.

:class:`Assignment` holds a kernel's (particle, node, weight) pairs;
:func:`deposit_by_assignment` sums them per group and node with
:func:`numpy.bincount`, the reference deposit of every kernel;
:func:`as_axes`, :func:`check_dimension`, :func:`grid_columns` and
:func:`check_groups` check and lay out the grid axes and the particle groups for
:class:`~postproc.kernels.HeavisideBins` and the radial kernels
(:mod:`postproc.kernels_radial`). :mod:`postproc.kernels` (the kernel
interface) re-exports the public names.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np


@dataclass(frozen=True)
class Assignment:
    """Sparse particle-to-node assignment of a kernel.

    Attributes
    ----------
    particle : ndarray of int, shape (M,)
        Particle index of each pair.
    node : ndarray of int, shape (M,)
        Flat node index of each pair.
    weight : ndarray of float, shape (M,)
        Kernel weight :math:`w_{in}`, units 1/volume.
    """

    particle: np.ndarray
    node: np.ndarray
    weight: np.ndarray


def as_axes(edges_or_nodes) -> tuple[np.ndarray, ...]:
    """Normalise one array or a sequence of arrays into a tuple of strictly increasing 1D axes.

    Parameters
    ----------
    edges_or_nodes : array_like or sequence of array_like
        One axis (an array, or a sequence of numbers), or one axis per coordinate.

    Returns
    -------
    tuple of ndarray
        Float arrays, in the unit given.

    Raises
    ------
    ValueError
        If an axis is not 1-D, has fewer than two values or does not increase strictly.
    """
    if isinstance(edges_or_nodes, np.ndarray) or np.isscalar(edges_or_nodes[0]):
        axes = (edges_or_nodes,)
    else:
        axes = tuple(edges_or_nodes)
    axes = tuple(np.asarray(a, dtype=float) for a in axes)
    for a in axes:
        if a.ndim != 1 or a.size < 2 or np.any(np.diff(a) <= 0):
            raise ValueError("each axis needs at least two strictly increasing values")
    return axes


def check_dimension(coordinates, ndim: int) -> None:
    """Refuse coordinates that resolve another number of axes than the kernel's ``ndim``.

    Parameters
    ----------
    coordinates : CartesianCoordinates, RCoordinates or RZCoordinates
    ndim : int
        Axes of the kernel's grid.

    Raises
    ------
    ValueError
        If ``len(coordinates.names) != ndim``.
    """
    if len(coordinates.names) != ndim:
        raise ValueError(
            f"kernel has {ndim} axes but coordinates {coordinates.kind!r} have "
            f"{len(coordinates.names)}"
        )


def grid_columns(names: Sequence[str], axes: Sequence[np.ndarray]) -> list[np.ndarray]:
    """Flattened C-ordered meshgrid of the axes.

    Parameters
    ----------
    names : sequence of str
        Coordinate names (unused: the columns come in the order of ``axes``).
    axes : sequence of ndarray
        Node (or edge) values per coordinate, any unit.

    Returns
    -------
    list of ndarray
        One array of ``prod(len(a))`` values per axis, the last axis fastest.
    """
    return [g.ravel() for g in np.meshgrid(*axes, indexing="ij")]


#: Particles per chunk of the numpy deposit: bounds the memory of the pair arrays
#: (~300 pairs per particle for a 3D Gaussian on an (r, z) grid).
DEPOSIT_CHUNK = 16384


def deposit_by_assignment(kernel, points, values, coordinates, box, groups=None, n_groups: int = 1) -> np.ndarray:
    """Kernel-weighted densities per group, the straightforward numpy way.

    ``kernel.assign`` gives the pairs (particle, node, weight); each column of
    ``values`` is then summed per (group, node) with :func:`numpy.bincount`.
    Particles are processed in chunks of :data:`DEPOSIT_CHUNK`.

    .. math::

        D_{gnk} = \\sum_{i:\\, g_i = g} w_{in}\\, q_{ik}

    Parameters
    ----------
    kernel : HeavisideBins, Gaussian or Lucy
    points : array_like, shape (N, ndim)
        Particle coordinates in the space of ``coordinates``, in the unit of the
        kernel's nodes or edges (the dump's length unit).
    values : array_like, shape (N, K) or (N,)
        Per-particle quantities :math:`q_{ik}`, any units.
    coordinates : CartesianCoordinates, RCoordinates or RZCoordinates
    box : array_like, shape (3, 2)
        Box bounds of the frame, same length unit.
    groups : array_like of int, shape (N,), optional
        Group of each particle in ``[0, n_groups)``, e.g. its species index;
        None puts every particle in group 0.
    n_groups : int

    Returns
    -------
    ndarray, shape (n_groups, n_nodes, K)
        Densities: the unit of ``values`` per volume.

    Raises
    ------
    ValueError
        If ``groups`` is not ``N`` integers in ``[0, n_groups)``, or the
        coordinates do not fit the kernel.
    """
    points = np.asarray(points, dtype=float).reshape(len(points), -1)
    values = np.asarray(values, dtype=float).reshape(len(points), -1)
    groups = check_groups(groups, len(points), n_groups)
    n_nodes, n_k = kernel.n_nodes, values.shape[1]
    out = np.zeros((n_groups * n_nodes, n_k))
    for start in range(0, len(points), DEPOSIT_CHUNK):
        chunk = slice(start, start + DEPOSIT_CHUNK)
        a = kernel.assign(points[chunk], coordinates, box)
        index = a.node if groups is None else groups[chunk][a.particle] * n_nodes + a.node
        for k in range(n_k):
            out[:, k] += np.bincount(index, weights=a.weight * values[chunk][a.particle, k],
                                     minlength=n_groups * n_nodes)
    return out.reshape(n_groups, n_nodes, n_k)


def check_groups(groups, n: int, n_groups: int):
    """Check the group of each particle for a deposit.

    Parameters
    ----------
    groups : array_like of int, shape (n,), or None
        Group of each particle.
    n : int
        Number of particles.
    n_groups : int
        Number of groups, at least 1.

    Returns
    -------
    ndarray of int64, shape (n,), or None
        ``groups`` as int64; None when ``groups`` is None.

    Raises
    ------
    ValueError
        If ``n_groups < 1``, or ``groups`` is not ``n`` integers in ``[0, n_groups)``.
    """
    if int(n_groups) < 1:
        raise ValueError(f"n_groups must be at least 1, not {n_groups}")
    if groups is None:
        return None
    groups = np.asarray(groups)
    if groups.shape != (n,) or not np.issubdtype(groups.dtype, np.integer):
        raise ValueError(f"groups must be {n} integers, got shape {groups.shape} of {groups.dtype}")
    if n and (groups.min() < 0 or groups.max() >= n_groups):
        raise ValueError(f"groups must lie in [0, {n_groups}), found [{groups.min()}, {groups.max()}]")
    return groups.astype(np.int64)
