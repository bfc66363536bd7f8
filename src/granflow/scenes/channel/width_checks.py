"""Debnath, Kesava Rao & Kumaran (2022) across channel widths: the narrowest and the widest W at one φ̄.

:func:`width_checks` adds to the channel's record the paper's statements about W (§3.1) that two widths
at the same average volume fraction :math:`\\bar\\phi` can test, each in the form the paper states it,
from the cases' :class:`~.analysis.ChannelAnalysis`:

* fig. 4(a): :math:`u_{slip}` and :math:`u_{max}` rise with W, by a factor of 3 from W = 60 to
  150 d_p: the ratio of the wider W's speed to the narrower's, within (1, 3] for widths within 60-150;
* §3.1: the slip length :math:`l_s = u_{slip}/(du_y/dx)_{wall}`, the gradient from eq. (3.1) as the paper
  takes it, grows :math:`\\propto W`: the ratio of :math:`l_s/W` of the wider W to the narrower's (paper 1),
  a comparison, as for δ0.95/W below, only when both widths are at least 100 d_p;
* fig. 7(a): σ_xx rises significantly with W (at every W): the ratio of the wider W's plateau (σ_xx beyond
  the wall bin) to the narrower's (paper > 1); and :math:`\\sigma_{xx}/W` "varies very little as W is varied
  for W > 60 d_p": the ratio of :math:`\\sigma_{xx}/W` of the wider W to the narrower's (paper 1), a comparison
  only when both widths exceed 60 d_p (the paper's widths: from 100 on), else a diagnostic;
* fig. 7(b): :math:`\\mu_{wall}` independent of W: the difference, wider minus narrower (paper 0);
* fig. 5(d): :math:`\\delta_{0.95}/W` independent of W for W ≥ 100 d_p, not at 60: the ratio is a
  comparison only when both widths are at least 100 d_p, else a diagnostic (the row's own kind).

The :math:`\\sqrt W` collapse of fig. 5(a-b) holds "for W ≥ 100 d_p (not at 60)": it needs two widths of at
least 100 d_p (:data:`SQRT_W_FROM`) and is then read as the exponent of :math:`u \\propto W^b` (paper 1/2).

Errors: each speed's correlation-aware error (the analysis' ``u_se``; δ0.95's from them), the shear rate's propagated
through the gradient operator (:mod:`.analysis.rheology`), σ_xx's plateau from its weighted line; the
systematic error varies the speeds' measurement choices (bin widths, where the wall bin is read, the window's
halves; both widths read alike, :func:`variant_ratios`), the gradient at the wall (eq. 3.1's against the
profile's own at the wall bin) and the plateau's start (2 and 3 d_p). Units: :math:`d_p`, :math:`\\sqrt{d_p/g}`, ρ_p = g = 1.
"""
from __future__ import annotations

import math

from granflow.validation import Check, systematic

from .analysis import ChannelAnalysis
from .more_checks import _ratio, delta_error, extreme_pairs, mu_wall_change, plateau_ratio

NAN = float("nan")
INF = float("inf")
#: the paper's factor of u_slip and u_max from W = 60 to 150 d_p (§3.1, fig. 4(a))
SPEED_FACTOR_60_150 = 3.0
#: the widths the paper's fig. 4(a) spans, d_p
PAPER_WIDTHS = (60.0, 150.0)
#: the narrowest width from which the paper finds u ∝ √W and δ0.95 ∝ W (§3.1, conclusions (ii)-(iv))
SQRT_W_FROM = 100.0

Q_USLIP_W = "u_slip at the wider W over at the narrower, same φ̄"
Q_UMAX_W = "u_max at the wider W over at the narrower, same φ̄"
Q_SLIP_LENGTH = "slip length l_s/W at the wider W over at the narrower, same φ̄"
Q_SXX_W = "σ_xx/W at the wider W over at the narrower, same φ̄"
Q_SXX_RISE = "σ_xx at the wider W over at the narrower, same φ̄"
Q_MU_WALL_W = "μ_wall at the wider W minus at the narrower, same φ̄"
Q_DELTA_W = "δ0.95/W at the wider W over at the narrower, same φ̄"
Q_SQRT_W = "u_max ∝ W^b across W ≥ 100 d_p, same φ̄: exponent b"
#: every quantity this module writes (paper_results.yaml's compared_by names them)
QUANTITIES = (Q_USLIP_W, Q_UMAX_W, Q_SLIP_LENGTH, Q_SXX_RISE, Q_SXX_W, Q_MU_WALL_W, Q_DELTA_W, Q_SQRT_W)


