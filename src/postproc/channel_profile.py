"""Channel profiles across x in Heaviside bins (Debnath et al. 2022): a :class:`~postproc.fields.FieldAccumulator`
on the channel's bins, over a sequence of frames."""
from __future__ import annotations

from typing import Iterable

import pandas as pd

from .coordinates import XCoordinates
from .fields import FieldAccumulator
from .frame import ParticleFrame
from .kernels import HeavisideBins, channel_bin_edges


def profile_from_frames(
    frames: Iterable[ParticleFrame],
    W: float,
    bin_width: float = 1.0,
    wall_bin_width: float = 1.5,
    n_blocks: int = 8,
    fluctuation: str = "window",
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
    fluctuation : str
        ``window`` or ``frame``: what T and the kinetic stress are fluctuations about (module docstring).

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
        fluctuation=fluctuation,
    )
    accumulator.prepare()
    for frame in frames:
        accumulator.accumulate(frame)
    return accumulator.conclude()
