"""The shear rate's shape in the zones of Debnath, Kesava Rao & Kumaran (2022), §3.2 and fig. 8(b), per case.

* "in the dense shearing zone, the error bars are smaller than the mean values, and the profiles are continuous,
  even when the shear rate is 4–5 orders of magnitude smaller than that at the wall" (§3.2; conclusion (vii):
  "3–4 orders"): log10 of the wall bin's shear rate over that of the dense zone's last bin before φ reaches 0.63;
* "in the dense shearing zone, the friction coefficient decreases approximately linearly in log I down to the
  lowest I, where (B3) tends to μ_s" (fig. 11a; conclusion x): μ against log10 I over the dense zone's bins, the
  straight line's slope (paper > 0: μ falls as I falls) and, from a weighted quadratic, the relative change κ of
  the slope from the zone's highest to its lowest I, (b_hi − b_lo)/b̄ (paper 0: about linear; B3, flattening at
  μ_s, gives about 2), a diagnostic while its error cannot tell the two apart;
* "for φ̄ = 0.62 there is no loose shearing zone" (§3.2; the blue lines of fig. 8 at φ̄ = 0.59-0.61): the loose
  zone's width, from the wall layer's 2 d_p to where φ reaches φ_ad (0 where it reaches it inside the layer);
  paper 0 from φ̄ = 0.62 on, > 0 below;
* "the shear rate profiles have negative curvature in the dense shearing zone, ... positive curvature in the loose
  shearing zone": the curvature of ln|du/dx| against x by a weighted quadratic over each zone's bins (the dense
  zone from φ = φ_ad to φ = 0.63, the loose from the wall layer's 2 d_p to φ_ad). The paper's fig. 8(b) spans
  "4–5 orders of magnitude" of shear rate, so its curvature is read on the logarithm; on a linear axis a shear rate
  that falls off toward zero curves upward in both zones. A zone with fewer than 4 bins gives no number.

Where the shear rate becomes zero (the plug edge of :func:`.analysis.rheology.flow_zones`) is no comparison of
its own: read against the plug's frozen scatter (3 × the rms shear rate of the channel's central 30 %), it moves
by 5–20 d_p as that region's start moves from 0.25 to 0.45 W, one outlying bin in the plug enough to move it.

The zones' edges and the fits' ranges are measurement choices: each is moved and the largest shift is the
systematic error (:func:`granflow.validation.systematic`). Units d_p, √(d_p/g).
"""
from __future__ import annotations

import math

import numpy as np

from granflow.validation import Check, systematic

from .analysis import ChannelAnalysis
from .more_checks import INDEPENDENT, WALL_LAYER, weighted_polyfit

NAN = float("nan")
Q_CURV_DENSE = "ln|du/dx| in the dense shearing zone: curvature (per d_p²)"
Q_CURV_LOOSE = "ln|du/dx| in the loose shearing zone: curvature (per d_p²)"
Q_ORDERS = "du/dx in the wall bin over at the dense zone's inner edge (φ = 0.63): orders of magnitude (log10)"
#: §3.2: the dense zone's shear rate "4–5 orders of magnitude smaller than that at the wall" at its lowest;
#: conclusion (vii): "3–4 orders"
SHEAR_ORDERS = (3.0, 5.0)
Q_MU_SLOPE = "μ against log10 I in the dense shearing zone: slope dμ/dlog10 I"
Q_MU_KAPPA = "μ against log10 I in the dense shearing zone: relative change κ of the slope across it"
#: a bin whose I is known to worse than this relative error is left out of μ(log I) (its log I is not placed)
MAX_I_REL_ERROR = 0.5
Q_LOOSE_WIDTH = "loose shearing zone's width (φ < φ_ad beyond the 2 d_p wall layer), d_p"
#: §3.2: "for φ̄ = 0.62 there is no loose shearing zone": from this φ̄ on the paper's width is 0, below it > 0
PHI_NO_LOOSE = 0.62
#: every quantity this module writes (paper_results.yaml's compared_by names them)
QUANTITIES = (Q_CURV_DENSE, Q_CURV_LOOSE, Q_ORDERS, Q_MU_SLOPE, Q_MU_KAPPA, Q_LOOSE_WIDTH)
#: fewest bins a zone's quadratic is fitted over (one degree of freedom beyond the three terms)
MIN_BINS = 4
SOURCE_CURV = "§3.2, fig. 8(b)"


