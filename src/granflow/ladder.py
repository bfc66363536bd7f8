"""A ladder toward a paper: one knob at a time from the validation case, error against the paper vs CPU-hours.

A ladder file (``config/ladders/<scene>.yaml``) names a scene, its rung, a sweep and a list of rungs, each a set
of scene-file changes (``set:``, dotted keys as ``--set``) or of sweep values (``sweep:``, replacing the ladder's
for that key) with the knob it turns in words; ``planned:`` rungs are only priced. A rung with ``replicate: true``
runs the first rung's cases again with another random seed and nothing else: the record reads it as the first
rung's second sample (:func:`scatter_lines`). A ``series:`` entry names rungs that turn one knob by steps and reads
the straight line through them at chosen points, such as the paper's size (:func:`series_fit`). A ``pools:`` entry
reads rungs run apart as one record (:func:`pool_checks`): the scene's validation over all their cases gives the
rows only a sweep across the rungs can, such as a scaling across feed rates. A ``contrasts:`` entry reads one rung
against a reference (another rung, or the committed record) row by row, for a paper's claim that a knob changes
nothing or moves a quantity one way (:mod:`granflow.ladder_contrasts`); its rows' state starts ``contrast``, so
they stay out of the cost pictures and the planner. Every rung, pool and contrast declares ``from_paper``, its
order from the paper's setup (0 the paper's), which ``ladder.csv`` carries.

The ladders are targets of the workflow (``snakemake ladder``, ``snakemake ladder_<scene>``): each rung run is a
one-scene campaign in memory (:func:`rung_campaign`: the scene file changed and validated exactly as a
campaign's) whose cases, under ``<results>/ladders/<scene>/<rung>/<scene>/<scene rung>/<case>``
(:func:`rung_dir`), are jobs of the campaign's own render / simulate / analyse rules, so a rung resumes, is
priced (:func:`ladder_plan`, ``granflow plan --config config/ladders/<scene>.yaml``) and runs on a profile as any
case does. The rule ``ladder_record`` then writes the record (:func:`record`): the scene's own validation
(:meth:`granflow.registry.Scene.validation`) on each rung's analysed cases, its headline checks, into
``validation/<scene>/ladder.csv``, ``ladder.md`` and ``figures/ladder.png``: |difference from the paper|
(relative, with the combined stat ⊕ syst error) against the rung's measured CPU-hours, the planned rungs at
their priced CPU-hours. ``tools/ladder.py`` is a command over the same functions. Nothing here tunes anything.
"""
from __future__ import annotations

import json
import math
import re
from pathlib import Path

import numpy as np
import pandas as pd

from granflow import registry
from granflow.config import ConfigError, load_yaml
from granflow.ladder_contrasts import RECORD, check_contrasts, contrast_checks, reference_label
from granflow.ladder_rates import calibration, cost_columns, measured_rates, planned_state, price_lines
from granflow.ladder_rejudge import CONTRAST, MEASURED, rejudge  # noqa: F401
from granflow.ladder_record_pool import committed_pool_checks, keep_pooled, kept_pooled, record_pool_checks
from granflow.ladder_series import SeriesFit, figure, scatter_lines, series_fit, series_lines  # noqa: F401
from granflow.scene_files import check_scene_sweep, load_scene
from granflow.schema import PROJECT_ROOT
from granflow.validation import case_summary, format_with_errors, scene_validation

ROOT = PROJECT_ROOT
#: where the ladder files are, relative to the project root
LADDER_DIR = "config/ladders"
#: a rung's name: it names the rung's folder (``<results>/ladders/<scene>/<rung>``)
RUNG_NAME = re.compile(r"[A-Za-z][A-Za-z0-9_]*")
#: a planned rung is priced, never run here: not held to this machine's CPU-hour limit
PRICED_ONLY_CPU_HOURS = 1e9


