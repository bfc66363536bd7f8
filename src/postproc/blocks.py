"""Frame sums kept in contiguous blocks, and the lifecycle every time-averaging analysis shares.

A result is read only after ``conclude()``; before that it raises. Block sums give
the standard errors of time averages (blocks of consecutive frames).
"""
from __future__ import annotations

import numpy as np
import pandas as pd

#: Sub-blocks kept per requested block (memory bound, see module docstring).
_SUBBLOCKS_PER_BLOCK = 16


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
