"""Channel profiles across x in Heaviside bins (Debnath et al. 2022): a :class:`~postproc.fields.FieldAccumulator`
on the channel's bins, over a sequence of frames, with the shear rate :math:`du_y/dx` across the bins and its
error (:func:`shear_rate`)."""
from __future__ import annotations

from typing import Iterable

import numpy as np
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
    table = accumulator.conclude()
    if "u_y" not in table:
        return table
    x = table["x"].to_numpy(float)
    values, se = accumulator.errors_of(lambda fields: {SHEAR: shear_rate(x, fields["u_y"]),
                                                       SCALED: scaled_velocity(fields["u_y"])}, [SHEAR, SCALED])
    for name in (SHEAR, SCALED):
        fields = [c for c in table.columns if c not in ("x", "x_lo", "x_hi") and not c.endswith("_se")]
        at = len(("x", "x_lo", "x_hi")) + len(fields)   # a field column among the fields, its error among the errors
        table.insert(at, name, values[name])
        table[f"{name}_se"] = se[name]
    return table


#: the shear-rate column of a channel profile
SHEAR = "du_y_dx"
#: the scaled-velocity column of a channel profile
SCALED = "u_scaled"


def scaled_velocity(u_y: np.ndarray) -> np.ndarray:
    """:math:`(u - u_{slip})/(u_{max} - u_{slip})` across the channel, :math:`u = |u_y|` (the paper's eq. 3.1 scaling):
    :math:`u_{slip}` the mean of the two wall bins, :math:`u_{max}` the fastest bin. Its error comes from the same
    scaling of each block's and sub-block's profile (:meth:`~postproc.fields.FieldAccumulator.errors_of`): a change
    of speed of the whole channel scales every bin alike and leaves it unchanged.

    Parameters
    ----------
    u_y : ndarray
        The bins' velocity along the flow, wall to wall.

    Returns
    -------
    ndarray
        The scaled velocity per bin (NaN with fewer than three bins or without shear).
    """
    u = np.abs(np.asarray(u_y, float))
    if len(u) < 3 or not np.isfinite(u).all():
        return np.full(len(u), np.nan)
    slip, top = 0.5 * (u[0] + u[-1]), float(np.max(u))
    return (u - slip) / (top - slip) if top > slip else np.full(len(u), np.nan)


def shear_rate(x: np.ndarray, u_y: np.ndarray) -> np.ndarray:
    """:math:`du_y/dx` at the bin centres ``x`` (:func:`numpy.gradient`: second-order central differences on the
    non-uniform bins, first order at the walls). Its error comes from the same difference of each block's and
    sub-block's profile (:meth:`~postproc.fields.FieldAccumulator.errors_of`): a change of speed of the whole
    channel moves every bin alike and no gradient.

    Parameters
    ----------
    x : ndarray
        Bin centres across the channel, length units.
    u_y : ndarray
        The bins' velocity along the flow.

    Returns
    -------
    ndarray
        :math:`du_y/dx` per bin (NaN with fewer than two bins).
    """
    u_y = np.asarray(u_y, float)
    return np.gradient(u_y, np.asarray(x, float)) if len(u_y) >= 2 else np.full(len(u_y), np.nan)
