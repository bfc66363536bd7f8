"""Figs. 11(b) and 13 of Debnath, Kesava Rao & Kumaran (2022): the loose shearing zone's rheology.

In the loose zone (:math:`\\phi < \\phi_{ad} = 0.587`, beyond the 2 :math:`d_p` wall layer) the paper finds
:math:`p_\\phi = \\sigma_{xx}/T` (eq. B8) and :math:`\\mu_\\phi = \\sigma_{xy}/(T^{1/2} du_y/dx)` (eq. B9)
functions of :math:`\\phi` alone (the same at every :math:`\\bar\\phi`), diverging as
:math:`(\\phi_{ad} - \\phi)^{-1}` at :math:`\\phi_{ad} = 0.59 \\pm 0.002`. :func:`kinetic_checks` tests both across
the lowest and highest :math:`\\bar\\phi` of each W (:func:`.more_checks.phi_pairs`):

* the collapse: the higher :math:`\\bar\\phi`'s coefficient over the lower's at equal :math:`\\phi`, the lower's
  :math:`1/c` interpolated linearly in :math:`\\phi` (straight for a divergence of this form) — paper: 1;
* the divergence: :math:`\\phi_{ad}` where a weighted line through :math:`1/c` of both cases' loose bins
  crosses zero (the paper's fit across its :math:`\\bar\\phi`);
* fig. 11(b): :math:`0.64 - \\phi` depends on :math:`I` alone in the loose zone — the higher
  :math:`\\bar\\phi`'s over the lower's at equal :math:`I`, interpolated linearly in :math:`\\ln I` (the log-log
  axes of the figure) — paper: 1.

:math:`D_\\phi` (eq. B10) needs the dissipation rate D, which we do not measure. Bins are taken as
independent, each with its correlation-aware error. Units: :math:`d_p`, :math:`\\sqrt{d_p/g}`, :math:`\\rho_p = 1`.
"""
from __future__ import annotations

import math

import numpy as np
import pandas as pd

from granflow.validation import Check, systematic

from .analysis import ChannelAnalysis
from .more_checks import INDEPENDENT, NAN, WALL_LAYER, field_column, phi_pairs, weighted_polyfit

Q_PAD_P = "φ_ad where p_φ = σ_xx/T diverges as (φ_ad − φ)⁻¹, loose zone"
Q_PAD_MU = "φ_ad where μ_φ = σ_xy/(T^½ du/dx) diverges as (φ_ad − φ)⁻¹, loose zone"
Q_COLLAPSE_P = "p_φ = σ_xx/T at the higher φ̄ over at the lower φ̄, equal φ, loose zone"
Q_COLLAPSE_MU = "μ_φ = σ_xy/(T^½ du/dx) at the higher φ̄ over at the lower φ̄, equal φ, loose zone"
Q_PHI_I = "0.64 − φ at the higher φ̄ over at the lower φ̄, equal I, loose zone"
#: φ_rcp of the paper's fig. 11(b), which plots 0.64 − φ
PHI_RCP = 0.64
#: every quantity this module writes
QUANTITIES = (Q_PAD_P, Q_PAD_MU, Q_COLLAPSE_P, Q_COLLAPSE_MU, Q_PHI_I)
#: the paper's divergence of the loose zone's coefficients (§3.2, fig. 13): φ_ad = 0.59 ± 0.002
PHI_AD_FIT, PHI_AD_FIT_ERROR = 0.59, 0.002
COEFFICIENTS = (("p_phi", "p_φ = σ_xx/T (eq. B8)"), ("mu_phi", "μ_φ = |σ_xy|/(T^½|du/dx|) (eq. B9)"))


