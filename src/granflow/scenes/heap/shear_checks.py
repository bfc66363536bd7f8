"""The shear rate's profile in depth (Fan et al. 2013, §3.2.1, Fig. 5b), read from the record's collapse.

The paper: "The shear rate at the same depth decreases in the streamwise direction. In a region that is
only a few particles thick near the free surface, the shear rate increases slightly to a maximum value as
z decreases. Below this region the shear rate decreases smoothly to zero." (its Fig. 5 is the 1.5 mm
monodisperse heap at 33 g/s; ours is the 1/2 mm mixture, each note says so).

In each usable streamwise bin (the record's ``profiles/collapse.csv``: u/u_s on z/δ, z = 0 at the local
free surface) :math:`\\dot\\gamma = \\partial u/\\partial z = (u_s/\\delta)\\, \\partial(u/u_s)/\\partial(z/\\delta)`,
by :func:`numpy.gradient` over the bins (second order inside, one-sided at the ends). Two rows per case:

* **the maximum below the top**: γ̇'s largest value inside the flowing layer deeper than :data:`TOP` d̄
  (−δ ≤ z ≤ −TOP d̄) over its largest in the top TOP d̄ (−TOP d̄ < z ≤ 0); the bins' mean. The paper's γ̇
  rises "slightly" from the surface to a maximum "a few particles" down, so the ratio is > 1; where γ̇ is
  largest at the surface and falls with depth it is < 1. The depth of the maximum is in the note (at the
  collapse's resolution, about 0.6 d̄);
* **at the same depth along x**: γ̇ interpolated at :data:`DEPTH` d̄ below the surface in each bin, the
  relative slope of its straight line on x/L (the paper: < 0).

Errors: the bins' scatter (mean) or the fit's, bins taken as independent. Syst: the derivative (np.gradient
on the bins, on a three-bin running mean, or neighbours' differences at their midpoints), the x/L range
(:data:`~granflow.scenes.heap.profile_checks.X_VARIANTS`) and, for the second row, the depth (:data:`DEPTH_VARIANTS`).
"""
from __future__ import annotations

import math

import numpy as np
import pandas as pd

from granflow.validation import Check

from .profile_checks import BINS_INDEPENDENT, X_RANGE, _ranged, mean_se, relative_slope, usable_bins, within

#: "a region only a few particles thick near the free surface": γ̇'s maximum below the top TOP d̄ against
#: its largest in them (> 1 where γ̇ rises from the surface to a maximum a few particles down), and variants
TOP, TOP_VARIANTS = 1.0, (0.75, 1.5)
#: "at the same depth": γ̇ read this many local mean diameters below the surface, and the variants
DEPTH, DEPTH_VARIANTS = 2.0, (1.5, 3.0)
#: the flowing layer, where the maximum is looked for
LAYER_ZT = (-1.0, 0.0)
NAN = float("nan")
SOURCE = "§3.2.1, Fig. 5b"
Q_TOP = f"γ̇(z): its largest value deeper than {TOP:g} d̄ over its largest in the top {TOP:g} d̄"
Q_ALONG = f"γ̇ at {DEPTH:g} d̄ below the surface: relative slope along x/L"
#: every row's quantity
QUANTITIES = (Q_TOP, Q_ALONG)
MIXTURE_NOTE = "the paper's Fig. 5 is the 1.5 mm monodisperse heap, ours the record's mixture"


def _smoothed(ut: np.ndarray) -> np.ndarray:
    """A three-bin running mean (the end bins kept)."""
    if len(ut) < 3:
        return ut
    out = ut.copy()
    out[1:-1] = (ut[:-2] + ut[1:-1] + ut[2:]) / 3.0
    return out


def scaled_shear(zt, ut, method: str = "gradient") -> tuple[np.ndarray, np.ndarray]:
    """``(z/δ, ∂(u/u_s)/∂(z/δ))`` of one bin's profile, sorted by z/δ; ``method`` is ``gradient``
    (numpy.gradient on the bins), ``smoothed`` (the same on a three-bin running mean) or ``midpoints``
    (neighbours' differences, placed halfway between them)."""
    order = np.argsort(np.asarray(zt, float))
    z, u = np.asarray(zt, float)[order], np.asarray(ut, float)[order]
    ok = np.isfinite(z) & np.isfinite(u)
    z, u = z[ok], u[ok]
    if len(z) < 3:
        return np.array([]), np.array([])
    if method == "midpoints":
        return 0.5 * (z[1:] + z[:-1]), np.diff(u) / np.diff(z)
    return z, np.gradient(_smoothed(u) if method == "smoothed" else u, z)


def per_bin(col: pd.DataFrame, sw: pd.DataFrame, method: str = "gradient", depth: float = DEPTH,
            top: float = TOP) -> pd.DataFrame:
    """Per usable bin (``x``, ``x_over_L``): ``below_over_top`` (γ̇'s largest value at −δ ≤ z ≤ −top d̄ over
    its largest at −top d̄ < z ≤ 0), ``depth_max`` (where in the layer γ̇ peaks, in d̄ below the surface) and
    ``gamma_at`` (γ̇ in 1/s at ``depth`` d̄ below the surface); NaN where the profile does not reach them."""
    rows = []
    info = sw.set_index("x")
    for x, g in col.groupby("x"):
        if x not in info.index:
            continue
        b = info.loc[x]
        delta, d_bar, u_s = float(b["delta"]), float(b["d_bar"]), float(b["u_s"])
        z, s = scaled_shear(g["zt"], g["ut"], method)
        if not len(z) or not (delta > 0 and d_bar > 0):
            rows.append((float(x), NAN, NAN, NAN))
            continue
        cut = -top * d_bar / delta                       # top d̄ below the surface, in z/δ
        layer = (z >= LAYER_ZT[0]) & (z <= LAYER_ZT[1])
        upper, lower = layer & (z > cut), layer & (z <= cut)
        ratio = float(s[lower].max() / s[upper].max()) if upper.any() and lower.any() else NAN
        z_max = float(z[layer][np.argmax(s[layer])]) if layer.any() else NAN
        at = -depth * d_bar / delta
        gamma = float(np.interp(at, z, s)) * u_s / delta if z.min() <= at <= z.max() else NAN
        rows.append((float(x), ratio, -z_max * delta / d_bar, gamma))
    got = pd.DataFrame(rows, columns=["x", "below_over_top", "depth_max", "gamma_at"])
    return sw[["x", "x_over_L"]].merge(got, on="x", how="inner")


