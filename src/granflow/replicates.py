"""Replicates: the same cases run from other seeds, judged as one record.

A campaign whose sweep lists seeds runs each case once per seed, in ``<case>/seed~<seed>``
(:data:`granflow.declarations.REPLICATE`). A scene's validation compares the cases of one seed with
its paper, exactly as without replicates (:func:`split` hands it the case names without the seed
level); :func:`pool` then sets the replicates' results beside each other, check by check: ours is
their mean, its statistical error the mean's (:math:`\\sqrt{\\sum_i \\sigma_i^2}/n`), ``run_to_run``
the replicates' scatter as a standard error of their mean (:math:`s/\\sqrt{n}`, sample standard
deviation ``s``; it holds the statistical scatter too, so stat ⊕ run-to-run counts that part twice:
the combined error errs wide), the systematic error the replicates' mean. A verdict may say
"differs" only with two replicates or more (:func:`granflow.verdicts.verdict`).
"""
from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import numpy as np

from .scene_hooks import REPLICATE


def seed_of(rel: str) -> int | None:
    """The seed of a case directory ``.../seed~<seed>`` (None without the replicate level)."""
    last = rel.strip("/").split("/")[-1]
    label, _, value = last.partition("~")
    return int(value) if label == REPLICATE.label and value else None


def base_of(rel: str) -> str:
    """The case a replicate repeats: ``theta~25/seed~7`` -> ``theta~25`` (a case without the level: itself)."""
    return rel.strip("/").rsplit("/", 1)[0] if seed_of(rel) is not None else rel


def split(cases: dict[str, Path]) -> dict[int | None, dict[str, Path]]:
    """``{seed: {case without the seed level: path}}``, seeds in the order first met.

    Without replicates: ``{None: cases}``. Every seed must replicate the same cases (a campaign's
    sweep runs every point once per seed); ValueError names a seed that lacks one.
    """
    groups: dict[int | None, dict[str, Path]] = {}
    for rel, path in cases.items():
        groups.setdefault(seed_of(rel), {})[base_of(rel)] = Path(path)
    if len(groups) > 1:
        if None in groups:
            raise ValueError(f"cases with and without a seed level: {', '.join(sorted(groups[None]))} have none")
        names = [set(g) for g in groups.values()]
        for seed, group in groups.items():
            missing = set().union(*names) - set(group)
            if missing:
                raise ValueError(f"seed {seed} lacks the replicate of {', '.join(sorted(missing))}: "
                                 f"every seed replicates every case")
    return groups


def _fmt(x: float) -> str:
    return f"{x:.4g}" if math.isfinite(x) else "–"


def pool(results: list, seeds: list):
    """One :class:`~granflow.validation.ValidationResult` from the replicates' (same order as ``seeds``).

    Checks are matched by quantity and case; a check missing from a replicate, or NaN there, is
    pooled over those that have it (its ``n_replicates`` says how many), a check only one made kept. Profiles, figures and
    differences are the first replicate's.
    """

    if len(results) == 1:
        return results[0]
    index = [{(c.quantity, c.case): c for c in r.checks} for r in results]
    # every check any replicate made, in the order first met (a replicate may lack one the others have)
    order = {}
    for idx in index:
        for key, c in idx.items():
            order.setdefault(key, c)
    pooled = []
    for key, first in order.items():
        same = [(seed, idx[key]) for seed, idx in zip(seeds, index) if key in idx]
        have = [(seed, c) for seed, c in same if math.isfinite(c.ours)]
        values = np.array([c.ours for _, c in have])
        errors = np.array([c.error for _, c in have])
        systs = np.array([c.syst for _, c in have])
        n = len(have)
        ours = float(values.mean()) if n else float("nan")
        error = float(math.sqrt(np.sum(errors ** 2)) / n) if n and np.all(np.isfinite(errors)) else float("nan")
        syst = float(np.mean(systs[np.isfinite(systs)])) if n and np.any(np.isfinite(systs)) else float("nan")
        r2r = float(values.std(ddof=1) / math.sqrt(n)) if n >= 2 else float("nan")
        each = "; ".join(f"seed {seed}: {_fmt(c.ours)}" + (f" ± {c.error:.2g}" if math.isfinite(c.error) else "")
                         for seed, c in same)
        note = ((f"{first.note.rstrip('. ')}. " if first.note else "")
                + f"Replicates ({n} of {len(results)} seeds measured it): {each}; mean {_fmt(ours)}, "
                  f"scatter s/√n = {_fmt(r2r)} (run_to_run)")
        # the first replicate's check with the pooled numbers: replace() judges it anew (its __post_init__)
        pooled.append(replace(first, ours=ours, error=error, syst=syst, run_to_run=r2r, n_replicates=n, note=note))
    return replace(results[0], checks=pooled)
