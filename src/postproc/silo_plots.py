"""Figures of the silo scene, after Rubio-Largo, Maza & Hidalgo (2016).

One function per paper figure, ``figNN_name(cases, path)`` (figures 2-12, plus
figure 13 for Beverloo's law): it writes one PNG (150 dpi) and returns the
:class:`matplotlib.figure.Figure`.  A case is a dict

``label``
    legend text, e.g. ``"R = 12 r_b"``;
``provenance``
    rung, R_c, N, Y or k_n, t_c and status of the run; printed in the footer
    of every figure after the case's label;
``scalars``
    ``R, R_c, r_b, radii, density, gravity, rung, reinsert`` (+ optional
    ``rho_bulk`` in kg/m^3 or ``phi_b``, the bulk density or volume fraction)
    and the analysis results ``W_f, W_se`` (steady discharge rate, kg/s;
    ``W_f_se`` is read when ``W_se`` is absent), ``t_start, t_end`` (steady window, s),
    ``phi_c, v_c`` (+ ``phi_c_se, v_c_se``), ``h_c, h_c_se`` (m),
    ``sqrt_profile_deviation``;
``flow``
    :func:`postproc.silo.flow_rates` table (``t, W_f, W_f_se, W_r, W_r_se``);
``fields``
    main time-averaged (r, z) field table (kernel width :math:`w = 2r_b`);
``contact``
    contact-stress table (``sigmac_*``, ``pc``; :math:`w = r_b/2`);
``kinetic_scan``
    dict kernel width w (in m, not in r_b) -> kinetic field table (figure 9).

Figures 3, 6a and 9-12 show one case, the *reference case*: the one whose
orifice is closest to the paper's :math:`R = 12 r_b` among those with the
table the figure needs.  Every figure copes with an empty case list, missing
tables and all-NaN columns (the panel says what is missing).  The footer names
every case's provenance, and the rung (``smoke``/``demo`` in red) is printed
at the top right, so a reduced run is never mistaken for the paper.  Paper
reference curves (:math:`\\sqrt{1-(r/R)^2}`) are labelled as such; no number
of the paper is drawn as data.
"""
from __future__ import annotations

import re
import textwrap

import numpy as np
import pandas as pd
from matplotlib.colors import LogNorm
from matplotlib.figure import Figure
from matplotlib.lines import Line2D

from . import silo
from .heap_plots import NO_CASE, _col, _colourbar, _finite, _frame, _label, _plot, _pm, _say, _scalar
from .heap_plots import _finish as _finish_with_footer
from .plots import MARKERS, _colour, _new_figure, _positive, _unavailable

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


def _finish(fig: Figure, cases: list[dict], path, right_in: float = 0.25) -> Figure:
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


def _no_case(axes):
    for ax in np.ravel(axes):
        _say(ax, NO_CASE, fontsize=11)


def _has(df: pd.DataFrame, *cols: str) -> bool:
    return len(df) > 0 and all(c in df and pd.to_numeric(df[c], errors="coerce").notna().any() for c in cols)


def _R_over_rb(case: dict) -> float:
    return _scalar(case, "R") / _scalar(case, "r_b")


def _case_name(case: dict) -> str:
    """The case's label, with R/r_b appended unless the label already names R."""
    x, label = _R_over_rb(case), _label(case)
    if not np.isfinite(x) or re.search(r"\bR\s*=", label):
        return label
    return f"{label} (R = {x:.3g} $r_b$)"


def _reference(cases: list[dict], key: str, *cols: str):
    """(index, case) of the case with R closest to 12 r_b among those whose table ``key`` has ``cols``."""
    have = [(i, c) for i, c in enumerate(cases) if _has(_frame(c, key), *cols)]
    if not have:
        return None
    return min(have, key=lambda ic: abs(np.nan_to_num(_R_over_rb(ic[1]), nan=np.inf) - R_REFERENCE))


def _length_unit(case: dict, kind: str) -> tuple[float, str]:
    """Scale and label of a height axis: ``kind`` "R" (z/R) or "2rb" (z/2r_b); metres if unknown."""
    scale = _scalar(case, "R") if kind == "R" else 2 * _scalar(case, "r_b")
    if np.isfinite(scale) and scale > 0:
        return scale, r"$z/R$" if kind == "R" else r"$z/2r_b$"
    return 1.0, r"$z$ [m]"


def _inset(ax, bounds=(0.58, 0.55, 0.38, 0.38)):
    inset = ax.inset_axes(list(bounds))
    inset.set_yscale("log")
    inset.tick_params(labelsize=6)
    return inset


def _plot_positive(ax, x, y, **kw) -> bool:
    x, y = _finite(x, y)
    ok = y > 0
    if not ok.any():
        return False
    ax.plot(x[ok], y[ok], **kw)
    return True


