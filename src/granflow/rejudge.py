"""A committed record judged again by today's rules, when its runs are gone.

The numbers stay as measured; what changes is how they are judged: each check takes its scene's
kind (:attr:`~granflow.scene_base.Scene.check_kinds`) and today's verdict
(:func:`granflow.verdicts.verdict`: kinds, ``not resolved``, ``differs`` only with replicates), the
checks the scene makes from the record's own profiles (:meth:`Scene.profile_checks`, e.g. the silo's
v_c² linearity from ``profiles/sweep.csv``) are made again by the same code (but those the record pooled
over replicates: its profiles are the first replicate's), and each case names its seed. ``summary.json`` says so under ``rejudged`` (commit, date, what was done); ``checks.csv`` is
rewritten. Everything else of the record (profiles, figures, logs) is left as it is.
"""
from __future__ import annotations

import datetime
import json
from dataclasses import asdict, fields
from pathlib import Path

import pandas as pd

from . import provenance, registry, replicates
from .validation import Check, _clean

#: what a rejudged record says it is
HOW = ("judged again without rerunning: the numbers as measured at the record's commits, each check's kind "
       "and verdict by the rules of the commit named here, the profile checks recomputed from profiles/ (but "
       "those pooled over replicates, kept as measured: profiles/ holds the first replicate's)")


def _check(entry: dict, kinds: dict[str, str]) -> Check:
    """A recorded check as a :class:`Check` of its scene's kind (NaN for a missing number)."""
    init = {f.name for f in fields(Check) if f.init}
    args = {k: v for k, v in entry.items() if k in init}
    for key in ("ours", "error", "syst", "run_to_run"):
        args[key] = float("nan") if args.get(key) is None else args[key]
    if args.get("paper_range") is not None:  # JSON keeps an open end (±inf) as null
        lo, hi = args["paper_range"]
        args["paper_range"] = (float("-inf") if lo is None else lo, float("inf") if hi is None else hi)
    args["kind"] = kinds.get(entry["quantity"], entry.get("kind") or "comparison")
    args["n_replicates"] = int(entry.get("n_replicates") or 1)
    return Check(**args)


def rejudge(folder: Path, scene_name: str) -> dict:
    """Rewrite ``folder/summary.json`` and ``folder/checks.csv`` by today's rules; return the summary."""
    folder = Path(folder)
    scene = registry.get(scene_name)
    summary = json.loads((folder / "summary.json").read_text())
    profiles = {p.stem: pd.read_csv(p) for p in sorted((folder / "profiles").glob("*.csv"))}
    # the profiles are the first replicate's: a row the record pooled over replicates (its run-to-run scatter
    # among them) is not made again from one, but kept as measured and judged by today's rules
    pooled = {c["quantity"] for c in summary["checks"] if int(c.get("n_replicates") or 1) > 1}
    remade = [c for c in scene.profile_checks(profiles) if c.quantity not in pooled]
    names = {c.quantity for c in remade}
    checks = [_check(c, scene.check_kinds) for c in summary["checks"] if c["quantity"] not in names]
    checks += [_check(asdict(c), scene.check_kinds) for c in remade]
    for c in summary["cases"]:
        seed = replicates.seed_of(c["dir"]) or (c.get("case") or {}).get("seed")
        c["seed"] = seed if isinstance(seed, int) or seed is None else int(seed)
    for c in summary["cases"]:
        c["seeds"] = [o["seed"] for o in summary["cases"]
                      if replicates.base_of(o["dir"]) == replicates.base_of(c["dir"])]
    git = provenance.git_state()
    summary["paper"] = scene.paper  # cited by authors, year and journal
    summary["checks"] = [asdict(c) for c in checks]
    summary["rejudged"] = {"commit": git["commit"], "date": datetime.date.today().isoformat(), "how": HOW}
    pd.DataFrame(summary["checks"], columns=[f.name for f in fields(Check)]).to_csv(folder / "checks.csv", index=False)
    (folder / "summary.json").write_text(json.dumps(_clean(summary), indent=1, ensure_ascii=False) + "\n")
    return summary


def changed_verdicts(before: dict, after: dict) -> list[tuple[str, str, str, str]]:
    """``(quantity, case, verdict before, verdict after)`` of every check whose verdict changed or is new."""
    old = {(c["quantity"], c["case"]): c["verdict"] for c in before["checks"]}
    out = []
    for c in after["checks"]:
        was = old.get((c["quantity"], c["case"]), "(new)")
        if was != c["verdict"]:
            out.append((c["quantity"], c["case"], was, c["verdict"]))
    return out
