"""Throughput of the generated decks against hand-tuned variants, run by hand (issue 18).

  python bench/bench_decks.py                       # default cases, every variant, 2 cores
  python bench/bench_decks.py --list                # the variants of each case, as edits of the deck; no run
  python bench/bench_decks.py --cases results/silo/demo/R~4.5 --variants ours,multi,omp-1x2 \\
      --steps 3000 --repeats 5

For each case (a finished or running case directory of the campaign: its rendered
``flow.lmp``, or ``average.lmp`` for a scene without flow stage such as the silo,
and the restarts under ``run/``), the newest restart of that stage is copied to a
scratch directory and the deck is run from it as generated ("ours") and as
variants made by text edits of the rendered deck:

=================  ===========================================================
``ours``           the deck as generated, on ``--cores`` MPI ranks x 1 thread
``serial``         the deck as generated, 1 rank x 1 thread (the baseline)
``omp-RxT``        R ranks x T OpenMP threads with ``-sf omp -pk omp T``
                   (defaults: ``omp-1x2`` and ``omp-2x1`` for 2 cores)
``multi``          ``neighbor <skin> multi`` (one collection per atom type)
``multi-comm``     ``multi`` and ``comm_modify mode multi``
``multi-reduce``   ``multi``, ``newton on`` and ``comm_modify mode multi reduce/multi``
``grid-default``   no ``processors`` line: LAMMPS's own grid
``grid-x|y|z``     ``processors * 1 1`` / ``1 * 1`` / ``1 1 *``
``balance-none``   no ``balance`` / ``fix balance``
``balance-shift``  ``balance`` + ``fix balance`` (``shift``; the deck's own if it has them,
                   else ``shift xyz 20 1.02`` every ``--balance-every`` steps)
``balance-rcb``    the same with ``rcb`` (and ``comm_style tiled``, ``comm_modify vel yes``);
                   on a deck with newton pair on also ``newton off`` (shown as
                   ``balance-rcb+newton-off``): LAMMPS refuses the history pair styles
                   with newton on under comm_style tiled ("Reverse comm fix variable
                   not yet supported by CommTiled")
``newton``         the other ``newton`` pair setting (shown as ``newton-on``/``newton-off``)
=================  ===========================================================

Variants compose with ``+`` (``multi+grid-y``, ``omp-1x2+multi``). A variant whose
deck and launch are those of ``ours`` (e.g. ``grid-x`` for the heap, whose deck
already says ``processors * 1 1``) is reported as such and not run. Every variant
also drops the deck's dumps and restart writing and replaces its ``run`` line by
``--warmup`` steps (not timed) and then ``--steps`` timed steps, keeping the deck's
run options (the heap's ``pre no post no every ...`` freezing); a deck missing an
expected line (``read_restart``, ``neighbor``, one ``run``) is refused by name.
Without dumps, the silo's contact dump (and its ``compute pair/local``) costs
nothing here, unlike in the campaign: the figures are those of the dynamics.

Timing: LAMMPS's ``Loop time of X on P procs for N steps with A atoms`` lines of the
timed run (one per sub-run of ``run ... every``). Atoms change during a run in the
heap (fix pour) and the silo (fix evaporate), and LAMMPS's own Performance line uses
the count at the end only; here atom-steps are summed per sub-run with the trapezoid
rule, the count at the start of the timed run being the ``Atoms`` column of its first
thermo row: Matom-step/s = sum_i N_i (A_{i-1} + A_i) / 2 / sum_i X_i / 1e6 (exact for
a steady feed or drain; the heap's sub-runs are n_freeze steps, the silo's run is one).
Setup (restart read, first neighbour build) is outside the loop time; ``wall_s`` in
the CSV is the whole process. The CSV also has LAMMPS's processor grid, the %total of
each section (Pair, Neigh, Comm, ...) of the last timing table (the heap prints one
for its last sub-run only) and the largest over the average owned atoms per rank.

Variants run in interleaved rounds (round-robin over the variants, the order rotated
each round), ``--repeats`` rounds per case. The table gives per variant the median
rate, its range over the rounds, the ratio ours/variant (median of the per-round
ratios: both ran minutes apart, so the machine's drift largely cancels) and the
efficiency per core against ``serial``; under it, ours/best, best being the variant
with the highest median on the same number of cores as ours. A variant that fails
(LAMMPS ERROR) is reported with its ERROR line and not run again. Figures are
ratios measured in one run, on a shared machine: they are recorded, never asserted.

Output: ``<out>.csv`` (one row per run) and ``<out>.md`` (command line, LAMMPS
version, host, load, one table per case), both rewritten after every case; ``--out``
defaults to ``bench/results/bench_decks_<UTC time>`` (ignored by git, as every
``results/``: add a run worth keeping by hand). ``--list`` prints the variants of each
case as edits of ours, and an estimate of the time from the case's production logs.
"""
from __future__ import annotations