def loose_coefficients(a: ChannelAnalysis, x_from: float = 0.0) -> pd.DataFrame:
    """Per loose-zone bin (``zones.labels == "loose"``, :math:`x \\ge` ``x_from``): φ, the kinetic-theory
    coefficients :math:`p_\\phi = \\sigma_{xx}/T` (B8) and :math:`\\mu_\\phi = |\\sigma_{xy}|/(T^{1/2}|du/dx|)` (B9),
    and their relative errors (the bins' errors independent)."""
    x = a.folded["x"].to_numpy(float)
    phi = a.folded["phi"].to_numpy(float)
    sxx, sxx_se = field_column(a, "sigma_xx")
    sxy, sxy_se = field_column(a, "sigma_xy")
    T, T_se = field_column(a, "T")
    gd, gd_se = a.rheo["gamma_dot"].to_numpy(float), a.rheo["gamma_dot_se"].to_numpy(float)
    keep = (a.zones.labels == "loose") & (x >= x_from)
    with np.errstate(divide="ignore", invalid="ignore"):
        p = sxx / T
        mu = np.abs(sxy) / (np.sqrt(T) * np.abs(gd))
        p_rel = np.hypot(sxx_se / sxx, T_se / T)
        mu_rel = np.sqrt((sxy_se / sxy) ** 2 + (0.5 * T_se / T) ** 2 + (gd_se / gd) ** 2)
    return pd.DataFrame({"phi": phi, "p_phi": p, "p_phi_rel": p_rel, "mu_phi": mu, "mu_phi_rel": mu_rel})[keep]


def divergence_point(phi, coefficient, rel_error) -> dict:
    """:math:`\\phi_{ad}` of :math:`c = A/(\\phi_{ad} - \\phi)`: a weighted line :math:`1/c = a_0 + a_1\\phi`
    (errors of :math:`1/c` its relative ones), :math:`\\phi_{ad} = -a_0/a_1` with its error by the delta method
    (χ²-scaled); ``n`` points, ``chi2_nu``."""
    phi, c, rel = (np.asarray(v, float) for v in (phi, coefficient, rel_error))
    ok = np.isfinite(phi) & np.isfinite(c) & (c > 0) & np.isfinite(rel)
    coef, cov, chi2_nu, nu = weighted_polyfit(phi[ok], 1.0 / c[ok], rel[ok] / c[ok], 1)
    if nu < 1 or not np.all(np.isfinite(coef)) or coef[1] == 0:
        return {"phi_ad": NAN, "se": NAN, "n": int(ok.sum()), "chi2_nu": NAN}
    jac = np.array([-1.0 / coef[1], coef[0] / coef[1] ** 2])
    return {"phi_ad": float(-coef[0] / coef[1]), "se": float(math.sqrt(jac @ cov @ jac)), "n": int(ok.sum()),
            "chi2_nu": chi2_nu}


def divergence_checks(cases: list, name: str, pair: str) -> list[Check]:
    """:math:`\\phi_{ad}` from :math:`p_\\phi` and from :math:`\\mu_\\phi` over the loose-zone bins of ``cases``
    (the paper fits across its φ̄), the outermost loose bin left out as the variant."""
    out = []
    tables = [loose_coefficients(c.analysis) for c in cases]
    inner = [loose_coefficients(c.analysis, WALL_LAYER + 1.0) for c in cases]
    for q, (key, label) in zip((Q_PAD_P, Q_PAD_MU), COEFFICIENTS):
        both, deeper = pd.concat(tables), pd.concat(inner)
        fit = divergence_point(both["phi"], both[key], both[f"{key}_rel"])
        alt = divergence_point(deeper["phi"], deeper[key], deeper[f"{key}_rel"])["phi_ad"]
        syst, text = systematic(fit["phi_ad"], {"from 3 d_p (the outermost loose bin left out)": alt})
        span = f"{both['phi'].min():.3g}-{both['phi'].max():.3g}" if len(both) else "none"
        out.append(Check(q, "0.59 ± 0.002 (p_φ, μ_φ; inclined plane 0.585 ± 0.005)", "§3.2, fig. 13; conclusion (ix)",
                         fit["phi_ad"], fit["se"], name, (PHI_AD_FIT, PHI_AD_FIT), paper_error=PHI_AD_FIT_ERROR,
                         syst=syst, variants=text,
                         note=f"{label} of the {fit['n']} loose-zone bins (2 d_p ≤ x, φ < 0.587) of {pair}, φ = "
                              f"{span}: a weighted line through 1/{key.replace('_phi', '_φ')} against φ crosses zero "
                              f"at φ_ad (the paper's fit ∝ (φ_ad − φ)⁻¹ across its φ̄); χ²/ν = {fit['chi2_nu']:.2g}; "
                              f"{INDEPENDENT}, error scaled by √(χ²/ν) when above 1. The loose zone ends at the "
                              f"paper's φ_ad = 0.587 by definition, so the fit extrapolates beyond its bins"))
    return out


