"""The error-versus-cost study: one fidelity knob at a time around a base case.

The campaign file's ``cost`` section names, per scene, a base rung, changes to
it (``set``: dotted keys of the scene file) and the values of each knob. This
module turns that into the list of *runs* (LAMMPS simulations) and *points*
(one analysed setting each) of ``workflows/rules/cost.smk``:

* simulation knobs (``dt_fraction``, ``stiffness``, ``size``) each need their own
  run, rendered from the base scene with that one value changed;
* post-processing knobs (``t_average``, ``bin_width``) reuse the base run: the base
  run averages for the longest ``t_average`` of the list, and a shorter setting
  analyses the first part of that window (its cost is the part of the run it needs);
  a bin or kernel width re-analyses the same frames.

Every knob's list contains the base value, so the base point is shared by all
knobs. Every variant scene is validated like the scene file itself before
anything runs.
"""
from __future__ import annotations

import copy
import math
from pathlib import Path

from .config import ConfigError
from .declarations import Knob
from .registry import Scene, names, refusal, refused, scenes
from .resources import check_size
from .scene_files import load_scene, validate_scene

KNOBS = ("dt_fraction", "stiffness", "size", "t_average", "bin_width")
POST_KNOBS = ("t_average", "bin_width")

def fmt(value: float) -> str:
    """Directory-name form of a knob value: 0.05 -> '0.05', 1e-05 -> '1e-05'."""
    return f"{float(value):g}"


def _get(tree: dict, dotted: str):
    node = tree
    for part in dotted.split("."):
        node = node[part]
    return node


def _put(tree: dict, dotted: str, value) -> None:
    parts = dotted.split(".")
    node = tree
    for part in parts[:-1]:
        if not isinstance(node.get(part), dict):
            raise ConfigError(f"cost: {'.'.join(parts[:-1])} is not a mapping of the scene file")
        node = node[part]
    node[parts[-1]] = value


def apply_set(scene: dict, study: dict, source: str) -> dict:
    """The scene file with the study's ``set`` changes applied, not yet validated (:func:`base_scene`).

    The base run averages for the longest ``t_average`` of the knob list. The study writes no
    particle snapshots (effect ``snapshots``): its runs are timed, and images are not read.
    """
    out = copy.deepcopy(scene)
    out["effects"]["snapshots"] = []
    rung = study["base_rung"]
    if rung not in out["rungs"]:
        raise ConfigError(f"{source}.base_rung = {rung!r} is not allowed: allowed one of "
                          f"{', '.join(out['rungs'])}")
    for key, value in (study.get("set") or {}).items():
        try:
            _get(out, key)
        except (KeyError, TypeError):
            raise ConfigError(f"{source}.set.{key} = {value!r} is not allowed: {key!r} is not a key of the "
                              f"{scene['scene']} scene file") from None
        _put(out, key, value)
    return out


def base_scene(scene: dict, study: dict, source: str) -> dict:
    """The scene file with the study's ``set`` changes applied (:func:`apply_set`), validated like the file."""
    return validate_scene(apply_set(scene, study, source), source=f"{source}.set")


def knob_base_value(knob: Knob, scene: dict, rung: str) -> float:
    """The base case's value of the knob declared as ``knob`` (1 for a size factor)."""
    return 1.0 if knob.mode == "scale" else float(_get(scene, knob.keys[0].format(r=rung)))


def with_knob(knob: Knob, scene: dict, rung: str, value: float) -> dict:
    """A copy of the base scene with the knob declared as ``knob`` at ``value``."""
    out = copy.deepcopy(scene)
    for key in knob.keys:
        key = key.format(r=rung)
        new = float(value) * _get(scene, key) if knob.mode == "scale" else float(value)
        _put(out, key, new)
    return out


def apply_knob(scene_name: str, scene: dict, rung: str, knob: str, value: float) -> dict:
    """A copy of the base scene of the registered scene ``scene_name`` with one knob at ``value``."""
    return with_knob(scenes()[scene_name].knobs[knob], scene, rung, value)


