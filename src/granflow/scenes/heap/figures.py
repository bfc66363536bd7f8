"""Figures of the heap scene, after Fan, Umbanhowar, Ottino & Lueptow (2013).

One function per paper figure, ``fig_xxx(cases, path)``: it writes one PNG
(150 dpi) and returns the :class:`matplotlib.figure.Figure`.  A case is a dict

``label``
    legend text, e.g. ``"1.5 mm, 33 g/s"``;
``provenance``
    rung, W, T, k_n / t_c, N and status of the run; printed in the footer of
    every figure, after the case's label;
``bidisperse``
    whether the case has two species;
``scalars``
    ``alpha_deg, alpha_se, v_r, v_r_se, v_r_predicted, L, delta_mean,
    delta_over_d, tail_A, tail_k, q_star_exponent, q_star_prefactor, q0,
    t_start, t_end, surface_z0``; the fitted free surface is
    :math:`z = z_0 - x_{lab}\\tan\\alpha + v_r t` (``surface_z0``, ``alpha_deg``,
    ``v_r``, with ``t`` the simulation time);
``per_x``
    one row per streamwise bin of the moving rotated frame: ``x, x_over_L, q,
    u_s, gamma_bar, delta_exp, delta_lin, delta_cut, delta, delta_eq31, d_bar,
    q_star, n_profile`` (+ ``c_s``);
``profile``
    one row per (x, z) bin: ``x, z, phi, u, w, u_std, u_se, w_se, n, d_mean``;
``collapse``
    ``x, zt, ut, wt`` with :math:`\\tilde z = z/\\delta`, :math:`u/u_s`,
    :math:`\\tilde w = w/v_r'`;
``surface``, ``alpha_t``, ``rise_by_x``, ``phi_columns``, ``deposit``
    lab-frame free surface :math:`z_s(t, x_{lab})`, :math:`\\alpha(t)`,
    :math:`v_r(x_{lab})`, time-averaged :math:`\\phi(x_{lab}, z_{lab})` columns
    and the deposit's :math:`c_s(x_{lab})` (bidisperse only, else ``None``).

Units are SI in the data; figures show x in m, depths and δ in mm, q in cm²/s.
Figures 5-8 show the first case (the paper's 1.5 mm, 33 g/s run), figures 9-11
and 3 all cases.  Every figure copes with an empty ``cases`` list, missing
frames and all-NaN columns (the panel then says what is missing), and no fit
is attempted on fewer than two finite points.  The layout, colours and the
provenance footer are those of the channel figures (:mod:`granflow.plotting`).
"""
from __future__ import annotations

import numpy as np
import pandas as pd
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.ticker import LogFormatter, StrMethodFormatter

from granflow.plotting import (
    MARKERS,
    float_column,
    cycle_colour,
    add_colourbar,
    finite,
    frame,
    case_label,
    new_figure,
    plot,
    pm,
    positive_mask,
    say,
    scalar,
    unavailable,
)
from granflow.plotting import finish_cases as _finish

from .figure_style import case_style, no_case
from .figures_surface import fig04b_surface_shape

#: Volume-fraction cutoff that locates the free surface (paper §3.1).
PHI_C = 0.35
#: The paper's exponential tail u/u_s = 2.4 exp(3.3 z/δ) and its fit range (figure 7b).
PAPER_TAIL_A, PAPER_TAIL_K = 2.4, 3.3
TAIL_RANGE = (-1.6, -0.7)
#: k = δ/z_0 of the exponential streamwise profile used in eq. (3.6).
K_EXP = 2.3
#: Figure 11 uses x/L >= 0.2 (bouncing near the feed zone) and finds a ≈ 0.22.
X_OVER_L_MIN = 0.2
PAPER_QSTAR_EXPONENT = 0.22
MM = 1e3    # m -> mm
CM2 = 1e4   # m^2/s -> cm^2/s


def _pick(values, n: int) -> np.ndarray:
    """``n`` distinct finite values at the centres of ``n`` equal quantile slices.

    Centred picks stay away from the ends of the range (feed zone, end wall).
    """
    v = np.unique(np.asarray(values, dtype=float))
    v = v[np.isfinite(v)]
    if len(v) <= n:
        return v
    return np.unique(v[np.floor((np.arange(n) + 0.5) / n * len(v)).astype(int)])


