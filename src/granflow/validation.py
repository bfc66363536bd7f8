"""The validation record: each scene's headline numbers against its paper.

A scene compares its finished cases with its paper in :meth:`granflow.registry.Scene.validation`,
which returns a :class:`ValidationResult`: one :class:`Check` per quantity (the paper's value
with the figure or table it comes from, ours with its statistical error, the case it was
measured on), the profiles its figures need, the figures to keep, and what differs from the
paper's set-up. This module is generic: it judges each check (:func:`verdict`), gathers the
provenance of the cases (git commit, LAMMPS version, CPU-hours), picks the key log lines, and
writes ``validation/<scene>/`` and the one table of ``validation/README.md``.

Verdicts are computed, never typed in: a check is ``within error`` when the paper's value or
range lies within ``k`` combined errors of ours (``k`` = :data:`SIGMAS`), otherwise it
``differs`` by the relative amount to the nearest paper value, in units of the error. The
combined error adds in quadrature the statistical error, the systematic error of the
measurement (:func:`systematic`: the largest shift of the headline over the measurement
choices it depends on, each recomputed from the same dumps) and the paper's own error; a
difference no larger than the systematic error alone is reported as such.
"""
from __future__ import annotations

import json
import math
import shutil
from dataclasses import asdict, dataclass, field, fields, replace
from pathlib import Path

import numpy as np
import pandas as pd

from . import provenance, replicates
from .coverage import coverage_line
from .registry import finite
from .verdicts import SIGMAS, systematic, verdict  # noqa: F401 (re-exported: the scenes import them from here)

#: the committed record may hold at most this many bytes per scene (DEVELOPERS.md)
MAX_SCENE_BYTES = 1_000_000


@dataclass
class Check:
    """One row of the validation table.

    Parameters
    ----------
    quantity : str
        What is compared, e.g. ``u_max/u_slip``.
    paper : str
        The paper's value as the paper states it, e.g. ``1.37-1.40``.
    source : str
        Where in the paper: figure, table, equation or section.
    ours : float
        Our value.
    error : float
        One standard error of ours (NaN when the quantity has none): the statistical error.
    case : str
        Case directory it was measured on, or ``sweep`` for a fit over the cases.
    paper_range : tuple of float or None
        The paper's value as numbers ``(lo, hi)`` (``lo == hi`` for one value); None when the
        paper gives a shape, not a number (the verdict is then the note's words).
    paper_error : float
        The paper's own uncertainty of a single value (0 when it gives none).
    unit : str
    note : str
        What the comparison means, or what we think causes a difference.
    syst : float
        Systematic error of ours: the largest shift of the value over the measurement choices
        in ``variants`` (NaN when none was computed; :func:`systematic`).
    variants : str
        Each measurement choice and the value it gives, e.g. ``slab ±0.25 r_b: 0.52; ...``.
    kind : str
        ``comparison``, ``consistency`` or ``diagnostic`` (:data:`granflow.verdicts.KINDS`): only a
        comparison is judged against the paper.
    run_to_run : float
        The replicates' scatter as a standard error of their mean (NaN for one replicate).
    n_replicates : int
        Independent runs (seeds) behind ``ours``.
    """

    quantity: str
    paper: str
    source: str
    ours: float
    error: float = float("nan")
    case: str = "sweep"
    paper_range: tuple[float, float] | None = None
    paper_error: float = 0.0
    unit: str = ""
    note: str = ""
    syst: float = float("nan")
    variants: str = ""
    kind: str = "comparison"
    run_to_run: float = float("nan")
    n_replicates: int = 1
    verdict: str = field(default="", init=False)
    difference: float = field(default=float("nan"), init=False)

    def __post_init__(self):
        self.ours = float(self.ours)
        self.error = float(self.error)
        self.syst = float(self.syst)
        self.run_to_run = float(self.run_to_run)
        self.n_replicates = int(self.n_replicates)
        self.verdict, self.difference = verdict(self.ours, self.error, self.paper_range, self.paper_error,
                                                self.syst, self.kind, self.run_to_run, self.n_replicates)


