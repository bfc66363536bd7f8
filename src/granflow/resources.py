"""What a case costs before it runs: MPI ranks, memory, runtime and CPU-hours from its parameters.

A rendered case's parameter record (``params.json``) says how many particles the
deck holds and how many time steps each stage runs; its scene turns that into a
:class:`Workload` (:meth:`granflow.registry.Scene.workload`). :func:`estimate`
prices a workload:

- **CPU-hours** = atom-steps / rate. The rate (atom-steps per CPU-second) is
  measured: :func:`calibrate` reads every finished run's ``run/status.json``
  (``atom_steps``, ``cpu_seconds``) under a results directory and pools them per
  scene. A scene without measured runs falls back to :data:`REFERENCE_RATE`.
- **ranks**: one per :data:`PARTICLES_PER_RANK` particles, at least 1, at most
  ``max_ranks`` (default :data:`DEFAULT_MAX_RANKS`) and the deck's decomposition.
- **wall hours** = CPU-hours / (ranks x :data:`PARALLEL_EFFICIENCY`, 1 on one rank).
- **runtime** of the simulate job: the runner (:class:`granflow.runner.CaseRunner`)
  runs *every* segment of a case in one process, so one Snakemake job runs the
  whole case (a killed job resumes after its last complete segment when rerun).
  ``runtime_min`` therefore covers all segments: wall x :data:`RUNTIME_MARGIN`
  plus :data:`SEGMENT_OVERHEAD_S` per LAMMPS invocation. ``segment_runtime_min``
  is what one segment alone needs (the longest one, same margin).
- **memory** of the job: the runner process, one LAMMPS base per rank and a
  per-particle term, times :data:`MEMORY_MARGIN`.

The limits every command checks before building anything
(:func:`check_size`, :func:`check_campaign_cpu_hours`) are defined here too: :data:`DEFAULT_MAX_PARTICLES`
per case, this machine's memory, and :func:`default_max_cpu_hours` (a week of this
machine's cores) per case and for a campaign's cases together, priced by :func:`estimate`
at the reference rate.

Workloads are upper bounds: the flow stage runs until ``t_flow_max`` and every
averaging segment runs, although the runner stops earlier when the flow is steady,
jammed, arrested, clogged or emptied.

Every constant below names the measurement it comes from.
"""
from __future__ import annotations

import json
import math
import os
from dataclasses import asdict, dataclass, field
from functools import lru_cache
from pathlib import Path

from . import registry
from .registry import Stage, Workload
from .schema import Validator, format_error, load_schema, require
from .yamlio import ConfigError

# ----------------------------------------------------------------- measured facts
#: atom-steps per CPU-second of ``gran/hooke/history`` when no run of the scene was measured:
#: a dense 10k-sphere bed ran at 8.8 Matom-step/s on 2 MPI ranks of these machines
#: (runner.py module docstring), i.e. 4.4 Matom-step per CPU-second
REFERENCE_RATE = 8.8e6 / 2
REFERENCE_RATE_SOURCE = ("reference: 4.4 Matom-step per CPU-second (8.8 Matom-step/s on 2 MPI ranks, "
                         "dense 10k-sphere bed, gran/hooke/history, measured on these machines)")