def _errorbar(ax, x, y, yerr=None, **kw) -> bool:
    """Errorbar of the finite (x, y) pairs sorted by x (NaN errors drawn as 0); whether drawn."""
    yerr = np.zeros(len(np.atleast_1d(x))) if yerr is None else np.nan_to_num(np.asarray(yerr, dtype=float))
    x, y, e = _finite(x, y, yerr)
    if not len(x):
        return False
    ax.errorbar(x, y, yerr=e, **kw)
    return True


def _map(fig: Figure, ax, table: pd.DataFrame, column: str, label: str, case: dict, norm=None, cmap="viridis",
         colourbar: bool = True):
    """Colour map of a field on the (r, z) grid with the silo bottom drawn; the mappable or None."""
    r, z, values = silo.field_map(table, column)
    if not np.isfinite(values).any():
        _unavailable(ax, label)
        return None
    if norm is not None:
        values = np.where(values > 0, values, np.nan)
    mesh = ax.pcolormesh(r, z, values.T, shading="nearest", cmap=cmap, norm=norm)
    R, R_c = _scalar(case, "R"), _scalar(case, "R_c")
    if np.isfinite(R):
        ax.plot([R, np.nanmax([R_c, r.max()])], [0, 0], color="black", lw=3, solid_capstyle="butt")
    ax.set_aspect("equal", adjustable="box")
    ax.set(xlabel=r"$r$ [m]", ylabel=r"$z$ [m]")
    if colourbar:
        _colourbar(fig, ax, mesh, label)
    return mesh


def _species_label(case: dict, s: int, prefix: str = "") -> str:
    scalars = case.get("scalars") or {}
    radii = scalars.get("radii") if hasattr(scalars, "get") else None
    r_b = _scalar(case, "r_b")
    try:
        radius = float(np.sort(np.asarray(radii, dtype=float))[s - 1])
    except (TypeError, ValueError, IndexError):
        radius = np.nan
    if np.isfinite(radius) and np.isfinite(r_b):
        return f"{prefix}$r_{{{s}}}$ = {radius / r_b:.4g} $r_b$"
    return f"{prefix}species {s}"


# --------------------------------------------------------------------------- figures
def fig02_flow_rate(cases: list[dict], path) -> Figure:
    """Paper figure 2: discharge rate against time, (a) raw and (b) rescaled.

    (a) :math:`W_f(t)` from the deleted mass (symbols, standard errors) and
    :math:`W_r(t)` from the falling free surface (lines) against
    :math:`t/t_d`, :math:`t_d = \\sqrt{2r_b/g}`; the steady window of each
    case is shaded and its steady rate dotted.  (b) both rates divided by
    :math:`\\rho_p\\phi_c v_c\\pi R^2` (:func:`postproc.silo.scaled_flow_rate`).
    """
    fig, axes = _new_figure(1, 2, (12, 4.6))
    ax_a, ax_b = axes[0]
    t_ds = [np.sqrt(2 * _scalar(c, "r_b") / _scalar(c, "gravity")) for c in cases]
    use_td = bool(cases) and all(np.isfinite(t_ds))
    xlabel = r"$t/t_d$,  $t_d = \sqrt{2 r_b/g}$" if use_td else r"$t$ [s]"
    ax_a.set(xlabel=xlabel, ylabel=r"$W$ [kg/s]", title="(a) discharge rate")
    ax_b.set(xlabel=xlabel, ylabel=r"$W/(\rho_p\phi_c v_c \pi R^2)$", title="(b) rescaled by the orifice flux")
    if not cases:
        _no_case(axes)
        return _finish(fig, cases, path)
    drawn_a = drawn_b = False
    for i, case in enumerate(cases):
        flow = _frame(case, "flow")
        if not len(flow):
            continue
        t_d = t_ds[i] if use_td else 1.0
        x = _col(flow, "t") / t_d
        colour, marker = _colour(i), MARKERS[i % len(MARKERS)]
        w_f, w_r = _col(flow, "W_f"), _col(flow, "W_r")
        drawn = _errorbar(ax_a, x, w_f, _col(flow, "W_f_se"), color=colour, marker=marker, ms=4,
                          ls="none", mfc="none", capsize=1.5, label=_case_name(case))
        drawn |= _errorbar(ax_a, x, w_r, None, color=colour, lw=1)
        drawn_a |= drawn
        t0, t1, W = _scalar(case, "t_start"), _scalar(case, "t_end"), _scalar(case, "W_f")
        if np.isfinite(t0) and np.isfinite(t1):
            ax_a.axvspan(t0 / t_d, t1 / t_d, color=colour, alpha=0.1, lw=0)
            if np.isfinite(W):
                ax_a.plot([t0 / t_d, t1 / t_d], [W, W], color=colour, ls=":", lw=1)
        scale = silo.scaled_flow_rate(1.0, _scalar(case, "density"), _scalar(case, "phi_c"),
                                      _scalar(case, "v_c"), _scalar(case, "R"))
        if np.isfinite(scale) and scale > 0:
            b = _errorbar(ax_b, x, w_f * scale, _col(flow, "W_f_se") * scale, color=colour, marker=marker,
                          ms=4, ls="none", mfc="none", capsize=1.5, label=_case_name(case))
            b |= _errorbar(ax_b, x, w_r * scale, None, color=colour, lw=1)
            drawn_b |= b
    if drawn_a:
        style = [Line2D([], [], color="0.3", marker="o", mfc="none", ls="none", label=r"$W_f$: deleted mass"),
                 Line2D([], [], color="0.3", lw=1, label=r"$W_r$: free surface"),
                 Line2D([], [], color="0.3", ls=":", label="steady rate (window shaded)")]
        ax_a.legend(handles=ax_a.get_legend_handles_labels()[0] + style, fontsize=7)
    else:
        _unavailable(ax_a, "flow-rate series")
    if drawn_b:
        ax_b.legend(fontsize=7)
    else:
        _say(ax_b, "rescaled rate not available\n(needs the flow series, φ_c and v_c)")
    return _finish(fig, cases, path)


