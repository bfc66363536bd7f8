"""What accuracy costs: how many CPU-hours bring a headline within P % of its paper, answered from the record.

``granflow plan --target 'SCENE:QUANTITY:P%'`` (:func:`answer`) reads the committed ladder of SCENE
(``validation/<scene>/ladder.csv``, its file ``config/ladders/<scene>.yaml``) and answers, in this order:

1. **measured**: the cheapest rung that ran whose value, with its combined error, lies within P of the paper's
   value or range (:func:`excess`: the far edge of ours ± error, outside the paper's range, relative to the
   edge it passes, is at most P); its measured CPU-hours;
2. **extrapolated**: else the ladder's ``series:`` (rungs along one knob, a straight line in its x,
   :func:`granflow.ladder.series_fit`) read from its rungs toward its points ``at`` (the paper's size): the
   cheapest x where the line, with its error, is within P, priced by a power law through the series' measured
   CPU-hours (:func:`cost_along`);
3. **cannot answer**, with the reasons: the measured errors alone exceed P (noise), no series for the
   quantity, a rung nearer the paper planned or not yet run, a paper value of 0 (no relative difference).

The combined error is stat ⊕ syst ⊕ run-to-run, the last from a replicate rung (another seed, nothing else:
one run's scatter |Δ|/√2) where the ladder has one; without one every rung is one sample, and the answer says
so. Wall-hours on N cores (``--cores N``) follow the plan's scaling (:mod:`granflow.resources`): one MPI rank
per 10,000 particles of a case at most, the rung's cases side by side, parallel efficiency 0.7 on more than
one rank.

.. math:: \\text{excess} = \\max\\Big(\\frac{lo - (y - e)}{|lo|},\\ \\frac{(y + e) - hi}{|hi|},\\ 0\\Big) \\le P
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd

from .config import ConfigError
from .schema import PROJECT_ROOT
from .ladder import LADDER_DIR, load_ladder, series_fit
from .resources import PARTICLES_PER_RANK, parallel_efficiency, suggested_ranks

#: points along a series searched for the cheapest setting within P
GRID = 2001


def ladders(root: Path = PROJECT_ROOT) -> dict[str, tuple[Path, Path]]:
    """Every scene with a committed ladder: ``scene -> (its ladder file, its ladder.csv)``."""
    out = {}
    for path in sorted((Path(root) / LADDER_DIR).glob("*.yaml")):
        record = Path(root) / "validation" / path.stem / "ladder.csv"
        if record.exists():
            out[path.stem] = (path, record)
    return out


def rung_headlines(ladder: dict) -> dict[str, list[str]]:
    """A rung's or pool's own ``headlines:`` (quantities it alone reads) -> the rungs that name it."""
    out: dict[str, list[str]] = {}
    for item in ladder.get("rungs", []) + ladder.get("pools", []) + ladder.get("planned", []):
        for head in item.get("headlines", []):
            out.setdefault(head, []).append(item["name"])
    return out


def parse_target(text: str, known: dict[str, pd.DataFrame],
                 headlines: dict[str, dict[str, list[str]]] | None = None) -> tuple[str, str, float]:
    """``SCENE:QUANTITY:P%`` -> (scene, the one quantity of its ladder QUANTITY names, P as a fraction); the
    quantity is any unique part of its name (case ignored; it may itself hold ':'), a quantity of the scene's
    ``ladder.csv`` or a rung's own headline that no row holds yet (``headlines``: scene -> :func:`rung_headlines`);
    where a part names several, the one that is not a rung's or pool's own headline wins.
    Refused (:class:`ConfigError`) naming the key, the value and what is allowed."""
    parts = str(text).split(":")
    if len(parts) < 3:
        raise ConfigError(f"--target = {text!r}: allowed SCENE:QUANTITY:P%, e.g. 'channel:u_max:1%'")
    scene, quantity, p_text = parts[0].strip(), ":".join(parts[1:-1]).strip(), parts[-1].strip()
    if scene not in known:
        raise ConfigError(f"--target = {text!r}: scene = {scene!r} has no committed ladder: allowed "
                          f"{', '.join(sorted(known)) or 'none'} (validation/<scene>/ladder.csv)")
    try:
        p = float(p_text[:-1] if p_text.endswith("%") else p_text)
    except ValueError:
        p = float("nan")
    if not (math.isfinite(p) and p > 0):
        raise ConfigError(f"--target = {text!r}: P = {p_text!r}: allowed a positive percentage, e.g. 5%")
    table = known[scene]
    costed = table[~table["state"].astype(str).str.startswith("contrast")] if "state" in table else table   # no cost
    rows = [q for q in dict.fromkeys(costed["quantity"].dropna())]
    # a rung's own headline that no row holds yet is matched only where the rows' quantities match none
    waiting = [h for h in (headlines or {}).get(scene, {}) if not any(str(q).startswith(h) for q in rows)]
    found, names = [], rows
    for names in (rows, waiting):
        found = [q for q in names if q.lower() == quantity.lower()] or \
                [q for q in names if quantity and quantity.lower() in q.lower()]
        if found:
            break
    if len(found) > 1:   # the ladder's own headlines before what only a rung or pool reads ('u_max' is u_max/u_slip)
        own = [q for q in found if not any(str(q).startswith(h) for h in (headlines or {}).get(scene, {}))]
        found = own if len(own) == 1 else found
    names = rows + waiting if not found else names
    if len(found) != 1:
        what = "names more than one" if found else "names none"
        raise ConfigError(f"--target = {text!r}: quantity = {quantity!r} {what} of the {scene} ladder's quantities: "
                          f"allowed a unique part of one of {'; '.join(map(repr, found or names))}")
    return scene, found[0], p / 100.0


def excess(ours: float, error: float, lo: float, hi: float) -> float:
    """How far ours ± error reaches outside the paper's range [lo, hi], relative to the edge it passes
    (0 inside; inf past an edge at 0, where a relative difference has no size)."""
    out = 0.0
    for reach, edge in ((lo - (ours - error), lo), ((ours + error) - hi, hi)):
        if reach > 0 and math.isfinite(edge):
            out = max(out, reach / abs(edge) if edge else math.inf)
    return out


def run_to_run(df: pd.DataFrame, ladder: dict, quantity: str) -> float:
    """One run's scatter of ``quantity`` from the ladder's replicate rungs: |Δ|/√2 of each replicate against the
    first rung, the largest (NaN without a replicate)."""
    first = ladder["rungs"][0]["name"]
    values = df[df["quantity"] == quantity].drop_duplicates("rung").set_index("rung")["ours"]
    spreads = [abs(values[r["name"]] - values[first]) / math.sqrt(2) for r in ladder["rungs"]
               if r.get("replicate") and r["name"] in values and first in values]
    spreads = [s for s in spreads if math.isfinite(s)]
    return max(spreads) if spreads else float("nan")


def _particles(cell) -> list[int]:
    return [int(p.replace(",", "")) for p in str(cell).split(", ") if p.replace(",", "").isdigit()]


def wall_hours(cpu_hours: float, cores: int, particles: list[int] = ()) -> tuple[float, int]:
    """(wall-hours, cores used) of ``cpu_hours`` on ``cores``: the cases side by side, each on at most one rank
    per 10,000 particles (all cores when the particles are not known), the plan's parallel efficiency."""
    used = min(cores, sum(suggested_ranks(n, max_ranks=cores) for n in particles)) if particles else cores
    used = max(1, used)
    return cpu_hours / (used * parallel_efficiency(used)), used


