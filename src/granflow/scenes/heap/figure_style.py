"""Helpers the heap's figure modules share: the empty-campaign panels and each case's style."""
from __future__ import annotations

import numpy as np

from granflow.plotting import MARKERS, NO_CASE, cycle_colour, say


def _no_case(axes):
    for ax in np.ravel(axes):
        say(ax, NO_CASE, fontsize=11)



def _case_style(i: int, case: dict) -> dict:
    """Colour and marker per case; filled for bidisperse, open for monodisperse (paper table 1)."""
    return dict(color=cycle_colour(i), marker=MARKERS[i % len(MARKERS)],
                mfc=cycle_colour(i) if case.get("bidisperse") else "none")
