"""The scene registry: every scene is one package under :mod:`granflow.scenes`.

A scene package ``granflow/scenes/<name>/`` defines ``SCENE``, an instance of a
:class:`Scene` subclass that declares everything particular to the scene: its
sweep axes, figures with captions, headline numbers, cost-study knobs, and the
functions that derive a case's deck parameters, judge its run, analyse it and
tabulate it. The generic layers (config validation, deck rendering, runner,
Snakemake rules, report, cost study, CLI) find scenes only through
:func:`scenes` and :func:`get` and never name one.

Adding a scene means adding its package (with ``SCENE``), its scene file
``config/scenes/<name>.yaml`` and its schema ``config/schema/<name>.schema.yaml``;
nothing else. Packages are found by :mod:`pkgutil`, so there is no list to edit.

The contract: what a scene must give is :data:`REQUIRED`, checked when its package is
found (:func:`check_package`, every problem of :func:`missing`); a package that fails the check
(or does not import) is refused by name with what it lacks (:class:`SceneError`, exit 2 from any
command that needs it) while the other scenes keep working. ``granflow check-scene`` runs the same
check on one package, anywhere (:func:`package_at`). What it may give is :data:`OPTIONAL`: the generic layers ask
:meth:`Scene.gives` and skip what a scene does not give. Everything else has a default
(:data:`DEFAULTED`).
"""
from __future__ import annotations

import importlib
import math
import pkgutil
import sys
import types
from contextlib import contextmanager
from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path

import yaml

from .declarations import Deferred, FigureSpec, Knob, SnapshotView, Stage, SweepAxis, Workload  # noqa: F401 (re-exported)
from .scene_base import DEFAULTED, GENERIC_STATUSES, OPTIONAL, REQUIRED, Scene, overrides  # noqa: F401 (re-exported)
from .yamlio import ConfigError

#: Where the scene packages live.
SCENES_PACKAGE = "granflow.scenes"
#: the project's config folder: each scene's schema and scene file
CONFIG_DIR = Path(__file__).resolve().parents[2] / "config"


class SceneError(ConfigError):
    """A scene package that does not meet the contract: named with what it lacks (exit 2)."""


def _case_keys(schema: Path) -> set | None:
    """Keys of a schema's ``case`` section (None when the file does not read as a schema)."""
    try:
        data = yaml.load(schema.read_text(), Loader=getattr(yaml, "CSafeLoader", yaml.SafeLoader))
        return set(data["properties"]["case"]["properties"])
    except (OSError, yaml.YAMLError, KeyError, TypeError):
        return None


def missing(scene, package: str, config_dir: Path | None = None) -> list[str]:
    """What ``scene``, the ``SCENE`` of package ``package``, lacks of :data:`REQUIRED`, one
    phrase each (empty when it meets the contract); files are looked for in ``config_dir``
    (default :data:`CONFIG_DIR`) and its package."""
    if not isinstance(scene, Scene):
        return [f"SCENE ({REQUIRED['SCENE']}; found {type(scene).__name__})"]
    config_dir = Path(CONFIG_DIR if config_dir is None else config_dir)
    out = []
    if scene.name != package:
        out.append(f"name (SCENE.name = {scene.name!r}: must be the package's name {package!r})")
    if not (isinstance(scene.summary, str) and scene.summary.strip()):
        out.append(f"summary ({REQUIRED['summary']})")
    axes_ok = (isinstance(scene.sweep, (tuple, list)) and bool(scene.sweep)
               and all(isinstance(a, SweepAxis) for a in scene.sweep))
    if not axes_ok:
        out.append(f"sweep ({REQUIRED['sweep']})")
    if not (isinstance(scene.figures, dict) and all(isinstance(f, FigureSpec) and callable(f.draw)
                                                   for f in scene.figures.values())):
        out.append(f"figures ({REQUIRED['figures']})")
    for method in ("parameters", "analyse") + (("figure_cases",) if scene.figures else ()):
        if not overrides(scene, method):
            out.append(f"{method}() ({REQUIRED[method + '()']})")
    schema = config_dir / "schema" / f"{package}.schema.yaml"
    keys = _case_keys(schema) if schema.is_file() else None
    if keys is None:
        out.append(f"schema ({schema}: {'no case section' if schema.is_file() else 'no such file'})")
    elif axes_ok and any(a.key not in keys for a in scene.sweep):
        out.append(f"sweep (axes {', '.join(a.key for a in scene.sweep if a.key not in keys)} are not keys of "
                   f"the case section of {schema})")
    scene_file = config_dir / "scenes" / f"{package}.yaml"
    if not scene_file.is_file():
        out.append(f"scene file ({scene_file}: no such file)")
    template = scene.package_dir / f"{package}.lmp.j2"
    if not template.is_file():
        out.append(f"deck template ({template}: no such file)")
    if scene.knobs and not scene.gives("cost_study"):
        out.append("headline and observables() (its knobs declare a cost study, which needs all three)")
    return out


@dataclass(frozen=True)
class PackageCheck:
    """One scene package checked against the contract: its ``SCENE`` (None when the package does not
    import or has no usable one) and every problem found, one phrase each (:func:`check_package`).

    ``import_error`` says why the package does not import (then nothing else was checked), and
    ``exception`` is that error itself, with its traceback (``--debug`` shows it, file and line);
    ``lacks`` lists what it lacks of :data:`REQUIRED` (:func:`missing`), all of it, not the first.
    """

    scene: Scene | None
    lacks: tuple[str, ...] = ()
    import_error: str = ""
    exception: BaseException | None = field(default=None, compare=False, repr=False)

    @property
    def ok(self) -> bool:
        return not self.import_error and not self.lacks

    @property
    def refusal(self) -> str:
        """Why discovery refuses the package (``''`` when it meets the contract)."""
        return self.import_error or ("it lacks " + "; ".join(self.lacks) if self.lacks else "")