def load_ladder(path: Path) -> dict:
    """A ladder file read strictly (:func:`granflow.config.load_yaml`); refused (:class:`ConfigError`, naming the
    file, the key and what is allowed) without its keys, with an unknown scene, or with a rung whose ``from_paper``
    is not a number >= 0 or a replicate that steps away from its first rung's order."""
    data = load_yaml(path)
    for key in ("scene", "rung", "scene_file", "rungs", "headlines", "from_paper_order"):
        if key not in data:
            raise ConfigError(f"ladder: {path}: missing key {key!r}")
    if data["scene"] not in registry.names():
        raise ConfigError(f"ladder: {path}: scene = {data['scene']!r}: allowed one of "
                          f"{', '.join(map(repr, registry.names()))} (the registered scenes)")
    pools, contrasts = data.get("pools") or [], data.get("contrasts") or []
    names = [r.get("name") for r in data["rungs"] + (data.get("planned") or []) + pools + contrasts]
    for pool in pools:
        pooled = pool.get("rungs")
        if not (isinstance(pooled, list) and len(set(pooled)) >= 2
                and set(pooled) <= (set(names) | {RECORD}) - {pool.get("name")} and isinstance(pool.get("knob"), str)):
            raise ConfigError(f"ladder: {path}: pool {pool.get('name')!r}: rungs = {pooled!r}: allowed a list of two "
                              f"or more rung names of this ladder (or {RECORD!r}, the committed record), with a knob "
                              f"in words")
    check_contrasts(data, path)
    for rung in data["rungs"] + (data.get("planned") or []) + pools + contrasts:
        name = rung.get("name")
        if not isinstance(name, str) or not RUNG_NAME.fullmatch(name) or names.count(name) > 1:
            raise ConfigError(f"ladder: {path}: rung name = {name!r}: allowed a name of letters, digits and _ "
                              f"given once (it names the rung's folder and target)")
        order = rung.get("from_paper")
        if isinstance(order, bool) or not isinstance(order, (int, float)) or not order >= 0:
            raise ConfigError(f"ladder: {path}: rung {rung.get('name')!r}: from_paper (its order from the paper's "
                              f"setup, a number >= 0) is {order!r}")
        if rung.get("replicate") and order != data["rungs"][0].get("from_paper"):
            raise ConfigError(f"ladder: {path}: replicate rung {rung['name']!r} has from_paper {order}, its first "
                              f"rung {data['rungs'][0]['from_paper']}: a reseed is no step toward the paper")
    return data


def ladder_files(root: Path = ROOT) -> list[Path]:
    """Every ladder file of the project (``config/ladders/<scene>.yaml``)."""
    return sorted((Path(root) / LADDER_DIR).glob("*.yaml"))


def with_from_paper(df: pd.DataFrame, ladder: dict) -> pd.DataFrame:
    """The ladder table with each rung's ``from_paper`` (its order from the paper's setup, from the ladder
    file) as the column after ``knob``; an earlier ``from_paper`` column is replaced."""
    order = {r["name"]: r["from_paper"] for r in ladder["rungs"] + (ladder.get("planned") or []) +
             (ladder.get("pools") or []) + (ladder.get("contrasts") or [])}
    out = df.drop(columns=["from_paper"], errors="ignore")
    out.insert(list(out.columns).index("knob") + 1 if "knob" in out else 0, "from_paper",
               [order.get(name, np.nan) for name in out["rung"]])
    return out


def order_line(ladder: dict) -> str:
    """The ladder's order of its rungs from the paper's setup, as ``ladder.md`` says it (nothing for a ladder
    that declares none: :func:`load_ladder` refuses a file without it)."""
    rungs = ladder["rungs"] + (ladder.get("planned") or []) + (ladder.get("pools") or []) + \
        (ladder.get("contrasts") or [])
    if "from_paper_order" not in ladder or any("from_paper" not in r for r in rungs):
        return ""
    rungs = sorted(rungs, key=lambda r: r["from_paper"])
    return ("Order from the paper's setup (`from_paper`; 0 is the paper's, the report's front page shows the "
            "measured rung nearest it): " + ", ".join(f"{r['name']} {r['from_paper']:g}" for r in rungs)
            + f". {ladder['from_paper_order'][0].upper()}{ladder['from_paper_order'][1:]}.\n\n")


def rung_level(ladder: dict, rung: dict) -> str:
    """The scene rung (validation, paper, ...) a ladder rung runs at: its own ``rung:``, else the ladder's."""
    return rung.get("rung", ladder["rung"])


def rung_dir(results: Path, ladder: dict, name: str) -> Path:
    """The rung's results directory, ``<results>/ladders/<scene>/<rung>``: its cases are
    ``<rung dir>/<scene>/<scene rung>/<case>``, a campaign's layout under it."""
    return Path(results) / "ladders" / ladder["scene"] / name


def rung_cases_root(results: Path, ladder: dict, rung: dict) -> Path:
    """Where the rung's case directories are: under :func:`rung_dir`, or, for runs made by ``tools/ladder.py
    prepare`` before the ladders were targets of the workflow, ``<results>/<scene>/<rung>/results/<scene>/<scene
    rung>`` (read, never written)."""
    tail = Path(ladder["scene"]) / rung_level(ladder, rung)
    new = rung_dir(results, ladder, rung["name"]) / tail
    old = Path(results) / ladder["scene"] / rung["name"] / "results" / tail
    return old if not new.exists() and old.exists() else new


