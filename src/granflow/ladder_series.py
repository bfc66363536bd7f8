"""A ladder's record read three ways besides its table (:mod:`granflow.ladder`): the figure of |difference from the
paper| against CPU-hours, what its replicate rungs say of the run-to-run scatter, and its series of rungs along one
knob fitted as a straight line and read at the paper's size."""
from __future__ import annotations

import math
import textwrap
from pathlib import Path
from typing import NamedTuple

import numpy as np
import pandas as pd

from granflow.validation import copy_figure, format_with_errors


#: panels per row of the ladder's figure (a ladder with pools has more headlines than fit on one row)
FIGURE_COLUMNS = 4


def figure(df: pd.DataFrame, ladder: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    run = df[df["state"].str.startswith("run")] if "state" in df else df.iloc[:0]
    if len(run) and "abs_rel_difference" in run:   # a diagnostic (no difference from the paper) has no point
        run = run[pd.to_numeric(run["abs_rel_difference"], errors="coerce").notna()]
    heads = list(dict.fromkeys(run["quantity"])) if len(run) else []
    ncol = min(FIGURE_COLUMNS, max(1, len(heads)))
    nrow = max(1, math.ceil(len(heads) / ncol))
    fig, axes = plt.subplots(nrow, ncol, figsize=(4.6 * ncol, 4.2 * nrow), squeeze=False)
    for ax in axes.flat[len(heads):] if heads else ():
        ax.set_visible(False)
    planned = df[df["state"].str.startswith("planned")]
    for ax, q in zip(axes.flat, heads):
        sub = run[run["quantity"] == q]
        for i, (_, r) in enumerate(sub.iterrows()):
            ax.errorbar([r["cpu_hours"]], [r["abs_rel_difference"]], yerr=[r["rel_error"]], marker="os^Dv<>"[i % 7],
                        capsize=3, ls="none", label=r["rung"])
        for _, r in planned.iterrows():
            ax.axvline(r["cpu_hours"], color="0.5", ls=":", lw=1)
            ax.text(r["cpu_hours"], ax.get_ylim()[1] * 0.95, f" {r['rung']}: {r['cpu_hours']:.3g} CPU-h (planned)",
                    rotation=90, va="top", ha="right", fontsize=7, color="0.4")
        ax.set(xscale="log", xlabel="CPU-hours (the rung's cases)", ylabel="|ours − paper| / paper (absolute where 0)",
               title=q if len(q) < 48 else q[:46] + "…")
        ax.title.set_fontsize(8)
        ax.set_ylim(bottom=0)
        ax.legend(fontsize=7)
    sweep = ", ".join(f"{k} {'/'.join(map(str, v))}" for k, v in (ladder.get("sweep") or {}).items())
    fig.suptitle(textwrap.fill(f"{ladder['scene']} ladder (rung {ladder['rung']}; {sweep}): error against the paper "
                               "(bars: stat ⊕ syst) against cost", 70), fontsize=9)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    full = path.with_name(f".{path.name}.full.png")
    fig.savefig(full, dpi=110)
    plt.close(fig)
    copy_figure(full, path)   # as the record's figures: a 256-colour palette, ~3x smaller
    full.unlink()


def scatter_lines(df: pd.DataFrame, ladder: dict) -> str:
    """What the ladder's replicate rungs say (a rung with ``replicate: true`` runs the first rung's cases again
    with another random seed and nothing else): per headline, how far the two samples lie apart, and each
    other rung's shift from the first rung beside that run-to-run scatter. Two samples differing by Δ put one
    run's scatter near |Δ|/√2; a rung's shift no larger than |Δ| is not told apart from a reseed."""
    replicas = [r["name"] for r in ladder["rungs"] if r.get("replicate")]
    run = df[df["state"].astype(str).str.startswith("run")] if len(df) else df
    if not replicas or not len(run):
        return ""
    first = ladder["rungs"][0]["name"]
    lines = []
    for q in dict.fromkeys(run["quantity"]):
        sub = run[run["quantity"] == q].drop_duplicates("rung").set_index("rung")
        if first not in sub.index:
            continue
        base = sub.loc[first, "ours"]
        for rep in (r for r in replicas if r in sub.index):
            spread = abs(sub.loc[rep, "ours"] - base)
            if not math.isfinite(spread):
                continue
            shifts = [f"{name} {sub.loc[name, 'ours'] - base:+.3g}"
                      + (f" ({abs(sub.loc[name, 'ours'] - base) / spread:.1f} × |Δ|)" if spread > 0 else "")
                      for name in sub.index if name not in (first, *replicas) and math.isfinite(sub.loc[name, "ours"])]
            lines.append(f"- {q}: {first} and its replicate {rep} (another seed, nothing else) differ by "
                         f"Δ = {sub.loc[rep, 'ours'] - base:+.3g} (one run's scatter ≈ |Δ|/√2 = {spread / math.sqrt(2):.2g}, "
                         f"against a quoted stat error of {sub.loc[first, 'stat']:.2g})"
                         + ("; the other rungs' shifts from " + first + ": " + ", ".join(shifts) if shifts else "")
                         + ". A shift no larger than |Δ| is not told apart from a reseed.")
    if not lines:
        return ""
    return "Run-to-run scatter (replicate rungs):\n\n" + "\n".join(lines) + "\n\n"


class SeriesFit(NamedTuple):
    """A straight line y = intercept + slope x through a series' rungs (:func:`series_fit`)."""
    rungs: list
    x: np.ndarray
    slope: float
    intercept: float
    cov: np.ndarray          # of (slope, intercept), from the errors given (not rescaled by χ²)
    chi2: float              # per degree of freedom
    paper: tuple             # (lo, hi) of the paper's value or range

    def at(self, x0: float) -> tuple[float, float]:
        """The line at ``x0`` and its error from the fit's covariance."""
        v = np.array([float(x0), 1.0])                     # polyfit's order: slope, intercept
        return float(self.slope * x0 + self.intercept), float(np.sqrt(v @ self.cov @ v))


def series_fit(df: pd.DataFrame, series: dict, quantity: str) -> SeriesFit | None:
    """The straight line in the series' x through its rungs' measured values of ``quantity`` (weighted least
    squares, weights 1/(stat² + syst²)); None with fewer than three finite rungs (no degree of freedom) or a
    rung without an error."""
    run = df[df["state"].astype(str).str.startswith("run")] if len(df) else df
    points = series["points"]
    if not len(run):
        return None
    sub = run[(run["quantity"] == quantity) & run["rung"].isin(list(points))].drop_duplicates("rung")
    sub = sub[np.isfinite(sub["ours"].astype(float))]
    if len(sub) < 3:
        return None
    x = np.array([float(points[r]) for r in sub["rung"]])
    y = sub["ours"].to_numpy(float)
    err = np.hypot(sub["stat"].fillna(0).to_numpy(float), sub["syst"].fillna(0).to_numpy(float))
    if not np.all(err > 0):
        return None
    (slope, intercept), cov = np.polyfit(x, y, 1, w=1 / err, cov="unscaled")   # cov of the errors given
    chi2 = float((((y - intercept - slope * x) / err) ** 2).sum()) / (len(x) - 2)
    paper = (sub["paper_lo"].iloc[0], sub["paper_hi"].iloc[0]) if "paper_lo" in sub else (np.nan, np.nan)
    return SeriesFit(list(sub["rung"]), x, float(slope), float(intercept), cov, chi2, paper)


def series_lines(df: pd.DataFrame, ladder: dict) -> str:
    """The ladder's ``series:``: rungs that turn one knob by steps (``points``: rung → x, e.g. 1/B), each headline
    fitted as a straight line in x (:func:`series_fit`) and read at the points ``at`` (label → x, e.g. the
    paper's size, or x = 0 for the infinite system) with the fit's error and the scene's verdict there. Three
    rungs or more (a fit with a degree of freedom); the line is an assumed form."""
    from granflow.validation import verdict

    run = df[df["state"].astype(str).str.startswith("run")] if len(df) else df
    lines = []
    for series in ladder.get("series") or []:
        for q in (dict.fromkeys(run["quantity"]) if len(run) else []):
            fit = series_fit(df, series, q)
            if fit is None:
                continue
            reads = []
            for label, x0 in series["at"].items():
                y0, e0 = fit.at(x0)
                words = (verdict(y0, e0, fit.paper)[0] if all(np.isfinite(fit.paper)) else "no paper range")
                reads.append(f"at {label} ({series['x']} = {float(x0):g}) {format_with_errors(y0, e0)}: {words}")
            lines.append(f"- {q} along {series['knob']}, a straight line in {series['x']} through "
                         f"{', '.join(fit.rungs)} (slope {fit.slope:+.3g} ± {np.sqrt(fit.cov[0, 0]):.2g}, "
                         f"χ²/ν = {fit.chi2:.2f}): " + "; ".join(reads)
                         + ". The straight line is assumed, not measured: a trend, not a result.")
    if not lines:
        return ""
    return "Series (rungs along one knob, extrapolated):\n\n" + "\n".join(lines) + "\n\n"
