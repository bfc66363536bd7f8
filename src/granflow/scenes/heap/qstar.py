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
from granflow.verdicts import systematic

#: the paper's exponent (§3.3, Fig. 11), to the digits stated
PAPER_RANGE = (0.215, 0.225)
#: the paper's fit uses x/L ≥ 0.2
MIN_X_OVER_L = 0.2
#: the fit-range variants (the syst): from x/L 0.3, and up to 0.8 (without the bins next to the end wall)
X_VARIANTS = (0.3, 0.8)
#: a comparison needs this many feed rates ...
MIN_RATES = 3
#: ... spanning at least this factor (the paper's 10-120 g/s span 12)
MIN_SPAN = 3.0
QUANTITY = "δ/d̄ ∝ q*^a across feed rates at fixed x/L ≥ 0.2: exponent a"


def feed_rate_of(case: str) -> float:
    """The feed rate in g/s that a heap case directory names (``.../mdot~33``), NaN if none."""
    m = re.search(r"(?:^|/)mdot~([0-9.eE+-]+)(?:/|$)", case)
    return float(m.group(1)) if m else float("nan")


def on_grid(case: pd.DataFrame, grid: np.ndarray, columns: tuple[str, ...] = ("ld", "lq")) -> pd.DataFrame:
    """One case's ``columns`` (by default ``ld`` = ln(δ/d̄) and ``lq`` = ln q*) at the x/L points of ``grid``
    (``x_over_L`` the point, ``bin`` it to 3 decimals): its own bin where one lies there, else linear between two
    of its usable bins that are neighbours (at most one bin width apart); a grid point outside its bins, or across
    a gap of unusable bins, is left out."""
    c = case.sort_values("x_over_L")
    x = c["x_over_L"].to_numpy(float)
    step = float(np.median(np.diff(x))) if len(x) > 1 else 0.0
    rows = []
    for p in grid:
        j = int(np.searchsorted(x, p - 1e-6))
        if j < len(x) and abs(x[j] - p) <= 1e-6:
            w = 0.0
        elif 0 < j < len(x) and x[j] - x[j - 1] <= 1.01 * step:
            w = (p - x[j - 1]) / (x[j] - x[j - 1])
        else:
            continue
        lo, hi = c.iloc[max(j - 1, 0)], c.iloc[j]
        lo = hi if w == 0.0 else lo
        rows.append({"bin": round(float(p), 3), "x_over_L": float(p),
                     **{k: (1 - w) * float(lo[k]) + w * float(hi[k]) for k in columns}})
    return pd.DataFrame(rows, columns=["bin", "x_over_L", *columns])


def _fit(df: pd.DataFrame, grid_of: str, lo: float = MIN_X_OVER_L, hi: float = math.inf) -> dict | None:
    """The fixed-effects slope over every case read at the x/L points of one case (``grid_of``) from ``lo`` to
    ``hi``; None when fewer than two feed rates share a point."""
    at = df.loc[df["case"] == grid_of, "x_over_L"]
    grid = at[(at >= lo - 1e-9) & (at <= hi + 1e-9)].to_numpy(float)
    parts = [on_grid(g, grid).assign(case=name, rate=g["rate"].iloc[0]) for name, g in df.groupby("case")]
    pts = pd.concat(parts, ignore_index=True) if parts else pd.DataFrame(columns=["bin", "ld", "lq", "case", "rate"])
    pts = pts[pts.groupby("bin")["rate"].transform("nunique") >= 2] if len(pts) else pts
    rates = sorted(pts["rate"].unique()) if len(pts) else []
    if len(rates) < 2:
        return None
    dq = pts["lq"] - pts.groupby("bin")["lq"].transform("mean")
    dl = pts["ld"] - pts.groupby("bin")["ld"].transform("mean")
    sxx = float(np.sum(dq ** 2))
    a = float(np.sum(dq * dl) / sxx)
    n_bins = int(pts["bin"].nunique())
    dof = len(pts) - n_bins - 1
    se = float(math.sqrt(np.sum((dl - a * dq) ** 2) / dof / sxx)) if dof > 0 else float("nan")
    per_bin = pts.groupby("bin").apply(
        lambda g: np.polyfit(g["lq"], g["ld"], 1)[0] if g["rate"].nunique() >= 2 else np.nan, include_groups=False)
    return {"a": a, "se": se, "n_bins": n_bins, "per_bin": per_bin, "rates": rates, "lo": float(pts["bin"].min()),
            "hi": float(pts["bin"].max())}


