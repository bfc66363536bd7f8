"""Constants and helpers shared by the silo figures."""
from __future__ import annotations

import re

import numpy as np
import pandas as pd
from matplotlib.figure import Figure

import granflow.scenes.silo.analysis as silo
from granflow.plotting import NO_CASE, add_colourbar, finite, frame, case_label, say, scalar, unavailable
from granflow.plotting import finish_cases as _finish_with_footer

#: The paper's reference orifice, R = 12 r_b (figures 3, 6).
R_REFERENCE = 12.0
#: Rungs whose figures are reduced runs, flagged in red.
REDUCED_RUNGS = ("smoke", "demo")
#: Panels per row of figure 7.
MAPS_PER_ROW = 4
#: Lowest value shown on a log colour scale, relative to the largest.
LOG_RANGE = 1e-4


# --------------------------------------------------------------------------- helpers
def _rung(case: dict) -> str:
    scalars = case.get("scalars") or {}
    rung = scalars.get("rung") if hasattr(scalars, "get") else None
    if rung is None or (isinstance(rung, float) and not np.isfinite(rung)):
        m = re.search(r"rung[\s:=~]*([A-Za-z0-9_-]+)", str(case.get("provenance", "")))
        rung = m.group(1) if m else "?"
    return str(rung)


def finish_with_rung(fig: Figure, cases: list[dict], path, right_in: float = 0.25) -> Figure:
    """Rung badge at the top right, then the heap figures' provenance footer and save."""
    rungs = list(dict.fromkeys(_rung(c) for c in cases))
    if rungs:
        reduced = [r for r in rungs if r in REDUCED_RUNGS]
        text = "rung: " + ", ".join(rungs)
        if reduced:
            text += " (reduced run)"
        fig.text(0.995, 0.998, text, ha="right", va="top", fontsize=7, fontweight="bold",
                 color="red" if reduced else "0.3")
    return _finish_with_footer(fig, cases, path, right_in=right_in)


def no_case(axes):
    for ax in np.ravel(axes):
        say(ax, NO_CASE, fontsize=11)


def has_values(df: pd.DataFrame, *cols: str) -> bool:
    return len(df) > 0 and all(c in df and pd.to_numeric(df[c], errors="coerce").notna().any() for c in cols)


def R_over_rb(case: dict) -> float:
    return scalar(case, "R") / scalar(case, "r_b")


def case_name(case: dict) -> str:
    """The case's label, with R/r_b appended unless the label already names R."""
    x, label = R_over_rb(case), case_label(case)
    if not np.isfinite(x) or re.search(r"\bR\s*=", label):
        return label
    return f"{label} (R = {x:.3g} $r_b$)"


def reference_case(cases: list[dict], key: str, *cols: str):
    """(index, case) of the case with R closest to 12 r_b among those whose table ``key`` has ``cols``."""
    have = [(i, c) for i, c in enumerate(cases) if has_values(frame(c, key), *cols)]
    if not have:
        return None
    return min(have, key=lambda ic: abs(np.nan_to_num(R_over_rb(ic[1]), nan=np.inf) - R_REFERENCE))


def length_unit(case: dict, kind: str) -> tuple[float, str]:
    """Scale and label of a height axis: ``kind`` "R" (z/R) or "2rb" (z/2r_b); metres if unknown."""
    scale = scalar(case, "R") if kind == "R" else 2 * scalar(case, "r_b")
    if np.isfinite(scale) and scale > 0:
        return scale, r"$z/R$" if kind == "R" else r"$z/2r_b$"
    return 1.0, r"$z$ [m]"


def log_inset(ax, bounds=(0.58, 0.55, 0.38, 0.38)):
    inset = ax.inset_axes(list(bounds))
    inset.set_yscale("log")
    inset.tick_params(labelsize=6)
    return inset


def plot_positive(ax, x, y, **kw) -> bool:
    x, y = finite(x, y)
    ok = y > 0
    if not ok.any():
        return False
    ax.plot(x[ok], y[ok], **kw)
    return True


def finite_errorbar(ax, x, y, yerr=None, **kw) -> bool:
    """Errorbar of the finite (x, y) pairs sorted by x (NaN errors drawn as 0); whether drawn."""
    yerr = np.zeros(len(np.atleast_1d(x))) if yerr is None else np.nan_to_num(np.asarray(yerr, dtype=float))
    x, y, e = finite(x, y, yerr)
    if not len(x):
        return False
    ax.errorbar(x, y, yerr=e, **kw)
    return True


def draw_map(fig: Figure, ax, table: pd.DataFrame, column: str, label: str, case: dict, norm=None, cmap="viridis",
             colourbar: bool = True):
    """Colour map of a field on the (r, z) grid with the silo bottom drawn; the mappable or None."""
    r, z, values = silo.field_map(table, column)
    if not np.isfinite(values).any():
        unavailable(ax, label)
        return None
    if norm is not None:
        values = np.where(values > 0, values, np.nan)
    mesh = ax.pcolormesh(r, z, values.T, shading="nearest", cmap=cmap, norm=norm)
    R, R_c = scalar(case, "R"), scalar(case, "R_c")
    if np.isfinite(R):
        ax.plot([R, np.nanmax([R_c, r.max()])], [0, 0], color="black", lw=3, solid_capstyle="butt")
    ax.set_aspect("equal", adjustable="box")
    ax.set(xlabel=r"$r$ [m]", ylabel=r"$z$ [m]")
    if colourbar:
        add_colourbar(fig, ax, mesh, label)
    return mesh


def species_label(case: dict, s: int, prefix: str = "") -> str:
    scalars = case.get("scalars") or {}
    radii = scalars.get("radii") if hasattr(scalars, "get") else None
    r_b = scalar(case, "r_b")
    try:
        radius = float(np.sort(np.asarray(radii, dtype=float))[s - 1])
    except (TypeError, ValueError, IndexError):
        radius = np.nan
    if np.isfinite(radius) and np.isfinite(r_b):
        return f"{prefix}$r_{{{s}}}$ = {radius / r_b:.4g} $r_b$"
    return f"{prefix}species {s}"
