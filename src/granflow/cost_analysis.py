"""Error against cost: which fidelity is good enough, and what does it cost.

For each scene (channel, heap, silo) one fidelity *knob* is varied at a time
around a shared base case (``dt_fraction``, ``stiffness``, ``size``,
``t_average``, ``bin_width``).  Every run point reports headline observables
with standard errors that allow for autocorrelation (:mod:`granflow.headline`)
and its cost.  This module turns those
records into

* errors of each observable against the knob's finest setting, with the
  statistical noise of the difference (:func:`knob_errors`);
* Pareto fronts in (cost, error) (:func:`pareto_front`);
* the cheapest setting of each knob that is within p % of the finest
  (:func:`within_table`, :func:`summary_markdown`);
* the measured scaling of the simulation cost with particle count and its
  extrapolation to the paper's size (:func:`cost_scaling`, :func:`extrapolate`);
* one figure per scene (:func:`granflow.cost_figure.plot_error_vs_cost`).

Input contract: a long DataFrame ``records``, one row per (run point,
observable), with columns

``scene, knob, value, is_base, finest``
    the scene, the knob varied, its setting, whether the point is the shared
    base case (it appears once per knob, so every knob's series is complete by
    itself) and which end of the knob's values is the finest (``"min"`` or
    ``"max"``);
``observable, label, x, se``
    observable name, human label, measured value (NaN when the run failed or
    the observable could not be measured) and its standard error (may be
    NaN): that of the mean of sub-window values with their statistical
    inefficiency, or the block error where too few sub-windows were
    measurable (:func:`granflow.headline.measure_with_errors`);
``se_block, g`` (optional, carried through)
    the block standard error (the cross-check) and the statistical
    inefficiency of the sub-window values;
``cpu_s, sim_cpu_s, post_cpu_s, loop_s, peak_mb``
    total CPU-seconds of the point (simulation + post-processing), their two
    parts, the LAMMPS loop wall time and the peak memory;
``n_particles, sim_time, status``
    particle count, simulated time (scene units) and run status.

Errors measure the distance from the finest setting *that was run*, not from
the converged answer: an error of 0 at the reference is a definition, and a
setting within p % of a reference that is itself not converged is only
within p % of that reference.  Pure numpy/pandas; no I/O (the figure: :mod:`granflow.cost_figure`).
"""
from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
import pandas as pd

#: Label of the rows of :func:`within_table` that combine every observable.
ALL = "all"
TABLE_COLUMNS = ["scene", "observable", "label", "knob", "tolerance", "value", "cpu_s", "cpu_h", "error",
                 "noise", "significant", "resolved", "paper_cpu_h", "note", "relative"]


# --------------------------------------------------------------------------- helpers
def column_values(df: pd.DataFrame, name: str) -> np.ndarray:
    """Column as floats; all NaN when absent."""
    if name in df:
        return pd.to_numeric(df[name], errors="coerce").to_numpy(dtype=float)
    return np.full(len(df), np.nan)


def percent(fraction: float) -> str:
    """A fraction as a short percentage number (``0.123`` -> ``"12"``, ``0.0042`` -> ``"0.42"``)."""
    if not np.isfinite(fraction):
        return "n/a"
    p = 100.0 * abs(fraction)
    return f"{p:.0f}" if p >= 10 else f"{p:.2g}"


def _finest_of(group: pd.DataFrame) -> str:
    finest = group["finest"].dropna().astype(str).str.lower().unique()
    if len(finest) != 1 or finest[0] not in ("min", "max"):
        raise ValueError(f"column 'finest' must be one of 'min'/'max' and the same for all rows of a knob; "
                         f"got {sorted(finest)}")
    return finest[0]


def _per_scene(spec: Mapping | None, scene: str, key: str) -> Mapping | None:
    """``spec`` itself when it has ``key``, else ``spec[scene]`` (None when absent)."""
    if spec is None:
        return None
    if key in spec:
        return spec
    sub = spec.get(scene)
    return sub if isinstance(sub, Mapping) and key in sub else None


