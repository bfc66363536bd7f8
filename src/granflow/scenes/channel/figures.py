"""Figures of the channel scene, after Debnath, Kesava Rao & Kumaran (2022).

Every function takes a list of *cases* and an output path, writes one PNG and
returns the :class:`matplotlib.figure.Figure`.  A case is a dict

``label``
    legend text, e.g. ``"W=20, φ̄=0.60"``;
``W``, ``phi_mean``
    channel width (:math:`d_p`) and nominal mean volume fraction;
``profile``
    the unfolded cross-channel profile (:mod:`granflow.scenes.channel.analysis` contract);
``scalars``
    the row returned by :func:`granflow.scenes.channel.analysis.analyse_channel`;
``provenance``
    where the numbers come from, e.g. ``"rung demo · W=20 d_p · B=6 · k_n=1e5 · N=2700"``.

All distinct provenance strings are printed in a footer, so a figure from a
small demo run is never mistaken for a figure of the paper.  Figures are drawn
on the Agg canvas directly (no pyplot, no global state).
"""
from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure
from matplotlib.lines import Line2D

import granflow.scenes.channel.analysis as ch
from granflow.plotting import MARKERS, cycle_colour, new_figure, positive_mask, unavailable, finish

#: Zone colours of the paper's figure 11 (plug is not sheared and not shown there).
ZONE_COLOURS = {"wall": "red", "loose": "black", "dense": "saddlebrown", "plug": "0.6"}
#: Zone-boundary line colours of the paper's figures 6 and 8.
BOUNDARY_STYLE = (("x_dense_plug", "black", "plug/dense"),
                  ("x_loose_dense", "blue", "dense/loose"),
                  ("x_wall_layer", "red", "loose/wall"))
PHI_RCP = 0.64


def _analyse(case: dict) -> ch.ChannelAnalysis:
    return ch.analyse_profile(case["profile"], case["W"])


def _zone_lines(ax, zones: ch.FlowZones, linestyle="-"):
    for attr, colour, _ in BOUNDARY_STYLE:
        x = getattr(zones, attr)
        if np.isfinite(x):
            ax.axvline(x, color=colour, lw=0.8, ls=linestyle, alpha=0.8)


def _zone_legend_handles():
    return [Line2D([], [], color=c, lw=0.8, label=lab) for _, c, lab in BOUNDARY_STYLE]


def fig_velocity_profiles(cases: list[dict], path) -> Figure:
    """Paper figure 4: velocity profiles and the universal scaled profile.

    (a) downward speed :math:`u = -u_y` against distance from the wall
    :math:`x/d_p` with standard-error bars; (b) scaled velocity
    :math:`(u-u_{slip})/(u_{max}-u_{slip})` against :math:`x/\\delta_{0.95}` with
    eq. (3.1) (:math:`a = 3`, dashed red) and each case's fitted exponent (dotted).
    """
    fig, axes = new_figure(1, 2, (11, 4.6))
    ax_a, ax_b = axes[0]
    xi_max = 0.0
    for i, case in enumerate(cases):
        a = _analyse(case)
        x = a.folded["x"].to_numpy()
        u, u_se = ch.downward_speed(a.folded)
        kw = dict(color=cycle_colour(i), marker=MARKERS[i % len(MARKERS)], ms=3.5, lw=0.8, capsize=1.5)
        ax_a.errorbar(x, u, yerr=np.nan_to_num(u_se), label=case["label"], **kw)
        sc = a.scales
        if not (np.isfinite(sc.delta_095) and sc.u_max > sc.u_slip):
            continue
        xi = x / sc.delta_095
        xi_max = max(xi_max, float(np.nanmax(xi)))
        ax_b.errorbar(xi, ch.scaled_velocity(a.folded, sc), yerr=np.nan_to_num(u_se) / (sc.u_max - sc.u_slip),
                      ls="none", label=case["label"], **kw)
        if np.isfinite(a.fit.a):
            grid = np.linspace(0, xi.max(), 200)
            ax_b.plot(grid, ch.universal_profile(grid, a.fit.a), color=cycle_colour(i), ls=":", lw=1,
                      label=f"fit a = {a.fit.a:.2f} ± {a.fit.a_se:.2f}")
    grid = np.linspace(0, max(xi_max, 1.0), 300)
    ax_b.plot(grid, ch.universal_profile(grid), "r--", lw=1.5, label="eq. (3.1), a = 3")
    ax_a.set(xlabel=r"$x/d_p$ (from the wall)", ylabel=r"$u = -u_y$  [$\sqrt{g d_p}$]",
             title="(a) downward velocity")
    ax_b.set(xlabel=r"$x/\delta_{0.95}$", ylabel=r"$(u-u_{slip})/(u_{max}-u_{slip})$",
             title="(b) scaled velocity")
    ax_a.legend(fontsize=7)
    ax_b.legend(fontsize=7)
    return finish(fig, cases, path)


