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


def new_figure(nrows: int, ncols: int, size: tuple[float, float]):
    """A new figure on its own Agg canvas (no pyplot) with a grid of axes.

    Parameters
    ----------
    nrows, ncols : int
        Rows and columns of the grid of axes.
    size : (float, float)
        Width and height of the figure, inches.

    Returns
    -------
    fig : matplotlib.figure.Figure
    axes : ndarray of Axes, shape (nrows, ncols)
        Always two-dimensional, even for one row or column.
    """
    fig = Figure(figsize=size)
    FigureCanvasAgg(fig)
    axes = fig.subplots(nrows, ncols, squeeze=False)
    return fig, axes


def cycle_colour(i: int):
    """The colour of the ``i``-th case: matplotlib's default cycle, ``"C0"`` to ``"C9"``, then again.

    Parameters
    ----------
    i : int
        The case's index (any non-negative integer).

    Returns
    -------
    str
        A colour specification ``"C<i mod 10>"``.
    """
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


def unavailable(ax, what: str):
    """Write "``what`` not available" in grey in the middle of an empty panel.

    Parameters
    ----------
    ax : matplotlib.axes.Axes
        The panel.
    what : str
        What the panel would have shown (e.g. ``"velocity profile"``).
    """
    ax.text(0.5, 0.5, f"{what} not available", transform=ax.transAxes, ha="center", va="center",
            color="0.4")


def positive_mask(y) -> np.ndarray:
    """Mask of finite positive values (what a log axis can show).

    Parameters
    ----------
    y : array_like
        Values, any unit and shape.

    Returns
    -------
    ndarray of bool
        The shape of ``y``: True where ``y`` is finite and above 0.
    """
    y = np.asarray(y, dtype=float)
    return np.isfinite(y) & (y > 0)
NO_CASE = "no averaged case"


# --------------------------------------------------------------------------- helpers
def finish_cases(fig: Figure, cases: list[dict], path, right_in: float = 0.25) -> Figure:
    """Footer naming every case (``label: provenance``), fixed margins, save at 150 dpi.

    As :func:`finish`, with each case's provenance prefixed by its label; with no case,
    the footer says :data:`NO_CASE`.

    Parameters
    ----------
    fig : matplotlib.figure.Figure
        The figure to finish.
    cases : list of dict
        The cases drawn; each may have ``label`` and ``provenance`` (str).
    path : str or path-like
        Where to save the figure (its folder is made if missing).
    right_in : float, optional
        Right margin, inches.

    Returns
    -------
    matplotlib.figure.Figure
        ``fig``, saved.
    """
    rows = [dict(provenance=f"{case_label(c)}: {str(c.get('provenance') or '').strip() or 'provenance not given'}")
            for c in cases]
    return finish(fig, rows or [dict(provenance=NO_CASE)], path, right_in=right_in)


def case_label(case: dict) -> str:
    """A case's label, as legends and footers show it.

    Parameters
    ----------
    case : dict
        A case handed to a figure; its ``label`` key, if any, is used.

    Returns
    -------
    str
        ``str(case["label"])``, or ``"?"`` when the case has none.
    """
    return str(case.get("label", "?"))


def say(ax, text: str, **kw):
    """Write ``text`` in grey in the middle of a panel (e.g. why it is empty).

    Parameters
    ----------
    ax : matplotlib.axes.Axes
        The panel.
    text : str
        What to write.
    **kw
        Further keyword arguments, ``kw``, passed to :meth:`matplotlib.axes.Axes.text` (e.g. ``fontsize``).
    """
    ax.text(0.5, 0.5, text, transform=ax.transAxes, ha="center", va="center", color="0.4", **kw)


def frame(case: dict, key: str) -> pd.DataFrame:
    """A table of a case, or an empty one when the case has no such table.

    Parameters
    ----------
    case : dict
        A case handed to a figure.
    key : str
        The table's key in ``case`` (e.g. ``"profile"``).

    Returns
    -------
    pandas.DataFrame
        ``case[key]`` when it is a DataFrame, else an empty DataFrame.
    """
    df = case.get(key)
    return df if isinstance(df, pd.DataFrame) else pd.DataFrame()