@dataclass
class ValidationResult:
    """What a scene's :meth:`~granflow.registry.Scene.validation` returns.

    Parameters
    ----------
    checks : list of Check
    profiles : dict of str to DataFrame
        Small tables the figures need (written as ``profiles/<name>.csv``).
    figures : list of str
        Names of the scene's figures (``<results>/<scene>/<rung>/figures/<name>.png``) to keep.
    differences : list of str
        What differs from the paper's set-up, and why.
    note : str
        Why there are no checks, for a scene that declares no validation (:data:`NO_VALIDATION`).
    """

    checks: list[Check]
    profiles: dict[str, pd.DataFrame] = field(default_factory=dict)
    figures: list[str] = field(default_factory=list)
    differences: list[str] = field(default_factory=list)
    note: str = ""


#: the record of a scene without :meth:`~granflow.registry.Scene.validation` says so instead of its checks
NO_VALIDATION = ("no validation declared: the scene gives no validation(), so its cases are listed and nothing "
                 "is compared")


def scene_validation(scene, scene_dir: Path, cases: dict[str, Path]) -> ValidationResult:
    """The scene's :meth:`~granflow.registry.Scene.validation` of its cases, or, for a scene that
    declares none, a result without checks whose note says so (:data:`NO_VALIDATION`)."""
    if not scene.gives("validation"):
        return ValidationResult(checks=[], note=NO_VALIDATION)
    # each seed's cases judged as a campaign without replicates would be, then pooled check by check
    groups = replicates.split(cases)
    kinds = getattr(scene, "check_kinds", {})
    results = [with_kinds(scene.validation(scene_dir, group), kinds) for group in groups.values()]
    return replicates.pool(results, list(groups))


def with_kinds(result: ValidationResult, kinds: dict[str, str]) -> ValidationResult:
    """``result`` with each check of a quantity named in ``kinds`` of that kind (its verdict judged anew)."""
    checks = [replace(c, kind=kinds[c.quantity]) if c.quantity in kinds else c for c in result.checks]
    return replace(result, checks=checks)


#: log lines worth keeping from each case (substrings; the first and last match of each)
KEY_LOG_LINES = ("LAMMPS (", "Loop time", "WARNING", "ERROR")