def fig_ratio_vs_phi(cases: list[dict], path) -> Figure:
    """Paper figure 5(c): :math:`u_{max}/u_{slip}` against :math:`\\bar\\phi`, one series per W.

    Error bars are the ratio's standard error propagated from the ``u_y_se``
    columns (``scalars["ratio_se"]``).
    """
    fig, axes = new_figure(1, 1, (6, 4.6))
    ax = axes[0, 0]
    widths = sorted({float(c["W"]) for c in cases})
    for i, W in enumerate(widths):
        rows = sorted((c for c in cases if float(c["W"]) == W), key=lambda c: c["phi_mean"])
        phi = [c["phi_mean"] for c in rows]
        ratio = [c["scalars"].get("ratio", np.nan) for c in rows]
        err = [c["scalars"].get("ratio_se", np.nan) for c in rows]
        ax.errorbar(phi, ratio, yerr=np.nan_to_num(np.asarray(err, dtype=float)), color=cycle_colour(i),
                    marker=MARKERS[i % len(MARKERS)], lw=0.8, capsize=2, label=f"W = {W:g} $d_p$")
    ax.set(xlabel=r"$\bar\phi$", ylabel=r"$u_{max}/u_{slip}$", title=r"ratio of centre and slip velocities")
    ax.legend(fontsize=8)
    return finish(fig, cases, path)


def fig_stress_profiles(cases: list[dict], path) -> Figure:
    """Paper figure 6: :math:`\\sigma_{xx}` (left axis) and :math:`\\sigma_{xy}` (right axis).

    Against distance from the wall, with zone boundaries: black plug/dense,
    blue dense/loose, red loose/wall (line style per case).
    """
    fig, axes = new_figure(1, 1, (7.5, 4.8))
    ax = axes[0, 0]
    ax2 = ax.twinx()
    drawn = False
    for i, case in enumerate(cases):
        a = _analyse(case)
        f = a.folded
        x = f["x"].to_numpy()
        m = MARKERS[i % len(MARKERS)]
        ls = ("-", "--", "-.", ":")[i % 4]
        for col, axis, colour in (("sigma_xx", ax, "black"), ("sigma_xy", ax2, "saddlebrown")):
            if col in f:
                axis.errorbar(x, f[col], yerr=_se(f, col), color=colour,
                              marker=m, ms=3.5, lw=0.8, ls=ls, capsize=1.5)
                drawn = True
        _zone_lines(ax, a.zones, ls)
    if not drawn:
        unavailable(ax, "stress")
    ax.set(xlabel=r"$x/d_p$ (from the wall)", ylabel=r"$\sigma_{xx}$  [$\rho_p g d_p$]")
    ax2.set_ylabel(r"$\sigma_{xy}$  [$\rho_p g d_p$]", color="saddlebrown")
    handles = [Line2D([], [], color="black", marker=MARKERS[0], label=r"$\sigma_{xx}$ (left)"),
               Line2D([], [], color="saddlebrown", marker=MARKERS[0], label=r"$\sigma_{xy}$ (right)")]
    handles += [Line2D([], [], color="0.3", marker=MARKERS[i % len(MARKERS)], ls=("-", "--", "-.", ":")[i % 4],
                       label=c["label"]) for i, c in enumerate(cases)]
    ax.legend(handles=handles + _zone_legend_handles(), fontsize=7, loc="best")
    ax.set_title("normal and shear stress (compressive positive)")
    return finish(fig, cases, path, right_in=0.9)


