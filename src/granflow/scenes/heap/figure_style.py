"""Helpers the heap's figure modules share: the empty-campaign panels and each case's style."""
from __future__ import annotations

import numpy as np

from granflow.plotting import MARKERS, NO_CASE, cycle_colour, say


def no_case(axes):
    """Write :data:`~granflow.plotting.NO_CASE` in the middle of every panel (a figure with no case).

    Parameters
    ----------
    axes : matplotlib.axes.Axes or array_like of Axes
        The figure's panels, any shape.
    """
    for ax in np.ravel(axes):
        say(ax, NO_CASE, fontsize=11)



def case_style(i: int, case: dict) -> dict:
    """Colour and marker per case; filled for bidisperse, open for monodisperse (paper table 1).

    Parameters
    ----------
    i : int
        The case's index among the figure's cases.
    case : dict
        The case; a true ``bidisperse`` fills its markers.

    Returns
    -------
    dict
        Keyword arguments of :meth:`matplotlib.axes.Axes.plot`: ``color``, ``marker``
        and ``mfc`` (the marker's face colour, ``"none"`` for open).
    """
    return dict(color=cycle_colour(i), marker=MARKERS[i % len(MARKERS)],
                mfc=cycle_colour(i) if case.get("bidisperse") else "none")