def _overrides(rung: dict) -> list[str]:
    return [f"{k}={json.dumps(v) if not isinstance(v, str) else v}" for k, v in (rung.get("set") or {}).items()]


def rung_sweep(ladder: dict, rung: dict) -> dict:
    """The rung's sweep: the ladder's, with the values the rung's ``sweep:`` gives replacing its keys'."""
    return {**(ladder.get("sweep") or {}), **(rung.get("sweep") or {})}


def rung_campaign(ladder: dict, rung: dict, results: Path, root: Path = ROOT, priced_only: bool = False) -> dict:
    """The rung as a validated one-scene campaign, in memory (the shape :func:`granflow.campaign.validate_campaign`
    returns, which :func:`granflow.resources.plan_campaign` prices): the ladder's scene file with the rung's
    ``set:`` applied and validated by the scene's schema, its sweep checked by the scene's pre-run checks and size
    limits exactly as a campaign's; ``results_dir`` the rung's directory (:func:`rung_dir`). A rung
    ``priced_only`` (planned, never run here) is not held to this machine's CPU-hour limit."""
    scene = load_scene(Path(root) / ladder["scene_file"], _overrides(rung))
    level, sweep = rung_level(ladder, rung), rung_sweep(ladder, rung)
    source = f"ladder {ladder['scene']}, rung {rung['name']} ({ladder['scene_file']} with {rung.get('set') or {}})"
    limits = {"max_cpu_hours": PRICED_ONLY_CPU_HOURS} if priced_only else {}
    check_scene_sweep(ladder["scene"], scene, sweep, level, source, limits)
    return {"rung": level, "results_dir": str(rung_dir(results, ladder, rung["name"])), **limits,
            "scenes": {ladder["scene"]: {"enabled": True, "sweep": sweep, "scene": scene}}}


def plan(ladder: dict, rung: dict, results: Path, root: Path = ROOT, priced_only: bool = False,
         rates: dict | None = None, **kwargs) -> dict:
    """The rung's plan (:func:`granflow.resources.plan_campaign` of :func:`rung_campaign`): its cases priced,
    each with its state in the rung's directory (done, partial: a rerun resumes, todo). A rung without runs of
    its own is priced at the ladder's measured ``rates`` (:func:`granflow.ladder_rates.measured_rates`) where
    one fits its pair style, else at the reference rate."""
    from granflow.resources import plan_campaign

    cfg = rung_campaign(ladder, rung, results, root, priced_only)
    p = plan_campaign(cfg, cfg["results_dir"], **kwargs)
    cal = calibration(p, ladder["scene"], rates or {})
    return plan_campaign(cfg, cfg["results_dir"], calibration=cal, **kwargs) if cal else p


def committed_rates(ladder: dict, root: Path = ROOT) -> dict:
    """The measured rates of the committed ``validation/<scene>/ladder.csv`` (none without one)."""
    path = Path(root) / "validation" / ladder["scene"] / "ladder.csv"
    return measured_rates(pd.read_csv(path)) if path.exists() else {}


def ladder_plan(ladder: dict, results: Path, root: Path = ROOT, **kwargs) -> dict:
    """Every rung of the ladder priced as one campaign: the rungs run (``rungs:``) and the planned ones, each
    row's ``scene`` ``<scene>/<rung>`` (``granflow plan --config config/ladders/<scene>.yaml``); a rung without
    runs here at the rate the committed ladder's measured rungs ran at (:func:`plan`)."""
    from granflow.resources import plan_totals

    out, rates = None, committed_rates(ladder, root)
    for rung in ladder["rungs"] + (ladder.get("planned") or []):
        p = plan(ladder, rung, results, root, priced_only=rung in (ladder.get("planned") or []), rates=rates,
                 **kwargs)
        label = f"{ladder['scene']}/{rung['name']}" + ("" if rung in ladder["rungs"] else " (planned)")
        rows = [dict(r, scene=label) for r in p["rows"]]
        if out is None:
            out = dict(p, rows=[], scenes={}, rates={}, rung=f"ladder {ladder['scene']}", results=str(results))
        out["rows"] += rows
        out["scenes"][label] = plan_totals(rows)
        out["rates"][label] = p["rates"][ladder["scene"]]
    out["total"] = plan_totals(out["rows"])
    return out


