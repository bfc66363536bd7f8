"""The campaign file, loaded in one pass: read, its own keys, its scenes, their limits, its cost study.

:func:`load_campaign` reads the file and its overrides (:mod:`granflow.config`), then
:func:`validate_campaign` checks what was read phase by phase, each in its own module: the
campaign's own keys (:mod:`granflow.schema`), each scene resolved and checked with its sweeps
(:mod:`granflow.scene_files`), the sweep points' size and CPU-hour limits (:mod:`granflow.resources`,
where cases are priced), then the cost study (:mod:`granflow.cost`, whose runs meet the same
limits one by one). It runs before any Snakemake rule;
every refusal is a :class:`granflow.config.ConfigError` naming the key, the value and the allowed range.
"""
from __future__ import annotations

from pathlib import Path
from typing import Iterable

from .config import apply_overrides, load_yaml
from .cost import cost_studies
from .resources import check_campaign_limits
from .scene_files import check_scenes
from .schema import check_campaign_keys


def validate_campaign(data: dict, root: Path, source: str = "config") -> dict:
    """Validate a campaign dict (e.g. Snakemake's ``config``): its keys, scenes, sweeps, limits and cost study.

    Scene file paths are relative to ``root``. Returns a copy with each enabled
    scene's validated content under ``scenes.<name>.scene`` and, with a ``cost``
    section, the studies under ``cost_studies``.
    """
    data = check_campaign_keys(data, root, source)
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
    under ``scenes.<name>.scene``.
    """
    data = apply_overrides(load_yaml(path), overrides)
    root = Path(root) if root else Path.cwd()
    return validate_campaign(data, root, source=str(path))
