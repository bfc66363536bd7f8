"""Heap decks: feed-rate planning and refusals, effects -> exactly those commands, skiprun."""
import copy
import math
import re

import pytest

from granflow.campaign import load_campaign
from granflow.config import ConfigError
from granflow.deck import STAGES, render_case
from granflow.preflight import PreflightError
from granflow.scenes.heap.parameters import feed_plan, species

#: a feed rate the smoke rung's small feed zone can deliver
SMOKE_CASE = {"feed_rate": 0.003}


def test_contact_time_and_restitution_of_reference_pair(heap_scene, tmp_path):
    """k_n and xi_n reproduce the paper's t_c = 1 ms and e = 0.8 for two 1.5 mm particles."""
    record = render_case(heap_scene, "demo", tmp_path)
    ref = [c for c in record["contacts"] if c["name"] == "0.0015-0.0015 pair"][0]
    assert ref["t_c"] == pytest.approx(1.0e-3, rel=1e-9)
    assert ref["e_n"] == pytest.approx(0.8, rel=1e-9)
    # the deck's time step against a hand calculation from config/scenes/heap.yaml (demo rung,
    # mono1.5): the 1.5 mm pair (m_eff = m/2, m = rho pi d^3/6, rho = 2500) has t_c = 1 ms and
    # e = 0.8, so xi_n = -2 ln e/t_c and k_n = m_eff (pi^2/t_c^2 + xi_n^2/4); the shortest contact
    # is the pair of the smallest particles of the spread, uniform with std 0.1 d, so
    # d_lo = d (1 - 0.1 sqrt 3); dt = 0.02 of it
    rho, d, t_ref, e = 2500.0, 1.5e-3, 1.0e-3, 0.8
    m_pair = lambda diameter: rho * math.pi * diameter**3 / 6 / 2  # noqa: E731
    xi_n = -2 * math.log(e) / t_ref
    k_n = m_pair(d) * (math.pi**2 / t_ref**2 + xi_n**2 / 4)
    t_c = math.pi / math.sqrt(k_n / m_pair(d * (1 - 0.1 * math.sqrt(3))) - xi_n**2 / 4)
    assert t_c == pytest.approx(7.5097e-4, rel=1e-4)
    deck = {name: float(value) for name, value in
            re.findall(r"^variable +(\w+) +equal +([-+.0-9eE]+) +#", (tmp_path / "flow.lmp").read_text(), re.M)}
    assert deck["k_n"] == pytest.approx(k_n, abs=5e-10)     # written with 9 decimals
    assert deck["t_c_min"] == pytest.approx(t_c, abs=5e-13)
    assert deck["dt"] == pytest.approx(0.02 * t_c, abs=5e-13)  # written with 12 decimals
    assert re.search(r"^timestep +\$\{dt\}$", (tmp_path / "flow.lmp").read_text(), re.M)


def test_species_spread_is_uniform_with_the_requested_std(heap_scene):
    (sp,) = species(heap_scene, "mono1.5")
    # a uniform distribution on [lo, hi] has std (hi - lo)/sqrt(12)
    assert (sp["d_hi"] - sp["d_lo"]) / math.sqrt(12) == pytest.approx(0.1 * 1.5e-3, rel=1e-12)


def test_feed_plan_delivers_the_requested_rate(heap_scene):
    plan = feed_plan(heap_scene, "demo", {**heap_scene["case"], "feed_rate": 0.033})
    # whole particles per insertion: within half the allowed tolerance
    assert plan["rate_planned"] == pytest.approx(0.033, rel=0.025)
    assert plan["top_slab_fraction"] <= heap_scene["protocol"]["feed_max_fraction"]


def test_bidisperse_feed_is_equal_volumes(heap_scene):
    case = {**heap_scene["case"], "mixture": "bi1-2", "feed_rate": 0.02}
    plan = feed_plan(heap_scene, "demo", case)
    sp = species(heap_scene, "bi1-2")
    vol = [p["nper"] * s["mean_volume"] for p, s in zip(plan["pours"], sp)]
    # rounding to whole particles: 2.5 % of each share at most
    assert vol[0] == pytest.approx(vol[1], rel=0.05)


def test_infeasible_rate_is_refused_with_the_largest_feasible_rate(heap_scene):
    with pytest.raises(PreflightError, match=r"largest feasible rate [0-9.]+ kg/s"):
        feed_plan(heap_scene, "smoke", {**heap_scene["case"], "feed_rate": 0.5})


