"""The silo's checks of the seven sizes and of the kernel width, from the record's profiles alone.

Rubio-Largo et al. (2016) state, for the partial kinetic pressures :math:`p^k_s` on the axis (their
eq. 8, Figs. 10-12): the transition height :math:`h_c` is the same for every particle type; the
partial kinetic stress is larger for bigger particles; with weak segregation :math:`\\phi_s \\propto
r_s^3`; and (Fig. 9) :math:`h_c` does not move with the kernel width w. The record keeps the partial
profiles (``partial_kinetic_axis``: ``pk_s<i>``, ``pk_s<i>_se``, ``phi_s<i>`` per axis node, w = 2 r_b,
types 1 ... 7 smallest first) and the per-orifice :math:`h_c/R` readings (``sweep``).
:func:`granflow.scenes.silo.profile_checks.profile_checks` calls these.
"""
from __future__ import annotations

import math

import numpy as np
import pandas as pd
from scipy.stats import spearmanr

from granflow.validation import Check, systematic

from .analysis import transition_height

SOURCE_HC = "§3, Figs. 10-11; abstract"
SOURCE_BIG = "§3, Figs. 10-11; abstract; §4"
SOURCE_PHI = "§3, Fig. 12"


def _species(partial: pd.DataFrame) -> list[int]:
    return sorted(int(c[4:]) for c in partial if c.startswith("pk_s") and not c.endswith("_se"))


def species_checks(partial: pd.DataFrame | None, sweep: pd.DataFrame | None, radii=None) -> list[Check]:
    """:func:`species_hc_check`, then per case :func:`partial_size_check` and :func:`volume_fraction_check`."""
    if partial is None or partial.empty:
        why = "no partial_kinetic_axis profile"
        return [Check(species_hc_name(), "0", SOURCE_HC, float("nan"), paper_range=(0.0, 0.0), note=why),
                Check(PARTIAL_NAME, "> 1", SOURCE_BIG, float("nan"), paper_range=(1.0, math.inf), note=why),
                Check(PHI_NAME, "3", SOURCE_PHI, float("nan"), paper_range=(3.0, 3.0), note=why)]
    out = [species_hc_check(partial)]
    hc = {} if sweep is None else dict(zip(sweep["case"], sweep["h_c_over_R"]))
    for case, g in partial.groupby("case", sort=False):
        g = g.sort_values("z_over_R")
        out.append(partial_size_check(case, g, hc.get(case, float("nan"))))
        out.append(volume_fraction_check(case, g, radii))
    return out


def species_hc_name() -> str:
    return "h_c per size: (h_c,largest − h_c,smallest)/h̄_c from a line through the 7 sizes"


def species_hc_check(partial: pd.DataFrame) -> Check:
    """The relative change of :math:`h_c` from the smallest to the largest size (paper: 0).

    Per case, :math:`h_{c,s}/R` of each species' axis profile (:func:`transition_height`, its error
    from resampling the profile with its errors), a weighted line against the species index
    ``s``; the change across the sizes, ``(n − 1) × slope / mean``, is averaged over the cases
    weighted by its errors.
    """
    q, paper = species_hc_name(), "0 (\"the location of the transition region results the same for all particle types\")"
    ids = _species(partial)
    rel, rel_se, per = [], [], []
    chis = []
    for case, g in partial.groupby("case", sort=False):
        g = g.sort_values("z_over_R")
        z = g["z_over_R"].to_numpy(float)
        h = np.array([transition_height(z, g[f"pk_s{s}"], g[f"pk_s{s}_se"]) for s in ids])
        ok = np.isfinite(h).all(axis=1) & (h[:, 1] > 0)
        if ok.sum() < 3:
            continue
        x, y, e = np.array(ids, float)[ok], h[ok, 0], h[ok, 1]
        coef, cov = np.polyfit(x, y, 1, w=1 / e, cov="unscaled")
        chi2 = float(np.sum(((y - np.polyval(coef, x)) / e) ** 2) / (ok.sum() - 2))
        mean = float(np.average(y, weights=1 / e ** 2))
        span = x.max() - x.min()
        rel.append(span * coef[0] / mean)
        rel_se.append(span * math.sqrt(cov[0, 0] * max(1.0, chi2)) / mean)
        chis.append(chi2)
        per.append(f"{case}: " + ", ".join(f"{v:.2f}" for v in y) + f" (± {np.median(e):.2f})")
    if not rel:
        return Check(q, paper, SOURCE_HC, float("nan"), paper_range=(0.0, 0.0), note="fewer than 3 sizes with an h_c")
    w = 1 / np.array(rel_se) ** 2
    value, err = float(np.sum(w * rel) / w.sum()), float(1 / math.sqrt(w.sum()))
    spread = float(np.sum(w * (np.array(rel) - value) ** 2) / max(1, len(rel) - 1))
    err *= math.sqrt(max(1.0, spread))
    note = (f"h_c,s/R (smallest to largest; refined maximum of each p^k_s on the axis, w = 2 r_b time-averaged "
            f"fields, error from 400 resamples of the profile with its errors, nodes independent) per case: "
            f"{'; '.join(per)}; per case the weighted line's change over the sizes relative to the mean: "
            f"{', '.join(f'{r:+.3f} ± {s:.3f}' for r, s in zip(rel, rel_se))}, averaged weighted over "
            f"{len(rel)} cases (error scaled by their scatter's χ²/ν = {spread:.2g} when > 1); χ²/ν of the lines: "
            f"{', '.join(f'{c:.2g}' for c in chis)}")
    return Check(q, paper, SOURCE_HC, value, err, paper_range=(0.0, 0.0), note=note)


