"""The heap's checks made from the record's own profiles, in the paper's form (Fan et al. 2013, §3).

Every check here reads only the tables the record keeps (``profiles/streamwise.csv``,
``collapse.csv``, ``surface_at_window_start.csv``), so a committed record is judged by the same code
as a rerun (:meth:`HeapScene.profile_checks`, :func:`granflow.scenes.heap.validation.validation`).

Along the heap, per case, :math:`s = x/L` (:math:`L` from the feed zone's edge to the end wall along
the slope), over the usable bins at :data:`X_RANGE` (the paper excludes the feed region, §3.3; the
last bins sit in the end-wall pool):

* :math:`q(s)` and :math:`u_s(s)` linear (Fig. 6a,b): a least-squares line and quadratic; the line's
  zero :math:`s_0` (:math:`q = 0` at the end wall) and the relative curvature
  :math:`\\kappa = 2 c_2 \\Delta s / c_1` of :math:`y = c_0 + c_1 (s - \\bar s) + c_2 (s - \\bar s)^2`,
  the change of the slope across the fit range over the slope (0 on a line);
* :math:`\\bar{\\dot\\gamma}` falls to nearly 0 (Fig. 6c): the line's value at :math:`s = 1` over
  its value at :math:`s = 0`;
* eq. 3.1 (Fig. 6d): :math:`\\langle \\delta / \\delta_{3.1} \\rangle`;
* :math:`\\delta(x)` thins more near the end (Fig. 6d): the slope near the end over that along
  most of the layer (1 for a straight line);
* :math:`u_s \\delta / 2 q_0` falls linearly to the end (Fig. 10a): the line's zero;
* the collapse of :math:`u/u_s` on :math:`z/\\delta` (Fig. 7a) at every x: the shape integral
  :math:`I = \\langle u/u_s \\rangle_{-0.95 \\le z/\\delta \\le -0.15}` shows no trend with x;
  below the layer (Fig. 7b, §3.2.1) :math:`u/u_s < 0.01` and :math:`u \\sim O(1)` mm/s;
* :math:`w/v_r'` against eqs. 3.5 and 3.6 and :math:`-1` at :math:`z = -\\delta` (Fig. 8);
* the free surface within :math:`d_s` of the plane rising at :math:`v_r` (§3.1, Fig. 4b,c).

Across feed rates of one mixture (§3.3): δ grows with the feed rate (Fig. 10c); :math:`I` and
:math:`u_s\\delta/2q_0` are the same at the same x/L (Figs. 9, 10a); the q* exponent
(:func:`granflow.scenes.heap.qstar.across_feed_rates`).

Errors: fit parameters from the residuals' covariance and means as standard errors, the streamwise
bins taken as independent (neighbours share particles: an underestimate, each note says so); the
fit range and the δ method are measurement choices, their spread the systematic error
(:func:`granflow.validation.systematic`).
"""
from __future__ import annotations

import math
import re

import numpy as np
import pandas as pd

from granflow.validation import Check, systematic

from .analysis import normal_velocity_exponential, normal_velocity_linear
from .qstar import across_feed_rates, feed_rate_of, on_grid

#: the x/L range of every fit along the heap: away from the feed (bouncing, §3.3) and the end-wall pool
X_RANGE = (0.2, 0.9)
#: its variants inside the paper's x/L ≥ 0.2, the systematic error of every reading along the heap
X_VARIANTS = ((0.3, 0.9), (0.2, 0.8), (0.2, 0.95))
#: where δ's slope is read "along most of the layer" and "near the end" (Fig. 6d), and their variants
DELTA_MID, DELTA_END = (0.2, 0.7), (0.7, 0.95)
DELTA_SPLIT_VARIANTS = (((0.2, 0.6), (0.6, 0.95)), ((0.2, 0.8), (0.8, 0.95)), ((0.2, 0.7), (0.7, 0.9)))
#: the layer's shape integral I = mean of u/u_s over this z/δ (inside every bin's profile)
SHAPE_ZT = (-0.95, -0.15)
#: below the flowing layer (§3.2.3: |z/δ| > 2); the record keeps z/δ ≥ -3
DEEP_ZT, DEEP_ZT_VARIANT = (-3.0, -2.0), (-3.0, -2.5)
#: w/v_r' at the layer's bottom, and the layer for eqs. 3.5/3.6, with variants
BOTTOM_ZT, BOTTOM_ZT_VARIANT = (-1.1, -0.9), (-1.2, -0.8)
LAYER_ZT, LAYER_UPPER = (-1.0, 0.0), (-0.4, 0.0)
#: "~O(1 mm/s)" read as the decade around 1 mm/s
CREEP_RANGE_MM_S = (10 ** -0.5, 10 ** 0.5)
#: "γ̄ decreases to nearly zero" read as below a tenth of its value at x = 0
NEARLY_ZERO = 0.1
#: the columns of profiles/streamwise.csv the checks read
STREAMWISE_COLUMNS = ("x", "x_over_L", "q", "u_s", "gamma_bar", "delta", "delta_exp", "delta_lin", "delta_eq31")
BINS_INDEPENDENT = "bins taken as independent (neighbours share particles: an underestimate)"
NAN = float("nan")


