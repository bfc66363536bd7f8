"""What a rung not run will cost, at the rate this ladder's own measured rungs ran at.

The cost model (:mod:`granflow.resources`) prices a case as atom-steps / rate. A rung without runs of its own
was priced at the reference rate, one number measured once on a dense bed of another contact law. A ladder's
measured rungs say what its scene costs: each row of ``ladder.csv`` keeps the atom-steps and time steps its
cases ran beside their CPU-hours (:func:`cost_columns`, from each case's ``status.json`` and LAMMPS logs).

Per pair style (``pair granular`` costs about twice ``gran/hooke/history`` per atom-step), :func:`measured_rates`
fits log(rate) = a + b log(N̄) across the measured rungs, N̄ the mean particle count per step (atom-steps /
steps). The cost of an atom-step grows with N: the heap's ran at 0.17-0.25 µs per atom-step with ~1k
particles mostly in flight, 0.64-0.72 µs at 20-35k in a bed and 0.80-0.83 µs at 87-112k (one rank, its
segments' logs). With fewer than :data:`MIN_RUNGS_FOR_SIZE` rungs, or their N̄ within a factor
:data:`MIN_SIZE_SPAN`, the rate is their pooled one (Σ atom-steps / Σ CPU-seconds, b = 0). The price's error
is quoted with it: each measured rung left out and priced by the others, the rms of priced over taken − 1
(:func:`leave_one_out`, listed in ``ladder.md`` by :func:`price_lines`). CPU-seconds are what the runs took,
on a machine doing other work too: an MPI rank spins while its partner waits for a core, so a two-rank run
beside other jobs takes more CPU-seconds per atom-step than alone (the heap's W = 0.23 m, 10 g/s rung, two
ranks: 375 CPU-s for a segment at ~21k particles alone, 518 and 573 for the next two at ~23k and ~25k beside
test runs, 2026-11-28). :func:`calibration` turns the rate at a rung's N̄
into the :class:`granflow.resources.Calibration` its plan is priced with; a rung that ran here keeps the rate
of its own runs, and a pair style no rung measured keeps the reference rate.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
import pandas as pd

from granflow.resources import Calibration, Rate

#: rungs (at least) and the spread of their mean particle counts (at least) for a rate that depends on N̄
MIN_RUNGS_FOR_SIZE = 3
MIN_SIZE_SPAN = 2.0
#: states of ``ladder.csv`` rows whose CPU-hours are one rung's own cases (a pool's repeat its rungs')
_OWN_RUNS = ("run",)
_NOT_OWN = ("run (pooled",)
#: how the source of a ladder's measured rate starts
_SOURCE = "measured on this ladder's rungs"


def cost_columns(cases: list[dict]) -> dict:
    """A rung's ``atom_steps``, ``steps`` (sums over its cases, NaN unless every case says) and ``pair_style``
    from its case summaries (:func:`granflow.validation.case_summary`)."""
    def total(key: str) -> float:
        vals = [c.get(key) for c in cases]
        ok = cases and all(isinstance(v, (int, float)) and math.isfinite(v) and v > 0 for v in vals)
        return float(sum(vals)) if ok else float("nan")

    styles = sorted({str(c["pair_style"]) for c in cases if c.get("pair_style")})
    return {"atom_steps": total("atom_steps"), "steps": total("steps"), "pair_style": ", ".join(styles) or np.nan}


@dataclass(frozen=True)
class LadderRate:
    """Atom-steps per CPU-second of one pair style, ``exp(log_a) N̄^b``, fitted across ``rungs``; ``error`` the
    relative error of a price at it: with three rungs or more the rms of each rung's price, the rung left out,
    against what it took (:func:`leave_one_out`); with two their rates' spread; NaN with one."""

    pair_style: str
    rungs: tuple[str, ...]
    log_a: float
    b: float
    error: float
    n_lo: float
    n_hi: float

    def at(self, n_mean: float) -> float:
        return float(math.exp(self.log_a) * n_mean ** self.b) if self.b else float(math.exp(self.log_a))

    def _error_words(self) -> str:
        if len(self.rungs) == 1:
            return "one rung: its error unknown"
        if len(self.rungs) == 2:
            return f"the two rungs' rates spread ±{100 * self.error:.0f} %"
        return f"±{100 * self.error:.0f} %, each rung left out and priced by the others"

    def short(self, n_mean: float) -> str:
        """The rate in a few words, for a planned rung's state in ``ladder.csv``."""
        ran = f"as rung {self.rungs[0]} ran" if len(self.rungs) == 1 else f"as rungs {', '.join(self.rungs)} ran"
        return f"{self.at(n_mean) / 1e6:.3g} Matom-step per CPU-s at {n_mean:,.0f} particles, {ran} ({self._error_words()})"

    def source(self, n_mean: float) -> str:
        form = (f"log-linear in the mean particle count (exponent {self.b:+.2f}) across their "
                f"{self.n_lo:,.0f}-{self.n_hi:,.0f}" if self.b else "pooled")
        return (f"{_SOURCE} {', '.join(self.rungs)} ({self.pair_style}; {form}): "
                f"{self.at(n_mean) / 1e6:.3g} Matom-step per CPU-s at {n_mean:,.0f} particles ({self._error_words()})")