import argparse
import csv
import os
import re
import shlex
import shutil
import socket
import statistics
import subprocess
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "src"))
sys.path.insert(0, str(ROOT / "bench"))

# the deck edits and variants (bench/deck_variants.py); the ones this file does not call are there for
# tests/unit/test_bench_decks.py, which reads them as bench_decks' own
from deck_variants import (  # noqa: E402, F401
    MARKER,
    DeckFormatError,
    Launch,
    Variant,
    build_variants,
    deck_diff,
    default_variants,
    insert_after_neighbor,
    newton_pair,
    set_balance,
    set_neighbor_style,
    set_newton,
    set_processors,
    set_run,
    strip_output,
)

#: representative cases, relative to --results: per scene the demo case and a validation-size one
DEFAULT_CASES = (
    "channel/demo/W~20/phi~0.6",
    "channel/validation/W~60/phi~0.6",
    "heap/demo/mix~mono1.5/mdot~33",
    "heap/validation/mix~bi1-2/mdot~33",
    "silo/demo/R~4.5",
    "silo/validation/R~7.5",
    "chute/demo/theta~25",
    "chute/validation/theta~25",
)


# ------------------------------------------------------------------ log parsing
@dataclass
class Timing:
    """The timed run of one log: loop seconds, steps, atom-steps, atoms at start and end."""

    loop_s: float
    steps: int
    atom_steps: float
    atoms_start: float
    atoms_end: float
    breakdown: dict = field(default_factory=dict)

    @property
    def matom_step_per_s(self) -> float:
        return self.atom_steps / self.loop_s / 1e6 if self.loop_s > 0 else float("nan")


def parse_timed_run(log_text: str) -> Timing:
    """Loop times and atom-steps of the run after :data:`MARKER` (see the module docstring)."""
    lines = log_text.splitlines()
    try:
        start = next(i for i, l in enumerate(lines) if l.strip() == MARKER)
    except StopIteration:
        raise ValueError(f"no {MARKER} line in the log: the timed run did not start") from None
    loops, atoms0, header = [], None, None
    for line in lines[start + 1:]:
        words = line.split()
        if line.startswith("Loop time of "):
            # Loop time of X on P procs for N steps with A atoms
            loops.append((float(words[3]), int(words[8]), float(words[11])))
            header = None
        elif words[:1] == ["Step"]:
            header = words
        elif header and atoms0 is None and "Atoms" in header and len(words) == len(header):
            try:
                atoms0 = float(words[header.index("Atoms")])
            except ValueError:
                pass
    if not loops:
        raise ValueError("no 'Loop time' line after the marker: the timed run did not finish")
    prev = atoms0 if atoms0 is not None else loops[0][2]
    atom_steps = 0.0
    for _, n, a in loops:
        atom_steps += n * (prev + a) / 2.0
        prev = a
    return Timing(loop_s=sum(x for x, _, _ in loops), steps=sum(n for _, n, _ in loops), atom_steps=atom_steps,
                  atoms_start=atoms0 if atoms0 is not None else loops[0][2], atoms_end=loops[-1][2],
                  breakdown=parse_breakdown(lines[start + 1:]))


def processor_grid(log_text: str) -> str:
    """The MPI grid LAMMPS reports (``2x1x1``), ``tiled`` under ``comm_style tiled``, else ''."""
    grids = re.findall(r"^\s*(\d+) by (\d+) by (\d+) MPI processor grid", log_text, re.M)
    if re.search(r"^comm_style\s+tiled", log_text, re.M):
        return "tiled"
    return "x".join(grids[-1]) if grids else ""