# --------------------------------------------------------------------------- fits
def polyfit(s, y, degree: int):
    """Least squares :math:`y = \\sum_k c_k (s - \\bar s)^k`: ``(c (lowest first), covariance, s̄)``.

    The covariance is :math:`\\hat\\sigma^2 (A^T A)^{-1}` with the residual variance (NaN without
    degrees of freedom); :math:`\\bar s` the mean of ``s`` (centred: c_0 and c_1 at the middle).
    """
    s, y = np.asarray(s, float), np.asarray(y, float)
    s, y = s[np.isfinite(s) & np.isfinite(y)], y[np.isfinite(s) & np.isfinite(y)]
    mid = float(np.mean(s)) if len(s) else NAN
    if len(s) <= degree:
        return np.full(degree + 1, NAN), np.full((degree + 1, degree + 1), NAN), mid
    A = np.vander(s - mid, degree + 1, increasing=True)
    coef, *_ = np.linalg.lstsq(A, y, rcond=None)
    dof = len(s) - degree - 1
    s2 = float(np.sum((y - A @ coef) ** 2) / dof) if dof > 0 else NAN
    return coef, s2 * np.linalg.inv(A.T @ A), mid


def _delta_method(value: float, grad, cov) -> tuple[float, float]:
    g = np.asarray(grad, float)
    return float(value), float(math.sqrt(max(0.0, g @ cov @ g))) if np.all(np.isfinite(cov)) else NAN


def line_zero(s, y) -> tuple[float, float]:
    """Where the least-squares line of y on s crosses 0, and its error."""
    (c0, c1), cov, mid = polyfit(s, y, 1)
    return _delta_method(mid - c0 / c1, (-1.0 / c1, c0 / c1 ** 2), cov)


def curvature(s, y) -> tuple[float, float]:
    """:math:`\\kappa = 2 c_2 \\Delta s / c_1`: the change of the slope across the range over the slope."""
    (c0, c1, c2), cov, _ = polyfit(s, y, 2)
    s = np.asarray(s, float)
    span = float(np.ptp(s[np.isfinite(s)])) if np.isfinite(s).any() else NAN
    return _delta_method(2 * c2 * span / c1, (0.0, -2 * c2 * span / c1 ** 2, 2 * span / c1), cov)


def end_over_start(s, y) -> tuple[float, float]:
    """The least-squares line's value at s = 1 over its value at s = 0."""
    (c0, c1), cov, m = polyfit(s, y, 1)
    a, b = c0 + c1 * (1 - m), c0 - c1 * m
    return _delta_method(a / b, ((b - a) / b ** 2, ((1 - m) * b + m * a) / b ** 2), cov)


def relative_slope(s, y) -> tuple[float, float]:
    """The line's slope over the mean of y."""
    (c0, c1), cov, _ = polyfit(s, y, 1)
    return _delta_method(c1 / c0, (-c1 / c0 ** 2, 1.0 / c0), cov)


def slope(s, y) -> tuple[float, float]:
    """The least-squares line's slope and its error."""
    (_, c1), cov, _ = polyfit(s, y, 1)
    return float(c1), float(math.sqrt(cov[1, 1])) if np.isfinite(cov[1, 1]) else NAN


def mean_se(values) -> tuple[float, float]:
    v = np.asarray(values, float)
    v = v[np.isfinite(v)]
    if len(v) == 0:
        return NAN, NAN
    return float(v.mean()), float(v.std(ddof=1) / math.sqrt(len(v))) if len(v) > 1 else NAN


# --------------------------------------------------------------------------- inputs
def usable_bins(streamwise: pd.DataFrame) -> pd.DataFrame:
    """The usable streamwise bins, with ``case`` and sorted by x (a column the record lacks: NaN)."""
    df = streamwise.copy()
    for name in STREAMWISE_COLUMNS:
        if name not in df:
            df[name] = NAN
    if "usable" in df:
        df = df[df["usable"].astype(str).str.lower().isin(("true", "1", "1.0"))]
    return df.sort_values(["case", "x"]).reset_index(drop=True)


def within(df: pd.DataFrame, rng, column: str = "x_over_L") -> pd.DataFrame:
    return df[(df[column] >= rng[0] - 1e-9) & (df[column] <= rng[1] + 1e-9)]