def width_pairs(cases: list) -> list[tuple]:
    """``(narrowest W, widest W)`` cases at each φ̄ that has two different W (cases without an analysed
    steady profile left out)."""
    return extreme_pairs(cases, "phi_mean", "W")


def slip_length(a: ChannelAnalysis, measured: bool = False) -> tuple[float, float]:
    """:math:`l_s = u_{slip}/(du_y/dx)_{wall}` and its error, the gradient at the wall from eq. (3.1) as the
    paper takes it, :math:`3(u_{max}-u_{slip})/\\delta_{0.95}`, or with ``measured`` the folded profile's
    gradient at the wall bin (:mod:`.analysis.rheology`); errors of the speeds (δ0.95's neglected)."""
    s = a.scales
    if measured:
        g, g_se = float(abs(a.rheo["gamma_dot"].iloc[0])), float(a.rheo["gamma_dot_se"].iloc[0])
    else:
        span = s.u_max - s.u_slip
        g = 3.0 * span / s.delta_095 if s.delta_095 > 0 else NAN
        g_se = g * math.hypot(s.u_max_se, s.u_slip_se) / span if span > 0 else NAN
    if not (g > 0 and math.isfinite(s.u_slip)):
        return NAN, NAN
    ls = s.u_slip / g
    return ls, ls * math.hypot(s.u_slip_se / s.u_slip, g_se / g)


def variant_ratios(wide, narrow, key: str) -> dict:
    """The headline ``key`` of ``wide`` over ``narrow``'s for each measurement choice both were read with
    (:func:`.measurement.headline_variants`: bin widths, where the wall bin is read, the window's halves); a
    reading with its own error stays ``(value, se)``, the ratio's from both."""
    out = {}
    for name in set(wide.variants.get(key, {})) & set(narrow.variants.get(key, {})):
        a, b = wide.variants[key][name], narrow.variants[key][name]
        if isinstance(a, tuple) and isinstance(b, tuple):
            out[name] = _ratio(a[0], a[1], b[0], b[1])
        else:
            out[name] = _ratio(a[0] if isinstance(a, tuple) else a, 0, b[0] if isinstance(b, tuple) else b, 0)[0]
    return dict(sorted(out.items()))


def width_checks(cases: list) -> list[Check]:
    """Rows comparing the narrowest and widest W at each φ̄ (:func:`width_pairs`)."""
    return [check for narrow, wide in width_pairs(cases) for check in _pair_checks(narrow, wide)]