def _measured_rows(df: pd.DataFrame) -> pd.DataFrame:
    """One row per measured rung that kept its atom-steps, steps, pair style and CPU-hours (numbers as floats)."""
    need = {"atom_steps", "steps", "pair_style", "cpu_hours", "state", "rung"}
    if df.empty or not need <= set(df.columns):
        return pd.DataFrame(columns=sorted(need))
    state = df["state"].astype(str)
    rows = df[state.str.startswith(_OWN_RUNS) & ~state.str.startswith(_NOT_OWN)].drop_duplicates("rung")
    rows = rows.assign(**{k: pd.to_numeric(rows[k], errors="coerce") for k in ("atom_steps", "steps", "cpu_hours")})
    ok = (rows["atom_steps"] > 0) & (rows["steps"] > 0) & (rows["cpu_hours"] > 0) & rows["pair_style"].notna()
    return rows[ok & ~rows["pair_style"].astype(str).str.contains(",")]


def _fit(style: str, g: pd.DataFrame) -> LadderRate:
    ast, steps, cpu = (g[k].to_numpy(float) for k in ("atom_steps", "steps", "cpu_hours"))
    n_mean, rate = ast / steps, ast / (3600 * cpu)
    if len(g) >= MIN_RUNGS_FOR_SIZE and n_mean.max() >= MIN_SIZE_SPAN * n_mean.min():
        b, log_a = np.polyfit(np.log(n_mean), np.log(rate), 1)
    else:
        b, log_a = 0.0, float(np.log(ast.sum() / (3600 * cpu.sum())))
    spread = float(np.std(np.log(rate) - log_a, ddof=1)) if len(g) == 2 else float("nan")
    return LadderRate(style, tuple(g["rung"]), float(log_a), float(b), spread, float(n_mean.min()), float(n_mean.max()))


def leave_one_out(style: str, g: pd.DataFrame) -> list[tuple[str, float, float]]:
    """Each rung of ``g`` (one pair style's measured rows) priced at the rate of the others, at its mean
    particle count: ``(rung, CPU-hours priced, CPU-hours taken)``."""
    out = []
    for i in g.index:
        r, rate = g.loc[i], _fit(style, g.drop(index=i))
        out.append((str(r["rung"]), float(r["atom_steps"] / rate.at(r["atom_steps"] / r["steps"]) / 3600),
                    float(r["cpu_hours"])))
    return out


def measured_rates(df: pd.DataFrame) -> dict[str, LadderRate]:
    """Per pair style, the rate of the ladder's measured rungs (rows of ``ladder.csv`` or of the table being
    written) that kept their atom-steps, steps and CPU-hours; a pool's rows are left out (its CPU-hours are
    its rungs')."""
    out = {}
    for style, g in _measured_rows(df).groupby("pair_style"):
        rate = _fit(str(style), g)
        if len(g) >= MIN_RUNGS_FOR_SIZE:
            errors = [priced / taken - 1 for _, priced, taken in leave_one_out(str(style), g)]
            rate = replace(rate, error=float(np.sqrt(np.mean(np.square(errors)))))
        out[str(style)] = rate
    return out


def price_lines(df: pd.DataFrame) -> str:
    """How far the rate prices the rungs it comes from, each left out in turn (:func:`leave_one_out`), per pair
    style with three measured rungs or more. For ``ladder.md``; empty without such rungs."""
    rows = _measured_rows(df)
    lines = []
    for style, g in rows.groupby("pair_style"):
        if len(g) < MIN_RUNGS_FOR_SIZE:
            continue
        parts = [f"{rung} {priced:.3g} against {taken:.3g} ({100 * (priced / taken - 1):+.0f} %)"
                 for rung, priced, taken in leave_one_out(str(style), g)]
        rate = measured_rates(g)[str(style)]
        lines.append(f"- {style}: {rate.source(float(g['atom_steps'].sum() / g['steps'].sum()))}. Each rung left "
                     f"out and priced by the others (CPU-h priced against taken): " + "; ".join(parts) + ".")
    if not lines:
        return ""
    return ("Prices (rungs not run and planned ones are priced at the rate the measured rungs ran at, "
            "`granflow/ladder_rates.py`):\n\n" + "\n".join(lines) + "\n\n")


def calibration(plan: dict, scene: str, rates: dict[str, LadderRate]) -> Calibration | None:
    """The calibration that prices a rung's plan (:func:`granflow.resources.plan_campaign`) at its ladder's
    measured rate, or None when the rung ran here (its own runs calibrate it) or no rung of its pair style
    was measured."""
    rows = plan["rows"]
    if not rows or not str(plan["rates"].get(scene, "")).startswith("reference"):
        return None
    style = rows[0]["pair_style"]
    if style not in rates or any(r["pair_style"] != style for r in rows):
        return None
    n_mean = sum(r["atom_steps"] for r in rows) / max(1, sum(r["steps"] for r in rows))
    rate = rates[style]
    return Calibration(rates={scene: Rate(rate.at(n_mean), rate.source(n_mean), runs=len(rate.rungs))})


def planned_state(plan: dict, scene: str, rates: dict[str, LadderRate]) -> str:
    """A planned rung's state in ``ladder.csv``: priced by the cost model, at which rate."""
    rows = plan["rows"]
    if not rows or rows[0]["pair_style"] not in rates or not str(plan["rates"].get(scene, "")).startswith(_SOURCE):
        return "planned (cost model, not run)"
    n_mean = sum(r["atom_steps"] for r in rows) / max(1, sum(r["steps"] for r in rows))
    return f"planned (cost model at {rates[rows[0]['pair_style']].short(n_mean)}; not run)"


__all__ = ["LadderRate", "cost_columns", "measured_rates", "calibration", "planned_state", "price_lines",
           "leave_one_out"]