def rung_setups(ladder: dict, results: Path, root: Path = ROOT) -> dict[str, dict]:
    """Each rung run (``rungs:``, not the planned ones) as :func:`rung_campaign`, by name: what the workflow's
    ``ladder`` targets build, with the render / simulate / analyse rules of a campaign."""
    return {rung["name"]: rung_campaign(ladder, rung, results, root) for rung in ladder["rungs"]}


def rung_cases(ladder: dict, setup: dict) -> list[str]:
    """The rung's cases (``W~20/phi~0.6``: each named by its sweep values), in sweep order."""
    scene, sc = registry.get(ladder["scene"]), setup["scenes"][ladder["scene"]]
    return [scene.case_dir(p) for p in scene.sweep_points(sc["scene"], sc["sweep"], setup["rung"])]


def rung_case_dirs(ladder: dict, setup: dict) -> list[str]:
    """The rung's case directories (``<rung dir>/<scene>/<scene rung>/<case>``), in sweep order."""
    return [f"{setup['results_dir']}/{ladder['scene']}/{setup['rung']}/{c}" for c in rung_cases(ladder, setup)]


def rung_checks(ladder: dict, rung: dict, results: Path) -> tuple[list, list[dict]]:
    """(the headline checks of the rung's analysed cases, their case summaries): the ladder's headlines and the
    rung's own (``headlines:``, the rows only its setting gives, such as a zone that exists at one φ̄ only)."""
    base = rung_cases_root(results, ladder, rung)
    cases = {str(p.parent.parent.relative_to(base)): p.parent.parent
             for p in sorted(base.glob("**/analysis/scalars.json"))}
    return _headline_checks(ladder, base, cases, ladder["headlines"] + list(rung.get("headlines") or []))


def _headline_checks(ladder: dict, base: Path, cases: dict, headlines: list) -> tuple[list, list[dict]]:
    if not cases:
        return [], []
    # judged as the record is: the scene's check kinds, replicates pooled (granflow.validation.scene_validation)
    result = scene_validation(registry.get(ladder["scene"]), base, cases)
    keep = [c for c in result.checks if any(c.quantity.startswith(h) for h in headlines)]
    return keep, [case_summary(p) for p in cases.values()]


def _at_hand(ladder: dict, rung: dict | None, results: Path) -> tuple[Path | None, dict[str, Path], bool]:
    """(where the rung's cases are, its analysed cases by name, whether every case of its sweep is analysed)."""
    base = rung_cases_root(results, ladder, rung) if rung else None
    found = {str(p.parent.parent.relative_to(base)): p.parent.parent
             for p in sorted(base.glob("**/analysis/scalars.json"))} if base else {}
    return base, found, bool(rung) and len(found) >= math.prod(len(v) for v in rung_sweep(ladder, rung).values())


def pool_checks(ladder: dict, pool: dict, results: Path, root: Path = ROOT) -> tuple[list, list[dict], str]:
    """A pool's rows: the scene's validation over the analysed cases of all its rungs at once, its headlines
    (the pool's ``headlines``, else the ladder's), their case summaries, and what it waits for ("" when every
    rung has its cases analysed). Rungs whose cases share a name (the same sweep point) cannot be pooled. A pool
    with ``record`` reads the committed record's profiles beside its rungs, and a rung whose runs are not at hand
    the profiles the committed record kept of it (``validation/<scene>/pooled/<rung>/``): then the rows are the
    scene's profile checks over them all (:mod:`granflow.ladder_record_pool`)."""
    by_name = {r["name"]: r for r in ladder["rungs"]}
    cases, missing, kept = {}, [], {}
    members = [name for name in pool["rungs"] if name != RECORD]
    for name in members:
        _, found, complete = _at_hand(ladder, by_name.get(name), results)
        if not complete:
            if (committed := kept_pooled(ladder["scene"], name, root)) is None:
                missing.append(name)
            else:
                kept[f"{name}'s kept profiles"] = committed
            continue
        for case, path in found.items():
            if case in cases:
                raise ConfigError(f"ladder {ladder['scene']}: pool {pool['name']!r}: case {case!r} is in two of its "
                                  f"rungs: allowed rungs whose cases differ (each its own sweep point)")
            cases[case] = path
    if missing:
        return [], [], "waits for " + ", ".join(missing)
    base = rung_cases_root(results, ladder, by_name[members[0]])
    headlines = pool.get("headlines") or ladder["headlines"]
    if RECORD in pool["rungs"]:
        return record_pool_checks(ladder["scene"], base, cases, headlines, root, kept)
    if kept:
        return (*committed_pool_checks(ladder["scene"], base, cases, headlines, kept), "")
    return (*_headline_checks(ladder, base, cases, headlines), "")