def key_log_lines(case_dir: Path, limit: int = 40) -> list[str]:
    """The status and the key lines of a case's LAMMPS logs (version, loop times, warnings)."""
    lines = []
    status = case_dir / "run" / "status.json"
    if status.exists():
        st = json.loads(status.read_text())
        lines.append(f"status: {st.get('status')}: {st.get('reason')}")
        if "max_overlap" in st:
            lines.append(f"largest overlap: {st['max_overlap']:.4g} of the smallest diameter")
    for log in sorted((case_dir / "run" / "logs").glob("*.log")):
        seen = {}
        for line in log.read_text(errors="replace").splitlines():
            for key in KEY_LOG_LINES:
                if key in line:
                    seen.setdefault(key, []).append(line.strip())
        for key in KEY_LOG_LINES:
            hits = seen.get(key, [])
            for hit in dict.fromkeys(hits[:1] + hits[-1:]):
                lines.append(f"{log.name}: {hit}")
    return lines[:limit] if len(lines) <= limit else lines[:limit // 2] + ["..."] + lines[-limit // 2:]


def case_summary(case_dir: Path) -> dict:
    """Provenance of one case (commit, LAMMPS version, status, CPU-hours) for the record."""
    # the provenance written right after the run (rule provenance), else as of now
    written = case_dir / "provenance.json"
    prov = json.loads(written.read_text()) if written.exists() else provenance.case_provenance(case_dir)
    status = json.loads((case_dir / "run" / "status.json").read_text())
    record = json.loads((case_dir / "params.json").read_text())
    cpu = prov.get("cpu_seconds")
    # a scene whose runner runs a fixed schedule (completed) labels the case in its analysis
    scalars_path = case_dir / "analysis" / "scalars.json"
    analysed = json.loads(scalars_path.read_text()) if scalars_path.exists() else {}
    final = analysed.get("status") or prov["status"]
    return {
        "case": prov["case"], "status": final,
        "reason": (analysed.get("status_reason") if analysed.get("status") else None) or status.get("reason"),
        "run_status": prov["status"],
        # the commit that finished the run (runs before it was recorded: the record's commit)
        "granflow_commit": status.get("granflow_commit", prov["granflow_commit"]),
        "granflow_dirty": status.get("granflow_dirty", prov["granflow_dirty"]),
        "granflow_dirty_files": prov.get("granflow_dirty_files", []) if "granflow_commit" not in status else None,
        "lammps_version": prov["lammps_version"], "ranks": prov["ranks"],
        "cpu_hours": cpu / 3600.0 if isinstance(cpu, (int, float)) else float("nan"),
        "wall_hours": (prov["wall_seconds"] / 3600.0 if isinstance(prov.get("wall_seconds"), (int, float))
                       else float("nan")),
        "particles": (record.get("n_particles") or (record.get("parameters") or {}).get("n_particles")
                      or record.get("n_particles_estimate")),
        "max_overlap": status.get("max_overlap"),
        # what the run cost per atom-step (granflow.ladder_rates prices the rungs not run from it)
        "atom_steps": status.get("atom_steps"), "steps": _steps_run(case_dir),
        "pair_style": (record.get("contact_law") or {}).get("pair_style"),
    }


def _steps_run(case_dir: Path) -> float:
    """Time steps the case's LAMMPS runs took, from the loop lines of its logs
    (:func:`granflow.runner.loop_totals`; NaN without any)."""
    from .runner import loop_totals  # deferred: the runner is needed only to read finished runs

    steps = sum(loop_totals(log.read_text(errors="replace"))[1]
                for log in sorted((case_dir / "run" / "logs").glob("*.log")))
    return float(steps) if steps else float("nan")


def _clean(value):
    """JSON-safe: NaN and inf become None."""
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, dict):
        return {k: _clean(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_clean(v) for v in value]
    return value


#: files of ``validation/<scene>/`` written by another rule (``ladder_record``, :mod:`granflow.ladder`) that a rewrite of the
#: record keeps: the ladder, and the profiles its pools read (``pooled/``, a directory kept whole), are measured on
#: other runs than the record's cases
KEPT_FILES = ("ladder.csv", "ladder.md", "figures/ladder.png", "pooled")


def write_record(scene_name: str, rung: str, result: ValidationResult, case_dirs: dict[str, Path],
                 figures_dir: Path, out: Path, paper: str = "") -> dict:
    """Write ``out`` = ``validation/<scene>/``: summary.json, checks.csv, profiles, figures, logs
    (everything else there is replaced, but for :data:`KEPT_FILES`).

    ``case_dirs`` maps each case's directory name (e.g. ``W~60/phi~0.6``) to its path.

    Returns the summary. Refuses (ValueError) a record over :data:`MAX_SCENE_BYTES`.
    """
    out = Path(out)
    # the code that writes the record; the record's own files (validation/) do not make it dirty
    record_git = provenance.git_state()
    files = record_git["dirty_files"]
    record_dirty = ([f for f in files if not f.startswith("validation/")] if isinstance(files, list)
                    else record_git["dirty"])
    kept = {str(f.relative_to(out)): f.read_bytes() for name in KEPT_FILES
            for f in ([out / name] if (out / name).is_file() else sorted((out / name).rglob("*"))) if f.is_file()}
    if out.exists():
        shutil.rmtree(out)
    (out / "profiles").mkdir(parents=True)
    (out / "figures").mkdir()
    (out / "logs").mkdir()
    for name, data in kept.items():
        (out / name).parent.mkdir(parents=True, exist_ok=True)
        (out / name).write_bytes(data)
    cases = [dict(dir=rel, **case_summary(Path(path))) for rel, path in case_dirs.items()]
    for c in cases:  # each run's seed, and every seed its case ran from (the replicates)
        c["seed"] = replicates.seed_of(c["dir"]) or (c.get("case") or {}).get("seed")
    for c in cases:
        c["seeds"] = [o["seed"] for o in cases if replicates.base_of(o["dir"]) == replicates.base_of(c["dir"])]
    checks = [asdict(c) for c in result.checks]
    # the columns named: a scene without checks still gets the table's header
    pd.DataFrame(checks, columns=[f.name for f in fields(Check)]).to_csv(out / "checks.csv", index=False)
    for name, table in result.profiles.items():
        table.to_csv(out / "profiles" / f"{name}.csv", index=False, float_format="%.6g")
    for name in result.figures:
        src = Path(figures_dir) / f"{name}.png"
        if src.exists():
            copy_figure(src, out / "figures" / src.name)
    for rel, path in case_dirs.items():
        (out / "logs" / (rel.replace("/", "_") + ".txt")).write_text("\n".join(key_log_lines(Path(path))) + "\n")
    commits = sorted({c["granflow_commit"] for c in cases if c["granflow_commit"]})
    summary = {
        "scene": scene_name, "rung": rung, "paper": paper,
        "granflow_commits": commits,
        "record_commit": record_git["commit"], "record_dirty": record_dirty,
        "lammps_versions": sorted({str(c["lammps_version"]) for c in cases}),
        "cpu_hours": sum(c["cpu_hours"] for c in cases if math.isfinite(c["cpu_hours"])),
        "cases": cases, "checks": checks, "differences": result.differences,
        "figures": [f"figures/{n}.png" for n in result.figures if (out / "figures" / f"{n}.png").exists()],
        "sigmas": SIGMAS,
    }
    if result.note:  # only then: the records of scenes with checks keep their keys
        summary["note"] = result.note
    (out / "summary.json").write_text(json.dumps(_clean(summary), indent=1, ensure_ascii=False) + "\n")
    size = sum(p.stat().st_size for p in out.rglob("*") if p.is_file())
    if size > MAX_SCENE_BYTES:
        raise ValueError(f"validation record of {scene_name} is {size / 1e6:.2f} MB: allowed <= "
                         f"{MAX_SCENE_BYTES / 1e6:.1f} MB (fewer or smaller figures and profiles)")
    return summary


def copy_figure(src: Path, dst: Path) -> None:
    """Copy a PNG into the record as a 256-colour palette image when that is smaller (plots have few
    colours; typically 3-4x smaller, keeping the record under :data:`MAX_SCENE_BYTES`), else as it is."""
    shutil.copyfile(src, dst)
    try:
        from PIL import Image

        with Image.open(src) as img:
            small = img.convert("RGB").quantize(colors=256, method=Image.Quantize.MEDIANCUT)
            tmp = dst.with_suffix(".tmp.png")
            small.save(tmp, optimize=True)
        if tmp.stat().st_size < dst.stat().st_size:
            tmp.replace(dst)
        else:
            tmp.unlink()
    except (OSError, ValueError):
        pass   # not a PNG Pillow reads: the plain copy stays


def format_with_errors(x: float, err: float = float("nan"), syst: float | None = None) -> str:
    """``x ± stat`` or ``x ± stat ± syst`` with the digits of the smaller finite error."""
    if x is None or not math.isfinite(x):
        return "–"
    errs = [e for e in (err, syst) if e is not None and math.isfinite(e) and e > 0]
    if not errs:
        return f"{x:.4g}"
    digits = max(0, 1 - int(math.floor(math.log10(min(errs)))))
    text = f"{x:.{digits}f}"
    text += f" ± {err:.{digits}f}" if err is not None and math.isfinite(err) and err > 0 else " ± –"
    if syst is not None and math.isfinite(syst):
        text += f" ± {syst:.{digits}f}"
    return text


def readme_table(summaries: list[dict]) -> str:
    """The one table of ``validation/README.md`` from the scenes' summaries."""
    rows = ["| scene | quantity | kind | paper (source) | ours ± stat (± syst) | run-to-run (seeds) | case | rung, size "
            "| CPU-h | verdict |",
            "|---|---|---|---|---|---|---|---|---|---|"]
    for s in summaries:
        size = ", ".join(sorted({f"{c['particles']:,} particles" for c in s["cases"] if c.get("particles")}))
        for c in s["checks"]:
            unit = f" {c['unit']}" if c.get("unit") else ""
            r2r, n = c.get("run_to_run"), c.get("n_replicates") or 1
            spread = f"{r2r:.2g} ({n})" if isinstance(r2r, float) and math.isfinite(r2r) else f"– ({n})"
            rows.append(f"| {s['scene']} | {c['quantity']} | {c.get('kind') or 'comparison'} | {c['paper']}{unit} "
                        f"({c['source']}) | {format_with_errors(c['ours'], c['error'], c.get('syst'))}{unit} | "
                        f"{spread} | {c['case']} | {s['rung']}, {size} | {s['cpu_hours']:.2f} | {c['verdict']} |")
    return "\n".join(rows) + "\n"


# ------------------------------------------------------------------ helpers of the scenes' checks
def read_case(path: Path) -> tuple[dict, dict, dict, str]:
    """``(params.json, run/status.json, analysis/scalars.json, why_not)`` of a finished case.

    ``why_not`` is empty for a case averaged in a steady state, else why it has no numbers to compare.
    """
    path = Path(path)
    record = json.loads((path / "params.json").read_text())
    status = json.loads((path / "run" / "status.json").read_text())
    scalars_path = path / "analysis" / "scalars.json"
    scalars = json.loads(scalars_path.read_text()) if scalars_path.exists() else {}
    why_not = ""
    if status.get("status") != "steady":
        why_not = f"not measured: {status.get('status')}: {status.get('reason')}"
        if status.get("dumps"):
            why_not += " (the frames it averaged anyway are in table.csv, not compared: no steady average)"
    elif not status.get("dumps"):
        why_not = "not measured: steady but no averaged frames"
    elif not scalars:
        why_not = "not measured: no analysis/scalars.json"
    return record, status, scalars, why_not


def read_table(file: Path) -> pd.DataFrame:
    """A CSV table (a case's ``analysis/<name>.csv``, a scene's ``table.csv``), or an empty table where
    the file is absent, empty or holds no columns (what an empty DataFrame writes).

    Parameters
    ----------
    file : Path
        The CSV file.
    """
    file = Path(file)
    if not (file.exists() and file.stat().st_size):
        return pd.DataFrame()
    try:
        return pd.read_csv(file)
    except pd.errors.EmptyDataError:  # a table without columns (an analysis of a run that was not averaged)
        return pd.DataFrame()


def concat_profiles(named_parts) -> dict[str, pd.DataFrame]:
    """``{name: one table}`` from ``(name, [per-case tables])`` pairs, leaving out names without tables."""
    return {name: pd.concat(parts, ignore_index=True) for name, parts in named_parts if parts}


def time_average_errors(scene_name: str, case_dir: Path, record: dict, why_not: str = "",
                        n_blocks: int = 4) -> dict:
    """Headline values of a case with their time-average errors over the rung's averaging time.

    :func:`granflow.headline.measure_with_errors` (correlation-aware errors, ``n_blocks`` blocks as the
    cross-check); ``{"why": ...}`` when ``why_not`` says the case has no steady average, or when its
    dumps cannot be read (the values stay, the errors are NaN).
    """
    from .headline import measure_with_errors

    if why_not:
        return {"why": why_not}
    try:
        return measure_with_errors(scene_name, case_dir, record, record["rung_knobs"]["t_average"],
                                   n_blocks=n_blocks)
    except (OSError, ValueError) as err:
        return {"why": f"no time-average error: {type(err).__name__}: {err}"}


def headline_errors(scene_name: str, case_dir: Path, record: dict, status: dict, fallback: dict,
                    measured: bool = True) -> tuple[dict, str]:
    """The standard error of each headline number, and a note on how it was obtained.

    :func:`granflow.headline.measure_with_errors` over the rung's averaging time when the case
    was ``measured`` and its dumps (``status["dumps"]``) are there; otherwise ``fallback``
    (``{key: the analysis's own error}``, NaN where it has none), and the note says why.
    """
    from .headline import measure_with_errors

    if not measured:
        return dict(fallback), ""
    dumps = status.get("dumps") or []
    if not dumps or not all((Path(case_dir) / "run" / d).exists() for d in dumps):
        return dict(fallback), "dumps absent: the analysis's own errors"
    try:
        m = measure_with_errors(scene_name, case_dir, record, record["rung_knobs"]["t_average"], n_blocks=4)
    except (OSError, ValueError, KeyError, IndexError, np.linalg.LinAlgError) as exc:
        return dict(fallback), f"measure_with_errors failed ({exc}): the analysis's own errors"
    errors = {k: finite(m[k]["se"]) if k in m else fallback[k] for k in fallback}
    first = m.get(next(iter(fallback)), {})
    return errors, (f"error: {first.get('se_method', 'block')} over "
                    f"{first.get('n_series', first.get('n_blocks'))} sub-windows")


def error_note(entry: dict | None, why: str = "") -> str:
    """Which error a check carries, from one key's entry of :func:`time_average_errors`."""
    if not entry or not math.isfinite(entry.get("se", float("nan"))):
        return f"error: none ({why or 'no finite block values'})"
    method = entry.get("se_method", "block")
    if method == "block":
        return f"error: block standard error of the time average ({entry.get('n_blocks')} blocks)"
    text = (f"error: {method} standard error of the time average (statistical inefficiency "
            f"g = {entry.get('g', float('nan')):.2g} over {entry.get('n_series', '?')} sub-windows")
    if entry.get("reliable") is False:
        text += "; fewer than 50 g sub-windows, so g may be underestimated"
    text += ")"
    if math.isfinite(entry.get("se_block", float("nan"))):
        text += f"; {entry.get('n_blocks')}-block error {entry['se_block']:.2g}"
    return text


def sci(x: float, digits: int = 1) -> str:
    """``1e6``, ``1.2e-4``: a number in the papers' short scientific form."""
    mantissa, exponent = f"{float(x):.{digits - 1}e}".split("e")
    return f"{mantissa}e{int(exponent)}"


README_HEAD = """# Validation record

Each scene's headline numbers against its paper, at the `{rung}` rung: the finest these
2-core machines afford (each case at most ~1.5 h on 2 cores). Written by `make validate`
(`snakemake --configfile config/validation.yaml --cores 2 --set-threads simulate=1 validate`),
which reruns the campaign `config/validation.yaml` (every simulation resumes from its last
restart, so it can be split over sittings) and rewrites this folder. Do not edit by hand.

- **ours ± stat**: one standard error that knows about correlation: the series of the
  quantity over consecutive sub-windows of the averaging window, its statistical inefficiency
  g (integrated autocorrelation time, `emcee.autocorr.integrated_time`) and
  se = sd·sqrt(g/n) (`postproc.autocorr`); the block error stays in `summary.json` as a
  cross-check. Fit parameters carry the fit's standard errors.
- **± syst** (where shown): the systematic error of the measurement, the largest shift of the
  number over the measurement choices it depends on (kernel width, slab, fit form, fit range,
  …), each recomputed from the same dumps; `<scene>/checks.csv` lists every variant
  (`variants`). A number without it has not had its measurement choices varied yet.
- **run-to-run (seeds)**: a case run from several seeds (`<case>/seed~<seed>`, the campaign's
  `sweep.seed`) is judged seed by seed and pooled: ours is the replicates' mean, stat the mean's
  error, run-to-run their scatter s/√n (it holds the statistical scatter too, so the combined
  error errs wide); `(1)`: one run, its scatter unknown.
- **kind**: *comparison* (can fail against the paper), *consistency* (forced by the quantity's
  definition or an exact identity of our code: a test of the code, never a verdict against the
  paper), *diagnostic* (a reading of a measurement choice). Only comparisons get a verdict.
- **verdict**: *within the systematic error* when the difference from the paper is no larger
  than the systematic error alone; *within error* when the paper's value (or the nearest end
  of its range) lies within {sigmas:g} combined errors (stat, run-to-run, syst and the paper's,
  in quadrature); *not resolved (± x)* instead of either when {sigmas:g} combined errors exceed
  25 % of the paper's value (such an error cannot tell a 25 % difference from none); otherwise
  *differs by* the relative amount and the number of standard errors, which needs two
  replicates: one run says *one sample: off by*. A quantity the paper gives only as a shape is
  compared in words (see the note in `<scene>/checks.csv`). Nothing was tuned to match a paper.
- **coverage** (under the table): how many of the results each paper states (its
  `src/granflow/scenes/<scene>/paper_results.yaml`) a comparison of the record tests.
- Each `<scene>/summary.json` carries the granflow commit and the LAMMPS version of its runs,
  each case's status, particles, largest overlap and CPU-hours; `<scene>/logs/` has the key
  LAMMPS log lines, `<scene>/profiles/` the profiles its figures show, `<scene>/figures/` the
  figures.

"""


def ladder_rows(scene_folder: Path) -> list[dict]:
    """The rows of ``scene_folder/ladder.csv`` as dicts of strings ([] without one): what
    :func:`granflow.coverage.count` reads of a ladder."""
    path = Path(scene_folder) / "ladder.csv"
    if not path.is_file():
        return []
    import csv

    with open(path, newline="", encoding="utf-8") as f:
        return list(csv.DictReader(f))


def write_readme(folder: Path) -> str:
    """Write ``folder/README.md`` from every ``folder/<scene>/summary.json``; return the text."""
    folder = Path(folder)
    summaries = [json.loads(p.read_text()) for p in sorted(folder.glob("*/summary.json"))]
    for s in summaries:
        for c in s["checks"]:
            for key in ("ours", "error", "difference", "syst", "run_to_run"):
                c[key] = float("nan") if c.get(key) is None else c[key]
        for c in s["cases"]:
            c["cpu_hours"] = float("nan") if c.get("cpu_hours") is None else c["cpu_hours"]
    rungs = sorted({s["rung"] for s in summaries}) or ["validation"]
    text = README_HEAD.format(rung=", ".join(rungs), sigmas=SIGMAS)
    text += readme_table(summaries) + "\n"
    text += "".join(f"- {s['scene']}: {s['note']}\n" for s in summaries if s.get("note"))
    # how much of each paper the record compares (granflow.coverage: the scene's paper_results.yaml)
    text += "".join(f"- {s['scene']}: {line}\n" for s in summaries
                    if (line := coverage_line(s["scene"], s["checks"], ladder_rows(folder / s["scene"]))))
    text += "\n" if any(s.get("note") for s in summaries) else ""
    text += "## Cost\n\n| scene | cases | particles | CPU-hours | commit | LAMMPS |\n|---|---|---|---|---|---|\n"
    for s in summaries:
        parts = [c["particles"] for c in s["cases"] if c.get("particles")]
        size = f"{min(parts):,}–{max(parts):,}" if parts else "–"
        text += (f"| {s['scene']} | {len(s['cases'])} | {size} | {s['cpu_hours']:.2f} | "
                 f"{', '.join(c[:10] for c in s['granflow_commits'])} | {', '.join(s['lammps_versions'])} |\n")
    total = sum(s["cpu_hours"] for s in summaries)
    text += f"| all | {sum(len(s['cases']) for s in summaries)} | | {total:.2f} | | |\n\n"
    text += "## Cases\n\n| scene | case | status | particles | largest overlap (of d_min) | CPU-h |\n|---|---|---|---|---|---|\n"
    for s in summaries:
        for c in s["cases"]:
            ov = c.get("max_overlap")
            ov = f"{100 * ov:.2f} %" if isinstance(ov, (int, float)) else "–"
            text += (f"| {s['scene']} | {c['dir']} | {c['status']} | {c.get('particles') or '–'} | {ov} | "
                     f"{c['cpu_hours']:.2f} |\n")
    changes = sorted((folder / "changes").glob("*.md"))
    if changes:
        text += ("\n## Changes: one-knob reruns against this record\n\n"
                 "Written by `tools/compare_record.py` (the scene's own validation on the rerun cases, "
                 "beside the same checks above); the record above is the last full `make validate`.\n\n")
        text += "".join(p.read_text() for p in changes)
    ladders = sorted(folder.glob("*/ladder.md"))
    if ladders:
        text += ("\n## Ladders: one knob at a time toward the paper\n\n"
                 "Written by `snakemake ladder` (config/ladders/<scene>.yaml: every rung run, then the record) from "
                 "each rung's analysed cases "
                 "(the figure: `<scene>/figures/ladder.png`).\n\n")
        for p in ladders:
            text += p.read_text()
            figure = p.parent / "figures" / "ladder.png"
            if figure.exists():
                text += (f"\n![{p.parent.name}: error against the paper against CPU-hours, one point per rung]"
                         f"({figure.relative_to(folder).as_posix()})\n\n")
    text += "\n## What differs from the papers\n\n"
    for s in summaries:
        text += f"### {s['scene']}" + (f" ({s['paper']})" if s.get("paper") else "") + "\n\n"
        text += "".join(f"- {d}\n" for d in s["differences"]) or f"- {s.get('note') or 'nothing stated'}\n"
        text += "\n"
    (folder / "README.md").write_text(text)
    return text