# --------------------------------------------------------------------------- errors
def knob_errors(records: pd.DataFrame, noise_sigmas: float = 2.0) -> pd.DataFrame:
    """Error of every run point against the finest setting of its knob.

    For every (scene, knob, observable) the reference is the row at the finest
    knob value (the smallest ``value`` when ``finest`` is ``"min"``, the
    largest when ``"max"``) among the rows with a finite ``x``; so a failed
    run at the finest value makes the next finest the reference.  Then

    .. math:: e = \\frac{x - x_{ref}}{|x_{ref}|}, \\qquad
              n = \\frac{\\sqrt{s^2 + s_{ref}^2}}{|x_{ref}|}

    with :math:`s` the standard errors ``se`` (a NaN ``se`` counts as 0 and
    sets ``se_missing``).  A difference is *significant* when
    :math:`|e| > k n` with :math:`k` = ``noise_sigmas``.  The reference row
    has :math:`e = 0`, :math:`n = s_{ref}/|x_{ref}|` and is never
    significant.  When :math:`x_{ref} = 0` the error and the noise are
    absolute (not divided by :math:`|x_{ref}|`) and ``relative`` is False.

    Parameters
    ----------
    records : DataFrame
        Long table of the module's input contract (one row per run point and
        observable).
    noise_sigmas : float
        Number of standard errors of the difference beyond which it counts as
        significant.

    Returns
    -------
    DataFrame
        ``records`` (same index and row order, all input columns) plus
        ``x_ref, se_ref, ref_value, error, abs_error, noise, se_missing,
        significant, is_ref, relative, noise_sigmas, note``.  Rows without a
        finite ``x`` have NaN errors (``note`` = ``"x not finite"``); groups
        without any finite ``x`` have NaN everywhere and ``note`` =
        ``"no finite reference"``.
    """
    out = records.copy()
    n = len(out)
    cols = {name: np.full(n, np.nan) for name in ("x_ref", "se_ref", "ref_value", "error", "noise")}
    se_missing = np.zeros(n, dtype=bool)
    significant = np.zeros(n, dtype=bool)
    is_ref = np.zeros(n, dtype=bool)
    relative = np.ones(n, dtype=bool)
    note = np.full(n, "", dtype=object)

    x_all, se_all, v_all = column_values(out, "x"), column_values(out, "se"), column_values(out, "value")
    positions = pd.RangeIndex(n)
    keys = ["scene", "knob", "observable"]
    groups = pd.Series(positions, index=positions).groupby([out[k].to_numpy() for k in keys], sort=False,
                                                            dropna=False)
    for _, pos in groups:
        idx = pos.to_numpy()
        finest = _finest_of(out.iloc[idx])
        x, se, v = x_all[idx], se_all[idx], v_all[idx]
        ok = np.isfinite(x) & np.isfinite(v)
        if not ok.any():
            note[idx] = "no finite reference"
            se_missing[idx] = ~np.isfinite(se)
            continue
        cand = np.flatnonzero(ok)
        pick = cand[np.argmin(v[cand])] if finest == "min" else cand[np.argmax(v[cand])]
        x_ref, se_ref = x[pick], se[pick]
        rel = x_ref != 0
        scale = abs(x_ref) if rel else 1.0
        s_ref = 0.0 if not np.isfinite(se_ref) else se_ref
        s = np.where(np.isfinite(se), se, 0.0)

        error = (x - x_ref) / scale
        noise = np.sqrt(s ** 2 + s_ref ** 2) / scale
        error[pick], noise[pick] = 0.0, s_ref / scale
        sig = np.abs(error) > noise_sigmas * noise
        sig[pick] = False
        sig &= np.isfinite(error)

        cols["x_ref"][idx], cols["se_ref"][idx], cols["ref_value"][idx] = x_ref, se_ref, v[pick]
        cols["error"][idx], cols["noise"][idx] = error, np.where(np.isfinite(x), noise, np.nan)
        significant[idx] = sig
        is_ref[idx[pick]] = True
        relative[idx] = rel
        se_missing[idx] = ~np.isfinite(se) | (not np.isfinite(se_ref))
        se_missing[idx[pick]] = not np.isfinite(se_ref)
        note[idx[~np.isfinite(x)]] = "x not finite"

    for name, values in cols.items():
        out[name] = values
    out["abs_error"] = np.abs(cols["error"])
    out["se_missing"] = se_missing
    out["significant"] = significant
    out["is_ref"] = is_ref
    out["relative"] = relative
    out["noise_sigmas"] = float(noise_sigmas)
    out["note"] = note
    return out


def pareto_front(cost, error) -> np.ndarray:
    """Mask of the non-dominated points when both cost and error are minimised.

    Point *i* is dominated when another point *j* has
    :math:`c_j \\le c_i` and :math:`e_j \\le e_i` with at least one strict
    inequality.  Points with a NaN (or infinite) cost or error are never on
    the front and dominate nothing.  Exact duplicates do not dominate each
    other, so both stay on the front.

    Parameters
    ----------
    cost, error : array_like
        One value per point, same length.

    Returns
    -------
    ndarray of bool
        True for the points on the front.
    """
    c = np.asarray(cost, dtype=float).ravel()
    e = np.asarray(error, dtype=float).ravel()
    if c.shape != e.shape:
        raise ValueError(f"cost and error differ in length ({c.size} != {e.size})")
    ok = np.isfinite(c) & np.isfinite(e)
    front = ok.copy()
    cv, ev = c[ok], e[ok]
    for i in np.flatnonzero(ok):
        le = (cv <= c[i]) & (ev <= e[i])
        lt = (cv < c[i]) | (ev < e[i])
        if np.any(le & lt):
            front[i] = False
    return front