def shape_integrals(collapse: pd.DataFrame, bins: pd.DataFrame, zt=SHAPE_ZT, point: float | None = None):
    """Per bin ``x``: the mean of u/u_s interpolated on z/δ over ``zt`` (or at ``point``), NaN where the
    bin's profile does not span it; with the bin's x/L."""
    grid = np.array([point]) if point is not None else np.linspace(zt[0], zt[1], 9)
    out = []
    for x, g in collapse.groupby("x"):
        g = g.dropna(subset=["zt", "ut"]).sort_values("zt")
        ok = len(g) >= 2 and g["zt"].min() <= grid.min() and g["zt"].max() >= grid.max()
        out.append((float(x), float(np.mean(np.interp(grid, g["zt"], g["ut"]))) if ok else NAN))
    got = pd.DataFrame(out, columns=["x", "I"])
    return bins[["x", "x_over_L"]].merge(got, on="x", how="inner").dropna()


def smallest_diameter(case: str) -> float:
    """The small species' diameter (m) of the case's mixture (``mix~<name>``) in the heap's scene file,
    NaN when neither is found."""
    m = re.search(r"(?:^|/)mix~([^/]+)", case)
    if not m:
        return NAN
    try:
        from granflow.scene_files import load_scene
        from granflow.schema import PROJECT_ROOT

        mixtures = load_scene(PROJECT_ROOT / "config" / "scenes" / "heap.yaml")["particles"]["mixtures"]
        return float(min(mixtures[m.group(1)]["diameters"]))
    except (OSError, KeyError, ValueError):
        return NAN


# --------------------------------------------------------------------------- checks
def _ranged(measure, frame, rng=X_RANGE, variants=X_VARIANTS, extra=None):
    """``(value, stat, syst, variants' text, n)`` of ``measure(sub-frame) -> (value, se)`` over ``rng``,
    the fit-range variants (subsets or supersets of the same bins) and ``extra`` (other measurements)."""
    sub = within(frame, rng)
    value, se = measure(sub) if len(sub) else (NAN, NAN)
    alt = {f"x/L over {lo:g}-{hi:g}": measure(within(frame, (lo, hi))) for lo, hi in variants}
    alt.update(extra or {})
    syst, text = systematic(value, alt, central_se=se)
    return value, se, syst, text, len(sub)


def _cols(name):
    return lambda d: (d["x_over_L"].to_numpy(float), d[name].to_numpy(float))


