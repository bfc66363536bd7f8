"""Where a campaign's time goes: Snakemake's benchmark record of every job, summed per rule
and per phase of ``make demo`` (install, rendering, LAMMPS, analysis, figures, report).

Every rule of the campaign that does work writes a ``benchmark:`` file,
``<dir>/benchmarks/<rule>[_<wildcard>].tsv``, where ``<dir>`` is the directory of the
job's results: a case (``<results>/<scene>/<rung>/<case>``), a scene
(``<results>/<scene>/<rung>``) or, for the rules of the whole campaign,
``<results>/benchmarks/<rung>``. Snakemake (9.x) writes one tab-separated line per run
under the header ``s  h:m:s  max_rss  max_vms  max_uss  max_pss  io_in  io_out  mean_load
cpu_time``: wall seconds, peak resident memory of the job's process tree (MB, summed over
its processes), ... and CPU seconds (user + system, every process of the tree). Memory and
CPU are sampled (every 0.5 s at first, then every 30 s): a job that ends before the first
sample has them ``NA``, and the CPU seconds of a subprocess that ends between two samples
are partly missed, so the CPU column is a lower bound.

Three times lie outside Snakemake and are read from files the Makefile writes, when they
exist (else the table says "not measured", never a guess): the install
(``.venv/.install_seconds``), the ``snakemake`` call of ``make demo``
(``<results>/timing/workflow_seconds``) and its ``snakemake --report`` call
(``<results>/timing/report_seconds``). The rule that writes this table runs after every
other job of the campaign; it cannot time itself, nor the ``--report`` that follows it in
``make demo`` (that file is from the previous ``make demo``; the table gives its date).

Each job's benchmark is that of its last run: after a rerun of part of the campaign the
table still holds every job of the campaign, i.e. what a whole ``make demo`` costs.

The time lost around LAMMPS comes from each case's ``run/status.json``, which records
the seconds of LAMMPS's run loops (``loop_seconds``, from its logs) and the wall seconds of
the LAMMPS invocations (``wall_seconds``), beside the ``simulate`` job's own wall time.

Nothing here names a scene. ``python -m granflow.timing results`` prints the table (Markdown).
"""
from __future__ import annotations

import argparse
import csv
import json
import math
import os
import sys
from datetime import datetime, timezone
from pathlib import Path

#: the phases of ``make demo``, in order; a rule of no known phase goes to "other"
PHASES = ("install", "rendering", "LAMMPS", "analysis", "figures", "report", "other")
#: the phase of each rule of the campaign (rule names, never scene names)
RULE_PHASE = {
    "render": "rendering",
    "simulate": "LAMMPS",
    "analyse": "analysis",
    "table": "figures",
    "figure": "figures",
    "snapshots": "figures",
    "provenance": "report",
    "provenance_table": "report",
    "validation_record": "report",
    "validation_readme": "report",
    "validation_report": "report",
    "validation_ladder_report": "report",
    "ladder_record": "report",
    "accuracy_cost_report": "report",
    "overview": "report",
}
#: the rule writing this table: not timed (it would have to time itself)
TIMING_RULE = "timing"
#: the columns of Snakemake's benchmark file that the table uses
REQUIRED_COLUMNS = ("s", "max_rss", "cpu_time")
#: Snakemake's marks of a value it could not measure (NA: not sampled; -: not available)
MISSING = ("NA", "-", "")
#: a case's LAMMPS record, beside its ``benchmarks`` folder (rule simulate's output)
STATUS = Path("run") / "status.json"
#: where the Makefile records the times outside Snakemake, relative to the results directory
WORKFLOW_SECONDS = Path("timing") / "workflow_seconds"
REPORT_SECONDS = Path("timing") / "report_seconds"
#: where the Makefile records the install time, relative to the checkout
INSTALL_SECONDS = Path(".venv") / ".install_seconds"
CSV_COLUMNS = ("phase", "rule", "jobs", "wall_s", "cpu_s", "cpu_sampled_jobs", "max_rss_mb", "wall_share", "note")


