"""The silo scene's declaration: sweep, checks, discharge verdict, analysis glue, table with the
Beverloo fit, figures, headline, cost knobs."""
from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pandas as pd

from granflow.registry import Deferred, FigureSpec, Knob, Scene, SnapshotView, SweepAxis
from granflow.schema import require

from .parameters import discharge_verdict, gas_count, rim_ring, silo_parameters, species

#: analysis tables of every case (plus kinetic_w<w> for each kernel width of cg.w_scan)
TABLES = ("flow", "fields", "contact", "orifice_plane", "kinetic_eq7", "kinetic_fine")

#: the names of silo/figures' SILO_FIGURES, in its order (tests/unit/test_silo_plots.py keeps them equal): the
#: scene declares its figures without importing matplotlib (granflow.registry.Deferred)
FIGURE_NAMES = (
    "fig02_flow_rate", "fig03_fields", "fig04_phi_orifice", "fig05_vz_orifice", "fig05d_orifice_plane",
    "fig06_contact_pressure", "fig07_kinetic_pressure_maps", "fig08_kinetic_axis", "fig09_kinetic_w",
    "fig10_cumulative", "fig11_partial", "fig12_partial_over_phi", "fig13_beverloo",
)


class SiloScene(Scene):
    name = "silo"
    statuses = {
        "clogged": "outflow below protocol.clog_rate_fraction of the Beverloo estimate in a segment after the first: an arch blocks the orifice",
        "unsteady": "the discharge was analysed but no steady window of the outflow W_f was found",
    }
    #: a cut through the axis (particles within 8 % of the diameter of the plane y = 0), seen from
    #: -y: the converging flow above the orifice at the bottom; colour by speed
    time_unit = "s"
    snapshot = SnapshotView(color="speed", view=(90.0, -90.0), center=(0.5, 0.5, 0.38), size=(600, 900), zoom=2.4,
                            slab_y=0.08)
    summary = "3D flat-bottomed cylindrical silo discharging through a circular orifice (Rubio-Largo et al. 2016)"
    paper = "Rubio-Largo, Maza & Hidalgo (2016), Comput. Part. Mech., \"Large-scale numerical simulations of polydisperse particle flow in a silo\""
    #: a pure power law cannot return 1/2 over R = 3.8-7.7 mean diameters even where v² = 2γg(R − R0) holds,
    #: and the kernel node is cut by the deletion plane: readings of measurement choices, no verdict; the
    #: paper states no Beverloo C or k; h_c's other reading is not the paper's way
    check_kinds = {"v_z(0) ∝ R^a: exponent a (orifice plane, no kernel)": "diagnostic",
                   "v_z(0) ∝ R^a: exponent a (kernel node, w = 2 r_b)": "diagnostic",
                   "h_c ∝ R^β: exponent β": "diagnostic",
                   "Beverloo C": "diagnostic", "Beverloo k": "diagnostic"}
    sweep = (SweepAxis("R", "R"),)
    # the figures of silo/figures (SILO_FIGURES), with the paper figure each reproduces; drawn when asked
    figures = {name: FigureSpec(Deferred("granflow.scenes.silo.figures", name),
                                "Beverloo" if name == "fig13_beverloo" else name[3:5].lstrip("0"))
               for name in FIGURE_NAMES}
    table_sort = ("R",)
    headline = (("W_f", "steady W_f (kg/s)"), ("profile_deviation", "orifice profile vs √(1−(r/R)²)"),
                ("h_c_over_R", "h_c/R"))
    knobs = {
        "dt_fraction": Knob(("rungs.{r}.dt_fraction",), "set", "min", "dt / t_c"),
        "stiffness": Knob(("rungs.{r}.Y_factor",), "set", "max", "Y / Y_paper"),
        "size": Knob(("rungs.{r}.R_c", "rungs.{r}.fill_height"), "scale", "max", "factor on R_c and fill height"),
        "t_average": Knob(("rungs.{r}.t_discharge", "rungs.{r}.t_average"), "set", "max", "discharge time used, s"),
        "bin_width": Knob(("cg.w_fields",), "set", "min", "kernel width w, r_b"),
    }

    # -- configuration ---------------------------------------------------------------
    def check(self, scene: dict, source: str) -> None:
        f = scene["particles"]["radius_fractions"]
        require(list(f) == sorted(f) and len(set(f)) == len(f),
               f"{source}: particles.radius_fractions = {f}: allowed only strictly increasing (type 1 is the smallest)")
        require(set(scene["effects"]["walls"]) == {"side", "floor"},
               f"{source}: effects.walls = {scene['effects']['walls']}: allowed [side, floor] (the silo needs both)")
        require(not scene["effects"]["reinsert"] or scene["effects"]["deletion"],
               f"{source}: effects.reinsert = true needs effects.deletion = true: allowed reinsert only with deletion")
        # each ran at smoke (R = 3.5 r_b) and ended 'clogged' with outflow 0, an arch named that is not there
        require(scene["effects"]["deletion"],
                f"{source}: effects.deletion = false is not allowed: the outflow is measured as the mass deleted "
                f"below the orifice, so without deletion it reads 0 and every run ends 'clogged' (an arch "
                f"blocking the orifice) whatever flows: allowed true")
        require(scene["effects"]["gravity"],
                f"{source}: effects.gravity = false is not allowed: the silo drains under gravity alone; "
                f"without it the bed does not settle, nothing leaves through the orifice and the run ends "
                f"'clogged' with outflow 0 (re-insertion's downward push aside): allowed true")

    def check_case(self, scene: dict, rung: str, case: dict, source: str) -> None:
        """The orifice must fit the rung's silo."""
        R_c, R = scene["rungs"][rung]["R_c"], case["R"]
        require(R <= R_c - 2, f"{source}: scenes.silo.sweep.R = {R} (in r_b) does not fit the {rung} silo of "
                             f"R_c = {R_c} r_b: allowed 1 <= R <= R_c - 2 = {R_c - 2}")

    # -- decks and runs --------------------------------------------------------------
    def parameters(self, scene: dict, rung: str, case: dict | None = None):
        return silo_parameters(scene, rung, case)

    def particle_count(self, scene: dict, rung: str, case: dict | None = None) -> int:
        """The gas (a formula: :func:`gas_count`, the lattice is not built) and the frozen rim ring."""
        case = dict(scene["case"], **(case or {}))
        rim = rim_ring(case["R"] * scene["particles"]["r_b"], species(scene)[0]["radius"])
        return gas_count(scene, scene["rungs"][rung]) + rim["n"]

    def describe(self, record: dict) -> str:
        return f"R = {record['R_over_rb']:g} r_b, R_c = {record['R_c']:g} m, {record['n_particles']} particles"

    def workload(self, record: dict):
        """The default (settling up to ``n_settle``, then the discharge segments) with the frozen
        rim ring's atoms added; the count is the fill's, an upper bound: without re-insertion it
        falls as the silo empties. The deck splits x and y only (``processors * * 1``): at most
        one rank per two largest diameters across, in each."""
        base = super().workload(record)
        n = int(record["n_particles"]) + int(record["rim"]["n"])
        per_side = max(1, int((2 * record["R_c"]) // (4 * record["r_b"])))
        stages = {k: dataclasses.replace(s, atom_steps=float(n) * s.steps) for k, s in base.stages.items()}
        return dataclasses.replace(base, particles=n, stages=stages, max_ranks=per_side ** 2,
                                   note="" if record["reinsert"] else "fill count: falls as the silo empties")

    def after_segment(self, segment_thermo, record):
        """``clogged`` or ``completed`` (emptied) after a discharge segment: see :func:`discharge_verdict`."""
        return discharge_verdict(segment_thermo, record)

    # -- analysis --------------------------------------------------------------------
    def analyse_threads(self, cores: int) -> int:
        return cores

    def analyse(self, case_dir: Path):
        from granflow.case import case_inputs

        from .pipeline import silo_analysis

        case_dir, record, status = case_inputs(case_dir)
        if status["dumps"] and status["status"] in ("completed", "clogged"):
            tables, scalars = silo_analysis(case_dir)
            verdict = "steady" if "W_f" in scalars else "unsteady"
        else:
            tables, scalars, verdict = {}, {}, status["status"]
        names = list(TABLES) + [f"kinetic_w{w:g}" for w in record["cg"]["w_scan"]]
        tables = {name: tables.get(name, pd.DataFrame()) for name in names}
        k = record["rung_knobs"]
        run_status = status["status"]
        scalars.update({
            "rung": record["rung"], "R": record["R"], "R_over_rb": record["R_over_rb"], "R_c": record["R_c"],
            "r_b": record["r_b"], "radii": [s["radius"] for s in record["species"]], "density": record["density"],
            "gravity": record["gravity"], "reinsert": record["reinsert"], "Y": record["Y"], "k_n": record["k_n"],
            "t_c_min": record["parameters"]["t_c_min"], "dt": record["dt"], "n_particles": record["n_particles"],
            "status": verdict if run_status == "completed" else run_status,
            "status_reason": scalars.get("steady_reason") if run_status == "completed" else status.get("reason"),
            "run_reason": status.get("reason"),
            "max_overlap": status.get("max_overlap"), "dangerous_builds": status.get("dangerous_builds"),
            "matom_step_per_s": status.get("matom_step_per_s"), "loop_seconds": status.get("loop_seconds"),
            "label": f"R = {record['R_over_rb']:g} r_b",
            "provenance": (f"rung {record['rung']} · R_c={k['R_c']:g} r_b · Y={record['Y']:.3g} Pa "
                           f"(k_n={record['k_n']:.3g} N/m) · t_c={record['parameters']['t_c_min']:.2g} s · "
                           f"N={record['n_particles']} · {'re-insertion' if record['reinsert'] else 'no re-insertion'} · "
                           f"{verdict if run_status == 'completed' else run_status}"),
        })
        return tables, scalars

    def table(self, rows):
        """One row per orifice radius, with the Beverloo fit over the steady ones on every row."""
        from .analysis import beverloo_fit, mean_diameter

        table = pd.DataFrame(rows).sort_values("R")
        for col in ("W_f", "W_f_se", "rho_bulk"):
            if col not in table:
                table[col] = np.nan
        ok = table[np.isfinite(table["W_f"]) & (table["status"] == "steady")]
        fit = {"beverloo_n": len(ok)}
        if len(ok) >= 3:
            try:
                res = beverloo_fit(2 * ok["R"], ok["W_f"], ok["W_f_se"], rho_b=float(ok["rho_bulk"].mean()),
                                   g=float(ok["gravity"].iloc[0]), d=mean_diameter(ok["radii"].iloc[0]))
                fit.update({f"beverloo_{k}": v for k, v in res.items() if np.isscalar(v)})
            except ValueError as exc:
                fit["beverloo_note"] = str(exc)
        else:
            fit["beverloo_note"] = f"{len(ok)} steady orifice sizes: a Beverloo fit needs at least 3"
        for key, value in fit.items():
            table[key] = value
        return table.drop(columns=[c for c in ("radii",) if c in table])

    def figure_cases(self, cases):
        out = []
        for s, tables in cases:
            if tables["fields"].empty:  # no steady window: in the table with its status, not in the figures
                continue
            scan = {float(name.split("_w", 1)[1]) * s["r_b"]: t for name, t in tables.items()
                    if name.startswith("kinetic_w")}
            out.append({"label": s["label"], "provenance": s["provenance"], "scalars": s, "flow": tables["flow"],
                        "fields": tables["fields"], "contact": tables["contact"], "kinetic_scan": scan,
                        "orifice_plane": tables.get("orifice_plane")})
        return out

    # -- the validation record -------------------------------------------------------------
    def validation(self, scene_dir, cases):
        """Rubio-Largo et al. (2016) against the cases: :func:`granflow.scenes.silo.validation.validation`."""
        from .validation import validation

        return validation(Path(scene_dir), cases)

    def profile_checks(self, profiles):
        """Every check made from the record's profiles alone (:func:`~granflow.scenes.silo.profile_checks.profile_checks`:
        v_c² linear in R, the orifice collapse, the axis pressures, the sizes, the kernel width); the species'
        radii, which the profiles do not list, from ``config/scenes/silo.yaml``."""
        from granflow.scene_files import load_scene
        from granflow.schema import PROJECT_ROOT

        from .profile_checks import profile_checks

        scene = load_scene(PROJECT_ROOT / "config" / "scenes" / f"{self.name}.yaml")
        return profile_checks(profiles, radii=scene["particles"]["radius_fractions"])

    # -- the error-versus-cost study -------------------------------------------------------
    def observables(self, case_dir, record, t_average, block=None):
        """Over the discharge up to ``t_average`` after the opening, whose steady part the analysis finds
        (the returned window); ``block`` imposes a part of it."""
        from .pipeline import silo_observables

        obs, window = silo_observables(case_dir, record, t_max=t_average, steady=block)
        return dict(self.nan_observables(), **obs), window

    def paper_reference(self, scene: dict) -> dict:
        _, context = self.parameters(scene, "paper")
        rec = context["record"]
        return {"n_particles": int(rec["n_particles"]),
                "sim_time": float(scene["protocol"]["t_settle_max"] + rec["rung_knobs"]["t_discharge"]),
                "dt": rec["dt"], "dt_fraction": rec["dt"] / rec["parameters"]["t_c_min"],
                "how": "longest settling + t_discharge"}

    def cost_note(self, scene: dict, rung: str) -> str:
        r = scene["rungs"][rung]
        return (f"R_c = {r['R_c']:g} r_b, R = {scene['case']['R']:g} r_b, Y = {r['Y_factor']:g} Y_paper, "
                f"dt = {r['dt_fraction']:g} t_c")
