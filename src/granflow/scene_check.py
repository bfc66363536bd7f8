"""``granflow check-scene``: one scene package against the scene contract, one finding a line.

The contract is the registry's own (:func:`granflow.registry.check_package`, which discovery
runs on every package): each part of :data:`~granflow.registry.REQUIRED` the package lacks, each
of :data:`~granflow.registry.OPTIONAL` it does not give (a note: the campaign runs without it).
Then what discovery does not check: the schema is a JSON schema and the scene file meets it
(with the scene's own :meth:`~granflow.registry.Scene.check`), and the smoke rung renders its
decks (:func:`granflow.deck.render_case`, into a temporary folder; when the scene refuses the
file's case at smoke, the first rung that renders it).

A package is found by its name (``src/granflow/scenes/<name>`` of a project root) or by the
path of its folder; one that is not the running granflow's own is imported for the check alone
(:func:`granflow.registry.package_at`), its files looked for in the project's ``config/``.
"""
from __future__ import annotations

import contextlib
import importlib
import tempfile
from dataclasses import dataclass
from pathlib import Path

from . import registry
from .config import load_yaml
from .scene_files import check_rung, validate_scene
from .schema import Validator
from .deck import STAGES, render_case
from .yamlio import ConfigError

#: the rung whose decks are rendered (the others only when the scene refuses the file's case there)
SMOKE = "smoke"
#: the page that explains the contract and the two commands
DOCS_PAGE = "docs/adding-a-scene.md"


@dataclass(frozen=True)
class Finding:
    """One line of the check: ``kind`` is ``lacks`` (a required part missing), ``broken`` (a file or
    the smoke rung that fails), ``note`` (an optional part not given) or ``ok``."""

    kind: str
    text: str
    #: the rung an ``ok`` line rendered
    rung: str = ""

    @property
    def required(self) -> bool:
        """Whether it makes the package incomplete (exit 2)."""
        return self.kind in ("lacks", "broken")

    def line(self) -> str:
        return f"  {self.kind:7s} {self.text}"


def locate(target: str, root: Path | None) -> tuple[Path, Path]:
    """The package folder and the config folder of ``target``: a scene's name (the package
    ``<root>/src/granflow/scenes/<name>``, ``root`` default the working directory) or the path of a
    package folder (its project root is ``root``, else the one it lies in, else the working
    directory). Refuses a target that names no folder."""
    path = Path(target)
    if "/" not in target and target not in (".", ".."):
        base = Path.cwd() if root is None else root
        folder = base / "src" / "granflow" / "scenes" / target
        if not folder.is_dir():
            raise ConfigError(f"NAME = {target!r} is not allowed: {folder} is not a folder: allowed a scene's name "
                              f"(a package under {base / 'src/granflow/scenes'}) or the path of a package folder")
        return folder, base / "config"
    if not (path / "__init__.py").is_file():
        raise ConfigError(f"NAME = {target!r} is not allowed: {path} is not a package folder (no __init__.py): "
                          f"allowed a scene's name or the path of a package folder")
    if root is None:
        parts = path.resolve().parts
        inside = len(parts) >= 4 and parts[-4:-1] == ("src", "granflow", "scenes")
        root = path.resolve().parents[3] if inside else Path.cwd()
    return path, root / "config"


def is_own(folder: Path) -> bool:
    """Whether ``folder`` is a package of the running granflow's :mod:`granflow.scenes`."""
    here = Path(__file__).resolve().parent / "scenes"
    return folder.resolve().parent == here