class BenchmarkError(ValueError):
    """A benchmark or seconds file that cannot be read as one (names the file and what is wrong)."""


def _number(text: str, where: str) -> float | None:
    """A non-negative finite number, or None for Snakemake's NA/-; anything else is refused."""
    text = text.strip()
    if text in MISSING:
        return None
    try:
        value = float(text)
    except ValueError:
        raise BenchmarkError(f"{where}: {text!r} is not a number (allowed: a number of seconds or MB, "
                             f"or {'/'.join(m for m in MISSING if m)} for not measured)") from None
    if not math.isfinite(value) or value < 0:
        raise BenchmarkError(f"{where}: {text!r} is not a finite non-negative number")
    return value


def read_benchmark(path: str | Path) -> list[dict]:
    """The records of one Snakemake benchmark file (one per run of the job).

    Returns
    -------
    list of dict
        ``{"wall_s", "cpu_s", "max_rss_mb"}`` per record: wall seconds ``s``, CPU seconds
        ``cpu_time`` and peak RSS ``max_rss`` (MB); the last two None when not sampled.

    Raises
    ------
    BenchmarkError
        Not a benchmark file: a header without the columns ``s``, ``max_rss``, ``cpu_time``,
        no record, a row of the wrong length, or a value that is not a number.
    """
    path = Path(path)
    try:
        lines = [line.rstrip("\n") for line in path.read_text().splitlines() if line.strip()]
    except (OSError, UnicodeDecodeError) as exc:
        raise BenchmarkError(f"{path}: cannot be read as a Snakemake benchmark file ({exc})") from None
    header = lines[0].split("\t") if lines else []
    missing = [c for c in REQUIRED_COLUMNS if c not in header]
    if missing:
        raise BenchmarkError(f"{path}: not a Snakemake benchmark file: its header {lines[0][:80]!r} lacks the "
                             f"column(s) {', '.join(missing)} (expected tab-separated s, h:m:s, max_rss, ..., "
                             f"cpu_time)" if lines else f"{path}: empty, not a Snakemake benchmark file")
    if len(lines) < 2:
        raise BenchmarkError(f"{path}: a header and no record: the job did not finish writing it")
    col = {name: header.index(name) for name in REQUIRED_COLUMNS}
    records = []
    for n, line in enumerate(lines[1:], start=2):
        cells = line.split("\t")
        if len(cells) != len(header):
            raise BenchmarkError(f"{path}, line {n}: {len(cells)} tab-separated values for {len(header)} columns")
        wall = _number(cells[col["s"]], f"{path}, line {n}, column s")
        if wall is None:
            raise BenchmarkError(f"{path}, line {n}, column s: the wall time is missing")
        records.append({"wall_s": wall, "cpu_s": _number(cells[col["cpu_time"]], f"{path}, line {n}, column cpu_time"),
                        "max_rss_mb": _number(cells[col["max_rss"]], f"{path}, line {n}, column max_rss")})
    return records


def rule_of(path: str | Path) -> str:
    """The rule of a benchmark file from its name: ``figure_fig04.tsv`` -> ``figure``
    (the longest rule of :data:`RULE_PHASE` that the name starts with, else the whole stem)."""
    stem = Path(path).stem
    known = [r for r in RULE_PHASE if stem == r or stem.startswith(r + "_")]
    return max(known, key=len) if known else stem


def find_benchmarks(results_dir: str | Path, rung: str, dirs=None) -> tuple[list[Path], int]:
    """The benchmark files of the campaign at ``rung`` under ``results_dir``.

    Those of the scenes' results (``<results>/<scene>/<rung>/**/benchmarks/*.tsv``) and of
    the whole campaign (``<results>/benchmarks/<rung>/*.tsv``). With ``dirs`` (the job
    directories of the campaign, as the workflow names them), a scene's file is kept only if
    its job directory is one of them: a case dropped from the sweep keeps its files on disk,
    and they are left out. Returns the files and how many were left out.
    """
    results_dir = Path(results_dir)
    scene_files = sorted(results_dir.glob(f"*/{rung}/**/benchmarks/*.tsv"))
    kept = scene_files
    if dirs is not None:
        wanted = {os.path.normpath(d) for d in dirs}
        kept = [p for p in scene_files if os.path.normpath(p.parent.parent) in wanted]
    campaign = sorted((results_dir / "benchmarks" / rung).glob("*.tsv"))
    return kept + campaign, len(scene_files) - len(kept)


