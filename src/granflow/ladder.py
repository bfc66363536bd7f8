"""A ladder toward a paper: one knob at a time from the validation case, error against the paper vs CPU-hours.

The ladder file (``config/ladders/<scene>.yaml``), each rung's scene file and campaign, the ladder's table
(``validation/<scene>/ladder.csv``), its markdown and figure; ``tools/ladder.py`` is the command over these.
"""
from __future__ import annotations

import json
import math
import textwrap
from pathlib import Path

import numpy as np
import pandas as pd
import yaml

from granflow import registry
from granflow.campaign import load_campaign
from granflow.config import PROJECT_ROOT, apply_overrides, load_scene, load_yaml
from granflow.validation import case_summary, format_with_errors

ROOT = PROJECT_ROOT


def load_ladder(path: Path) -> dict:
    data = load_yaml(path)
    for key in ("scene", "rung", "scene_file", "rungs", "headlines", "from_paper_order"):
        if key not in data:
            raise SystemExit(f"ladder: {path}: missing key {key!r}")
    registry.get(data["scene"])            # refuses an unknown scene by name
    for rung in data["rungs"] + (data.get("planned") or []):
        order = rung.get("from_paper")
        if isinstance(order, bool) or not isinstance(order, (int, float)) or not order >= 0:
            raise SystemExit(f"ladder: {path}: rung {rung.get('name')!r}: from_paper (its order from the paper's "
                             f"setup, a number >= 0) is {order!r}")
        if rung.get("replicate") and order != data["rungs"][0].get("from_paper"):
            raise SystemExit(f"ladder: {path}: replicate rung {rung['name']!r} has from_paper {order}, its first "
                             f"rung {data['rungs'][0]['from_paper']}: a reseed is no step toward the paper")
    return data


def with_from_paper(df: pd.DataFrame, ladder: dict) -> pd.DataFrame:
    """The ladder table with each rung's ``from_paper`` (its order from the paper's setup, from the ladder
    file) as the column after ``knob``; an earlier ``from_paper`` column is replaced."""
    order = {r["name"]: r["from_paper"] for r in ladder["rungs"] + (ladder.get("planned") or [])}
    out = df.drop(columns=["from_paper"], errors="ignore")
    out.insert(list(out.columns).index("knob") + 1 if "knob" in out else 0, "from_paper",
               [order.get(name, np.nan) for name in out["rung"]])
    return out


def order_line(ladder: dict) -> str:
    """The ladder's order of its rungs from the paper's setup, as ``ladder.md`` says it (nothing for a ladder
    that declares none: :func:`load_ladder` refuses a file without it)."""
    rungs = ladder["rungs"] + (ladder.get("planned") or [])
    if "from_paper_order" not in ladder or any("from_paper" not in r for r in rungs):
        return ""
    rungs = sorted(rungs, key=lambda r: r["from_paper"])
    return ("Order from the paper's setup (`from_paper`; 0 is the paper's, the report's front page shows the "
            "measured rung nearest it): " + ", ".join(f"{r['name']} {r['from_paper']:g}" for r in rungs)
            + f". {ladder['from_paper_order'][0].upper()}{ladder['from_paper_order'][1:]}.\n\n")


def rung_dir(results: Path, ladder: dict, name: str) -> Path:
    return Path(results) / ladder["scene"] / name


def _overrides(rung: dict) -> list[str]:
    return [f"{k}={json.dumps(v) if not isinstance(v, str) else v}" for k, v in (rung.get("set") or {}).items()]


def rung_sweep(ladder: dict, rung: dict) -> dict:
    """The rung's sweep: the ladder's, with the values the rung's ``sweep:`` gives replacing its keys'."""
    return {**(ladder.get("sweep") or {}), **(rung.get("sweep") or {})}


