"""A campaign of one scene: the overlay that disables every other scene of a campaign.

``granflow campaign --only SCENE --out FILE`` writes it. Snakemake merges a ``--configfile``
over ``config/config.yaml`` key by key, so the overlay holds only ``enabled`` keys: ``false`` for
every other scene (the campaign's and every registered one) and for their cost studies, ``true``
for SCENE. It is checked before it is written with the loader ``granflow check-config`` uses
(:func:`granflow.campaign.load_campaign`), the overlay given as the ``--set`` overrides it
amounts to; a refusal names the key, the value and what is allowed (exit 2), and nothing is
written. Run it with the target, if any, before ``--configfile`` (which takes every word after it
as one more config file)::

    granflow campaign --only chute --out /tmp/chute_only.yaml
    snakemake --cores 2 --configfile /tmp/chute_only.yaml
    snakemake results/chute/demo/table.csv --cores 2 --configfile /tmp/chute_only.yaml
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from . import registry
from .campaign import load_campaign
from .config import ConfigError, load_yaml

#: the first words of every overlay this module writes (an existing file that starts so may be replaced)
HEADER = "# A campaign of one scene, written by `granflow campaign"
#: the campaign file Snakemake reads first (the Snakefile's ``configfile:``), from the project root
DEFAULT_CAMPAIGN = Path("config/config.yaml")

DESCRIPTION = (
    "Write FILE, a campaign overlay that runs SCENE only: every other scene of the campaign (and every\n"
    "other registered scene) disabled, and their cost studies. Snakemake merges it over the campaign:\n\n"
    "  snakemake --cores 2 --configfile FILE\n"
    "  snakemake TARGET --cores 2 --configfile FILE     (the target first: --configfile takes every word\n"
    "                                                    after it as one more config file)\n\n"
    "The campaign with the overlay is checked before anything is written, as granflow check-config checks a\n"
    "campaign (every case of SCENE: schema, sizes, CPU-hours); a refusal names key, value and what is\n"
    "allowed (exit 2).")
EPILOG = (
    "examples:\n"
    "  granflow campaign --only chute --out /tmp/chute_only.yaml\n"
    "  granflow campaign --only silo --config config/validation.yaml --out /tmp/silo_validation.yaml\n\n"
    "With another --config than config/config.yaml, give both files to snakemake, the campaign first:\n"
    "  snakemake --cores 2 --configfile config/validation.yaml /tmp/silo_validation.yaml\n"
    "docs/campaign.md: a campaign of one scene, and the order of snakemake's arguments")


@dataclass(frozen=True)
class OneScene:
    """What :func:`write_overlay` wrote: the overlay's text and the campaign it makes."""

    only: str
    disabled: tuple[str, ...]
    rung: str
    cases: int
    text: str
    command: str


def check_only(name: str) -> None:
    """Refuse a SCENE that is not a registered scene (a refused package: with what it lacks)."""
    if name in registry.refused():
        raise registry.refusal(name, f"--only = {name!r}: the scene is refused: {registry.refused()[name]}")
    if name not in registry.names():
        raise ConfigError(f"--only = {name!r} is not allowed: allowed one of "
                          f"{', '.join(map(repr, registry.names()))} (the registered scenes, `granflow scenes`)")


def overlay(base: dict, only: str) -> dict:
    """The overlay of ``base`` (a campaign dict) that leaves ``only`` its one enabled scene.

    Every scene of ``base`` and every scene package found (registered or refused) other than
    ``only`` gets ``enabled: false``, so the overlay holds whichever campaign files Snakemake
    merges under it; so does every cost study of ``base`` but ``only``'s (a study's other keys
    are the campaign's: the overlay only switches it).
    """
    others = (set(base.get("scenes") or {}) | set(registry.names()) | set(registry.refused())) - {only}
    out = {"scenes": {only: {"enabled": True}, **{name: {"enabled": False} for name in sorted(others)}}}
    studies = sorted(set((base.get("cost") or {}).get("scenes") or {}) - {only})
    if studies:
        out["cost"] = {"scenes": {name: {"enabled": False} for name in studies}}
    return out


def as_overrides(data: dict, prefix: tuple[str, ...] = ()) -> list[str]:
    """The overlay as ``--set`` overrides (``scenes.heap.enabled=false``): what merging it does."""
    out = []
    for key, value in data.items():
        if isinstance(value, dict):
            out += as_overrides(value, (*prefix, key))
        else:
            out.append(".".join((*prefix, key)) + "=" + ("true" if value is True else "false"))
    return out