def streamwise_checks(case: str, sw: pd.DataFrame) -> list[Check]:
    """q, u_s, γ̄, δ along one case's heap (Fig. 6, Fig. 10a)."""
    checks = []
    rng = f"{X_RANGE[0]:g} ≤ x/L ≤ {X_RANGE[1]:g}"
    err = f"error: the fit's covariance, {BINS_INDEPENDENT}; syst: the x/L range"

    v, se, sy, tx, n = _ranged(lambda d: line_zero(*_cols("q")(d)), sw)
    (c0, c1), _, m = polyfit(*_cols("q")(within(sw, X_RANGE)), 1)
    q0 = c0 - c1 * m
    checks.append(Check("q(x): zero of its straight line in x/L", "1: q falls linearly to 0 at the end wall",
                        "§3.2.2, Fig. 6a; §1", v, se, case=case, paper_range=(1.0, 1.0), syst=sy, variants=tx,
                        note=f"least-squares line of the 2D flow rate q = ∫u dz on x/L over the {n} usable bins at "
                             f"{rng}, x_0/L where it crosses 0 (q_0 = {q0 * 1e4:.3g} cm²/s at x = 0); {err}"))
    for name, col, paper, src in (("q(x)", "q", "0: q falls linearly", "§3.2.2, Fig. 6a"),
                                  ("u_s(x)", "u_s", "0: u_s falls approximately linearly", "§3.2.2, Fig. 6b")):
        v, se, sy, tx, n = _ranged(lambda d, c=col: curvature(*_cols(c)(d)), sw)
        checks.append(Check(f"{name}: relative curvature κ along x/L", paper, src, v, se, case=case,
                            paper_range=(0.0, 0.0), syst=sy, variants=tx,
                            note=f"quadratic {col} = c0 + c1 s + c2 s² (s = x/L − its mean) over the {n} usable bins "
                                 f"at {rng}; κ = 2 c2 Δs/c1, the change of the slope across the range over the "
                                 f"slope (0 on a straight line; > 0: the slope steepens downstream, < 0: it flattens); {err}"))

    v, se, sy, tx, n = _ranged(lambda d: end_over_start(*_cols("gamma_bar")(d)), sw)
    last = sw.dropna(subset=["gamma_bar"])
    if last.empty:
        last = pd.DataFrame({"x_over_L": [NAN], "gamma_bar": [NAN]})
    checks.append(Check("γ̄(x): its straight line at x = L over at x = 0",
                        f"≈ 0: γ̄ 'decreases to nearly zero' (read as < {NEARLY_ZERO:g})", "§3.2.2, Fig. 6c",
                        v, se, case=case, paper_range=(0.0, NEARLY_ZERO), syst=sy, variants=tx,
                        note=f"least-squares line of γ̄ = [u_s − u(−δ)]/δ on x/L over the {n} usable bins at {rng}, "
                             f"extrapolated to the end wall and to the feed edge; the paper gives no number, 'nearly "
                             f"zero' is read as below {NEARLY_ZERO:g} of the start. The last usable bin (x/L = "
                             f"{last['x_over_L'].iloc[-1]:g}) has γ̄ = {last['gamma_bar'].iloc[-1]:.3g} /s against "
                             f"{within(last, (0.18, 0.22))['gamma_bar'].mean():.3g} /s at x/L ≈ 0.2. With δ where "
                             f"u = 0.1 u_s, γ̄ = 0.9 u_s/δ: it falls as u_s does only where δ stays; {err}"))

    ratio = lambda col: (lambda d: mean_se(d[col] / d["delta_eq31"]))  # noqa: E731
    extra = {f"δ by {w}": ratio(c)(within(sw, X_RANGE))[0] for w, c in
             (("the exponential fit × 2.3", "delta_exp"), ("linear extrapolation", "delta_lin")) if c in sw}
    v, se, sy, tx, n = _ranged(ratio("delta"), sw, extra=extra)
    checks.append(Check("δ/δ_3.1: measured over Khakhar et al.'s eq. 3.1", "≈ 1: eq. 3.1 'matches … fairly well'",
                        "§3.2.2, eq. 3.1, Fig. 6d", v, se, case=case, paper_range=(1.0, 1.0), syst=sy, variants=tx,
                        note=f"mean over the {n} usable bins at {rng} of δ (0.1 u_s cutoff) over δ_3.1 = [δ_L² + "
                             f"2 v_r'(L − x)/γ̄]^½ with the local γ̄, the normal rise speed v_r' and δ_L at the last "
                             f"usable bin (the analysis's delta_eq31); error: the bins' scatter, {BINS_INDEPENDENT}; "
                             f"syst: the x/L range and the paper's other two δ methods"))

    checks.append(_delta_x_check(case, sw))

    lhs = sw.assign(scaled=sw["u_s"] * sw["delta"])
    v, se, sy, tx, n = _ranged(lambda d: line_zero(*_cols("scaled")(d)), lhs)
    checks.append(Check("u_s δ/(2 q_0): zero of its straight line in x/L",
                        "1: collapses onto one line falling linearly to the end of the layer", "§3.3, Fig. 10a",
                        v, se, case=case, paper_range=(1.0, 1.0), syst=sy, variants=tx,
                        note=f"least-squares line of u_s δ on x/L over the {n} usable bins at {rng}, x_0/L where it "
                             f"crosses 0 (q_0 scales it and drops out; its value at x = 0 over 2 q_0, q_0 from q's "
                             f"line: {line_at(lhs, 'scaled', 0.0) / (2 * q0):.3g}); {err}"))

    g = sw["gamma_bar"] * sw["delta"] / sw["u_s"]
    v, se = mean_se(g)
    checks.append(Check("γ̄ δ/u_s: why γ̄ δ²/(2 q_0) is 0.9 u_s δ/(2 q_0)",
                        "0.9 when δ is where u = 0.1 u_s and γ̄ the layer's mean ∂u/∂z", "§3.2.2; §3.3, Fig. 10b",
                        v, se, case=case, paper_range=(0.9, 0.9), kind="consistency",
                        note=f"mean over {g.notna().sum()} usable bins: γ̄ = [u_s − u(−δ)]/δ with u(−δ) = 0.1 u_s "
                             "makes γ̄ δ = 0.9 u_s, so Fig. 10b is Fig. 10a times 0.9: a test of the code"))
    return checks


def line_at(df: pd.DataFrame, col: str, s: float) -> float:
    (c0, c1), _, m = polyfit(*_cols(col)(within(df, X_RANGE)), 1)
    return float(c0 + c1 * (s - m))


def _delta_x_check(case: str, sw: pd.DataFrame) -> Check:
    def ratio(mid, end):
        a, b = within(sw, end), within(sw, mid)
        (se_end, ee), (sm, em) = slope(*_cols("delta")(a)), slope(*_cols("delta")(b))
        if not (sm and se_end):  # a flat δ: no ratio of slopes
            return NAN, NAN
        r = se_end / sm
        return r, abs(r) * math.hypot(ee / se_end, em / sm)

    v, se = ratio(DELTA_MID, DELTA_END)
    alt = {f"x/L {m[0]:g}-{m[1]:g} and {e[0]:g}-{e[1]:g}": ratio(m, e) for m, e in DELTA_SPLIT_VARIANTS}
    sy, tx = systematic(v, alt, central_se=se)
    mid = within(sw, DELTA_MID)
    drop = relative_slope(*_cols("delta")(mid))[0] * float(np.ptp(mid["x_over_L"]))
    return Check("δ(x): slope near the end over that along most of the layer",
                 "> 1: δ 'decreases slightly along much of the length … somewhat more at the end'",
                 "§3.2.2, Fig. 6d", v, se, case=case, paper_range=(1.0, math.inf), syst=sy, variants=tx,
                 note=f"least-squares lines of δ on x/L over the usable bins at {DELTA_END[0]:g}-{DELTA_END[1]:g} "
                      f"and at {DELTA_MID[0]:g}-{DELTA_MID[1]:g}, the ratio of their slopes; error: each fit's "
                      f"covariance, {BINS_INDEPENDENT}; syst: where the split and the end are. Along most of the "
                      f"layer δ changes by {drop:+.0%} (the paper: 6d to 7d, about ±8 %, Fig. 6d)")