def write_rung(ladder: dict, rung: dict, results: Path) -> tuple[Path, Path]:
    """The rung's scene file (the ladder's, changed) and its one-scene campaign; both validated."""
    out = rung_dir(results, ladder, rung["name"])
    out.mkdir(parents=True, exist_ok=True)
    scene_data = apply_overrides(load_yaml(ROOT / ladder["scene_file"]), _overrides(rung))
    scene_file = out / "scene.yaml"
    head = (f"# ladder rung {rung['name']}: {rung['knob']}\n# {ladder['scene_file']} with {rung.get('set') or {}}"
            + (f", sweep {rung['sweep']}" if rung.get("sweep") else "") + "\n")
    text = head + yaml.safe_dump(scene_data, sort_keys=False, allow_unicode=True)
    if not scene_file.exists() or scene_file.read_text() != text:   # unchanged: keep its time stamp
        scene_file.write_text(text)
    load_scene(scene_file)
    campaign = {"rung": rung.get("rung", ladder["rung"]), "results_dir": str(out / "results"),
                "scenes": {name: {"enabled": False} for name in registry.names() if name != ladder["scene"]}}
    campaign["scenes"][ladder["scene"]] = {"enabled": True, "scene_file": str(scene_file),
                                           "sweep": rung_sweep(ladder, rung)}
    campaign_file = out / "campaign.yaml"
    text = yaml.safe_dump(campaign, sort_keys=False)
    if not campaign_file.exists() or campaign_file.read_text() != text:
        campaign_file.write_text(text)
    return scene_file, campaign_file


def plan(campaign_file: Path, priced_only: bool = False) -> dict:
    """The rung's plan; a rung ``priced_only`` (planned, never run here) is not held to this
    machine's CPU-hour limit (``max_cpu_hours``, a week of its cores by default)."""
    from granflow.resources import plan_campaign

    cfg = load_campaign(campaign_file, ["max_cpu_hours=1000000000"] if priced_only else [], root=ROOT)
    return plan_campaign(cfg, Path(cfg["results_dir"]))


def targets(plan_: dict) -> list[str]:
    """Each case's analysis, named by the checksum list analyse writes last."""
    return [str(Path(r["case_dir"]) / "analysis" / "SHA256SUMS") for r in plan_["rows"]]


def rung_checks(ladder: dict, rung: dict, results: Path) -> tuple[list, list[dict]]:
    """(the headline checks of the rung's analysed cases, their case summaries)."""
    base = rung_dir(results, ladder, rung["name"]) / "results" / ladder["scene"] / rung.get("rung", ladder["rung"])
    cases = {str(p.parent.parent.relative_to(base)): p.parent.parent
             for p in sorted(base.glob("**/analysis/scalars.json"))}
    if not cases:
        return [], []
    result = registry.get(ladder["scene"]).validation(base, cases)
    keep = [c for c in result.checks if any(c.quantity.startswith(h) for h in ladder["headlines"])]
    return keep, [case_summary(p) for p in cases.values()]


def committed_checks(ladder: dict) -> tuple[list, list[dict]]:
    """The base rung read from the committed record (``validation/<scene>/summary.json``) when its runs
    are not at hand: the headline checks of the cases matching the ladder's sweep (each key with one value,
    named ``key~value`` in the case), or sweep-wide ones."""
    from granflow.validation import Check

    path = ROOT / "validation" / ladder["scene"] / "summary.json"
    if not path.exists():
        return [], []
    summary = json.loads(path.read_text())
    values = [v[0] for v in (ladder.get("sweep") or {}).values() if len(v) == 1]

    def matches(case: str) -> bool:
        parts = [p.split("~", 1)[1] for p in case.split("/") if "~" in p]
        return all(any(_same(p, v) for p in parts) for v in values)

    keep, dirs = [], set()
    for c in summary["checks"]:
        if any(c["quantity"].startswith(h) for h in ladder["headlines"]) and (c["case"] == "sweep" or matches(c["case"])):
            nan = float("nan")
            keep.append(Check(c["quantity"], c["paper"], c["source"], nan if c["ours"] is None else c["ours"],
                              nan if c.get("error") is None else c["error"], case=c["case"],
                              paper_range=tuple(c["paper_range"]) if c.get("paper_range") else None,
                              paper_error=c.get("paper_error") or 0.0, note=c.get("note", ""),
                              syst=nan if c.get("syst") is None else c["syst"], variants=c.get("variants", "")))
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


