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
:data:`MIN_SIZE_SPAN`, the rate is their pooled one (Σ atom-steps / Σ CPU-seconds, b = 0). The rungs' scatter
about the line (rms of log rate) is quoted with the price. :func:`calibration` turns the rate at a rung's N̄
into the :class:`granflow.resources.Calibration` its plan is priced with; a rung that ran here keeps the rate
of its own runs, and a pair style no rung measured keeps the reference rate.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

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
    """Atom-steps per CPU-second of one pair style, ``exp(log_a) N̄^b``, fitted across ``rungs``."""

    pair_style: str
    rungs: tuple[str, ...]
    log_a: float
    b: float
    scatter: float          # rms of log(rate) about the line (0 with one rung)
    n_lo: float
    n_hi: float

    def at(self, n_mean: float) -> float:
        return float(math.exp(self.log_a) * n_mean ** self.b) if self.b else float(math.exp(self.log_a))

    def short(self, n_mean: float) -> str:
        """The rate in a few words, for a planned rung's state in ``ladder.csv``."""
        ran = (f"as rung {self.rungs[0]} ran" if len(self.rungs) == 1 else
               f"as rungs {', '.join(self.rungs)} ran (±{100 * self.scatter:.0f} %)")
        return f"{self.at(n_mean) / 1e6:.3g} Matom-step per CPU-s at {n_mean:,.0f} particles, {ran}"

    def source(self, n_mean: float) -> str:
        form = (f"log-linear in the mean particle count (exponent {self.b:+.2f}) across their "
                f"{self.n_lo:,.0f}-{self.n_hi:,.0f}" if self.b else "pooled")
        return (f"{_SOURCE} {', '.join(self.rungs)} ({self.pair_style}; {form}): "
                f"{self.at(n_mean) / 1e6:.3g} Matom-step per CPU-s at {n_mean:,.0f} particles "
                + (f"(rungs scatter ±{100 * self.scatter:.0f} % about it)" if len(self.rungs) > 1 else "(one rung)"))


def measured_rates(df: pd.DataFrame) -> dict[str, LadderRate]:
    """Per pair style, the rate of the ladder's measured rungs (rows of ``ladder.csv`` or of the table being
    written) that kept their atom-steps, steps and CPU-hours; a pool's rows are left out (its CPU-hours are
    its rungs')."""
    need = {"atom_steps", "steps", "pair_style", "cpu_hours", "state", "rung"}
    if df.empty or not need <= set(df.columns):
        return {}
    state = df["state"].astype(str)
    rows = df[state.str.startswith(_OWN_RUNS) & ~state.str.startswith(_NOT_OWN)].drop_duplicates("rung")
    num = {k: pd.to_numeric(rows[k], errors="coerce") for k in ("atom_steps", "steps", "cpu_hours")}
    ok = (num["atom_steps"] > 0) & (num["steps"] > 0) & (num["cpu_hours"] > 0) & rows["pair_style"].notna()
    out = {}
    for style, g in rows[ok].groupby("pair_style"):
        if "," in str(style):
            continue
        ast, steps, cpu = (num[k][g.index].to_numpy(float) for k in ("atom_steps", "steps", "cpu_hours"))
        n_mean, rate = ast / steps, ast / (3600 * cpu)
        x, y = np.log(n_mean), np.log(rate)
        if len(g) >= MIN_RUNGS_FOR_SIZE and n_mean.max() >= MIN_SIZE_SPAN * n_mean.min():
            b, log_a = np.polyfit(x, y, 1)
            resid = y - (log_a + b * x)
            scatter = float(np.sqrt(np.sum(resid ** 2) / (len(g) - 2)))
        else:
            b, log_a = 0.0, float(np.log(ast.sum() / (3600 * cpu.sum())))
            scatter = float(np.std(y - log_a, ddof=1)) if len(g) > 1 else 0.0
        out[str(style)] = LadderRate(str(style), tuple(g["rung"]), float(log_a), float(b), scatter,
                                     float(n_mean.min()), float(n_mean.max()))
    return out


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


__all__ = ["LadderRate", "cost_columns", "measured_rates", "calibration", "planned_state"]
