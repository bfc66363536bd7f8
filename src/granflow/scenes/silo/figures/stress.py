"""Silo figures 7-13: kinetic pressure, partial stresses, Beverloo; the figure list."""
from __future__ import annotations

import textwrap

import numpy as np
import pandas as pd
from matplotlib.colors import LogNorm
from matplotlib.figure import Figure

import granflow.scenes.silo.analysis as silo
from granflow.plotting import (
    MARKERS,
    float_column,
    cycle_colour,
    add_colourbar,
    frame,
    new_figure,
    plot,
    pm,
    positive_mask,
    scalar,
    unavailable,
)

from .common import (
    LOG_RANGE,
    MAPS_PER_ROW,
    R_REFERENCE,
    R_over_rb,
    case_name,
    draw_map,
    finish_with_rung,
    finite_errorbar,
    has_values,
    length_unit,
    log_inset,
    no_case,
    plot_positive,
    reference_case,
    species_label,
)
from .discharge import fig02_flow_rate, fig03_fields, fig04_phi_orifice, fig05_vz_orifice, fig05d_orifice_plane, fig06_contact_pressure


def fig07_kinetic_pressure_maps(cases: list[dict], path) -> Figure:
    """Paper figure 7: kinetic pressure :math:`p^k(r, z)`, one panel per orifice, common log colour scale.

    Main fields (:math:`w = 2r_b`); panels in increasing R, at most four
    per row; values below
    :math:`10^{-4}` of the largest are left blank.
    """
    order = sorted(range(len(cases)), key=lambda i: np.nan_to_num(scalar(cases[i], "R"), nan=np.inf))
    n = max(1, len(cases))
    ncols = min(n, MAPS_PER_ROW)
    nrows = -(-n // ncols)
    fig, grid = new_figure(nrows, ncols, (3.6 * ncols + 1.2, 5.2 * nrows))
    for ax in grid.ravel()[n:]:
        fig.delaxes(ax)
    axes = grid.ravel()[:n]
    if not cases:
        no_case(axes)
        return finish_with_rung(fig, cases, path, right_in=0.9)
    pos = [float_column(frame(c, "fields"), "pk") for c in cases]
    pos = np.concatenate([p[positive_mask(p)] for p in pos]) if pos else np.array([])
    norm = LogNorm(vmin=max(pos.min(), pos.max() * LOG_RANGE), vmax=pos.max()) if len(pos) else None
    mappable = None
    for k, i in enumerate(order):
        ax, case = axes[k], cases[i]
        ax.set_title(f"({chr(97 + k)}) {case_name(case)}", fontsize=9)
        if norm is None:
            unavailable(ax, "kinetic pressure")
            continue
        mappable = draw_map(fig, ax, frame(case, "fields"), "pk", r"$p^k$ [Pa]", case, norm=norm, cmap="inferno",
                            colourbar=False) or mappable
        if k % ncols:
            ax.set_ylabel("")
    if mappable is not None:
        add_colourbar(fig, axes[-1], mappable, r"$p^k$ [Pa]")
    return finish_with_rung(fig, cases, path, right_in=0.9)


def _h_c(case: dict, prof: pd.DataFrame) -> tuple[float, float]:
    """h_c and its error: the case's scalars, else measured on ``prof`` (:func:`granflow.scenes.silo.analysis.transition_height`)."""
    h, h_se = scalar(case, "h_c"), scalar(case, "h_c_se")
    if np.isfinite(h):
        return h, h_se
    return silo.transition_height(prof["z"], prof["value"], prof["value_se"])


def fig08_kinetic_axis(cases: list[dict], path) -> Figure:
    """Paper figure 8: kinetic pressure on the axis against :math:`z/R`, inset semilog.

    The dotted vertical lines mark each case's transition height :math:`h_c/R`
    (:func:`granflow.scenes.silo.analysis.transition_height`), given with its error in the legend.
    """
    fig, axes = new_figure(1, 1, (7.5, 5.2))
    ax = axes[0, 0]
    ax.set(ylabel=r"$p^k(r=0)$ [Pa]", title="kinetic pressure on the axis")
    inset = log_inset(ax)
    if not cases:
        ax.set_xlabel(r"$z/R$")
        no_case(axes)
        return finish_with_rung(fig, cases, path)
    drawn = False
    xlabel = r"$z/R$"
    for i, case in enumerate(cases):
        prof = silo.axis_profile(frame(case, "fields"), "pk")
        scale, xlabel_i = length_unit(case, "R")
        colour = cycle_colour(i)
        h, h_se = _h_c(case, prof)
        label = f"{case_name(case)}: $h_c/R$ = {pm(h / scale, h_se / scale, '.2f')}"
        d = finite_errorbar(ax, prof["z"] / scale, prof["value"], prof["value_se"], color=colour,
                            marker=MARKERS[i % len(MARKERS)], ms=3, lw=0.8, capsize=1.5, label=label)
        if d:
            xlabel = xlabel if scale != 1.0 else xlabel_i
            plot_positive(inset, prof["z"] / scale, prof["value"], color=colour, lw=0.8)
            if np.isfinite(h):
                ax.axvline(h / scale, color=colour, ls=":", lw=1)
        drawn |= d
    ax.set_xlabel(xlabel)
    if drawn:
        ax.legend(fontsize=7, loc="upper right", bbox_to_anchor=(1.0, 0.5))
    else:
        unavailable(ax, "kinetic pressure on the axis")
    return finish_with_rung(fig, cases, path)


def fig09_kinetic_w(cases: list[dict], path) -> Figure:
    """Paper figure 9: kinetic pressure on the axis for several kernel widths w, inset semilog.

    For the case with R closest to :math:`12 r_b` among those with a kinetic
    scan; the legend gives :math:`h_c` measured at each w.
    """
    fig, axes = new_figure(1, 1, (7.5, 5.2))
    ax = axes[0, 0]
    ax.set(ylabel=r"$p^k(r=0)$ [Pa]")
    inset = log_inset(ax)
    if not cases:
        ax.set_xlabel(r"$z/2r_b$")
        no_case(axes)
        return finish_with_rung(fig, cases, path)
    have = [(i, c) for i, c in enumerate(cases)
            if isinstance(c.get("kinetic_scan"), dict) and any(has_values(frame(c["kinetic_scan"], w), "pk")
                                                               for w in c["kinetic_scan"])]
    ax.set_xlabel(r"$z/2r_b$")
    if not have:
        ax.set_title("kinetic pressure on the axis for several w")
        unavailable(ax, "kinetic scan over w")
        return finish_with_rung(fig, cases, path)
    _, case = min(have, key=lambda ic: abs(np.nan_to_num(R_over_rb(ic[1]), nan=np.inf) - R_REFERENCE))
    scale, xlabel = length_unit(case, "2rb")
    r_b = scalar(case, "r_b")
    ax.set(xlabel=xlabel, title=f"kinetic pressure on the axis for several w, {case_name(case)}")
    scan = case["kinetic_scan"]
    for j, w in enumerate(sorted(scan, key=float)):
        prof = silo.axis_profile(frame(scan, w), "pk")
        h, h_se = silo.transition_height(prof["z"], prof["value"], prof["value_se"])
        w_text = f"w = {float(w) / r_b:.3g} $r_b$" if np.isfinite(r_b) else f"w = {float(w):.3g} m"
        h_text = f"$h_c/2r_b$ = {pm(h / scale, h_se / scale, '.2f')}" if scale != 1.0 else \
            f"$h_c$ = {pm(h, h_se, '.3g', 'm')}"
        if finite_errorbar(ax, prof["z"] / scale, prof["value"], prof["value_se"], color=cycle_colour(j),
                           marker=MARKERS[j % len(MARKERS)], ms=3, lw=0.8, capsize=1.5, label=f"{w_text}: {h_text}"):
            plot_positive(inset, prof["z"] / scale, prof["value"], color=cycle_colour(j), lw=0.8)
            if np.isfinite(h):
                ax.axvline(h / scale, color=cycle_colour(j), ls=":", lw=1)
    ax.legend(fontsize=7, loc="upper right", bbox_to_anchor=(1.0, 0.5))
    return finish_with_rung(fig, cases, path)


def fig10_cumulative(cases: list[dict], path) -> Figure:
    """Paper figure 10: cumulative kinetic pressure on the axis, :math:`\\sum_{r_s \\ge r'} p^k_s`, inset semilog.

    For the case with R closest to :math:`12 r_b` (main fields); the curve
    for the smallest :math:`r'` is the total :math:`p^k` (dashed black,
    drawn from the ``pk`` column as a check).
    """
    fig, axes = new_figure(1, 1, (7.5, 5.2))
    ax = axes[0, 0]
    ax.set(xlabel=r"$z/2r_b$", ylabel=r"cumulative $p^k(r=0)$ [Pa]")
    inset = log_inset(ax)
    if not cases:
        no_case(axes)
        return finish_with_rung(fig, cases, path)
    ref = reference_case(cases, "fields", "pk_s1")
    if ref is None:
        ax.set_title("cumulative kinetic pressure on the axis")
        unavailable(ax, "partial kinetic pressures")
        return finish_with_rung(fig, cases, path)
    case = ref[1]
    table = frame(case, "fields")
    scale, xlabel = length_unit(case, "2rb")
    ax.set(xlabel=xlabel, title=f"cumulative kinetic pressure on the axis, {case_name(case)}")
    cum = silo.cumulative_kinetic_pressure(table)
    ids = silo.species_ids(table, "pk")
    for j, s in enumerate(ids):
        prof = silo.axis_profile(cum, f"pk_cum_s{s}")
        kw = dict(color=cycle_colour(j), lw=1)
        plot(ax, prof["z"] / scale, prof["value"], label=species_label(case, s, "sizes ≥ "), **kw)
        plot_positive(inset, prof["z"] / scale, prof["value"], **kw)
    total = silo.axis_profile(table, "pk")
    if plot(ax, total["z"] / scale, total["value"], color="black", ls="--", lw=1,
             label=r"total $p^k$ (column pk)"):
        plot_positive(inset, total["z"] / scale, total["value"], color="black", ls="--", lw=1)
    ax.legend(fontsize=7, loc="upper right", bbox_to_anchor=(1.0, 0.5))
    return finish_with_rung(fig, cases, path)


def fig11_partial(cases: list[dict], path) -> Figure:
    """Paper figure 11: partial kinetic pressures :math:`p^k_s` on the axis, (a) linear, (b) semilog.

    For the case with R closest to :math:`12 r_b` (main fields).
    """
    fig, axes = new_figure(1, 2, (12, 4.8))
    ax_a, ax_b = axes[0]
    ax_b.set_yscale("log")
    for ax in (ax_a, ax_b):
        ax.set(xlabel=r"$z/2r_b$", ylabel=r"$p^k_s(r=0)$ [Pa]")
    ax_a.set_title("(a) partial kinetic pressure on the axis")
    ax_b.set_title("(b) semilog")
    if not cases:
        no_case(axes)
        return finish_with_rung(fig, cases, path)
    ref = reference_case(cases, "fields", "pk_s1")
    if ref is None:
        unavailable(ax_a, "partial kinetic pressures")
        unavailable(ax_b, "partial kinetic pressures")
        return finish_with_rung(fig, cases, path)
    case = ref[1]
    table = frame(case, "fields")
    scale, xlabel = length_unit(case, "2rb")
    ax_a.set_title(f"(a) partial kinetic pressure on the axis, {case_name(case)}", fontsize=9)
    for j, s in enumerate(silo.species_ids(table, "pk")):
        prof = silo.axis_profile(table, f"pk_s{s}")
        kw = dict(color=cycle_colour(j), marker=MARKERS[j % len(MARKERS)], ms=2.5, lw=0.8,
                  label=species_label(case, s))
        finite_errorbar(ax_a, prof["z"] / scale, prof["value"], prof["value_se"], capsize=1, **kw)
        plot_positive(ax_b, prof["z"] / scale, prof["value"], **kw)
    for ax in (ax_a, ax_b):
        ax.set_xlabel(xlabel)
    ax_a.legend(fontsize=7)
    return finish_with_rung(fig, cases, path)


def fig12_partial_over_phi(cases: list[dict], path) -> Figure:
    """Paper figure 12: :math:`p^k_s/\\phi_s` on the axis (semilog), for the case with R closest to :math:`12 r_b`.

    Nodes with :math:`\\phi_s < 10^{-3}` are left out
    (:func:`granflow.scenes.silo.analysis.partial_over_fraction`).
    """
    fig, axes = new_figure(1, 1, (7.5, 5.2))
    ax = axes[0, 0]
    ax.set_yscale("log")
    ax.set(xlabel=r"$z/2r_b$", ylabel=r"$p^k_s/\phi_s\ (r=0)$ [Pa]")
    if not cases:
        no_case(axes)
        return finish_with_rung(fig, cases, path)
    ref = reference_case(cases, "fields", "pk_s1", "phi_s1")
    if ref is None:
        ax.set_title("partial kinetic pressure per partial volume fraction")
        unavailable(ax, "partial kinetic pressures and volume fractions")
        return finish_with_rung(fig, cases, path)
    case = ref[1]
    table = silo.partial_over_fraction(frame(case, "fields"))
    scale, xlabel = length_unit(case, "2rb")
    ax.set(xlabel=xlabel, title=f"partial kinetic pressure per partial volume fraction, {case_name(case)}")
    drawn = False
    for j, s in enumerate(silo.species_ids(table, "pk_over_phi")):
        prof = silo.axis_profile(table, f"pk_over_phi_s{s}")
        drawn |= plot_positive(ax, prof["z"] / scale, prof["value"], color=cycle_colour(j),
                               marker=MARKERS[j % len(MARKERS)], ms=2.5, lw=0.8, label=species_label(case, s))
    if drawn:
        ax.legend(fontsize=7)
    else:
        unavailable(ax, "positive p_s/φ_s")
    return finish_with_rung(fig, cases, path)


def _beverloo_inputs(cases: list[dict]):
    """Orifice diameters, steady rates and errors of the cases with a finite rate, and the material constants."""
    rows = [(2 * scalar(c, "R"), scalar(c, "W_f"), _W_se(c), i, c) for i, c in enumerate(cases)]
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
    rho_b = scalar(first, "rho_bulk")
    if not np.isfinite(rho_b):
        rho_b = scalar(first, "density") * scalar(first, "phi_b")
    have_phi_b = bool(np.isfinite(rho_b))
    return rows, dict(d=d, g=scalar(first, "gravity"), rho_b=rho_b if have_phi_b else scalar(first, "density"),
                      have_phi_b=have_phi_b)


def _W_se(case: dict) -> float:
    """Standard error of the steady rate: ``W_se``, else ``W_f_se``."""
    se = scalar(case, "W_se")
    return se if np.isfinite(se) else scalar(case, "W_f_se")


def fig13_beverloo(cases: list[dict], path) -> Figure:
    """Beverloo's law over the orifice sizes: (a) W against D with the fit, (b) the linearisation.

    (a) steady rates :math:`W_f` (standard errors) against :math:`D = 2R` and
    :math:`W = C\\rho_b\\sqrt g (D-kd)^{5/2}` fitted by
    :func:`granflow.scenes.silo.analysis.beverloo_fit` (:math:`d` the number-mean diameter,
    :math:`\\rho_b` = ``rho_bulk`` or :math:`\\rho_p\\phi_b`; without either the fit uses
    :math:`\\rho_p` and reports :math:`C\\phi_b`); (b) :math:`W^{2/5}` against D
    with its least-squares line, which crosses zero at :math:`D = kd`.
    At least three orifice sizes are needed; otherwise both panels say so
    and show the points only.
    """
    fig, axes = new_figure(1, 2, (12, 4.8))
    ax_a, ax_b = axes[0]
    ax_a.set(xlabel=r"$D = 2R$ [m]", ylabel=r"$W$ [kg/s]", title="(a) steady discharge rate")
    ax_b.set(xlabel=r"$D = 2R$ [m]", ylabel=r"$W^{2/5}$ [(kg/s)$^{2/5}$]", title="(b) linearisation")
    if not cases:
        no_case(axes)
        return finish_with_rung(fig, cases, path)
    rows, const = _beverloo_inputs(cases)
    if not rows:
        unavailable(ax_a, "steady flow rate")
        unavailable(ax_b, "steady flow rate")
        return finish_with_rung(fig, cases, path)
    D = np.array([r[0] for r in rows])
    W = np.array([r[1] for r in rows])
    W_se = np.array([r[2] for r in rows])
    for D_i, W_i, se_i, i, c in rows:
        style = dict(color=cycle_colour(i), marker=MARKERS[i % len(MARKERS)], ms=5, ls="none", capsize=2,
                     label=case_name(c))
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
                  "k-", lw=1.2, label=f"Beverloo fit: {c_name} = {pm(fit['C'], fit['C_se'])}, "
                                      f"k = {pm(fit['k'], fit['k_se'])}{chi}")
    if np.isfinite(lin["slope"]):
        ax_b.plot(grid, lin["slope"] * grid + lin["intercept"], "k-", lw=1,
                  label=f"line: zero at D = {lin['D0']:.3g} m" + (
                      f" = {lin['D0'] / const['d']:.2f} d" if np.isfinite(const.get("d", np.nan)) else "")
                  + (f", $R^2$ = {lin['r2']:.4f}" if np.isfinite(lin["r2"]) else ""))
    for ax, y in ((ax_a, W), (ax_b, np.where(W > 0, np.abs(W) ** 0.4, np.nan))):
        ax.set_xlim(0, 1.1 * D.max())
        ax.set_ylim(0, 1.35 * np.nanmax(y) if np.isfinite(y).any() and np.nanmax(y) > 0 else None)
        ax.legend(fontsize=7, loc="lower right")
    return finish_with_rung(fig, cases, path)


#: Figure name -> function, in the paper's order (13: Beverloo's law).
SILO_FIGURES = {
    "fig02_flow_rate": fig02_flow_rate,
    "fig03_fields": fig03_fields,
    "fig04_phi_orifice": fig04_phi_orifice,
    "fig05_vz_orifice": fig05_vz_orifice,
    "fig05d_orifice_plane": fig05d_orifice_plane,
    "fig06_contact_pressure": fig06_contact_pressure,
    "fig07_kinetic_pressure_maps": fig07_kinetic_pressure_maps,
    "fig08_kinetic_axis": fig08_kinetic_axis,
    "fig09_kinetic_w": fig09_kinetic_w,
    "fig10_cumulative": fig10_cumulative,
    "fig11_partial": fig11_partial,
    "fig12_partial_over_phi": fig12_partial_over_phi,
    "fig13_beverloo": fig13_beverloo,
}