class CostStudy:
    """Runs and points of one scene's study.

    Its scenes (the base, each post-processing knob's setting, each run) are built one at a time,
    each validated like the scene file before the next is built (:meth:`_build`).

    Parameters
    ----------
    scene_name : str
    scene : dict
        The validated scene file.
    study : dict
        The campaign's ``cost.scenes.<scene>`` entry.
    declared : Scene, optional
        The scene's declaration (its knobs), as :func:`cost_studies` resolved it; the registry's if not given.
    """

    def __init__(self, scene_name: str, scene: dict, study: dict, source: str = "cost",
                 declared: Scene | None = None):
        self.name = scene_name
        self.source = f"{source}.scenes.{scene_name}"
        self.rung = study["base_rung"]
        self.study = study
        for built, where in self._build(scene, declared):
            validate_scene(built, source=where)

    def _build(self, scene: dict, declared: Scene | None):
        """Build the study's scenes, yielding each as it is built with the source its refusals name: the
        base (the scene file after ``set``), each setting of a post-processing knob, then each run of a
        simulation knob. The caller validates each before this goes on, so the knobs' base values are
        read from a base that is known to be valid."""
        self.base = apply_set(scene, self.study, self.source)
        yield self.base, f"{self.source}.set"
        self.knobs = {k: [float(v) for v in vals] for k, vals in self.study["knobs"].items() if vals}
        self.declared = scenes()[self.name] if declared is None else declared
        known = self.declared.knobs
        for knob in self.knobs:
            if knob not in known:
                raise ConfigError(f"{self.source}.knobs.{knob} is not allowed: the {self.name} scene has the knobs "
                                  f"{', '.join(known)}")
        self.base_values = {k: knob_base_value(known[k], self.base, self.rung) for k in self.knobs}
        for knob, values in self.knobs.items():
            b = self.base_values[knob]
            if not any(math.isclose(v, b, rel_tol=1e-9) for v in values):
                raise ConfigError(f"{self.source}.knobs.{knob} = {values} is not allowed: the list must contain the "
                                  f"base case's value {b:g} (from rung {self.rung} after {self.source}.set)")
        for knob in POST_KNOBS:  # analysis settings: each value within the bounds of the scene key it sets
            for v in self.knobs.get(knob, []):
                yield with_knob(known[knob], self.base, self.rung, v), f"{self.source}.knobs.{knob} (value {v:g})"
        if "t_average" in self.knobs:
            longest = max(self.knobs["t_average"])
            self.base_run_scene = with_knob(known["t_average"], self.base, self.rung, longest)
        else:
            self.base_run_scene = self.base
        self.scenes = {"base": self.base_run_scene}
        for knob, values in self.knobs.items():
            if knob in POST_KNOBS:
                continue
            for v in values:
                if self.is_base(knob, v):
                    continue
                variant = with_knob(known[knob], self.base_run_scene, self.rung, v)
                self.scenes[self.run_name(knob, v)] = variant
                yield variant, f"{self.source}.knobs.{knob} (value {v:g})"

    # ------------------------------------------------------------------ names
    def is_base(self, knob: str, value: float) -> bool:
        return math.isclose(float(value), self.base_values[knob], rel_tol=1e-9)

    @staticmethod
    def run_name(knob: str, value: float) -> str:
        return f"{knob}~{fmt(value)}"

    def runs(self) -> list[str]:
        """LAMMPS runs: ``base`` and one per non-base value of a simulation knob."""
        return list(self.scenes)

    def points(self) -> list[str]:
        """Analysed settings: ``base`` and one per non-base value of every knob."""
        out = ["base"]
        for knob, values in self.knobs.items():
            out += [self.run_name(knob, v) for v in values if not self.is_base(knob, v)]
        return out

    def point(self, name: str) -> dict:
        """What a point is: its knob and value, the run it analyses and the analysis settings."""
        if name == "base":
            knob, value = None, None
        else:
            knob, raw = name.split("~", 1)
            value = float(raw)
        run = name if knob is not None and knob not in POST_KNOBS else "base"
        t_average = self.base_values.get("t_average", None)
        if t_average is None:
            t_average = float(_get(self.base, f"rungs.{self.rung}.t_average"))
        if knob == "t_average":
            t_average = value
        post = {}
        if knob == "bin_width":
            keys = self.declared.knobs["bin_width"].keys
            post = {k.format(r=self.rung): value for k in keys}
        return {"name": name, "knob": knob, "value": value, "run": run, "t_average": t_average, "post": post}

    def finest(self, knob: str) -> str:
        return self.declared.knobs[knob].finest

    def unit(self, knob: str) -> str:
        return self.declared.knobs[knob].unit


def post_record(record: dict, post: dict) -> dict:
    """A parameter record with the post-processing settings of a point (bin or kernel widths).

    ``post`` maps the scene keys (``rungs.<r>.bin_width``, ``cg.w_fields``) to values;
    the record keeps rung values under ``rung_knobs`` and the silo's ``cg`` at the top.
    """
    out = copy.deepcopy(record)
    for key, value in post.items():
        parts = key.split(".")
        if parts[0] == "rungs":
            out["rung_knobs"][parts[2]] = value
        else:
            _put(out, key, value)
    return out