def cost_along(fit_rungs: list[str], x: np.ndarray, df: pd.DataFrame):
    """CPU-hours along a series: a power law cpu = a x^k through its rungs' measured CPU-hours (log-log least
    squares), or None with fewer than two positive points."""
    cpu = df.drop_duplicates("rung").set_index("rung")["cpu_hours"].reindex(fit_rungs).to_numpy(float)
    ok = np.isfinite(cpu) & (cpu > 0) & (x > 0)
    if ok.sum() < 2:
        return None
    k, log_a = np.polyfit(np.log(x[ok]), np.log(cpu[ok]), 1)
    return lambda x0: float(np.exp(log_a) * x0 ** k) if x0 > 0 else math.inf


def _setting(series: dict, x0: float) -> str:
    label = str(series["x"])
    name = label[2:].split(" ")[0] if label.startswith("1/") else ""
    return f"{label} = {x0:.3g}" + (f" ({name} ≈ {1 / x0:.3g})" if name and x0 > 0 else "")


def extrapolate(df: pd.DataFrame, ladder: dict, quantity: str, p: float, r2r: float) -> tuple[dict | None, str]:
    """The cheapest setting along one of the ladder's series where the line, with its error (⊕ run-to-run), is
    within ``p``: ``({series, x, setting, value, error, cpu_hours}, "")`` or ``(None, why not)``."""
    why = []
    for series in ladder.get("series") or []:
        fit = series_fit(df, series, quantity)
        if fit is None:
            why.append(f"its series along {series['knob']} has fewer than three measured rungs")
            continue
        price = cost_along(fit.rungs, fit.x, df)
        ends = [float(v) for v in series["at"].values()] + list(fit.x)
        best = None
        for x0 in np.linspace(min(ends), max(ends), GRID):
            y0, e0 = fit.at(x0)
            e0 = math.hypot(e0, r2r) if math.isfinite(r2r) else e0
            cpu = price(x0) if price else math.nan
            if excess(y0, e0, *fit.paper) <= p and math.isfinite(cpu) and (best is None or cpu < best["cpu_hours"]):
                best = {"series": series["knob"], "x": float(x0), "setting": _setting(series, x0), "value": y0,
                        "error": e0, "cpu_hours": cpu, "rungs": fit.rungs, "chi2": fit.chi2}
        if best:
            return best, ""
        y0, e0 = fit.at(min(series["at"].values()))
        why.append(f"its series along {series['knob']} (through {', '.join(fit.rungs)}) is not within it anywhere "
                   f"up to {_setting(series, min(series['at'].values()))} ({y0:.4g} ± {e0:.2g})"
                   + ("" if price else "; fewer than two priced rungs"))
    return None, "; ".join(why) or "no series: the ladder turns no knob by steps to extrapolate along"