def shear_rate_checks(case: str, col: pd.DataFrame, sw: pd.DataFrame) -> list[Check]:
    """The two rows of the module docstring for one case (``col``: its collapse, ``sw``: its usable bins
    with ``delta``, ``d_bar`` and ``u_s``)."""
    q_top, q_along = Q_TOP, Q_ALONG
    paper_top = "> 1: rises 'slightly' to a maximum a few particles below the surface"
    need = {"delta", "d_bar", "u_s"}
    if col.empty or not need <= set(sw.columns):
        why = "the record keeps no collapse" if col.empty else f"the streamwise table lacks {sorted(need - set(sw.columns))}"
        return [Check(q_top, paper_top, SOURCE, NAN, case=case, paper_range=(1.0, math.inf), note=why),
                Check(q_along, "< 0: falls at the same depth", SOURCE, NAN, case=case,
                      paper_range=(-math.inf, 0.0), note=why)]
    base = per_bin(col, sw)
    other = {m: per_bin(col, sw, m) for m in ("smoothed", "midpoints")}

    ratio = lambda d: mean_se(d["below_over_top"])                                 # noqa: E731
    extra = {f"derivative: {m}": ratio(within(o, X_RANGE))[0] for m, o in other.items()}
    extra.update({f"top {t:g} d̄": ratio(within(per_bin(col, sw, top=t), X_RANGE))[0] for t in TOP_VARIANTS})
    v, se, sy, tx, n = _ranged(ratio, base, extra=extra)
    sub = within(base, X_RANGE)
    spacing = [float(np.median(np.diff(np.sort(g["zt"].to_numpy(float))))) for _, g in col.groupby("x") if len(g) > 1]
    bin_d = float(np.median(spacing)) * float((sw["delta"] / sw["d_bar"]).median()) if spacing else NAN
    out = [Check(q_top, paper_top, SOURCE, v, se, case=case, paper_range=(1.0, math.inf), syst=sy, variants=tx,
                 note=f"γ̇ = (u_s/δ) ∂(u/u_s)/∂(z/δ) over the collapse's bins (about {bin_d:.2g} d̄ apart) in each of "
                      f"{n} usable bins at {X_RANGE[0]:g} ≤ x/L ≤ {X_RANGE[1]:g}: its largest value at −δ ≤ z ≤ −{TOP:g} d̄ "
                      f"over its largest in the top {TOP:g} d̄, the bins' mean; γ̇ peaks {sub['depth_max'].median():.2g} d̄ "
                      f"below the surface (median), {(sub['depth_max'] < TOP).mean():.0%} of the bins in the top "
                      f"{TOP:g} d̄; {MIXTURE_NOTE}; error: the bins' scatter, {BINS_INDEPENDENT}; syst: the x/L range, "
                      f"the derivative, the top's depth ({', '.join(f'{t:g}' for t in TOP_VARIANTS)} d̄)")]

    along = lambda d: relative_slope(*_pairs(d))                                    # noqa: E731
    extra = {f"derivative: {m}": along(within(o, X_RANGE))[0] for m, o in other.items()}
    extra.update({f"at {dv:g} d̄": along(within(per_bin(col, sw, depth=dv), X_RANGE))[0] for dv in DEPTH_VARIANTS})
    v, se, sy, tx, n = _ranged(along, base, extra=extra)
    g = within(base, X_RANGE)["gamma_at"]
    out.append(Check(q_along, "< 0: falls at the same depth", SOURCE, v, se, case=case,
                     paper_range=(-math.inf, 0.0), syst=sy, variants=tx,
                     note=f"γ̇ interpolated {DEPTH:g} d̄ below the local surface in {n} usable bins at {X_RANGE[0]:g} ≤ "
                          f"x/L ≤ {X_RANGE[1]:g} ({g.max():.3g} to {g.min():.3g} 1/s); the slope of its straight line on "
                          f"x/L over its mean; {MIXTURE_NOTE}; error: the fit's, {BINS_INDEPENDENT}; syst: the x/L "
                          f"range, the derivative, the depth ({', '.join(f'{d:g}' for d in DEPTH_VARIANTS)} d̄)"))
    return out


def _pairs(d: pd.DataFrame):
    d = d.dropna(subset=["gamma_at"])
    return d["x_over_L"].to_numpy(float), d["gamma_at"].to_numpy(float)


def shear_checks(profiles: dict) -> list[Check]:
    """:func:`shear_rate_checks` for every case of the record's profiles (``streamwise``, ``collapse``)."""
    streamwise = profiles.get("streamwise")
    if streamwise is None or streamwise.empty:
        return []
    sw = usable_bins(streamwise)
    col = profiles.get("collapse", pd.DataFrame(columns=["case", "x", "zt", "ut", "wt"]))
    return [c for case, bins in sw.groupby("case", sort=True)
            for c in shear_rate_checks(case, col[col["case"] == case], bins)]