def keep_pooled_rungs(ladder: dict, results: Path, out: Path) -> list[str]:
    """Keep in the record (``<out>/pooled/<rung>/``, :func:`~granflow.ladder_record_pool.keep_pooled`) the
    profiles of every rung a pool reads whose cases are all analysed under ``results``; returns their names."""
    by_name, kept = {r["name"]: r for r in ladder["rungs"]}, []
    for name in dict.fromkeys(n for pool in ladder.get("pools") or [] for n in pool["rungs"] if n != RECORD):
        base, found, complete = _at_hand(ladder, by_name.get(name), results)
        if complete:
            keep_pooled(ladder["scene"], name, base, found, out)
            kept.append(name)
    return kept


def _kept_checks(ladder: dict, rung: dict, quantities: list) -> list:
    """A rung's committed ladder.csv rows (:func:`committed_rows`) of ``quantities`` as checks, for a contrast whose
    side's runs are not at hand: its numbers are those of the code that measured them, with no measurement choices
    to apply to both sides (the contrast's syst is then the larger side's)."""
    from granflow.validation import Check

    def num(r: dict, key: str) -> float:
        v = pd.to_numeric(pd.Series([r.get(key)]), errors="coerce").iloc[0]
        return float(v) if pd.notna(v) else float("nan")

    out = []
    for r in committed_rows(ladder, rung):
        if not isinstance(r.get("quantity"), str) or not any(r["quantity"].startswith(q) for q in quantities):
            continue
        lo, hi = num(r, "paper_lo"), num(r, "paper_hi")
        n = num(r, "n_replicates")
        out.append(Check(r["quantity"], str(r.get("paper", "")), "", num(r, "ours"), num(r, "stat"),
                         case=f"{rung['name']} (kept)", paper_range=(lo, hi) if math.isfinite(lo) or math.isfinite(hi)
                         else None, syst=num(r, "syst"), run_to_run=num(r, "run_to_run"),
                         n_replicates=int(n) if math.isfinite(n) else 1,
                         kind=r["kind"] if isinstance(r.get("kind"), str) else "comparison"))
    return out


def contrast_table_checks(ladder: dict, contrast: dict, results: Path) -> tuple[list, list[dict], str]:
    """A contrast's rows (:func:`granflow.ladder_contrasts.contrast_checks`), the rung's case summaries, and what
    it waits for ("" when both sides are measured): the rung's checks from its analysed cases, the reference's
    from its own (a rung) or from the committed record (``record``: :func:`committed_checks`)."""
    by_name = {r["name"]: r for r in ladder["rungs"]}
    quantities = [row["quantity"] for row in contrast["rows"]]

    def measured(rung: dict) -> tuple[list, list[dict]]:
        base = rung_cases_root(results, ladder, rung)
        cases = {str(p.parent.parent.relative_to(base)): p.parent.parent
                 for p in sorted(base.glob("**/analysis/scalars.json"))}
        if cases:
            return _headline_checks(ladder, base, cases, quantities)
        return _kept_checks(ladder, rung, quantities), []   # its runs absent: its committed rows, if any

    if contrast["rung"] not in by_name or contrast["reference"] not in {*by_name, RECORD}:
        return [], [], "waits for its rungs (not rungs of this ladder)"
    rung_side, cases = measured(by_name[contrast["rung"]])
    ref_side = (committed_checks(ladder, quantities)[0] if contrast["reference"] == RECORD
                else measured(by_name[contrast["reference"]])[0])
    waits = [name for name, side in ((contrast["rung"], rung_side), (reference_label(contrast), ref_side))
             if not side]
    if waits:
        return [], cases, "waits for " + ", ".join(waits)
    unknown = contrast_checks(contrast, ref_side, ref_side)[1]
    if unknown:
        raise ConfigError(f"ladder {ladder['scene']}: contrast {contrast['name']!r}: rows {unknown!r} match no one "
                          f"check of {reference_label(contrast)}: allowed the start of one check's quantity of the "
                          f"scene's validation")
    checks, missing = contrast_checks(contrast, ref_side, rung_side)
    if missing or not all(math.isfinite(c.ours) for c in checks):
        ended = "; ".join(f"{c['status']}: {str(c['reason']).split(': ERROR')[0]}" for c in cases
                          if c.get("status") not in ("steady", None))
        return [], cases, f"{contrast['rung']} measured no {', '.join(missing) or 'value'}" + \
            (f" ({ended})" if ended else "")
    return checks, cases, ""


