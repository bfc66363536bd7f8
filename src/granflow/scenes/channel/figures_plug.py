"""The channel's steadiness and plug-structure figure (no paper equivalent: it says whether our thin cell
is steady and whether its plug rearranges, which the paper's deep cell does; :mod:`.analysis.plug`).

Each case (as in :mod:`granflow.scenes.channel.figures`) carries the tables ``blocks`` (per block of the
averaging window: ``t_mid``, ``ratio``, ``ratio_se``) and ``structure`` (per frame: ``t``,
``nonaffine_rms_plug``, ``q6_plug``, ``crystal_plug``, ``q6_shear``, ``crystal_shear``).
"""
from __future__ import annotations

import numpy as np
import pandas as pd
from matplotlib.figure import Figure

from granflow.plotting import MARKERS, cycle_colour, new_figure, finish
from postproc.structure import Q6_FCC


def fig_steadiness_plug(cases: list[dict], path) -> Figure:
    """(a) :math:`u_{max}/u_{slip}` per block of the averaging window, with the paper's 1.37-1.40;
    (b) the plug's root-mean-square non-affine displacement since the window's start, :math:`d_p`;
    (c) :math:`q_6` of the plug (filled) and of the shear zone (open), fcc's 0.5745 dotted, and the
    crystal-like fraction of the plug (right axis)."""
    fig, axes = new_figure(1, 3, (13, 4.2))
    a, b, c = axes[0]
    c2 = c.twinx()
    a.axhspan(1.37, 1.40, color="0.85", label="paper 1.37–1.40")
    for i, case in enumerate(cases):
        colour, marker = cycle_colour(i), MARKERS[i % len(MARKERS)]
        blocks = case.get("blocks", pd.DataFrame())
        if not blocks.empty:
            a.errorbar(blocks["t_mid"], blocks["ratio"], yerr=np.nan_to_num(blocks["ratio_se"].to_numpy(float)),
                       color=colour, marker=marker, lw=0.8, capsize=2, label=case["label"])
        s = case.get("structure", pd.DataFrame())
        if s.empty:
            continue
        b.plot(s["t"], s["nonaffine_rms_plug"], color=colour, lw=1.0, label=case["label"])
        m = s.dropna(subset=["q6_plug"])
        c.plot(m["t"], m["q6_plug"], color=colour, marker=marker, ms=3, lw=0.6)
        c.plot(m["t"], m["q6_shear"], color=colour, marker=marker, ms=3, lw=0.6, mfc="none", ls=":")
        c2.plot(m["t"], m["crystal_plug"], color=colour, lw=1.2, ls="--")
    b.axhline(1.0, color="0.5", lw=0.8, ls="--", label="one diameter")
    c.axhline(Q6_FCC, color="0.5", lw=0.8, ls=":")
    a.set(xlabel=r"time in the averaging window, $\sqrt{d_p/g}$", ylabel=r"$u_{max}/u_{slip}$ per block",
          title="(a) steadiness")
    b.set(xlabel=r"time, $\sqrt{d_p/g}$", ylabel=r"plug rms non-affine displacement, $d_p$",
          title="(b) does the plug rearrange?")
    c.set(xlabel=r"time, $\sqrt{d_p/g}$", ylabel=r"$q_6$ (plug filled, shear zone open)", ylim=(0.3, 0.6),
          title="(c) bond order")
    c2.set(ylabel="crystal-like fraction of the plug (dashed)", ylim=(0.0, 1.0))
    a.legend(fontsize=7)
    b.legend(fontsize=7)
    return finish(fig, cases, path, right_in=0.75)