def collapse_ratio(high: pd.DataFrame, low: pd.DataFrame, key: str) -> dict:
    """Weighted mean over the higher φ̄'s loose bins whose φ lies within the lower φ̄'s of
    :math:`\\ln(c_{high}/c_{low}(\\phi))`, :math:`1/c_{low}` interpolated linearly in φ between its two neighbouring
    bins (their errors, independent, interpolated alike); ``ratio`` = exp of it, its error (χ²-scaled), ``n``."""
    low = low.dropna(subset=["phi", key]).sort_values("phi")
    phi_l, inv_l, rel_l = low["phi"].to_numpy(float), 1.0 / low[key].to_numpy(float), low[f"{key}_rel"].to_numpy(float)
    ys, ses = [], []
    for phi, c, rel in zip(high["phi"], high[key], high[f"{key}_rel"]):
        if not (np.isfinite(c) and c > 0 and len(phi_l) >= 2 and phi_l[0] <= phi <= phi_l[-1]):
            continue
        k = int(np.clip(np.searchsorted(phi_l, phi), 1, len(phi_l) - 1))
        w = (phi - phi_l[k - 1]) / (phi_l[k] - phi_l[k - 1]) if phi_l[k] > phi_l[k - 1] else 0.5
        inv = (1 - w) * inv_l[k - 1] + w * inv_l[k]
        inv_se = math.hypot((1 - w) * inv_l[k - 1] * rel_l[k - 1], w * inv_l[k] * rel_l[k])
        if inv > 0:
            ys.append(math.log(c * inv))
            ses.append(math.hypot(rel, inv_se / inv))
    coef, cov, _, nu = weighted_polyfit(np.zeros(len(ys)), np.array(ys), np.array(ses), 0)
    r = math.exp(coef[0]) if np.isfinite(coef[0]) else NAN
    return {"ratio": r, "se": r * math.sqrt(cov[0, 0]) if np.isfinite(r) else NAN, "n": len(ys)}


def collapse_checks(low, high, name: str, pair: str) -> list[Check]:
    """The higher φ̄'s coefficients over the lower's at equal φ in the loose zone (:func:`collapse_ratio`)."""
    out = []
    for q, (key, label) in zip((Q_COLLAPSE_P, Q_COLLAPSE_MU), COEFFICIENTS):
        fit = collapse_ratio(loose_coefficients(high.analysis), loose_coefficients(low.analysis), key)
        alt = collapse_ratio(loose_coefficients(high.analysis, WALL_LAYER + 1.0),
                             loose_coefficients(low.analysis, WALL_LAYER + 1.0), key)["ratio"]
        syst, text = systematic(fit["ratio"], {"from 3 d_p (the outermost loose bin left out)": alt})
        out.append(Check(q, "1: a function of φ alone in the loose zone (hard-particle models apply)",
                         "§3.2, fig. 13; conclusion (viii)", fit["ratio"], fit["se"], name, (1.0, 1.0), syst=syst,
                         variants=text,
                         note=f"{label}: exp of the weighted mean of ln(c_high/c_low) over the {fit['n']} loose-zone "
                              f"bins of the higher φ̄ whose φ lies within the lower φ̄'s loose bins, {pair}; 1/c_low "
                              f"interpolated linearly in φ (straight where c ∝ (φ_ad − φ)⁻¹); {INDEPENDENT}, error "
                              f"scaled by √(χ²/ν) when above 1"))
    return out