def parse_breakdown(lines: list[str]) -> dict:
    """%total per section (Pair, Neigh, Comm, Modify, ...) of the last timing table, and
    the largest/average owned atoms per rank (``Nlocal``) as ``imbalance``."""
    out: dict = {}
    for i, line in enumerate(lines):
        if line.startswith("Section |"):
            out = {}
            for row in lines[i + 2:]:
                cells = [c.strip() for c in row.split("|")]
                if len(cells) != 6:
                    break
                try:
                    out[cells[0].lower()] = float(cells[5])
                except ValueError:
                    break
        m = re.match(r"Nlocal:\s+(\S+) ave\s+(\S+) max", line)
        if m and float(m[1]) > 0:
            out["imbalance"] = float(m[2]) / float(m[1])
    return out


# ------------------------------------------------------------------ summary
def summarize(rows: list[dict], ours: str = "ours") -> tuple[list[dict], dict]:
    """Per-variant statistics of one case's runs, and the ours/best verdict.

    ``rows``: dicts with ``variant``, ``round``, ``cores``, ``matom_step_per_s`` (None for
    a failed run) and ``error``. Returns the rows of the table (median, min, max, runs,
    ratio ours/variant as the median of per-round ratios, efficiency per core against
    ``serial``) and ``{"best", "ours_over_best", "cores"}``; best is the variant with the
    highest median among those on as many cores as ours.
    """
    by: dict[str, list[dict]] = {}
    for r in rows:
        by.setdefault(r["variant"], []).append(r)
    ours_by_round = {r["round"]: r["matom_step_per_s"] for r in by.get(ours, []) if r["matom_step_per_s"]}
    serial = [r["matom_step_per_s"] for r in by.get("serial", []) if r["matom_step_per_s"]]
    serial_median = statistics.median(serial) if serial else None
    table = []
    for name, runs in by.items():
        rates = [r["matom_step_per_s"] for r in runs if r["matom_step_per_s"]]
        errors = [r["error"] for r in runs if r.get("error")]
        paired = [ours_by_round[r["round"]] / r["matom_step_per_s"] for r in runs
                  if r["matom_step_per_s"] and r["round"] in ours_by_round]
        cores = runs[0]["cores"]
        med = statistics.median(rates) if rates else None
        imbalance = [r["imbalance"] for r in runs if r.get("imbalance")]
        table.append({
            "variant": name, "launch": runs[0].get("launch", ""), "grid": runs[0].get("grid", ""),
            "imbalance": statistics.median(imbalance) if imbalance else None, "cores": cores, "runs": len(rates),
            "median": med, "min": min(rates) if rates else None, "max": max(rates) if rates else None,
            "ours_over": statistics.median(paired) if paired else None,
            "per_core_vs_serial": med / cores / serial_median if med and serial_median else None,
            "error": errors[0] if errors else "",
        })
    ours_rows = [t for t in table if t["variant"] == ours]
    verdict = {"best": None, "ours_over_best": None, "cores": ours_rows[0]["cores"] if ours_rows else None}
    same = [t for t in table if t["median"] and t["cores"] == verdict["cores"]]
    if same and ours_rows and ours_rows[0]["median"]:
        best = max(same, key=lambda t: t["median"])
        verdict["best"] = best["variant"]
        verdict["ours_over_best"] = ours_rows[0]["median"] / best["median"]
    return table, verdict


def _fmt(x, spec=".3g") -> str:
    return "" if x is None else format(x, spec)


def markdown_table(title: str, note: str, table: list[dict], verdict: dict, skipped: list[str]) -> str:
    """One case's markdown section."""
    out = [f"### {title}", "", note, "",
           "| variant | ranks x threads | grid | runs | Matom-step/s median | min - max | ours / variant "
           "| per core vs serial | atoms max/avg | error |",
           "| --- | --- | --- | ---: | ---: | ---: | ---: | ---: | ---: | --- |"]
    for t in table:
        spread = f"{_fmt(t['min'])} - {_fmt(t['max'])}" if t["min"] is not None else ""
        out.append(f"| {t['variant']} | {t['launch']} | {t.get('grid', '')} | {t['runs']} | {_fmt(t['median'])} "
                   f"| {spread} | {_fmt(t['ours_over'], '.2f')} | {_fmt(t['per_core_vs_serial'], '.2f')} "
                   f"| {_fmt(t.get('imbalance'), '.2f')} | {t['error']} |")
    out.append("")
    if verdict["best"]:
        out.append(f"ours / best on {verdict['cores']} cores = **{verdict['ours_over_best']:.2f}** "
                   f"(best: {verdict['best']})")
    for s in skipped:
        out.append(f"- {s}")
    return "\n".join(out) + "\n"


