"""Silo figures 2-6: flow rate, fields, orifice profiles, contact pressure."""
from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure
from matplotlib.lines import Line2D

import granflow.scenes.silo.analysis as silo
from granflow.plotting import MARKERS, float_column, cycle_colour, frame, new_figure, pm, say, scalar, unavailable

from .common import case_name, draw_map, finish_with_rung, finite_errorbar, has_values, no_case, reference_case


# --------------------------------------------------------------------------- figures
def fig02_flow_rate(cases: list[dict], path) -> Figure:
    """Paper figure 2: discharge rate against time, (a) raw and (b) rescaled.

    (a) :math:`W_f(t)` from the deleted mass (symbols, standard errors) and
    :math:`W_r(t)` from the falling free surface (lines) against
    :math:`t/t_d`, :math:`t_d = \\sqrt{2r_b/g}`; the steady window of each
    case is shaded and its steady rate dotted.  (b) both rates divided by
    :math:`\\rho_p\\phi_c v_c\\pi R^2` (:func:`granflow.scenes.silo.analysis.scaled_flow_rate`).
    """
    fig, axes = new_figure(1, 2, (12, 4.6))
    ax_a, ax_b = axes[0]
    t_ds = [np.sqrt(2 * scalar(c, "r_b") / scalar(c, "gravity")) for c in cases]
    use_td = bool(cases) and all(np.isfinite(t_ds))
    xlabel = r"$t/t_d$,  $t_d = \sqrt{2 r_b/g}$" if use_td else r"$t$ [s]"
    ax_a.set(xlabel=xlabel, ylabel=r"$W$ [kg/s]", title="(a) discharge rate")
    ax_b.set(xlabel=xlabel, ylabel=r"$W/(\rho_p\phi_c v_c \pi R^2)$", title="(b) rescaled by the orifice flux")
    if not cases:
        no_case(axes)
        return finish_with_rung(fig, cases, path)
    drawn_a = drawn_b = False
    for i, case in enumerate(cases):
        flow = frame(case, "flow")
        if not len(flow):
            continue
        t_d = t_ds[i] if use_td else 1.0
        x = float_column(flow, "t") / t_d
        colour, marker = cycle_colour(i), MARKERS[i % len(MARKERS)]
        w_f, w_r = float_column(flow, "W_f"), float_column(flow, "W_r")
        drawn = finite_errorbar(ax_a, x, w_f, float_column(flow, "W_f_se"), color=colour, marker=marker, ms=4,
                                ls="none", mfc="none", capsize=1.5, label=case_name(case))
        drawn |= finite_errorbar(ax_a, x, w_r, None, color=colour, lw=1)
        drawn_a |= drawn
        t0, t1, W = scalar(case, "t_start"), scalar(case, "t_end"), scalar(case, "W_f")
        if np.isfinite(t0) and np.isfinite(t1):
            ax_a.axvspan(t0 / t_d, t1 / t_d, color=colour, alpha=0.1, lw=0)
            if np.isfinite(W):
                ax_a.plot([t0 / t_d, t1 / t_d], [W, W], color=colour, ls=":", lw=1)
        scale = silo.scaled_flow_rate(1.0, scalar(case, "density"), scalar(case, "phi_c"),
                                      scalar(case, "v_c"), scalar(case, "R"))
        if np.isfinite(scale) and scale > 0:
            b = finite_errorbar(ax_b, x, w_f * scale, float_column(flow, "W_f_se") * scale, color=colour, marker=marker,
                                ms=4, ls="none", mfc="none", capsize=1.5, label=case_name(case))
            b |= finite_errorbar(ax_b, x, w_r * scale, None, color=colour, lw=1)
            drawn_b |= b
    if drawn_a:
        style = [Line2D([], [], color="0.3", marker="o", mfc="none", ls="none", label=r"$W_f$: deleted mass"),
                 Line2D([], [], color="0.3", lw=1, label=r"$W_r$: free surface"),
                 Line2D([], [], color="0.3", ls=":", label="steady rate (window shaded)")]
        ax_a.legend(handles=ax_a.get_legend_handles_labels()[0] + style, fontsize=7)
    else:
        unavailable(ax_a, "flow-rate series")
    if drawn_b:
        ax_b.legend(fontsize=7)
    else:
        say(ax_b, "rescaled rate not available\n(needs the flow series, φ_c and v_c)")
    return finish_with_rung(fig, cases, path)