def _line_fit(x, y):
    """Least-squares line ``y = slope x + intercept``.

    Returns ``(slope, intercept, slope_se)``, or ``None`` with fewer than two
    finite points or no spread in ``x``; ``slope_se`` is NaN with two points.

    .. math:: \\sigma_{slope}^2 = \\frac{\\sum r_i^2/(n-2)}{\\sum (x_i-\\bar x)^2}
    """
    x, y = finite(x, y)
    if len(x) < 2 or np.ptp(x) == 0:
        return None
    slope, intercept = np.polyfit(x, y, 1)
    n = len(x)
    sxx = np.sum((x - x.mean()) ** 2)
    resid = y - (slope * x + intercept)
    se = float(np.sqrt(np.sum(resid ** 2) / (n - 2) / sxx)) if n > 2 else np.nan
    return float(slope), float(intercept), se


def _x_over_L(case: dict, x: np.ndarray) -> tuple[np.ndarray, str]:
    L = scalar(case, "L")
    if np.isfinite(L) and L > 0:
        return x / L, r"$x/L$"
    return x, r"$x$ [m]"


def _colour_by_x(ax, case: dict, df: pd.DataFrame, y: str, positive: bool = False):
    """Scatter ``y`` against ``zt`` coloured by streamwise position.

    Returns ``(drawn, mappable, colour_label)``; ``mappable`` is None when
    nothing was drawn or no x is known (then one colour is used).
    """
    zt, val, x = float_column(df, "zt"), float_column(df, y), float_column(df, "x")
    ok = np.isfinite(zt) & np.isfinite(val)
    if positive:
        ok &= positive_mask(val)
    if not ok.any():
        return False, None, ""
    c, label = _x_over_L(case, x[ok])
    if np.isfinite(c).any():
        return True, ax.scatter(zt[ok], val[ok], c=c, cmap="viridis", s=6, lw=0), label
    ax.scatter(zt[ok], val[ok], color=cycle_colour(0), s=6, lw=0)
    return True, None, ""


# --------------------------------------------------------------------------- figures
def fig03_segregation(cases: list[dict], path) -> Figure:
    """Paper figure 3(c): small-particle volume concentration of the deposit.

    :math:`c_s = f_s/(f_s + f_l)` against :math:`x_{lab}`, one series per
    bidisperse case; monodisperse cases have no such curve.
    """
    fig, axes = new_figure(1, 1, (6.5, 4.6))
    ax = axes[0, 0]
    ax.set(xlabel=r"$x_{lab}$ [m]", ylabel=r"$c_s$", title="small-particle concentration in the deposit")
    if not cases:
        no_case(axes)
        return _finish(fig, cases, path)
    bi = [(i, c) for i, c in enumerate(cases) if c.get("bidisperse")]
    drawn = False
    for i, case in bi:
        dep = frame(case, "deposit")
        drawn |= plot(ax, float_column(dep, "x_lab"), float_column(dep, "c_s"), ms=4, lw=0.8, label=case_label(case),
                       **case_style(i, case))
    if not bi:
        say(ax, "no bidisperse case:\nc_s(x) is not defined for one species", fontsize=11)
    elif not drawn:
        unavailable(ax, "deposit c_s")
    else:
        ax.set_ylim(0, 1)
        ax.legend(fontsize=8)
    return _finish(fig, cases, path)


