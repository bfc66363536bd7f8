"""Frame sums kept in contiguous blocks, and the lifecycle every time-averaging analysis shares.

A result is read only after ``conclude()``; before that it raises.

Standard errors of time-averaged fields follow the project's rule for any time
average (:mod:`postproc.autocorr`): the error of the mean of the field's series
over the sub-blocks of consecutive frames, with the series' statistical
inefficiency :math:`g` (:func:`correlated_errors`); while the series does not
resolve its correlation (fewer than :math:`50\\max(g, g_b)` sub-blocks, :math:`g_b` the
inefficiency the blocks imply) the larger of that and the
block error (:func:`block_errors`, the spread of ``n_blocks`` contiguous
blocks), by :func:`postproc.autocorr.combined_error`.
"""
from __future__ import annotations

from typing import Callable, Mapping, Sequence

import numpy as np
import pandas as pd

from .autocorr import MIN_SAMPLES, combined_errors, statistical_inefficiencies

#: Sub-blocks kept per requested block (memory bound, see module docstring).
SUBBLOCKS_PER_BLOCK = 16


class BlockedSums:
    """Frame sums kept in at most ``capacity`` contiguous sub-blocks of equal length.

    The per-frame sums of every time-averaging analysis (:class:`ConcludedResult`):
    memory stays bounded by ``capacity`` sub-blocks however many frames are added,
    as full sub-blocks merge pairwise (see :meth:`add`).

    Parameters
    ----------
    capacity : int
        Sub-blocks kept at most (rounded up to even); the analyses ask for
        :data:`SUBBLOCKS_PER_BLOCK` times their ``n_blocks``.

    Attributes
    ----------
    sums : list of ndarray
        The sum of each sub-block, in time order, each the shape of one frame's values.
    counts : list of int
        Frames in each sub-block.
    length : int
        Frames per full sub-block (doubles at every merge).
    """

    def __init__(self, capacity: int):
        self.capacity = capacity + capacity % 2
        self.sums: list[np.ndarray] = []
        self.counts: list[int] = []
        self.length = 1  # frames per full sub-block

    @property
    def n_frames(self) -> int:
        """Frames added so far."""
        return int(sum(self.counts))

    def add(self, x: np.ndarray) -> None:
        """Add one frame's values to the last sub-block, or start a new one.

        A full last sub-block starts a new one; when all ``capacity`` are full,
        adjacent pairs merge first (the sub-block length doubles).

        Parameters
        ----------
        x : ndarray
            The frame's values (e.g. primitive densities, shape (n_nodes, K)); the
            same shape every frame, any unit.
        """
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
        """Mean over all frames added, the shape of one frame's values.

        Returns
        -------
        ndarray
        """
        return np.sum(self.sums, axis=0) / self.n_frames

    def block_means(self, n_blocks: int) -> list[np.ndarray]:
        """Means over ``min(n_blocks, n_subblocks)`` contiguous, nearly equal blocks.

        Parameters
        ----------
        n_blocks : int
            Blocks wanted; whole sub-blocks are grouped by their middle frame.

        Returns
        -------
        list of ndarray
            One mean per block, in time order, each the shape of a frame's values.
        """
        counts = np.asarray(self.counts, dtype=float)
        nb = min(n_blocks, len(counts))
        middle = np.cumsum(counts) - 0.5 * counts
        label = np.floor(middle * nb / counts.sum()).astype(int)
        means = []
        for b in range(nb):
            members = np.flatnonzero(label == b)
            means.append(sum(self.sums[j] for j in members) / counts[members].sum())
        return means

    def subblock_means(self) -> tuple[list[np.ndarray], np.ndarray]:
        """Means over each current sub-block, in time order, and the sub-blocks' frame counts.

        Returns
        -------
        means : list of ndarray
            One per sub-block, in time order.
        counts : ndarray of float, shape (n_sub,)
            Frames in each sub-block.
        """
        counts = np.asarray(self.counts, dtype=float)
        return [s / c for s, c in zip(self.sums, counts)], counts


def block_errors(block_values: np.ndarray) -> np.ndarray:
    """Block standard error of the mean of each column.

    .. math:: \\mathrm{se}_\\mathrm{block} = \\frac{\\operatorname{std}_{\\mathrm{ddof}=1}(f_b)}
        {\\sqrt{n_\\mathrm{blocks}}}

    Parameters
    ----------
    block_values : ndarray, shape (n_blocks, n_nodes)
        A derived field in each block.

    Returns
    -------
    ndarray, shape (n_nodes,)
        NaN with fewer than two blocks, or where any block is NaN.
    """
    block_values = np.asarray(block_values, dtype=float)
    if len(block_values) < 2:
        return np.full(block_values.shape[1:], np.nan)
    return block_values.std(axis=0, ddof=1) / np.sqrt(len(block_values))


