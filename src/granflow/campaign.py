"""The campaign file, loaded in one pass: read, its own keys, its scenes, their limits, its cost study.

:func:`load_campaign` runs the phases in order, each in its own module and each calling only
modules below it: it reads the file and its overrides (:mod:`granflow.config`), then checks the
campaign's own keys (:mod:`granflow.schema`) and its ``results_dir`` against the project root
(:func:`check_results_dir`), resolves and checks each scene with its sweeps
(:mod:`granflow.scene_files`), holds the sweep points to the size and CPU-hour limits
(:mod:`granflow.resources`, where cases are priced), then builds the cost study (:mod:`granflow.cost`,
whose runs meet the same limits one by one). :func:`validate_campaign` runs the same checking
phases on a campaign that was read elsewhere (Snakemake's ``config``). It runs before any Snakemake rule;
every refusal is a :class:`granflow.config.ConfigError` naming the key, the value and the allowed range.
"""
from __future__ import annotations

import os
from pathlib import Path
from typing import Iterable

from .config import ConfigError, apply_overrides, load_yaml
from .cost import cost_studies
from .resources import check_campaign_limits
from .scene_files import check_scenes
from .schema import check_campaign_keys


def validate_campaign(data: dict, root: Path, source: str = "config") -> dict:
    """Validate a campaign dict (e.g. Snakemake's ``config``): its keys, scenes, sweeps, limits and cost study.

    Scene file paths are relative to ``root``. Returns a copy with each enabled
    scene's validated content under ``scenes.<name>.scene`` and, with a ``cost``
    section, the studies under ``cost_studies``. The phases of :func:`load_campaign`, after its reading.
    """
    data = check_campaign_keys(data, source)
    check_results_dir(data.get("results_dir", "results"), root, source)
    points = check_scenes(data, root, source)
    check_campaign_limits(data, points, source)
    if data.get("cost"):
        data["cost_studies"] = cost_studies(data, root, source)
    return data


def load_campaign(path: str | Path, overrides: Iterable[str] = (), root: Path | None = None) -> dict:
    """Load, override and validate the campaign file and every enabled scene file.

    Scene files and a relative ``results_dir`` are found from ``root`` (default: the working
    directory, the project root for every command, as for Snakemake), never from where the
    file lies. Returns the campaign dict with each enabled scene's validated file content
    under ``scenes.<name>.scene``. The phases run here one after the other, as in
    :func:`validate_campaign`, each handing the campaign only to the modules below it.
    """
    source = str(path)
    data = apply_overrides(load_yaml(path), overrides)
    root = Path(root) if root else Path.cwd()
    data = check_campaign_keys(data, source)
    check_results_dir(data.get("results_dir", "results"), root, source)
    points = check_scenes(data, root, source)
    check_campaign_limits(data, points, source)
    if data.get("cost"):
        data["cost_studies"] = cost_studies(data, root, source)
    return data


def check_results_dir(value: str, root: Path, source: str = "config") -> None:
    """Refuse a relative ``results_dir`` that leads out of the project root ``root`` (``..``,
    ``../x``, ``a/../../b``); an absolute path is the way to write elsewhere. Judged on the
    path as written, so a ``results`` symlink to a scratch disk stays allowed. A ``results_dir``
    that is (or lies under) something other than a directory, e.g. a regular file, is refused too."""
    _check_results_is_a_directory(value, root, source)
    if Path(value).is_absolute():
        return
    norm = os.path.normpath(value)
    if norm == os.pardir or norm.startswith(os.pardir + os.sep):
        where = os.path.normpath(os.path.join(Path(root).absolute(), value))
        raise ConfigError(f"{source}: results_dir = {value!r} resolves to {where}, outside the project root "
                          f"{Path(root).absolute()}: allowed a relative path that stays inside the project; "
                          f"give an absolute path to write elsewhere")


def _check_results_is_a_directory(value: str, root: Path, source: str) -> None:
    """Refuse a ``results_dir`` whose nearest existing part (itself, or the parent it would be made
    in) is not a directory: the workflow could not make its case folders there."""
    where = Path(value) if Path(value).is_absolute() else Path(root).absolute() / value
    for part in (where, *where.parents):
        if part.exists():
            if not part.is_dir():
                kind = "a regular file" if part.is_file() else "not a directory"
                what = "" if part == where else f" (its part {part})"
                raise ConfigError(f"{source}: results_dir = {value!r}{what} is {kind}: allowed a directory, "
                                  f"or a path where one can be made")
            return