def answer(target: str, cores: int, root: Path = PROJECT_ROOT) -> dict:
    """One answer to ``SCENE:QUANTITY:P%`` (:func:`parse_target`) as a dict with ``line``, its text."""
    found = ladders(root)
    tables = {scene: pd.read_csv(record) for scene, (_, record) in found.items()}
    loaded = {scene: load_ladder(path) for scene, (path, _) in found.items()}
    heads = {scene: rung_headlines(lad) for scene, lad in loaded.items()}
    scene, quantity, p = parse_target(target, tables, heads)
    df, ladder = tables[scene], loaded[scene]
    ran = df[(df["quantity"] == quantity) & df["state"].astype(str).str.startswith("run")
             & np.isfinite(df["ours"].astype(float))]
    # a diagnostic row (its validation gives no verdict against the paper, e.g. a q* exponent over two feed rates)
    # is no answer to "within P of the paper"
    diagnostic = ran["kind"].astype(str).eq("diagnostic") if "kind" in ran else pd.Series(False, index=ran.index)
    rows, only_diagnostic = ran[~diagnostic], sorted(set(ran.loc[diagnostic, "rung"]))
    r2r = run_to_run(df, ladder, quantity)
    samples = ("run-to-run from a replicate rung included" if math.isfinite(r2r)
               else "one sample each: no replicate rung, run-to-run not included")
    out = {"target": target, "scene": scene, "quantity": quantity, "p_percent": 100 * p, "cores": cores,
           "run_to_run": None if not math.isfinite(r2r) else r2r}
    head = f"{scene} '{quantity}' within {100 * p:g} %"
    measured = []
    for _, r in rows.iterrows():
        err = math.hypot(*(v for v in (r["stat"], r["syst"], r2r) if math.isfinite(v)))
        measured.append((excess(r["ours"], err, r["paper_lo"], r["paper_hi"]), err, r))
    within = sorted((m for m in measured if m[0] <= p), key=lambda m: m[2]["cpu_hours"])
    if within:
        x, err, r = within[0]
        wall, used = wall_hours(r["cpu_hours"], cores, _particles(r.get("particles")))
        out.update(answer="measured", rung=r["rung"], knob=r["knob"], ours=r["ours"], error=err,
                   paper=r["paper"], excess=x, cpu_hours=r["cpu_hours"], wall_hours=wall, cores_used=used)
        out["line"] = (f"{head}: measured, rung {r['rung']}: {r['ours']:.4g} ± {err:.2g} against the paper's "
                       f"{r['paper']} (reaches {100 * x:.2g} % outside it; {samples}), {r['cpu_hours']:.3g} CPU-h "
                       f"measured, {wall:.3g} wall-h on {used} of {cores} cores")
        if str(r["state"]).startswith("run (kept"):   # granflow.ladder.committed_rows: an earlier code's numbers
            out["line"] += f" ({r['state'][5:-1]}: its errors are those of the code that measured it)"
        return out
    best, why = extrapolate(df, ladder, quantity, p, r2r)
    if best:
        wall, used = wall_hours(best["cpu_hours"], cores)
        out.update(answer="extrapolated", **best, wall_hours=wall, cores_used=used)
        out["line"] = (f"{head}: extrapolated along {best['series']} (a straight line through "
                       f"{', '.join(best['rungs'])}, χ²/ν = {best['chi2']:.2f}; assumed, not measured) to "
                       f"{best['setting']}: {best['value']:.4g} ± {best['error']:.2g}; ~{best['cpu_hours']:.3g} CPU-h "
                       f"(a power law through the series' measured CPU-hours), {wall:.3g} wall-h on {cores} cores")
        return out
    out.update(answer="cannot answer", reasons=reasons(df, ladder, quantity, p, measured, why))
    if only_diagnostic:
        out["reasons"].append(f"{', '.join(only_diagnostic)} measure{'s' if len(only_diagnostic) == 1 else ''} it "
                              "only as a diagnostic (no verdict against the paper)")
    out["line"] = f"{head}: cannot answer: " + "; ".join(out["reasons"])
    return out