def _se(df, col: str) -> np.ndarray:
    """Standard-error column as error-bar lengths (0 where absent)."""
    return np.nan_to_num(df[f"{col}_se"].to_numpy(dtype=float)) if f"{col}_se" in df else np.zeros(len(df))


def fig_phi_shear_temperature(cases: list[dict], path) -> Figure:
    """Paper figure 8: (a) :math:`\\phi`, (b) :math:`|du/dx|`, (c) :math:`T`, (d) shear production.

    (b)-(d) on log scales (positive values only).  (d) is the shear production
    :math:`\\sigma_{xy}\\,du/dx = -\\sigma_{xy}\\,du_y/dx`; the dissipation rate
    :math:`D` of the paper is not measured by this pipeline.
    """
    fig, axes = new_figure(2, 2, (11, 8))
    (ax_phi, ax_gd), (ax_t, ax_p) = axes
    have = dict(phi=False, T=False, P=False)
    for i, case in enumerate(cases):
        a = _analyse(case)
        f, r = a.folded, a.rheo
        x = f["x"].to_numpy()
        kw = dict(color=cycle_colour(i), marker=MARKERS[i % len(MARKERS)], ms=3, lw=0.8, capsize=1.5,
                  label=case["label"])
        if "phi" in f:
            ax_phi.errorbar(x, f["phi"], yerr=_se(f, "phi"), **kw)
            have["phi"] = True
        gd = np.abs(r["gamma_dot"].to_numpy())
        ok = positive_mask(gd)
        ax_gd.errorbar(x[ok], gd[ok], yerr=np.nan_to_num(r["gamma_dot_se"].to_numpy()[ok]), **kw)
        if "T" in f:
            t = f["T"].to_numpy()
            ok = positive_mask(t)
            ax_t.errorbar(x[ok], t[ok], yerr=_se(f, "T")[ok], **kw)
            have["T"] = True
        p = r["shear_production"].to_numpy()
        ok = positive_mask(p)
        if ok.any():
            ax_p.errorbar(x[ok], p[ok], yerr=np.nan_to_num(r["shear_production_se"].to_numpy()[ok]), **kw)
            have["P"] = True
        for ax in (ax_phi, ax_gd, ax_t, ax_p):
            _zone_lines(ax, a.zones, ("-", "--", "-.", ":")[i % 4])
    ax_phi.axhline(ch.PHI_AD, color="blue", ls=":", lw=0.8)
    ax_phi.axhline(ch.PHI_PLUG, color="black", ls=":", lw=0.8)
    for ax in (ax_gd, ax_t, ax_p):
        ax.set_yscale("log", nonpositive="mask")
    for key, ax, what in (("phi", ax_phi, "φ"), ("T", ax_t, "granular temperature"),
                          ("P", ax_p, "shear stress")):
        if not have[key]:
            unavailable(ax, what)
    ax_phi.set(ylabel=r"$\phi$", title=r"(a) volume fraction ($\phi_{ad}$ = 0.587, 0.63 dotted)")
    ax_gd.set(ylabel=r"$|du/dx|$  [$\sqrt{g/d_p}$]", title="(b) shear rate")
    ax_t.set(ylabel=r"$T$  [$g d_p$]", title="(c) granular temperature")
    ax_p.set(ylabel=r"$\sigma_{xy}\,du/dx$  [$\rho_p g^{3/2} d_p^{1/2}$]",
             title="(d) shear production (dissipation rate D not measured)")
    for ax in (ax_phi, ax_gd, ax_t, ax_p):
        ax.set_xlabel(r"$x/d_p$ (from the wall)")
    ax_phi.legend(handles=ax_phi.get_legend_handles_labels()[0] + _zone_legend_handles(), fontsize=7)
    return finish(fig, cases, path)


