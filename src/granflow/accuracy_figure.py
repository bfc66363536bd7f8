"""What accuracy costs, one picture per scene: |difference from the paper| against CPU-hours for every rung of
its committed ladder, the series' extrapolation toward the paper's size, and the smoke cost study's knobs.

Per headline one panel: each measured rung (``validation/<scene>/ladder.csv``) at its measured CPU-hours, its
|difference| relative to the paper's value or range (absolute where the paper's value is 0) with the combined
error (stat ⊕ syst ⊕ run-to-run from a replicate rung, :func:`granflow.planner.run_to_run`) as its bar; each
planned rung as a dotted line at its priced CPU-hours; each ``series:`` of the ladder
(:func:`granflow.ladder.series_fit`) as a line with its error band, from its rungs toward its points ``at`` (the
paper's size), priced by a power law through its measured CPU-hours (:func:`granflow.planner.cost_along`), its
``at`` points as open diamonds; and, where a smoke cost study was run (``<results>/cost/<scene>/errors.csv``),
its knobs' points faded: their error is against the study's own finest run, not the paper.

.. math:: |\\Delta| = \\frac{\\operatorname{dist}(y, [lo, hi])}{|\\text{nearest edge}|}

(absolute where the paper's range has an edge at 0)
"""
from __future__ import annotations

import math
import textwrap
from pathlib import Path

import numpy as np
import pandas as pd

from .ladder import series_fit
from .planner import cost_along, excess, run_to_run

#: points along a series' line
LINE_POINTS = 200


def absolute(df: pd.DataFrame, quantity: str) -> bool:
    """Whether the paper's value or range of ``quantity`` has an edge at 0: its differences are absolute."""
    rows = df[df["quantity"] == quantity]
    return bool(len(rows)) and bool(((rows["paper_lo"] == 0) | (rows["paper_hi"] == 0)).any())


def measured_points(df: pd.DataFrame, ladder: dict, quantity: str) -> pd.DataFrame:
    """The measured rungs of ``quantity``: ``rung, cpu_hours, difference, error`` (fractions of the paper's value,
    the record's ``abs_rel_difference``; absolute where the paper has an edge at 0, :func:`absolute`),
    ``replicate``, ``diagnostic`` (a row its validation gives no verdict against the paper, drawn open). The error
    is stat ⊕ syst ⊕ run-to-run, on the difference's scale."""
    rows = df[(df["quantity"] == quantity) & df["state"].astype(str).str.startswith("run")
              & np.isfinite(df["ours"].astype(float))]
    r2r = run_to_run(df, ladder, quantity)
    absolute_ = absolute(df, quantity)
    reseeds = {r["name"] for r in ladder["rungs"] if r.get("replicate")}
    out = []
    for _, r in rows.iterrows():
        err = math.hypot(*(v for v in (r["stat"], r["syst"], r2r) if math.isfinite(v)))
        edge = min(max(r["ours"], r["paper_lo"]), r["paper_hi"])       # the paper's value nearest ours
        out.append({"rung": r["rung"], "cpu_hours": r["cpu_hours"], "difference": r["abs_rel_difference"],
                    "error": err if absolute_ else err / abs(edge), "replicate": r["rung"] in reseeds,
                    "diagnostic": str(r.get("kind", "")) == "diagnostic"})
    return pd.DataFrame(out, columns=["rung", "cpu_hours", "difference", "error", "replicate", "diagnostic"])


def series_curves(df: pd.DataFrame, ladder: dict, quantity: str) -> list[dict]:
    """Each series' extrapolation of ``quantity``: ``{knob, cpu, difference, low, high, at: [(label, cpu,
    difference)]}`` from its rungs' x toward its smallest positive ``at`` point (x = 0, the infinite system, has
    no finite price)."""
    out = []
    for series in ladder.get("series") or []:
        fit = series_fit(df, series, quantity)
        price = cost_along(fit.rungs, fit.x, df) if fit else None
        if fit is None or price is None:
            continue
        ends = [float(v) for v in series["at"].values() if float(v) > 0] + list(fit.x)
        xs = np.geomspace(max(ends), min(ends), LINE_POINTS)
        curve = {"knob": series["knob"], "cpu": [], "difference": [], "low": [], "high": [], "at": []}
        for x0 in xs:
            y, e = fit.at(x0)
            d, hi = excess(y, 0.0, *fit.paper), excess(y, e, *fit.paper)
            curve["cpu"].append(price(x0))
            curve["difference"].append(d)
            curve["high"].append(hi)
            curve["low"].append(max(0.0, 2 * d - hi))
        for label, x0 in series["at"].items():
            if float(x0) > 0:
                y, _ = fit.at(float(x0))
                curve["at"].append((label, price(float(x0)), excess(y, 0.0, *fit.paper)))
        out.append(curve)
    return out


