"""bench/bench_decks.py without LAMMPS: the deck edits of its variants, the log parsing and
the table's ratios. The decks below are excerpts of rendered decks (results/<scene>/demo),
reduced to the lines the benchmark edits or must leave alone."""
import importlib.util
import re
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
_spec = importlib.util.spec_from_file_location("bench_decks", ROOT / "bench" / "bench_decks.py")
bd = importlib.util.module_from_spec(_spec)
sys.modules["bench_decks"] = bd  # dataclasses look their module up by name
_spec.loader.exec_module(bd)

# channel flow: no processors or newton line (LAMMPS defaults), no balancing, a bare run
CHANNEL = """\
# Stage flow: continue the flow from the previous segment's restart.
read_restart    ${restart_in}
neighbor        ${skin} bin
neigh_modify    delay 0 every 1 check yes one ${neigh_one} page ${neigh_page}
fix             grav all gravity 1.0 vector 0 -1 0
fix             integrate all nve/sphere
# a dump of the wall force would go here; restarts are written at the end
thermo_style    custom step time atoms v_ucm
thermo          ${n_thermo}
run             ${n_segment}
write_restart   ${restart_out}
"""

# heap flow: its own grid and x-shift balancing, and a run with per-sub-run commands
HEAP = """\
# split along x only (a restart does not keep the grid)
processors      * 1 1
read_restart    ${restart_in}
neighbor        ${skin} bin
neigh_modify    delay 0 every 1 check yes one ${neigh_one} page ${neigh_page} exclude group frozen frozen
pair_style      gran/hooke/history ${k_n} ${k_t} ${xi_n} ${xi_t} ${friction} 1
fix             integrate all nve/sphere
# the heap grows from the end wall backwards: rebalance the x cuts now and as it grows
balance         1.05 shift x 20 1.02
fix             lb all balance ${n_balance} 1.05 shift x 20 1.02
thermo          ${n_thermo}
run             ${n_segment} pre no post no every ${n_freeze} "group frozen variable touching" "velocity frozen set 0.0 0.0 0.0"
write_restart   ${restart_out}
"""

# silo discharge: newton off and a grid before read_restart, particle and contact dumps
SILO = """\
units           si
newton          off
comm_modify     vel yes
processors      * * 1
read_restart    ${restart_in}
if "${segment} == 1" then "reset_timestep 0 time 0.0"
neighbor        ${skin} bin
neigh_modify    delay 0 every 1 check yes one ${neigh_one} page ${neigh_page}
neigh_modify    exclude group rim rim
fix             integrate mobile nve/sphere
dump            particles mobile custom ${n_dump} ${dump_file} id type radius mass x y z vx vy vz
dump            contacts all local ${n_contact} ${contacts_file} c_cids[1] c_cids[2]
dump_modify     contacts colname 1 id1 colname 2 id2
run             ${n_segment}
write_restart   ${restart_out}
"""


def commands(text):
    """The command lines (no comments, no blanks) as lists of words."""
    return [l.split() for l in text.splitlines() if l.strip() and not l.lstrip().startswith("#")]


def heads(text, word):
    return [" ".join(w) for w in commands(text) if w[0] == word]


# ------------------------------------------------------------------ single edits
def test_strip_output_drops_dumps_and_restarts_only():
    out = bd.strip_output(SILO)
    assert not [w for w in commands(out) if w[0] in ("dump", "dump_modify", "write_restart")]
    # everything else is kept verbatim, in order
    kept = [l for l in SILO.splitlines() if not l.split()[0] in ("dump", "dump_modify", "write_restart")]
    assert out.splitlines() == kept
    # a comment that mentions a dump is not a dump command
    assert "# a dump of the wall force would go here" in bd.strip_output(CHANNEL)


def test_strip_output_drops_the_continuation_lines_of_a_dropped_command():
    """The snapshot's write_dump image spans lines joined by a trailing &: all of them go."""
    deck = ("variable        snap_speed atom sqrt(vx*vx+vy*vy+vz*vz)\n"
            "write_dump      all image ${snapshot_file} v_snap_speed diameter &\n"
            "                view 0.0 0.0 up 0.0 1.0 0.0 center s 0.5 0.5 0.5 &\n"
            "                modify backcolor white amap min max cf 0.0 3 min blue 0.5 yellow max red\n"
            "fix             1 all nve/sphere &\n"
            "                disc\n"
            "run             1000\n")
    out = bd.strip_output(deck)
    assert out.splitlines() == ["variable        snap_speed atom sqrt(vx*vx+vy*vy+vz*vz)",
                                "fix             1 all nve/sphere &", "                disc",
                                "run             1000"]