def fig04_surface(cases: list[dict], path) -> Figure:
    """Paper figure 4: free surface, dynamic angle of repose and rise velocity (first case).

    (a) time-averaged :math:`\\phi(z_{lab})` at four :math:`x_{lab}` with the
    cutoff :math:`\\phi_c = 0.35`; (b) :math:`z_s(x_{lab})` at the start, middle
    and end of the averaging window with a line fitted at each time (solid) and
    the global fit :math:`z_0 - x_{lab}\\tan\\alpha + v_r t` (dashed), inset
    :math:`\\alpha(t)`; (c) :math:`z_s(t)` at three :math:`x_{lab}` with linear
    fits, legend giving the measured :math:`v_r` and the one predicted by mass
    conservation.
    """
    fig, axes = new_figure(1, 3, (15, 4.8))
    ax_phi, ax_s, ax_t = axes[0]
    inset = ax_s.inset_axes([0.17, 0.1, 0.33, 0.3])
    ax_phi.set(xlabel=r"$z_{lab}$ [m]", ylabel=r"$\phi$", title="(a) volume fraction columns")
    ax_s.set(xlabel=r"$x_{lab}$ [m]", ylabel=r"$z_s$ [m]", title="(b) free surface")
    ax_t.set(xlabel=r"$t$ [s]", ylabel=r"$z_s$ [m]", title="(c) rise of the free surface")
    inset.set_xlabel(r"$t$ [s]", fontsize=7)
    inset.set_ylabel(r"$\alpha$ [°]", fontsize=7)
    inset.tick_params(labelsize=6)
    if not cases:
        no_case([ax_phi, ax_s, ax_t])
        return _finish(fig, cases, path)
    case = cases[0]

    # (a) phi columns
    cols = frame(case, "phi_columns")
    xl, zl, phi = float_column(cols, "x_lab"), float_column(cols, "z_lab"), float_column(cols, "phi")
    drawn = False
    for j, xv in enumerate(_pick(xl, 4)):
        sel = xl == xv
        drawn |= plot(ax_phi, zl[sel], phi[sel], color=cycle_colour(j), lw=1, marker=".", ms=3,
                       label=f"$x_{{lab}}$ = {xv:.3f} m")
    ax_phi.axhline(PHI_C, color="black", ls="--", lw=0.8, label=r"$\phi_c$ = 0.35 (free surface)")
    if not drawn:
        unavailable(ax_phi, "φ columns")
    ax_phi.legend(fontsize=7)

    # (b) free surface at three times, inset alpha(t)
    surf = frame(case, "surface")
    t, xs, zs = float_column(surf, "t"), float_column(surf, "x_lab"), float_column(surf, "z_s")
    times = np.unique(t[np.isfinite(t)])
    z0, alpha, v_r = (scalar(case, k) for k in ("surface_z0", "alpha_deg", "v_r"))
    chosen = []
    if len(times):
        t0, t1 = scalar(case, "t_start"), scalar(case, "t_end")
        t0 = t0 if np.isfinite(t0) else times[0]
        t1 = t1 if np.isfinite(t1) else times[-1]
        chosen = list(dict.fromkeys(times[np.argmin(np.abs(times - tt))] for tt in (t0, 0.5 * (t0 + t1), t1)))
    drawn = False
    for j, tv in enumerate(chosen):
        sel = t == tv
        xj, zj = finite(xs[sel], zs[sel])
        if not len(xj):
            continue
        fit = _line_fit(xj, zj)
        ang = f", α = {np.degrees(np.arctan(-fit[0])):.2f}°" if fit else ""
        ax_s.plot(xj, zj, "o", color=cycle_colour(j), ms=3, mfc="none", label=f"t = {tv:.2f} s{ang}")
        if fit:
            ax_s.plot(xj, fit[0] * xj + fit[1], "-", color=cycle_colour(j), lw=1)
        if np.isfinite(z0) and np.isfinite(alpha) and np.isfinite(v_r):
            ax_s.plot(xj, z0 - xj * np.tan(np.radians(alpha)) + v_r * tv, "--", color="black", lw=0.8,
                      label=r"global fit $z_0 - x_{lab}\tan\alpha + v_r t$" if not drawn else None)
        drawn = True
    if drawn:
        ax_s.legend(fontsize=7, loc="upper right")
    else:
        unavailable(ax_s, "free surface")
    ax_s.set_title(f"(b) free surface, α = {pm(alpha, scalar(case, 'alpha_se'), '.2f', '°')}")
    at = frame(case, "alpha_t")
    if plot(inset, float_column(at, "t"), float_column(at, "alpha_deg"), color="0.2", marker="o", ms=2, lw=0.6):
        if np.isfinite(alpha):
            inset.axhline(alpha, color="red", lw=0.8, ls=":")
    else:
        say(inset, "α(t) not available", fontsize=7)

    # (c) z_s(t) at three columns
    drawn = False
    for j, xv in enumerate(_pick(xs, 3)):
        sel = xs == xv
        tj, zj = finite(t[sel], zs[sel])
        if not len(tj):
            continue
        fit = _line_fit(tj, zj)
        slope = f": slope {fit[0] * MM:.3g} mm/s" if fit else ""
        ax_t.plot(tj, zj, "o", color=cycle_colour(j), ms=3, mfc="none", label=f"$x_{{lab}}$ = {xv:.3f} m{slope}")
        if fit:
            ax_t.plot(tj, fit[0] * tj + fit[1], "-", color=cycle_colour(j), lw=1)
        drawn = True
    if not drawn:
        unavailable(ax_t, "z_s(t)")
    measured = pm(v_r * MM, scalar(case, "v_r_se") * MM, unit="mm/s")
    predicted = pm(scalar(case, "v_r_predicted") * MM, np.nan, unit="mm/s")
    vr_txt = [Line2D([], [], ls="none", label=f"$v_r$ measured = {measured}"),
              Line2D([], [], ls="none", label=f"$v_r$ predicted (mass conservation) = {predicted}")]
    ax_t.margins(y=0.45)  # headroom for the legend above the highest column
    ax_t.legend(handles=ax_t.get_legend_handles_labels()[0] + vr_txt, fontsize=7, loc="upper left")
    return _finish(fig, cases, path)