# ------------------------------------------------------------------ cases and runs
@dataclass
class Case:
    """A case directory, the deck of the stage benchmarked and the restart it starts from."""

    path: Path
    label: str
    deck: Path
    restart: Path
    segment: int


def resolve_case(path: Path, results: Path, stage: str = "auto") -> Case:
    """The deck (``flow.lmp``, else ``average.lmp``) and the newest complete restart of
    that stage (else of the stage before it, else ``init.restart``); ``segment`` is the
    number of the segment that would follow it. Raises FileNotFoundError with the reason."""
    if not path.is_dir():
        raise FileNotFoundError(f"{path}: no such case directory (run its campaign first, or render one with "
                                f"`granflow render <scene> --rung validation --out DIR` and `granflow run DIR`)")
    stages = ["flow", "average"] if stage == "auto" else [stage]
    deck_stage = next((s for s in stages if (path / f"{s}.lmp").exists()), None)
    if deck_stage is None:
        raise FileNotFoundError(f"{path}: no {' or '.join(s + '.lmp' for s in stages)}")
    run = path / "run"
    order = ["flow", "average"] if deck_stage == "average" else ["flow"]
    for prefix in reversed(order):
        restarts = sorted(run.glob(f"{prefix}_[0-9][0-9][0-9].restart"))
        if restarts:
            last = restarts[-1]
            seg = int(last.stem.rsplit("_", 1)[1]) + 1 if prefix == deck_stage else 1
            break
    else:
        last, seg = run / "init.restart", 1
        if not last.exists():
            raise FileNotFoundError(f"{path}: no restart under {run} (the case has not run)")
    try:
        label = str(path.resolve().relative_to(results.resolve()))
    except ValueError:
        label = str(path)
    return Case(path, label, path / f"{deck_stage}.lmp", last, seg)


def estimate_seconds(case: Case, runs: int, atom_steps_per_run: float, startup_s: float = 2.0) -> float | None:
    """Rough wall time of ``runs`` runs of the case: its atoms times the steps at the rate of its
    own production logs (the campaign's ranks; most variants are about as fast, omp-1x2 slower),
    plus ``startup_s`` per run (restart read, setup). None when the case has no timed log."""
    from granflow.runner import loop_cost

    stage = case.deck.stem
    seconds = atom_steps = 0.0
    for log in sorted((case.path / "run" / "logs").glob(f"{stage}_*.log")):
        x, a = loop_cost(log.read_text(errors="replace"))
        seconds, atom_steps = seconds + x, atom_steps + a
    if not seconds:
        return None
    return runs * (atom_steps_per_run / (atom_steps / seconds) + startup_s)


def case_atoms(case: Case) -> int | None:
    """Atoms at the end of the newest log of the benchmarked stage (from its last Loop line)."""
    logs = sorted((case.path / "run" / "logs").glob(f"{case.restart.stem.rsplit('_', 1)[0]}_*.log"))
    for log in reversed(logs):
        loops = [l for l in log.read_text(errors="replace").splitlines() if l.startswith("Loop time of ")]
        if loops:
            return int(float(loops[-1].split()[11]))
    return None


def lammps_version(lmp: str) -> str:
    out = subprocess.run([lmp, "-h"], capture_output=True, text=True).stdout
    return next((l.strip() for l in out.splitlines() if "Large-scale" in l), "unknown")


