"""Figures of the chute scene (matplotlib Figure + Agg canvas, 150 dpi, provenance footer).

Each function takes the list of cases built by ``ChuteScene.figure_cases``: dicts with
``scalars`` (the case's analysis scalars) and ``profile`` (its height profile or None).
"""
from __future__ import annotations

import math
import textwrap

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

#: the paper's steady range of angles for h ~ 20-40 d, degrees
PAPER_STEADY_RANGE = (20.0, 26.0)


def _footer(fig: Figure, cases) -> None:
    lines = sorted({c["scalars"].get("provenance", "?") for c in cases})
    text = "\n".join(textwrap.shorten(l, 160) for l in lines) or "no cases"
    fig.text(0.01, 0.005, "Provenance (a demo figure is not a paper figure):\n" + text,
             fontsize=6, va="bottom", ha="left", family="monospace")
    fig.subplots_adjust(bottom=0.14 + 0.025 * len(lines))


def _save(fig: Figure, path) -> None:
    FigureCanvasAgg(fig)
    fig.savefig(path, dpi=150)


def _profiled(cases):
    return [c for c in cases if c.get("profile") is not None and len(c["profile"])]


def fig_profiles(cases, path) -> None:
    """u_x(z) with the Bagnold fit, phi(z) and T(z), one line per angle."""
    fig = Figure(figsize=(11, 4.8))
    axes = fig.subplots(1, 3, sharey=True)
    for c in _profiled(cases):
        s, p = c["scalars"], c["profile"]
        z = p["z"] - s.get("z_base", 0.0)
        line, = axes[0].plot(p["u_x"], z, "o-", ms=3, label=f"{s['theta']:g} deg ({s['status']})")
        if "u_bagnold" in p and np.isfinite(s.get("bagnold_A", np.nan)):
            bulk = (p["z"] >= s["bulk_lo"]) & (p["z"] <= s["bulk_hi"])
            axes[0].plot(p["u_bagnold"][bulk], z[bulk], "--", color=line.get_color(),
                         label=f"Bagnold A = {s['bagnold_A']:.3g}, R2 = {s['bagnold_r2']:.3f}")
        axes[1].plot(p["phi"], z, "o-", ms=3, color=line.get_color())
        if "T" in p:  # needs the spin columns in the dump
            axes[2].plot(p["T"], z, "o-", ms=3, color=line.get_color())
    axes[0].set_xlabel("u_x / sqrt(g d)")
    axes[1].set_xlabel("phi")
    axes[2].set_xlabel("T / (m g d)")
    axes[0].set_ylabel("z - z0 / d (above the base)")
    axes[0].legend(fontsize=7)
    fig.suptitle("Chute flow profiles (Silbert et al. 2001)")
    _footer(fig, cases)
    _save(fig, path)


def fig_stress(cases, path) -> None:
    """-sigma_xz/sigma_zz against z with tan(theta), and sigma_zz against the weight above."""
    fig = Figure(figsize=(10, 4.8))
    ax, bx = fig.subplots(1, 2)
    top = 0.0
    for c in _profiled(cases):
        s, p = c["scalars"], c["profile"]
        line, = ax.plot(p["stress_ratio"], p["z"] - s.get("z_base", 0.0), "o-", ms=3,
                        label=f"{s['theta']:g} deg: bulk {s['stress_ratio']:.3f} +- {s['stress_ratio_se']:.3f}")
        ax.axvline(s["tan_theta"], color=line.get_color(), ls=":")
        ax.axhspan(s["bulk_lo"] - s["z_base"], s["bulk_hi"] - s["z_base"], color="0.9", zorder=0)
        bx.plot(p["weight_above"], p["sigma_zz"], "o", ms=3, color=line.get_color(),
                label=f"{s['theta']:g} deg: bulk residual {s['weight_residual']:.2%}")
        top = max(top, float(np.nanmax(p["weight_above"])))
    ax.set_xlim(0, 1.0)
    ax.set_xlabel("-sigma_xz / sigma_zz (dotted: tan theta)")
    ax.set_ylabel("z - z0 / d")
    ax.legend(fontsize=7)
    bx.plot([0, top], [0, top], "k-", lw=0.8)
    bx.set_xlabel("g cos(theta) int_z^h rho dz' / (m g / d^2)")
    bx.set_ylabel("sigma_zz / (m g / d^2)")
    bx.legend(fontsize=7)
    fig.suptitle("Momentum balance of the chute flow")
    _footer(fig, cases)
    _save(fig, path)


def fig_regimes(cases, path) -> None:
    """Status and depth-averaged speed against the angle, the paper's steady range shaded."""
    fig = Figure(figsize=(6.5, 4.8))
    ax = fig.subplots()
    ax.axvspan(*PAPER_STEADY_RANGE, color="0.9", label="paper: steady (h ~ 20-40 d)")
    markers = {"steady": "o", "arrested": "s", "accelerating": "^"}
    for c in cases:
        s = c["scalars"]
        u = s.get("u_mean", s.get("u_cm_last", math.nan))
        ax.plot([s["theta"]], [u if np.isfinite(u) else 0.0], markers.get(s["status"], "x"), ms=8,
                label=f"{s['theta']:g} deg: {s['status']}")
    ax.set_xlabel("theta / deg")
    ax.set_ylabel("u_mean (steady) or last u_cm / sqrt(g d)")
    ax.legend(fontsize=7)
    fig.suptitle("Flow regimes of the chute")
    _footer(fig, cases)
    _save(fig, path)