def collapse_checks(case: str, col: pd.DataFrame, sw: pd.DataFrame) -> list[Check]:
    """u/u_s and w/v_r' against z/δ (Figs. 7, 8) and the creep below the layer (§3.2.1)."""
    checks = []
    shape = shape_integrals(col, sw)
    point = shape_integrals(col, sw, point=-0.5)
    v, se, sy, tx, n = _ranged(lambda d: relative_slope(d["x_over_L"], d["I"]), shape,
                               extra={"u/u_s at z/δ = −0.5": relative_slope(*_xi(within(point, X_RANGE)))[0]})
    checks.append(Check("u/u_s on z/δ: relative slope of the layer's shape along x/L", "0: one curve at every x",
                        "§3.2.3, Fig. 7a", v, se, case=case, paper_range=(0.0, 0.0), syst=sy, variants=tx,
                        note=f"I = mean of u/u_s interpolated at {SHAPE_ZT[0]:g} ≤ z/δ ≤ {SHAPE_ZT[1]:g} in each of "
                             f"{n} usable bins at {X_RANGE[0]:g} ≤ x/L ≤ {X_RANGE[1]:g} (⟨I⟩ = "
                             f"{within(shape, X_RANGE)['I'].mean():.3f}); the slope of I's line on x/L over ⟨I⟩ (the "
                             f"collapse forces u/u_s = 1 at z = 0 and 0.1 at z = −δ, I reads the shape between); "
                             f"error: the fit's, {BINS_INDEPENDENT}; syst: the x/L range, u/u_s at z/δ = −0.5 alone"))

    merged = col.merge(sw[["x", "x_over_L", "u_s"]], on="x", how="inner")
    deep = lambda zt: (lambda d: mean_se(d[(d["zt"] >= zt[0]) & (d["zt"] < zt[1])]["ut"]))  # noqa: E731
    v, se, sy, tx, _ = _ranged(deep(DEEP_ZT), merged,
                               extra={f"z/δ {DEEP_ZT_VARIANT[0]:g} to {DEEP_ZT_VARIANT[1]:g}":
                                      deep(DEEP_ZT_VARIANT)(within(merged, X_RANGE))})
    pts = within(merged, X_RANGE)
    pts = pts[(pts["zt"] >= DEEP_ZT[0]) & (pts["zt"] < DEEP_ZT[1])]
    checks.append(Check("u/u_s below the layer, −3 ≤ z/δ < −2", "< 0.01 but non-zero", "§3.2.3, Fig. 7b",
                        v, se, case=case, paper_range=(0.0, 0.01), syst=sy, variants=tx,
                        note=f"mean of the {len(pts)} collapsed points at {DEEP_ZT[0]:g} ≤ z/δ < {DEEP_ZT[1]:g} of the "
                             f"usable bins at {X_RANGE[0]:g} ≤ x/L ≤ {X_RANGE[1]:g} (the record keeps z/δ ≥ −3); "
                             f"{(pts['ut'].abs() < 0.01).mean():.0%} of them have |u/u_s| < 0.01, the largest "
                             f"{pts['ut'].abs().max():.3g}, {(pts['ut'] > 0).mean():.0%} positive; error: the points' "
                             f"scatter, points taken as independent; syst: the x/L range and z/δ < −2.5"))
    creep = lambda zt: (lambda d: mean_se(1e3 * (d["ut"] * d["u_s"])[(d["zt"] >= zt[0]) & (d["zt"] < zt[1])]))  # noqa: E731
    v, se, sy, tx, _ = _ranged(creep(DEEP_ZT), merged,
                               extra={f"z/δ {DEEP_ZT_VARIANT[0]:g} to {DEEP_ZT_VARIANT[1]:g}":
                                      creep(DEEP_ZT_VARIANT)(within(merged, X_RANGE))})
    checks.append(Check("u below the flowing layer (−3 ≤ z/δ < −2): creep speed", "~O(1 mm/s)", "§3.2.1, Fig. 5a",
                        v, se, case=case, unit="mm/s", paper_range=CREEP_RANGE_MM_S, syst=sy, variants=tx,
                        note="mean of (u/u_s) u_s over the same points as the row above, along the slope in the lab "
                             "(the moving frame subtracts the rise from w only); 'O(1 mm/s)' read as the decade "
                             f"{CREEP_RANGE_MM_S[0]:.2g}-{CREEP_RANGE_MM_S[1]:.2g} mm/s; error: the points' scatter, "
                             "points taken as independent; syst: the x/L range and z/δ < −2.5"))
    return checks + normal_velocity_checks(case, merged)