def phi_of_i_ratio(high: ChannelAnalysis, low: ChannelAnalysis, x_from: float = 0.0) -> dict:
    """Weighted mean over the higher φ̄'s loose bins whose I lies within the lower φ̄'s of
    :math:`\\ln[(0.64 - \\phi_{high})/(0.64 - \\phi_{low}(I))]`, :math:`\\ln(0.64 - \\phi_{low})` interpolated linearly in
    :math:`\\ln I` (φ's errors, independent, propagated; I's neglected); ``ratio``, its error (χ²-scaled), ``n``."""
    def loose(a):
        x = a.folded["x"].to_numpy(float)
        phi, se = field_column(a, "phi")
        I = a.rheo["I"].to_numpy(float)
        keep = (a.zones.labels == "loose") & (x >= x_from) & (I > 0) & (phi < PHI_RCP)
        order = np.argsort(I[keep])
        return np.log(I[keep][order]), np.log(PHI_RCP - phi[keep][order]), (se / (PHI_RCP - phi))[keep][order]

    li_h, y_h, e_h = loose(high)
    li_l, y_l, e_l = loose(low)
    ys, ses = [], []
    for li, y, e in zip(li_h, y_h, e_h):
        if len(li_l) < 2 or not li_l[0] <= li <= li_l[-1]:
            continue
        k = int(np.clip(np.searchsorted(li_l, li), 1, len(li_l) - 1))
        w = (li - li_l[k - 1]) / (li_l[k] - li_l[k - 1]) if li_l[k] > li_l[k - 1] else 0.5
        ys.append(y - ((1 - w) * y_l[k - 1] + w * y_l[k]))
        ses.append(math.sqrt(e**2 + ((1 - w) * e_l[k - 1]) ** 2 + (w * e_l[k]) ** 2))
    coef, cov, _, _ = weighted_polyfit(np.zeros(len(ys)), np.array(ys), np.array(ses), 0)
    r = math.exp(coef[0]) if np.isfinite(coef[0]) else NAN
    return {"ratio": r, "se": r * math.sqrt(cov[0, 0]) if np.isfinite(r) else NAN, "n": len(ys)}


def phi_of_i_check(low, high, name: str, pair: str) -> Check:
    """0.64 − φ of the higher φ̄ over the lower's at equal I in the loose zone (:func:`phi_of_i_ratio`)."""
    fit = phi_of_i_ratio(high.analysis, low.analysis)
    alt = phi_of_i_ratio(high.analysis, low.analysis, WALL_LAYER + 1.0)["ratio"]
    syst, text = systematic(fit["ratio"], {"from 3 d_p (the outermost loose bin left out)": alt})
    return Check(Q_PHI_I, "1: 0.64 − φ depends on I alone in the loose zone (on I and φ̄ in the dense zone)",
                 "§3.2, fig. 11(b)", fit["ratio"], fit["se"], name, (1.0, 1.0), syst=syst, variants=text,
                 note=f"exp of the weighted mean of ln[(0.64 − φ_high)/(0.64 − φ_low)] over the {fit['n']} loose-zone "
                      f"bins of the higher φ̄ whose I = d_p|du/dx|/√(σ_xx/ρ_p) lies within the lower φ̄'s loose bins, "
                      f"{pair}; ln(0.64 − φ_low) interpolated linearly in ln I; {INDEPENDENT} (I's error neglected), "
                      f"error scaled by √(χ²/ν) when above 1")


def kinetic_checks(cases: list) -> list[Check]:
    """The collapse and the divergence of the loose zone's coefficients for each W's two φ̄ (:func:`phi_pairs`)."""
    out = []
    for low, high, name, pair in phi_pairs(cases):
        out += collapse_checks(low, high, name, pair) + divergence_checks([low, high], name, pair)
        out.append(phi_of_i_check(low, high, name, pair))
    return out
