"""Each scene file, and each scene of a campaign: resolved by the registry, checked by its schema and
by the scene's own checks, its rungs and its sweeps.

:func:`load_scene` reads, overrides and validates one scene file (:func:`validate_scene`);
:func:`check_scenes` does so for every enabled scene of a campaign, has its sweep checked against
the scene's schema (:func:`granflow.schema.check_sweep`) and each sweep point by its scene; the
points' sizes are the limits' (:mod:`granflow.resources`). :func:`check_scene_sweep`
checks one scene's sweep alone, sizes included, as a ladder's rung.
"""
from __future__ import annotations

from pathlib import Path
from typing import Iterable

from . import registry
from .config import apply_overrides
from .resources import check_campaign_cpu_hours, check_sweep_sizes
from .schema import check_sweep, load_schema, require, validate  # noqa: F401 (load_schema: the name stays here for the callers that patch it)
from .yamlio import ConfigError, load_yaml

RUNGS = ("smoke", "demo", "study", "paper", "validation")


def validate_scene(scene: dict, source: str = "scene", declared: registry.Scene | None = None,
                   schema: dict | None = None) -> dict:
    """Schema plus cross-field checks of a scene file; returns it unchanged. ``declared`` and
    ``schema``: the declaration and schema of a scene that is not registered (``granflow
    check-scene`` on a package by its path), else the registry's and ``config/schema``'s."""
    name = scene.get("scene")
    if declared is None:
        if name in registry.refused():
            raise registry.refusal(name, f"{source}: scene = {name!r}: {registry.refused()[name]}")
        if name not in registry.names():
            raise ConfigError(f"{source}: scene = {name!r} is not allowed: allowed one of "
                              f"{', '.join(map(repr, registry.names()))}")
        declared = registry.get(name)
    validate(scene, name, source, schema)
    declared.check(scene, source)
    for rname, r in scene["rungs"].items():
        require(r["dump_interval"] <= r["t_average"],
               f"{source}: rungs.{rname}.dump_interval = {r['dump_interval']}: allowed <= t_average = {r['t_average']}")
        require(r["thermo_interval"] <= r["t_segment"],
               f"{source}: rungs.{rname}.thermo_interval = {r['thermo_interval']}: allowed <= t_segment = {r['t_segment']}")
    return scene


def load_scene(path: str | Path, overrides: Iterable[str] = ()) -> dict:
    """Load, override and validate a scene file."""
    data = apply_overrides(load_yaml(path), overrides)
    return validate_scene(data, source=str(path))


def check_scenes(data: dict, root: Path, source: str = "config") -> dict[str, list[dict]]:
    """Resolve and check each scene of a campaign whose own keys are checked
    (:func:`granflow.schema.check_campaign_keys`).

    Scene file paths are relative to ``root``. Each enabled scene's file is loaded and validated
    (:func:`load_scene`) and put under ``scenes.<name>.scene`` of ``data``; every sweep point is
    checked by its scene (schema bounds of the swept key, then the scene's own feasibility checks).
    Returns the sweep points of each enabled scene, for the size limits
    (:func:`granflow.resources.check_campaign_limits`).
    """
    path = source
    points = {}
    for name, sc in data.get("scenes", {}).items():
        if name in registry.refused() and sc.get("enabled", True):  # a disabled one is not needed
            raise registry.refusal(name, f"{path}: scenes.{name} is enabled, but the scene is refused: "
                                         f"{registry.refused()[name]}")
        require(name in registry.names() or name in registry.refused(),
                f"{path}: scenes.{name} is not allowed: allowed one of "
                f"{', '.join(map(repr, registry.names()))} (the registered scenes)")
        if not sc.get("enabled", True):
            continue
        sweep = sc.get("sweep") or {}
        scene_path = Path(sc.get("scene_file") or f"config/scenes/{name}.yaml")
        if not scene_path.is_absolute():
            scene_path = root / scene_path
        scene = load_scene(scene_path)
        require(scene["scene"] == name, f"{path}: scenes.{name}.scene_file = {sc.get('scene_file')!r} describes "
                                       f"the {scene['scene']} scene: allowed a {name} scene file")
        rung = data["rung"]
        require(rung in scene["rungs"],
               f"{path}: rung = {rung!r} is not defined in {scene_path}: allowed {', '.join(scene['rungs'])}")
        declared = registry.get(name)
        check_sweep(name, sweep, declared.sweep, path)
        points[name] = list(declared.sweep_points(scene, sweep, rung))
        for point in points[name]:
            declared.check_case(scene, rung, point, path)
        sc["scene"] = scene
    return points


def check_scene_sweep(name: str, scene: dict, sweep: dict, rung: str, source: str, limits: dict | None = None) -> float:
    """A validated scene's sweep at ``rung`` checked as a campaign of that scene alone checks it (the rung
    defined, every point within the schema, feasible and within the size limits, all points together
    within ``max_cpu_hours`` of ``limits``); returns the points' CPU-hours. A ladder's rung
    (:mod:`granflow.ladder`) is checked so, its scene changed in memory."""
    require(rung in scene["rungs"], f"{source}: rung = {rung!r} is not defined: allowed {', '.join(scene['rungs'])}")
    declared = registry.get(name)
    check_sweep(name, sweep, declared.sweep, source)
    points = list(declared.sweep_points(scene, sweep, rung))
    for point in points:
        declared.check_case(scene, rung, point, source)
    estimates = {name: check_sweep_sizes(name, scene, rung, points, limits, source)}
    return check_campaign_cpu_hours(estimates, rung, limits, source)


def check_rung(scene: dict, rung: str, source: str = "--rung") -> dict:
    """Return the rung preset, or refuse an unknown rung name."""
    if rung not in scene["rungs"]:
        raise ConfigError(f"{source} = {rung!r} does not exist: allowed {', '.join(scene['rungs'])}")
    return scene["rungs"][rung]
