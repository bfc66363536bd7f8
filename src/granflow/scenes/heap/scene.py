"""The heap scene's declaration: sweep, checks, analysis glue, table, figures, headline, cost knobs."""
from __future__ import annotations

import dataclasses
import math
from pathlib import Path

from granflow.config import ConfigError
from granflow.preflight import PreflightError
from granflow.registry import Deferred, FigureSpec, Knob, Scene, SnapshotView, Stage, SweepAxis
from granflow.schema import require

from .parameters import feed_plan, heap_parameters

#: the names of heap/figures.py's HEAP_FIGURES, in its order (tests/unit/test_heap_plots.py keeps them equal): the
#: scene declares its figures without importing matplotlib (granflow.registry.Deferred)
FIGURE_NAMES = (
    "fig03_segregation", "fig04_surface", "fig04b_surface_shape", "fig05_velocity", "fig06_streamwise",
    "fig07_collapse", "fig08_normal", "fig09_all_cases", "fig10_scaled", "fig11_qstar",
)

#: analysis tables of a case, in the order the figures read them
TABLES = ("per_x", "profile", "collapse", "surface", "alpha_t", "rise_by_x", "phi_columns", "deposit", "deposit_variants",
          "static_bed", "phi_profile", "surface_cutoff", "gap_surface_velocity", "deposit_gap")