def test_campaign_refuses_an_infeasible_sweep_point(root):
    with pytest.raises(ConfigError, match=r"scenes.heap.sweep.feed_rate = 0.5 .*largest feasible rate"):
        load_campaign(root / "config" / "config.yaml", ["scenes.heap.sweep.feed_rate=[0.5]"], root=root)
    with pytest.raises(ConfigError, match=r"scenes.heap.sweep.mixture = 'nope' is not allowed"):
        load_campaign(root / "config" / "config.yaml", ["scenes.heap.sweep.mixture=[nope]"], root=root)


def test_effects_off_means_commands_absent(heap_scene, tmp_path):
    scene = copy.deepcopy(heap_scene)
    scene["effects"].update(freeze_base=False, walls=["base", "end", "sides"])
    render_case(scene, "smoke", tmp_path, SMOKE_CASE)
    flow = (tmp_path / "flow.lmp").read_text()
    commands = [l for l in flow.splitlines() if l and not l.startswith(("#", "variable "))]
    assert not [l for l in commands if "freeze" in l or "frozen" in l or l.startswith("run") and " every " in l]
    assert "xplane NULL ${W}" in flow
    render_case(heap_scene, "smoke", tmp_path / "on", SMOKE_CASE)
    on = (tmp_path / "on" / "flow.lmp").read_text()
    assert "fix             freeze frozen freeze" in on and "xplane 0.0 ${W}" in on
    # particle dumps only where the analysis reads them
    assert not re.search(r"^dump ", on, re.M) and re.search(r"^dump .*x y z vx vy vz", (tmp_path / "on" / "average.lmp").read_text(), re.M)


def test_bidisperse_deck_pours_two_types(heap_scene, tmp_path):
    render_case(heap_scene, "demo", tmp_path, {"mixture": "bi1-2", "feed_rate": 0.02})
    flow = (tmp_path / "flow.lmp").read_text()
    assert "create_box      2 box" in (tmp_path / "init.lmp").read_text()
    # each species pours into its own group (t1, t2), which per-type walls act on
    assert len(re.findall(r"^fix +pour(\d) t\1 pour \d+ \1 ", flow, re.M)) == 2


@pytest.mark.parametrize("mixture, multi", [("mono1.5", False), ("bi1-2", True), ("bi1-3", True)])
def test_neighbour_binning_follows_the_size_ratio(heap_scene, tmp_path, mixture, multi):
    """Per-species neighbour bins (and ghost cutoffs) from a size ratio of 1.5: bench-measured faster there."""
    import json

    render_case(heap_scene, "demo", tmp_path, {"mixture": mixture, "feed_rate": 0.02})
    for stage in ("flow", "average"):
        deck = (tmp_path / f"{stage}.lmp").read_text()
        assert bool(re.search(r"^neighbor +\$\{skin\} multi$", deck, re.M)) == multi
        assert bool(re.search(r"^comm_modify +mode multi$", deck, re.M)) == multi
        assert bool(re.search(r"^neighbor +\$\{skin\} bin$", deck, re.M)) == (not multi)
    record = json.loads((tmp_path / "params.json").read_text())
    assert record["neighbor_multi"] == multi and (record["size_ratio"] >= 1.5) == multi


@pytest.mark.lammps
@pytest.mark.parametrize("rung", ["smoke", "demo", "study", "paper", "validation"])
def test_every_rung_passes_skiprun(heap_scene, tmp_path, skiprun, replace_once, rung):
    """Each stage parses and sets up in LAMMPS; fix pour plans exactly our nper and nfreq."""
    record = render_case(heap_scene, rung, tmp_path, SMOKE_CASE if rung == "smoke" else None)

    def one_step(stage, text):
        """-skiprun would still loop over the freeze interval's short runs; one step is enough here.
        The init stage only builds the box (``run 0``); each flow stage has the one segment run."""
        if stage == "init":
            assert "${n_segment}" not in text
            return text
        return replace_once(text, "run             ${n_segment}", "run 1")

    out = skiprun(tmp_path, STAGES, edit=one_step)
    m = re.search(r"Particle insertion: (\d+) every (\d+) steps", out["flow"])
    assert m, out["flow"][-2000:]
    # LAMMPS's own nper and nfreq are the ones the rate was planned with
    assert int(m.group(2)) == record["parameters"]["n_feed"] == record["feed"]["nfreq"]
    assert int(m.group(1)) == record["feed"]["pours"][0]["nper"]
