"""A ladder's pool that reads the committed validation record beside its rungs.

A pool (:func:`granflow.ladder.pool_checks`) reads rungs run apart as one record. When one of its ``rungs`` is
``record`` (:data:`granflow.ladder_contrasts.RECORD`), the committed record's cases join them without their runs:
the record keeps the small tables its scene's checks across cases are made from (``validation/<scene>/profiles/``,
its first replicate's), and :meth:`~granflow.scene_hooks.SceneHooks.profile_checks` is the code that makes those
checks from them, as it does when a record is judged again (:mod:`granflow.rejudge`). So the pool's rows are the
scene's profile checks over the record's profiles and the rungs' (from their analysed cases) together: the heap's
q* exponent across the record's feed rates and the rungs' others, say.
"""
from __future__ import annotations

import json
from pathlib import Path

import pandas as pd

from granflow import registry
from granflow.config import ConfigError
from granflow.schema import PROJECT_ROOT
from granflow.validation import ValidationResult, case_summary, scene_validation, with_kinds


def committed_profiles(scene: str, root: Path = PROJECT_ROOT) -> dict[str, pd.DataFrame]:
    """The committed record's profiles of ``scene`` by name (``validation/<scene>/profiles/<name>.csv``)."""
    return {p.stem: pd.read_csv(p) for p in sorted((Path(root) / "validation" / scene / "profiles").glob("*.csv"))}


def first_replicate_cases(scene: str, root: Path = PROJECT_ROOT) -> list[dict]:
    """The committed record's case summaries of its first replicate (the seed its profiles are of), each with its
    CPU-hours (NaN where the record gives none)."""
    path = Path(root) / "validation" / scene / "summary.json"
    if not path.exists():
        return []
    cases = json.loads(path.read_text()).get("cases") or []
    first = [c for c in cases if not c.get("seeds") or c.get("seed") == c["seeds"][0]]
    return [dict(c, cpu_hours=float("nan") if c.get("cpu_hours") is None else float(c["cpu_hours"])) for c in first]


def _cases_of(profiles: dict[str, pd.DataFrame]) -> set[str]:
    return {str(c) for df in profiles.values() if "case" in df for c in df["case"].unique()}


def record_pool_checks(scene_name: str, base: Path, cases: dict[str, Path], headlines: list,
                       root: Path = PROJECT_ROOT) -> tuple[list, list[dict], str]:
    """(the pool's checks, its case summaries, what it waits for): the scene's profile checks over the committed
    record's profiles and those the scene's validation makes of the rungs' analysed ``cases`` (under ``base``),
    kept where their quantity starts with one of ``headlines``. Refused (:class:`ConfigError`) when a rung's case
    has the name of one of the record's (the same sweep point twice)."""
    recorded = committed_profiles(scene_name, root)
    if not recorded:
        return [], [], f"waits for the record's profiles (validation/{scene_name}/profiles/)"
    scene = registry.get(scene_name)
    ours = scene_validation(scene, base, cases).profiles if cases else {}
    twice = _cases_of(recorded) & _cases_of(ours)
    if twice:
        raise ConfigError(f"ladder {scene_name}: a pool with the record: case(s) {', '.join(sorted(twice))} are the "
                          f"record's and a rung's: allowed rungs whose cases differ from the record's")
    combined = {name: pd.concat([df for df in (recorded.get(name), ours.get(name)) if df is not None and not df.empty],
                                ignore_index=True)
                for name in set(recorded) | set(ours)
                if any(df is not None and not df.empty for df in (recorded.get(name), ours.get(name)))}
    checks = with_kinds(ValidationResult(checks=scene.profile_checks(combined)), scene.check_kinds).checks
    keep = [c for c in checks if any(c.quantity.startswith(h) for h in headlines)]
    return keep, first_replicate_cases(scene_name, root) + [case_summary(p) for p in cases.values()], ""
