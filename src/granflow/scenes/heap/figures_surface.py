"""The heap's free-surface shape figure (fig04b): the S-shape and the planar middle α is read on."""
from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure

from granflow.plotting import finish_cases as _finish
from granflow.plotting import new_figure, scalar, unavailable

from .figure_style import case_style, no_case


def fig04b_surface_shape(cases: list[dict], path) -> Figure:
    """The free surface's shape, and the planar middle the validation reads α on.

    (a) the time-averaged surface :math:`\\bar z_s(x_{lab})` minus the plane fitted over the planar
    middle (:data:`~granflow.scenes.heap.analysis.ALPHA_PLANAR_MIDDLE` of the flowing length from the
    feed zone's edge to the end wall), mm; (b) the local slope :math:`-d\\bar z_s/dx` per column,
    degrees, with that middle shaded and the angles of the plane over it and over the whole surface.
    The S-shape (a flat patch where the fed particles land, a pool against the end wall) is what a short
    heap adds to a planar surface.
    """
    from .analysis import ALPHA_PLANAR_MIDDLE, fit_surface, surface_grid

    fig, axes = new_figure(1, 2, (12, 4.6))
    ax_r, ax_s = axes[0]
    ax_r.set(xlabel=r"$x_{lab}$ [m]", ylabel=r"$\bar z_s - $ plane [mm]", title="(a) surface minus the planar middle's plane")
    ax_s.set(xlabel=r"$x_{lab}$ [m]", ylabel="local slope [°]", title="(b) local slope of the surface")
    if not cases:
        no_case([ax_r, ax_s])
        return _finish(fig, cases, path)
    drawn = False
    for i, case in enumerate(cases):
        surf = case.get("surface")
        x_feed, W = scalar(case, "x_feed"), scalar(case, "W")
        if surf is None or surf.empty or not (np.isfinite(x_feed) and np.isfinite(W)):
            continue
        grid = surface_grid(surf)
        if grid is None:
            continue
        t, x, Z = grid
        L = W - x_feed
        lo, hi = (x_feed + f * L for f in ALPHA_PLANAR_MIDDLE)
        try:
            mid = fit_surface(t, x, Z, (lo, hi))
            whole = fit_surface(t, x, Z, (x_feed, W - 0.5 * (x[1] - x[0])))
        except (ValueError, np.linalg.LinAlgError):
            continue
        if not (np.isfinite(mid.alpha_deg) and np.isfinite(whole.alpha_deg)):
            continue
        mean = np.nanmean(Z, axis=0)
        t_mean = float(np.mean(t))
        plane = mid.z0 - x * np.tan(np.radians(mid.alpha_deg)) + mid.v_r * t_mean
        style = case_style(i, case)
        ax_r.plot(x, 1e3 * (mean - plane), lw=1, ms=3, label=case["label"], **style)
        slope = -np.degrees(np.arctan(np.gradient(mean, x)))
        ax_s.plot(x, slope, lw=1, ms=3, label=f"{case['label']}: α = {mid.alpha_deg:.2f}° (middle), "
                                                 f"{whole.alpha_deg:.2f}° (whole)", **style)
        ax_s.axhline(mid.alpha_deg, color=style["color"], ls="--", lw=0.8)
        if i == 0:
            for ax in (ax_r, ax_s):
                ax.axvspan(lo, hi, color="0.92", lw=0, zorder=0)
                ax.axvline(x_feed, color="0.5", ls=":", lw=0.8)
            ax_s.text(0.5 * (lo + hi), 0.97, "planar middle", transform=ax_s.get_xaxis_transform(), ha="center",
                      va="top", fontsize=7, color="0.4")
        drawn = True
    if drawn:
        ax_r.axhline(0.0, color="k", lw=0.6)
        ax_r.legend(fontsize=7)
        ax_s.legend(fontsize=7, loc="lower center")
    else:
        for ax in (ax_r, ax_s):
            unavailable(ax, "the free surface")
    return _finish(fig, cases, path)
