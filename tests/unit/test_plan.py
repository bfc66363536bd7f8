"""Planning a campaign: workloads against the rendered decks, the estimate's arithmetic,
ranks, done-detection, calibration and `granflow plan`."""
import json
import math
import re

import numpy as np
import pytest

from granflow import registry, resources
from granflow.cli import main
from granflow.scene_files import load_scene
from granflow.deck import render_case
from granflow.resources import (
    PARTICLES_PER_RANK,
    REFERENCE_RATE,
    Calibration,
    Rate,
    Workload,
    calibrate,
    case_state,
    estimate,
    simulate_resources,
    suggested_ranks,
)

#: the smoke case each scene is rendered at (every registered scene is: one not named here at its
#: scene file's own case)
SMOKE_CASES = {"channel": {"phi_mean": 0.58}, "heap": {"feed_rate": 0.005}, "silo": {"R": 3.0},
               "chute": {"theta_deg": 24.0}}
#: the default campaign made feasible at the smoke rung
SMOKE_SETS = ["--set", "scenes.heap.sweep.feed_rate=[0.005]", "--set", "scenes.silo.sweep.R=[3.0,4.0]"]


def deck_variables(text: str) -> dict:
    """The deck's numbers (``variable name equal <number>``; formulas are left out)."""
    pattern = r"^variable\s+(\S+)\s+equal\s+([-+0-9.eE]+)\s"
    return {m.group(1): float(m.group(2)) for m in re.finditer(pattern, text, re.M)}


def deck_runs(text: str, variables: dict) -> tuple[int, list[str]]:
    """Steps of the deck's plain ``run N`` / ``run ${var}`` lines (a ``jump SELF`` loop repeated), and
    the runs it cannot evaluate (expressions of run-time quantities)."""
    total, unknown = 0, []
    for m in re.finditer(r"^run\s+(\S+)", text, re.M):
        arg = m.group(1)
        if arg.startswith("$("):
            unknown.append(arg)
            continue
        total += int(variables[arg[2:-1]] if arg.startswith("${") else float(arg))
    assert "jump" not in text, "a looping deck: count its loop"
    return total, unknown


@pytest.fixture(scope="module", params=registry.names())
def rendered(request, root, tmp_path_factory):
    name = request.param
    scene = load_scene(root / "config" / "scenes" / f"{name}.yaml")
    out = tmp_path_factory.mktemp(name)
    record = render_case(scene, "smoke", out, SMOKE_CASES.get(name))
    decks = {p.stem: p.read_text() for p in out.glob("*.lmp")}
    return name, record, decks, out


def test_workload_steps_are_the_decks_runs(rendered):
    """Each stage's steps: the deck's runs x the segments the runner runs (all of them)."""
    name, record, decks, _ = rendered
    work = registry.get(name).workload(record)
    segments = {"init": 1, "flow": record["n_flow_segments"], "average": record["n_average_segments"]}
    for stage, k in segments.items():
        got = work.stages[stage]
        if stage not in decks:
            assert got.steps == 0 and k == 0, (name, stage)
            continue
        variables = deck_variables(decks[stage])
        plain, unknown = deck_runs(decks[stage], variables)
        assert got.segments == k
        if not unknown:
            # chute's init adds a one-step check (`run 1`) that the workload leaves out
            assert abs(got.steps - k * plain) <= 1, (name, stage, got.steps, k * plain)
        else:
            # the channel's lid: at most 10 time units coming down, or up over the packed column
            assert name == "channel" and stage == "init" and len(unknown) == 1, unknown
            dt = variables["dt"]
            assert plain + math.ceil(10 / dt) <= got.steps <= plain + math.ceil(variables["H_per"] /
                                                                                variables["lid_speed"] / dt)