def table(ladder: dict, results: Path) -> pd.DataFrame:
    rows = []
    for rung in ladder["rungs"]:
        checks, cases = rung_checks(ladder, rung, results)
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
        for c in checks:
            rows.append({"rung": rung["name"], "knob": rung["knob"], "state": state, "quantity": c.quantity,
                         "replicate": bool(rung.get("replicate")),
                         "paper": c.paper, "ours": c.ours, "stat": c.error, "syst": c.syst, "verdict": c.verdict,
                         "abs_rel_difference": abs(c.difference) if math.isfinite(c.difference) else np.nan,
                         "rel_error": _rel_error(c) if c.paper_range and math.isfinite(c.ours) else np.nan,
                         "paper_lo": min(c.paper_range) if c.paper_range else np.nan,
                         "paper_hi": max(c.paper_range) if c.paper_range else np.nan,
                         "cases": len(cases), "particles": ", ".join(sorted({f"{c['particles']:,}" for c in cases
                                                                             if c.get("particles")})),
                         "cpu_hours": cpu})
    for rung in ladder.get("planned", []):
        _, campaign = write_rung(ladder, rung, results)
        p = plan(campaign, priced_only=True)
        rows.append({"rung": rung["name"], "knob": rung["knob"], "state": "planned (cost model, not run)",
                     "cases": len(p["rows"]), "particles": ", ".join(f"{r['particles']:,}" for r in p["rows"]),
                     "cpu_hours": p["total"]["cpu_hours"]})
    return with_from_paper(pd.DataFrame(rows), ladder)


def figure(df: pd.DataFrame, ladder: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    run = df[df["state"].str.startswith("run")] if "state" in df else df.iloc[:0]
    heads = list(dict.fromkeys(run["quantity"])) if len(run) else []
    fig, axes = plt.subplots(1, max(1, len(heads)), figsize=(4.6 * max(1, len(heads)), 4.2), squeeze=False)
    planned = df[df["state"].str.startswith("planned")]
    for ax, q in zip(axes[0], heads):
        sub = run[run["quantity"] == q]
        for i, (_, r) in enumerate(sub.iterrows()):
            ax.errorbar([r["cpu_hours"]], [r["abs_rel_difference"]], yerr=[r["rel_error"]], marker="os^Dv<>"[i % 7],
                        capsize=3, ls="none", label=r["rung"])
        for _, r in planned.iterrows():
            ax.axvline(r["cpu_hours"], color="0.5", ls=":", lw=1)
            ax.text(r["cpu_hours"], ax.get_ylim()[1] * 0.95, f" {r['rung']}: {r['cpu_hours']:.3g} CPU-h (planned)",
                    rotation=90, va="top", ha="right", fontsize=7, color="0.4")
        ax.set(xscale="log", xlabel="CPU-hours (the rung's cases)", ylabel="|ours − paper| / paper (absolute where 0)",
               title=q if len(q) < 48 else q[:46] + "…")
        ax.title.set_fontsize(8)
        ax.set_ylim(bottom=0)
        ax.legend(fontsize=7)
    sweep = ", ".join(f"{k} {'/'.join(map(str, v))}" for k, v in (ladder.get("sweep") or {}).items())
    fig.suptitle(textwrap.fill(f"{ladder['scene']} ladder (rung {ladder['rung']}; {sweep}): error against the paper "
                               "(bars: stat ⊕ syst) against cost", 70), fontsize=9)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)


def markdown(df: pd.DataFrame, ladder: dict) -> str:
    text = (f"### {ladder['scene']}: ladder toward the paper (rung {ladder['rung']}, sweep {ladder.get('sweep')})\n\n"
            "One knob per rung from the validation case (`config/ladders/" + f"{ladder['scene']}.yaml`, "
            "`tools/ladder.py`); each headline by the scene's own validation, ours ± stat ± syst; CPU-hours "
            "measured (planned rungs: the cost model's upper bound).\n\n" + order_line(ladder) +
            "| rung | knob | quantity | ours ± stat ± syst | paper | verdict | CPU-h |\n|---|---|---|---|---|---|---|\n")
    for _, r in df.iterrows():
        if not str(r["state"]).startswith("run"):
            cpu = f"{r['cpu_hours']:.3g}" if math.isfinite(r["cpu_hours"]) else "–"
            text += f"| {r['rung']} | {r['knob']} | – | {r['state']} | | | {cpu} |\n"
            continue
        ours = format_with_errors(r["ours"], r["stat"], r["syst"])
        where = "" if r["state"] == "run" else f" ({r['state'][5:-1]})"
        text += (f"| {r['rung']} | {r['knob']}{where} | {r['quantity']} | {ours} | {r['paper']} | "
                 f"{r['verdict']} | {r['cpu_hours']:.2f} |\n")
    return text + "\n" + scatter_lines(df, ladder) + series_lines(df, ladder)