def test_set_run_warmup_marker_and_timed_run():
    out = bd.set_run(CHANNEL, 3000, warmup=200)
    runs = heads(out, "run")
    assert runs == ["run 200 pre yes post yes", "run 3000 pre yes post yes"]
    lines = out.splitlines()
    i = lines.index(f'print           "{bd.MARKER}"')
    assert lines[i - 1].split()[:2] == ["run", "200"] and lines[i + 1].split()[:2] == ["run", "3000"]
    # no warm-up: the marker and the timed run only
    assert heads(bd.set_run(CHANNEL, 500), "run") == ["run 500 pre yes post yes"]


def test_set_run_keeps_the_decks_run_options():
    out = bd.set_run(HEAP, 1000, warmup=100)
    opts = 'pre no post no every ${n_freeze} "group frozen variable touching" "velocity frozen set 0.0 0.0 0.0"'
    assert [l for l in out.splitlines() if l.startswith("run")] == [
        f"run             100 {opts}", f"run             1000 {opts}"]


@pytest.mark.parametrize("text,count", [(CHANNEL.replace("run             ${n_segment}\n", ""), 0),
                                        (CHANNEL + "run 10\n", 2)])
def test_set_run_refuses_other_than_one_run_line(text, count):
    with pytest.raises(bd.DeckFormatError, match=f"exactly one run line.*found {count}"):
        bd.set_run(text, 100)


def test_neighbor_style_keeps_the_skin_and_refuses_a_missing_line():
    out = bd.set_neighbor_style(CHANNEL, "multi")
    assert heads(out, "neighbor") == ["neighbor ${skin} multi"]
    assert len(out.splitlines()) == len(CHANNEL.splitlines())
    with pytest.raises(bd.DeckFormatError, match="no neighbor line"):
        bd.set_neighbor_style(CHANNEL.replace("neighbor        ${skin} bin\n", ""), "multi")


def test_insert_after_neighbor_follows_the_neigh_modify_lines():
    out = bd.insert_after_neighbor(SILO, ["comm_modify     mode multi"]).splitlines()
    i = out.index("comm_modify     mode multi")
    assert out[i - 1] == "neigh_modify    exclude group rim rim"
    assert i > out.index("read_restart    ${restart_in}")
    # comm settings before read_restart would be reset by it: refused
    swapped = "neighbor        ${skin} bin\nread_restart    ${restart_in}\nrun 1\n"
    with pytest.raises(bd.DeckFormatError, match="before read_restart"):
        bd.insert_after_neighbor(swapped, ["comm_modify     mode multi"])


@pytest.mark.parametrize("deck", [CHANNEL, HEAP, SILO])
@pytest.mark.parametrize("grid", ["* 1 1", "1 * 1", "1 1 *"])
def test_processors_one_line_before_read_restart(deck, grid):
    out = bd.set_processors(deck, grid).splitlines()
    procs = [i for i, l in enumerate(out) if l.startswith("processors")]
    assert len(procs) == 1 and out[procs[0]].split()[1:] == grid.split()
    assert out[procs[0] + 1].startswith("read_restart")


@pytest.mark.parametrize("deck", [CHANNEL, HEAP, SILO])
def test_processors_none_is_lammps_default(deck):
    out = bd.set_processors(deck, None)
    assert not heads(out, "processors")
    assert len(out.splitlines()) == len(deck.splitlines()) - len(heads(deck, "processors"))


def test_balance_none_removes_static_and_dynamic_balancing():
    out = bd.set_balance(HEAP, "none", 1000)
    assert "balance" not in " ".join(" ".join(w[:4]) for w in commands(out))
    assert bd.set_balance(CHANNEL, "none", 1000) == CHANNEL


def test_balance_shift_keeps_the_decks_own_or_adds_one_before_the_run():
    assert bd.set_balance(HEAP, "shift", 1000) == HEAP
    out = bd.set_balance(CHANNEL, "shift", 500).splitlines()
    run = next(i for i, l in enumerate(out) if l.startswith("run"))
    assert out[run - 2].split() == ["balance", "1.05", "shift", "xyz", "20", "1.02"]
    assert out[run - 1].split() == ["fix", "bench_balance", "all", "balance", "500", "1.05",
                                    "shift", "xyz", "20", "1.02"]