#: cost of one atom-step of each pair style relative to ``gran/hooke/history`` (measured:
#: ``pair granular`` with the same contacts ~2.5x dearer)
PAIR_FACTORS = {"gran/hooke/history": 1.0, "gran/hooke": 1.0, "gran/hertz/history": 1.0, "granular": 2.5}
#: particles per MPI rank. Cases below this run on one rank: on 2 cores the small
#: (2k-particle) demo cases ran 1.3-1.45x faster one rank per case, side by side, than
#: one case on 2 ranks (workflows/rules/common.smk, simulate_threads); the 10k bed
#: above still ran well on 2 ranks (5k per rank)
PARTICLES_PER_RANK = 10_000
#: ranks of one case unless the caller says otherwise (one or two cluster nodes)
DEFAULT_MAX_RANKS = 64
#: parallel efficiency on more than one rank: the 2k-particle demo channel ran at
#: 17.6 Matom-step/s on 2 ranks against 12.5 on one (bench/bench_channel.py), 0.70;
#: cases planned at >= PARTICLES_PER_RANK per rank do at least as well
PARALLEL_EFFICIENCY = 0.7
#: runtime margin on the wall estimate: measured rates of one scene spread by +-30 %
#: (demo chute 3.3-4.8, channel 4.7-5.7 Matom-step/s on one rank of a shared machine)
RUNTIME_MARGIN = 1.5
#: per LAMMPS invocation: start, read/write restart, the runner's verdict (measured
#: wall - loop: 0.2-1 s per segment for channel, chute, silo, 13 s for the heap's pours)
SEGMENT_OVERHEAD_S = 30.0
#: shortest runtime requested for any job, minutes
RUNTIME_FLOOR_MIN = 10
#: the plan flags jobs longer than this (a common partition limit), minutes
RUNTIME_LIMIT_MIN = 24 * 60
#: the runner process as ``status.json`` sees it: peak_rss_mb of every demo run is
#: 145-150 MB whatever the size (665 to 25k particles), the Python runner counted through fork
RUNNER_MB = 150.0
#: one LAMMPS rank with few particles (measured: lmp with 2k spheres, neigh_page 100000: 32 MB)
LAMMPS_RANK_MB = 32.0
#: LAMMPS memory per particle (measured: dense fcc bed, 12 contacts each, gran/hooke/history,
#: 55k -> 187k spheres on one rank: 78 -> 187 MB peak RSS, 0.85 kB per particle)
KB_PER_PARTICLE = 0.85
#: memory margin: neighbour lists grow with compaction, ranks are imbalanced, dumps buffer
MEMORY_MARGIN = 1.5
#: runs shorter than this (CPU-seconds) are start-up dominated and left out of the calibration
MIN_CALIBRATION_CPU_S = 10.0


def pair_factor(style: str) -> float:
    """Cost of one atom-step of ``style`` relative to ``gran/hooke/history`` (:data:`PAIR_FACTORS`)."""
    return PAIR_FACTORS.get(style, PAIR_FACTORS["granular"] if "granular" in style else 1.0)


# ------------------------------------------------------------------- calibration
@dataclass(frozen=True)
class Rate:
    """Atom-steps per CPU-second and where the number comes from."""

    value: float
    source: str
    runs: int = 0


@dataclass(frozen=True)
class Calibration:
    """Rates per scene measured from finished runs, and the memory model's numbers."""

    rates: dict[str, Rate] = field(default_factory=dict)
    runner_mb: float = RUNNER_MB
    kb_per_particle: float = KB_PER_PARTICLE
    memory_source: str = (f"reference: runner {RUNNER_MB:g} MB + {LAMMPS_RANK_MB:g} MB per rank + "
                          f"{KB_PER_PARTICLE:g} kB per particle")

    def rate(self, workload: Workload) -> Rate:
        """The scene's measured rate, or the reference rate divided by the pair style's cost factor."""
        if workload.scene in self.rates:
            return self.rates[workload.scene]
        factor = pair_factor(workload.pair_style)
        if factor != 1.0:
            return Rate(REFERENCE_RATE / factor,
                        f"{REFERENCE_RATE_SOURCE}, / {factor:g} for pair {workload.pair_style}")
        return Rate(REFERENCE_RATE, REFERENCE_RATE_SOURCE)


def measured_runs(results: str | Path) -> list[dict]:
    """Every run under ``results`` with a ``run/status.json`` and its case's ``params.json``:
    ``{scene, rung, case_dir, particles, atom_steps, cpu_seconds, wall_seconds, nprocs, peak_rss_mb}``."""
    out = []
    for status_path in sorted(Path(results).glob("**/run/status.json")):
        case_dir = status_path.parent.parent
        try:
            status = json.loads(status_path.read_text())
            record = json.loads((case_dir / "params.json").read_text())
        except (OSError, ValueError):
            continue
        prm = record.get("parameters", {})
        out.append({"scene": record.get("scene"), "rung": record.get("rung"), "case_dir": str(case_dir),
                    "particles": prm.get("n_particles", record.get("n_particles_estimate")),
                    **{k: status.get(k) for k in ("atom_steps", "cpu_seconds", "wall_seconds", "nprocs",
                                                  "peak_rss_mb", "matom_step_per_s", "status")}})
    return out


def _positive(value) -> bool:
    return isinstance(value, (int, float)) and math.isfinite(value) and value > 0


