"""Exact overlap of spheres with slabs: volume fractions in bins.

A sphere cut by parallel planes splits its volume exactly among the slabs
between them (:func:`sphere_slab_fraction`, the spherical-cap formula);
:func:`slab_pairs` lists every (sphere, slab) pair with its fraction. Used by
:class:`postproc.fields.FieldAccumulator` with ``volume="exact"`` and by the
heap's volume-fraction columns.
"""
from __future__ import annotations

import numpy as np


def fraction_below(plane, c, r):
    """Fraction of a sphere (centre ``c``, radius ``r``) below the plane at ``plane``.

    With :math:`h` the signed distance of the plane from the centre, the part
    below is a cap of height :math:`r + h` and volume :math:`\\frac{\\pi}{3}(r+h)^2(2r-h)`.
    A sphere of radius 0 (a point particle) is all below a plane above its centre,
    else all above.

    Parameters
    ----------
    plane : float or array_like
        Coordinate of the plane along the axis normal to it.
    c : float or array_like
        Coordinate of each sphere's centre along the same axis, the unit of ``plane``.
    r : float or array_like
        Radius of each sphere, the same unit; ``plane``, ``c`` and ``r`` broadcast together.

    Returns
    -------
    ndarray
        Fractions in :math:`[0, 1]`, the broadcast shape of the arguments.
    """
    with np.errstate(divide="ignore", invalid="ignore"):
        s = np.clip((plane - c) / r, -1.0, 1.0)
    s = np.where(r > 0, s, np.where(plane > c, 1.0, -1.0))  # a point particle
    return 0.25 * (1.0 + s) ** 2 * (2.0 - s)


def sphere_slab_fraction(c, r, lo, hi):
    """Exact fraction of a sphere's volume between two parallel planes.

    Along any axis, for a sphere of centre coordinate :math:`c` and radius
    :math:`r`, the volume below a plane at signed distance :math:`h` from the
    centre (:math:`|h| \\le r`) is the cap

    .. math::

        V_{below}(h) = \\frac{\\pi}{3} (r + h)^2 (2r - h),

    so the fraction between :math:`lo < hi` is
    :math:`[V_{below}(hi - c) - V_{below}(lo - c)] / \\tfrac43\\pi r^3`.

    Parameters
    ----------
    c, r, lo, hi : array_like
        Broadcast together; lengths in any consistent unit.

    Returns
    -------
    ndarray
        Fractions in :math:`[0, 1]`.
    """
    c, r, lo, hi = (np.asarray(a, dtype=float) for a in (c, r, lo, hi))
    return fraction_below(hi, c, r) - fraction_below(lo, c, r)


def slab_pairs(c: np.ndarray, r: np.ndarray, edges: np.ndarray):
    """Every (particle, slab) pair with the exact fraction of the particle in the slab.

    Parts of spheres outside the edges are not assigned to any slab; pairs with
    a zero fraction are dropped.

    Parameters
    ----------
    c : ndarray, shape (n,)
        Coordinate of each particle's centre along the axis normal to the slabs.
    r : ndarray, shape (n,)
        Radius of each particle, the unit of ``c``.
    edges : ndarray, shape (n_slabs + 1,)
        Increasing slab edges along the same axis, the unit of ``c``.

    Returns
    -------
    particle : ndarray of int, shape (n_pairs,)
        Index of the particle of each pair, in particle order.
    slab : ndarray of int, shape (n_pairs,)
        Index of the slab of each pair (slab ``k`` lies between ``edges[k]`` and ``edges[k + 1]``).
    fraction : ndarray of float, shape (n_pairs,)
        Fraction of the particle's volume in the slab, in :math:`(0, 1]`.
    """
    n = len(edges) - 1
    first = np.clip(np.searchsorted(edges, c - r, side="right") - 1, 0, n - 1)
    last = np.clip(np.searchsorted(edges, c + r, side="left") - 1, 0, n - 1)
    count = np.maximum(last - first + 1, 1)
    particle = np.repeat(np.arange(len(c)), count)
    offset = np.arange(particle.size) - np.repeat(np.cumsum(count) - count, count)
    slab = first[particle] + offset
    fraction = sphere_slab_fraction(c[particle], r[particle], edges[slab], edges[slab + 1])
    keep = fraction > 0
    return particle[keep], slab[keep], fraction[keep]