def test_balance_rcb_replaces_the_style_and_tiles_the_communication():
    out = bd.set_balance(HEAP, "rcb", 1000)
    assert heads(out, "balance") == ["balance 1.05 rcb"]
    assert [" ".join(w) for w in commands(out) if w[:1] == ["fix"] and w[3] == "balance"] == \
        ["fix lb all balance ${n_balance} 1.05 rcb"]
    lines = out.splitlines()
    # comm_style tiled resets comm settings: ghost velocities (needed by pair gran) right after it
    i = lines.index("comm_style      tiled")
    assert lines[i + 1] == "comm_modify     vel yes"
    assert i > lines.index("read_restart    ${restart_in}")
    # a deck without balancing gets rcb lines of its own
    added = bd.set_balance(CHANNEL, "rcb", 700)
    assert heads(added, "balance") == ["balance 1.05 rcb"] and "comm_style      tiled" in added
    assert "fix             bench_balance all balance 700 1.05 rcb" in added


def test_balance_keeps_keywords_after_the_shift_arguments():
    deck = HEAP.replace("fix             lb all balance ${n_balance} 1.05 shift x 20 1.02",
                        "fix             lb all balance ${n_balance} 1.05 shift x 20 1.02 weight neigh 0.5")
    out = bd.set_balance(deck, "rcb", 1000)
    assert "fix             lb all balance ${n_balance} 1.05 rcb weight neigh 0.5" in out


def test_newton_setting_before_read_restart():
    # read_restart does not restore the restart's newton pair: no line means LAMMPS's default, on
    assert bd.newton_pair(CHANNEL) is True and bd.newton_pair(SILO) is False
    off = bd.set_newton(CHANNEL, False)
    assert bd.newton_pair(off) is False
    on = bd.set_newton(SILO, True)
    assert heads(on, "newton") == ["newton on"] and bd.newton_pair(on) is True
    lines = on.splitlines()
    assert lines.index("newton          on") < lines.index("read_restart    ${restart_in}")


# ------------------------------------------------------------------ variants
NAMES = bd.default_variants(2)


def test_default_variants_cover_the_settings_of_issue_18():
    assert NAMES[:4] == ["ours", "serial", "omp-1x2", "omp-2x1"]
    for name in ("multi", "multi-comm", "grid-default", "grid-x", "grid-y", "grid-z",
                 "balance-none", "balance-shift", "balance-rcb"):
        assert name in NAMES


@pytest.mark.parametrize("deck", [CHANNEL, HEAP, SILO])
def test_every_variant_drops_output_and_runs_the_benchmark_steps(deck):
    variants = bd.build_variants(deck, NAMES, cores=2, steps=3000, warmup=100, balance_every=1000)
    assert variants[0].name == "ours" and variants[0].launch == bd.Launch(2, 1, False)
    for v in variants:
        words = commands(v.deck)
        assert not [w for w in words if w[0] in ("dump", "dump_modify", "write_restart")], v.name
        assert [w[1] for w in words if w[0] == "run"] == ["100", "3000"], v.name
        assert words.count(["print", f'"{bd.MARKER}"']) == 1


def test_ours_is_the_deck_as_generated_apart_from_output_and_run():
    ours = bd.build_variants(SILO, ["ours"], 2, 3000, 0, 1000)[0]
    assert ours.deck == bd.set_run(bd.strip_output(SILO), 3000, 0)


def test_launches_of_the_parallel_variants():
    v = {x.name: x for x in bd.build_variants(CHANNEL, NAMES, 2, 100, 0, 1000)}
    assert v["serial"].launch == bd.Launch(1, 1) and v["serial"].launch.cores == 1
    assert v["omp-1x2"].launch == bd.Launch(1, 2, True)
    assert v["omp-1x2"].launch.lmp_args() == ["-sf", "omp", "-pk", "omp", "2"]
    assert v["omp-2x1"].launch == bd.Launch(2, 1, True) and v["omp-2x1"].launch.cores == 2
    assert v["multi"].launch.lmp_args() == []
    # the parallel variants run the deck of ours
    assert v["serial"].deck == v["omp-1x2"].deck == v["ours"].deck
    with pytest.raises(ValueError, match="threads without -sf omp"):
        bd.build_variants(CHANNEL, ["mpi-1x2"], 2, 100, 0, 1000)