def committed_checks(ladder: dict, headlines: list | None = None) -> tuple[list, list[dict]]:
    """The base rung read from the committed record (``validation/<scene>/summary.json``) when its runs
    are not at hand: the headline checks (``headlines``, else the ladder's) of the cases matching the ladder's
    sweep (each key with one value, named ``key~value`` in the case), or sweep-wide ones, with their
    replicates' scatter."""
    headlines = ladder["headlines"] if headlines is None else headlines
    from granflow.validation import Check

    path = ROOT / "validation" / ladder["scene"] / "summary.json"
    if not path.exists():
        return [], []
    summary = json.loads(path.read_text())
    sweep = ladder.get("sweep") or {}
    values = [v[0] for v in sweep.values() if len(v) == 1]
    # the case the ladder's sweep point names, where every key has one value (its label may carry other units)
    named = registry.get(ladder["scene"]).case_dir({k: v[0] for k, v in sweep.items()}) \
        if sweep and all(len(v) == 1 for v in sweep.values()) else None

    def matches(case: str) -> bool:
        parts = [p.split("~", 1)[1] for p in case.split("/") if "~" in p]
        return case == named or all(any(_same(p, v) for p in parts) for v in values)

    def open_range(rng) -> tuple | None:   # JSON keeps an open end (±inf) as null
        return None if not rng else (-math.inf if rng[0] is None else rng[0], math.inf if rng[1] is None else rng[1])

    keep, dirs = [], set()
    for c in summary["checks"]:
        if any(c["quantity"].startswith(h) for h in headlines) and (c["case"] == "sweep" or matches(c["case"])):
            nan = float("nan")
            keep.append(Check(c["quantity"], c["paper"], c["source"], nan if c["ours"] is None else c["ours"],
                              nan if c.get("error") is None else c["error"], case=c["case"],
                              paper_range=open_range(c.get("paper_range")),
                              paper_error=c.get("paper_error") or 0.0, note=c.get("note", ""),
                              syst=nan if c.get("syst") is None else c["syst"], variants=c.get("variants", ""),
                              kind=c.get("kind") or "comparison",
                              run_to_run=nan if c.get("run_to_run") is None else c["run_to_run"],
                              n_replicates=int(c.get("n_replicates") or 1)))
            dirs.add(c["case"])
    cases = [dict(c, cpu_hours=float("nan") if c.get("cpu_hours") is None else c["cpu_hours"])
             for c in summary["cases"] if c["dir"] in dirs or "sweep" in dirs]
    return keep, cases


def _same(text: str, value) -> bool:
    try:
        return math.isclose(float(text), float(value))
    except ValueError:
        return text == str(value)


def _rel_error(check) -> float:
    """The check's combined error (stat ⊕ syst) relative to the paper's nearest value (absolute against 0)."""
    lo, hi = sorted(check.paper_range)
    nearest = min(max(check.ours, lo), hi)
    err = math.hypot(*(e if math.isfinite(e) else 0.0 for e in (check.error, check.syst)))
    return err / abs(nearest) if nearest else err


def case_label(case: dict) -> str:
    """A case of a rung in words, from its summary's ``case`` (e.g. ``theta_deg 25, seed 6620117``)."""
    return ", ".join(f"{k} {v:g}" if isinstance(v, float) else f"{k} {v}" for k, v in case["case"].items())


#: the state of a row kept from the committed ladder.csv (:func:`committed_rows`), with the file's commit
KEPT = "run (kept from the committed ladder.csv{when}; its runs are not at hand)"


def _last_commit(path: Path) -> str:
    """`` of <date> (<commit>)``: the last commit of ``path``, or nothing outside a git clone."""
    import subprocess

    try:
        out = subprocess.run(["git", "log", "-1", "--format=%cs (%h)", "--", str(path)], cwd=ROOT, text=True,
                             capture_output=True, timeout=30).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return ""
    return f" of {out}" if out else ""