def snakemake_command(config: Path, out: Path, root: Path) -> str:
    """How Snakemake runs the overlay: over ``config/config.yaml`` alone, or over ``config`` too."""
    files = [str(out)]
    if Path(root, config).resolve() != Path(root, DEFAULT_CAMPAIGN).resolve():
        files.insert(0, str(config))
    return f"snakemake --cores 2 --configfile {' '.join(files)}"


def render(ov: dict, only: str, config: Path, command: str, summary: str) -> str:
    """The overlay's YAML text, every key commented, with the command that wrote it and the one that runs it."""
    lines = [f"{HEADER} --only {only} --config {config}`:",
             f"# {only} is its one enabled scene; every other scene{', and its cost study,' * ('cost' in ov)} is "
             f"disabled.",
             f"# Checked against {config} when written: {summary}.",
             "# Snakemake merges it over the campaign (a target goes before --configfile, which takes every",
             "# word after it as one more config file):",
             f"#   {command}",
             f"#   snakemake results/{only}/<rung>/table.csv --cores 2 --configfile {command.split('--configfile ')[1]}",
             "scenes:"]
    for name, entry in ov["scenes"].items():
        why = "on: the one scene of this campaign" if entry["enabled"] else f"off: this campaign runs {only} only"
        lines += [f"  {name}:", f"    enabled: {str(entry['enabled']).lower():5s}  # {why}"]
    if "cost" in ov:
        lines += ["cost:", "  scenes:"]
        for name in ov["cost"]["scenes"]:
            lines += [f"    {name}:", f"      enabled: false  # its cost study off: {only} only"]
    return "\n".join(lines) + "\n"


def check_out(out: str, config: Path, force: bool) -> Path:
    """Refuse an ``--out`` that is not a file path to write, or that would replace a file
    ``granflow campaign`` did not write (unless ``force``), or the campaign itself."""
    if not out.strip():
        raise ConfigError("--out '' is not allowed: allowed a file path (the overlay is written there)")
    path = Path(out)
    if path.is_dir():
        raise ConfigError(f"--out {out} is a directory: allowed a file path, e.g. {path / 'one_scene.yaml'}")
    if path.exists() and path.resolve() == config.resolve():
        raise ConfigError(f"--out {out} is the campaign file (--config): allowed another file (the overlay is "
                          f"merged over the campaign, never written into it)")
    if path.exists() and not force:
        with path.open(errors="replace") as fh:
            ours = fh.readline().startswith(HEADER)
        if not ours:
            raise ConfigError(f"--out {out} exists and was not written by granflow campaign: allowed a new file, "
                              f"or one granflow campaign wrote; pass --force to replace it")
    return path


def write_overlay(only: str, config: str | Path, out: str, root: Path, force: bool = False) -> OneScene:
    """Check the campaign ``config`` with ``only`` as its one scene, then write the overlay to ``out``.

    Parameters
    ----------
    only : str
        The scene to run, a registered scene.
    config : str or Path
        The campaign file the overlay goes over (``config/config.yaml`` for Snakemake's own).
    out : str
        The file to write (its folder is made if missing).
    root : Path
        The project root: scene files and a relative ``results_dir`` are found from there.
    force : bool
        Replace an existing file that ``granflow campaign`` did not write.

    Returns
    -------
    OneScene
        The overlay's text, its scene, the scenes it disables, the rung, the number of cases and
        the snakemake command that runs it.

    Raises
    ------
    ConfigError
        If ``only``, ``config``, ``out`` or the campaign with the overlay is refused (nothing is written).
    """
    check_only(only)
    config = Path(config)
    base = load_yaml(config)
    if "scene" in base:
        raise ConfigError(f"--config {config} is a scene file (scene = {base['scene']!r}): allowed a campaign file, "
                          f"e.g. {DEFAULT_CAMPAIGN}")
    path = check_out(out, config, force)
    ov = overlay(base, only)
    cfg = load_campaign(config, as_overrides(ov), root=root)
    entry = cfg["scenes"][only]
    cases = len(registry.get(only).sweep_points(entry["scene"], entry.get("sweep") or {}, cfg["rung"]))
    disabled = tuple(name for name, e in ov["scenes"].items() if not e["enabled"])
    summary = f"a valid campaign, rung {cfg['rung']}, scenes: {only} ({cases} case{'s' * (cases != 1)})"
    command = snakemake_command(config, path, root)
    text = render(ov, only, config, command, summary).replace("<rung>", cfg["rung"])
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text)
    return OneScene(only, disabled, cfg["rung"], cases, text, command)


__all__ = ["DESCRIPTION", "EPILOG", "OneScene", "overlay", "write_overlay"]