def _xi(d):
    return d["x_over_L"], d["I"]


def normal_velocity_checks(case: str, merged: pd.DataFrame) -> list[Check]:
    """w/v_r' against eqs. 3.5 and 3.6 and its value at z = −δ (Fig. 8), per bin then over the bins."""
    if "wt" not in merged or merged["wt"].isna().all():
        return [Check(q, p, "§3.2.3, Fig. 8", NAN, case=case, paper_range=r, note="the collapse has no w")
                for q, p, r in _W_ROWS]

    def per_bin(model, zt):
        def measure(d):
            d = d[(d["zt"] >= zt[0]) & (d["zt"] <= zt[1])]
            dev = d["wt"] - (model(d["zt"]) if model is not None else 0.0)
            return mean_se(dev.groupby(d["x"]).mean())
        return measure

    checks = []
    for (q, paper, rng), model in zip(_W_ROWS, (normal_velocity_exponential, normal_velocity_linear, None)):
        zt = LAYER_ZT if model is not None else BOTTOM_ZT
        inside = within(merged, X_RANGE)
        if model is None:  # where the bottom is read is a choice: a window of another width
            extra = {f"z/δ {BOTTOM_ZT_VARIANT[0]:g} to {BOTTOM_ZT_VARIANT[1]:g}": per_bin(None, BOTTOM_ZT_VARIANT)(inside)}
            parts, what, choice = "", "w/v_r'", "the x/L range and the window's width"
        else:  # the layer is the paper's claim: its parts are reported, not varied
            upper = per_bin(model, LAYER_UPPER)(inside)[0]
            lower = per_bin(model, (LAYER_ZT[0], LAYER_UPPER[0]))(inside)[0]
            extra, what, choice = {}, "w/v_r' − the equation's value", "the x/L range"
            parts = (f"; the mean deviation is {upper:+.3f} at {LAYER_UPPER[0]:g} ≤ z/δ ≤ {LAYER_UPPER[1]:g} and "
                     f"{lower:+.3f} below (< 0: w more negative than the equation)")
        v, se, sy, tx, _ = _ranged(per_bin(model, zt), merged, extra=extra)
        n = inside["x"].nunique()
        checks.append(Check(q, paper, "§3.2.3, eqs. 3.5-3.6, Fig. 8", v, se, case=case, paper_range=rng, syst=sy,
                            variants=tx,
                            note=f"mean over the {n} usable bins at {X_RANGE[0]:g} ≤ x/L ≤ {X_RANGE[1]:g} of each "
                                 f"bin's mean {what} at {zt[0]:g} ≤ z/δ ≤ {zt[1]:g} (w in the frame rising with the "
                                 f"surface, v_r' = v_r cos α){parts}; the paper: both equations agree, 'even though "
                                 f"some deviations exist', and 'slightly underpredict' at |z/δ| < 0.4; error: the "
                                 f"bins' scatter, {BINS_INDEPENDENT}; syst: {choice}"))
    return checks


_W_ROWS = (("w/v_r' − eq. 3.6 (exponential u, k = 2.3) over the layer", "≈ 0: the data agree with eq. 3.6", (0.0, 0.0)),
           ("w/v_r' − eq. 3.5 (linear u) over the layer", "≈ 0: the data agree with eq. 3.5", (0.0, 0.0)),
           ("w/v_r' at the bottom of the layer, z/δ ≈ −1", "−1: w falls from 0 to −v_r' at z = −δ", (-1.0, -1.0)))