def cost_studies(data: dict, root: Path, source: str) -> dict:
    """Every scene study of the ``cost`` section, its variant scenes validated and preflighted."""
    from .preflight import PreflightError

    studies = {}
    for name, study in (data["cost"].get("scenes") or {}).items():
        if name not in names() and name not in refused():
            raise ConfigError(f"{source}: cost.scenes.{name} is not allowed: allowed one of "
                              f"{', '.join(map(repr, names()))} (the registered scenes)")
        if not study.get("enabled", True):
            continue
        if name in refused():
            raise refusal(name, f"{source}: cost.scenes.{name} is enabled, but the scene is refused: "
                                f"{refused()[name]}")
        declared = scenes()[name]  # registered, not refused: its declaration, for the study and its preflight
        if not declared.gives("cost_study"):
            raise ConfigError(f"{source}: cost.scenes.{name} is not allowed: the {name} scene declares no cost "
                              f"study (it needs knobs, headline and observables(); granflow.registry.OPTIONAL): "
                              f"allowed no cost.scenes.{name} entry, or enabled: false")
        sc = data.get("scenes", {}).get(name) or {}
        scene_path = Path(sc.get("scene_file") or f"config/scenes/{name}.yaml")
        scene = sc.get("scene") or load_scene(scene_path if scene_path.is_absolute() else root / scene_path)
        cs = CostStudy(name, scene, study, source=f"{source}: cost", declared=declared)
        for run, variant in cs.scenes.items():
            check_size(name, variant, cs.rung, None, data, source,
                       f"cost.scenes.{name} run {run!r} (rung {cs.rung})")
            try:
                declared.parameters(variant, cs.rung)  # preflight: time step, feasibility
            except (PreflightError, ValueError) as exc:
                raise ConfigError(f"{source}: cost.scenes.{name} run {run!r} is not allowed: {exc}") from None
        studies[name] = cs
    return studies


__all__ = ["KNOBS", "POST_KNOBS", "CostStudy", "cost_studies", "apply_knob", "base_scene",
           "post_record", "fmt"]


# ------------------------------------------------------------------------- cost records
def segment_costs(run_dir) -> list[dict]:
    """Loop time, steps and atom-steps of every segment of a run, from its LAMMPS logs (in run order),
    with the CPU-seconds and peak memory the runner measured for it (NaN if not recorded)."""
    import json
    from pathlib import Path

    from .runner import loop_totals  # deferred: the runner is needed only to read finished runs

    logs = sorted(Path(run_dir, "logs").glob("*.log"))
    order = {"init": 0, "flow": 1, "average": 2}
    logs.sort(key=lambda p: (order.get(p.stem.split("_")[0], 3), p.stem))
    out = []
    for path in logs:
        text = path.read_text(errors="replace")
        seconds, steps, atom_steps = loop_totals(text)
        usage = path.with_suffix(".usage.json")
        u = json.loads(usage.read_text()) if usage.exists() else {}
        out.append({"segment": path.stem, "loop_s": seconds, "steps": steps, "atom_steps": atom_steps,
                    "cpu_s": u.get("cpu_s", float("nan")), "peak_rss_mb": u.get("peak_rss_mb", float("nan"))})
    return out


def prefix_segments(segments: list[dict], t_average: float, t_segment: float) -> list[dict]:
    """The segments a run needs for ``t_average`` of averaging: all set-up and flow
    segments and the first ceil(t_average / t_segment) averaging segments."""
    n_avg = max(1, math.ceil(t_average / t_segment - 1e-6))
    out = []
    for seg in segments:
        if seg["segment"].startswith("average_") and int(seg["segment"].split("_")[1]) > n_avg:
            continue
        out.append(seg)
    return out


def paper_reference(scene_name: str, scene: dict) -> dict | None:
    """Particle count and simulated time of the paper rung for the study's case (for the extrapolation);
    None for a scene that declares no :meth:`~granflow.registry.Scene.paper_reference` (no extrapolation)."""
    declared = scenes()[scene_name]
    return declared.paper_reference(scene) if declared.gives("paper_reference") else None


def paper_time_step(knob: str | None, value: float | None, dt_run: float, base_dt_fraction: float,
                    paper: dict) -> float:
    """The time step a paper-size run would take with one knob at ``value``.

    The paper rung's own step, except for the knob's own setting: a time-step fraction
    ``value`` of the paper's contact time, or the paper's fraction of this run's
    (softer or stiffer) contact time.
    """
    if knob == "dt_fraction":
        return paper["dt"] * value / paper["dt_fraction"]
    if knob == "stiffness":
        return dt_run * paper["dt_fraction"] / base_dt_fraction
    return paper["dt"]