def cost_study_points(path: Path | None) -> pd.DataFrame:
    """The smoke cost study's points (``errors.csv``): ``knob, cpu_hours, difference`` (|error| against its own
    finest run); empty when no study was run."""
    if path is None or not Path(path).exists():
        return pd.DataFrame(columns=["knob", "cpu_hours", "difference"])
    errors = pd.read_csv(path)
    errors = errors[np.isfinite(errors["error"].astype(float)) & (errors["cpu_s"] > 0)]
    return pd.DataFrame({"knob": errors["knob"], "cpu_hours": errors["cpu_s"] / 3600.0,
                         "difference": errors["error"].abs()})


def plot_accuracy_cost(df: pd.DataFrame, ladder: dict, out: Path, cost_errors: Path | None = None) -> dict:
    """The picture (one panel per headline) into ``out``; returns what it drew: ``{measured, extrapolated,
    planned, cost_study}`` counts, for the caption and the tests."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    run = df[df["state"].astype(str).str.startswith("run")]
    heads = [q for q in dict.fromkeys(run["quantity"].dropna())]
    planned = df[df["state"].astype(str).str.startswith("planned")].drop_duplicates("rung")
    study = cost_study_points(cost_errors)
    fig, axes = plt.subplots(1, max(1, len(heads)), figsize=(4.6 * max(1, len(heads)), 4.4), squeeze=False)
    drawn = {"measured": 0, "extrapolated": 0, "planned": len(planned) * len(heads), "cost_study": 0}
    for ax, q in zip(axes[0], heads):
        scale = 1.0 if absolute(df, q) else 100.0     # per cent of the paper's value, or absolute where it is 0
        if len(study) and scale != 1.0:   # relative errors: on the panels in per cent only
            ax.scatter(study["cpu_hours"], 100 * study["difference"], s=12, color="0.6", alpha=0.35,
                       label="smoke cost study (vs its finest run)")
            drawn["cost_study"] += len(study)
        for curve in series_curves(df, ladder, q):
            ax.plot(curve["cpu"], scale * np.array(curve["difference"]), color="C3", lw=1.2,
                    label=f"extrapolated along {curve['knob']}")
            ax.fill_between(curve["cpu"], scale * np.array(curve["low"]), scale * np.array(curve["high"]),
                            color="C3", alpha=0.15, lw=0)
            for label, cpu, d in curve["at"]:
                ax.plot([cpu], [scale * d], marker="D", mfc="none", color="C3", ls="none")
                ax.annotate(textwrap.shorten(label, 28), (cpu, scale * d), fontsize=6, color="C3",
                            xytext=(3, 3), textcoords="offset points")
                drawn["extrapolated"] += 1
        points = measured_points(df, ladder, q)
        for i, (_, r) in enumerate(points.iterrows()):
            ax.errorbar([r["cpu_hours"]], [scale * r["difference"]], yerr=[scale * r["error"]], marker="os^Dv<>p"[i % 8],
                        capsize=3, ls="none", mfc="none" if r["diagnostic"] else None,
                        label=r["rung"] + (" (reseed)" if r["replicate"] else "") + (" (diagnostic)" if r["diagnostic"] else ""))
            drawn["measured"] += 1
        for _, r in planned.iterrows():
            ax.axvline(r["cpu_hours"], color="0.5", ls=":", lw=1)
            ax.text(r["cpu_hours"], 0.98, f" {r['rung']} (planned)", transform=ax.get_xaxis_transform(),
                    rotation=90, va="top", ha="right", fontsize=6, color="0.4")
        ax.set(xscale="log", xlabel="CPU-hours",
               ylabel="|ours − paper| (absolute: the paper's edge is 0)" if scale == 1 else "|ours − paper| (% of the paper)",
               title=textwrap.shorten(q, 60))
        ax.title.set_fontsize(8)
        ax.yaxis.label.set_fontsize(7)
        ax.set_ylim(bottom=0)
        ax.legend(fontsize=6)
    fig.suptitle(textwrap.fill(f"{ladder['scene']}: what accuracy costs (measured rungs: filled, bars stat ⊕ syst ⊕ "
                               "run-to-run; open: a diagnostic, no verdict; extrapolated: line, band and open diamonds)", 60 * max(1, len(heads))),
                 fontsize=8)
    fig.tight_layout()
    Path(out).parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=110)
    plt.close(fig)
    return drawn


__all__ = ["plot_accuracy_cost", "measured_points", "series_curves", "cost_study_points"]
