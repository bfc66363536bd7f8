"""The channel scene's declaration: sweep, checks, analysis glue, table, figures, headline, cost knobs."""
from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import pandas as pd

from granflow.registry import Deferred, FigureSpec, Knob, Scene, SnapshotView, Stage, SweepAxis
from granflow.schema import require

from .parameters import channel_parameters


#: the module of the figures (imported when one is drawn: granflow.registry.Deferred)
_FIGURES = "granflow.scenes.channel.figures"


def _or_placeholder(draw):
    """The figure, or with no averaged case a short note in its place rather than a failed campaign."""
    def draw_or_say(cases, path):
        if cases:
            return draw(cases, path)
        from matplotlib.figure import Figure

        fig = Figure(figsize=(6, 2))
        fig.text(0.5, 0.5, "no averaged case: every case is jammed, unsteady or unstable\n(see table.csv)",
                 ha="center", va="center")
        fig.savefig(path, dpi=150)
        return fig

    return draw_or_say


class ChannelScene(Scene):
    name = "channel"
    #: seen along the periodic depth z: walls left and right, flow downwards; colour by speed
    time_unit = "√(d_p/g)"
    snapshot = SnapshotView(color="speed", view=(0.0, 0.0), up=(0.0, 1.0, 0.0), size=(500, 900), zoom=1.0)
    summary = "periodic vertical channel between two flat frictional walls (Debnath, Kesava Rao & Kumaran 2022)"
    paper = "Debnath, Kesava Rao & Kumaran (2022), J. Fluid Mech., \"Different shear regimes in the dense granular flow in a vertical channel\""
    #: eq. 3.1's a is forced ≈ ln 20 by δ0.95's definition (the scaled profile is 0.95 there); the drift and the
    #: plug's non-affine motion read our own run, the paper gives no number
    check_kinds = {"eq. 3.1 exponent a": "consistency",
                   "drift of u_max/u_slip over the averaging window": "diagnostic",
                   "plug: rms non-affine displacement over the window": "diagnostic"}
    sweep = (SweepAxis("W", "W"), SweepAxis("phi_mean", "phi"))
    figures = {
        "fig04_velocity": FigureSpec(_or_placeholder(Deferred(_FIGURES, "fig_velocity_profiles")), "4"),
        "fig05c_ratio": FigureSpec(_or_placeholder(Deferred(_FIGURES, "fig_ratio_vs_phi")), "5(c)"),
        "fig06_stress": FigureSpec(_or_placeholder(Deferred(_FIGURES, "fig_stress_profiles")), "6"),
        "fig08_phi_shear_T": FigureSpec(_or_placeholder(Deferred(_FIGURES, "fig_phi_shear_temperature")), "8"),
        "fig11_rheology": FigureSpec(_or_placeholder(Deferred(_FIGURES, "fig_rheology")), "11"),
        "fig_steadiness_plug": FigureSpec(_or_placeholder(Deferred(_FIGURES + "_plug", "fig_steadiness_plug")), "—"),
    }
    table_sort = ("W", "phi_mean")
    headline = (("u_ratio", "u_max/u_slip"), ("delta_over_W", "δ0.95/W"),
                ("sigma_xx_over_W", "σxx/W"), ("eq31_exponent", "eq. 3.1 exponent"))
    knobs = {
        "dt_fraction": Knob(("rungs.{r}.dt_fraction",), "set", "min", "dt / t_c"),
        "stiffness": Knob(("rungs.{r}.k_n",), "set", "max", "k_n, m_p g/d_p"),
        "size": Knob(("rungs.{r}.W", "rungs.{r}.B", "rungs.{r}.H"), "scale", "max", "factor on W, B, H"),
        "t_average": Knob(("rungs.{r}.t_average",), "set", "max", "averaging time, √(d_p/g)"),
        "bin_width": Knob(("rungs.{r}.bin_width",), "set", "min", "bin width, d_p"),
    }

    # -- configuration ---------------------------------------------------------------
    def check(self, scene: dict, source: str) -> None:
        p = scene["particles"]
        require(len(p["diameters"]) == len(p["number_fractions"]),
               f"{source}: particles.number_fractions has {len(p['number_fractions'])} entries, "
               f"particles.diameters has {len(p['diameters'])}: allowed only equal lengths")
        total = sum(p["number_fractions"])
        require(math.isclose(total, 1.0, abs_tol=1e-6),
               f"{source}: particles.number_fractions sum to {total:g}: allowed sum = 1")
        for name, r in scene["rungs"].items():
            W = r["W"]
            require(2 * r["wall_bin_width"] + r["bin_width"] <= W,
                   f"{source}: rungs.{name}.W = {W} leaves no interior bin: allowed W >= "
                   f"2*wall_bin_width + bin_width = {2 * r['wall_bin_width'] + r['bin_width']}")
            require(r["t_segment"] <= r["t_flow_max"],
                   f"{source}: rungs.{name}.t_segment = {r['t_segment']}: allowed <= t_flow_max = {r['t_flow_max']}")
        self.check_effects(scene["effects"], source)

    def check_effects(self, eff: dict, source: str) -> None:
        """Refuse effects the channel cannot run with, naming the key, the value and why (each
        ran at smoke and failed as its message says)."""
        require("x" in eff["walls"],
                f"{source}: effects.walls = {list(eff['walls'])} is not allowed: the channel is bounded across x "
                f"by its two walls alone (x is a fixed boundary), so particles leave the box and LAMMPS stops "
                f"with lost atoms while the bed settles"
                + (" (and effects.wall_force = true reads the force of walls that do not exist)"
                   if eff["wall_force"] else "") + ": allowed [x]")
        periodic = list(eff["periodic"])
        require("z" in periodic,
                f"{source}: effects.periodic = {periodic} is not allowed: the channel has no walls in z, so a "
                f"non-periodic z is a fixed boundary that particles leave, and LAMMPS stops with lost atoms: "
                f"allowed [y, z]")
        require("y" in periodic,
                f"{source}: effects.periodic = {periodic} is not allowed: the flow direction y is made periodic "
                f"after packing whatever this says (a channel without ends), so the file would describe a run "
                f"other than the one made: allowed [y, z]")

    def check_case(self, scene: dict, rung: str, case: dict, source: str) -> None:
        r = scene["rungs"][rung]
        W = case.get("W") if case.get("W") is not None else r["W"]
        require(2 * r["wall_bin_width"] + r["bin_width"] <= W,
               f"{source}: scenes.channel.sweep.W = {W} leaves no interior bin: allowed W >= "
               f"{2 * r['wall_bin_width'] + r['bin_width']}")

    def case_values(self, scene: dict, rung: str, case: dict | None = None) -> dict:
        merged = dict(scene["case"], **(case or {}))
        if merged.get("W") is None:
            merged["W"] = scene["rungs"][rung]["W"]
        return merged

    # -- decks -----------------------------------------------------------------------
    def parameters(self, scene: dict, rung: str, case: dict | None = None):
        return channel_parameters(scene, rung, case)

    def describe(self, record: dict) -> str:
        prm = record["parameters"]
        return f"W = {prm['W']:g} d_p, phi_mean = {prm['phi_mean']:g}, {prm['n_particles']} particles"

    #: densest packing a settled column reaches (random close packing), for the lid's travel bound
    PHI_RCP = 0.64

    def workload(self, record: dict):
        """The default, plus the lid stage of init: it moves from the settled column top plus d_max
        to H_per at max(lid_speed, travel/10) (at most 10 time units when it comes down), or, over a
        column that settled below H_per, up at lid_speed (the column top is at least
        phi_mean/PHI_RCP H_per). Measured: the demo channel's lid moved 3.8 time units."""
        base = super().workload(record)
        prm = record["parameters"]
        below = prm["H_per"] * (1.0 - prm["phi_mean"] / self.PHI_RCP) - prm["d_max"]
        lid = math.ceil(max(10.0, below / prm["lid_speed"]) / prm["dt"])
        init = base.stages["init"]
        stages = dict(base.stages, init=Stage(init.steps + lid, init.atom_steps + lid * base.particles, init.segments))
        return dataclasses.replace(base, stages=stages)

    # -- analysis --------------------------------------------------------------------
    def analyse(self, case_dir: Path):
        from granflow.case import case_inputs

        from .analysis import analyse_channel
        from .pipeline import channel_profile, momentum_balance

        case_dir, record, status = case_inputs(case_dir)
        W, phi = record["parameters"]["W"], record["parameters"]["phi_mean"]
        thermo = pd.read_csv(case_dir / "run" / "thermo.csv")
        total_mass = sum(s["count"] * s["mass"] for s in record["species"])
        tables = {}
        if status["dumps"]:
            profile, facts = channel_profile(case_dir)
            scalars = analyse_channel(profile, W, phi)
            window = thermo[thermo["stage"] == "average"]
            tables, more = self._steadiness_and_plug(case_dir, record, scalars, profile)
            scalars.update(more)
        else:
            # not averaged (jammed, no steady state, unstable): an empty profile, the reason in the table
            profile = pd.DataFrame(columns=["x", "x_lo", "x_hi"])
            facts = {"n_particles": record["parameters"]["n_particles"], "n_frames": 0, "total_mass": total_mass}
            scalars = {"notes": f"not averaged: {status['status']}"}
            window = thermo
        balance = momentum_balance(window, facts["total_mass"])
        k = record["rung_knobs"]
        scalars.update({
            "rung": record["rung"], "W": W, "phi_mean": phi, "B": k["B"], "k_n": k["k_n"],
            "dt": record["dt"], "n_particles": facts["n_particles"], "n_frames": facts["n_frames"],
            "status": status["status"], "status_reason": status.get("reason"),
            "max_overlap": status.get("max_overlap"), "dangerous_builds": status.get("dangerous_builds"),
            "averaged_unsteady": bool(status["dumps"]) and status["status"] != "steady",
            "momentum_residual": balance["residual"], "momentum_steady_residual": balance["steady_residual"],
            "wall_force": balance["wall_force"], "weight": balance["weight"],
            "matom_step_per_s": status.get("matom_step_per_s"),
            "provenance": (f"rung {record['rung']} · W={W:g} d_p · B={k['B']:g} · k_n={k['k_n']:.0e} · "
                           f"N={facts['n_particles']} · {status['status']}"),
        })
        return {"profile": profile, **tables}, scalars

    @staticmethod
    def _steadiness_and_plug(case_dir: Path, record: dict, scalars: dict, profile) -> tuple[dict, dict]:
        """Per-block u_max/u_slip with its drift, and the plug's structure (:mod:`.analysis.plug`)."""
        from .analysis.plug import Q6_CUTOFF_VARIANTS, drift
        from .pipeline import channel_blocks, channel_plug_structure

        window = float(record["rung_knobs"]["t_average"])
        blocks = channel_blocks(case_dir, record, window)
        change, change_se = drift(blocks)
        plug = channel_plug_structure(case_dir, record, float(scalars.get("x_dense_plug", float("nan"))), profile)
        s = plug.summary
        out = {"ratio_drift": change, "ratio_drift_se": change_se,
               "ratio_block_sd": float(blocks["ratio"].std(ddof=1)) if len(blocks) > 1 else float("nan"),
               "n_blocks": int(len(blocks))}
        names = {"q6_plug": "plug_q6", "crystal_plug": "plug_crystal_fraction", "q6_shear": "shear_q6",
                 "crystal_shear": "shear_crystal_fraction", "layering_plug": "plug_layering",
                 "layering_random": "plug_layering_random", "nonaffine_rms_plug": "plug_nonaffine_rms",
                 "Q6_plug": "plug_Q6", "Q6_plug_se": "plug_Q6_se", "Q6_plug_inner": "plug_Q6_inner",
                 **{f"Q6_plug_cut{c:g}": f"plug_Q6_cut{c:g}" for c in Q6_CUTOFF_VARIANTS}}
        out.update({column: s.get(key, float("nan")) for key, column in names.items()})
        return {"blocks": blocks, "structure": plug.frames}, out

    def figure_cases(self, cases):
        out = []
        for s, tables in cases:
            profile = tables.get("profile", pd.DataFrame())
            if profile.empty:  # not averaged: shown in the table with its status, not in the figures
                continue
            out.append({"label": f"W={s['W']:g}, φ̄={s['phi_mean']:g}", "W": s["W"], "phi_mean": s["phi_mean"],
                        "profile": profile, "scalars": s, "provenance": s["provenance"],
                        "blocks": tables.get("blocks", pd.DataFrame()),
                        "structure": tables.get("structure", pd.DataFrame())})
        return out

    # -- the error-versus-cost study -------------------------------------------------------
    def observables(self, case_dir, record, t_average, block=None):
        from .pipeline import channel_observables

        return self.averaged_window(channel_observables, case_dir, record, t_average, block)

    # -- the validation record ---------------------------------------------------------
    def validation(self, scene_dir: Path, cases: dict[str, Path]):
        """Checks against Debnath et al. (2022): :func:`granflow.scenes.channel.validation.validation`."""
        from .validation import validation

        return validation(scene_dir, cases)

    def paper_reference(self, scene: dict) -> dict:
        _, context = self.parameters(scene, "paper")
        rec = context["record"]
        rung = rec["rung_knobs"]
        return {"n_particles": int(rec["parameters"]["n_particles"]),
                "sim_time": float(scene["protocol"]["settle_time"] * 1.2 + rung["t_flow_max"] + rung["t_average"]),
                "dt": rec["dt"], "dt_fraction": rec["dt"] / rec["parameters"]["t_c_min"],
                "how": "settle + t_flow_max + t_average"}

    def cost_note(self, scene: dict, rung: str) -> str:
        r = scene["rungs"][rung]
        return f"W = {r['W']:g} d_p, k_n = {r['k_n']:.0e}, dt = {r['dt_fraction']:g} t_c"