def calibrate(*results: str | Path) -> Calibration:
    """Rates and memory from the finished runs under the ``results`` directories.

    Per scene, rate = sum of atom-steps / sum of CPU-seconds over its runs of at least
    :data:`MIN_CALIBRATION_CPU_S` (every rung and the cost study's runs; larger runs
    weigh more). The runner's memory is the median ``peak_rss_mb`` after taking off
    the reference per-particle term; the per-particle term stays the reference unless
    the runs show a larger one (at the sizes run so far the runner process dominates).
    """
    runs = [r for d in results if d and Path(d).is_dir() for r in measured_runs(d)]
    by_scene: dict[str, list[dict]] = {}
    for r in runs:
        if r["scene"] and _positive(r["atom_steps"]) and _positive(r["cpu_seconds"]) \
                and r["cpu_seconds"] >= MIN_CALIBRATION_CPU_S:
            by_scene.setdefault(r["scene"], []).append(r)
    rates = {}
    for scene, rs in sorted(by_scene.items()):
        steps, cpu = sum(r["atom_steps"] for r in rs), sum(r["cpu_seconds"] for r in rs)
        rungs = ", ".join(sorted({str(r["rung"] or "cost") for r in rs}))
        rates[scene] = Rate(steps / cpu, f"measured: {len(rs)} {scene} run(s) ({rungs}), {steps:.3g} atom-steps "
                                         f"in {cpu / 3600:.3g} CPU-h = {steps / cpu / 1e6:.2f} Matom-step per CPU-s",
                            runs=len(rs))
    mem = [(r["particles"] / max(1, int(r["nprocs"] or 1)), r["peak_rss_mb"]) for r in runs
           if _positive(r["peak_rss_mb"]) and _positive(r["particles"])]
    if not mem:
        return Calibration(rates=rates)
    rest = sorted(m - KB_PER_PARTICLE * n / 1024 for n, m in mem)
    runner = max(rest[len(rest) // 2], LAMMPS_RANK_MB)
    kb = KB_PER_PARTICLE
    if len(mem) >= 3:
        xs, ys = [n for n, _ in mem], [m for _, m in mem]
        xm, ym = sum(xs) / len(xs), sum(ys) / len(ys)
        sxx = sum((x - xm) ** 2 for x in xs)
        if sxx > 0:
            kb = max(kb, 1024 * sum((x - xm) * (y - ym) for x, y in zip(xs, ys)) / sxx)
    source = (f"measured: runner {runner:.0f} MB (median peak_rss_mb of {len(mem)} runs, "
              f"{min(n for n, _ in mem):.0f}-{max(n for n, _ in mem):.0f} particles per rank) + "
              f"{LAMMPS_RANK_MB:g} MB per rank + {kb:.3g} kB per particle"
              + ("" if kb > KB_PER_PARTICLE else " (reference; the runs do not resolve it)"))
    return Calibration(rates=rates, runner_mb=runner, kb_per_particle=kb, memory_source=source)


# ---------------------------------------------------------------------- estimate
@dataclass(frozen=True)
class Estimate:
    """What one case costs (see the module docstring for each number)."""

    particles: int
    atom_steps: float
    cpu_hours: float
    ranks: int
    wall_hours: float
    core_hours: float
    mem_mb: int
    runtime_min: int
    segment_runtime_min: int
    segments: int
    rate: float
    rate_source: str
    memory_source: str

    def as_dict(self) -> dict:
        return asdict(self)


def suggested_ranks(particles: int, max_ranks: int | None = None, deck_limit: int | None = None) -> int:
    """``ceil(particles / PARTICLES_PER_RANK)``, at least 1, at most ``max_ranks`` and ``deck_limit``."""
    cap = max(1, int(max_ranks or DEFAULT_MAX_RANKS))
    if deck_limit:
        cap = min(cap, max(1, int(deck_limit)))
    return max(1, min(cap, math.ceil(max(0, particles) / PARTICLES_PER_RANK)))


def parallel_efficiency(ranks: int) -> float:
    return 1.0 if ranks <= 1 else PARALLEL_EFFICIENCY


def _minutes(wall_s: float, segments: int) -> int:
    return max(RUNTIME_FLOOR_MIN, math.ceil((RUNTIME_MARGIN * wall_s + segments * SEGMENT_OVERHEAD_S) / 60.0))


def memory_mb(particles: int, ranks: int | None = None, calibration: Calibration | None = None) -> int:
    """Memory of a simulate job with ``particles`` on ``ranks`` (default :func:`suggested_ranks`), MB."""
    cal = calibration or Calibration()
    ranks = int(ranks) if ranks else suggested_ranks(particles)
    return int(math.ceil(MEMORY_MARGIN * (cal.runner_mb + ranks * LAMMPS_RANK_MB
                                          + cal.kb_per_particle * particles / 1024)))


def machine_memory_mb() -> int:
    """Physical memory of this machine, MB (the default memory budget of a case)."""
    try:
        return int(os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES") / 2**20)
    except (ValueError, OSError, AttributeError):
        return 0


#: most particles of one case unless the campaign's ``limits.max_particles`` or ``--max-particles``
#: says otherwise: ~7x the largest paper-rung case (silo, 278k), ~4.5 GB by the memory model above
DEFAULT_MAX_PARTICLES = 2_000_000

#: days of all this machine's cores that one case, and one campaign's cases together, may cost
#: unless the campaign's ``max_cpu_hours`` or ``--max-cpu-hours`` says otherwise: a week
DEFAULT_CPU_DAYS = 7


def machine_cores() -> int:
    """Cores of this machine as Python sees them (:func:`os.cpu_count`, 1 if unknown)."""
    return os.cpu_count() or 1


def default_max_cpu_hours() -> float:
    """Most estimated CPU-hours of one case and of a campaign when nothing says otherwise: a week
    of this machine's cores, ``7 x 24 x os.cpu_count()`` (336 on 2 cores)."""
    return 24.0 * DEFAULT_CPU_DAYS * machine_cores()


def default_max_cpu_hours_text() -> str:
    """Where the default CPU-hour limit comes from, for messages."""
    n = machine_cores()
    return (f"the default: a week of this machine's {n} core{'s' if n != 1 else ''}, "
            f"{DEFAULT_CPU_DAYS} x 24 x {n} = {default_max_cpu_hours():,.0f}")


def estimate(workload: Workload, ranks: int | None = None, calibration: Calibration | None = None,
             max_ranks: int | None = None) -> Estimate:
    """Price a workload on ``ranks`` MPI ranks (default :func:`suggested_ranks`)."""
    cal = calibration or Calibration()
    rate = cal.rate(workload)
    ranks = int(ranks) if ranks else suggested_ranks(workload.particles, max_ranks, workload.max_ranks)
    cpu_s = workload.atom_steps / rate.value
    speed = ranks * parallel_efficiency(ranks)
    wall_s = cpu_s / speed
    segment_wall_s = workload.longest_segment_atom_steps / rate.value / speed
    mem = memory_mb(workload.particles, ranks, cal)
    return Estimate(
        particles=workload.particles, atom_steps=workload.atom_steps, cpu_hours=cpu_s / 3600, ranks=ranks,
        wall_hours=wall_s / 3600, core_hours=ranks * wall_s / 3600, mem_mb=mem,
        runtime_min=_minutes(wall_s, workload.segments), segment_runtime_min=_minutes(segment_wall_s, 1),
        segments=workload.segments, rate=rate.value, rate_source=rate.source, memory_source=cal.memory_source)


def results_root(params_path: str | Path, record: dict) -> Path | None:
    """The results directory of a case ``<results>/<scene>/<rung>/<case...>/params.json``, if it is one."""
    parts = Path(params_path).resolve().parent.parts
    for i in range(len(parts) - 2, 0, -1):
        if parts[i] == record.get("scene") and parts[i + 1] == record.get("rung"):
            return Path(*parts[:i])
        if parts[i] == "cost" and parts[i + 1] == record.get("scene"):  # <results>/cost/<scene>/runs/<run>
            return Path(*parts[:i])
    return None


@lru_cache(maxsize=8)
def _calibration_of(results: str) -> Calibration:
    return calibrate(results)


def simulate_resources(params_path: str | Path, max_ranks: int | None = None) -> dict:
    """Resources of the Snakemake ``simulate`` job of a rendered case.

    ``tasks``: MPI ranks; ``mem_mb``: the job's memory; ``runtime``: minutes for the
    *whole case*, because one simulate job runs every segment (init, flow, averaging)
    in one runner process. Rates are calibrated from the finished runs of the same
    results directory (cached per process), else the reference rate.
    """
    record = json.loads(Path(params_path).read_text())
    workload = registry.get(record["scene"]).workload(record)
    root = results_root(params_path, record)
    cal = _calibration_of(str(root)) if root else Calibration()
    est = estimate(workload, calibration=cal, max_ranks=max_ranks)
    return {"tasks": est.ranks, "mem_mb": est.mem_mb, "runtime": est.runtime_min}


# -------------------------------------------------------------------------- plan
#: statuses of ``run/status.json`` that are not a finished run
UNFINISHED = ("", "unknown", "interrupted")


def case_state(case_dir: str | Path, record: dict | None = None) -> dict:
    """Whether a case already ran: ``state`` is ``done`` (``run/status.json`` with a final status),
    ``partial`` (complete segments, no status yet: a rerun resumes) or ``todo``; ``status`` the run's;
    ``params_current`` whether the ``params.json`` on disk is what ``record`` renders (None if absent)."""
    case_dir = Path(case_dir)
    on_disk = case_dir / "params.json"
    current = None
    if record is not None and on_disk.exists():
        try:  # the same record as render writes (JSON turns tuples into lists)
            current = json.loads(on_disk.read_text()) == json.loads(json.dumps(record))
        except (OSError, ValueError):
            current = False
    status_path = case_dir / "run" / "status.json"
    status = ""
    if status_path.exists():
        try:
            status = str(json.loads(status_path.read_text()).get("status") or "")
        except (OSError, ValueError):
            status = ""
    if status not in UNFINISHED:
        return {"state": "done", "status": status, "params_current": current, "segments_done": None}
    restarts = list((case_dir / "run").glob("*.restart")) if (case_dir / "run").is_dir() else []
    return {"state": "partial" if restarts else "todo", "status": status, "params_current": current,
            "segments_done": len(restarts)}


_SUMMED = ("particles", "atom_steps", "cpu_hours", "core_hours", "wall_hours")


def plan_totals(rows: list[dict]) -> dict:
    todo = [r for r in rows if r["state"] != "done"]
    out = {"cases": len(rows), "done": len(rows) - len(todo)}
    out.update({k: sum(r[k] for r in rows) for k in _SUMMED})
    out["mem_mb_max"] = max((r["mem_mb"] for r in rows), default=0)
    out["ranks_max"] = max((r["ranks"] for r in rows), default=0)
    out["runtime_min_max"] = max((r["runtime_min"] for r in rows), default=0)
    out["remaining_cpu_hours"] = sum(r["cpu_hours"] for r in todo)
    out["remaining_core_hours"] = sum(r["core_hours"] for r in todo)
    return out


def plan_campaign(campaign: dict, results: str | Path, calibration: Calibration | None = None,
                  max_ranks: int | None = None, runtime_limit_min: int = RUNTIME_LIMIT_MIN) -> dict:
    """Every case of a validated campaign (:func:`granflow.campaign.load_campaign`) priced and
    checked against ``results``: ``{rung, results, rows, scenes (totals), total, rates, memory,
    assumptions}``. Records are rendered in memory (no decks are written, LAMMPS is not needed)."""
    rung = campaign["rung"]
    cal = calibration if calibration is not None else calibrate(results)
    rows, scenes, rates = [], {}, {}
    for name, sc in campaign["scenes"].items():
        if not sc.get("enabled", True):
            continue
        scene = registry.get(name)
        scene_rows = []
        for point in scene.sweep_points(sc["scene"], sc.get("sweep") or {}, rung):
            rel = scene.case_dir(point)
            # the record exactly as render writes it (with what render adds, e.g. snapshots)
            _, context = scene.rendered_parameters(sc["scene"], rung, scene.case_from_dir(rel))
            record = context["record"]
            work = scene.workload(record)
            est = estimate(work, calibration=cal, max_ranks=max_ranks)
            case_dir = Path(results) / name / rung / rel
            row = {"scene": name, "case": rel, "case_dir": str(case_dir), "growing": work.growing,
                   "steps": work.steps, "segments": work.segments, "pair_style": work.pair_style,
                   "note": work.note, **est.as_dict(), **case_state(case_dir, record),
                   "over_runtime_limit": est.runtime_min > runtime_limit_min}
            del row["rate_source"], row["memory_source"]
            scene_rows.append(row)
            rates[name] = est.rate_source
        rows += scene_rows
        scenes[name] = plan_totals(scene_rows)
    return {"rung": rung, "results": str(results), "rows": rows, "scenes": scenes, "total": plan_totals(rows),
            "rates": rates, "memory": cal.memory_source,
            "assumptions": {"particles_per_rank": PARTICLES_PER_RANK, "max_ranks": max_ranks or DEFAULT_MAX_RANKS,
                            "parallel_efficiency": PARALLEL_EFFICIENCY, "runtime_margin": RUNTIME_MARGIN,
                            "segment_overhead_s": SEGMENT_OVERHEAD_S, "memory_margin": MEMORY_MARGIN,
                            "runtime_limit_min": runtime_limit_min,
                            "upper_bound": "flow until t_flow_max and every averaging segment"}}


def _hours(h: float) -> str:
    return f"{h:.3g}" if h < 1000 else f"{h:,.0f}"


def _runtime(minutes: int) -> str:
    return f"{minutes // 60}:{minutes % 60:02d}"


def format_plan(plan: dict) -> str:
    """The plan as a table: one line per case, a total per scene and overall, then the rates used."""
    head = (f"{'scene':8s} {'case':24s} {'particles':>10s} {'atom-steps':>10s} {'CPU-h':>8s} {'ranks':>5s} "
            f"{'wall-h':>8s} {'runtime':>8s} {'mem_mb':>7s}  state")
    lines = [f"granflow plan: rung {plan['rung']}, results in {plan['results']}", "", head, "-" * len(head)]

    def line(scene, case, t, ranks, wall, runtime, mem, state):
        return (f"{scene:8s} {case:24s} {t['particles']:>10,d} {t['atom_steps']:>10.3g} {_hours(t['cpu_hours']):>8s} "
                f"{ranks:>5s} {wall:>8s} {runtime:>8s} {mem:>7s}  {state}")

    for name, tot in plan["scenes"].items():
        for r in (r for r in plan["rows"] if r["scene"] == name):
            state = r["state"] + (f" ({r['status']})" if r["status"] else "")
            if r["state"] == "done" and r["params_current"] is False:
                state += " *"
            if r["state"] == "partial":
                state += f" ({r['segments_done']} segments)"
            case = r["case"] + ("+" if r["growing"] else "")
            lines.append(line(name, case, r, str(r["ranks"]), _hours(r["wall_hours"]), _runtime(r["runtime_min"]),
                              str(r["mem_mb"]), state))
        lines.append(line(name, f"total ({tot['cases']} cases)", tot, f"<={tot['ranks_max']}", "", "",
                          f"<={tot['mem_mb_max']}", f"{tot['done']} done, "
                          f"{_hours(tot['remaining_cpu_hours'])} CPU-h to go"))
        lines.append("")
    t = plan["total"]
    lines.append(line("all", f"total ({t['cases']} cases)", t, f"<={t['ranks_max']}", "", "", f"<={t['mem_mb_max']}",
                      f"{t['done']} done, {_hours(t['remaining_cpu_hours'])} CPU-h "
                      f"({_hours(t['remaining_core_hours'])} core-h at the ranks shown) to go"))
    a = plan["assumptions"]
    lines += ["", "Upper bounds: flow until t_flow_max and every averaging segment (the runner stops earlier when "
              "a case is steady, jammed, arrested, clogged or emptied).",
              f"ranks: one per {a['particles_per_rank']:,} particles, at most {a['max_ranks']} (and the deck's "
              f"decomposition); wall-h = CPU-h / (ranks x {a['parallel_efficiency']:g} on > 1 rank).",
              f"runtime (h:mm): the simulate job runs every segment of its case: {a['runtime_margin']:g} x wall + "
              f"{a['segment_overhead_s']:g} s per segment. mem_mb: the job, x {a['memory_margin']:g} margin.",
              "+ particles poured over time (the count at the end); * params.json on disk differs from what "
              "the config renders now (a changed scene file reruns the case).",
              "rates (atom-steps per CPU-second):"]
    lines += [f"  {name}: {src}" for name, src in plan["rates"].items()]
    over = [f"{r['scene']}/{r['case']} ({_runtime(r['runtime_min'])})" for r in plan["rows"]
            if r["over_runtime_limit"] and r["state"] != "done"]
    if over:
        lines.append(f"longer than {_runtime(a['runtime_limit_min'])} (a scheduler may kill them; a rerun resumes "
                     f"after the last complete segment, or give more ranks): " + ", ".join(over))
    lines.append(f"memory: {plan['memory']}")
    return "\n".join(lines)


# ------------------------------------------------------------------------------ limits
#: the campaign keys that bound one case (and the campaign) before anything is built; the CLI's
#: ``--max-particles``, ``--memory-mb`` and ``--max-cpu-hours`` set them, Snakemake's ``--config KEY=V``
LIMIT_KEYS = ("max_particles", "memory_mb", "max_cpu_hours")

#: how to raise each limit, for the refusals
_RAISE = {key: (f"raise it with --{key.replace('_', '-')} {arg} (granflow check-config, plan, render), "
                f"snakemake --config {key}={arg}, or {key} in the campaign file")
          for key, arg in (("max_particles", "N"), ("memory_mb", "MB"), ("max_cpu_hours", "H"))}


def check_limits(limits: dict, source: str = "command line") -> dict:
    """Refuse limits given on the command line without a campaign file (``granflow render``,
    ``check-config`` on a scene file) that the campaign schema would refuse, naming the option
    (``--max-cpu-hours``): the same bounds as in a campaign file. Returns ``limits``."""
    props = load_schema("config")["properties"]
    option = {key: "--" + key.replace("_", "-") for key in LIMIT_KEYS}
    schema = {"type": "object", "properties": {option[k]: props[k] for k in LIMIT_KEYS}}
    given = {option.get(k, k): v for k, v in limits.items()}
    for err in sorted(Validator(schema).iter_errors(given), key=lambda e: list(map(str, e.absolute_path))):
        raise ConfigError(format_error(err, source))
    return limits


def size_limits(limits: dict | None = None) -> tuple[int, int, float]:
    """``(max_particles, memory budget in MB, max_cpu_hours)`` of one case from ``limits`` (the
    campaign dict, whose ``max_particles``/``memory_mb``/``max_cpu_hours`` the CLI's
    ``--max-particles``/``--memory-mb``/``--max-cpu-hours`` set), else 2 million particles, this
    machine's memory and a week of this machine's cores
    (:func:`default_max_cpu_hours`)."""
    limits = limits or {}
    max_particles = int(limits.get("max_particles") or DEFAULT_MAX_PARTICLES)
    memory = int(limits.get("memory_mb") or machine_memory_mb() or 0)
    cpu_hours = float(limits.get("max_cpu_hours") or default_max_cpu_hours())
    return max_particles, memory, cpu_hours


def _cpu_hour_limit_text(limits: dict | None) -> str:
    """Where the CPU-hour limit comes from, for messages."""
    if (limits or {}).get("max_cpu_hours"):
        return f"max_cpu_hours = {limits['max_cpu_hours']:g}"
    return default_max_cpu_hours_text()


def _limit_hours(h: float) -> str:
    return f"{h:,.0f}" if h >= 100 else f"{h:.3g}"


def check_size(name: str, scene: dict, rung: str, case: dict | None, limits: dict | None,
               source: str, label: str) -> Estimate:
    """Refuse a case over the size limits before anything is built; return its estimate.

    ``label`` names the case in the message (e.g. ``scenes.silo.sweep point R = 6``). In order:
    the particles, the scene's :meth:`~granflow.registry.Scene.particle_count` (a formula, no
    arrays; it also refuses a geometry that does not fit); the memory,
    :func:`memory_mb`; then the deck's parameters are derived (their preflight:
    time step, feasibility) and the CPU-hours priced by :func:`estimate` from
    the case's workload at the reference rate, as ``granflow plan`` prices a scene without
    measured runs (a fixed rate, so whether a config passes does not change as runs finish).
    Returns that :class:`Estimate` (``particles``, ``cpu_hours``, ...).
    """
    sc = registry.get(name)
    max_particles, budget, max_cpu_hours = size_limits(limits)
    try:
        n = sc.particle_count(scene, rung, case)
    except ValueError as exc:  # PreflightError (time step, geometry) or a scene's own refusal
        raise ConfigError(f"{source}: {label} is not allowed: {exc}") from None
    mem = memory_mb(n)
    require(n <= max_particles,
            f"{source}: {label} is too large: estimated {n:,} particles (about {mem / 1024:.3g} GB of memory): "
            f"allowed at most {max_particles:,} particles; {_RAISE['max_particles']}")
    try:
        est = estimate(sc.workload(sc.parameters(scene, rung, case)[1]["record"]))
    except ValueError as exc:  # the deck's preflight: time step, feasibility
        raise ConfigError(f"{source}: {label} is not allowed: {exc}") from None
    if budget and mem > budget:
        raise ConfigError(
            f"{source}: {label} is too large: estimated {n:,} particles, {mem:,} MB of memory and "
            f"{est.cpu_hours:.3g} CPU-hours at {est.rate / 1e6:.3g} Matom-step per CPU-second: allowed at most "
            f"{budget:,} MB (this machine's memory unless --memory-mb, snakemake --config memory_mb=MB or memory_mb in the "
            f"campaign file says otherwise)")
    require(est.cpu_hours <= max_cpu_hours,
            f"{source}: {label} is too large: estimated {_limit_hours(est.cpu_hours)} CPU-hours ({est.particles:,} particles, "
            f"{est.atom_steps:.3g} atom-steps at {est.rate / 1e6:.3g} Matom-step per CPU-second, the reference rate "
            f"for its pair style that granflow plan uses without measured runs): allowed at most {_limit_hours(max_cpu_hours)} CPU-hours "
            f"({_cpu_hour_limit_text(limits)}); {_RAISE['max_cpu_hours']}")
    return est


def check_sweep_sizes(name: str, scene: dict, rung: str, points: list[dict], limits: dict | None,
                      source: str) -> list[Estimate]:
    """Every sweep point of scene ``name`` at ``rung`` within the size limits (:func:`check_size`);
    returns the points' estimates."""
    estimates = []
    for point in points:
        what = ", ".join(f"{k} = {v}" for k, v in point.items())
        estimates.append(check_size(name, scene, rung, point, limits, source, f"scenes.{name} case {what} (rung {rung})"))
    return estimates


def check_campaign_limits(campaign: dict, points: dict[str, list[dict]], source: str) -> float:
    """Every sweep point of a campaign's scenes (``points``, from :func:`granflow.scene_files.check_scenes`)
    within the size limits, all together within ``max_cpu_hours`` (the cost study's runs, a target of their
    own, are checked one by one, by :func:`granflow.cost.cost_studies`). Returns the total CPU-hours."""
    rung = campaign["rung"]
    estimates = {name: check_sweep_sizes(name, campaign["scenes"][name]["scene"], rung, pts, campaign, source)
                 for name, pts in points.items()}
    return check_campaign_cpu_hours(estimates, rung, campaign, source)


def check_campaign_cpu_hours(estimates: dict[str, list], rung: str, limits: dict | None, source: str) -> float:
    """Refuse a campaign whose cases (``{scene: [Estimate, ...]}``, from :func:`check_size`)
    together are estimated above ``max_cpu_hours``; return the total CPU-hours."""
    _, _, max_cpu_hours = size_limits(limits)
    per_scene = {name: sum(e.cpu_hours for e in ests) for name, ests in estimates.items()}
    total = sum(per_scene.values())
    cases = sum(len(ests) for ests in estimates.values())
    parts = ", ".join(f"{name} {_limit_hours(h)}" for name, h in sorted(per_scene.items(), key=lambda kv: -kv[1]))
    require(total <= max_cpu_hours,
            f"{source}: the campaign at rung {rung} is too large: its {cases} cases are estimated at "
            f"{_limit_hours(total)} CPU-hours together ({parts}; at the reference rate, as granflow plan prices a "
            f"scene without measured runs): allowed at most {_limit_hours(max_cpu_hours)} CPU-hours "
            f"({_cpu_hour_limit_text(limits)}); {_RAISE['max_cpu_hours']}")
    return total


__all__ = ["Stage", "Workload", "Rate", "Calibration", "Estimate", "calibrate", "measured_runs", "estimate",
           "suggested_ranks", "simulate_resources", "pair_factor", "case_state",
           "plan_campaign", "plan_totals", "format_plan", "REFERENCE_RATE", "PARTICLES_PER_RANK", "DEFAULT_MAX_RANKS",
           "DEFAULT_MAX_PARTICLES", "default_max_cpu_hours", "LIMIT_KEYS", "check_limits", "size_limits",
           "check_size", "check_sweep_sizes", "check_campaign_limits", "check_campaign_cpu_hours"]
