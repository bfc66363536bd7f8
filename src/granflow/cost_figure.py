"""The error-versus-cost figure of a scene (:func:`plot_error_vs_cost`): each observable's error against
the finest setting of each knob, against CPU-hours, from :func:`granflow.cost_analysis.knob_errors`."""
from __future__ import annotations

import textwrap

import numpy as np
import pandas as pd
from matplotlib.figure import Figure
from matplotlib.lines import Line2D

from .cost_analysis import column_values, pareto_front, percent
from .plotting import MARKERS, cycle_colour, new_figure, unavailable

#: Tolerance drawn as a dashed line in :func:`plot_error_vs_cost` (fraction).
GUIDE_TOLERANCE = 0.05
#: Panels per figure in :func:`plot_error_vs_cost` (2 columns).
MAX_PANELS = 4


def _footer(fig: Figure, footer: str, right_in: float = 0.25) -> None:
    """Provenance footer at the bottom and fixed margins (as :func:`granflow.plotting.finish`, without saving)."""
    chars_per_line = int(fig.get_figwidth() * 15)
    text = "\n".join(textwrap.wrap("Provenance: " + (str(footer).strip() or "provenance not given"),
                                   chars_per_line))
    n_lines = text.count("\n") + 1
    height, width = fig.get_figheight(), fig.get_figwidth()
    bottom = (0.13 * n_lines + 0.1) / height
    fig.subplots_adjust(left=0.85 / width, right=1 - right_in / width, bottom=bottom + 0.6 / height,
                        top=1 - 0.6 / height, wspace=0.28, hspace=0.45)
    fig.text(0.01, 0.01, text, ha="left", va="bottom", fontsize=7, color="0.25", family="monospace")


def _panel(ax, obs: pd.DataFrame, knobs: list[str]) -> bool:
    """Draw one observable's error-cost panel; return whether anything was drawn."""
    cost = column_values(obs, "cpu_s")
    scale = np.where(obs["relative"].to_numpy(dtype=bool), 100.0, 1.0)
    y = column_values(obs, "abs_error") * scale
    sigmas = column_values(obs, "noise_sigmas") if "noise_sigmas" in obs else np.full(len(obs), 2.0)
    band = sigmas * column_values(obs, "noise") * scale
    is_ref = obs["is_ref"].to_numpy(dtype=bool)
    sig = obs["significant"].to_numpy(dtype=bool)
    value = column_values(obs, "value")
    drawable = np.isfinite(cost) & (cost > 0) & np.isfinite(y)
    on_edge = drawable & ((y <= 0) | is_ref)      # error 0: drawn on the bottom edge
    positive = drawable & ~on_edge
    if not drawable.any():
        return False

    levels = np.concatenate([y[positive], band[drawable & np.isfinite(band) & (band > 0)],
                             [100 * GUIDE_TOLERANCE]])
    floor = 10 ** (np.floor(np.log10(levels.min())) - 0.5)
    y_draw = np.where(on_edge, floor, y)

    for i, knob in enumerate(knobs):
        k = (obs["knob"].to_numpy() == knob) & drawable
        if not k.any():
            continue
        colour, marker = cycle_colour(i), MARKERS[i % len(MARKERS)]
        order = np.flatnonzero(k)[np.argsort(value[k], kind="stable")]
        ax.plot(cost[order], y_draw[order], color=colour, lw=0.6, alpha=0.6, zorder=2)
        for j in order:
            hollow = on_edge[j] or not sig[j]
            ax.plot(cost[j], y_draw[j], marker=marker, ms=6 if not on_edge[j] else 7, color=colour,
                    mfc="none" if hollow else colour, mew=1.0, ls="none", zorder=4, clip_on=False)
            text = f"{value[j]:g}" + (" ref" if on_edge[j] else "")
            ax.annotate(text, (cost[j], y_draw[j]), xytext=(3, 3), textcoords="offset points", fontsize=5.5,
                        color=colour, zorder=5)
            if np.isfinite(band[j]) and band[j] > 0:
                ax.plot(cost[j], band[j], marker="_", ms=11, mew=1.2, color="0.55", ls="none", zorder=3)

    front = pareto_front(np.where(positive, cost, np.nan), np.where(positive, y, np.nan))
    if front.any():
        order = np.argsort(cost[front])
        ax.step(cost[front][order], y[front][order], where="post", color="k", lw=1.0, alpha=0.7, zorder=3)

    ax.axhline(100 * GUIDE_TOLERANCE, color="0.3", ls="--", lw=0.8, zorder=1)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_ylim(bottom=floor / 1.25, top=max(levels.max(), np.nanmax(y_draw)) * 3)
    if not obs["relative"].all():
        ax.text(0.02, 0.98, "x_ref = 0: absolute error", transform=ax.transAxes, ha="left", va="top",
                fontsize=6, color="0.4")
    return True


