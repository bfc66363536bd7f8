"""Targets named on the Snakemake command line get the campaign file's validation.

``snakemake results/channel/demo/W~999/phi~0.99/run/status.json`` names a case by
its path; the rules' wildcards would accept it and build a case that no campaign
file described and no check saw. :func:`check_targets` refuses every target path
under the results directory whose scene, rung or case is not one of the campaign's,
naming the allowed values; the campaign's own sweep is the one place cases come
from (change it with ``--config``/``--set`` or the file, and it is validated).
"""
from __future__ import annotations

import os
from pathlib import Path
from typing import Iterable

from .config import ConfigError


def cli_targets(argv: list[str]) -> list[str]:
    """The files named on a ``snakemake`` command line: its targets and the arguments of the
    options that name targets too (``--forcerun``, ``--until``, ``--prioritize``...)."""
    from snakemake.cli import get_argument_parser

    try:
        args, _ = get_argument_parser().parse_known_args(argv)
    except SystemExit:  # Snakemake reports its own usage errors
        return []
    out = list(getattr(args, "targets", None) or [])
    for option in ("forcerun", "until", "prioritize", "omit_from"):
        out += list(getattr(args, option, None) or [])
    return [str(t) for t in out]


def _relative(target: str, workdir: Path) -> str:
    path = Path(os.path.normpath(target))
    if path.is_absolute():
        try:
            path = path.relative_to(workdir.resolve())
        except ValueError:
            return ""
    return path.as_posix()


def _listing(values: Iterable[str], most: int = 12) -> str:
    values = list(values)
    shown = ", ".join(values[:most])
    return shown + (f" (and {len(values) - most} more)" if len(values) > most else "") if values else "none"


def check_targets(targets: Iterable[str], results: str, rung: str, cases: dict[str, list[str]],
                  registered: Iterable[str], cost: dict[str, tuple[list[str], list[str]]] | None = None,
                  workdir: str | Path = ".", ladders: dict[str, dict[str, tuple[str, list[str]]]] | None = None) -> None:
    """Refuse a target under ``results`` that is not part of the campaign.

    ``cases`` maps each enabled scene to its case directories (``W~20/phi~0.6``);
    ``registered`` are all scene names; ``cost`` maps each scene of the cost study to
    its ``(runs, points)``; ``ladders`` each scene with a ladder to its rungs run, each ``(its scene rung,
    its cases)``: a target under ``<results>/ladders/`` names one of them. A target outside ``results``, or a rule
    name, passes.
    """
    root = Path(os.path.normpath(results)).as_posix()
    registered = set(registered)
    cost = cost or {}
    for target in targets:
        rel = _relative(target, Path(workdir))
        if not rel.startswith(root + "/"):
            continue
        parts = rel[len(root) + 1:].split("/")
        head = parts[0]
        if head == "cost" and len(parts) >= 3:
            _check_cost(target, parts, cost)
        elif head == "ladders" and len(parts) >= 2:
            _check_ladder(target, parts[1:], ladders or {})
        elif head in registered:
            _check_case(target, parts, rung, cases)


def _check_case(target: str, parts: list[str], rung: str, cases: dict[str, list[str]]) -> None:
    scene = parts[0]
    if scene not in cases:
        raise ConfigError(f"target {target}: scene {scene} is not enabled in this campaign: allowed "
                          f"{_listing(sorted(cases))} (enable it with --config or in the campaign file)")
    if len(parts) < 2:
        return
    if parts[1] != rung:
        raise ConfigError(f"target {target}: rung {parts[1]} is not this campaign's: allowed {rung} "
                          f"(run another rung with --config rung={parts[1]})")
    named = [p for p in parts[2:] if "~" in p]
    if not named:
        return
    case = "/".join(parts[2:2 + len(named)])
    if case not in cases[scene]:
        raise ConfigError(f"target {target}: case {case} is not one of the campaign's {scene} cases at rung "
                          f"{rung}: allowed {_listing(cases[scene])} (add it to scenes.{scene}.sweep, where it "
                          f"is validated)")


def _check_ladder(target: str, parts: list[str], ladders: dict[str, dict[str, tuple[str, list[str]]]]) -> None:
    """``<results>/ladders/<scene>/<rung>/<scene>/<scene rung>/<case...>``: each part one of the ladder's."""
    scene = parts[0]
    if scene not in ladders:
        raise ConfigError(f"target {target}: scene {scene} has no ladder: allowed {_listing(sorted(ladders))} "
                          f"(config/ladders/<scene>.yaml)")
    if len(parts) < 2 or parts[1] in ("benchmarks", "logs"):
        return
    if parts[1] not in ladders[scene]:
        raise ConfigError(f"target {target}: rung {parts[1]} is not one the {scene} ladder runs: allowed "
                          f"{_listing(ladders[scene])} (a planned rung runs once it is listed under rungs:)")
    level, cases = ladders[scene][parts[1]]
    if len(parts) >= 4 and (parts[2], parts[3]) != (scene, level):
        raise ConfigError(f"target {target}: allowed {scene}/{level} under the rung's folder")
    named = [p for p in parts[4:] if "~" in p]
    if named and "/".join(named) not in cases:
        raise ConfigError(f"target {target}: case {'/'.join(named)} is not one of the {scene} ladder's rung "
                          f"{parts[1]}: allowed {_listing(cases)}")


def _check_cost(target: str, parts: list[str], cost: dict[str, tuple[list[str], list[str]]]) -> None:
    scene = parts[1]
    if scene not in cost:
        raise ConfigError(f"target {target}: scene {scene} has no cost study in this campaign: allowed "
                          f"{_listing(sorted(cost))}")
    if len(parts) < 4 or parts[2] not in ("runs", "points"):
        return
    runs, points = cost[scene]
    allowed = runs if parts[2] == "runs" else points
    if parts[3] not in allowed:
        raise ConfigError(f"target {target}: cost-study {parts[2][:-1]} {parts[3]} is not one of the {scene} "
                          f"study's: allowed {_listing(allowed)}")


__all__ = ["check_targets", "cli_targets"]