def surface_checks(case: str, surf: pd.DataFrame, d_s: float) -> list[Check]:
    """The surface of the window's frames brought back by the fitted rise, against planes (§3.1)."""
    s = surf.sort_values("x_lab")
    fit = s[s["in_fit"].astype(str).str.lower().isin(("true", "1", "1.0"))]
    off = (fit["z_s_mean"] - fit["z_s_fit"]).abs() / d_s
    per_frame = np.sqrt((fit["z_s_mean"] - fit["z_s_fit"]) ** 2 + fit["z_s_std"] ** 2) / d_s
    inner = off.iloc[1:-1]
    sy, tx = systematic(off.max(), {"without the range's end columns": inner.max()})
    why = "" if math.isfinite(d_s) else "; d_s not found (the case names no mixture of config/scenes/heap.yaml)"
    out = [Check("free surface from the plane rising at v_r: largest offset over d_s", "< 1 (|Δz_s/d_s| < 1)",
                 "§3.1, Fig. 4b,c", off.max(), case=case, paper_range=(0.0, 1.0), syst=sy, variants=tx,
                 note=f"|mean surface − plane| over the {len(fit)} columns of the record's plane fit (its planar middle), "
                      f"each frame's surface (φ = 0.35) brought back by the fitted rise v_r; d_s = {d_s * 1e3:g} mm; "
                      f"the frames scatter by {fit['z_s_std'].mean() / d_s:.2g} d_s about their mean (per frame, √(offset² + "
                      f"variance) reaches {per_frame.max():.2g} d_s; the paper's bound is for every time); a largest "
                      f"offset: no statistical error (the profile keeps no frame count){why}")]
    (c0, c1), _, m = polyfit(s["x_lab"], s["z_s_mean"], 1)
    res = (s["z_s_mean"] - (c0 + c1 * (s["x_lab"] - m))).abs() / d_s
    n_cut = max(1, len(s) // 10)
    (a0, a1), _, am = polyfit(s["x_lab"].iloc[n_cut:-n_cut], s["z_s_mean"].iloc[n_cut:-n_cut], 1)
    res_in = (s["z_s_mean"] - (a0 + a1 * (s["x_lab"] - am))).abs().iloc[n_cut:-n_cut] / d_s
    sy, tx = systematic(res.max(), {"without the 10 % of columns at each end": res_in.max()})
    out.append(Check("free surface from one straight line over the whole heap: largest offset over d_s",
                     "< 1: the surface is uniformly sloped (its line within d_s, §3.1)", "§3.1, Fig. 4b",
                     res.max(), case=case, paper_range=(0.0, 1.0), syst=sy, variants=tx,
                     note=f"least-squares line of the window's mean surface over all {len(s)} columns (the paper fits "
                          f"the entire surface), its largest distance from the surface (rms "
                          f"{math.sqrt(float(np.mean(res ** 2))):.2g} d_s); no statistical error{why}"))
    return out


# --------------------------------------------------------------------------- across feed rates
def _bin_width(d: pd.DataFrame) -> float:
    x = np.sort(d["x_over_L"].to_numpy(float))
    return float(np.median(np.diff(x))) if len(x) > 1 else 0.0


def _same_bins(a: pd.DataFrame, b: pd.DataFrame) -> bool:
    """Whether two cases' bins lie on one lattice of x/L (the same width, offset by whole bins)."""
    wa, wb = _bin_width(a), _bin_width(b)
    if not (wa > 0 and abs(wa - wb) <= 1e-4 * wa):
        return False
    off = (float(a["x_over_L"].min()) - float(b["x_over_L"].min())) / wa
    return abs(off - round(off)) < 1e-3


def feed_rate_checks(sw: pd.DataFrame, col: pd.DataFrame) -> list[Check]:
    """The lowest and the highest feed rate of one mixture at the same x/L bins (Figs. 9, 10a,c)."""
    rows = (("δ at the higher feed rate over the lower, same x/L", "> 1: δ grows with the feed rate",
             "§3.3, Fig. 10c", (1.0, math.inf)),
            ("u/u_s on z/δ across feed rates: the layer's shape, higher over lower rate", "1: one curve for all runs",
             "§3.3, Fig. 9", (1.0, 1.0)),
            ("u_s δ/(2 q_0) across feed rates: higher over lower rate, same x/L", "1: one curve for all runs",
             "§3.3, Fig. 10a", (1.0, 1.0)))
    df = sw.assign(rate=sw["case"].map(feed_rate_of), mix=sw["case"].str.extract(r"mix~([^/]+)", expand=False))
    pairs = [(g.loc[g["rate"].idxmin(), "case"], g.loc[g["rate"].idxmax(), "case"])
             for _, g in df.dropna(subset=["rate"]).groupby("mix") if g["rate"].nunique() >= 2]
    if not pairs:
        return [Check(q, p, s, NAN, paper_range=r, note="needs two feed rates of one mixture") for q, p, s, r in rows]
    lo, hi = pairs[0]
    # bins at the same x/L: as the record keeps them (6 digits) and as a run gives them (every digit) they meet at 5
    a, b = (sw[sw["case"] == c].assign(x_over_L=lambda d: d["x_over_L"].round(5)) for c in (lo, hi))
    q0 = {c: line_at(d, "q", 0.0) for c, d in ((lo, a), (hi, b))}
    shape = {c: shape_integrals(col[col["case"] == c], d) for c, d in ((lo, a), (hi, b))}
    cols = [c for c in ("q", "u_s", "delta", "delta_exp", "delta_lin") if c in sw]
    # each read at the x/L of the case with the wider bins (its own bins where they meet, else linear between
    # neighbouring bins, qstar.on_grid); the other case's bins a syst
    frame = {lo: a, hi: b}
    coarse, fine = sorted((lo, hi), key=lambda c: -_bin_width(frame[c]))
    aligned = _same_bins(frame[coarse], frame[fine])

    def paired(grid_of: str, frames: dict, columns) -> pd.DataFrame:
        grid = frame[grid_of]["x_over_L"].to_numpy(float)
        at = {c: on_grid(frames[c], grid, tuple(columns)).drop(columns="bin") for c in (lo, hi)}
        return at[lo].merge(at[hi], on="x_over_L", suffixes=("_lo", "_hi"))

    both, shapes = paired(coarse, frame, cols), paired(coarse, shape, ["I"])
    other = {} if aligned else {"both": paired(fine, frame, cols), "shapes": paired(fine, shape, ["I"])}
    grid_note = ("" if aligned else f"; the two cases' bins lie at different x/L: both read at the x/L of "
                 f"{feed_rate_of(coarse):g} g/s's (the wider) bins, the other's linear between its neighbouring "
                 f"bins, and at {feed_rate_of(fine):g} g/s's bins for the syst")
    other_grid = f"read at {feed_rate_of(fine):g} g/s's x/L bins"
    ratio = lambda c: (lambda d: mean_se(d[f"{c}_hi"] / d[f"{c}_lo"]))  # noqa: E731
    rates = f"{feed_rate_of(lo):g} and {feed_rate_of(hi):g} g/s ({feed_rate_of(hi) / feed_rate_of(lo):.2g}x apart)"
    out = []
    extra = {f"δ by {c}": ratio(c)(within(both, X_RANGE))[0] for c in ("delta_exp", "delta_lin") if f"{c}_lo" in both}
    if other:
        extra[other_grid] = ratio("delta")(within(other["both"], X_RANGE))[0]
    v, se, sy, tx, n = _ranged(ratio("delta"), both, extra=extra)
    out.append(Check(*rows[0][:3], v, se, paper_range=rows[0][3], syst=sy, variants=tx,
                     note=f"mean over the {n} x/L bins at {X_RANGE[0]:g}-{X_RANGE[1]:g} usable in both cases of δ's "
                          f"ratio, {rates}; error: the bins' scatter, {BINS_INDEPENDENT}; syst: the x/L range and "
                          f"the paper's other two δ methods{grid_note}"))
    v, se, sy, tx, n = _ranged(ratio("I"), shapes,
                               extra={other_grid: ratio("I")(within(other["shapes"], X_RANGE))[0]} if other else None)
    out.append(Check(*rows[1][:3], v, se, paper_range=rows[1][3], syst=sy, variants=tx,
                     note=f"mean over the {n} shared x/L bins of the ratio of I = ⟨u/u_s⟩ at {SHAPE_ZT[0]:g} ≤ z/δ ≤ "
                          f"{SHAPE_ZT[1]:g} (the row along x), {rates}: one mixture, so only the feed rate of the "
                          f"paper's 10-120 g/s and size ratios 1-3 is tested; error: the bins' scatter, "
                          f"{BINS_INDEPENDENT}; syst: the x/L range{grid_note}"))

    def us_of(d: pd.DataFrame, q: dict) -> pd.DataFrame:
        return d.assign(us_lo=d["u_s_lo"] * d["delta_lo"] / q[lo], us_hi=d["u_s_hi"] * d["delta_hi"] / q[hi])

    us = us_of(both, q0)
    first = {c: float(d["q"].iloc[0]) for c, d in ((lo, a), (hi, b))}
    alt = {"q_0 = q of the first bin": ratio("us")(within(us_of(both, first), X_RANGE))[0]}
    if other:
        alt[other_grid] = ratio("us")(within(us_of(other["both"], q0), X_RANGE))[0]
    v, se, sy, tx, n = _ranged(ratio("us"), us, extra=alt)
    out.append(Check(*rows[2][:3], v, se, paper_range=rows[2][3], syst=sy, variants=tx,
                     note=f"mean over the {n} shared x/L bins of the ratio of u_s δ/(2 q_0), q_0 each case's q line "
                          f"(x/L {X_RANGE[0]:g}-{X_RANGE[1]:g}) at x = 0 ({q0[lo] * 1e4:.3g} and {q0[hi] * 1e4:.3g} "
                          f"cm²/s), {rates}; error: the bins' scatter, {BINS_INDEPENDENT}; syst: the x/L range, q_0 "
                          f"from the first bin{grid_note}"))
    return out


# --------------------------------------------------------------------------- all
def profile_checks(profiles: dict) -> list[Check]:
    """Every check the heap makes from its record's profiles (module docstring), then the q* exponent
    across feed rates (:func:`~granflow.scenes.heap.qstar.across_feed_rates`)."""
    streamwise = profiles.get("streamwise")
    if streamwise is None or streamwise.empty:
        return across_feed_rates(streamwise)
    sw = usable_bins(streamwise)
    col = profiles.get("collapse", pd.DataFrame(columns=["case", "x", "zt", "ut", "wt"]))
    surf = profiles.get("surface_at_window_start", pd.DataFrame())
    checks = []
    for case, bins in sw.groupby("case", sort=True):
        checks += streamwise_checks(case, bins)
        checks += collapse_checks(case, col[col["case"] == case], bins)
        if not surf.empty and case in set(surf["case"]):
            checks += surface_checks(case, surf[surf["case"] == case], smallest_diameter(case))
    checks += feed_rate_checks(sw, col)
    return checks + across_feed_rates(streamwise)