# --------------------------------------------------------------------------- cost
def cost_scaling(records: pd.DataFrame) -> dict:
    """Measured scaling of the simulation cost with the particle count.

    Fits, in log-log over the distinct runs of the ``size`` knob (one row per
    knob value, the base case included),

    .. math:: \\frac{\\mathrm{sim\\_cpu\\_s}}{\\mathrm{sim\\_time}} = a N^b

    by ordinary least squares of :math:`\\ln` (cost rate) on :math:`\\ln N`.
    Only runs with a positive finite cost, simulated time and particle count
    enter.  With fewer than two distinct particle counts nothing is measured:
    the exponent is the linear-scaling assumption :math:`b = 1` (``measured``
    False) and the prefactor the geometric mean of rate/N over the usable
    runs (NaN when there are none).

    Parameters
    ----------
    records : DataFrame
        Records of **one** scene (input contract of the module).

    Returns
    -------
    dict
        ``exponent`` (b), ``exponent_se`` (standard error of b from the fit
        residuals; NaN with two points or when not measured), ``prefactor``
        (a, CPU-seconds per unit simulated time at N = 1), ``measured``,
        ``n_points`` (distinct usable runs).

    Raises
    ------
    ValueError
        When ``records`` holds more than one scene (their costs do not share
        a prefactor).
    """
    if "scene" in records and records["scene"].nunique() > 1:
        raise ValueError(f"cost_scaling needs the records of one scene, got {sorted(records['scene'].unique())}")
    size = records[records["knob"] == "size"].drop_duplicates(subset=["knob", "value"])
    rate = column_values(size, "sim_cpu_s") / column_values(size, "sim_time")
    N = column_values(size, "n_particles")
    ok = np.isfinite(rate) & (rate > 0) & np.isfinite(N) & (N > 0)
    lx, ly = np.log(N[ok]), np.log(rate[ok])
    k = int(ok.sum())
    if len(np.unique(lx)) < 2:
        prefactor = float(np.exp(np.mean(ly - lx))) if k else np.nan
        return dict(exponent=1.0, exponent_se=np.nan, prefactor=prefactor, measured=False, n_points=k)
    b, ln_a = np.polyfit(lx, ly, 1)
    if k > 2:
        resid = ly - (b * lx + ln_a)
        b_se = float(np.sqrt(np.sum(resid ** 2) / (k - 2) / np.sum((lx - lx.mean()) ** 2)))
    else:
        b_se = np.nan
    return dict(exponent=float(b), exponent_se=b_se, prefactor=float(np.exp(ln_a)), measured=True, n_points=k)


def extrapolate(cpu_s: float, n_particles: float, sim_time: float, scaling: Mapping, paper: Mapping) -> float:
    """Extrapolated CPU-seconds of a run at the paper's size and duration.

    .. math:: C' = C \\left(\\frac{N'}{N}\\right)^b \\frac{t'}{t}

    with :math:`C` the measured CPU-seconds of the run (``cpu_s``),
    :math:`N, t` its particle count and simulated time, :math:`N', t'` the
    paper's and :math:`b` = ``scaling["exponent"]`` (:func:`cost_scaling`).
    This is an **extrapolation**, not a measurement: it assumes the cost per
    particle-step follows the fitted power law far outside the fitted range,
    a fixed time step (so cost ∝ simulated time) and that post-processing,
    included in ``cpu_s``, scales like the simulation.  Quote it as an order
    of magnitude, and say whether ``scaling["measured"]`` was True.

    Parameters
    ----------
    cpu_s : float
        Measured CPU-seconds of the run.
    n_particles : float
        Particle count of the run.
    sim_time : float
        Simulated time of the run (scene units).
    scaling : mapping
        At least ``exponent``.
    paper : mapping
        ``n_particles`` and ``sim_time`` of the paper's run (same time units).

    Returns
    -------
    float
        CPU-seconds; NaN when an input is missing, not finite or not positive.
    """
    try:
        vals = [float(cpu_s), float(n_particles), float(sim_time), float(scaling["exponent"]),
                float(paper["n_particles"]), float(paper["sim_time"])]
    except (KeyError, TypeError, ValueError):
        return np.nan
    C, N, t, b, N_p, t_p = vals
    if not all(np.isfinite(vals)) or min(N, t, N_p, t_p) <= 0 or C < 0:
        return np.nan
    return float(C * (N_p / N) ** b * (t_p / t))