def check_scene(folder: Path, config_dir: Path) -> list[Finding]:
    """Every finding of the scene package ``folder`` with its files in ``config_dir``, in order:
    what it lacks of REQUIRED, its schema and scene file, the smoke rung, the optional parts."""
    name = folder.name
    if not name.isidentifier():
        return [Finding("broken", f"package name {name!r}: not a Python identifier, so it cannot be imported")]
    importlib.invalidate_caches()  # a package written since this process started
    if is_own(folder):
        importing = contextlib.nullcontext(f"{registry.SCENES_PACKAGE}.{name}")
    else:
        importing = registry.package_at(folder)
    with importing as module:
        checked = registry.check_package(module, name, config_dir)
        if checked.import_error:
            return [Finding("broken", f"package: {checked.import_error}; nothing else is checked until it imports")]
        found = [Finding("lacks", lack) for lack in checked.lacks]
        if checked.scene is None:
            return found
        scene = _scene_file(checked.scene, name, config_dir, found)
        if scene is None or found:
            found.append(Finding("note", "decks: not rendered until the required parts are there"))
        else:
            found.extend(_render(checked.scene, scene))
        for hook, meaning in registry.OPTIONAL.items():
            if not checked.scene.gives(hook):
                found.append(Finding("note", f"gives no {hook}: {meaning}"))
    return found


def _scene_file(declared: registry.Scene, name: str, config_dir: Path, found: list[Finding]) -> dict | None:
    """The scene file checked against the schema (both files present: :func:`registry.missing` names
    an absent one) and the scene's own checks; its content, or None with a finding per problem."""
    schema_path = config_dir / "schema" / f"{name}.schema.yaml"
    scene_path = config_dir / "scenes" / f"{name}.yaml"
    if not (schema_path.is_file() and scene_path.is_file()):
        return None
    try:
        schema = load_yaml(schema_path)
        Validator.check_schema(schema)
    except Exception as exc:  # noqa: BLE001 - any fault of the file is a finding
        found.append(Finding("broken", f"schema {schema_path}: {_first_line(exc)}"))
        return None
    try:
        scene = load_yaml(scene_path)
        return validate_scene(scene, str(scene_path), declared=declared, schema=schema)
    except ConfigError as exc:
        found.extend(Finding("broken", f"scene file {line}") for line in str(exc).splitlines())
    except Exception as exc:  # noqa: BLE001 - e.g. a key the generic rung checks need
        found.append(Finding("broken", f"scene file {scene_path}: {type(exc).__name__}: {exc}"))
    return None


def _render(declared: registry.Scene, scene: dict) -> list[Finding]:
    """Whether the decks render, into a temporary folder removed afterwards: at the smoke rung, with
    the scene file's case. A case the scene refuses there (a ``ValueError``: its preflight or its own
    check, as :func:`granflow.resources.check_size` takes it: too large, infeasible at that size) is a
    note, and the file's other rungs are tried in turn, as ``granflow check-config`` does; the package
    is broken when no rung renders, when it has no smoke rung, or when rendering fails otherwise."""
    try:
        check_rung(scene, SMOKE)
    except ConfigError as exc:
        return [Finding("broken", f"{SMOKE} rung: {exc}")]
    refused = []
    for rung in [SMOKE, *(r for r in scene["rungs"] if r != SMOKE)]:
        try:
            with tempfile.TemporaryDirectory(prefix="check-scene-") as out:
                record = render_case(scene, rung, out, declared=declared)
                decks = sorted(Path(out).glob("*.lmp"),
                               key=lambda p: (STAGES.index(p.stem) if p.stem in STAGES else len(STAGES), p.stem))
        except ValueError as exc:  # the scene refuses the case at this rung
            refused.append(Finding("note", f"{rung} rung refuses the scene file's case ({_error(exc)})"))
            continue
        except Exception as exc:  # noqa: BLE001 - whatever else stops the rendering is the finding
            return [*refused, Finding("broken", f"{rung} rung does not render: {_error(exc)}")]
        return [*refused, Finding("ok", f"{rung} rung renders {', '.join(p.name for p in decks)} and params.json "
                                        f"({declared.describe(record)})", rung)]
    return [Finding("broken", f"no rung renders the scene file's case: {f.text}") for f in refused]


def _error(exc: Exception) -> str:
    return f"{type(exc).__name__}: {_first_line(exc)}"


def _first_line(exc: Exception) -> str:
    text = str(exc).strip()
    return text.splitlines()[0] if text else type(exc).__name__


__all__ = ["DOCS_PAGE", "Finding", "check_scene", "is_own", "locate"]