def test_workload_particles_are_the_decks(rendered):
    name, record, decks, out = rendered
    work = registry.get(name).workload(record)
    first = decks["init"] if name != "heap" else decks["flow"]
    variables = deck_variables(first)
    if name == "silo":  # the gas and the frozen rim ring, from the data file LAMMPS reads
        atoms = int(re.search(r"^(\d+) atoms", (out / "atoms.data").read_text(), re.M).group(1))
        assert work.particles == atoms
    elif name == "heap":  # poured: sum(nper) every n_feed steps, over every segment
        assert work.growing
        batches = int(variables["n_segment"]) // int(variables["n_feed"])
        pours = [int(n) for n in re.findall(r"^fix\s+pour\d+\s+all\s+pour\s+(\d+)", decks["flow"], re.M)]
        nper = [p["nper"] for p in record["feed"]["pours"]]
        assert all(count >= batches * n for count, n in zip(pours, nper))  # each segment's pour can deliver
        n_seg = record["n_flow_segments"] + record["n_average_segments"]
        assert work.particles == n_seg * batches * sum(nper)
    else:
        assert work.particles == int(variables["n_particles"])
    assert work.pair_style == "gran/hooke/history" and resources.pair_factor(work.pair_style) == 1.0


def test_workload_atom_steps(rendered):
    """Constant counts: particles x steps; the heap: its count summed over every step."""
    name, record, _, _ = rendered
    work = registry.get(name).workload(record)
    if not work.growing:
        assert work.atom_steps == pytest.approx(work.particles * work.steps)
        return
    prm = record["parameters"]
    seg, nfreq = int(prm["n_segment"]), int(prm["n_feed"])
    batch = sum(p["nper"] for p in record["feed"]["pours"])
    n_seg = record["n_flow_segments"] + record["n_average_segments"]
    step = np.arange(n_seg * seg)
    k, local = step // seg, step % seg + 1  # segment, step within it (fix pour inserts at 1, 1 + nfreq, ...)
    atoms = k * (seg // nfreq) * batch + batch * np.ceil(local / nfreq)
    assert work.atom_steps == pytest.approx(float(atoms.sum()))
    assert work.particles == atoms[-1]


def test_estimate_arithmetic():
    work = Workload.constant("x", 25_000, {"init": (1000, 1), "flow": (2_000_000, 10)})
    rate = 2.0e6
    cal = Calibration(rates={"x": Rate(rate, "test")}, runner_mb=100.0, kb_per_particle=1.0)
    est = estimate(work, calibration=cal)
    assert est.atom_steps == 25_000 * 2_001_000
    assert est.cpu_hours == pytest.approx(est.atom_steps / rate / 3600)
    assert est.ranks == 3 == suggested_ranks(25_000)
    eff = resources.PARALLEL_EFFICIENCY
    assert est.wall_hours == pytest.approx(est.cpu_hours / (3 * eff))
    assert est.core_hours == pytest.approx(3 * est.wall_hours)
    assert est.runtime_min == math.ceil((resources.RUNTIME_MARGIN * est.wall_hours * 3600
                                         + 11 * resources.SEGMENT_OVERHEAD_S) / 60)
    assert est.segment_runtime_min < est.runtime_min
    assert est.mem_mb == math.ceil(resources.MEMORY_MARGIN * (100 + 3 * resources.LAMMPS_RANK_MB + 25_000 / 1024))
    one = estimate(work, ranks=1, calibration=cal)
    assert one.wall_hours == pytest.approx(one.cpu_hours) and one.cpu_hours == pytest.approx(est.cpu_hours)
    # no measured run of the scene: the reference rate, divided by the pair style's cost
    ref = estimate(work)
    assert ref.rate == REFERENCE_RATE and ref.rate_source.startswith("reference")
    dear = estimate(Workload.constant("x", 25_000, {"flow": (2_000_000, 10)}, pair_style="granular"))
    assert dear.rate == pytest.approx(REFERENCE_RATE / 2.5) and "granular" in dear.rate_source
    assert dear.cpu_hours == pytest.approx(2.5 * estimate(Workload.constant("x", 25_000, {"flow": (2_000_000, 10)}))
                                           .cpu_hours)


def test_pair_style_is_read_from_the_template(tmp_path):
    """The default workload names the deck's pair style: `pair granular` anywhere in the template."""
    (tmp_path / "fake.lmp.j2").write_text("{% include \"include/header.lmp.j2\" %}\n"
                                          "pair_style      granular\npair_coeff * * hertz/material 1e5 0.3 0.3\n")

    class Fake(registry.Scene):
        name = "fake"
        package_dir = tmp_path

    work = Fake().workload({"parameters": {"n_particles": 100, "n_settle": 10, "n_segment": 5},
                            "n_flow_segments": 2, "n_average_segments": 1})
    assert work.pair_style == "granular" and resources.pair_factor("granular") == 2.5
    assert (work.particles, work.steps, work.segments) == (100, 25, 4)
    assert {n: s.steps for n, s in work.stages.items()} == {"init": 10, "flow": 10, "average": 5}


def test_ranks_monotone_and_capped():
    ns = [0, 1, 500, PARTICLES_PER_RANK - 1, PARTICLES_PER_RANK, PARTICLES_PER_RANK + 1, 55_000, 10 ** 6, 10 ** 8]
    ranks = [suggested_ranks(n) for n in ns]
    assert ranks == sorted(ranks)
    assert ranks[:5] == [1, 1, 1, 1, 1] and ranks[5] == 2
    assert ranks[-1] == resources.DEFAULT_MAX_RANKS
    assert suggested_ranks(10 ** 8, max_ranks=16) == 16
    assert suggested_ranks(10 ** 8, max_ranks=16, deck_limit=5) == 5
    assert suggested_ranks(10 ** 6, max_ranks=16, deck_limit=0) == 16  # 0 / None: no deck limit


def _fake_run(case_dir, record, status="steady", atom_steps=1e9, cpu=200.0, rss=150.0):
    (case_dir / "run").mkdir(parents=True)
    (case_dir / "params.json").write_text(json.dumps(record, indent=2, sort_keys=True) + "\n")
    (case_dir / "run" / "status.json").write_text(json.dumps(
        {"status": status, "atom_steps": atom_steps, "cpu_seconds": cpu, "wall_seconds": cpu, "nprocs": 1,
         "peak_rss_mb": rss, "matom_step_per_s": atom_steps / cpu / 1e6}))


def test_case_state(tmp_path):
    record = {"scene": "x", "parameters": {"n_particles": 10}}
    assert case_state(tmp_path / "nothing", record)["state"] == "todo"
    _fake_run(tmp_path / "done", record)
    got = case_state(tmp_path / "done", record)
    assert got["state"] == "done" and got["status"] == "steady" and got["params_current"] is True
    assert case_state(tmp_path / "done", dict(record, rung="other"))["params_current"] is False
    (tmp_path / "part" / "run").mkdir(parents=True)
    (tmp_path / "part" / "run" / "init.restart").write_text("")
    assert case_state(tmp_path / "part")["state"] == "partial"
    _fake_run(tmp_path / "unknown", record, status="unknown")
    assert case_state(tmp_path / "unknown")["state"] == "todo"


def test_calibration_from_status_files(tmp_path):
    rec = {"scene": "chute", "rung": "smoke", "parameters": {"n_particles": 1000}}
    _fake_run(tmp_path / "chute" / "smoke" / "a", rec, atom_steps=3e9, cpu=1000.0)
    _fake_run(tmp_path / "chute" / "smoke" / "b", rec, atom_steps=1e9, cpu=1000.0)
    _fake_run(tmp_path / "chute" / "smoke" / "tiny", rec, atom_steps=1e9, cpu=1.0)  # start-up dominated: left out
    cal = calibrate(tmp_path)
    assert cal.rates["chute"].value == pytest.approx(4e9 / 2000) and cal.rates["chute"].runs == 2
    assert cal.runner_mb == pytest.approx(150 - resources.KB_PER_PARTICLE * 1000 / 1024)
    assert "silo" not in cal.rates


def test_simulate_resources(root, tmp_path):
    scene = load_scene(root / "config" / "scenes" / "chute.yaml")
    case = tmp_path / "results" / "chute" / "smoke" / "theta~24"
    render_case(scene, "smoke", case, {"theta_deg": 24.0})
    got = simulate_resources(case / "params.json")
    assert set(got) == {"tasks", "mem_mb", "runtime"} and got["tasks"] == 1
    assert all(isinstance(v, int) and v > 0 for v in got.values())
    assert got["runtime"] >= resources.RUNTIME_FLOOR_MIN
    assert resources.results_root(case / "params.json", {"scene": "chute", "rung": "smoke"}) == \
        (tmp_path / "results").resolve()


def test_plan_command(capsys, root, tmp_path):
    args = ["plan", "--rung", "smoke", *SMOKE_SETS, "--set", f"results_dir={tmp_path}"]
    assert main(args) == 0
    text = capsys.readouterr().out
    assert "all      total (9 cases)" in text and "rates (atom-steps per CPU-second)" in text
    assert main([*args, "--json"]) == 0
    plan = json.loads(capsys.readouterr().out)
    rows = plan["rows"]
    assert plan["rung"] == "smoke" and len(rows) == 9 and {r["scene"] for r in rows} == set(plan["scenes"])
    for key in ("particles", "atom_steps", "cpu_hours", "core_hours"):
        assert plan["total"][key] == pytest.approx(sum(r[key] for r in rows))
        for name, tot in plan["scenes"].items():
            assert tot[key] == pytest.approx(sum(r[key] for r in rows if r["scene"] == name))
    assert plan["total"]["done"] == 0 and all(r["state"] == "todo" for r in rows)
    for r in rows:
        assert r["cpu_hours"] == pytest.approx(r["atom_steps"] / r["rate"] / 3600)


def test_plan_sees_done_cases(capsys, root, tmp_path):
    """A case with a final status.json under the results directory is done; its rate calibrates the scene.
    Its params.json is render's own (issue 41: plan built the record without render's ``snapshots``
    key and called every finished case "params.json differs"; this test faked the file the same way)."""
    scene = registry.get("silo")
    sc = load_scene(root / "config" / "scenes" / "silo.yaml")
    rel = scene.case_dir({"R": 3.0})
    case = tmp_path / "silo" / "smoke" / rel
    record = render_case(sc, "smoke", case, scene.case_from_dir(rel))
    assert "snapshots" in record
    (case / "params.json").rename(case / "rendered.json")
    _fake_run(case, record, status="completed", atom_steps=5e9, cpu=1000.0)
    (case / "rendered.json").rename(case / "params.json")  # the status is faked; the record is render's
    assert main(["plan", "--rung", "smoke", *SMOKE_SETS, "--set", f"results_dir={tmp_path}", "--json"]) == 0
    plan = json.loads(capsys.readouterr().out)
    silo = {r["case"]: r for r in plan["rows"] if r["scene"] == "silo"}
    assert silo[rel]["state"] == "done" and silo[rel]["status"] == "completed" and silo[rel]["params_current"]
    assert silo["R~4"]["state"] == "todo"
    assert plan["scenes"]["silo"]["done"] == 1 and plan["total"]["done"] == 1
    assert plan["scenes"]["silo"]["remaining_cpu_hours"] == pytest.approx(silo["R~4"]["cpu_hours"])
    assert silo[rel]["rate"] == pytest.approx(5e6) and plan["rates"]["silo"].startswith("measured")
    assert plan["rates"]["channel"].startswith("reference")


def test_plan_refuses_an_infeasible_case(capsys, tmp_path):
    """Validated as the Snakefile does: the default heap feed rate does not fit the smoke feed zone."""
    assert main(["plan", "--rung", "smoke", "--set", f"results_dir={tmp_path}"]) == 2
    assert "feed_rate" in capsys.readouterr().err