def correlated_errors(sub_values: np.ndarray, counts: np.ndarray, block_se: np.ndarray) -> np.ndarray:
    """Standard error of the time average of each column, allowing for autocorrelation.

    Column :math:`j` of ``sub_values`` is the series :math:`y_i` of a derived
    field over sub-blocks of :math:`c_i` consecutive frames. Its error is
    :func:`postproc.autocorr.weighted_mean_error` (the count-weighted
    ratio-estimator variance times the statistical inefficiency :math:`g` of
    :math:`y_i`),

    .. math:: \\mathrm{se}^2 = g\\,\\frac{n}{n-1}\\,
        \\frac{\\sum_i c_i^2 (y_i - \\bar y)^2}{(\\sum_i c_i)^2}, \\qquad
        \\bar y = \\frac{\\sum_i c_i y_i}{\\sum_i c_i},

    combined with the column's block error by
    :func:`postproc.autocorr.combined_error`: ``se`` when the series resolves its
    correlation (:math:`n \\ge 50 \\max(g, g_b)`), else the larger of ``se`` and the block error; the
    block error when fewer than :data:`~postproc.autocorr.MIN_SAMPLES`
    sub-blocks are finite.

    Every column's :math:`g` comes from one call of emcee
    (:func:`postproc.autocorr.statistical_inefficiencies`); a column with NaN sub-blocks (a node that
    held no mass then) uses its finite ones as one consecutive series, as
    :func:`~postproc.autocorr.weighted_mean_error` does.

    Parameters
    ----------
    sub_values : ndarray, shape (n_sub, n_nodes)
        The derived field of each sub-block, in time order.
    counts : ndarray, shape (n_sub,)
        Frames in each sub-block.
    block_se : ndarray, shape (n_nodes,)
        Block errors (:func:`block_errors`).

    Returns
    -------
    ndarray, shape (n_nodes,)

    Raises
    ------
    ValueError
        If the shapes do not match as above.
    """
    y = np.asarray(sub_values, dtype=float)
    counts = np.asarray(counts, dtype=float)
    block_se = np.asarray(block_se, dtype=float)
    if y.ndim != 2 or y.shape[0] != counts.shape[0] or block_se.shape != y.shape[1:]:
        raise ValueError(f"need sub_values (n_sub, n_nodes), counts (n_sub,), block_se (n_nodes,); got "
                         f"{y.shape}, {counts.shape}, {block_se.shape}")
    out = block_se.copy()  # fewer than MIN_SAMPLES finite sub-blocks: the block error
    finite = np.isfinite(y)
    n_finite = finite.sum(axis=0)
    # each column's finite sub-blocks first, in time order, then columns with as many at once
    order = np.argsort(~finite, axis=0, kind="stable")
    y = np.take_along_axis(y, order, axis=0)
    counts = counts[order]
    for n in np.unique(n_finite[n_finite >= MIN_SAMPLES]):
        cols = np.flatnonzero(n_finite == n)
        out[cols] = _combined_columns(y[:n, cols], counts[:n, cols], block_se[cols])
    return out


def _combined_columns(y: np.ndarray, counts: np.ndarray, block_se: np.ndarray) -> np.ndarray:
    """:func:`postproc.autocorr.combined_error` of :func:`~postproc.autocorr.weighted_mean_error`, per column,
    with every column's :math:`g` from one call of emcee (:func:`postproc.autocorr.statistical_inefficiencies`).

    ``y`` and ``counts`` are finite (n, m) arrays with :math:`n \\ge` ``MIN_SAMPLES``.
    """
    n = len(y)
    w = counts / counts.sum(axis=0)
    mean = (w * y).sum(axis=0)
    se_naive = np.sqrt(n / (n - 1) * ((w * (y - mean)) ** 2).sum(axis=0))
    g = statistical_inefficiencies(y)
    return combined_errors(se_naive * np.sqrt(g), se_naive, g, n, block_se)


def time_average_errors(sums: BlockedSums, derive: Callable[[np.ndarray], Mapping[str, np.ndarray]],
                        names: Sequence[str], n_blocks: int) -> tuple[dict[str, np.ndarray], dict[str, np.ndarray]]:
    """Correlation-aware and block standard errors of derived time-averaged fields.

    Every field is derived from the averaged primitives of each block and of
    each sub-block, exactly as from the average over all frames.

    Parameters
    ----------
    sums : BlockedSums
        The per-frame primitive sums.
    derive : callable
        Primitive means (n_nodes, K) -> {name: (n_nodes,) field}.
    names : sequence of str
        Fields to give errors for.
    n_blocks : int
        Blocks for the block error.

    Returns
    -------
    se, se_block : dict of str to ndarray
        Per name: :func:`correlated_errors` (the error to report) and
        :func:`block_errors` (the cross-check it is combined with).
    """
    blocks = [derive(m) for m in sums.block_means(n_blocks)]
    sub_means, counts = sums.subblock_means()
    subs = [derive(m) for m in sub_means]
    se, se_block = {}, {}
    for name in names:
        se_block[name] = block_errors(np.array([b[name] for b in blocks]))
        se[name] = correlated_errors(np.array([s[name] for s in subs]), counts, se_block[name])
    return se, se_block


class ConcludedResult:
    """The read side of the prepare / accumulate / conclude lifecycle.

    Subclasses set ``_result`` in ``conclude()`` and keep their per-frame sums in
    ``_sums`` (a :class:`BlockedSums`, or None before ``prepare()``).
    """

    _result: pd.DataFrame | None = None
    _sums: "BlockedSums | None" = None

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