def _legend_handles(knobs: list[str], noise_sigmas: float) -> list[Line2D]:
    handles = [Line2D([], [], color=cycle_colour(i), marker=MARKERS[i % len(MARKERS)], lw=0.6, label=k)
               for i, k in enumerate(knobs)]
    handles += [Line2D([], [], color="0.3", marker="o", mfc="none", ls="none",
                       label=f"hollow: within {noise_sigmas:g}σ noise / ref"),
                Line2D([], [], color="0.55", marker="_", ms=11, ls="none", label=f"{noise_sigmas:g}σ noise"),
                Line2D([], [], color="k", lw=1.0, alpha=0.7, drawstyle="steps-post", label="Pareto front"),
                Line2D([], [], color="0.3", ls="--", lw=0.8, label=f"{percent(GUIDE_TOLERANCE)} %")]
    return handles


def plot_error_vs_cost(errors: pd.DataFrame, scene: str, footer: str) -> Figure:
    """Error against cost of one scene, one panel per observable.

    Log-log panels (at most :data:`MAX_PANELS`, two columns, the first
    observables in order of appearance): x = CPU-seconds of the run point,
    y = |error| against the finest setting in % (absolute where
    :math:`x_{ref} = 0`).  One colour and marker per knob, the points of a
    knob joined in order of the knob value and annotated with it.  The
    reference (error 0) sits on the bottom edge as an open marker labelled
    ``ref``.  A grey tick above each point marks ``noise_sigmas`` × noise: a
    point below its tick is hollow (not significant).  The black step line is
    the Pareto front over all knobs (refs and NaNs excluded), the dashed line
    is 5 %.

    Parameters
    ----------
    errors : DataFrame
        Output of :func:`knob_errors` (any number of scenes).
    scene : str
        Scene to draw.
    footer : str
        Provenance (rung, size, stiffness ...) printed at the bottom.

    Returns
    -------
    Figure
        Agg-backed figure, not saved.
    """
    df = errors[errors["scene"] == scene]
    observables = list(dict.fromkeys(df["observable"]))
    shown = observables[:MAX_PANELS]
    n = max(len(shown), 1)
    ncols = 1 if n == 1 else 2
    nrows = int(np.ceil(n / ncols))
    fig, axes = new_figure(nrows, ncols, (5.0 * ncols, 3.6 * nrows + 0.6))
    axes = list(np.ravel(axes))
    for ax in axes[n:]:
        fig.delaxes(ax)
    knobs = list(dict.fromkeys(df["knob"]))
    sigmas = column_values(df, "noise_sigmas")
    noise_sigmas = float(sigmas[np.isfinite(sigmas)][0]) if np.isfinite(sigmas).any() else 2.0
    if not shown:
        unavailable(axes[0], f"records of scene {scene!r}")
    for ax, obs_name in zip(axes, shown):
        obs = df[df["observable"] == obs_name]
        label = str(obs["label"].iloc[0]) if "label" in obs and pd.notna(obs["label"].iloc[0]) else obs_name
        ax.set_title(label, fontsize=9)
        if not _panel(ax, obs, knobs):
            unavailable(ax, "finite error and cost")
            continue
        ax.set_xlabel("CPU-seconds per run point", fontsize=8)
        ax.set_ylabel("|error| vs finest setting [%]", fontsize=8)
        ax.tick_params(labelsize=7)
        ax.grid(True, which="major", color="0.92", lw=0.5)
    if shown:
        axes[0].legend(handles=_legend_handles(knobs, noise_sigmas), fontsize=6, loc="best",
                       framealpha=0.8)
    fig.suptitle(f"error against cost — {scene}", fontsize=11)
    extra = f" | {len(observables) - len(shown)} more observables not shown" if len(observables) > len(shown) else ""
    _footer(fig, f"{footer}{extra}")
    return fig