# --------------------------------------------------------------------------- tables
def _resolution(noise: float, p: float, relative: bool) -> tuple[bool, str]:
    """``(resolved, note)``: unresolved when the noise (one standard error) exceeds ``p``."""
    if np.isfinite(noise) and noise > p:
        return False, (f"noise ±{percent(noise)} % exceeds {percent(p)} %" if relative
                       else f"noise ±{noise:.3g} exceeds {p:g} (absolute)")
    return True, ""


def _paper_cpu_h(cpu_s, n_particles, sim_time, scene, scaling, paper) -> float:
    sc, pp = _per_scene(scaling, scene, "exponent"), _per_scene(paper, scene, "n_particles")
    if sc is None or pp is None:
        return np.nan
    return extrapolate(cpu_s, n_particles, sim_time, sc, pp) / 3600.0


def _cheapest(rows: pd.DataFrame) -> pd.Series:
    """The row with the lowest ``cpu_s`` (NaN last); ties go to the smaller error."""
    return rows.sort_values(["cpu_s", "abs_error"], na_position="last", kind="stable").iloc[0]


def within_table(errors: pd.DataFrame, tolerances: Sequence[float] = (0.05, 0.10), scaling: Mapping | None = None,
                 paper: Mapping | None = None) -> pd.DataFrame:
    """Cheapest setting of each knob within p of the finest setting.

    One row per (scene, observable, knob, tolerance p): among the settings of
    the knob whose ``abs_error`` <= p (the reference, error 0, always
    qualifies) the one with the lowest ``cpu_s``.  ``resolved`` is False when
    that row's noise (one standard error of the difference, relative) exceeds
    p: the statistics cannot then tell whether the setting is within p, and
    ``note`` says so.  Plus one row per (scene, knob, p) with ``observable``
    = ``"all"``: the cheapest setting at which every observable of the knob
    that has a finite reference is within p; its ``error`` is the signed
    error of the worst observable there, ``noise`` the largest noise,
    ``significant`` whether any difference is significant and ``resolved``
    whether every noise is <= p.

    Parameters
    ----------
    errors : DataFrame
        Output of :func:`knob_errors`.
    tolerances : sequence of float
        Tolerances p as fractions (0.05 = 5 %).
    scaling : mapping, optional
        :func:`cost_scaling` result, or a mapping scene -> such a result.
    paper : mapping, optional
        ``{"n_particles": N', "sim_time": t'}``, or a mapping scene -> such a
        dict.  With ``scaling`` it gives ``paper_cpu_h``
        (:func:`extrapolate`), else NaN.

    Returns
    -------
    DataFrame
        Columns ``scene, observable, label, knob, tolerance, value, cpu_s,
        cpu_h, error, noise, significant, resolved, paper_cpu_h, note,
        relative`` (``relative`` False: error, noise and p are absolute since
        :math:`x_{ref} = 0`).
    """
    rows = []

    def emit(scene, observable, label, knob, p, pick, note, relative=True, error=np.nan, noise=np.nan,
             significant=False, resolved=False):
        cpu_s = float(pick["cpu_s"]) if pick is not None else np.nan
        paper_h = (_paper_cpu_h(cpu_s, pick.get("n_particles", np.nan), pick.get("sim_time", np.nan), scene,
                                scaling, paper) if pick is not None else np.nan)
        rows.append(dict(scene=scene, observable=observable, label=label, knob=knob, tolerance=float(p),
                         value=float(pick["value"]) if pick is not None else np.nan, cpu_s=cpu_s,
                         cpu_h=cpu_s / 3600.0, error=error, noise=noise, significant=bool(significant),
                         resolved=bool(resolved), paper_cpu_h=paper_h, note=note, relative=bool(relative)))

    for (scene, knob), sk in errors.groupby(["scene", "knob"], sort=False):
        observables = list(dict.fromkeys(sk["observable"]))
        for p in tolerances:
            # per observable
            for obs in observables:
                g = sk[sk["observable"] == obs]
                label = str(g["label"].iloc[0]) if "label" in g else obs
                ok = g[np.isfinite(column_values(g, "abs_error")) & (column_values(g, "abs_error") <= p)]
                if ok.empty:
                    emit(scene, obs, label, knob, p, None, "no finite reference")
                    continue
                pick = _cheapest(ok)
                rel = bool(pick["relative"])
                resolved, note = _resolution(float(pick["noise"]), p, rel)
                notes = [note] if note else []
                if not rel:
                    notes.append("absolute error (x_ref = 0)")
                if bool(pick["is_ref"]):
                    notes.append("only the finest setting" if len(ok) == 1 else "finest setting (reference)")
                emit(scene, obs, label, knob, p, pick, "; ".join(notes), rel, float(pick["error"]),
                     float(pick["noise"]), pick["significant"], resolved)
            # every observable with a finite reference at once
            with_ref = [o for o in observables if np.isfinite(column_values(sk[sk["observable"] == o], "x_ref")).any()]
            if not with_ref:
                emit(scene, ALL, "all observables", knob, p, None, "no finite reference")
                continue
            sub = sk[sk["observable"].isin(with_ref)]
            best, best_cost = None, np.inf
            for value, gv in sub.groupby("value", sort=True):
                ae = gv.groupby("observable")["abs_error"].max()
                if set(ae.index) != set(with_ref) or not (np.isfinite(ae) & (ae <= p)).all():
                    continue
                cost = float(np.nanmin(column_values(gv, "cpu_s"))) if np.isfinite(column_values(gv, "cpu_s")).any() else np.inf
                if best is None or cost < best_cost:
                    best, best_cost = gv, cost
            if best is None:
                emit(scene, ALL, "all observables", knob, p, None, f"no setting has every observable within "
                                                                  f"{percent(p)} %")
                continue
            worst = best.iloc[int(np.argmax(column_values(best, "abs_error")))]
            pick = _cheapest(best)
            noise = float(np.nanmax(column_values(best, "noise"))) if np.isfinite(column_values(best, "noise")).any() else np.nan
            rel = bool(best["relative"].all())
            resolved, note = _resolution(noise, p, rel)
            notes = [note] if note else []
            if not rel:
                notes.append("some errors absolute (x_ref = 0)")
            if float(worst["abs_error"]) > 0:
                notes.append(f"worst: {worst['observable']}")
            emit(scene, ALL, "all observables", knob, p, pick, "; ".join(notes), rel, float(worst["error"]), noise,
                 bool(best["significant"].any()), resolved)
    return pd.DataFrame(rows, columns=TABLE_COLUMNS)