def _when(path: Path) -> str:
    return datetime.fromtimestamp(path.stat().st_mtime, tz=timezone.utc).strftime("%Y-%m-%d %H:%M UTC")


def measured_seconds(path: str | Path | None, what: str, writer: str) -> tuple[float | None, str]:
    """Seconds recorded in a file by the Makefile, with a note saying what they are and where
    they come from (``what (path, date)``); ``(None, "not measured: ...")`` when there is no file.
    ``writer`` says what writes the file."""
    if path is None:
        return None, "not measured"
    if not Path(path).exists():
        return None, f"not measured: no {path} ({writer})"
    path = Path(path)
    text = path.read_text().strip()
    seconds = _number(text, f"{path}") if text else None
    if seconds is None:
        raise BenchmarkError(f"{path}: {text!r} is not a number of seconds ({writer})")
    return seconds, f"{what} ({path}, written {_when(path)})"


def lammps_overhead(benchmarks: list[Path]) -> dict:
    """LAMMPS's run loops against the ``simulate`` jobs' wall time, over the cases where both
    are known and agree (a run resumed over several jobs sums LAMMPS over all of them but its
    benchmark holds the last job only: it is left out).

    Returns
    -------
    dict
        ``cases``, ``left_out``, and the sums over the cases: ``job_wall_s`` (the jobs),
        ``lammps_wall_s`` (the LAMMPS invocations), ``loop_s`` (their run loops) and
        ``lammps_cpu_s`` (the CPU seconds of the LAMMPS processes as the runner counts them,
        exactly, where Snakemake's samples may miss a short segment).
        Around LAMMPS: ``job_wall_s - loop_s``, of which ``lammps_wall_s - loop_s`` inside
        the LAMMPS processes (start-up, setup, output after the loops) and
        ``job_wall_s - lammps_wall_s`` outside them (Python, the runner, the MPI launcher).
    """
    out = {"cases": 0, "left_out": 0, "job_wall_s": 0.0, "lammps_wall_s": 0.0, "loop_s": 0.0, "lammps_cpu_s": 0.0}
    for bench in benchmarks:
        if rule_of(bench) != "simulate":
            continue
        status_path = bench.parent.parent / STATUS
        try:
            status = json.loads(status_path.read_text())
        except (OSError, ValueError):
            out["left_out"] += 1
            continue
        job = sum(r["wall_s"] for r in read_benchmark(bench))
        loop, lmp = status.get("loop_seconds"), status.get("wall_seconds")
        if not (isinstance(loop, (int, float)) and isinstance(lmp, (int, float)) and 0 <= loop <= lmp <= job):
            out["left_out"] += 1
            continue
        out["cases"] += 1
        out["job_wall_s"] += job
        out["lammps_wall_s"] += lmp
        out["loop_s"] += loop
        cpu = status.get("cpu_seconds")
        out["lammps_cpu_s"] += cpu if isinstance(cpu, (int, float)) and math.isfinite(cpu) else math.nan
    return out


