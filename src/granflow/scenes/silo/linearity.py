"""The paper's √R in the paper's form: is the orifice speed squared a straight line in R?

Rubio-Largo et al. (2016, §3, Fig. 5) find :math:`v_z(0) \\sim \\sqrt{R}` over three orifices of
6.75-12 r_b. With Beverloo's empty annulus the same physics reads
:math:`v_c^2 = 2\\gamma g (R - R_0)`, and over R = 6-12 r_b (3.8-7.7 mean diameters) a pure power law
fitted to it returns 0.58-0.69, not 1/2: the pure power law cannot test the claim. The test here is
the law's own form, across the runs (one v_c per orifice):

* the straight line :math:`v_c^2 = c_0 + c_1 R`, weighted by :math:`1/\\sigma(v_c^2)`, gives
  :math:`R_0 = -c_0/c_1`, :math:`\\gamma = c_1/(2g)` with errors and its :math:`\\chi^2/\\nu`;
* the comparison is its curvature: :math:`v_c^2 = c_0 + c_1 R + c_2 R^2` fitted the same way, read
  as :math:`\\kappa = c_2 \\bar R / (c_1 + 2 c_2 \\bar R)`, the relative change of the slope across the mean orifice
  (0 for the paper's law), with the fit's error scaled by :math:`\\sqrt{\\chi^2/\\nu}` when that exceeds 1;
* :math:`R_0` is a diagnostic (the paper states none).

:func:`linearity_checks` reads the record's ``sweep`` profile only (``R_over_rb``, ``v_c_plane``,
``v_c_plane_se``, ``D``), so a committed record is judged by the same code as a rerun.
"""
from __future__ import annotations

import math

import numpy as np
import pandas as pd

from granflow.validation import Check

#: the paper's section and figure of v ∝ √R
SOURCE = "§3, Fig. 5 (v_z ∝ √R), with Beverloo's offset: v² = 2γg(R − R0)"
#: the silo's gravity, m/s² (the paper's g = 10, config/scenes/silo.yaml)
GRAVITY = 10.0


def _fit(x: np.ndarray, y: np.ndarray, se: np.ndarray, deg: int) -> tuple[np.ndarray, np.ndarray, float]:
    """Weighted polynomial (highest power first), its covariance scaled by χ²/ν when > 1, and χ²/ν."""
    coef, cov = np.polyfit(x, y, deg, w=1.0 / se, cov="unscaled")
    dof = len(x) - deg - 1
    chi2 = float(np.sum(((y - np.polyval(coef, x)) / se) ** 2) / dof) if dof > 0 else float("nan")
    return coef, cov * max(1.0, chi2 if math.isfinite(chi2) else 1.0), chi2


def linearity_checks(sweep: pd.DataFrame | None) -> list[Check]:
    """The curvature of :math:`v_c^2(R)` (comparison, paper 0) and Beverloo's :math:`R_0` (diagnostic).

    Rows with a finite plane-crossing :math:`v_c` and a positive error; fewer than 4 give NaN (three
    parameters and one degree of freedom).
    """
    paper = "v² linear in R (v ∝ √(R − R0)): curvature 0"
    names = ("v_c² = c0 + c1 R + c2 R²: relative curvature κ at R̄ (orifice plane, no kernel)",
             "Beverloo offset R0 of v_c² = 2γg(R − R0), r_b (orifice plane)")
    cols = {"R_over_rb", "v_c_plane", "v_c_plane_se"}
    ok = (sweep is not None and cols <= set(sweep)
          and np.isfinite(sweep[list(cols)].to_numpy(float)).all(axis=1) & (sweep["v_c_plane_se"] > 0))
    rows = sweep[ok] if sweep is not None and cols <= set(sweep) else None
    if rows is None or len(rows) < 4:
        why = f"needs 4 orifices with a plane reading; has {0 if rows is None else len(rows)}"
        return [Check(names[0], paper, SOURCE, float("nan"), paper_range=(0.0, 0.0), note=why),
                Check(names[1], "not stated", SOURCE, float("nan"), note=why, kind="diagnostic")]
    R = rows["R_over_rb"].to_numpy(float)
    v, v_se = rows["v_c_plane"].to_numpy(float), rows["v_c_plane_se"].to_numpy(float)
    y, y_se = v ** 2, 2.0 * v * v_se
    (c1, c0), cov1, chi1 = _fit(R, y, y_se, 1)
    r0 = -c0 / c1
    # R0 = -c0/c1: first-order propagation with the covariance of (c1, c0)
    grad = np.array([c0 / c1 ** 2, -1.0 / c1])
    r0_se = float(math.sqrt(grad @ cov1 @ grad))
    r_b = float(np.nanmean(rows["D"] / (2.0 * rows["R_over_rb"]))) if "D" in rows else float("nan")
    gamma = c1 / r_b / (2.0 * GRAVITY) if math.isfinite(r_b) else float("nan")
    gamma_se = math.sqrt(cov1[0, 0]) / r_b / (2.0 * GRAVITY) if math.isfinite(r_b) else float("nan")
    resid = np.max(np.abs(y - np.polyval([c1, c0], R)) / y)
    (q2, q1, q0), cov2, chi2 = _fit(R, y, y_se, 2)
    rbar = float(np.mean(R))
    slope = q1 + 2.0 * q2 * rbar  # the slope at the mean orifice
    kappa = q2 * rbar / slope
    g = np.array([rbar / slope - q2 * rbar * 2.0 * rbar / slope ** 2, -q2 * rbar / slope ** 2, 0.0])
    kappa_se = float(math.sqrt(g @ cov2 @ g))
    each = ", ".join(f"{r:g}: {x:.4g} ± {e:.2g}" for r, x, e in zip(R, v, v_se))
    note = (f"v_c (m/s) at R/r_b = {each}; weighted line v_c² = c0 + c1 R over {len(R)} orifices: R0 = {r0:.3g} ± "
            f"{r0_se:.2g} r_b, γ = c1/(2g r_b) = {gamma:.3g} ± {gamma_se:.2g}, χ²/ν = {chi1:.2g} (errors scaled by it "
            f"when > 1; the plane readings' errors count no run-to-run scatter), largest relative residual "
            f"{resid:.1%}; the quadratic's χ²/ν = {chi2:.2g}. κ = c2 R̄/(c1 + 2 c2 R̄), the slope taken at R̄ = "
            f"{rbar:g} r_b: the relative change of dv²/dR across the mean orifice (0 on the paper's law)")
    return [Check(names[0], paper, SOURCE, kappa, kappa_se, paper_range=(0.0, 0.0), note=note),
            Check(names[1], "not stated (the paper fits no offset)", SOURCE, r0, r0_se, note=note, unit="",
                  kind="diagnostic")]