def fig03_fields(cases: list[dict], path) -> Figure:
    """Paper figure 3: (a) volume fraction :math:`\\phi(r, z)` and (b) vertical velocity :math:`v_z(r, z)`.

    For the case with R closest to :math:`12 r_b`; main fields
    (:math:`w = 2r_b`).  The thick black line is the silo bottom, from the
    orifice rim to the wall.
    """
    fig, axes = new_figure(1, 2, (11, 5.2))
    ax_phi, ax_v = axes[0]
    if not cases:
        no_case(axes)
        return finish_with_rung(fig, cases, path, right_in=0.9)
    ref = reference_case(cases, "fields", "phi") or reference_case(cases, "fields", "u_z")
    if ref is None:
        unavailable(ax_phi, "φ field")
        unavailable(ax_v, "v_z field")
        return finish_with_rung(fig, cases, path, right_in=0.9)
    _, case = ref
    table = frame(case, "fields")
    draw_map(fig, ax_phi, table, "phi", r"$\phi$", case, cmap="viridis")
    draw_map(fig, ax_v, table, "u_z", r"$v_z$ [m/s]", case, cmap="magma")
    ax_phi.set_title(f"(a) volume fraction, {case_name(case)}", fontsize=9)
    ax_v.set_title(f"(b) vertical velocity, {case_name(case)}", fontsize=9)
    return finish_with_rung(fig, cases, path, right_in=0.9)


def _orifice(case: dict):
    """:func:`granflow.scenes.silo.analysis.orifice_profiles` of a case, or None when it cannot be formed."""
    table = frame(case, "fields")
    R = scalar(case, "R")
    if not has_values(table, "r", "z") or not (np.isfinite(R) and R > 0):
        return None
    try:
        return silo.orifice_profiles(table, R)
    except ValueError:
        return None


def fig04_phi_orifice(cases: list[dict], path) -> Figure:
    """Paper figure 4: volume fraction across the orifice, (a) :math:`\\phi(r)`, (b) :math:`\\phi/\\phi(0)` vs r/R.

    Read on the node row nearest the orifice plane z = 0
    (:func:`granflow.scenes.silo.analysis.orifice_profiles`); error bars are standard errors.
    """
    fig, axes = new_figure(1, 2, (11, 4.6))
    ax_a, ax_b = axes[0]
    ax_a.set(xlabel=r"$r$ [m]", ylabel=r"$\phi(r)$", title="(a) volume fraction at the orifice")
    ax_b.set(xlabel=r"$r/R$", ylabel=r"$\phi(r)/\phi(0)$", title="(b) scaled by the orifice radius")
    if not cases:
        no_case(axes)
        return finish_with_rung(fig, cases, path)
    drawn_a = drawn_b = False
    for i, case in enumerate(cases):
        o = _orifice(case)
        if o is None:
            continue
        p = o["profile"]
        kw = dict(color=cycle_colour(i), marker=MARKERS[i % len(MARKERS)], ms=3.5, lw=0.8, capsize=1.5,
                  label=f"{case_name(case)}, z = {o['z_row']:.3g} m")
        drawn_a |= finite_errorbar(ax_a, p["r"], p["phi"], p["phi_se"], **kw)
        drawn_b |= finite_errorbar(ax_b, p["r_over_R"], p["phi_norm"], p["phi_se"] / o["phi_c"], **kw)
    for ax, drawn, what in ((ax_a, drawn_a, "φ(r) at the orifice"), (ax_b, drawn_b, "φ(r)/φ(0)")):
        if drawn:
            ax.legend(fontsize=7)
        else:
            unavailable(ax, what)
    return finish_with_rung(fig, cases, path)