def fig05_velocity(cases: list[dict], path) -> Figure:
    """Paper figure 5: (a) :math:`u(z)` at four x, (b) shear rate :math:`\\partial u/\\partial z` (first case).

    Error bars in (a) are the standard errors ``u_se``; the shear rate is the
    finite difference :func:`numpy.gradient` of the finite points of each column.
    """
    fig, axes = new_figure(1, 2, (11, 4.6))
    ax_u, ax_g = axes[0]
    ax_u.set(xlabel=r"$z$ [mm] (0 at the free surface)", ylabel=r"$u$ [m/s]", title="(a) streamwise velocity")
    ax_g.set(xlabel=r"$z$ [mm] (0 at the free surface)", ylabel=r"$\dot\gamma = \partial u/\partial z$ [1/s]",
             title="(b) shear rate")
    if not cases:
        no_case(axes)
        return _finish(fig, cases, path)
    case = cases[0]
    prof = frame(case, "profile")
    x, z, u, u_se = (float_column(prof, k) for k in ("x", "z", "u", "u_se"))
    drawn = False
    for j, xv in enumerate(_pick(x, 4)):
        sel = x == xv
        zj, uj, sej = finite(z[sel], u[sel], np.nan_to_num(u_se[sel]))
        if not len(zj):
            continue
        kw = dict(color=cycle_colour(j), marker=MARKERS[j % len(MARKERS)], ms=3, lw=0.8, label=f"x = {xv:.3f} m")
        ax_u.errorbar(zj * MM, uj, yerr=sej, capsize=1.5, **kw)
        if len(zj) >= 2:
            ax_g.plot(zj * MM, np.gradient(uj, zj), **kw)
        drawn = True
    if drawn:
        ax_u.legend(fontsize=8)
        ax_g.legend(fontsize=8)
    else:
        unavailable(ax_u, "velocity profile")
        unavailable(ax_g, "shear rate")
    return _finish(fig, cases, path)


def fig06_streamwise(cases: list[dict], path) -> Figure:
    """Paper figure 6: streamwise variation of the kinematics of the first case.

    (a) :math:`q(x)`, (b) :math:`u_s(x)`, (c) :math:`\\bar{\\dot\\gamma}(x)`, (d) :math:`\\delta(x)`.
    (a) carries the mass-conservation line :math:`q_0(1-x/L)`;
    (d) shows δ from the exponential fit (× 2.3), the linear extrapolation and
    the 0.1 :math:`u_s` cutoff, and eq. (3.1) of Khakhar et al. (2001),
    :math:`\\delta = [\\delta_L^2 + 2 v_r (L-x)/\\bar{\\dot\\gamma}]^{1/2}`, as a solid curve.
    """
    fig, axes = new_figure(2, 2, (11, 8))
    (ax_q, ax_us), (ax_g, ax_d) = axes
    for ax in axes.ravel():
        ax.set_xlabel(r"$x$ [m]")
    ax_q.set(ylabel=r"$q$ [cm²/s]", title="(a) local 2D flow rate")
    ax_us.set(ylabel=r"$u_s$ [m/s]", title="(b) surface velocity")
    ax_g.set(ylabel=r"$\bar{\dot\gamma}$ [1/s]", title="(c) flowing-layer mean shear rate")
    ax_d.set(ylabel=r"$\delta$ [mm]", title="(d) flowing-layer thickness")
    if not cases:
        no_case(axes)
        return _finish(fig, cases, path)
    case = cases[0]
    px = frame(case, "per_x")
    x = float_column(px, "x")
    kw = dict(color=cycle_colour(0), marker="o", ms=3.5, lw=0.8)
    for ax, col, scale, what in ((ax_q, "q", CM2, "q"), (ax_us, "u_s", 1.0, "u_s"),
                                 (ax_g, "gamma_bar", 1.0, "mean shear rate")):
        if not plot(ax, x, float_column(px, col) * scale, label=case_label(case), **kw):
            unavailable(ax, what)
    q0, L = scalar(case, "q0"), scalar(case, "L")
    if np.isfinite(q0) and np.isfinite(L) and L > 0:
        grid = np.linspace(0, L, 50)
        ax_q.plot(grid, q0 * (1 - grid / L) * CM2, "k--", lw=1, label=r"$q_0(1-x/L)$")
    if np.isfinite(L):
        for ax in axes.ravel():
            ax.axvline(L, color="0.5", ls=":", lw=0.8)
    drawn = False
    for col, marker, colour, label in (("delta_exp", "o", "C0", r"exponential fit, $2.3 z_0$"),
                                       ("delta_lin", "^", "C1", "linear extrapolation"),
                                       ("delta_cut", "s", "C2", r"cutoff $0.1 u_s$")):
        drawn |= plot(ax_d, x, float_column(px, col) * MM, color=colour, marker=marker, mfc="none", ms=4,
                       ls="none", label=label)
    drawn |= plot(ax_d, x, float_column(px, "delta_eq31") * MM, color="black", lw=1.5,
                   label="eq. (3.1), Khakhar et al. (2001)")
    if not drawn:
        unavailable(ax_d, "δ")
    for ax in axes.ravel():
        if ax.get_legend_handles_labels()[0]:
            ax.legend(fontsize=7)
    return _finish(fig, cases, path)