def committed_rows(ladder: dict, rung: dict, path: Path | None = None) -> list[dict]:
    """The measured rows of ``rung`` in the committed ``validation/<scene>/ladder.csv`` (or ``path``), when it
    names the same rung with the same knob: how one rung is added to a committed ladder without running the
    others again (``tools/ladder.py record --keep-committed``). Their verdicts are judged again by today's rules
    (:func:`rejudge`); their numbers are those of the code that measured them, their state says they were kept.
    A rung that ran and measured nothing (``ran, not measured: ...``) keeps that row and its reason."""
    path = ROOT / "validation" / ladder["scene"] / "ladder.csv" if path is None else Path(path)
    if not path.exists():
        return []
    df = pd.read_csv(path)
    same = df[(df["rung"] == rung["name"]) & (df["knob"] == rung["knob"])]
    mine = same[same["state"].astype(str).str.startswith(MEASURED) & same["quantity"].notna()]
    if mine.empty:  # a rung that ran and measured nothing keeps why, said to be kept
        ran = same[same["state"].astype(str).str.startswith("ran, not measured")]
        when = _last_commit(path)
        return [{k: v for k, v in r.items() if k != "from_paper" and not (isinstance(v, float) and math.isnan(v))}
                | ({} if "(kept from" in r["state"] else {"state": f"{r['state']} (kept from the committed ladder.csv{when})"})
                for r in ran.to_dict("records")]
    when = _last_commit(path)

    def kept_state(state: str) -> str:   # a row kept before names where from; a contrast's keeps its words
        if state.startswith(KEPT.split("{")[0]) or "(kept from" in state:
            return state
        return f"{state} (kept from the committed ladder.csv{when})" if state.startswith(CONTRAST) else \
            KEPT.format(when=when)

    mine = rejudge(mine.assign(state=mine["state"].astype(str).map(kept_state)), ladder)
    return [{k: v for k, v in r.items() if k != "from_paper"} for r in mine.to_dict("records")]


def table(ladder: dict, results: Path, keep_committed: bool = False, root: Path = ROOT) -> pd.DataFrame:
    """Every rung's headline rows: measured from its analysed cases under ``results``; the base rung from the
    committed record when its runs are absent; with ``keep_committed``, any other rung without runs from the
    committed ladder.csv (:func:`committed_rows`); planned rungs priced."""
    rows = []
    for rung in ladder["rungs"]:
        checks, cases = rung_checks(ladder, rung, results)
        if not checks and keep_committed and (kept := committed_rows(ladder, rung)):
            rows += kept
            continue
        state = "run"
        if not checks and not rung.get("set") and not rung.get("rung") and not rung.get("sweep"):
            checks, cases = committed_checks(ladder)
            state = "run (the committed record)"
        cpu = sum(c["cpu_hours"] for c in cases if math.isfinite(c["cpu_hours"]))
        expected = math.prod(len(v) for v in rung_sweep(ladder, rung).values())
        if checks and state == "run" and len(cases) < expected:
            rows.append({"rung": rung["name"], "knob": rung["knob"], "cases": len(cases), "cpu_hours": cpu,
                         "state": f"incomplete: {len(cases)} of {expected} cases analysed"})
            continue
        if not checks:
            rows.append({"rung": rung["name"], "knob": rung["knob"], "state": "not run", "cpu_hours": np.nan})
        ended = [f"{c['status']}: {c['reason']}" for c in cases if c.get("status") not in ("steady", None)]
        if checks and ended and not any(math.isfinite(c.ours) for c in checks):
            # ran, but nothing measurable: the run's own status says why (a guard, no steady state, ...)
            rows.append({"rung": rung["name"], "knob": rung["knob"], "cases": len(cases), "cpu_hours": cpu,
                         "state": "ran, not measured: " + "; ".join(ended)})
            continue
        if ended and state == "run":  # some cases measured, others not: the rung's numbers are the measured ones'
            lost = "; ".join(f"{case_label(c)} {c['status']}: {str(c['reason']).split(': ERROR')[0]}"
                             for c in cases if c.get("status") not in ("steady", None))
            state = f"run ({len(ended)} of {len(cases)} cases not measured: {lost})"
        rows += _rows(rung, state, checks, cases, cpu)
    for pool in ladder.get("pools") or []:
        checks, cases, waits = pool_checks(ladder, pool, results, root)
        if not checks and keep_committed and (kept := committed_rows(ladder, pool)):
            rows += kept
        elif not checks:
            rows.append({"rung": pool["name"], "knob": pool["knob"], "state": f"not run ({waits or 'no cases'})",
                         "cpu_hours": np.nan})
        else:
            cpu = sum(c["cpu_hours"] for c in cases if math.isfinite(c["cpu_hours"]))
            rows += _rows(pool, f"run (pooled: {' + '.join(pool['rungs'])})", checks, cases, cpu)
    for contrast in ladder.get("contrasts") or []:
        checks, cases, waits = contrast_table_checks(ladder, contrast, results)
        if not checks and keep_committed and (kept := committed_rows(ladder, contrast)):
            rows += kept
        elif not checks:
            rows.append({"rung": contrast["name"], "knob": contrast["knob"], "cpu_hours": np.nan,
                         "state": f"ran, not measured: {waits}" if cases else f"not run ({waits})"})
        else:
            cpu = sum(c["cpu_hours"] for c in cases if math.isfinite(c["cpu_hours"]))
            rows += _rows(contrast, f"{CONTRAST} {contrast['rung']} against {reference_label(contrast)}", checks,
                          cases, cpu)
    rates = measured_rates(pd.DataFrame(rows))
    for rung in ladder.get("planned", []):
        p = plan(ladder, rung, results, priced_only=True, rates=rates)
        rows.append({"rung": rung["name"], "knob": rung["knob"], "state": planned_state(p, ladder["scene"], rates),
                     "cases": len(p["rows"]), "particles": ", ".join(f"{r['particles']:,}" for r in p["rows"]),
                     "cpu_hours": p["total"]["cpu_hours"]})
    return with_from_paper(pd.DataFrame(rows), ladder)


