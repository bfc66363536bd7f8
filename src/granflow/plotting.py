"""Figure helpers every scene's figures share: new figures, colours, the provenance footer.

Figures are drawn on the Agg canvas directly (no pyplot, no global state). Every
figure carries a footer naming where its numbers come from (rung, size, stiffness),
so a figure from a small demo run is never mistaken for a figure of the paper.
"""
from __future__ import annotations

import textwrap
from pathlib import Path

import numpy as np
import pandas as pd
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

MARKERS = ("o", "^", "v", "D", "s", "P", "X", "<", ">")
DPI = 150


def _new_figure(nrows: int, ncols: int, size: tuple[float, float]):
    fig = Figure(figsize=size)
    FigureCanvasAgg(fig)
    axes = fig.subplots(nrows, ncols, squeeze=False)
    return fig, axes


def _colour(i: int):
    return f"C{i % 10}"


def finish(fig: Figure, cases: list[dict], path, right_in: float = 0.25) -> Figure:
    """Add the provenance footer, lay out with fixed margins (``right_in`` inches on the right) and save."""
    seen = []
    for c in cases:
        p = str(c.get("provenance", "")).strip() or "provenance not given"
        if p not in seen:
            seen.append(p)
    chars_per_line = int(fig.get_figwidth() * 15)  # 7 pt monospace: ~4.2 pt per character
    text = "\n".join(textwrap.wrap("Provenance: " + " | ".join(seen), chars_per_line))
    n_lines = text.count("\n") + 1
    height, width = fig.get_figheight(), fig.get_figwidth()
    footer = (0.13 * n_lines + 0.1) / height
    # fixed margins in inches (tight_layout doubles the drawing time): room for
    # tick labels and axis labels, plus the footer at the bottom
    fig.subplots_adjust(left=0.85 / width, right=1 - right_in / width,
                        bottom=footer + 0.6 / height, top=1 - 0.4 / height,
                        wspace=0.28, hspace=0.35)
    fig.text(0.01, 0.01, text, ha="left", va="bottom", fontsize=7, color="0.25", family="monospace")
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=DPI)
    return fig


def _unavailable(ax, what: str):
    ax.text(0.5, 0.5, f"{what} not available", transform=ax.transAxes, ha="center", va="center",
            color="0.4")


def _positive(y) -> np.ndarray:
    """Mask of finite positive values (what a log axis can show)."""
    y = np.asarray(y, dtype=float)
    return np.isfinite(y) & (y > 0)
NO_CASE = "no averaged case"


# --------------------------------------------------------------------------- helpers
def _finish_cases(fig: Figure, cases: list[dict], path, right_in: float = 0.25) -> Figure:
    """Footer naming every case (``label: provenance``), fixed margins, save at 150 dpi."""
    rows = [dict(provenance=f"{_label(c)}: {str(c.get('provenance') or '').strip() or 'provenance not given'}")
            for c in cases]
    return finish(fig, rows or [dict(provenance=NO_CASE)], path, right_in=right_in)


def _label(case: dict) -> str:
    return str(case.get("label", "?"))


def _say(ax, text: str, **kw):
    ax.text(0.5, 0.5, text, transform=ax.transAxes, ha="center", va="center", color="0.4", **kw)


def _frame(case: dict, key: str) -> pd.DataFrame:
    df = case.get(key)
    return df if isinstance(df, pd.DataFrame) else pd.DataFrame()


def _col(df: pd.DataFrame, name: str) -> np.ndarray:
    """Column as floats; all NaN when absent."""
    if name in df:
        return pd.to_numeric(df[name], errors="coerce").to_numpy(dtype=float)
    return np.full(len(df), np.nan)


def _scalar(case: dict, key: str) -> float:
    """``case["scalars"][key]`` as a float (dict or Series); NaN when absent."""
    scalars = case.get("scalars")
    try:
        return float(np.nan if scalars is None else scalars.get(key, np.nan))
    except (TypeError, ValueError):
        return np.nan


def _finite(*arrays):
    """The arrays restricted to rows where all are finite, sorted by the first."""
    arrays = [np.asarray(a, dtype=float) for a in arrays]
    ok = np.logical_and.reduce([np.isfinite(a) for a in arrays])
    order = np.argsort(arrays[0][ok], kind="stable")
    return [a[ok][order] for a in arrays]


def _pm(value: float, se: float, fmt: str = ".3g", unit: str = "") -> str:
    """``value ± se unit``; ``n/a`` when the value is not finite."""
    if not np.isfinite(value):
        return "n/a"
    text = f"{value:{fmt}} ± {se:{fmt}}" if np.isfinite(se) else f"{value:{fmt}}"
    return text + ("" if unit in ("", "°") else " ") + unit


def _plot(ax, x, y, **kw) -> bool:
    """Plot the finite (x, y) pairs sorted by x; return whether anything was drawn."""
    x, y = _finite(x, y)
    if len(x) == 0:
        return False
    ax.plot(x, y, **kw)
    return True


def _colourbar(fig: Figure, ax, mappable, label: str):
    if mappable is not None:
        cax = ax.inset_axes([1.03, 0.0, 0.035, 1.0], label="<colorbar>")
        fig.colorbar(mappable, cax=cax, label=label)