def fig03_fields(cases: list[dict], path) -> Figure:
    """Paper figure 3: (a) volume fraction :math:`\\phi(r, z)` and (b) vertical velocity :math:`v_z(r, z)`.

    For the case with R closest to :math:`12 r_b`; main fields
    (:math:`w = 2r_b`).  The thick black line is the silo bottom, from the
    orifice rim to the wall.
    """
    fig, axes = _new_figure(1, 2, (11, 5.2))
    ax_phi, ax_v = axes[0]
    if not cases:
        _no_case(axes)
        return _finish(fig, cases, path, right_in=0.9)
    ref = _reference(cases, "fields", "phi") or _reference(cases, "fields", "u_z")
    if ref is None:
        _unavailable(ax_phi, "φ field")
        _unavailable(ax_v, "v_z field")
        return _finish(fig, cases, path, right_in=0.9)
    _, case = ref
    table = _frame(case, "fields")
    _map(fig, ax_phi, table, "phi", r"$\phi$", case, cmap="viridis")
    _map(fig, ax_v, table, "u_z", r"$v_z$ [m/s]", case, cmap="magma")
    ax_phi.set_title(f"(a) volume fraction, {_case_name(case)}", fontsize=9)
    ax_v.set_title(f"(b) vertical velocity, {_case_name(case)}", fontsize=9)
    return _finish(fig, cases, path, right_in=0.9)


def _orifice(case: dict):
    """:func:`postproc.silo.orifice_profiles` of a case, or None when it cannot be formed."""
    table = _frame(case, "fields")
    R = _scalar(case, "R")
    if not _has(table, "r", "z") or not (np.isfinite(R) and R > 0):
        return None
    try:
        return silo.orifice_profiles(table, R)
    except ValueError:
        return None


def fig04_phi_orifice(cases: list[dict], path) -> Figure:
    """Paper figure 4: volume fraction across the orifice, (a) :math:`\\phi(r)`, (b) :math:`\\phi/\\phi(0)` vs r/R.

    Read on the node row nearest the orifice plane z = 0
    (:func:`postproc.silo.orifice_profiles`); error bars are standard errors.
    """
    fig, axes = _new_figure(1, 2, (11, 4.6))
    ax_a, ax_b = axes[0]
    ax_a.set(xlabel=r"$r$ [m]", ylabel=r"$\phi(r)$", title="(a) volume fraction at the orifice")
    ax_b.set(xlabel=r"$r/R$", ylabel=r"$\phi(r)/\phi(0)$", title="(b) scaled by the orifice radius")
    if not cases:
        _no_case(axes)
        return _finish(fig, cases, path)
    drawn_a = drawn_b = False
    for i, case in enumerate(cases):
        o = _orifice(case)
        if o is None:
            continue
        p = o["profile"]
        kw = dict(color=_colour(i), marker=MARKERS[i % len(MARKERS)], ms=3.5, lw=0.8, capsize=1.5,
                  label=f"{_case_name(case)}, z = {o['z_row']:.3g} m")
        drawn_a |= _errorbar(ax_a, p["r"], p["phi"], p["phi_se"], **kw)
        drawn_b |= _errorbar(ax_b, p["r_over_R"], p["phi_norm"], p["phi_se"] / o["phi_c"], **kw)
    for ax, drawn, what in ((ax_a, drawn_a, "φ(r) at the orifice"), (ax_b, drawn_b, "φ(r)/φ(0)")):
        if drawn:
            ax.legend(fontsize=7)
        else:
            _unavailable(ax, what)
    return _finish(fig, cases, path)