def log_shear_curvature(a: ChannelAnalysis, x_from: float, x_to: float) -> dict:
    """Weighted quadratic of :math:`\\ln|\\dot\\gamma|` in x over the folded bins with ``x_from`` ≤ x < ``x_to``:
    its x² coefficient (the curvature's half) times 2, its error (χ²-scaled), ``n``; NaN with fewer than
    :data:`MIN_BINS` bins."""
    x = a.folded["x"].to_numpy(float)
    gd, gd_se = np.abs(a.rheo["gamma_dot"].to_numpy(float)), a.rheo["gamma_dot_se"].to_numpy(float)
    keep = (x >= x_from) & (x < x_to) & np.isfinite(gd) & (gd > 0) & np.isfinite(gd_se) & (gd_se > 0)
    if keep.sum() < MIN_BINS:
        return {"curvature": NAN, "se": NAN, "n": int(keep.sum()), "chi2_nu": NAN}
    coef, cov, chi2_nu, nu = weighted_polyfit(x[keep], np.log(gd[keep]), gd_se[keep] / gd[keep], 2)
    return {"curvature": float(2 * coef[2]), "se": float(2 * math.sqrt(cov[2, 2])), "n": int(keep.sum()),
            "chi2_nu": chi2_nu}


def _curvature_check(case, quantity: str, x_from: float, x_to: float, sign: str, variants: dict) -> Check:
    a = case.analysis
    fit = log_shear_curvature(a, x_from, x_to)
    var = {k: log_shear_curvature(a, lo, hi)["curvature"] for k, (lo, hi) in variants.items()}
    syst, text = systematic(fit["curvature"], var)
    zone = "dense" if sign == "< 0" else "loose"
    rng = (-math.inf, 0.0) if sign == "< 0" else (0.0, math.inf)
    note = (f"weighted quadratic of ln|du/dx| in x over the {fit['n']} folded bins with {x_from:.3g} ≤ x < "
            f"{x_to:.3g} d_p (the {zone} zone), χ²/ν = {fit['chi2_nu']:.2g} (errors scaled by it when above 1); "
            f"{INDEPENDENT}; the curvature is read on the logarithm, as fig. 8(b) spans 4–5 orders of magnitude"
            if math.isfinite(fit["curvature"]) else
            f"the {zone} zone ({x_from:.3g} ≤ x < {x_to:.3g} d_p) holds {fit['n']} bins with a shear rate, fewer "
            f"than {MIN_BINS}: no curvature")
    return Check(quantity, f"{sign} ({zone} zone: {'negative' if sign == '< 0' else 'positive'} curvature, an "
                           f"inflection at φ_ad)", SOURCE_CURV, fit["curvature"], fit["se"], case.name, rng,
                 syst=syst, variants=text, note=note)


def shear_orders(a: ChannelAnalysis, x_edge: float, shift: int = 0) -> dict:
    """log10 of |du/dx| in the wall bin over |du/dx| in the last bin before ``x_edge`` (moved ``shift`` bins), its
    error (the two bins' errors independent), and that bin's x."""
    x = a.folded["x"].to_numpy(float)
    gd, se = np.abs(a.rheo["gamma_dot"].to_numpy(float)), a.rheo["gamma_dot_se"].to_numpy(float)
    inner = np.flatnonzero(x < x_edge)
    k = int(inner[-1]) + shift if len(inner) else -1
    if not (0 < k < len(x)) or not (gd[k] > 0 and gd[0] > 0):
        return {"orders": NAN, "se": NAN, "x": NAN}
    return {"orders": math.log10(gd[0] / gd[k]), "se": math.hypot(se[0] / gd[0], se[k] / gd[k]) / math.log(10.0),
            "x": float(x[k])}