def reasons(df: pd.DataFrame, ladder: dict, quantity: str, p: float, measured: list, why: str) -> list[str]:
    """Why neither a measured rung nor the series answers: noise, a paper value of 0, no or no good series, and
    the rungs nearer the paper's setup that are planned or not run (their CPU-hours)."""
    out = []
    holders = rung_headlines(ladder).get(quantity, [])
    if holders and not (df["quantity"] == quantity).any():
        states = df.drop_duplicates("rung").set_index("rung")["state"].astype(str)
        return ["no rung measured it: it is the headline of " + ", ".join(
            f"{r} ({states.get(r, 'not in ladder.csv')})" for r in holders)
                + f" (priced by `granflow plan --config {LADDER_DIR}/{ladder['scene']}.yaml`)"]
    if not measured:
        out.append("no rung measured it")
    elif all(not math.isfinite(m[0]) for m in measured):
        out.append("the paper's value is 0 where ours lies: a difference from it has no relative size")
    else:
        least = min(measured, key=lambda m: m[1] / max(abs(m[2]["ours"]), 1e-300))
        rel = least[1] / abs(least[2]["ours"]) if least[2]["ours"] else math.inf
        if rel > p:
            out.append(f"noise: the smallest combined error of a measured rung ({least[2]['rung']}) is "
                       f"{100 * rel:.2g} % of its value, above {100 * p:g} %")
        else:
            out.append(f"no measured rung is within it (nearest {min(m[0] for m in measured) * 100:.2g} % outside)")
    out.append(why)
    nearest = min((m[2]["from_paper"] for m in measured), default=math.inf)
    state = df["state"].astype(str)
    later = df[(df["from_paper"] <= nearest) & ~state.str.startswith(("run", "contrast"))].drop_duplicates("rung")
    if len(later):
        out.append("rungs as near the paper's setup or nearer, not run: " + ", ".join(
            f"{r['rung']} ({'planned, ' if str(r['state']).startswith('planned') else ''}"
            + (f"{r['cpu_hours']:.3g} CPU-h)" if math.isfinite(r["cpu_hours"]) else "not priced)")
            for _, r in later.iterrows()))
    return out


def format_answers(answers: list[dict]) -> str:
    return "\n".join(a["line"] for a in answers)


__all__ = ["answer", "parse_target", "rung_headlines", "excess", "run_to_run", "wall_hours", "cost_along", "extrapolate", "reasons",
           "ladders", "format_answers", "PARTICLES_PER_RANK"]