def float_column(df: pd.DataFrame, name: str) -> np.ndarray:
    """Column as floats; all NaN when absent.

    Parameters
    ----------
    df : pandas.DataFrame
        The table.
    name : str
        The column's name.

    Returns
    -------
    ndarray of float, shape (len(df),)
        The column's values in their unit (values that are not numbers as NaN),
        or all NaN when ``df`` has no such column.
    """
    if name in df:
        return pd.to_numeric(df[name], errors="coerce").to_numpy(dtype=float)
    return np.full(len(df), np.nan)


def scalar(case: dict, key: str) -> float:
    """``case["scalars"][key]`` as a float (dict or Series); NaN when absent.

    Parameters
    ----------
    case : dict
        A case handed to a figure; its ``scalars`` (dict or pandas Series), if any, are read.
    key : str
        The scalar's name.

    Returns
    -------
    float
        The scalar in its own unit; NaN when the case has no scalars, no such key,
        or a value that is not a number.
    """
    scalars = case.get("scalars")
    try:
        return float(np.nan if scalars is None else scalars.get(key, np.nan))
    except (TypeError, ValueError):
        return np.nan


def finite(*arrays):
    """The arrays restricted to rows where all are finite, sorted by the first.

    Parameters
    ----------
    *arrays : array_like
        One-dimensional arrays of one length ``n``, any units.

    Returns
    -------
    list of ndarray of float
        One per argument, each of shape (m,), ``m <= n``: the rows where every array
        is finite, in increasing order of the first (a stable sort).
    """
    arrays = [np.asarray(a, dtype=float) for a in arrays]
    ok = np.logical_and.reduce([np.isfinite(a) for a in arrays])
    order = np.argsort(arrays[0][ok], kind="stable")
    return [a[ok][order] for a in arrays]


def pm(value: float, se: float, fmt: str = ".3g", unit: str = "") -> str:
    """``value ± se unit``; ``n/a`` when the value is not finite.

    Parameters
    ----------
    value : float
        The value, in ``unit``.
    se : float
        Its standard error, in ``unit``; left out when not finite.
    fmt : str, optional
        Format specification of both numbers.
    unit : str, optional
        Unit written after them: after a space, except ``°`` (none).

    Returns
    -------
    str
        E.g. ``"0.512 ± 0.003 m/s"``; ``"n/a"`` when ``value`` is not finite.
    """
    if not np.isfinite(value):
        return "n/a"
    text = f"{value:{fmt}} ± {se:{fmt}}" if np.isfinite(se) else f"{value:{fmt}}"
    return text + ("" if unit in ("", "°") else " ") + unit


def plot(ax, x, y, **kw) -> bool:
    """Plot the finite (x, y) pairs sorted by x; return whether anything was drawn.

    Parameters
    ----------
    ax : matplotlib.axes.Axes
        The panel.
    x, y : array_like, shape (n,)
        The points, in the panel's units; pairs where either is not finite are left out.
    **kw
        Further keyword arguments, ``kw``, passed to :meth:`matplotlib.axes.Axes.plot` (e.g. ``color``).

    Returns
    -------
    bool
        Whether any pair was finite (and so drawn).
    """
    x, y = finite(x, y)
    if len(x) == 0:
        return False
    ax.plot(x, y, **kw)
    return True


def add_colourbar(fig: Figure, ax, mappable, label: str):
    """A colour bar for ``mappable`` just right of ``ax`` (an inset axes), if there is one.

    Parameters
    ----------
    fig : matplotlib.figure.Figure
        The figure of ``ax``.
    ax : matplotlib.axes.Axes
        The panel the colour bar belongs to.
    mappable : matplotlib.cm.ScalarMappable or None
        What was drawn in colours (e.g. a scatter's collection); None draws nothing.
    label : str
        The colour bar's label, with its unit.
    """
    if mappable is not None:
        cax = ax.inset_axes([1.03, 0.0, 0.035, 1.0], label="<colorbar>")
        fig.colorbar(mappable, cax=cax, label=label)