def run_variant(v: Variant, case: Case, scratch: Path, tag: str, tools, timeout: float) -> dict:
    """Run one variant once in ``scratch``; returns the CSV row (rate None and error set on failure)."""
    from granflow.runner import error_line

    deck = scratch / f"{v.name.replace('+', '_')}.lmp"
    deck.write_text(v.deck)
    log_path = scratch / f"{v.name.replace('+', '_')}_{tag}.log"
    cmd = [*tools.launch(v.launch.ranks), tools.lmp, "-in", deck.name, "-log", log_path.name, "-nocite",
           "-screen", "none", *v.launch.lmp_args(),
           "-var", "restart_in", case.restart.name, "-var", "segment", str(case.segment),
           "-var", "restart_out", "bench.restart", "-var", "dump_file", "bench_dump.bin",
           "-var", "contacts_file", "bench_contacts.dump"]
    env = dict(os.environ, OMP_NUM_THREADS=str(v.launch.threads))
    t0 = time.time()
    try:
        proc = subprocess.run(cmd, cwd=scratch, env=env, capture_output=True, text=True, timeout=timeout)
        rc, tail = proc.returncode, proc.stdout + proc.stderr
    except subprocess.TimeoutExpired:
        rc, tail = -1, f"timed out after {timeout:.0f} s"
    wall = time.time() - t0
    text = log_path.read_text(errors="replace") if log_path.exists() else ""
    row = {"case": case.label, "variant": v.name, "round": tag, "launch": str(v.launch), "cores": v.launch.cores,
           "grid": processor_grid(text), "wall_s": round(wall, 2), "log": str(log_path),
           "matom_step_per_s": None, "error": ""}
    bad = error_line(text + "\n" + tail)
    if rc != 0 or bad:
        row["error"] = bad or f"exit {rc}: {tail.strip().splitlines()[-1] if tail.strip() else 'no output'}"
        return row
    try:
        t = parse_timed_run(text)
    except ValueError as exc:
        row["error"] = str(exc)
        return row
    row.update(steps=t.steps, loop_s=round(t.loop_s, 4), atoms_start=int(t.atoms_start),
               atoms_end=int(t.atoms_end), matom_step_per_s=round(t.matom_step_per_s, 4),
               **{f"pct_{k}": v_ for k, v_ in t.breakdown.items() if k != "imbalance"},
               imbalance=round(t.breakdown["imbalance"], 3) if "imbalance" in t.breakdown else None)
    return row


def rotated(items: list, k: int) -> list:
    """``items`` rotated left by ``k``: round k of the interleaving starts with item k."""
    if not items:
        return []
    k %= len(items)
    return items[k:] + items[:k]


def bench_case(case: Case, names: list[str], args, tools, log) -> tuple[list[dict], str]:
    """Every round of every variant of one case; returns the CSV rows and the markdown section."""
    variants = build_variants(case.deck.read_text(), names, args.cores, args.steps, args.warmup,
                              args.balance_every)
    skipped = [f"{v.name}: same deck and launch as {v.same_as}, not run" for v in variants if v.same_as]
    todo = [v for v in variants if not v.same_as]
    scratch = Path(args.scratch) / re.sub(r"[^A-Za-z0-9.]+", "_", case.label)
    shutil.rmtree(scratch, ignore_errors=True)
    scratch.mkdir(parents=True)
    shutil.copy2(case.restart, scratch / case.restart.name)
    rows, failed = [], set()
    for k in range(args.repeats):
        for v in rotated(todo, k):
            if v.name in failed:
                continue
            row = run_variant(v, case, scratch, f"r{k + 1}", tools, args.timeout)
            row["round"] = k + 1
            rows.append(row)
            log(f"{case.label} round {k + 1}/{args.repeats} {v.name:<16} "
                + (f"{row['matom_step_per_s']:.3f} Matom-step/s ({row['wall_s']:.1f} s wall)"
                   if row["matom_step_per_s"] else f"FAILED: {row['error']}"))
            if row["error"]:
                failed.add(v.name)
    table, verdict = summarize(rows)
    atoms = [r["atoms_start"] for r in rows if r.get("atoms_start")]
    note = (f"deck `{case.deck}` from `{case.restart.name}` (segment {case.segment}), "
            f"{atoms[0] if atoms else '?'} atoms at the start, {args.warmup} + {args.steps} steps, "
            f"{args.repeats} rounds")
    if not args.keep_scratch:
        shutil.rmtree(scratch, ignore_errors=True)
    return rows, markdown_table(case.label, note, table, verdict, skipped)