def test_variants_equal_to_ours_are_named_and_not_run():
    heap = {x.name: x.same_as for x in bd.build_variants(HEAP, NAMES, 2, 100, 0, 1000)}
    assert heap["grid-x"] == "ours" and heap["balance-shift"] == "ours"
    assert heap["grid-default"] is None and heap["balance-none"] is None
    channel = {x.name: x.same_as for x in bd.build_variants(CHANNEL, NAMES, 2, 100, 0, 1000)}
    assert channel["grid-default"] == "ours" and channel["balance-none"] == "ours"
    assert channel["grid-x"] is None  # same grid as LAMMPS picks, maybe, but not the same text
    # the launch counts: ours' deck on one rank is not ours
    assert channel["serial"] is None


def test_newton_and_rcb_resolve_against_the_deck():
    channel = [v.name for v in bd.build_variants(CHANNEL, NAMES, 2, 100, 0, 1000)]
    silo = [v.name for v in bd.build_variants(SILO, NAMES, 2, 100, 0, 1000)]
    assert "newton-off" in channel and "newton-on" in silo
    # rcb with newton pair on is refused by LAMMPS for the history pair styles: turned off with it
    assert "balance-rcb+newton-off" in channel and "balance-rcb" in silo
    rcb = next(v for v in bd.build_variants(CHANNEL, ["balance-rcb"], 2, 100, 0, 1000)
               if v.name.startswith("balance-rcb"))
    assert bd.newton_pair(rcb.deck) is False


def test_composed_variants_apply_their_tokens_in_order():
    v = bd.build_variants(SILO, ["omp-1x2+multi+grid-y"], 2, 100, 0, 1000)[1]
    assert v.name == "omp-1x2+multi+grid-y" and v.launch == bd.Launch(1, 2, True)
    assert heads(v.deck, "neighbor") == ["neighbor ${skin} multi"]
    assert heads(v.deck, "processors") == ["processors 1 * 1"]
    reduce = bd.build_variants(SILO, ["multi-reduce"], 2, 100, 0, 1000)[1]
    assert heads(reduce.deck, "newton") == ["newton on"]
    assert heads(reduce.deck, "comm_modify") == ["comm_modify vel yes", "comm_modify mode multi reduce/multi"]


def test_unknown_variant_names_the_known_ones():
    with pytest.raises(ValueError, match="unknown variant 'multy'.*multi-comm"):
        bd.build_variants(CHANNEL, ["multy"], 2, 100, 0, 1000)


def test_deck_diff_lists_removed_and_added_lines():
    ours = bd.build_variants(HEAP, ["ours"], 2, 100, 0, 1000)[0].deck
    grid = bd.build_variants(HEAP, ["grid-y"], 2, 100, 0, 1000)[1].deck
    assert bd.deck_diff(ours, grid) == ["-processors      * 1 1", "+processors      1 * 1"]


def test_rotated_interleaving_starts_each_round_with_the_next_variant():
    assert [bd.rotated([1, 2, 3], k) for k in range(4)] == [[1, 2, 3], [2, 3, 1], [3, 1, 2], [1, 2, 3]]
    assert bd.rotated([], 3) == []


# ------------------------------------------------------------------ log parsing
LOG = f"""\
run             100 pre yes post yes
   Step          Time         Atoms
       0   0               1000
     100   0.1             1000
Loop time of 9.0 on 2 procs for 100 steps with 1000 atoms

print           "{bd.MARKER}"
{bd.MARKER}
run             300 pre no post no every 100 "group frozen variable touching"
   Step          Time         Atoms
     100   0.1             1000
     200   0.2             1100
Loop time of 2.0 on 2 procs for 100 steps with 1100 atoms
   Step          Time         Atoms
     200   0.2             1100
     300   0.3             1100
Loop time of 1.5 on 2 procs for 100 steps with 1100 atoms
   Step          Time         Atoms
     300   0.3             1100
     400   0.4             1300
Loop time of 2.5 on 2 procs for 100 steps with 1300 atoms

MPI task timing breakdown:
Section |  min time  |  avg time  |  max time  |%varavg| %total
---------------------------------------------------------------
Pair    | 1.0        | 1.1        | 1.2        |   2.0 | 55.00
Neigh   | 0.1        | 0.1        | 0.1        |   0.0 |  5.00
Comm    | 0.5        | 0.6        | 0.7        |   5.5 | 30.00
Other   |            | 0.2        |            |       | 10.00

Nlocal:            650 ave         715 max         585 min
"""