def fig07_collapse(cases: list[dict], path) -> Figure:
    """Paper figure 7: :math:`u/u_s` against :math:`z/\\delta` at all x of the first case.

    (a) linear axes, (b) semilog with our tail fit :math:`u/u_s = A e^{k z/\\delta}`
    over :math:`-1.6 < z/\\delta < -0.7` (``tail_A``, ``tail_k``) and the paper's
    :math:`2.4 e^{3.3 z/\\delta}` (thin dashed).  Colour is the streamwise position.
    """
    fig, axes = new_figure(1, 2, (11, 4.6))
    ax_lin, ax_log = axes[0]
    for ax in (ax_lin, ax_log):
        ax.set(xlabel=r"$z/\delta$", ylabel=r"$u/u_s$")
    ax_lin.set_title("(a) scaled streamwise velocity")
    ax_log.set_title("(b) semilog")
    ax_log.set_yscale("log")
    if not cases:
        no_case(axes)
        return _finish(fig, cases, path)
    case = cases[0]
    col = frame(case, "collapse")
    if not _colour_by_x(ax_lin, case, col, "ut")[0]:
        unavailable(ax_lin, "u/u_s")
    drawn, mappable, colour_label = _colour_by_x(ax_log, case, col, "ut", positive=True)
    if not drawn:
        unavailable(ax_log, "positive u/u_s")
    zz = np.linspace(*TAIL_RANGE, 50)
    A, k = scalar(case, "tail_A"), scalar(case, "tail_k")
    if np.isfinite(A) and np.isfinite(k) and A > 0:
        ax_log.plot(zz, A * np.exp(k * zz), "k-", lw=1.5,
                    label=f"fit: {A:.2f} exp({k:.2f} z/δ), −1.6 < z/δ < −0.7")
    ax_log.plot(zz, PAPER_TAIL_A * np.exp(PAPER_TAIL_K * zz), "r--", lw=0.8,
                label="paper (Fan et al. 2013): 2.4 exp(3.3 z/δ)")
    ax_log.legend(fontsize=7, loc="lower right")
    add_colourbar(fig, ax_log, mappable, colour_label)
    return _finish(fig, cases, path, right_in=0.9)