def _orders_check(case) -> Check:
    a = case.analysis
    edge = a.zones.x_plug_phi063
    r = shear_orders(a, edge)
    var = {"one bin further out": shear_orders(a, edge, -1)["orders"],
           "one bin further in": shear_orders(a, edge, +1)["orders"]}
    syst, text = systematic(r["orders"], var)
    return Check(Q_ORDERS, "3–5 (the dense zone's shear rate 3–4, at its lowest 4–5, orders below the wall's)",
                 "§3.2, fig. 8(b); conclusion (vii)", r["orders"], r["se"], case.name, SHEAR_ORDERS, syst=syst,
                 variants=text,
                 note=f"the wall bin's |du/dx| over that of the bin at x = {r['x']:.3g} d_p, the last before φ reaches "
                      f"0.63 at x = {edge:.3g} d_p (the paper's plug edge); the shear rate's error from each block's "
                      f"own gradient; the paper's figure is at W = 100 d_p")


def mu_log_i(a: ChannelAnalysis, x_from: float, x_to: float) -> dict:
    """μ against L = log10 I over the folded bins with ``x_from`` ≤ x < ``x_to`` (I known to
    :data:`MAX_I_REL_ERROR`): the weighted line's slope and its error; the weighted quadratic's relative change of
    slope across the bins' range of L, κ = (b(L_max) − b(L_min))/b(L_mid), and its error (χ²-scaled); ``n``."""
    x = a.folded["x"].to_numpy(float)
    I, I_se = a.rheo["I"].to_numpy(float), a.rheo["I_se"].to_numpy(float)
    mu, mu_se = a.rheo["mu"].to_numpy(float), a.rheo["mu_se"].to_numpy(float)
    keep = ((x >= x_from) & (x < x_to) & np.isfinite(I) & (I > 0) & (I_se < MAX_I_REL_ERROR * I)
            & np.isfinite(mu) & np.isfinite(mu_se) & (mu_se > 0))
    nan = {"slope": NAN, "slope_se": NAN, "kappa": NAN, "kappa_se": NAN, "n": int(keep.sum()), "range": (NAN, NAN)}
    if keep.sum() < MIN_BINS:
        return nan
    L = np.log10(I[keep])
    line, line_cov, _, _ = weighted_polyfit(L, mu[keep], mu_se[keep], 1)
    coef, cov, _, _ = weighted_polyfit(L, mu[keep], mu_se[keep], 2)
    lo, hi, mid = float(L.min()), float(L.max()), float(0.5 * (L.min() + L.max()))
    b_mid = coef[1] + 2 * coef[2] * mid
    kappa = 2 * coef[2] * (hi - lo) / b_mid
    # κ's error from the quadratic's covariance (the gradient of κ in (c0, c1, c2))
    grad = np.array([0.0, -kappa / b_mid, 2 * (hi - lo) / b_mid - kappa * 2 * mid / b_mid])
    return {"slope": float(line[1]), "slope_se": float(math.sqrt(line_cov[1, 1])), "kappa": float(kappa),
            "kappa_se": float(math.sqrt(grad @ cov @ grad)), "n": int(keep.sum()), "range": (lo, hi)}