def test_timed_run_sums_sub_runs_with_the_trapezoid_rule():
    t = bd.parse_timed_run(LOG)
    # the warm-up before the marker is left out; three sub-runs of 100 steps, atoms
    # 1000 -> 1100 -> 1100 -> 1300: 100 * (1050 + 1100 + 1200) atom-steps in 6 s
    assert t.steps == 300 and t.loop_s == pytest.approx(6.0)
    assert t.atom_steps == pytest.approx(100 * (1050 + 1100 + 1200))
    assert t.atoms_start == 1000 and t.atoms_end == 1300
    assert t.matom_step_per_s == pytest.approx(335000 / 6.0 / 1e6)
    assert t.breakdown == pytest.approx({"pair": 55.0, "neigh": 5.0, "comm": 30.0, "other": 10.0,
                                         "imbalance": 715 / 650})


def test_constant_atoms_give_lammps_own_figure():
    log = f"{bd.MARKER}\nLoop time of 4.0 on 2 procs for 2000 steps with 5000 atoms\n"
    # no thermo row: the start count is the end count; LAMMPS prints N A / X = 2.5 Matom-step/s
    assert bd.parse_timed_run(log).matom_step_per_s == pytest.approx(2.5)


@pytest.mark.parametrize("log,why", [("Loop time of 1 on 1 procs for 1 steps with 1 atoms\n", "no GRANFLOW"),
                                     (f"{bd.MARKER}\nERROR: Lost atoms\n", "did not finish")])
def test_timed_run_missing_is_an_error(log, why):
    with pytest.raises(ValueError, match=why):
        bd.parse_timed_run(log)


# ------------------------------------------------------------------ table
def _rows():
    rows = []
    # two rounds; the machine is 20 % slower in round 2 for every variant alike
    for rnd, slow in ((1, 1.0), (2, 0.8)):
        for variant, cores, rate in (("ours", 2, 4.0), ("serial", 1, 2.5), ("grid-y", 2, 5.0),
                                     ("multi", 2, 3.0)):
            rows.append({"variant": variant, "round": rnd, "cores": cores, "launch": f"{cores}x1",
                         "matom_step_per_s": rate * slow, "error": ""})
    rows.append({"variant": "balance-rcb", "round": 1, "cores": 2, "launch": "2x1",
                 "matom_step_per_s": None, "error": "ERROR: something refused"})
    return rows


def test_summary_ratios_and_best_on_the_same_cores():
    table, verdict = bd.summarize(_rows())
    t = {r["variant"]: r for r in table}
    assert t["ours"]["median"] == pytest.approx(3.6) and t["ours"]["runs"] == 2
    assert (t["grid-y"]["min"], t["grid-y"]["max"]) == pytest.approx((4.0, 5.0))
    # per-round ratios cancel the drift: exactly 4/5 and 4/3
    assert t["grid-y"]["ours_over"] == pytest.approx(0.8)
    assert t["multi"]["ours_over"] == pytest.approx(4 / 3)
    # efficiency per core against serial: 3.6 / 2 / 2.25
    assert t["ours"]["per_core_vs_serial"] == pytest.approx(0.8)
    assert t["balance-rcb"]["runs"] == 0 and t["balance-rcb"]["error"] == "ERROR: something refused"
    # serial is faster per core but runs on one: best is among the 2-core variants
    assert verdict == {"best": "grid-y", "ours_over_best": pytest.approx(0.8), "cores": 2}


def test_summary_when_ours_is_best_or_failed():
    rows = [r for r in _rows() if r["variant"] != "grid-y"]
    assert bd.summarize(rows)[1]["best"] == "ours"
    failed = [dict(r, matom_step_per_s=None, error="ERROR: x") if r["variant"] == "ours" else r for r in rows]
    assert bd.summarize(failed)[1]["ours_over_best"] is None


def test_markdown_table_has_every_variant_and_the_verdict():
    table, verdict = bd.summarize(_rows())
    md = bd.markdown_table("heap/demo/x", "note", table, verdict, ["grid-x: same deck and launch as ours, not run"])
    assert md.startswith("### heap/demo/x")
    body = [l for l in md.splitlines() if l.startswith("| ") and not l.startswith(("| variant", "| ---"))]
    assert [l.split("|")[1].strip() for l in body] == ["ours", "serial", "grid-y", "multi", "balance-rcb"]
    assert re.search(r"ours / best on 2 cores = \*\*0\.80\*\* \(best: grid-y\)", md)
    assert "- grid-x: same deck and launch as ours, not run" in md