def fig08_normal(cases: list[dict], path) -> Figure:
    """Paper figure 8: scaled normal velocity :math:`w/v_r'` against :math:`z/\\delta` (first case).

    With eq. (3.5), :math:`\\tilde w = 2\\tilde z + \\tilde z^2` (linear
    profile, dashed) and eq. (3.6),
    :math:`\\tilde w = (e^{k\\tilde z} - 1)/(1 - e^{-k})` with k = 2.3
    (exponential profile, solid).
    """
    fig, axes = new_figure(1, 1, (7, 4.8))
    ax = axes[0, 0]
    ax.set(xlabel=r"$\tilde z = z/\delta$", ylabel=r"$\tilde w = w/v_r'$", title="scaled normal velocity")
    if not cases:
        no_case(axes)
        return _finish(fig, cases, path)
    case = cases[0]
    drawn, mappable, colour_label = _colour_by_x(ax, case, frame(case, "collapse"), "wt")
    if not drawn:
        unavailable(ax, "w/v_r'")
    zz = np.linspace(-1.0, 0.0, 100)
    ax.plot(zz, 2 * zz + zz ** 2, "k--", lw=1.2, label=r"eq. (3.5), linear $u$: $2\tilde z + \tilde z^2$")
    ax.plot(zz, (np.exp(K_EXP * zz) - 1) / (1 - np.exp(-K_EXP)), "k-", lw=1.2,
            label=r"eq. (3.6), exponential $u$, k = 2.3")
    ax.legend(fontsize=7)
    add_colourbar(fig, ax, mappable, colour_label)
    return _finish(fig, cases, path, right_in=0.9)


def fig09_all_cases(cases: list[dict], path) -> Figure:
    """Paper figure 9: :math:`u/u_s` against :math:`z/\\delta` for every case, (a) linear, (b) semilog."""
    fig, axes = new_figure(1, 2, (11, 4.6))
    ax_lin, ax_log = axes[0]
    for ax in (ax_lin, ax_log):
        ax.set(xlabel=r"$z/\delta$", ylabel=r"$u/u_s$")
    ax_lin.set_title("(a) all cases")
    ax_log.set_title("(b) semilog")
    ax_log.set_yscale("log")
    if not cases:
        no_case(axes)
        return _finish(fig, cases, path)
    drawn = False
    for i, case in enumerate(cases):
        col = frame(case, "collapse")
        zt, ut = float_column(col, "zt"), float_column(col, "ut")
        kw = dict(ls="none", ms=2.5, alpha=0.7, label=case_label(case), **case_style(i, case))
        drawn |= plot(ax_lin, zt, ut, **kw)
        pos = positive_mask(ut)
        plot(ax_log, zt[pos], ut[pos], **kw)
    if drawn:
        ax_lin.legend(fontsize=7, markerscale=2)
    else:
        unavailable(ax_lin, "u/u_s")
        unavailable(ax_log, "u/u_s")
    return _finish(fig, cases, path)


def fig10_scaled(cases: list[dict], path) -> Figure:
    """Paper figure 10: scaled local kinematics against :math:`x/L` for all cases.

    (a) :math:`u_s\\delta/(2q_0)`, (b) :math:`\\bar{\\dot\\gamma}\\delta^2/(2q_0)`,
    (c) δ, (d) :math:`\\delta/\\bar d`.  The dashed line :math:`1 - x/L` in (a)
    and (b) is what a linear profile with :math:`q = q_0(1-x/L)` gives
    (:math:`u_s = 2q/\\delta`, :math:`\\bar{\\dot\\gamma} = u_s/\\delta`).
    Filled symbols bidisperse, open monodisperse.
    """
    fig, axes = new_figure(2, 2, (11, 8))
    (ax_u, ax_g), (ax_d, ax_dd) = axes
    for ax in axes.ravel():
        ax.set_xlabel(r"$x/L$")
    ax_u.set(ylabel=r"$u_s\delta/(2q_0)$", title="(a) scaled surface velocity")
    ax_g.set(ylabel=r"$\bar{\dot\gamma}\delta^2/(2q_0)$", title="(b) scaled mean shear rate")
    ax_d.set(ylabel=r"$\delta$ [mm]", title="(c) flowing-layer thickness")
    ax_dd.set(ylabel=r"$\delta/\bar d$", title="(d) thickness in mean diameters")
    if not cases:
        no_case(axes)
        return _finish(fig, cases, path)
    drawn = dict.fromkeys(("u", "g", "d", "dd"), False)
    for i, case in enumerate(cases):
        px = frame(case, "per_x")
        xl, us, gb, delta, d_bar = (float_column(px, k) for k in ("x_over_L", "u_s", "gamma_bar", "delta", "d_bar"))
        q0 = scalar(case, "q0")
        kw = dict(ms=4, lw=0.8, label=case_label(case), **case_style(i, case))
        drawn["u"] |= plot(ax_u, xl, us * delta / (2 * q0), **kw)
        drawn["g"] |= plot(ax_g, xl, gb * delta ** 2 / (2 * q0), **kw)
        drawn["d"] |= plot(ax_d, xl, delta * MM, **kw)
        drawn["dd"] |= plot(ax_dd, xl, delta / d_bar, **kw)
    grid = np.linspace(0, 1, 20)
    for ax in (ax_u, ax_g):
        ax.plot(grid, 1 - grid, "k--", lw=1, label=r"$1 - x/L$ (linear profile)")
    for key, ax in (("u", ax_u), ("g", ax_g), ("d", ax_d), ("dd", ax_dd)):
        if not drawn[key]:
            unavailable(ax, ax.get_ylabel())
    ax_u.legend(fontsize=7)
    return _finish(fig, cases, path)