def summary_markdown(table: pd.DataFrame, tolerance: float = 0.05) -> str:
    """Markdown table of the :func:`within_table` rows at one tolerance.

    Columns: scene, observable, knob, cheapest setting, error ± noise (%),
    CPU-s, paper CPU-h (extrapolated) and the note.  The paper column is an
    extrapolation (:func:`extrapolate`), never a measurement.

    Parameters
    ----------
    table : DataFrame
        Output of :func:`within_table`.
    tolerance : float
        Which tolerance to show (fraction).

    Returns
    -------
    str
        A caption line and the table; a one-line message when no row matches.
    """
    rows = table[np.isclose(column_values(table, "tolerance"), tolerance)]
    caption = f"Cheapest setting within {percent(tolerance)} % of the finest setting of each knob"
    if rows.empty:
        return caption + ": no rows.\n"
    head = ["scene", "observable", "knob", "cheapest setting", "error ± noise [%]", "CPU-s",
            "paper CPU-h (extrapolated)", "note"]
    lines = [caption + ":", "", "| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for _, r in rows.iterrows():
        err, noise = float(r["error"]), float(r["noise"])
        if not np.isfinite(err):
            err_text = "n/a"
        elif bool(r.get("relative", True)):
            err_text = f"{100 * err:+.2g} ± {100 * noise:.2g}" if np.isfinite(noise) else f"{100 * err:+.2g}"
        else:
            err_text = f"{err:+.3g} ± {noise:.2g} (abs)" if np.isfinite(noise) else f"{err:+.3g} (abs)"
        value = float(r["value"])
        cpu, paper_h = float(r["cpu_s"]), float(r["paper_cpu_h"])
        obs = str(r["observable"]) if r["observable"] == ALL else str(r.get("label") or r["observable"])
        cells = [str(r["scene"]), obs, str(r["knob"]),
                 f"{value:g}" if np.isfinite(value) else "n/a", err_text,
                 f"{cpu:.3g}" if np.isfinite(cpu) else "n/a",
                 f"{paper_h:.3g}" if np.isfinite(paper_h) else "n/a",
                 str(r["note"] or "")]
        lines.append("| " + " | ".join(c.replace("|", "\\|") for c in cells) + " |")
    return "\n".join(lines) + "\n"