def fig05_vz_orifice(cases: list[dict], path) -> Figure:
    """Paper figure 5: vertical velocity across the orifice and its scaling with R.

    (a) downward speed :math:`-v_z(r)` on the orifice row; (b)
    :math:`v_z(r)/v_z(0)` against :math:`r/R` with the reference form
    :math:`\\sqrt{1-(r/R)^2}` (the legend gives each case's rms deviation over
    :math:`r < 0.9R`); (c) :math:`v_c = |v_z(0)|` against :math:`\\sqrt R`
    with the line through the origin fitted by
    :func:`granflow.scenes.silo.analysis.velocity_scaling_fit`.
    """
    fig, axes = new_figure(1, 3, (15, 4.6))
    ax_a, ax_b, ax_c = axes[0]
    ax_a.set(xlabel=r"$r$ [m]", ylabel=r"$-v_z(r)$ [m/s]", title="(a) velocity at the orifice")
    ax_b.set(xlabel=r"$r/R$", ylabel=r"$v_z(r)/v_z(0)$", title="(b) scaled by the orifice radius")
    ax_c.set(xlabel=r"$\sqrt{R}$ [m$^{1/2}$]", ylabel=r"$v_c = |v_z(0)|$ [m/s]", title=r"(c) $v_c$ against $\sqrt{R}$")
    if not cases:
        no_case(axes)
        return finish_with_rung(fig, cases, path)
    drawn_a = drawn_b = False
    Rs, vcs, vc_ses = [], [], []
    for i, case in enumerate(cases):
        o = _orifice(case)
        style = dict(color=cycle_colour(i), marker=MARKERS[i % len(MARKERS)], ms=3.5)
        if o is not None:
            p = o["profile"]
            kw = dict(lw=0.8, capsize=1.5, **style)
            drawn_a |= finite_errorbar(ax_a, p["r"], -p["u_z"], p["u_z_se"], label=case_name(case), **kw)
            dev = scalar(case, "sqrt_profile_deviation")
            dev = dev if np.isfinite(dev) else o["sqrt_profile_deviation"]
            drawn_b |= finite_errorbar(ax_b, p["r_over_R"], p["vz_norm"], p["u_z_se"] / o["v_c"],
                                       label=f"{case_name(case)}: rms dev. {dev:.3f}", **kw)
        v_c = scalar(case, "v_c")
        v_c_se = scalar(case, "v_c_se")
        if not np.isfinite(v_c) and o is not None:
            v_c, v_c_se = o["v_c"], o["v_c_se"]
        R = scalar(case, "R")
        if np.isfinite(v_c) and np.isfinite(R) and R > 0:
            ax_c.errorbar([np.sqrt(R)], [v_c], yerr=[np.nan_to_num(v_c_se)], ls="none", capsize=2,
                          label=case_name(case), **style)
            Rs.append(R), vcs.append(v_c), vc_ses.append(v_c_se)
    x = np.linspace(0, 1, 200)
    ax_b.plot(x, np.sqrt(1 - x ** 2), "k-", lw=1.5, label=r"reference $\sqrt{1-(r/R)^2}$ (Janda et al. 2012)")
    ax_b.axvspan(silo.SQRT_PROFILE_RANGE, 1.0, color="0.9", lw=0, zorder=0)
    if drawn_a:
        ax_a.legend(fontsize=7)
    else:
        unavailable(ax_a, "v_z(r) at the orifice")
    if not drawn_b:
        unavailable(ax_b, "v_z(r)/v_z(0)")
    ax_b.legend(fontsize=7, loc="lower left")
    if Rs:
        fit = silo.velocity_scaling_fit(Rs, vcs, vc_ses)
        if np.isfinite(fit["a"]):
            xs = np.linspace(0, np.sqrt(max(Rs)) * 1.1, 50)
            ax_c.plot(xs, fit["a"] * xs, "k--", lw=1,
                      label=f"fit $v_c = a\\sqrt{{R}}$: a = {pm(fit['a'], fit['a_se'], '.3g', 'm^1/2/s')}")
        ax_c.set_xlim(left=0)
        ax_c.set_ylim(bottom=0)
        ax_c.legend(fontsize=7)
    else:
        unavailable(ax_c, "v_c")
    return finish_with_rung(fig, cases, path)