def _pair_checks(narrow, wide) -> list[Check]:
    lo, hi = narrow.analysis, wide.analysis
    phi = float(narrow.record["parameters"]["phi_mean"])
    name = f"{narrow.name} vs {wide.name}"
    pair = f"W = {lo.W:g} and {hi.W:g} d_p at φ̄ = {phi:g}"
    in_span = PAPER_WIDTHS[0] <= lo.W and hi.W <= PAPER_WIDTHS[1]
    out = []
    for q, key, label in ((Q_USLIP_W, "u_slip", "u_slip (speed of the wall bin)"),
                          (Q_UMAX_W, "u_max", "u_max (the folded profile's largest speed)")):
        a, b = getattr(hi.scales, key), getattr(lo.scales, key)
        r, se = _ratio(a, getattr(hi.scales, f"{key}_se"), b, getattr(lo.scales, f"{key}_se"))
        syst, text = systematic(r, variant_ratios(wide, narrow, key))
        out.append(Check(q, f"> 1, at most {SPEED_FACTOR_60_150:g} within W = 60-150 d_p: u_slip and u_max rise "
                            f"by a factor of 3 from W = 60 to 150 d_p", "§3.1, fig. 4(a)", r, se, name,
                         (1.0, SPEED_FACTOR_60_150) if in_span else (1.0, INF), syst=syst, variants=text,
                         note=f"{label} at {pair}: {a:.4g} over {b:.4g}; error from each speed's correlation-aware "
                              f"error. The paper's factor 3 spans W = 60-150 d_p; between our widths it bounds the "
                              f"rise from above (√W alone would give {math.sqrt(hi.W / lo.W):.3g})"))

    wide_enough = lo.W >= SQRT_W_FROM
    kind = "comparison" if wide_enough else "diagnostic"
    why_wide = (f"Both widths are at least {SQRT_W_FROM:g} d_p: compared" if wide_enough else
                f"The paper's scalings (u ∝ √W, δ0.95 ∝ W, hence l_s ∝ W) hold from W = {SQRT_W_FROM:g} d_p, so a "
                f"pair with W = {lo.W:g} compares no number")
    (l_lo, l_lo_se), (l_hi, l_hi_se) = slip_length(lo), slip_length(hi)
    r, se = _ratio(l_hi / hi.W, l_hi_se / hi.W, l_lo / lo.W, l_lo_se / lo.W)
    alt = _ratio(slip_length(hi, True)[0] / hi.W, 0, slip_length(lo, True)[0] / lo.W, 0)[0]
    syst, text = systematic(r, {"du/dx measured at the wall bin (the folded profile's gradient)": alt})
    out.append(Check(Q_SLIP_LENGTH, "1 for W ≥ 100 d_p: the slip length u_slip/(du_y/dx)_wall grows ∝ W, the "
                                    "gradient from eq. (3.1)", "§3.1", r, se, name, (1.0, 1.0), kind=kind,
                     syst=syst, variants=text,
                     note=f"l_s = u_slip δ0.95/(3(u_max − u_slip)) (the wall gradient of eq. 3.1, as the paper takes "
                          f"it) = {l_hi:.3g} d_p at W = {hi.W:g}, {l_lo:.3g} d_p at {lo.W:g} (φ̄ = {phi:g}); l_s ∝ W "
                          f"gives 1, an l_s independent of W {lo.W / hi.W:.3g}. {why_wide}"))

    p = plateau_ratio(hi, lo, hi.W, lo.W)
    plateaus = (f"σ_xx's plateau (weighted line's mean beyond the wall bin) = {p['hi']:.4g} at W = {hi.W:g}, "
                f"{p['lo']:.4g} at {lo.W:g} ρ_p g d_p (φ̄ = {phi:g}); bins taken as independent, each with its "
                f"correlation-aware error")
    widths = hi.W / lo.W
    out.append(Check(Q_SXX_RISE, "> 1: 'a significant increase in σ_xx as W is increased'", "§3.1, fig. 7(a)",
                     p["ratio"] * widths, p["se"] * widths, name, (1.0, INF), syst=p["syst"] * widths,
                     variants=p["variants"], note=f"{plateaus}. σ_xx ∝ W gives {widths:.3g}"))
    sxx_kind = "comparison" if lo.W > PAPER_WIDTHS[0] else "diagnostic"
    out.append(Check(Q_SXX_W, "1: σ_xx/W varies very little with W for W > 60 d_p (σ_xx ∝ W)", "§3.1, fig. 7(a)",
                     p["ratio"], p["se"], name, (1.0, 1.0), kind=sxx_kind, syst=p["syst"], variants=p["variants"],
                     note=f"{plateaus}. " + ("Both widths exceed 60 d_p: compared" if sxx_kind == "comparison" else
                                             f"The paper's σ_xx/W holds 'for W > {PAPER_WIDTHS[0]:g} d_p', so a pair "
                                             f"with W = {lo.W:g} compares no number")))

    m = mu_wall_change(hi, lo)
    out.append(Check(Q_MU_WALL_W, "0: μ_wall independent of W", "§3.1, fig. 7(b)", m["change"], m["se"], name,
                     (0.0, 0.0), syst=m["syst"], variants=m["variants"],
                     note=f"μ_wall = τ_w/σ_xx (τ_w = g∫_0^(W/2) ρ_p φ dx, σ_xx's plateau) = {m['hi']:.4g} at W = "
                          f"{hi.W:g}, {m['lo']:.4g} at {lo.W:g} (φ̄ = {phi:g}); error from σ_xx's"))

    d_lo, d_hi = lo.scales.delta_095 / lo.W, hi.scales.delta_095 / hi.W
    r, se = _ratio(d_hi, delta_error(hi) / hi.W, d_lo, delta_error(lo) / lo.W)
    out.append(Check(Q_DELTA_W, "1 for W ≥ 100 d_p (δ0.95 ∝ W); not at W = 60", "§3.1, fig. 5(d); conclusions (iii)-(iv)",
                     r, se, name, (1.0, 1.0), kind=kind,
                     note=f"δ0.95/W = {d_hi:.4g} at W = {hi.W:g}, {d_lo:.4g} at {lo.W:g} (φ̄ = {phi:g}); each δ0.95's "
                          f"error linearised from the speeds' errors at the two bins it is interpolated between. "
                          f"{why_wide}"))

    if wide_enough:
        b = math.log(hi.scales.u_max / lo.scales.u_max) / math.log(hi.W / lo.W)
        b_se = math.hypot(hi.scales.u_max_se / hi.scales.u_max, lo.scales.u_max_se / lo.scales.u_max) / \
            math.log(hi.W / lo.W)
        out.append(Check(Q_SQRT_W, "1/2: u_max ∝ √W for W ≥ 100 d_p", "§3.1, fig. 5(a-b); conclusion (ii)", b, b_se,
                         name, (0.5, 0.5), note=f"two-point exponent of u_max between {pair}"))
    return out