def across_feed_rates(streamwise: pd.DataFrame | None) -> list[Check]:
    """The q* exponent with one intercept per x/L point (module docstring); [] without the columns.

    Cases whose flowing layers differ in length (a wider feed zone) have their bins at other x/L: every case is
    then read at the x/L of the case with the widest bins (:func:`on_grid`, linear between its neighbouring bins),
    and the reading at the narrowest case's bins is one more systematic variant beside the x/L range and δ's
    methods."""
    need = {"case", "x_over_L", "delta", "d_bar", "q_star"}
    if streamwise is None or not need <= set(streamwise):
        return []
    df = streamwise.copy()
    if "usable" in df:
        df = df[df["usable"].astype(str).str.lower().isin(("true", "1", "1.0"))]
    df = df[(df["q_star"] > 0)].assign(rate=df["case"].map(feed_rate_of), x_over_L=df["x_over_L"].astype(float),
                                        lq=np.log(df["q_star"]))
    df = df[np.isfinite(df["rate"])]
    # δ by the paper's other two methods (Fig. 6d), where the profile has them: a systematic variant each
    by_method = {c: df[df[c] > 0].assign(ld=np.log(df[c] / df["d_bar"])) for c in ("delta_exp", "delta_lin") if c in df}
    df = df[df["delta"] > 0].assign(ld=np.log(df["delta"] / df["d_bar"]))
    paper = "≈ 0.22 (eleven runs of 10-120 g/s pooled at x/L ≥ 0.2)"
    source = "§3.3, Fig. 11"
    widths = {name: float(np.median(np.diff(np.sort(g["x_over_L"].to_numpy())))) if len(g) > 1 else 0.0
              for name, g in df.groupby("case")}
    coarsest = max(widths, key=widths.get) if widths else None
    fit = _fit(df, coarsest) if widths else None
    if fit is None:
        rates = sorted(df.loc[df["x_over_L"] >= MIN_X_OVER_L - 1e-9, "rate"].unique())
        return [Check(QUANTITY, paper, source, float("nan"), paper_range=PAPER_RANGE, kind="diagnostic",
                      note=f"needs two feed rates at the same x/L; has {', '.join(f'{r:g}' for r in rates) or 'none'} g/s")]
    a, se, rates, per_bin = fit["a"], fit["se"], fit["rates"], fit["per_bin"]
    aligned = len({round(w, 4) for w in widths.values()}) == 1
    # the x/L ranges read subsets of the same points: (value, se), so only their shift beyond their statistics counts
    ranges = {f"x/L ≥ {X_VARIANTS[0]:g}": _fit(df, coarsest, lo=X_VARIANTS[0]),
              f"x/L {MIN_X_OVER_L:g}-{X_VARIANTS[1]:g} (the end wall's bins left out)": _fit(df, coarsest, hi=X_VARIANTS[1])}
    others = {f"δ by {c}": _fit(d, coarsest) for c, d in by_method.items()}
    if not aligned:
        others["read at the narrowest case's x/L bins"] = _fit(df, min(widths, key=widths.get))
    alt = {**{k: (v["a"], v["se"]) for k, v in ranges.items() if v}, **{k: v["a"] for k, v in others.items() if v}}
    syst, variants = systematic(a, alt, central_se=se)
    span = rates[-1] / rates[0]
    enough = len(rates) >= MIN_RATES and span >= MIN_SPAN
    note = (f"ln(δ/d̄) on ln q* with one intercept per x/L point, {fit['n_bins']} points at x/L = {fit['lo']:g}-"
            f"{fit['hi']:g} shared by {len(rates)} feed rates ({', '.join(f'{r:g}' for r in rates)} g/s, span "
            f"{span:.2g}x); per-point slopes {per_bin.min():.3f} to {per_bin.max():.3f} (median {per_bin.median():.3f}); "
            f"error: the residuals', points taken as independent (an underestimate). ")
    note += "Syst: the x/L range, δ by the paper's other two methods"
    note += ("; the cases' bins lie at different x/L (flowing layers of different length): each case is read at "
             "the x/L of the widest bins, linear between its neighbouring bins, and at the narrowest case's bins "
             "for the syst. " if not aligned else ". ")
    note += ("A comparison: the paper's pooling over feed rates." if enough else
             f"A diagnostic until {MIN_RATES} feed rates span {MIN_SPAN:g}x (the paper's 10-120 g/s span 12x): "
             f"two rates {span:.2g}x apart leave the exponent to the noise of two δ readings per bin")
    return [Check(QUANTITY, paper, source, a, se, paper_range=PAPER_RANGE, note=note, syst=syst, variants=variants,
                  kind="comparison" if enough else "diagnostic")]