def scatter_lines(df: pd.DataFrame, ladder: dict) -> str:
    """What the ladder's replicate rungs say (a rung with ``replicate: true`` runs the first rung's cases again
    with another random seed and nothing else): per headline, how far the two samples lie apart, and each
    other rung's shift from the first rung beside that run-to-run scatter. Two samples differing by Δ put one
    run's scatter near |Δ|/√2; a rung's shift no larger than |Δ| is not told apart from a reseed."""
    replicas = [r["name"] for r in ladder["rungs"] if r.get("replicate")]
    run = df[df["state"].astype(str).str.startswith("run")] if len(df) else df
    if not replicas or not len(run):
        return ""
    first = ladder["rungs"][0]["name"]
    lines = []
    for q in dict.fromkeys(run["quantity"]):
        sub = run[run["quantity"] == q].drop_duplicates("rung").set_index("rung")
        if first not in sub.index:
            continue
        base = sub.loc[first, "ours"]
        for rep in (r for r in replicas if r in sub.index):
            spread = abs(sub.loc[rep, "ours"] - base)
            if not math.isfinite(spread):
                continue
            shifts = [f"{name} {sub.loc[name, 'ours'] - base:+.3g}"
                      + (f" ({abs(sub.loc[name, 'ours'] - base) / spread:.1f} × |Δ|)" if spread > 0 else "")
                      for name in sub.index if name not in (first, *replicas) and math.isfinite(sub.loc[name, "ours"])]
            lines.append(f"- {q}: {first} and its replicate {rep} (another seed, nothing else) differ by "
                         f"Δ = {sub.loc[rep, 'ours'] - base:+.3g} (one run's scatter ≈ |Δ|/√2 = {spread / math.sqrt(2):.2g}, "
                         f"against a quoted stat error of {sub.loc[first, 'stat']:.2g})"
                         + ("; the other rungs' shifts from " + first + ": " + ", ".join(shifts) if shifts else "")
                         + ". A shift no larger than |Δ| is not told apart from a reseed.")
    if not lines:
        return ""
    return "Run-to-run scatter (replicate rungs):\n\n" + "\n".join(lines) + "\n\n"


def series_lines(df: pd.DataFrame, ladder: dict) -> str:
    """The ladder's ``series:``: rungs that turn one knob by steps (``points``: rung → x, e.g. 1/B), each headline
    fitted as a straight line in x by weighted least squares (weights 1/(stat² + syst²)) and read at the points
    ``at`` (label → x, e.g. the paper's size, or x = 0 for the infinite system) with the fit's error and the
    scene's verdict there. Three rungs or more (a fit with a degree of freedom); the line is an assumed form."""
    from granflow.validation import verdict

    run = df[df["state"].astype(str).str.startswith("run")] if len(df) else df
    lines = []
    for series in ladder.get("series") or []:
        points = series["points"]
        for q in (dict.fromkeys(run["quantity"]) if len(run) else []):
            sub = run[(run["quantity"] == q) & run["rung"].isin(list(points))].drop_duplicates("rung")
            sub = sub[np.isfinite(sub["ours"].astype(float))]
            if len(sub) < 3:
                continue
            x = np.array([float(points[r]) for r in sub["rung"]])
            y = sub["ours"].to_numpy(float)
            err = np.hypot(sub["stat"].fillna(0).to_numpy(float), sub["syst"].fillna(0).to_numpy(float))
            if not np.all(err > 0):
                continue
            (slope, intercept), cov = np.polyfit(x, y, 1, w=1 / err, cov="unscaled")   # cov of the errors given
            chi2 = float((((y - intercept - slope * x) / err) ** 2).sum()) / (len(x) - 2)
            paper = (sub["paper_lo"].iloc[0], sub["paper_hi"].iloc[0]) if "paper_lo" in sub else (np.nan, np.nan)
            reads = []
            for label, x0 in series["at"].items():
                v = np.array([float(x0), 1.0])                     # polyfit's order: slope, intercept
                y0, e0 = float(slope * x0 + intercept), float(np.sqrt(v @ cov @ v))
                words = (verdict(y0, e0, paper)[0] if all(np.isfinite(paper)) else "no paper range")
                reads.append(f"at {label} ({series['x']} = {float(x0):g}) {format_with_errors(y0, e0)}: {words}")
            lines.append(f"- {q} along {series['knob']}, a straight line in {series['x']} through "
                         f"{', '.join(sub['rung'])} (slope {slope:+.3g} ± {np.sqrt(cov[0, 0]):.2g}, χ²/ν = {chi2:.2f}): "
                         + "; ".join(reads) + ". The straight line is assumed, not measured: a trend, not a result.")
    if not lines:
        return ""
    return "Series (rungs along one knob, extrapolated):\n\n" + "\n".join(lines) + "\n\n"
