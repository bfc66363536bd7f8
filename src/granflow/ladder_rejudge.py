"""A committed ladder's rows judged again by today's rules, and the states a ladder row can be measured in.

:func:`rejudge` gives each measured row of a ``ladder.csv`` the verdict its own numbers earn today, without
the runs (as ``tools/rejudge_record.py`` does for a record); :data:`MEASURED` names the states of measured rows
(:mod:`granflow.ladder` writes them).
"""
from __future__ import annotations

import numpy as np
import pandas as pd

from granflow import registry
from granflow.verdicts import verdict

#: how a contrast row's state starts (not "run": its rows are no rung's cost, so no picture or plan reads them)
CONTRAST = "contrast:"
#: the states of measured rows: a rung's or pool's (``run``) and a contrast's
MEASURED = ("run", CONTRAST)


def rejudge(df: pd.DataFrame, ladder: dict) -> pd.DataFrame:
    """The committed ladder's rows judged by today's rules without the runs (as tools/rejudge_record.py does
    for a record): each measured row's verdict from its numbers, of its scene's kind (``check_kinds``: a
    diagnostic gets no verdict; else the row's ``kind``, a check's own), against the paper's range (open
    on one side where a bound is infinite) and the paper's own error (``paper_error``); a row with ``n_replicates`` and ``run_to_run`` (a rung whose cases pooled
    several seeds) is judged with them, one without as one run (a replicate rung is its own row)."""
    kinds = registry.get(ladder["scene"]).check_kinds
    out = df.copy()
    for i, r in out.iterrows():
        if not str(r["state"]).startswith(MEASURED):
            continue
        # a range may be open on one side ("> 0": hi = inf); a row of before the paper_error column has none
        bounds = pd.to_numeric(pd.Series([r["paper_lo"], r["paper_hi"]]), errors="coerce")
        rng = tuple(bounds) if bounds.notna().all() and np.isfinite(bounds).any() else None
        pe = pd.to_numeric(r.get("paper_error", np.nan), errors="coerce")
        paper_error = float(pe) if pd.notna(pe) else 0.0
        syst = float(r["syst"]) if pd.notna(r["syst"]) else float("nan")
        stat = float(r["stat"]) if pd.notna(r["stat"]) else float("nan")
        rtr = float(r["run_to_run"]) if pd.notna(r.get("run_to_run", np.nan)) else float("nan")
        n = int(r["n_replicates"]) if pd.notna(r.get("n_replicates", np.nan)) else 1
        kind = r["kind"] if isinstance(r.get("kind"), str) else "comparison"   # the row's own, where it has one
        out.at[i, "verdict"] = verdict(float(r["ours"]), stat, rng, paper_error, syst=syst, run_to_run=rtr,
                                       n_replicates=n,
                                       kind=kinds.get(r["quantity"], kind))[0]
    return out