def write_csv(path: Path, rows: list[dict]) -> None:
    keys: list[str] = []
    for r in rows:
        keys += [k for k in r if k not in keys]
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=keys)
        w.writeheader()
        w.writerows(rows)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--cases", default=None,
                    help="comma-separated case directories, absolute or relative to --results "
                         f"(default: {', '.join(DEFAULT_CASES)}); missing ones are skipped with a message")
    ap.add_argument("--results", default=str(ROOT / "results"), help="campaign results directory")
    ap.add_argument("--stage", default="auto", choices=["auto", "flow", "average"],
                    help="deck to benchmark (auto: flow.lmp, else average.lmp)")
    ap.add_argument("--variants", default=None, help="comma-separated variants (default: all; see above)")
    ap.add_argument("--cores", type=int, default=2, help="cores of ours: MPI ranks x 1 thread (default 2)")
    ap.add_argument("--steps", type=int, default=3000, help="timed steps per run (default 3000)")
    ap.add_argument("--warmup", type=int, default=200, help="untimed steps before them (default 200)")
    ap.add_argument("--repeats", type=int, default=3, help="interleaved rounds (default 3)")
    ap.add_argument("--balance-every", type=int, default=1000,
                    help="steps between fix balance calls of the variants that add one (default 1000)")
    ap.add_argument("--timeout", type=float, default=3600.0, help="seconds before a run is killed")
    ap.add_argument("--out", default=None, help="output prefix: <out>.csv and <out>.md "
                                                "(default bench/results/bench_decks_<UTC time>)")
    ap.add_argument("--scratch", default="/tmp/granflow_bench_decks", help="scratch directory for the runs")
    ap.add_argument("--keep-scratch", action="store_true", help="keep decks and logs of the runs")
    ap.add_argument("--list", action="store_true",
                    help="print each case's variants as edits of ours and the estimated time; no run")
    args = ap.parse_args(argv)

    def log(msg: str) -> None:
        print(f"[bench_decks {time.strftime('%H:%M:%S')}] {msg}", file=sys.stderr, flush=True)

    results = Path(args.results)
    names = args.variants.split(",") if args.variants else default_variants(args.cores)
    cases, skipped_cases = [], []
    for c in (args.cases.split(",") if args.cases else DEFAULT_CASES):
        p = Path(c) if Path(c).is_absolute() or Path(c).exists() else results / c
        try:
            cases.append(resolve_case(p, results, args.stage))
        except FileNotFoundError as exc:
            skipped_cases.append(f"{c}: skipped: {exc}")
            log(f"skipped {c}: {exc}")
    if args.list:
        total = 0.0
        for case in cases:
            variants = build_variants(case.deck.read_text(), names, args.cores, args.steps, args.warmup,
                                      args.balance_every)
            todo = [v for v in variants if not v.same_as]
            atoms = case_atoms(case)
            est = estimate_seconds(case, len(todo) * args.repeats, atoms * (args.steps + args.warmup)) \
                if atoms else None
            total += est or 0.0
            print(f"== {case.label}: {case.deck.name} from {case.restart.name}, {atoms or '?'} atoms, "
                  f"{len(todo)} variants x {args.repeats} rounds, about "
                  + (f"{est / 60:.0f} min" if est else "? min"))
            for v in variants:
                what = f"same as {v.same_as}" if v.same_as else "; ".join(deck_diff(variants[0].deck, v.deck))
                print(f"  {v.name:<16} {str(v.launch):<8} {what}")
        print(f"about {total / 3600:.1f} h in all (at the rates of the cases' production logs)")
        return 0

    from granflow.provenance import git_state
    from granflow.runner import Tools

    tools = Tools.default()
    stamp = time.strftime("%Y%m%dT%H%M%SZ", time.gmtime())
    out = Path(args.out) if args.out else ROOT / "bench" / "results" / f"bench_decks_{stamp}"
    out.parent.mkdir(parents=True, exist_ok=True)
    git = git_state()
    header = [
        "# bench_decks: generated decks against hand-tuned variants", "",
        f"- command: `{shlex.join([Path(sys.executable).name, *sys.argv])}`",
        f"- LAMMPS: {lammps_version(tools.lmp)}",
        f"- host {socket.gethostname()}, {os.cpu_count()} CPUs, load average at start "
        f"{' '.join(f'{x:.2f}' for x in os.getloadavg())}, {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}",
        f"- granflow commit {git['commit']}{' (dirty)' if git['dirty'] else ''}",
        f"- rate = atom-steps of the timed run / its LAMMPS loop time (trapezoid over sub-runs when atoms "
        f"change); ours / variant = median over rounds of the per-round ratio", ""]
    sections, all_rows = [], []
    skipped = [f"- {s}" for s in skipped_cases]
    for case in cases:
        log(f"case {case.label}: {case.deck.name} from {case.restart.name}")
        rows, md = bench_case(case, names, args, tools, log)
        all_rows += rows
        sections.append(md)
        # after every case: a long run keeps what it has measured
        write_csv(out.with_suffix(".csv"), all_rows)
        out.with_suffix(".md").write_text("\n".join(header + sections + skipped) + "\n")
    header[-1:] = [f"- load average at end {' '.join(f'{x:.2f}' for x in os.getloadavg())}", ""]
    text = "\n".join(header + sections + skipped) + "\n"
    out.with_suffix(".md").write_text(text)
    print(text)
    log(f"wrote {out.with_suffix('.md')} and {out.with_suffix('.csv')}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