def check_package(module: str, package: str, config_dir: Path | None = None) -> PackageCheck:
    """Import the scene package ``module`` (its folder named ``package``) and check its ``SCENE``
    (:func:`missing`, files looked for in ``config_dir``). A package that does not import, has no
    ``SCENE`` or lacks a required part gives a :class:`PackageCheck` that says so, with every problem;
    any error of the package's own code is caught and named (it refuses that package only)."""
    try:
        imported = importlib.import_module(module)
    except Exception as exc:  # noqa: BLE001 - any error of a scene's code refuses that scene only
        return PackageCheck(None, import_error=f"its package does not import ({type(exc).__name__}: {exc})",
                            exception=exc)
    scene = getattr(imported, "SCENE", None)
    try:
        lacks = missing(scene, package, config_dir)
    except Exception as exc:  # noqa: BLE001 - e.g. a member that is not what its name says
        return PackageCheck(scene if isinstance(scene, Scene) else None,
                            (f"a SCENE that can be checked ({type(exc).__name__}: {exc})",), exception=exc)
    return PackageCheck(scene if isinstance(scene, Scene) else None, tuple(lacks))


#: the parent under which :func:`package_at` imports a scene package found by its path
CHECKED_PARENT = "_granflow_checked_scene"


@contextmanager
def package_at(path: str | Path):
    """Import the scene package folder ``path`` (anywhere, not only under :mod:`granflow.scenes`) for
    the duration: yields its module name, ``_granflow_checked_scene.<folder name>``, for
    :func:`check_package`. Its relative imports work as in place; afterwards its modules are
    forgotten (another package of the same name can be checked next)."""
    path = Path(path).resolve()
    parent = types.ModuleType(CHECKED_PARENT)
    parent.__path__ = [str(path.parent)]

    def forget():
        for name in [m for m in sys.modules if m == CHECKED_PARENT or m.startswith(CHECKED_PARENT + ".")]:
            del sys.modules[name]

    forget()
    sys.modules[CHECKED_PARENT] = parent
    importlib.invalidate_caches()
    try:
        yield f"{CHECKED_PARENT}.{path.name}"
    finally:
        forget()


@dataclass(frozen=True)
class Found:
    """The scene packages of one discovery: the usable ones by name, the refused ones with why, and
    the error that refused a package whose code failed (by name)."""

    scenes: dict
    refused: dict
    errors: dict = field(default_factory=dict)


def discover(package: str = SCENES_PACKAGE, config_dir: Path | None = None) -> Found:
    """Import every subpackage of ``package`` and check its ``SCENE`` (:func:`check_package`). A package
    that does not import, has no ``SCENE`` or lacks a required part is refused with the reason;
    the others are found, by name (sorted)."""
    scenes, refused, errors = {}, {}, {}
    for info in sorted(pkgutil.iter_modules(importlib.import_module(package).__path__), key=lambda m: m.name):
        if not info.ispkg:
            continue
        checked = check_package(f"{package}.{info.name}", info.name, config_dir)
        if checked.ok:
            scenes[info.name] = checked.scene
        else:
            refused[info.name] = checked.refusal
            if checked.exception is not None:
                errors[info.name] = checked.exception
    return Found(scenes, refused, errors)


# ------------------------------------------------------------------------- lookup
@lru_cache(maxsize=None)
def _found() -> Found:
    return discover()


def scenes() -> dict[str, Scene]:
    """Every registered scene that meets the contract, by name (sorted)."""
    return dict(_found().scenes)


def names() -> tuple[str, ...]:
    """Names of the usable scenes (sorted); :func:`refused` has the others."""
    return tuple(_found().scenes)


def refused() -> dict[str, str]:
    """Scene packages refused at discovery: name -> what is wrong."""
    return dict(_found().refused)


def refusal(name: str, text: str) -> SceneError:
    """A :class:`SceneError` saying ``text`` of the refused scene ``name``, caused by the error of its
    package's own code, if one refused it: a traceback (``--debug``) then shows that error first,
    with its file and line."""
    error = SceneError(text)
    error.__cause__ = _found().errors.get(name)
    return error


def get(name: str) -> Scene:
    """The scene called ``name``; :class:`SceneError` naming what a refused one lacks, ``KeyError``
    naming the registered ones for an unknown name."""
    found = _found()
    if name in found.refused:
        raise refusal(name, f"scene {name!r} is refused: {found.refused[name]} (granflow.registry.REQUIRED lists "
                            f"what a scene must give)")
    try:
        return found.scenes[name]
    except KeyError:
        raise KeyError(f"no scene {name!r}: registered scenes are {', '.join(found.scenes)}") from None


def finite(value) -> float:
    """``value`` as a float, NaN for anything that is not a finite number."""
    try:
        value = float(value)
    except (TypeError, ValueError):
        return float("nan")
    return value if math.isfinite(value) else float("nan")


__all__ = ["Scene", "SweepAxis", "Deferred", "FigureSpec", "Knob", "Stage", "Workload", "SnapshotView", "SceneError",
           "REQUIRED", "OPTIONAL", "DEFAULTED", "missing", "PackageCheck", "check_package", "package_at", "discover",
           "scenes", "names", "refused", "get", "finite"]