def _rows(rung: dict, state: str, checks: list, cases: list[dict], cpu: float) -> list[dict]:
    """One ladder.csv row per headline check of a rung (or pool) that was measured."""
    rows = []
    for c in checks:
        rows.append({"rung": rung["name"], "knob": rung["knob"], "state": state, "quantity": c.quantity,
                     "replicate": bool(rung.get("replicate")),
                     "paper": c.paper, "ours": c.ours, "stat": c.error, "syst": c.syst, "verdict": c.verdict,
                     "run_to_run": c.run_to_run, "n_replicates": c.n_replicates,
                     "abs_rel_difference": abs(c.difference) if math.isfinite(c.difference) else np.nan,
                     "rel_error": _rel_error(c) if c.paper_range and math.isfinite(c.ours) else np.nan,
                     "paper_error": c.paper_error,
                     "paper_lo": min(c.paper_range) if c.paper_range else np.nan,
                     "paper_hi": max(c.paper_range) if c.paper_range else np.nan,
                     "cases": len(cases), "particles": ", ".join(sorted({f"{c['particles']:,}" for c in cases
                                                                         if c.get("particles")})),
                     "cpu_hours": cpu, **cost_columns(cases), "kind": c.kind})
    return rows


def markdown(df: pd.DataFrame, ladder: dict) -> str:
    text = (f"### {ladder['scene']}: ladder toward the paper (rung {ladder['rung']}, sweep {ladder.get('sweep')})\n\n"
            "One knob per rung from the validation case (`config/ladders/" + f"{ladder['scene']}.yaml`, "
            f"`snakemake ladder_{ladder['scene']}`); each headline by the scene's own validation, ours ± stat ± syst; CPU-hours "
            "measured (planned rungs: the cost model's upper bound).\n\n" + order_line(ladder) +
            "| rung | knob | quantity | ours ± stat ± syst | paper | verdict | CPU-h |\n|---|---|---|---|---|---|---|\n")
    for _, r in df.iterrows():
        if not str(r["state"]).startswith(MEASURED):
            cpu = f"{r['cpu_hours']:.3g}" if math.isfinite(r["cpu_hours"]) else "–"
            text += f"| {r['rung']} | {r['knob']} | – | {r['state']} | | | {cpu} |\n"
            continue
        ours = format_with_errors(r["ours"], r["stat"], r["syst"])
        state = str(r["state"])
        where = "" if state == "run" else f" ({state})" if state.startswith(CONTRAST) else f" ({state[5:-1]})"
        text += (f"| {r['rung']} | {r['knob']}{where} | {r['quantity']} | {ours} | {r['paper']} | "
                 f"{r['verdict']} | {r['cpu_hours']:.2f} |\n")
    return text + "\n" + scatter_lines(df, ladder) + series_lines(df, ladder) + price_lines(df)


def record(ladder: dict, results: Path, out: Path, keep_committed: bool = False) -> str:
    """The ladder's record from its rungs' analysed cases under ``results`` (:func:`table`): ``<out>/ladder.csv``,
    ``ladder.md`` and ``figures/ladder.png`` (the workflow's rule ``ladder_record``; ``tools/ladder.py record``).
    With ``keep_committed``, a rung without runs keeps its committed rows (:func:`committed_rows`).
    Returns the markdown."""
    out = Path(out)
    keep_pooled_rungs(ladder, results, out)
    df = table(ladder, results, keep_committed)
    (out / "figures").mkdir(parents=True, exist_ok=True)
    df.to_csv(out / "ladder.csv", index=False, float_format="%.9g")   # enough digits that a verdict judged again from the file reads alike
    text = markdown(df, ladder)
    (out / "ladder.md").write_text(text)
    figure(df, ladder, out / "figures" / "ladder.png")
    return text