class HeapScene(Scene):
    name = "heap"
    statuses = {
        "unsteady": "the feed missed its rate by more than protocol.feed_rate_tol, or the rise velocity varies by 25 % or more along the heap",
    }
    #: seen through the front side wall (-y): feed on the left, end wall on the right; colour by
    #: species; no image of the init stage (the box is still empty)
    time_unit = "s"
    snapshot = SnapshotView(color="type", view=(90.0, -90.0), size=(900, 500), zoom=2.2, stages=("flow", "average"))
    summary = "quasi-2D bounded heap filled from one end, inclined base and end wall (Fan et al. 2013)"
    paper = "Fan, Umbanhowar, Ottino & Lueptow (2013), J. Fluid Mech., \"Kinematics of mono- and bidisperse granular flow in quasi-two-dimensional bounded heaps\""
    #: δ is where u = 0.1 u_s, which forces A e^{-k} ≈ 0.1: A is k counted again; the q* exponent fitted over x
    #: inside one case measures how δ thins toward the end wall, not the paper's pooling over feed rates
    check_kinds = {"tail u/u_s = A e^{k z/δ}: prefactor A": "consistency",
                   "δ/d̄ ∝ q*^a: exponent a": "diagnostic"}
    # directories carry the feed rate in g/s: mdot~33 for 0.033 kg/s
    sweep = (SweepAxis("mixture", "mix", name=True), SweepAxis("feed_rate", "mdot", scale=1000.0))
    # the figures of heap/figures.py (HEAP_FIGURES), with the paper figure each reproduces; drawn when asked
    figures = {name: FigureSpec(Deferred("granflow.scenes.heap.figures", name), name.split("_")[0][3:].lstrip("0"))
               for name in FIGURE_NAMES}
    table_sort = ("mixture", "feed_rate")
    headline = (("alpha", "α (deg)"), ("delta_over_d", "δ/d̄"), ("tail_exponent", "tail exponent"))
    knobs = {
        "dt_fraction": Knob(("rungs.{r}.dt_fraction",), "set", "min", "dt / t_c"),
        "stiffness": Knob(("rungs.{r}.t_c",), "set", "min", "contact time t_c, s"),
        "size": Knob(("rungs.{r}.W", "rungs.{r}.T", "case.feed_rate"), "scale", "max",
                     "factor on length W, gap T and feed rate"),
        "t_average": Knob(("rungs.{r}.t_average",), "set", "max", "averaging time, s"),
        "bin_width": Knob(("rungs.{r}.bin_dz_u",), "set", "min", "velocity depth bin, d̄"),
    }

    # -- configuration ---------------------------------------------------------------
    def check(self, scene: dict, source: str) -> None:
        for name, mix in scene["particles"]["mixtures"].items():
            d, f = mix["diameters"], mix["volume_fractions"]
            require(len(d) == len(f), f"{source}: particles.mixtures.{name}.volume_fractions has {len(f)} entries, "
                                     f"diameters has {len(d)}: allowed only equal lengths")
            require(math.isclose(sum(f), 1.0, abs_tol=1e-6),
                   f"{source}: particles.mixtures.{name}.volume_fractions sum to {sum(f):g}: allowed sum = 1")
            require(list(d) == sorted(d), f"{source}: particles.mixtures.{name}.diameters = {d}: "
                                         f"allowed only increasing (species 1 is the small one)")
        mix = scene["case"]["mixture"]
        require(mix in scene["particles"]["mixtures"],
               f"{source}: case.mixture = {mix!r} is not allowed: allowed one of "
               f"{', '.join(map(repr, scene['particles']['mixtures']))}")
        for name, r in scene["rungs"].items():
            require(r["feed_width"] < r["W"], f"{source}: rungs.{name}.feed_width = {r['feed_width']}: "
                                             f"allowed < W = {r['W']}")
        self.check_effects(scene["effects"], source)

    #: the walls that close the box (its faces are fixed boundaries): without one, particles leave
    #: through that face and LAMMPS stops with lost atoms (each measured at smoke)
    CLOSING_WALLS = {"end": "the end wall at x = W stops the flow down the base",
                     "feed_side": "the wall at x = 0 holds the pile under the feed",
                     "sides": "the side walls at y = 0 and T bound the gap"}

    def check_effects(self, eff: dict, source: str) -> None:
        """Refuse effects the heap cannot run with, naming the key, the value and why (each
        combination below ran at smoke and failed as its message says)."""
        require(eff["feed"], f"{source}: effects.feed = false is not allowed: the heap holds only the particles "
                             f"the feed pours (the init stage leaves the box empty), so there would be nothing "
                             f"to simulate (LAMMPS stops at the first flow segment: 'Velocity command with no "
                             f"atoms existing'): allowed true")
        require(eff["gravity"], f"{source}: effects.gravity = false is not allowed with effects.feed = true: the "
                                f"feed is LAMMPS's fix pour, which needs a fix gravity (LAMMPS stops: 'There must "
                                f"be exactly one fix gravity defined for fix pour'): allowed true")
        walls = list(eff["walls"])
        missing = [w for w in self.CLOSING_WALLS if w not in walls]
        require(not missing, f"{source}: effects.walls = {walls} is not allowed: it lacks {', '.join(missing)} ("
                             + "; ".join(self.CLOSING_WALLS[w] for w in missing) + "): the box's faces are fixed "
                             f"boundaries, so particles leave through each open face and LAMMPS stops with lost "
                             f"atoms: allowed end, feed_side and sides, with or without base")
        require("base" in walls or eff["freeze_base"],
                f"{source}: effects.walls = {walls} without base is not allowed with effects.freeze_base = false: "
                f"nothing then holds the particles on the inclined base, they fall out of the box and LAMMPS stops "
                f"with lost atoms: allowed base in effects.walls, or freeze_base = true (the particles frozen on "
                f"the base plane are then the base)")

    def check_case(self, scene: dict, rung: str, case: dict, source: str) -> None:
        """A known mixture, and a feed rate the feed zone can deliver."""
        mix, rate = case["mixture"], case["feed_rate"]
        require(mix in scene["particles"]["mixtures"],
               f"{source}: scenes.heap.sweep.mixture = {mix!r} is not allowed: allowed one of "
               f"{', '.join(map(repr, scene['particles']['mixtures']))}")
        try:
            feed_plan(scene, rung, dict(scene["case"], **case))
        except PreflightError as exc:
            raise ConfigError(f"{source}: scenes.heap.sweep.feed_rate = {rate} (mixture {mix}, rung {rung}) "
                              f"is not allowed: {exc}") from None

    # -- decks -----------------------------------------------------------------------
    def parameters(self, scene: dict, rung: str, case: dict | None = None):
        return heap_parameters(scene, rung, case)

    def describe(self, record: dict) -> str:
        prm = record["parameters"]
        return (f"W = {prm['W']:g} m, feed rate {prm['feed_rate']:g} kg/s ({prm['feed_rate_planned']:.4g} planned), "
                f"~{record['n_particles_estimate']} particles by the end")

    def workload(self, record: dict):
        """Particles are poured: none at the start, ``sum(nper)`` every ``n_feed`` steps from the
        first step of each segment (``fix pour`` inserts at step 1, 1 + n_feed, ...), so the count
        grows linearly and ``particles`` is the count at the end (not ``n_particles_estimate``,
        which stops at the estimated steady time plus t_average). Atom-steps sum the count over
        every step. The deck splits the box along x only (``processors * 1 1``): at most one
        rank per two largest diameters of W.
        """
        base = super().workload(record)
        prm = record["parameters"]
        seg, nfreq = int(prm["n_segment"]), int(prm["n_feed"])
        batch = sum(int(p["nper"]) for p in record["feed"]["pours"])
        batches = seg // nfreq  # insertions per segment (n_segment is a whole number of feed periods)
        n, stages = 0, {"init": Stage(0, 0.0, 1)}
        for name, k in (("flow", int(record["n_flow_segments"])), ("average", int(record["n_average_segments"]))):
            atom_steps = 0.0
            for _ in range(k):
                atom_steps += nfreq * (batches * n + batch * batches * (batches + 1) / 2)
                n += batches * batch
            stages[name] = Stage(k * seg, atom_steps, k)
        d_max = max(s["d_hi"] for s in record["species"])
        return dataclasses.replace(base, particles=n, stages=stages, growing=True,
                                   max_ranks=max(1, int(prm["W"] // (2 * d_max))),
                                   note="particles poured over time: the count at the end")

    def simulate_ranks(self, rung: str, cores: int) -> int:
        """All cores from demo up (one large case, balanced along x).

        Measured on 2 cores (demo heap, 11k particles, 3000 steps): 6.7 s on 2 ranks
        with the x cuts balanced; the heap is the longest job of the demo campaign.
        """
        return 1 if rung == "smoke" else cores

    # -- analysis --------------------------------------------------------------------
    def analyse(self, case_dir: Path):
        from granflow.case import case_inputs

        from .pipeline import heap_analysis

        case_dir, record, status = case_inputs(case_dir)
        if status["dumps"]:
            tables, scalars = heap_analysis(case_dir)
            # the steady filling stage: the surface rises uniformly (paper fig. 4c) and the feed delivers its rate
            problems = []
            if not scalars["feed_rate_ok"]:
                problems.append(f"feed rate {scalars['feed_rate_measured']:.4g} kg/s is "
                                f"{100 * scalars['feed_rate_error']:+.1f} % off the requested {scalars['feed_rate']:.4g}")
            if not scalars["rise_velocity_cv"] < 0.25:
                problems.append(f"rise velocity varies by {100 * scalars['rise_velocity_cv']:.0f} % along the heap")
            verdict = "steady" if not problems else "unsteady"
        else:
            tables, scalars = {}, {"notes": f"not averaged: {status['status']}"}
            problems, verdict = [status.get("reason") or status["status"]], status["status"]
        import pandas as pd

        tables = {name: tables.get(name, pd.DataFrame()) for name in TABLES}
        k = record["rung_knobs"]
        n = scalars.get("n_particles", record.get("n_particles_estimate"))
        scalars.update({
            "rung": record["rung"], "mixture": record["case"]["mixture"], "feed_rate": record["case"]["feed_rate"],
            "bidisperse": len(record["species"]) == 2,
            "W": k["W"], "T": k["T"], "x_feed": record["geometry"]["x_feed"], "t_c": k["t_c"], "dt": record["dt"], "k_n": record["parameters"]["k_n"],
            "status": verdict if status["status"] == "completed" else status["status"],
            "status_reason": "; ".join(problems) or (
                f"the feed delivered {scalars['feed_rate_measured']:.4g} kg/s ({100 * scalars['feed_rate_error']:+.1f} % "
                f"of the request) and the surface rose uniformly (v_r varies by {100 * scalars['rise_velocity_cv']:.0f} % "
                f"along the heap, limit 25 %)" if verdict == "steady" else status.get("reason")),
            "max_overlap": status.get("max_overlap"), "dangerous_builds": status.get("dangerous_builds"),
            "matom_step_per_s": status.get("matom_step_per_s"), "loop_seconds": status.get("loop_seconds"),
            "provenance": (f"rung {record['rung']} · W={k['W']:g} m · T={k['T'] * 1e3:g} mm · t_c={k['t_c']:g} s · "
                           f"N={n} · {verdict}"),
        })
        return tables, scalars

    def figure_cases(self, cases):
        out = []
        for s, tables in cases:
            if tables["profile"].empty:  # not averaged: in the table with its status, not in the figures
                continue
            label = f"{s['mixture']}, {1000 * s['feed_rate']:g} g/s"
            out.append({"label": label, "provenance": s["provenance"], "scalars": s, "bidisperse": s["bidisperse"],
                        **{k: tables[k] for k in TABLES}, "deposit": tables["deposit"] if s["bidisperse"] else None})
        return out

    # -- the validation record -------------------------------------------------------------
    def profile_checks(self, profiles):
        """The checks made from the record's profiles (streamwise, collapse, surface): Figs. 6-11 in the
        paper's form and δ/d̄ ∝ q*^a across feed rates (:func:`granflow.scenes.heap.profile_checks.profile_checks`,
        which validation() calls too) and γ̇'s profile in depth (:mod:`granflow.scenes.heap.shear_checks`)."""
        from .profile_checks import profile_checks
        from .shear_checks import shear_checks

        return profile_checks(profiles) + shear_checks(profiles)

    def validation(self, scene_dir, cases):
        """Fan et al. (2013) against the cases: :func:`granflow.scenes.heap.validation.validation`."""
        from .validation import validation

        return validation(Path(scene_dir), cases)

    # -- the error-versus-cost study -------------------------------------------------------
    def observables(self, case_dir, record, t_average, block=None):
        from .pipeline import heap_observables

        return self.averaged_window(heap_observables, case_dir, record, t_average, block)

    def paper_reference(self, scene: dict) -> dict:
        _, context = self.parameters(scene, "paper")
        rec = context["record"]
        return {"n_particles": int(rec["n_particles_estimate"]),
                "sim_time": float(rec["t_steady_estimate"] + rec["rung_knobs"]["t_average"]),
                "dt": rec["dt"], "dt_fraction": rec["dt"] / rec["parameters"]["t_c_min"],
                "how": "estimated filling time to a steady heap + t_average (particles at the end)"}

    def cost_note(self, scene: dict, rung: str) -> str:
        r = scene["rungs"][rung]
        return f"W = {r['W']:g} m, T = {r['T'] * 1e3:g} mm, t_c = {r['t_c']:g} s, dt = {r['dt_fraction']:g} t_c"
