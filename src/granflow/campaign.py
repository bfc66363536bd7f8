"""The campaign file: its scenes (each checked by its registered scene) and its cost study.

:func:`validate_campaign` runs before any Snakemake rule; every refusal is a
:class:`granflow.config.ConfigError` naming the key, the value and the allowed range.
"""
from __future__ import annotations

from pathlib import Path
from typing import Iterable

from .config import apply_overrides, load_yaml
from .scene_files import validate_campaign_scenes
from .cost import cost_studies


def validate_campaign(data: dict, root: Path, source: str = "config") -> dict:
    """Validate a campaign dict (e.g. Snakemake's ``config``): scenes, sweeps and the cost study.

    Scene file paths are relative to ``root``. Returns a copy with each enabled
    scene's validated content under ``scenes.<name>.scene`` and, with a ``cost``
    section, the studies under ``cost_studies``.
    """
    data = validate_campaign_scenes(data, root, source)
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