def _lammps_note(lost: dict) -> str:
    if not lost["cases"]:
        return ("time around LAMMPS not known: no case with both its simulate benchmark and a run/status.json "
                "recording loop_seconds and wall_seconds")
    job, lmp, loop = lost["job_wall_s"], lost["lammps_wall_s"], lost["loop_s"]
    note = (f"LAMMPS's run loops: {loop:,.0f} s of the simulate jobs' {job:,.0f} s ({loop / job:.1%}, "
            f"{lost['cases']} case(s)); around them {job - loop:,.0f} s: {lmp - loop:,.0f} s inside LAMMPS "
            f"(start-up, setup, output after the loops), {job - lmp:,.0f} s outside (Python, runner, launcher)")
    if math.isfinite(lost["lammps_cpu_s"]):
        note += f"; the LAMMPS processes used {lost['lammps_cpu_s']:,.0f} CPU s (the runner's count, all ranks)"
    if lost["left_out"]:
        note += (f"; {lost['left_out']} case(s) left out (no status, or a run resumed over several jobs whose "
                 f"benchmark holds the last job only)")
    return note


def _row(phase: str, rule: str, records: list[dict], note: str = "") -> dict:
    cpu = [r["cpu_s"] for r in records if r["cpu_s"] is not None]
    rss = [r["max_rss_mb"] for r in records if r["max_rss_mb"] is not None]
    return {"phase": phase, "rule": rule, "jobs": len(records),
            "wall_s": sum(r["wall_s"] for r in records) if records else None,
            "cpu_s": sum(cpu) if cpu else None, "cpu_sampled_jobs": len(cpu),
            "max_rss_mb": max(rss) if rss else None, "wall_share": None, "note": note}


def _outside(phase: str, rule: str, seconds: float | None, note: str) -> dict:
    """A row timed by the Makefile: one wall time, no CPU or memory (no job and no time if not measured)."""
    return _row(phase, rule, [{"wall_s": seconds, "cpu_s": None, "max_rss_mb": None}] if seconds is not None else [],
                note)


def campaign_timing(results_dir: str | Path, rung: str, *, dirs=None, install: str | Path | None = INSTALL_SECONDS,
                    workflow: str | Path | None = None, report: str | Path | None = None) -> dict:
    """The campaign's time per rule and per phase.

    Parameters
    ----------
    results_dir, rung
        The campaign's results directory and rung.
    dirs
        The campaign's job directories (see :func:`find_benchmarks`); None keeps every file found.
    install, workflow, report
        The files holding the seconds of the install, of the ``snakemake`` call and of the
        ``snakemake --report`` call (defaults: :data:`INSTALL_SECONDS`, and
        :data:`WORKFLOW_SECONDS`, :data:`REPORT_SECONDS` under ``results_dir``).

    Returns
    -------
    dict
        ``rules``: one row per rule (``phase, rule, jobs, wall_s, cpu_s, cpu_sampled_jobs,
        max_rss_mb, wall_share, note``) then the total; ``phases``: the same per phase then
        the total; ``notes``: what the table cannot show; ``lammps``: :func:`lammps_overhead`.
        ``wall_share`` is the row's share of the summed wall time of every measured row:

        .. math:: \\mathrm{share}_i = t_i / \\sum_j t_j

        (the shares of the measured rows sum to 1). A time that was not measured is None.
    """
    results_dir = Path(results_dir)
    workflow = results_dir / WORKFLOW_SECONDS if workflow is None else workflow
    report = results_dir / REPORT_SECONDS if report is None else report
    files, stale = find_benchmarks(results_dir, rung, dirs)
    by_rule: dict[str, list[dict]] = {}
    for path in files:
        by_rule.setdefault(rule_of(path), []).extend(read_benchmark(path))
    lost = lammps_overhead(files)

    seconds, note = measured_seconds(install, "make's last install of .venv", "make writes it when it installs .venv")
    rows = [_outside("install", "install (.venv)", seconds, note)]
    order = {r: i for i, r in enumerate(RULE_PHASE)}
    for rule in sorted(by_rule, key=lambda r: (PHASES.index(RULE_PHASE.get(r, "other")), order.get(r, 99), r)):
        rows.append(_row(RULE_PHASE.get(rule, "other"), rule, by_rule[rule],
                         _lammps_note(lost) if rule == "simulate" else ""))
    seconds, note = measured_seconds(report, "the last make demo's snakemake --report, which runs after this "
                                             "table's rule", "make demo writes it")
    rows.append(_outside("report", "snakemake --report", seconds, note))
    rows.append({**_outside("report", TIMING_RULE, None, "not timed: this table's own rule, which runs after "
                                                         "every job it times"), "jobs": 1})

    total = sum(r["wall_s"] for r in rows if r["wall_s"] is not None)
    for r in rows:
        r["wall_share"] = r["wall_s"] / total if r["wall_s"] is not None and total > 0 else None
    phases = []
    for phase in PHASES:
        members = [r for r in rows if r["phase"] == phase]
        if not members and phase != "other":  # every phase of make demo is shown, timed or not
            rules = ", ".join(r for r, ph in RULE_PHASE.items() if ph == phase)
            phases.append({**_combine(phase, rules, [], total, ""), "note": "no benchmark file found"})
        elif members:
            phases.append(_combine(phase, ", ".join(r["rule"] for r in members), members, total,
                                   _lammps_note(lost) if phase == "LAMMPS" else ""))
    seconds, elapsed = measured_seconds(workflow, "in the last make demo", "make demo writes it")
    notes = [("wall s is summed over jobs, which run side by side on the cores given to snakemake: the campaign "
              "takes less; " + (f"its snakemake call took {seconds:,.0f} s elapsed {elapsed}" if seconds is not None
                                else f"its elapsed time is {elapsed}")),
             "CPU s and max RSS are sampled by Snakemake (every 30 s after the first seconds): NA for a job that "
             "ends before the first sample, and CPU s is a lower bound",
             "each job's time is that of its last run, so the table is what the whole campaign costs"]
    if stale:
        notes.append(f"{stale} benchmark file(s) of job directories no longer in the campaign left out")
    return {"rules": rows + [_combine("total", "", rows, total, notes[0])],
            "phases": phases + [_combine("total", "", rows, total, notes[0])],
            "notes": notes, "lammps": lost}


