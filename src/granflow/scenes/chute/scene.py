"""The chute scene's declaration: sweep, checks, analysis glue, table, figures, headline, cost knobs."""
from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pandas as pd

from granflow.config import ConfigError
from granflow.registry import Deferred, FigureSpec, Knob, Scene, SnapshotView, SweepAxis, finite

from .parameters import chute_parameters

#: the module of the figures (imported when one is drawn: granflow.registry.Deferred)
_FIGURES = "granflow.scenes.chute.figures"


class ChuteScene(Scene):
    """The chute scene declaration (see the package docstring)."""

    name = "chute"
    #: seen from the side (-y): the flow goes left to right over the rough base; colour by speed
    time_unit = "√(d/g)"
    snapshot = SnapshotView(color="speed", view=(90.0, -90.0), center=(0.5, 0.5, 0.24), size=(500, 700), zoom=2.2)
    summary = "steady flow down a rough inclined plane: stress ratio tan(theta), weight, Bagnold profile, regimes"
    paper = "Silbert, Ertas, Grest, Halsey, Levine & Plimpton (2001), Phys. Rev. E 64, 051302"
    #: the plain ratio over tan θ holds only in steady flow: with the bed's acceleration the balance is the
    #: comparison, the plain ratio and the acceleration itself are readings of the run
    check_kinds = {"bulk -σ_xz/σ_zz / tan θ": "diagnostic",
                   "u_cm acceleration over the averaging window / (g sin θ)": "diagnostic"}
    sweep = (SweepAxis("theta_deg", "theta"),)
    figures = {  # captions: captions.yaml
        "fig_profiles": FigureSpec(Deferred(_FIGURES, "fig_profiles"), "Silbert et al. 2001, figs. 3-5 (velocity, packing, temperature profiles)"),
        "fig_stress": FigureSpec(Deferred(_FIGURES, "fig_stress"), "Silbert et al. 2001, section III (momentum balance)"),
        "fig_regimes": FigureSpec(Deferred(_FIGURES, "fig_regimes"), "Silbert et al. 2001, fig. 2 (flow regimes)"),
    }
    table_sort = ("theta",)
    # a bed that stopped will not start again: end the flow stage at once
    stop_statuses = ("arrested",)
    statuses = {
        "arrested": "the bed stopped: mean u_cm below protocol.arrest_speed over the last window (the paper's regime below theta_stop); not averaged",
        "accelerating": "u_cm still rising by more than steady_rel_tol per window with little scatter (the paper's regime above ~26 deg); not averaged",
    }
    headline = (
        # the ratio itself (about 1), not its error: the study compares relative differences
        ("stress_ratio_over_tan", "bulk -sigma_xz/sigma_zz / tan(theta)"),
        ("bagnold_A", "Bagnold amplitude A, sqrt(g/d)/d^(3/2)"),
        ("phi_bulk", "bulk volume fraction"),
    )
    knobs = {
        "dt_fraction": Knob(keys=("rungs.{r}.dt_fraction",), mode="set", finest="min", unit="dt / t_c"),
        "stiffness": Knob(keys=("rungs.{r}.k_n",), mode="set", finest="max", unit="k_n, m g/d"),
        "size": Knob(keys=("rungs.{r}.H", "rungs.{r}.Lx", "rungs.{r}.Ly"), mode="scale", finest="max",
                     unit="x rung size"),
        "t_average": Knob(keys=("rungs.{r}.t_average",), mode="set", finest="max", unit="sqrt(d/g)"),
        "bin_width": Knob(keys=("rungs.{r}.bin_width",), mode="set", finest="min", unit="d"),
    }

    # -- configuration ------------------------------------------------------------------
    def check(self, scene: dict, source: str) -> None:
        """Cross-field checks: segment lengths, bulk margins that leave a bulk, a base that exists."""
        for name, r in scene["rungs"].items():
            for key in ("t_segment", "dump_interval", "thermo_interval"):
                limit = "t_flow_max" if key == "t_segment" else "t_segment"
                if r[key] > r[limit]:
                    raise ConfigError(f"{source}: rungs.{name}.{key} = {r[key]}: allowed <= {limit} = {r[limit]}")
            if r["dump_interval"] > r["t_average"]:
                raise ConfigError(f"{source}: rungs.{name}.dump_interval = {r['dump_interval']}: "
                                  f"allowed <= t_average = {r['t_average']}")
            if 2 * r["bulk_margin"] + r["bin_width"] > r["H"]:
                raise ConfigError(f"{source}: rungs.{name}.bulk_margin = {r['bulk_margin']} leaves no bulk in a "
                                  f"bed of H = {r['H']}: allowed bulk_margin <= (H - bin_width)/2 = "
                                  f"{(r['H'] - r['bin_width']) / 2:g}")
        if "paper" in scene["rungs"] and scene["rungs"]["paper"]["k_n"] != 2.0e5:
            raise ConfigError(f"{source}: rungs.paper.k_n = {scene['rungs']['paper']['k_n']}: allowed 2e5 "
                              f"(the paper's stiffness)")

    def check_case(self, scene: dict, rung: str, case: dict, source: str) -> None:
        theta = self.case_values(scene, rung, case)["theta_deg"]
        if not 0.0 < float(theta) <= 60.0:
            raise ConfigError(f"{source}: theta_deg = {theta}: allowed 0 < theta_deg <= 60")

    # -- decks --------------------------------------------------------------------------
    def parameters(self, scene: dict, rung: str, case: dict | None = None):
        return chute_parameters(scene, rung, case)

    def describe(self, record: dict) -> str:
        p, r = record["parameters"], record["rung_knobs"]
        return (f"theta {p['theta_deg']:g} deg, {p['n_particles']} particles, {r['Lx']:g}x{r['Ly']:g}x{r['H']:g} d, "
                f"k_n {p['k_n']:.3g}, dt {record['dt']:.3g}")

    # -- running ------------------------------------------------------------------------
    def flow_verdict(self, steady, thermo: pd.DataFrame, record: dict):
        """``arrested`` for a bed that stopped, ``accelerating`` for one still speeding up.

        Arrested: the generic ``jammed``, or a mean :math:`u_{cm}` below
        ``protocol.arrest_speed`` over the last window (a creeping bed). Accelerating:
        no steady state because :math:`u_{cm}` keeps rising: over the last window
        (``protocol.steady_window``) the straight-line fit rises by more than
        ``protocol.steady_rel_tol`` of the mean, and the scatter about that line stays
        below ``protocol.steady_fluct_tol`` (a trend, not the noise of a small bed,
        which stays ``no_steady_state``).
        """
        proto = record["protocol"]
        if steady.status == "jammed" or (np.isfinite(steady.mean) and abs(steady.mean) < proto["arrest_speed"]
                                         and steady.status != "steady"):
            return dataclasses.replace(steady, status="arrested",
                                       reason=f"the bed stopped, the paper's arrested regime (below theta_stop(h), about 20 deg at H = 20-40 d): {steady.reason}")
        if steady.status != "no_steady_state" or len(thermo) < 3:
            return steady
        t, u = thermo["Time"].to_numpy(float), thermo["v_ucm"].to_numpy(float)
        last = t >= t[-1] - proto["steady_window"]
        t, u = t[last], u[last]
        if len(t) < 3 or not np.mean(u) > 0:
            return steady
        slope, intercept = np.polyfit(t, u, 1)
        rise = slope * (t[-1] - t[0]) / np.mean(u)
        scatter = np.std(u - (slope * t + intercept), ddof=2) / np.mean(u)
        if rise > proto["steady_rel_tol"] and scatter < proto["steady_fluct_tol"]:
            return dataclasses.replace(steady, status="accelerating",
                                       reason=f"u_cm still rising, the paper's accelerating regime (above about 26 deg at H = 20-40 d): "
                                              f"+{rise:.1%} of its mean over the last "
                                              f"{t[-1] - t[0]:.4g} time units, scatter about the trend {scatter:.1%}")
        return steady

    # -- analysis -----------------------------------------------------------------------
    def analyse(self, case_dir: Path):
        from .analysis import analyse_case

        return analyse_case(case_dir)

    def table(self, rows):
        """One row per angle, and on every row the flowing range the sweep brackets.

        ``theta_arrested_max`` is the largest angle that stopped, ``theta_steady_min``
        and ``theta_steady_max`` the extremes of the steady ones, ``theta_accelerating_min``
        the smallest that kept speeding up (NaN where the sweep has none); the paper's
        steady range for h ~ 20-40 d is about 20-26 degrees.
        """
        table = pd.DataFrame(rows)
        if table.empty:
            return table
        table = table.sort_values("theta")

        def extreme(status, how):
            values = table.loc[table["status"] == status, "theta"]
            return float(how(values)) if len(values) else float("nan")

        table["theta_arrested_max"] = extreme("arrested", max)
        table["theta_steady_min"] = extreme("steady", min)
        table["theta_steady_max"] = extreme("steady", max)
        table["theta_accelerating_min"] = extreme("accelerating", min)
        return table

    def figure_cases(self, cases):
        out = []
        for scalars, tables in cases:
            out.append({"scalars": scalars, "profile": tables.get("profile")})
        return sorted(out, key=lambda c: c["scalars"].get("theta", 0.0))

    # -- the error-versus-cost study ----------------------------------------------------
    def observables(self, case_dir: Path, record: dict, t_average: float, block=None):
        """Headline numbers over the first ``t_average`` of the averaging stage (or ``block`` of it)."""
        import json

        from .analysis import case_profile, profile_checks

        window = block or (0.0, t_average)
        case_dir = Path(case_dir)
        status = json.loads((case_dir / "run" / "status.json").read_text())
        got = case_profile(case_dir, record, status, window)
        if got is None:
            return self.nan_observables(), window
        checks = profile_checks(got[0], float(record["parameters"]["theta_deg"]),
                                float(record["parameters"]["base_height"]),
                                record["rung_knobs"]["bulk_margin"])
        checks["stress_ratio_over_tan"] = checks["stress_ratio_error"] + 1.0
        return {key: finite(checks.get(key)) for key, _ in self.headline}, window

    # -- the validation record ----------------------------------------------------------
    def validation(self, scene_dir: Path, cases: dict[str, Path]):
        """Checks against Silbert et al. (2001): :func:`granflow.scenes.chute.validation.validation`."""
        from .validation import validation

        return validation(scene_dir, cases)

    def paper_reference(self, scene: dict) -> dict:
        params, context = chute_parameters(scene, "paper")
        rec = context["record"]
        t_c = rec["parameters"]["t_c_min"]
        sim_time = scene["rungs"]["paper"]["t_flow_max"] + scene["rungs"]["paper"]["t_average"]
        return {"n_particles": rec["parameters"]["n_particles"], "sim_time": sim_time, "dt": rec["dt"],
                "dt_fraction": rec["dt"] / t_c,
                "how": "paper rung: Lx x Ly x H with phi_fill, flow t_flow_max then average t_average at dt"}

    def cost_note(self, scene: dict, rung: str) -> str:
        r = scene["rungs"][rung]
        return (f"chute rung {rung}: {r['Lx']:g}x{r['Ly']:g}x{r['H']:g} d, k_n {r['k_n']:.3g}, "
                f"theta {scene['case']['theta_deg']:g} deg")
