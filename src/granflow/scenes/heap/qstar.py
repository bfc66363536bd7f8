"""The heap's δ/d̄ ∝ q*^a the way the paper pools it: across feed rates, at fixed x/L.

Fan et al. (2013, §3.3, Fig. 11) pool eleven runs of 10-120 g/s (several mixtures) at x/L ≥ 0.2 and
find a ≈ 0.22. Within one case q* falls along the heap while δ thins toward the end wall, so a fit
over x inside a case measures that thinning, not how δ follows the feed: here each x/L bin is its own
group (a fixed effect) and only the change between feed rates at the same x/L enters,

.. math:: \\ln(\\delta/\\bar d)_{ij} = c_j + a \\ln q^*_{ij},

case i, bin j: the slope of the within-bin deviations. Its error is the residuals' (bins taken as
independent: neighbours share particles, an underestimate). It is a comparison with the paper only
over at least :data:`MIN_RATES` feed rates spanning at least :data:`MIN_SPAN`; with fewer it is a
diagnostic. :func:`across_feed_rates` reads the record's ``streamwise`` profile only, so a committed
record is judged by the same code as a rerun.
"""
from __future__ import annotations

import math
import re

import numpy as np
import pandas as pd

from granflow.validation import Check

#: the paper's exponent (§3.3, Fig. 11), to the digits stated
PAPER_RANGE = (0.215, 0.225)
#: the paper's fit uses x/L ≥ 0.2
MIN_X_OVER_L = 0.2
#: a comparison needs this many feed rates ...
MIN_RATES = 3
#: ... spanning at least this factor (the paper's 10-120 g/s span 12)
MIN_SPAN = 3.0
QUANTITY = "δ/d̄ ∝ q*^a across feed rates at fixed x/L ≥ 0.2: exponent a"


def feed_rate_of(case: str) -> float:
    """The feed rate in g/s that a heap case directory names (``.../mdot~33``), NaN if none."""
    m = re.search(r"(?:^|/)mdot~([0-9.eE+-]+)(?:/|$)", case)
    return float(m.group(1)) if m else float("nan")


def across_feed_rates(streamwise: pd.DataFrame | None) -> list[Check]:
    """The q* exponent with one intercept per x/L bin (module docstring); [] without the columns."""
    need = {"case", "x_over_L", "delta", "d_bar", "q_star"}
    if streamwise is None or not need <= set(streamwise):
        return []
    df = streamwise.copy()
    if "usable" in df:
        df = df[df["usable"].astype(str).str.lower().isin(("true", "1", "1.0"))]
    df = df[(df["x_over_L"] >= MIN_X_OVER_L - 1e-9) & (df["delta"] > 0) & (df["q_star"] > 0)]
    df = df.assign(rate=df["case"].map(feed_rate_of), bin=df["x_over_L"].round(3),
                   ld=np.log(df["delta"] / df["d_bar"]), lq=np.log(df["q_star"]))
    df = df[np.isfinite(df["rate"])]
    shared = df.groupby("bin")["rate"].transform("nunique") >= 2
    df = df[shared]
    rates = sorted(df["rate"].unique())
    paper = "≈ 0.22 (eleven runs of 10-120 g/s pooled at x/L ≥ 0.2)"
    source = "§3.3, Fig. 11"
    if len(rates) < 2:
        return [Check(QUANTITY, paper, source, float("nan"), paper_range=PAPER_RANGE, kind="diagnostic",
                      note=f"needs two feed rates at the same x/L; has {', '.join(f'{r:g}' for r in rates) or 'none'} g/s")]
    dq = df["lq"] - df.groupby("bin")["lq"].transform("mean")
    dl = df["ld"] - df.groupby("bin")["ld"].transform("mean")
    sxx = float(np.sum(dq ** 2))
    a = float(np.sum(dq * dl) / sxx)
    n_bins = int(df["bin"].nunique())
    dof = len(df) - n_bins - 1
    se = float(math.sqrt(np.sum((dl - a * dq) ** 2) / dof / sxx)) if dof > 0 else float("nan")
    per_bin = df.groupby("bin").apply(
        lambda g: np.polyfit(g["lq"], g["ld"], 1)[0] if g["rate"].nunique() >= 2 else np.nan, include_groups=False)
    span = rates[-1] / rates[0]
    enough = len(rates) >= MIN_RATES and span >= MIN_SPAN
    note = (f"ln(δ/d̄) on ln q* with one intercept per x/L bin, {n_bins} bins at x/L = {df['bin'].min():g}-"
            f"{df['bin'].max():g} shared by {len(rates)} feed rates ({', '.join(f'{r:g}' for r in rates)} g/s, span "
            f"{span:.2g}x); per-bin slopes {per_bin.min():.3f} to {per_bin.max():.3f} (median {per_bin.median():.3f}); "
            f"error: the residuals', bins taken as independent (an underestimate). ")
    note += ("A comparison: the paper's pooling over feed rates." if enough else
             f"A diagnostic until {MIN_RATES} feed rates span {MIN_SPAN:g}x (the paper's 10-120 g/s span 12x): "
             f"two rates {span:.2g}x apart leave the exponent to the noise of two δ readings per bin")
    return [Check(QUANTITY, paper, source, a, se, paper_range=PAPER_RANGE, note=note,
                  kind="comparison" if enough else "diagnostic")]
