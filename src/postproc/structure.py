"""Local structure of a packing: Steinhardt bond order and crystal-like particles.

For each particle :math:`i` with the :math:`N_b(i)` neighbours :math:`j` whose centres lie within
``cutoff`` (minimum image along the periodic axes), the bond-orientational vector

.. math:: q_{lm}(i) = \\frac{1}{N_b(i)} \\sum_j Y_{lm}(\\hat r_{ij}), \\qquad
    q_l(i) = \\sqrt{\\frac{4\\pi}{2l+1} \\sum_{m=-l}^{l} |q_{lm}(i)|^2}

(Steinhardt, Nelson & Ronchetti 1983): :math:`q_6` = 0.5745 in a perfect fcc lattice and 0.4848 in
hcp with 12 neighbours, about 0.3-0.4 in a dense random packing. A bond :math:`ij` is *solid-like*
when the normalised product

.. math:: d_6(i, j) = \\frac{\\mathrm{Re}\\sum_m q_{6m}(i)\\, q_{6m}^*(j)}{|q_6(i)|\\,|q_6(j)|} > 0.7,

and a particle with at least 7 solid-like bonds is *crystal-like* (ten Wolde, Ruiz-Montero &
Frenkel 1996, J. Chem. Phys. 104, 9932): every particle of a lattice, a few per cent of a random
packing. Knows no scene: give positions, the box and which axes are periodic.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree
from scipy.special import sph_harm_y

#: q_6 of perfect lattices with their 12 nearest neighbours
Q6_FCC = 0.5745
Q6_HCP = 0.4848
#: ten Wolde et al. (1996): a bond is solid-like above this d_6, a particle crystal-like with this many
SOLID_BOND = 0.7
CRYSTAL_BONDS = 7


@dataclass(frozen=True)
class BondOrder:
    """Per-particle bond order of one configuration.

    Attributes
    ----------
    qlm : ndarray, shape (N, 2l+1), complex
        :math:`q_{lm}(i)`, m = -l ... l (zero for a particle without neighbours).
    q : ndarray, shape (N,)
        :math:`q_l(i)` (NaN without neighbours).
    n_neighbours : ndarray of int, shape (N,)
    pairs : ndarray of int, shape (P, 2)
        The neighbour pairs (i < j).
    l : int
    """

    qlm: np.ndarray
    q: np.ndarray
    n_neighbours: np.ndarray
    pairs: np.ndarray
    l: int

    def solid_bonds(self, threshold: float = SOLID_BOND) -> np.ndarray:
        """Number of solid-like bonds of each particle, :math:`d_l(i, j)` > ``threshold``.

        Parameters
        ----------
        threshold : float
            A bond is solid-like when its :math:`d_l` exceeds it (:data:`SOLID_BOND`).

        Returns
        -------
        ndarray of int, shape (N,)
        """
        i, j = self.pairs[:, 0], self.pairs[:, 1]
        norm = np.linalg.norm(self.qlm, axis=1)
        with np.errstate(invalid="ignore", divide="ignore"):
            d = np.real(np.sum(self.qlm[i] * np.conj(self.qlm[j]), axis=1)) / (norm[i] * norm[j])
        solid = np.nan_to_num(d, nan=0.0) > threshold
        counts = np.zeros(len(self.q), dtype=int)
        np.add.at(counts, i[solid], 1)
        np.add.at(counts, j[solid], 1)
        return counts

    def global_q(self, mask=None) -> float:
        """The global bond order :math:`Q_l` of a set of particles (Steinhardt et al. 1983): the average of
        :math:`Y_{lm}` over every bond of the set's particles (each particle's :math:`q_{lm}(i)` weighted by
        its neighbours), then :math:`Q_l = [4\\pi/(2l+1) \\sum_m |\\bar Q_{lm}|^2]^{1/2}`. :math:`Q_6` is
        0.5745 for fcc, about :math:`1/\\sqrt{N_b}` for :math:`N_b` bonds without common orientation.

        Parameters
        ----------
        mask : ndarray of bool, shape (N,), optional
            The particles of the set (default: all).

        Returns
        -------
        float
            NaN when the set has no bond.
        """
        pick = np.ones(len(self.q), dtype=bool) if mask is None else np.asarray(mask, dtype=bool)
        weight = self.n_neighbours[pick]
        if weight.sum() == 0:
            return float("nan")
        mean = (self.qlm[pick] * weight[:, None]).sum(axis=0) / weight.sum()
        return float(np.sqrt(4.0 * np.pi / (2 * self.l + 1) * np.sum(np.abs(mean) ** 2)))

    def crystal_like(self, threshold: float = SOLID_BOND, min_bonds: int = CRYSTAL_BONDS) -> np.ndarray:
        """True for each particle with at least ``min_bonds`` solid-like bonds.

        Parameters
        ----------
        threshold : float
            A bond is solid-like when its :math:`d_l` exceeds it (:data:`SOLID_BOND`).
        min_bonds : int
            Fewest solid-like bonds of a crystal-like particle (:data:`CRYSTAL_BONDS`).

        Returns
        -------
        ndarray of bool, shape (N,)
        """
        return self.solid_bonds(threshold) >= min_bonds


def neighbour_pairs(position: np.ndarray, box: np.ndarray, periodic, cutoff: float) -> tuple[np.ndarray, np.ndarray]:
    """Pairs closer than ``cutoff`` and their separation vectors :math:`r_j - r_i` (minimum image).

    Parameters
    ----------
    position : ndarray, shape (N, 3)
        Particle centres, any length unit.
    box : ndarray, shape (3, 2)
        Lower and upper bound per axis, same unit.
    periodic : sequence of 3 bool
        Which axes wrap (a wall-bounded axis does not).
    cutoff : float
        Neighbour distance, in the units of ``position``.

    Returns
    -------
    pairs : ndarray of int, shape (P, 2)
        Indices ``(i, j)`` of each pair, i < j.
    separation : ndarray, shape (P, 3)
        :math:`r_j - r_i`, minimum-imaged along the periodic axes, same unit.
    """
    pos = np.asarray(position, dtype=float)
    box = np.asarray(box, dtype=float)
    lo, length = box[:, 0], box[:, 1] - box[:, 0]
    periodic = np.asarray(periodic, dtype=bool)
    shifted = pos - lo
    shifted[:, periodic] = np.mod(shifted[:, periodic], length[periodic])
    # a wall-bounded axis: a box wider than the particles' extent by twice the cutoff never wraps a pair
    span = np.where(periodic, length, np.ptp(shifted, axis=0) + 2.0 * cutoff + 1.0)
    if (~periodic).any():
        shifted[:, ~periodic] -= shifted[:, ~periodic].min(axis=0) - cutoff
    # cKDTree wants every coordinate in [0, boxsize)
    shifted = np.minimum(shifted, np.nextafter(span, 0.0))
    tree = cKDTree(shifted, boxsize=span)
    pairs = tree.query_pairs(cutoff, output_type="ndarray")
    if len(pairs) == 0:
        return np.zeros((0, 2), dtype=int), np.zeros((0, 3))
    d = shifted[pairs[:, 1]] - shifted[pairs[:, 0]]
    d[:, periodic] -= length[periodic] * np.round(d[:, periodic] / length[periodic])
    return pairs, d


def bond_order(position: np.ndarray, box: np.ndarray, periodic, cutoff: float, l: int = 6) -> BondOrder:
    """:math:`q_{lm}(i)` and :math:`q_l(i)` of every particle (module docstring).

    ``l`` must be even (then :math:`Y_{lm}(-\\hat r) = Y_{lm}(\\hat r)` and each pair counts once for both).

    Parameters
    ----------
    position : ndarray, shape (N, 3)
        Particle centres, any length unit.
    box : ndarray, shape (3, 2)
        Lower and upper bound per axis, same unit.
    periodic : sequence of 3 bool
        Which axes wrap.
    cutoff : float
        Neighbour distance, same unit.
    l : int
        Degree of the spherical harmonics, even.

    Returns
    -------
    BondOrder

    Raises
    ------
    ValueError
        For an odd ``l``.
    """
    if l % 2:
        raise ValueError(f"l = {l}: only even l (the bond direction's sign then does not matter)")
    n = len(position)
    pairs, d = neighbour_pairs(position, box, periodic, cutoff)
    r = np.linalg.norm(d, axis=1)
    polar = np.arccos(np.clip(d[:, 2] / np.where(r > 0, r, 1.0), -1.0, 1.0))
    azimuth = np.arctan2(d[:, 1], d[:, 0])
    qlm = np.zeros((n, 2 * l + 1), dtype=complex)
    counts = np.zeros(n, dtype=int)
    np.add.at(counts, pairs[:, 0], 1)
    np.add.at(counts, pairs[:, 1], 1)
    for k, m in enumerate(range(-l, l + 1)):
        y = sph_harm_y(l, m, polar, azimuth)
        np.add.at(qlm[:, k], pairs[:, 0], y)
        np.add.at(qlm[:, k], pairs[:, 1], y)
    has = counts > 0
    qlm[has] /= counts[has, None]
    q = np.full(n, np.nan)
    q[has] = np.sqrt(4.0 * np.pi / (2 * l + 1) * np.sum(np.abs(qlm[has]) ** 2, axis=1))
    return BondOrder(qlm, q, counts, pairs, l)


def layering(coordinate: np.ndarray, length: float, spacing: tuple[float, float]) -> tuple[float, float]:
    """How strongly points stack in layers along a periodic axis: ``(S, wavelength)``.

    .. math:: S = \\max_n \\left| \\frac{1}{N} \\sum_i e^{2\\pi i n z_i / L} \\right|

    over the whole numbers of layers :math:`n` whose spacing :math:`L/n` lies in ``spacing``
    (e.g. 0.8-1.2 particle diameters). S is 1 for perfect layers and about :math:`1/\\sqrt{N}`
    for points without order.

    Parameters
    ----------
    coordinate : ndarray, shape (N,)
        The points' coordinate along the axis, any length unit.
    length : float
        :math:`L`, the period of the axis (the box length), same unit.
    spacing : tuple of (float, float)
        Smallest and largest layer spacing to try, same unit.

    Returns
    -------
    S : float
        NaN without points; 0 when no whole number of layers fits ``spacing``.
    wavelength : float
        The layer spacing :math:`L/n` of the largest :math:`S`, same unit (NaN
        when none).
    """
    z = np.asarray(coordinate, dtype=float)
    if len(z) == 0:
        return float("nan"), float("nan")
    n_lo, n_hi = max(1, int(np.ceil(length / spacing[1]))), int(np.floor(length / spacing[0]))
    best, wave = 0.0, float("nan")
    for n in range(n_lo, n_hi + 1):
        s = float(np.abs(np.mean(np.exp(2j * np.pi * n * z / length))))
        if s > best:
            best, wave = s, length / n
    return best, wave