def fig05d_orifice_plane(cases: list[dict], path) -> Figure:
    """The orifice read without a kernel, beside the kernel reading (paper figure 5's quantities).

    (a) :math:`v_z(r)/v_c` against :math:`r/R` from the particles within ±0.5 r_b of the orifice
    plane (:class:`~granflow.scenes.silo.analysis.orifice.PlaneCrossing`) with
    :math:`\\sqrt{1-(r/R)^2}`; (b) :math:`\\phi(r)` from the same slab; (c) :math:`v_c` against
    :math:`R/r_b` on log axes: the plane reading (filled), the kernel node w = 2 r_b (open),
    :math:`\\sqrt{2gR}` (free fall from R above the orifice), the power-law fit and the fit
    :math:`A(R-R_0)^b` of the plane reading.
    """
    fig, axes = new_figure(1, 3, (15, 4.6))
    ax_a, ax_b, ax_c = axes[0]
    ax_a.set(xlabel=r"$r/R$", ylabel=r"$v_z(r)/v_c$", title="(a) velocity in the orifice plane (no kernel)")
    ax_b.set(xlabel=r"$r/R$", ylabel=r"$\phi(r)$", title=r"(b) $\phi$ in the orifice plane (no kernel)")
    ax_c.set(xlabel=r"$R/r_b$", ylabel=r"$v_c$ [m/s]", title=r"(c) $v_c$: plane and kernel", xscale="log", yscale="log")
    if not cases:
        no_case(axes)
        return finish_with_rung(fig, cases, path)
    Rs, vp, vp_se, vk, r_b, g = [], [], [], [], np.nan, np.nan
    for i, case in enumerate(cases):
        pl = case.get("orifice_plane")
        style = dict(color=cycle_colour(i), marker=MARKERS[i % len(MARKERS)], ms=3.5)
        v_c = abs(scalar(case, "v_c_plane"))
        if pl is not None and has_values(pl, "vz") and np.isfinite(v_c):
            p = pl[(pl["slab_half"] == scalar(case, "plane_slab_half")) & (pl["r_over_R"] <= 1.3)]
            finite_errorbar(ax_a, p["r_over_R"], -p["vz"] / v_c, p["vz_se"] / v_c, label=case_name(case), lw=0.8,
                            capsize=1.5, **style)
            finite_errorbar(ax_b, p["r_over_R"], p["phi"], p["phi_se"], label=case_name(case), lw=0.8, capsize=1.5,
                            **style)
        R_rb = scalar(case, "R") / scalar(case, "r_b")
        r_b, g = scalar(case, "r_b"), scalar(case, "gravity")
        if np.isfinite(v_c) and np.isfinite(R_rb):
            ax_c.errorbar([R_rb], [v_c], yerr=[np.nan_to_num(scalar(case, "v_c_plane_se"))], ls="none", capsize=2,
                          label=case_name(case), **style)
            Rs.append(R_rb), vp.append(v_c), vp_se.append(scalar(case, "v_c_plane_se"))
            vk.append(scalar(case, "v_c"))
            ax_c.plot([R_rb], [scalar(case, "v_c")], ls="none", marker=style["marker"], mfc="none",
                      color=style["color"], ms=5)
    x = np.linspace(0, 1, 200)
    ax_a.plot(x, np.sqrt(1 - x ** 2), "k-", lw=1.5, label=r"$\sqrt{1-(r/R)^2}$")
    ax_a.legend(fontsize=7, loc="lower left")
    ax_b.legend(fontsize=7, loc="lower left")
    if len(Rs) >= 2:
        R = np.array(Rs)
        xs = np.linspace(R.min() * 0.9, R.max() * 1.1, 100)
        ax_c.plot(xs, np.sqrt(2 * g * xs * r_b), "k:", lw=1, label=r"$\sqrt{2gR}$")
        pw = silo.scaling_exponent(R, vp, vp_se)
        ax_c.plot(xs, pw["prefactor"] * xs ** pw["exponent"], "k--", lw=1,
                  label=f"plane: $R^a$, a = {pm(pw['exponent'], pw['exponent_se'], '.2f')}")
        sh = silo.shifted_power_fit(R, vp, vp_se)
        if np.isfinite(sh["exponent"]):
            xx = xs[xs > sh["x0"]]
            ax_c.plot(xx, sh["prefactor"] * (xx - sh["x0"]) ** sh["exponent"], "b-", lw=1,
                      label=f"plane: $A(R-R_0)^b$, b = {pm(sh['exponent'], sh['exponent_se'], '.2f')}, "
                            f"$R_0$ = {sh['x0']:.2g} $r_b$")
        kw = silo.scaling_exponent(R, vk)
        if np.isfinite(kw["exponent"]):
            ax_c.plot(xs, kw["prefactor"] * xs ** kw["exponent"], color="0.5", ls="-.", lw=1,
                      label=f"kernel node (open): $R^a$, a = {kw['exponent']:.2f}")
        ax_c.legend(fontsize=7, loc="lower right")
        from matplotlib.ticker import NullFormatter, ScalarFormatter

        for axis in (ax_c.xaxis, ax_c.yaxis):     # plain numbers on the log axes
            axis.set_major_formatter(ScalarFormatter())
            axis.set_minor_formatter(NullFormatter())
        ax_c.set_xticks(sorted(set(round(r, 2) for r in Rs)))
    elif not Rs:
        unavailable(ax_c, "v_c")
    return finish_with_rung(fig, cases, path)