def fig05_vz_orifice(cases: list[dict], path) -> Figure:
    """Paper figure 5: vertical velocity across the orifice and its scaling with R.

    (a) downward speed :math:`-v_z(r)` on the orifice row; (b)
    :math:`v_z(r)/v_z(0)` against :math:`r/R` with the reference form
    :math:`\\sqrt{1-(r/R)^2}` (the legend gives each case's rms deviation over
    :math:`r < 0.9R`); (c) :math:`v_c = |v_z(0)|` against :math:`\\sqrt R`
    with the line through the origin fitted by
    :func:`postproc.silo.velocity_scaling_fit`.
    """
    fig, axes = _new_figure(1, 3, (15, 4.6))
    ax_a, ax_b, ax_c = axes[0]
    ax_a.set(xlabel=r"$r$ [m]", ylabel=r"$-v_z(r)$ [m/s]", title="(a) velocity at the orifice")
    ax_b.set(xlabel=r"$r/R$", ylabel=r"$v_z(r)/v_z(0)$", title="(b) scaled by the orifice radius")
    ax_c.set(xlabel=r"$\sqrt{R}$ [m$^{1/2}$]", ylabel=r"$v_c = |v_z(0)|$ [m/s]", title=r"(c) $v_c$ against $\sqrt{R}$")
    if not cases:
        _no_case(axes)
        return _finish(fig, cases, path)
    drawn_a = drawn_b = False
    Rs, vcs, vc_ses = [], [], []
    for i, case in enumerate(cases):
        o = _orifice(case)
        style = dict(color=_colour(i), marker=MARKERS[i % len(MARKERS)], ms=3.5)
        if o is not None:
            p = o["profile"]
            kw = dict(lw=0.8, capsize=1.5, **style)
            drawn_a |= _errorbar(ax_a, p["r"], -p["u_z"], p["u_z_se"], label=_case_name(case), **kw)
            dev = _scalar(case, "sqrt_profile_deviation")
            dev = dev if np.isfinite(dev) else o["sqrt_profile_deviation"]
            drawn_b |= _errorbar(ax_b, p["r_over_R"], p["vz_norm"], p["u_z_se"] / o["v_c"],
                                 label=f"{_case_name(case)}: rms dev. {dev:.3f}", **kw)
        v_c = _scalar(case, "v_c")
        v_c_se = _scalar(case, "v_c_se")
        if not np.isfinite(v_c) and o is not None:
            v_c, v_c_se = o["v_c"], o["v_c_se"]
        R = _scalar(case, "R")
        if np.isfinite(v_c) and np.isfinite(R) and R > 0:
            ax_c.errorbar([np.sqrt(R)], [v_c], yerr=[np.nan_to_num(v_c_se)], ls="none", capsize=2,
                          label=_case_name(case), **style)
            Rs.append(R), vcs.append(v_c), vc_ses.append(v_c_se)
    x = np.linspace(0, 1, 200)
    ax_b.plot(x, np.sqrt(1 - x ** 2), "k-", lw=1.5, label=r"reference $\sqrt{1-(r/R)^2}$ (Janda et al. 2012)")
    ax_b.axvspan(silo.SQRT_PROFILE_RANGE, 1.0, color="0.9", lw=0, zorder=0)
    if drawn_a:
        ax_a.legend(fontsize=7)
    else:
        _unavailable(ax_a, "v_z(r) at the orifice")
    if not drawn_b:
        _unavailable(ax_b, "v_z(r)/v_z(0)")
    ax_b.legend(fontsize=7, loc="lower left")
    if Rs:
        fit = silo.velocity_scaling_fit(Rs, vcs, vc_ses)
        if np.isfinite(fit["a"]):
            xs = np.linspace(0, np.sqrt(max(Rs)) * 1.1, 50)
            ax_c.plot(xs, fit["a"] * xs, "k--", lw=1,
                      label=f"fit $v_c = a\\sqrt{{R}}$: a = {_pm(fit['a'], fit['a_se'], '.3g', 'm^1/2/s')}")
        ax_c.set_xlim(left=0)
        ax_c.set_ylim(bottom=0)
        ax_c.legend(fontsize=7)
    else:
        _unavailable(ax_c, "v_c")
    return _finish(fig, cases, path)


def fig06_contact_pressure(cases: list[dict], path) -> Figure:
    """Paper figure 6: contact pressure :math:`p^c`, (a) map and (b) on the axis.

    (a) for the case with R closest to :math:`12 r_b`; (b) :math:`p^c(r=0, z)`
    for every case (contact table, :math:`w = r_b/2`), with standard errors.
    """
    fig, axes = _new_figure(1, 2, (11, 5.2))
    ax_m, ax_z = axes[0]
    ax_z.set(xlabel=r"$z$ [m]", ylabel=r"$p^c(r=0)$ [Pa]", title="(b) contact pressure on the axis")
    if not cases:
        _no_case(axes)
        return _finish(fig, cases, path, right_in=0.9)
    ref = _reference(cases, "contact", "pc")
    if ref is None:
        _unavailable(ax_m, "contact pressure")
    else:
        _map(fig, ax_m, _frame(ref[1], "contact"), "pc", r"$p^c$ [Pa]", ref[1], cmap="cividis")
        ax_m.set_title(f"(a) contact pressure, {_case_name(ref[1])}", fontsize=9)
    drawn = False
    for i, case in enumerate(cases):
        prof = silo.axis_profile(_frame(case, "contact"), "pc")
        drawn |= _errorbar(ax_z, prof["z"], prof["value"], prof["value_se"], color=_colour(i),
                           marker=MARKERS[i % len(MARKERS)], ms=3, lw=0.8, capsize=1.5, label=_case_name(case))
    if drawn:
        ax_z.axvline(0.0, color="0.5", ls=":", lw=0.8)
        ax_z.legend(fontsize=7)
    else:
        _unavailable(ax_z, "contact pressure on the axis")
    return _finish(fig, cases, path, right_in=0.9)