PARTIAL_NAME = "p^k_largest/p^k_smallest on the axis at h_c (partial kinetic pressures)"


def _ratio_at(g: pd.DataFrame, i, small: int, large: int) -> tuple[float, float]:
    a, b = g[f"pk_s{small}"].loc[i], g[f"pk_s{large}"].loc[i]
    a_se, b_se = g[f"pk_s{small}_se"].loc[i], g[f"pk_s{large}_se"].loc[i]
    if not (a > 0 and b > 0):
        return float("nan"), float("nan")
    return float(b / a), float(b / a * math.hypot(a_se / a, b_se / b))


def partial_size_check(case: str, g: pd.DataFrame, h_c_over_R: float) -> Check:
    """:math:`p^k_{largest}/p^k_{smallest}` on the axis node nearest :math:`h_c` (paper: > 1)."""
    paper = "> 1 (\"the partial kinetic stress is larger for bigger particles\")"
    ids = _species(g)
    if len(ids) < 2 or not math.isfinite(h_c_over_R):
        return Check(PARTIAL_NAME, paper, SOURCE_BIG, float("nan"), case=case, paper_range=(1.0, math.inf),
                     note="fewer than two sizes, or no h_c")
    small, large = ids[0], ids[-1]
    z = g["z_over_R"]
    i = (z - h_c_over_R).abs().idxmin()
    head = _ratio_at(g, i, small, large)
    alt = {"at z = R": _ratio_at(g, (z - 1.0).abs().idxmin(), small, large)[0],
           "each size's own maximum": float(g[f"pk_s{large}"].max() / g[f"pk_s{small}"].max())}
    inside = g[(z >= 0) & (z <= 2.0)]
    if len(inside):
        alt["mean over 0 ≤ z ≤ 2R"] = float(inside[f"pk_s{large}"].mean() / inside[f"pk_s{small}"].mean())
    syst, text = systematic(head[0], alt)
    row = np.array([g[f"pk_s{s}"].loc[i] for s in ids])
    rho = spearmanr(ids, row).statistic if len(ids) > 2 else float("nan")
    inversions = sum(1 for a, b in zip(ids, ids[1:])
                     if g[f"pk_s{b}"].loc[i] < g[f"pk_s{a}"].loc[i]
                     - 2 * math.hypot(g[f"pk_s{a}_se"].loc[i], g[f"pk_s{b}_se"].loc[i]))
    note = (f"size {large} (largest) over {small} (smallest) at the axis node z = {z.loc[i]:.3g}R nearest h_c "
            f"({h_c_over_R:.3g}R), w = 2 r_b time-averaged fields (the paper's Fig. 11: w = r_b/2); the seven "
            f"sizes there: {', '.join(f'{v:.3g}' for v in row)} Pa, Spearman ρ with size {rho:.3f}, "
            f"{inversions} neighbouring pair(s) out of order by more than 2 errors; error from the two nodes' errors")
    return Check(PARTIAL_NAME, paper, SOURCE_BIG, head[0], head[1], case=case, paper_range=(1.0, math.inf),
                 note=note, syst=syst, variants=text)


PHI_NAME = "φ_s ∝ r_s^n on the axis (partial volume fractions): exponent n"


def phi_exponent(g: pd.DataFrame, radii, lo: float, hi: float) -> tuple[float, float, int]:
    """Mean over the axis nodes in ``lo`` ≤ z/R ≤ ``hi`` of the slope of ln φ_s against ln r_s, and the
    mean of the nodes' fit errors (the profile has no errors of φ_s: each node's error is from its
    residuals; nodes taken as fully correlated, an upper bound)."""
    ids = [s for s in _species(g) if f"phi_s{s}" in g]
    r = np.log(np.asarray(radii, float)[np.array(ids) - 1])
    sel = g[(g["z_over_R"] >= lo - 1e-9) & (g["z_over_R"] <= hi + 1e-9)]
    slopes, errs = [], []
    for _, row in sel.iterrows():
        phi = np.array([row[f"phi_s{s}"] for s in ids], float)
        if not (phi > 0).all():
            continue
        (b, _), cov = np.polyfit(r, np.log(phi), 1, cov=True)
        slopes.append(b)
        errs.append(math.sqrt(cov[0, 0]))
    if not slopes:
        return float("nan"), float("nan"), 0
    return float(np.mean(slopes)), float(np.mean(errs)), len(slopes)