def _mu_checks(case, x_from: float, x_to: float, variants: dict) -> list[Check]:
    a = case.analysis
    fit = mu_log_i(a, x_from, x_to)
    var = {k: mu_log_i(a, lo, hi) for k, (lo, hi) in variants.items()}
    where = (f"{fit['n']} folded bins of the dense zone ({x_from:.3g} ≤ x < {x_to:.3g} d_p; I known to "
             f"{MAX_I_REL_ERROR:.0%}), log10 I from {fit['range'][0]:.2f} to {fit['range'][1]:.2f}; μ = |σ_xy|/σ_xx, "
             f"I = d_p|du/dx|/√(σ_xx/ρ_p); {INDEPENDENT}, errors scaled by √(χ²/ν) when above 1")
    out = []
    for quantity, key, paper, rng, kind, why in (
            (Q_MU_SLOPE, "slope", "> 0: μ falls about linearly in log I down to the dense zone's lowest I",
             (0.0, math.inf), "comparison", ""),
            (Q_MU_KAPPA, "kappa", "0: about linear in log I (B3, flattening at μ_s, gives about 2)", (0.0, 0.0),
             "diagnostic", "; a diagnostic: its error (1-2.4 at W = 60-100 d_p) cannot tell linear (0) from B3's "
                           "flattening (about 2), so no verdict")):
        syst, text = systematic(fit[key], {k: v[key] for k, v in var.items()})
        out.append(Check(quantity, paper, "§3.2, fig. 11(a); conclusion (x)", fit[key], fit[f"{key}_se"], case.name,
                         rng, syst=syst, variants=text, note=where + why, kind=kind))
    return out


def _loose_width_check(case) -> Check:
    a = case.analysis
    z = a.zones
    phi_mean = float(case.record["parameters"]["phi_mean"])
    width = z.x_loose_dense - z.x_wall_layer if math.isfinite(z.x_loose_dense) else 0.0
    bin_width = float(np.median(np.diff(a.folded["x"].to_numpy(float))))
    none = phi_mean >= PHI_NO_LOOSE - 1e-9
    paper = ("0: no loose shearing zone at φ̄ = 0.62" if none else
             "> 0: a loose shearing zone between the wall layer and φ_ad (fig. 8, φ̄ = 0.59-0.61)")
    return Check(Q_LOOSE_WIDTH, paper, "§3.2, fig. 8(a)", width, bin_width / math.sqrt(12.0), case.name,
                 (0.0, 0.0) if none else (0.0, math.inf),
                 note=f"φ̄ = {phi_mean:g}: φ reaches φ_ad = 0.587 at x = {z.x_loose_dense:.3g} d_p (interpolated between "
                      f"the bins about it; {z.reason or 'after the wall layer'}); error: the crossing read to a bin "
                      f"({bin_width:g} d_p/√12)")


def case_zone_checks(case) -> list[Check]:
    """This module's rows for one :class:`.validation.ChannelCase` ([] without a steady analysis)."""
    a: ChannelAnalysis | None = case.analysis
    if a is None or case.why_not:
        return []
    z = a.zones
    out = [_loose_width_check(case)] + ([_orders_check(case)] if math.isfinite(z.x_plug_phi063) else [])
    loose_from, dense_from, dense_to = WALL_LAYER, z.x_loose_dense, z.x_plug_phi063
    if math.isfinite(dense_from) and math.isfinite(dense_to):
        out.append(_curvature_check(case, Q_CURV_DENSE, dense_from, dense_to, "< 0", {
            "to the shear-rate plug edge": (dense_from, z.x_dense_plug),
            "one bin in from each edge": (dense_from + 1.0, dense_to - 1.0)}))
    if math.isfinite(dense_from) and math.isfinite(dense_to):
        out += _mu_checks(case, dense_from, dense_to, {
            "to the shear-rate plug edge": (dense_from, z.x_dense_plug),
            "one bin in from each edge": (dense_from + 1.0, dense_to - 1.0)})
    if math.isfinite(dense_from):
        out.append(_curvature_check(case, Q_CURV_LOOSE, loose_from, dense_from, "> 0", {
            "from the wall bin": (0.0, dense_from), "one bin past φ_ad": (loose_from, dense_from + 1.0)}))
    return out


def zone_checks(cases: list) -> list[Check]:
    """The rows of every case (:func:`case_zone_checks`)."""
    return [c for case in cases for c in case_zone_checks(case)]