def _combine(phase: str, rule: str, rows: list[dict], total: float, note: str) -> dict:
    walls = [r["wall_s"] for r in rows if r["wall_s"] is not None]
    cpus = [r["cpu_s"] for r in rows if r["cpu_s"] is not None]
    rss = [r["max_rss_mb"] for r in rows if r["max_rss_mb"] is not None]
    not_measured = [r["rule"] for r in rows if r["wall_s"] is None]
    if not_measured:
        note = "; ".join(filter(None, [note, "not measured: " + ", ".join(not_measured)]))
    wall = sum(walls) if walls else None
    return {"phase": phase, "rule": rule, "jobs": sum(r["jobs"] for r in rows), "wall_s": wall,
            "cpu_s": sum(cpus) if cpus else None, "cpu_sampled_jobs": sum(r["cpu_sampled_jobs"] for r in rows),
            "max_rss_mb": max(rss) if rss else None,
            "wall_share": wall / total if wall is not None and total > 0 else None, "note": note}


def _seconds(x) -> str:
    if x is None:
        return "not measured"
    return f"{x:,.0f}" if x >= 100 else f"{x:.1f}"


def _cells(r: dict) -> list[str]:
    cpu = "NA" if r["cpu_s"] is None else _seconds(r["cpu_s"])
    if r["cpu_s"] is not None and r["cpu_sampled_jobs"] < r["jobs"]:
        cpu += f" ({r['cpu_sampled_jobs']} of {r['jobs']} jobs)"
    return [str(r["jobs"]), _seconds(r["wall_s"]), "–" if r["wall_share"] is None else f"{r['wall_share']:.1%}",
            cpu, "NA" if r["max_rss_mb"] is None else f"{r['max_rss_mb']:,.0f}"]


def _md_cell(text: str) -> str:
    return str(text).replace("|", "\\|").replace("\n", " ")