def fig11_qstar(cases: list[dict], path) -> Figure:
    """Paper figure 11: :math:`\\delta/\\bar d` against :math:`q^*` (log-log) for :math:`x/L \\ge 0.2`.

    :math:`q^* = q/(\\bar d\\sqrt{g\\bar d})` (the caption's axis reads
    :math:`2q/(g^{1/2}\\bar d^{3/2})`; a constant factor does not change the
    exponent).  The power law :math:`\\delta/\\bar d = c\\,(q^*)^a` is fitted
    here by least squares on the logarithms of all plotted points of all cases;
    its exponent (± standard error) is in the legend, next to a slope-0.22 guide
    (the paper's value) through the centroid of the points.
    """
    fig, axes = new_figure(1, 1, (7, 5))
    ax = axes[0, 0]
    ax.set(xlabel=r"$q^* = q/(\bar d\sqrt{g\bar d})$", ylabel=r"$\delta/\bar d$",
           title=r"flowing-layer thickness against local flow rate ($x/L \geq 0.2$)")
    ax.set_xscale("log")
    ax.set_yscale("log")
    for axis in (ax.xaxis, ax.yaxis):  # plain numbers: δ/d̄ spans less than a decade
        axis.set_major_formatter(StrMethodFormatter("{x:g}"))
        axis.set_minor_formatter(LogFormatter(minor_thresholds=(2, 0.5)))
    if not cases:
        no_case(axes)
        return _finish(fig, cases, path)
    qs, ds = [], []
    for i, case in enumerate(cases):
        px = frame(case, "per_x")
        xl, q_star = float_column(px, "x_over_L"), float_column(px, "q_star")
        ratio = float_column(px, "delta") / float_column(px, "d_bar")
        sel = (xl >= X_OVER_L_MIN) & positive_mask(q_star) & positive_mask(ratio)
        if sel.any():
            ax.plot(q_star[sel], ratio[sel], ls="none", ms=4, label=case_label(case), **case_style(i, case))
            qs.append(q_star[sel])
            ds.append(ratio[sel])
    fit = _line_fit(np.log(np.concatenate(qs)), np.log(np.concatenate(ds))) if qs else None
    if fit:
        a, log_c, a_se = fit
        lq = np.log(np.concatenate(qs))
        grid = np.exp(np.linspace(lq.min(), lq.max(), 50))
        ax.plot(grid, np.exp(log_c) * grid ** a, "k-", lw=1.2,
                label=f"fit over all cases: a = {a:.3f}" + (f" ± {a_se:.3f}" if np.isfinite(a_se) else ""))
        lx, ly = lq.mean(), np.log(np.concatenate(ds)).mean()
        ax.plot(grid, np.exp(ly + PAPER_QSTAR_EXPONENT * (np.log(grid) - lx)), ":", color="0.4", lw=1,
                label="paper (Fan et al. 2013): a ≈ 0.22")
    elif not qs:
        unavailable(ax, "δ/d̄ and q*")
    else:
        ax.text(0.5, 0.1, "fewer than two distinct points: no fit", transform=ax.transAxes,
                ha="center", color="0.4")
    if qs:
        ax.legend(fontsize=7)
    return _finish(fig, cases, path)


#: Figure name -> function, in the paper's order.
HEAP_FIGURES = {
    "fig03_segregation": fig03_segregation,
    "fig04_surface": fig04_surface,
    "fig04b_surface_shape": fig04b_surface_shape,
    "fig05_velocity": fig05_velocity,
    "fig06_streamwise": fig06_streamwise,
    "fig07_collapse": fig07_collapse,
    "fig08_normal": fig08_normal,
    "fig09_all_cases": fig09_all_cases,
    "fig10_scaled": fig10_scaled,
    "fig11_qstar": fig11_qstar,
}