def fig07_kinetic_pressure_maps(cases: list[dict], path) -> Figure:
    """Paper figure 7: kinetic pressure :math:`p^k(r, z)`, one panel per orifice, common log colour scale.

    Main fields (:math:`w = 2r_b`); panels in increasing R, at most four
    per row; values below
    :math:`10^{-4}` of the largest are left blank.
    """
    order = sorted(range(len(cases)), key=lambda i: np.nan_to_num(_scalar(cases[i], "R"), nan=np.inf))
    n = max(1, len(cases))
    ncols = min(n, MAPS_PER_ROW)
    nrows = -(-n // ncols)
    fig, grid = _new_figure(nrows, ncols, (3.6 * ncols + 1.2, 5.2 * nrows))
    for ax in grid.ravel()[n:]:
        fig.delaxes(ax)
    axes = grid.ravel()[:n]
    if not cases:
        _no_case(axes)
        return _finish(fig, cases, path, right_in=0.9)
    pos = [_col(_frame(c, "fields"), "pk") for c in cases]
    pos = np.concatenate([p[_positive(p)] for p in pos]) if pos else np.array([])
    norm = LogNorm(vmin=max(pos.min(), pos.max() * LOG_RANGE), vmax=pos.max()) if len(pos) else None
    mappable = None
    for k, i in enumerate(order):
        ax, case = axes[k], cases[i]
        ax.set_title(f"({chr(97 + k)}) {_case_name(case)}", fontsize=9)
        if norm is None:
            _unavailable(ax, "kinetic pressure")
            continue
        mappable = _map(fig, ax, _frame(case, "fields"), "pk", r"$p^k$ [Pa]", case, norm=norm, cmap="inferno",
                        colourbar=False) or mappable
        if k % ncols:
            ax.set_ylabel("")
    if mappable is not None:
        _colourbar(fig, axes[-1], mappable, r"$p^k$ [Pa]")
    return _finish(fig, cases, path, right_in=0.9)


def _h_c(case: dict, prof: pd.DataFrame) -> tuple[float, float]:
    """h_c and its error: the case's scalars, else measured on ``prof`` (:func:`postproc.silo.transition_height`)."""
    h, h_se = _scalar(case, "h_c"), _scalar(case, "h_c_se")
    if np.isfinite(h):
        return h, h_se
    return silo.transition_height(prof["z"], prof["value"], prof["value_se"])


def fig08_kinetic_axis(cases: list[dict], path) -> Figure:
    """Paper figure 8: kinetic pressure on the axis against :math:`z/R`, inset semilog.

    The dotted vertical lines mark each case's transition height :math:`h_c/R`
    (:func:`postproc.silo.transition_height`), given with its error in the legend.
    """
    fig, axes = _new_figure(1, 1, (7.5, 5.2))
    ax = axes[0, 0]
    ax.set(ylabel=r"$p^k(r=0)$ [Pa]", title="kinetic pressure on the axis")
    inset = _inset(ax)
    if not cases:
        ax.set_xlabel(r"$z/R$")
        _no_case(axes)
        return _finish(fig, cases, path)
    drawn = False
    xlabel = r"$z/R$"
    for i, case in enumerate(cases):
        prof = silo.axis_profile(_frame(case, "fields"), "pk")
        scale, xlabel_i = _length_unit(case, "R")
        colour = _colour(i)
        h, h_se = _h_c(case, prof)
        label = f"{_case_name(case)}: $h_c/R$ = {_pm(h / scale, h_se / scale, '.2f')}"
        d = _errorbar(ax, prof["z"] / scale, prof["value"], prof["value_se"], color=colour,
                      marker=MARKERS[i % len(MARKERS)], ms=3, lw=0.8, capsize=1.5, label=label)
        if d:
            xlabel = xlabel if scale != 1.0 else xlabel_i
            _plot_positive(inset, prof["z"] / scale, prof["value"], color=colour, lw=0.8)
            if np.isfinite(h):
                ax.axvline(h / scale, color=colour, ls=":", lw=1)
        drawn |= d
    ax.set_xlabel(xlabel)
    if drawn:
        ax.legend(fontsize=7, loc="upper right", bbox_to_anchor=(1.0, 0.5))
    else:
        _unavailable(ax, "kinetic pressure on the axis")
    return _finish(fig, cases, path)


def fig09_kinetic_w(cases: list[dict], path) -> Figure:
    """Paper figure 9: kinetic pressure on the axis for several kernel widths w, inset semilog.

    For the case with R closest to :math:`12 r_b` among those with a kinetic
    scan; the legend gives :math:`h_c` measured at each w.
    """
    fig, axes = _new_figure(1, 1, (7.5, 5.2))
    ax = axes[0, 0]
    ax.set(ylabel=r"$p^k(r=0)$ [Pa]")
    inset = _inset(ax)
    if not cases:
        ax.set_xlabel(r"$z/2r_b$")
        _no_case(axes)
        return _finish(fig, cases, path)
    have = [(i, c) for i, c in enumerate(cases)
            if isinstance(c.get("kinetic_scan"), dict) and any(_has(_frame(c["kinetic_scan"], w), "pk")
                                                               for w in c["kinetic_scan"])]
    ax.set_xlabel(r"$z/2r_b$")
    if not have:
        ax.set_title("kinetic pressure on the axis for several w")
        _unavailable(ax, "kinetic scan over w")
        return _finish(fig, cases, path)
    _, case = min(have, key=lambda ic: abs(np.nan_to_num(_R_over_rb(ic[1]), nan=np.inf) - R_REFERENCE))
    scale, xlabel = _length_unit(case, "2rb")
    r_b = _scalar(case, "r_b")
    ax.set(xlabel=xlabel, title=f"kinetic pressure on the axis for several w, {_case_name(case)}")
    scan = case["kinetic_scan"]
    for j, w in enumerate(sorted(scan, key=float)):
        prof = silo.axis_profile(_frame(scan, w), "pk")
        h, h_se = silo.transition_height(prof["z"], prof["value"], prof["value_se"])
        w_text = f"w = {float(w) / r_b:.3g} $r_b$" if np.isfinite(r_b) else f"w = {float(w):.3g} m"
        h_text = f"$h_c/2r_b$ = {_pm(h / scale, h_se / scale, '.2f')}" if scale != 1.0 else \
            f"$h_c$ = {_pm(h, h_se, '.3g', 'm')}"
        if _errorbar(ax, prof["z"] / scale, prof["value"], prof["value_se"], color=_colour(j),
                     marker=MARKERS[j % len(MARKERS)], ms=3, lw=0.8, capsize=1.5, label=f"{w_text}: {h_text}"):
            _plot_positive(inset, prof["z"] / scale, prof["value"], color=_colour(j), lw=0.8)
            if np.isfinite(h):
                ax.axvline(h / scale, color=_colour(j), ls=":", lw=1)
    ax.legend(fontsize=7, loc="upper right", bbox_to_anchor=(1.0, 0.5))
    return _finish(fig, cases, path)


def fig10_cumulative(cases: list[dict], path) -> Figure:
    """Paper figure 10: cumulative kinetic pressure on the axis, :math:`\\sum_{r_s \\ge r'} p^k_s`, inset semilog.

    For the case with R closest to :math:`12 r_b` (main fields); the curve
    for the smallest :math:`r'` is the total :math:`p^k` (dashed black,
    drawn from the ``pk`` column as a check).
    """
    fig, axes = _new_figure(1, 1, (7.5, 5.2))
    ax = axes[0, 0]
    ax.set(xlabel=r"$z/2r_b$", ylabel=r"cumulative $p^k(r=0)$ [Pa]")
    inset = _inset(ax)
    if not cases:
        _no_case(axes)
        return _finish(fig, cases, path)
    ref = _reference(cases, "fields", "pk_s1")
    if ref is None:
        ax.set_title("cumulative kinetic pressure on the axis")
        _unavailable(ax, "partial kinetic pressures")
        return _finish(fig, cases, path)
    case = ref[1]
    table = _frame(case, "fields")
    scale, xlabel = _length_unit(case, "2rb")
    ax.set(xlabel=xlabel, title=f"cumulative kinetic pressure on the axis, {_case_name(case)}")
    cum = silo.cumulative_kinetic_pressure(table)
    ids = silo.species_ids(table, "pk")
    for j, s in enumerate(ids):
        prof = silo.axis_profile(cum, f"pk_cum_s{s}")
        kw = dict(color=_colour(j), lw=1)
        _plot(ax, prof["z"] / scale, prof["value"], label=_species_label(case, s, "sizes ≥ "), **kw)
        _plot_positive(inset, prof["z"] / scale, prof["value"], **kw)
    total = silo.axis_profile(table, "pk")
    if _plot(ax, total["z"] / scale, total["value"], color="black", ls="--", lw=1,
             label=r"total $p^k$ (column pk)"):
        _plot_positive(inset, total["z"] / scale, total["value"], color="black", ls="--", lw=1)
    ax.legend(fontsize=7, loc="upper right", bbox_to_anchor=(1.0, 0.5))
    return _finish(fig, cases, path)


def fig11_partial(cases: list[dict], path) -> Figure:
    """Paper figure 11: partial kinetic pressures :math:`p^k_s` on the axis, (a) linear, (b) semilog.

    For the case with R closest to :math:`12 r_b` (main fields).
    """
    fig, axes = _new_figure(1, 2, (12, 4.8))
    ax_a, ax_b = axes[0]
    ax_b.set_yscale("log")
    for ax in (ax_a, ax_b):
        ax.set(xlabel=r"$z/2r_b$", ylabel=r"$p^k_s(r=0)$ [Pa]")
    ax_a.set_title("(a) partial kinetic pressure on the axis")
    ax_b.set_title("(b) semilog")
    if not cases:
        _no_case(axes)
        return _finish(fig, cases, path)
    ref = _reference(cases, "fields", "pk_s1")
    if ref is None:
        _unavailable(ax_a, "partial kinetic pressures")
        _unavailable(ax_b, "partial kinetic pressures")
        return _finish(fig, cases, path)
    case = ref[1]
    table = _frame(case, "fields")
    scale, xlabel = _length_unit(case, "2rb")
    ax_a.set_title(f"(a) partial kinetic pressure on the axis, {_case_name(case)}", fontsize=9)
    for j, s in enumerate(silo.species_ids(table, "pk")):
        prof = silo.axis_profile(table, f"pk_s{s}")
        kw = dict(color=_colour(j), marker=MARKERS[j % len(MARKERS)], ms=2.5, lw=0.8,
                  label=_species_label(case, s))
        _errorbar(ax_a, prof["z"] / scale, prof["value"], prof["value_se"], capsize=1, **kw)
        _plot_positive(ax_b, prof["z"] / scale, prof["value"], **kw)
    for ax in (ax_a, ax_b):
        ax.set_xlabel(xlabel)
    ax_a.legend(fontsize=7)
    return _finish(fig, cases, path)


def fig12_partial_over_phi(cases: list[dict], path) -> Figure:
    """Paper figure 12: :math:`p^k_s/\\phi_s` on the axis (semilog), for the case with R closest to :math:`12 r_b`.

    Nodes with :math:`\\phi_s < 10^{-3}` are left out
    (:func:`postproc.silo.partial_over_fraction`).
    """
    fig, axes = _new_figure(1, 1, (7.5, 5.2))
    ax = axes[0, 0]
    ax.set_yscale("log")
    ax.set(xlabel=r"$z/2r_b$", ylabel=r"$p^k_s/\phi_s\ (r=0)$ [Pa]")
    if not cases:
        _no_case(axes)
        return _finish(fig, cases, path)
    ref = _reference(cases, "fields", "pk_s1", "phi_s1")
    if ref is None:
        ax.set_title("partial kinetic pressure per partial volume fraction")
        _unavailable(ax, "partial kinetic pressures and volume fractions")
        return _finish(fig, cases, path)
    case = ref[1]
    table = silo.partial_over_fraction(_frame(case, "fields"))
    scale, xlabel = _length_unit(case, "2rb")
    ax.set(xlabel=xlabel, title=f"partial kinetic pressure per partial volume fraction, {_case_name(case)}")
    drawn = False
    for j, s in enumerate(silo.species_ids(table, "pk_over_phi")):
        prof = silo.axis_profile(table, f"pk_over_phi_s{s}")
        drawn |= _plot_positive(ax, prof["z"] / scale, prof["value"], color=_colour(j),
                                marker=MARKERS[j % len(MARKERS)], ms=2.5, lw=0.8, label=_species_label(case, s))
    if drawn:
        ax.legend(fontsize=7)
    else:
        _unavailable(ax, "positive p_s/φ_s")
    return _finish(fig, cases, path)


def _beverloo_inputs(cases: list[dict]):
    """Orifice diameters, steady rates and errors of the cases with a finite rate, and the material constants."""
    rows = [(2 * _scalar(c, "R"), _scalar(c, "W_f"), _W_se(c), i, c) for i, c in enumerate(cases)]
    rows = [r for r in rows if np.isfinite(r[0]) and np.isfinite(r[1])]
    if not rows:
        return rows, {}
    first = rows[0][4]
    scalars = first.get("scalars") or {}
    radii = scalars.get("radii") if hasattr(scalars, "get") else None
    try:
        d = silo.mean_diameter(radii)
    except (TypeError, ValueError):
        d = np.nan
    rho_b = _scalar(first, "rho_bulk")
    if not np.isfinite(rho_b):
        rho_b = _scalar(first, "density") * _scalar(first, "phi_b")
    have_phi_b = bool(np.isfinite(rho_b))
    return rows, dict(d=d, g=_scalar(first, "gravity"), rho_b=rho_b if have_phi_b else _scalar(first, "density"),
                      have_phi_b=have_phi_b)


def _W_se(case: dict) -> float:
    """Standard error of the steady rate: ``W_se``, else ``W_f_se``."""
    se = _scalar(case, "W_se")
    return se if np.isfinite(se) else _scalar(case, "W_f_se")


def fig13_beverloo(cases: list[dict], path) -> Figure:
    """Beverloo's law over the orifice sizes: (a) W against D with the fit, (b) the linearisation.

    (a) steady rates :math:`W_f` (standard errors) against :math:`D = 2R` and
    :math:`W = C\\rho_b\\sqrt g (D-kd)^{5/2}` fitted by
    :func:`postproc.silo.beverloo_fit` (:math:`d` the number-mean diameter,
    :math:`\\rho_b` = ``rho_bulk`` or :math:`\\rho_p\\phi_b`; without either the fit uses
    :math:`\\rho_p` and reports :math:`C\\phi_b`); (b) :math:`W^{2/5}` against D
    with its least-squares line, which crosses zero at :math:`D = kd`.
    At least three orifice sizes are needed; otherwise both panels say so
    and show the points only.
    """
    fig, axes = _new_figure(1, 2, (12, 4.8))
    ax_a, ax_b = axes[0]
    ax_a.set(xlabel=r"$D = 2R$ [m]", ylabel=r"$W$ [kg/s]", title="(a) steady discharge rate")
    ax_b.set(xlabel=r"$D = 2R$ [m]", ylabel=r"$W^{2/5}$ [(kg/s)$^{2/5}$]", title="(b) linearisation")
    if not cases:
        _no_case(axes)
        return _finish(fig, cases, path)
    rows, const = _beverloo_inputs(cases)
    if not rows:
        _unavailable(ax_a, "steady flow rate")
        _unavailable(ax_b, "steady flow rate")
        return _finish(fig, cases, path)
    D = np.array([r[0] for r in rows])
    W = np.array([r[1] for r in rows])
    W_se = np.array([r[2] for r in rows])
    for D_i, W_i, se_i, i, c in rows:
        style = dict(color=_colour(i), marker=MARKERS[i % len(MARKERS)], ms=5, ls="none", capsize=2,
                     label=_case_name(c))
        ax_a.errorbar([D_i], [W_i], yerr=[np.nan_to_num(se_i)], **style)
        if W_i > 0:
            ax_b.errorbar([D_i], [W_i ** 0.4], yerr=[np.nan_to_num(0.4 * W_i ** -0.6 * se_i)], **style)
    weights = W_se if np.all(np.isfinite(W_se) & (W_se > 0)) else None
    grid = np.linspace(0, D.max() * 1.1, 200)
    lin = dict(slope=np.nan)
    try:
        if not np.isfinite([const["d"], const["g"], const["rho_b"]]).all():
            raise ValueError("particle radii, gravity or density not given")
        fit = silo.beverloo_fit(D, W, weights, const["rho_b"], const["g"], const["d"])
    except ValueError as err:
        for ax in (ax_a, ax_b):
            ax.text(0.03, 0.97, "no fit: " + "\n".join(textwrap.wrap(str(err), 45)), transform=ax.transAxes,
                    ha="left", va="top", fontsize=8, color="0.3")
    else:
        lin = fit["linear"]
        c_name = "C" if const["have_phi_b"] else r"$C\phi_b$"
        chi = f", $\\chi^2/\\nu$ = {fit['chi2_dof']:.2g}" if np.isfinite(fit["chi2_dof"]) else ""
        ax_a.plot(grid, silo.beverloo_law(grid, fit["C"], fit["k"], const["rho_b"], const["g"], const["d"]),
                  "k-", lw=1.2, label=f"Beverloo fit: {c_name} = {_pm(fit['C'], fit['C_se'])}, "
                                      f"k = {_pm(fit['k'], fit['k_se'])}{chi}")
    if np.isfinite(lin["slope"]):
        ax_b.plot(grid, lin["slope"] * grid + lin["intercept"], "k-", lw=1,
                  label=f"line: zero at D = {lin['D0']:.3g} m" + (
                      f" = {lin['D0'] / const['d']:.2f} d" if np.isfinite(const.get("d", np.nan)) else "")
                  + (f", $R^2$ = {lin['r2']:.4f}" if np.isfinite(lin["r2"]) else ""))
    for ax, y in ((ax_a, W), (ax_b, np.where(W > 0, np.abs(W) ** 0.4, np.nan))):
        ax.set_xlim(0, 1.1 * D.max())
        ax.set_ylim(0, 1.35 * np.nanmax(y) if np.isfinite(y).any() and np.nanmax(y) > 0 else None)
        ax.legend(fontsize=7, loc="lower right")
    return _finish(fig, cases, path)


#: Figure name -> function, in the paper's order (13: Beverloo's law).
SILO_FIGURES = {
    "fig02_flow_rate": fig02_flow_rate,
    "fig03_fields": fig03_fields,
    "fig04_phi_orifice": fig04_phi_orifice,
    "fig05_vz_orifice": fig05_vz_orifice,
    "fig06_contact_pressure": fig06_contact_pressure,
    "fig07_kinetic_pressure_maps": fig07_kinetic_pressure_maps,
    "fig08_kinetic_axis": fig08_kinetic_axis,
    "fig09_kinetic_w": fig09_kinetic_w,
    "fig10_cumulative": fig10_cumulative,
    "fig11_partial": fig11_partial,
    "fig12_partial_over_phi": fig12_partial_over_phi,
    "fig13_beverloo": fig13_beverloo,
}