def markdown(timing: dict, rung: str) -> str:
    """The two tables (per phase, per rule) and the notes, in Markdown (for docs/outputs.md)."""
    head = ["jobs", "wall s", "share of wall", "CPU s", "max RSS MB"]
    lines = [f"Where the campaign's time goes (rung {rung}), per phase:", "",
             "| phase | rules | " + " | ".join(head) + " |", "|---|---|" + "---:|" * len(head)]
    for r in timing["phases"]:
        lines.append("| " + " | ".join(_md_cell(c) for c in [r["phase"], r["rule"], *_cells(r)]) + " |")
    lines += ["", "Per rule:", "", "| phase | rule | " + " | ".join(head) + " | note |",
              "|---|---|" + "---:|" * len(head) + "---|"]
    for r in timing["rules"]:
        lines.append("| " + " | ".join(_md_cell(c) for c in [r["phase"], r["rule"], *_cells(r), r["note"]]) + " |")
    lines += [""] + [f"- {_md_cell(n)}" for n in timing["notes"]]
    if timing["lammps"]["cases"] or timing["lammps"]["left_out"]:
        lines.append(f"- {_lammps_note(timing['lammps'])}")
    return "\n".join(lines) + "\n"


def write_csv(rows: list[dict], path: str | Path) -> None:
    """One table as CSV: seconds to 0.01 s, MB to 0.1 MB, shares to 1e-4; empty = not measured."""
    def cell(key, value):
        if value is None:
            return ""
        if key in ("wall_s", "cpu_s"):
            return f"{value:.2f}"
        if key == "max_rss_mb":
            return f"{value:.1f}"
        if key == "wall_share":
            return f"{value:.4f}"
        return value

    Path(path).parent.mkdir(parents=True, exist_ok=True)
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=CSV_COLUMNS)
        w.writeheader()
        for r in rows:
            w.writerow({k: cell(k, r[k]) for k in CSV_COLUMNS})


def write_timing(results_dir: str | Path, rung: str, rules_csv: str | Path, phases_csv: str | Path,
                 markdown_path: str | Path, **kwargs) -> str:
    """Write the per-rule and per-phase tables (CSV) and the Markdown of both; returns the Markdown.
    ``kwargs`` go to :func:`campaign_timing`."""
    timing = campaign_timing(results_dir, rung, **kwargs)
    write_csv(timing["rules"], rules_csv)
    write_csv(timing["phases"], phases_csv)
    text = markdown(timing, rung)
    Path(markdown_path).write_text(text)
    return text


def _default_rung() -> str | None:
    from .config import load_yaml  # the campaign file, read as strictly as everywhere else

    path = Path("config") / "config.yaml"
    return load_yaml(path).get("rung") if path.exists() else None


def main(argv: list[str] | None = None) -> int:
    """``python -m granflow.timing results [--rung R]``: print the tables (Markdown); with
    ``--out DIR`` also write timing.csv, phases.csv and timing.md there."""
    ap = argparse.ArgumentParser(prog="python -m granflow.timing", description=__doc__.split("\n\n")[0])
    ap.add_argument("results_dir", help="the campaign's results directory (e.g. results)")
    ap.add_argument("--rung", default=None, help="the campaign's rung (default: config/config.yaml's)")
    ap.add_argument("--install", default=str(INSTALL_SECONDS),
                    help=f"file with the install's seconds (default {INSTALL_SECONDS})")
    ap.add_argument("--out", default=None, help="also write timing.csv, phases.csv and timing.md into this folder")
    args = ap.parse_args(argv)
    try:
        rung = args.rung or _default_rung()
        if not rung:
            raise BenchmarkError("no --rung given and no config/config.yaml to read it from")
        if not Path(args.results_dir).is_dir():
            raise BenchmarkError(f"{args.results_dir}: no such results directory")
        if args.out:
            out = Path(args.out)
            text = write_timing(args.results_dir, rung, out / "timing.csv", out / "phases.csv", out / "timing.md",
                                install=args.install)
        else:
            text = markdown(campaign_timing(args.results_dir, rung, install=args.install), rung)
    except BenchmarkError as exc:
        print(f"granflow.timing: {exc}", file=sys.stderr)
        return 2
    print(text, end="")
    return 0


if __name__ == "__main__":
    sys.exit(main())