def fig_rheology(cases: list[dict], path, params: ch.MuIParameters = ch.JOP2015) -> Figure:
    """Paper figure 11: (a) :math:`\\mu(I)`, (b) :math:`0.64 - \\phi` against :math:`I`.

    Points are coloured by zone (wall red, loose black, dense brown); plug bins
    have no measurable shear rate and are left out.  The dotted blue curves are
    eqs. (B3) and (B4) with the model constants of Jop (2015); the black dotted
    line in (b) is a slope-1 guide.
    """
    fig, axes = new_figure(1, 2, (11, 4.6))
    ax_mu, ax_phi = axes[0]
    all_I = []
    phi_pts = []
    for i, case in enumerate(cases):
        a = _analyse(case)
        r, labels = a.rheo, a.zones.labels
        I, mu = r["I"].to_numpy(), r["mu"].to_numpy()
        phi = a.folded["phi"].to_numpy(dtype=float) if "phi" in a.folded else np.full(len(I), np.nan)
        m = MARKERS[i % len(MARKERS)]
        for zone in ("wall", "loose", "dense"):
            sel = (labels == zone) & np.isfinite(I) & (I > 0)
            if not sel.any():
                continue
            all_I.append(I[sel])
            ax_mu.plot(I[sel], mu[sel], m, color=ZONE_COLOURS[zone], ms=4, mfc="none")
            dphi = PHI_RCP - phi[sel]
            ok = np.isfinite(dphi) & (dphi > 0)
            ax_phi.plot(I[sel][ok], dphi[ok], m, color=ZONE_COLOURS[zone], ms=4, mfc="none")
            phi_pts.append((I[sel][ok], dphi[ok]))
    if all_I:
        I_all = np.concatenate(all_I)
        grid = np.logspace(np.log10(I_all.min()) - 0.3, np.log10(I_all.max()) + 0.3, 200)
    else:
        grid = np.logspace(-5, 0, 200)
        unavailable(ax_mu, "μ(I) (needs stress and shear rate)")
    ax_mu.plot(grid, params.mu(grid), ":", color="blue", lw=1.5, label="(B3), Jop 2015 constants")
    ax_phi.plot(grid, PHI_RCP - params.phi(grid), ":", color="blue", lw=1.5, label="(B4), Jop 2015 constants")
    pts = [p for p in phi_pts if len(p[0])]
    if pts:
        xs = np.concatenate([p[0] for p in pts])
        ys = np.concatenate([p[1] for p in pts])
        x0, y0 = np.exp(np.mean(np.log(xs))), np.exp(np.mean(np.log(ys)))
        ax_phi.plot(grid, y0 * grid / x0, ":", color="black", lw=1, label="slope 1")
    ax_mu.set_xscale("log")
    ax_phi.set_xscale("log")
    ax_phi.set_yscale("log")
    ax_mu.set(xlabel=r"$I = d_p|du/dx|/\sqrt{\sigma_{xx}/\rho_p}$", ylabel=r"$\mu = |\sigma_{xy}|/\sigma_{xx}$",
              title=r"(a) friction coefficient")
    ax_phi.set(xlabel=r"$I$", ylabel=r"$0.64 - \phi$", title=r"(b) volume fraction")
    zone_handles = [Line2D([], [], color=ZONE_COLOURS[z], marker="o", mfc="none", ls="none", label=f"{z} zone")
                    for z in ("wall", "loose", "dense")]
    case_handles = [Line2D([], [], color="0.3", marker=MARKERS[i % len(MARKERS)], mfc="none", ls="none",
                           label=c["label"]) for i, c in enumerate(cases)]
    for ax in (ax_mu, ax_phi):
        ax.legend(handles=ax.get_legend_handles_labels()[0] + zone_handles + case_handles, fontsize=7)
    return finish(fig, cases, path)