def volume_fraction_check(case: str, g: pd.DataFrame, radii) -> Check:
    """The exponent of :math:`\\phi_s \\propto r_s^n` on the axis above the orifice (paper: 3)."""
    paper = "3 (\"φ_k ∝ r_k³\", weak segregation)"
    if radii is None or len(_species(g)) < 3:
        return Check(PHI_NAME, paper, SOURCE_PHI, float("nan"), case=case, paper_range=(3.0, 3.0),
                     note="no species radii, or fewer than 3 sizes")
    top = float(g["z_over_R"].max())
    n, n_se, nodes = phi_exponent(g, radii, 0.0, top)
    alt = {}
    for a, b in ((0.0, 1.0), (1.0, top), (float(g["z_over_R"].min()), top)):
        alt[f"z = {a:.2g}-{b:.2g}R"] = phi_exponent(g, radii, a, b)[0]
    syst, text = systematic(n, alt)
    note = (f"slope of ln φ_s against ln r_s over the {len(_species(g))} sizes at each of {nodes} axis nodes with "
            f"0 ≤ z ≤ {top:.2g}R (w = 2 r_b fields), averaged; equal numbers of each size, so n = 3 when the sizes "
            "do not segregate; error: the nodes' fit errors from their residuals (the profile keeps no error of "
            "φ_s), nodes taken as fully correlated; syst: other height ranges")
    return Check(PHI_NAME, paper, SOURCE_PHI, n, n_se, case=case, paper_range=(3.0, 3.0), note=note, syst=syst,
                 variants=text)


def kernel_width_check(sweep: pd.DataFrame | None) -> Check:
    """:math:`h_c/R` at w = r_b/2 minus at w = 2 r_b, weighted mean over the orifices (paper: 0, Fig. 9)."""
    q = "h_c/R at w = r_b/2 minus at w = 2 r_b (weighted mean over the orifices)"
    paper, source = "0 (\"the location of transition region h_c(R) remains invariant\")", "§3, Fig. 9"
    cols = {"h_c_over_R", "h_c_over_R_se", "h_c_over_R_fine", "h_c_over_R_eq7", "h_c_over_R_eq7_se"}
    if sweep is None or not cols <= set(sweep):
        return Check(q, paper, source, float("nan"), paper_range=(0.0, 0.0), note="no sweep profile with h_c readings")
    s = sweep[np.isfinite(sweep[sorted(cols)].to_numpy(float)).all(axis=1) & (sweep["h_c_over_R_eq7_se"] > 0)]
    if len(s) < 2:
        return Check(q, paper, source, float("nan"), paper_range=(0.0, 0.0), note="fewer than 2 orifices with both")

    def mean(narrow):
        d = s[narrow].to_numpy(float) - s["h_c_over_R"].to_numpy(float)
        e = np.hypot(s["h_c_over_R_eq7_se"].to_numpy(float), s["h_c_over_R_se"].to_numpy(float))
        w = 1 / e ** 2
        m = float(np.sum(w * d) / w.sum())
        chi2 = float(np.sum(w * (d - m) ** 2) / (len(d) - 1))
        return m, float(math.sqrt(max(1.0, chi2) / w.sum())), chi2, d

    m, m_se, chi2, d = mean("h_c_over_R_fine")
    alt_m, alt_se, _, d7 = mean("h_c_over_R_eq7")
    syst, text = systematic(m, {"eq. 7 (fluctuations about each frame's local mean) at w = r_b/2": (alt_m, alt_se)},
                            central_se=m_se)
    note = (f"per R/r_b ({', '.join(f'{r:g}' for r in s['R_over_rb'])}): the time-averaged fields' h_c/R at w = r_b/2 "
            f"(nodes r_b/4) minus at w = 2 r_b (nodes r_b): {', '.join(f'{x:+.3f}' for x in d)}; eq. 7's at "
            f"w = r_b/2 minus w = 2 r_b: {', '.join(f'{x:+.3f}' for x in d7)}. The record keeps no error of the "
            "time-averaged w = r_b/2 reading: eq. 7's on the same nodes and frames stands in for it; weighted mean, "
            f"χ²/ν = {chi2:.2g} (error scaled by it when > 1); the mean h_c/R at w = 2 r_b is "
            f"{float(s['h_c_over_R'].mean()):.3g}")
    return Check(q, paper, source, m, m_se, paper_range=(0.0, 0.0), note=note, syst=syst, variants=text)