def fig06_contact_pressure(cases: list[dict], path) -> Figure:
    """Paper figure 6: contact pressure :math:`p^c`, (a) map and (b) on the axis.

    (a) for the case with R closest to :math:`12 r_b`; (b) :math:`p^c(r=0, z)`
    for every case (contact table, :math:`w = r_b/2`), with standard errors.
    """
    fig, axes = new_figure(1, 2, (11, 5.2))
    ax_m, ax_z = axes[0]
    ax_z.set(xlabel=r"$z$ [m]", ylabel=r"$p^c(r=0)$ [Pa]", title="(b) contact pressure on the axis")
    if not cases:
        no_case(axes)
        return finish_with_rung(fig, cases, path, right_in=0.9)
    ref = reference_case(cases, "contact", "pc")
    if ref is None:
        unavailable(ax_m, "contact pressure")
    else:
        draw_map(fig, ax_m, frame(ref[1], "contact"), "pc", r"$p^c$ [Pa]", ref[1], cmap="cividis")
        ax_m.set_title(f"(a) contact pressure, {case_name(ref[1])}", fontsize=9)
    drawn = False
    for i, case in enumerate(cases):
        prof = silo.axis_profile(frame(case, "contact"), "pc")
        drawn |= finite_errorbar(ax_z, prof["z"], prof["value"], prof["value_se"], color=cycle_colour(i),
                                 marker=MARKERS[i % len(MARKERS)], ms=3, lw=0.8, capsize=1.5, label=case_name(case))
    if drawn:
        ax_z.axvline(0.0, color="0.5", ls=":", lw=0.8)
        ax_z.legend(fontsize=7)
    else:
        unavailable(ax_z, "contact pressure on the axis")
    return finish_with_rung(fig, cases, path, right_in=0.9)
