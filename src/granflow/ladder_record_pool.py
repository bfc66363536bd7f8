"""What a ladder's pool reads besides its rungs' runs: the committed record, and the profiles its rungs left.

A pool (:func:`granflow.ladder.pool_checks`) reads rungs run apart as one record. Two kinds of committed tables
join the runs at hand, so a pool does not need all its runs on one machine at once:

* the record's: when one of the pool's ``rungs`` is ``record`` (:data:`granflow.ladder_contrasts.RECORD`), the
  committed record's cases join the rungs without their runs. The record keeps the small tables its scene's checks
  across cases are made from (``validation/<scene>/profiles/``, its first replicate's);
* a pooled rung's own: recording a ladder (:func:`granflow.ladder.record`) keeps the profiles of every rung a pool
  reads, with its case summaries, in ``validation/<scene>/pooled/<rung>/`` (:func:`keep_pooled`); a rung whose runs
  are not at hand is read from them (:func:`kept_pooled`).

:meth:`~granflow.scene_hooks.SceneHooks.profile_checks` is the code that makes the pool's checks from those tables,
as it does when a record is judged again (:mod:`granflow.rejudge`): the heap's q* exponent across the record's feed
rates and the rungs' others, say, or across rungs run in different months.
"""
from __future__ import annotations

import json
import shutil
from pathlib import Path

import pandas as pd

from granflow import registry
from granflow.config import ConfigError
from granflow.schema import PROJECT_ROOT
from granflow.validation import ValidationResult, _clean, case_summary, scene_validation, with_kinds

#: ``validation/<scene>/<POOLED>/<rung>/``: a pooled rung's profiles (``<name>.csv.gz``) and ``cases.json``
POOLED = "pooled"
#: the record's own name among a pool's sources
RECORD_SOURCE = "the record"


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
    return [_with_cpu(c) for c in first]


def _with_cpu(case: dict) -> dict:
    return dict(case, cpu_hours=float("nan") if case.get("cpu_hours") is None else float(case["cpu_hours"]))


def keep_pooled(scene_name: str, rung: str, base: Path, cases: dict[str, Path], out: Path) -> Path:
    """Keep the profiles the scene's validation makes of a pooled rung's analysed ``cases`` (under ``base``),
    gzipped as the record's are written (6 digits), and the cases' summaries, in ``<out>/pooled/<rung>/``; the
    directory is replaced only once its replacement is complete. Returns it."""
    profiles = scene_validation(registry.get(scene_name), base, cases).profiles
    final = Path(out) / POOLED / rung
    partial, old = final.with_name(f".{rung}.partial"), final.with_name(f".{rung}.old")
    shutil.rmtree(partial, ignore_errors=True)
    partial.mkdir(parents=True)
    for name, df in sorted(profiles.items()):
        # mtime 0: the same table gives the same bytes, so a record made again changes nothing in git
        df.to_csv(partial / f"{name}.csv.gz", index=False, float_format="%.6g",
                  compression={"method": "gzip", "mtime": 0})
    summaries = [dict(dir=rel, **case_summary(Path(path))) for rel, path in sorted(cases.items())]
    (partial / "cases.json").write_text(json.dumps(_clean(summaries), indent=1, ensure_ascii=False) + "\n")
    shutil.rmtree(old, ignore_errors=True)
    if final.exists():
        final.rename(old)
    partial.rename(final)
    shutil.rmtree(old, ignore_errors=True)
    return final


def kept_pooled(scene: str, rung: str, root: Path = PROJECT_ROOT) -> tuple[dict[str, pd.DataFrame], list[dict]] | None:
    """(profiles by name, case summaries) that :func:`keep_pooled` kept of ``rung`` in the committed record, or
    None where it kept none."""
    where = Path(root) / "validation" / scene / POOLED / rung
    if not (where / "cases.json").is_file():
        return None
    profiles = {p.name[:-len(".csv.gz")]: pd.read_csv(p) for p in sorted(where.glob("*.csv.gz"))}
    return profiles, [_with_cpu(c) for c in json.loads((where / "cases.json").read_text())]


def _cases_of(profiles: dict[str, pd.DataFrame]) -> set[str]:
    return {str(c) for df in profiles.values() if "case" in df for c in df["case"].unique()}


def committed_pool_checks(scene_name: str, base: Path, cases: dict[str, Path], headlines: list,
                          committed: dict[str, tuple[dict, list]]) -> tuple[list, list[dict]]:
    """(the pool's checks, its case summaries): the scene's profile checks over the ``committed`` sources' profiles
    (by source: the record, a rung whose runs are not at hand) and those the scene's validation makes of the rungs'
    analysed ``cases`` (under ``base``), kept where their quantity starts with one of ``headlines``. Refused
    (:class:`ConfigError`) when two sources have a case of the same name (the same sweep point twice)."""
    scene = registry.get(scene_name)
    sources = dict(committed)
    if cases:
        sources["the rungs at hand"] = (scene_validation(scene, base, cases).profiles,
                                        [case_summary(p) for p in cases.values()])
    names = list(sources)
    for i, a in enumerate(names):
        for b in names[i + 1:]:
            twice = _cases_of(sources[a][0]) & _cases_of(sources[b][0])
            if twice:
                raise ConfigError(f"ladder {scene_name}: a pool: case(s) {', '.join(sorted(twice))} are in {a} and "
                                  f"in {b}: allowed sources whose cases differ (each its own sweep point)")
    tables = [profiles for profiles, _ in sources.values()]
    combined = {name: pd.concat(parts, ignore_index=True)
                for name in sorted({n for t in tables for n in t})
                if (parts := [t[name] for t in tables if t.get(name) is not None and not t[name].empty])}
    checks = with_kinds(ValidationResult(checks=scene.profile_checks(combined)), scene.check_kinds).checks
    keep = [c for c in checks if any(c.quantity.startswith(h) for h in headlines)]
    return keep, [s for _, summaries in sources.values() for s in summaries]


def record_pool_checks(scene_name: str, base: Path, cases: dict[str, Path], headlines: list,
                       root: Path = PROJECT_ROOT, kept: dict[str, tuple[dict, list]] | None = None
                       ) -> tuple[list, list[dict], str]:
    """(the pool's checks, its case summaries, what it waits for) of a pool with the record: the record's committed
    profiles (its first replicate's cases) beside the rungs' analysed ``cases`` and the ``kept`` rungs' profiles
    (:func:`committed_pool_checks`); it waits for the record's profiles where there are none."""
    recorded = committed_profiles(scene_name, root)
    if not recorded:
        return [], [], f"waits for the record's profiles (validation/{scene_name}/profiles/)"
    committed = {RECORD_SOURCE: (recorded, first_replicate_cases(scene_name, root)), **(kept or {})}
    return (*committed_pool_checks(scene_name, base, cases, headlines, committed), "")
