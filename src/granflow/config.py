"""Load, override and validate granflow configuration.

Two kinds of file are validated against JSON schemas in ``config/schema``:
the campaign (``config/config.yaml``) and the scene files
(``config/scenes/<scene>.yaml``). Every refusal is a :class:`ConfigError` whose
message names the dotted key, the offending value and the allowed range, so a
user can fix the file without reading the schema. Every YAML text is read by :func:`yaml_load`
with bounded work (:data:`MAX_DOCUMENT_BYTES`, :data:`MAX_NODES` with aliases expanded,
:data:`MAX_DEPTH`), refusing a key given twice and a file that is not UTF-8.
"""
from __future__ import annotations

import copy
import functools
import math
import os
from pathlib import Path
from typing import Any, Iterable

import jsonschema
import yaml

from . import registry, resources
from .scene_hooks import REPLICATE
from .yamlio import (  # noqa: F401 (the loader's names, re-exported: granflow.config is where callers find them)
    MAX_DEPTH,
    MAX_DOCUMENT_BYTES,
    MAX_NODES,
    MAX_NUMBER_CHARS,
    TEMPLATING_KEYS,
    ConfigError,
    check_extent,
    dotted_path,
    load_yaml,
    refuse_templating,
    yaml_load,
)

#: Root of the project (``src/granflow/config.py`` -> project root).
PROJECT_ROOT = Path(__file__).resolve().parents[2]
SCHEMA_DIR = PROJECT_ROOT / "config" / "schema"
RUNGS = ("smoke", "demo", "study", "paper", "validation")


def load_schema(name: str) -> dict:
    """Schema ``config/schema/<name>.schema.yaml`` as a dict (a copy: parsed once per process)."""
    return copy.deepcopy(_schema(name))


@functools.lru_cache(maxsize=None)
def _schema(name: str) -> dict:
    return load_yaml(SCHEMA_DIR / f"{name}.schema.yaml")


# --------------------------------------------------------------------- overrides
def _split_key(text: str) -> tuple[list[str], str]:
    """``a."b.c".d=VALUE`` -> ``(['a', 'b.c', 'd'], 'VALUE')``: the key's parts split at dots,
    a part in double or single quotes taken whole (its dots are part of the name), and the text
    after the first ``=`` outside quotes. Empty unquoted parts are dropped, as ``a..b`` always was."""
    text = text.lstrip()
    parts, part, quoted, i = [], "", False, 0
    while i < len(text):
        ch = text[i]
        if ch in "\"'" and not part and not quoted:
            end = text.find(ch, i + 1)
            if end < 0:
                raise ConfigError(f"--set {text!r}: the quote {ch} at character {i + 1} is not closed: allowed a "
                                  f"name in quotes, e.g. particles.mixtures.\"mono1.5\".diameters=[1.5e-3]")
            part, quoted, i = text[i + 1:end], True, end + 1
            if i < len(text) and text[i] not in ".=":
                raise ConfigError(f"--set {text!r}: {text[i]!r} follows the quoted name {part!r}: allowed a "
                                  f"quoted name as a whole part of the key, between dots")
            continue
        if ch in ".=":
            if ch == "=" and not quoted:
                part = part.rstrip()
            if part or quoted:
                parts.append(part)
            part, quoted = "", False
            if ch == "=":
                return parts, text[i + 1:]
        else:
            part += ch
        i += 1
    raise ConfigError(f"--set {text!r}: expected KEY=VALUE with a dotted KEY, e.g. case.phi_mean=0.61 "
                      f"(a name with dots in quotes: particles.mixtures.\"mono1.5\".diameters=[1.5e-3])")


def key_text(parts: Iterable) -> str:
    """A key path as ``--set`` spells it: dotted, a name holding a dot in double quotes."""
    return ".".join(f'"{p}"' if "." in str(p) or not str(p) else str(p) for p in parts)


def parse_override(text: str) -> tuple[list[str], Any]:
    """Split ``a.b.c=VALUE`` into a key path and a YAML-parsed value.

    A name that holds a dot is written in quotes, ``particles.mixtures."mono1.5".diameters=...``
    (in a shell, the whole argument in single quotes). ``VALUE`` is read as YAML, so ``0.6`` is
    a number, ``[20, 30]`` a list and ``true`` a boolean; anything else stays a string and meets
    the schema's type.
    """
    parts, raw = _split_key(text)
    if not parts:
        raise ConfigError(f"--set {text!r}: empty key")
    try:
        value = yaml_load(raw, "--set", parts)
    except yaml.YAMLError:
        value = raw
    return parts, value


def apply_overrides(data: dict, overrides: Iterable[str]) -> dict:
    """Return a copy of ``data`` with each ``KEY=VALUE`` override applied.

    An override may create a new key; the schema then refuses it as unknown,
    exactly as it would in the file.
    """
    out = copy.deepcopy(data)
    for text in overrides or ():
        parts, value = parse_override(text)
        node = out
        for i, p in enumerate(parts[:-1]):
            if not isinstance(node, dict):
                raise ConfigError(f"--set {text}: {key_text(parts[:i])} is not a mapping")
            node = node.setdefault(p, {})
        if not isinstance(node, dict):
            raise ConfigError(f"--set {text}: {key_text(parts[:-1])} is not a mapping")
        node[parts[-1]] = value
    return out


# -------------------------------------------------------------------- validation
def _finite_number(checker, instance) -> bool:
    """JSON Schema's ``number``, finite only: NaN and infinities are not numbers a case can use
    (an int is always finite; its range check refuses one too large)."""
    return (jsonschema.Draft202012Validator.TYPE_CHECKER.is_type(instance, "number")
            and not _nonfinite(instance))


def _finite_integer(checker, instance) -> bool:
    return (jsonschema.Draft202012Validator.TYPE_CHECKER.is_type(instance, "integer")
            and not _nonfinite(instance))


#: Draft 2020-12 whose ``number`` and ``integer`` refuse NaN and +-inf (YAML's .nan, .inf, or --set x=.nan)
Validator = jsonschema.validators.extend(
    jsonschema.Draft202012Validator,
    type_checker=jsonschema.Draft202012Validator.TYPE_CHECKER.redefine("number", _finite_number)
    .redefine("integer", _finite_integer))


def _nonfinite(value) -> bool:
    return isinstance(value, float) and not math.isfinite(value)




def _allowed(schema: dict) -> str:
    """Human description of what ``schema`` allows."""
    bits = []
    if "enum" in schema:
        bits.append("one of " + ", ".join(repr(v) for v in schema["enum"]))
    if "const" in schema:
        bits.append(f"exactly {schema['const']!r}")
    lo = schema.get("minimum")
    xlo = schema.get("exclusiveMinimum")
    hi = schema.get("maximum")
    xhi = schema.get("exclusiveMaximum")
    if any(v is not None for v in (lo, xlo, hi, xhi)):
        left = f"{lo} <= " if lo is not None else (f"{xlo} < " if xlo is not None else "")
        right = f" <= {hi}" if hi is not None else (f" < {xhi}" if xhi is not None else "")
        bits.append(f"{left}value{right}")
    if "type" in schema and not bits:
        t = schema["type"]
        bits.append("type " + (" or ".join(t) if isinstance(t, list) else t))
    if "pattern" in schema:
        bits.append(f"matching {schema['pattern']}")
    return "; ".join(bits) or "see the schema"


def _format_error(err: jsonschema.ValidationError, source: str) -> str:
    key = dotted_path(err.absolute_path)
    desc = err.schema.get("description") if isinstance(err.schema, dict) else None
    tail = f" ({desc})" if desc else ""
    if err.validator == "additionalProperties":
        allowed = sorted(err.schema.get("properties", {}))
        extra = sorted(set(err.instance) - set(allowed))
        where = f"{key}." if err.absolute_path else ""
        return (f"{source}: unknown key {where}{extra[0]!s} (value {err.instance[extra[0]]!r}); "
                f"allowed keys here: {', '.join(allowed)}")
    if err.validator == "required":
        return f"{source}: {key}: {err.message}"
    if err.validator in ("minimum", "maximum", "exclusiveMinimum", "exclusiveMaximum", "enum", "const"):
        return f"{source}: {key} = {err.instance!r} is not allowed: allowed {_allowed(err.schema)}{tail}"
    if err.validator == "type" and _nonfinite(err.instance):
        allowed = _allowed(err.schema)
        allowed = "a finite number" if allowed.startswith("type ") else f"a finite number, {allowed}"
        return f"{source}: {key} = {err.instance!r} is not a finite number: allowed {allowed}{tail}"
    if err.validator == "type":
        return f"{source}: {key} = {err.instance!r} has the wrong type: allowed {_allowed(err.schema)}{tail}"
    return f"{source}: {key} = {err.instance!r}: {err.message}{tail}"


def validate(data: dict, schema_name: str, source: str = "config", schema: dict | None = None) -> None:
    """Validate ``data`` against a named schema (or ``schema`` itself); raise :class:`ConfigError`
    listing every problem, one per line."""
    refuse_templating(data, source)
    schema = load_schema(schema_name) if schema is None else schema
    validator = Validator(schema)
    errors = sorted(validator.iter_errors(data), key=lambda e: (list(map(str, e.absolute_path)), e.validator))
    # a non-finite number: one message ("not a finite number"), not also its range check's
    nonfinite = {tuple(e.absolute_path) for e in errors if e.validator == "type" and _nonfinite(e.instance)}
    errors = [e for e in errors if e.validator == "type" or tuple(e.absolute_path) not in nonfinite]
    if errors:
        raise ConfigError("\n".join(_format_error(e, source) for e in errors))


def require(cond: bool, msg: str) -> None:
    """Refuse with ``msg`` (a :class:`ConfigError` naming key, value and allowed range) unless ``cond``."""
    if not cond:
        raise ConfigError(msg)


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


def validate_campaign_scenes(data: dict, root: Path, source: str = "config") -> dict:
    """Validate a campaign dict's scenes (the whole campaign: :func:`granflow.campaign.validate_campaign`).

    Scene file paths are relative to ``root``. Every sweep point is checked by its
    scene (schema bounds of the swept key, then the scene's own feasibility checks) and
    against the size limits (:func:`check_size`), and all points together against
    ``max_cpu_hours`` (:func:`check_campaign_cpu_hours`; the cost study's runs, a target of
    their own, are checked one by one only). Returns a copy with each enabled scene's
    validated content under ``scenes.<name>.scene``.
    """
    data = copy.deepcopy(data)
    path = source
    validate(data, "config", source=source)
    check_results_dir(data.get("results_dir", "results"), root, source)
    estimates = {}
    for name, sc in data.get("scenes", {}).items():
        if name in registry.refused() and sc.get("enabled", True):  # a disabled one is not needed
            raise registry.refusal(name, f"{path}: scenes.{name} is enabled, but the scene is refused: "
                                         f"{registry.refused()[name]}")
        require(name in registry.names() or name in registry.refused(),
                f"{path}: scenes.{name} is not allowed: allowed one of "
                f"{', '.join(map(repr, registry.names()))} (the registered scenes)")
        if not sc.get("enabled", True):
            continue
        scene_path = Path(sc.get("scene_file") or f"config/scenes/{name}.yaml")
        if not scene_path.is_absolute():
            scene_path = root / scene_path
        scene = load_scene(scene_path)
        require(scene["scene"] == name, f"{path}: scenes.{name}.scene_file = {sc.get('scene_file')!r} describes "
                                       f"the {scene['scene']} scene: allowed a {name} scene file")
        rung = data["rung"]
        require(rung in scene["rungs"],
               f"{path}: rung = {rung!r} is not defined in {scene_path}: allowed {', '.join(scene['rungs'])}")
        estimates[name] = _check_sweep(name, sc.get("sweep") or {}, scene, rung, path, data)
        sc["scene"] = scene
    check_campaign_cpu_hours(estimates, data["rung"], data, path)
    return data


def check_scene_sweep(name: str, scene: dict, sweep: dict, rung: str, source: str, limits: dict | None = None) -> float:
    """A validated scene's sweep at ``rung`` checked as a campaign of that scene alone checks it (the rung
    defined, every point within the schema, feasible and within the size limits, all points together
    within ``max_cpu_hours`` of ``limits``); returns the points' CPU-hours. A ladder's rung
    (:mod:`granflow.ladder`) is checked so, its scene changed in memory."""
    require(rung in scene["rungs"], f"{source}: rung = {rung!r} is not defined: allowed {', '.join(scene['rungs'])}")
    estimates = {name: _check_sweep(name, sweep, scene, rung, source, limits)}
    return check_campaign_cpu_hours(estimates, rung, limits, source)


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


def _check_sweep(name: str, sweep: dict, scene: dict, rung: str, path: str, limits: dict | None = None) -> list:
    """Every value of the sweep within the scene schema's bounds of its case key, every point feasible
    and within the size limits (:func:`check_size`); returns the points' estimates."""
    sc = registry.get(name)
    case_schema = load_schema(name)["properties"]["case"]["properties"]
    # the scene's axes, and the seed of its replicates (REPLICATE) where its case has one
    axes = {a.key for a in sc.sweep} | ({REPLICATE.key} & set(case_schema))
    for key, values in sweep.items():
        require(key in axes, f"{path}: unknown key scenes.{name}.sweep.{key} (value {values!r}); "
                            f"allowed keys here: {', '.join(sorted(axes))}")
        schema = {k: v for k, v in case_schema[key].items() if k != "default"}
        if isinstance(schema.get("type"), list):  # a sweep lists values: null (= the rung's default) is not one
            schema["type"] = [t for t in schema["type"] if t != "null"]
        validator = Validator(schema)
        for i, value in enumerate(values):
            for err in validator.iter_errors(value):
                err.path.appendleft(i)
                for part in reversed(("scenes", name, "sweep", key)):
                    err.path.appendleft(part)
                raise ConfigError(_format_error(err, path))
    for axis in sc.sweep:  # one result directory per value, and the value the directory names
        seen = {}
        for value in sweep.get(axis.key) or []:
            label = f"{axis.label}~{axis.to_dir(value)}"
            require(label not in seen,
                    f"{path}: scenes.{name}.sweep.{axis.key} = {seen.get(label)!r} and {value!r} name the same "
                    f"result directory {label}: allowed values that differ within 6 significant digits")
            seen[label] = value
            if not axis.name:
                back = axis.from_dir(axis.to_dir(value))
                require(math.isclose(back, float(value), rel_tol=1e-12, abs_tol=1e-300),
                        f"{path}: scenes.{name}.sweep.{axis.key} = {value!r} has more digits than its result "
                        f"directory {label} keeps (it would run as {back:g}): allowed at most 6 significant digits")
    estimates = []
    for point in sc.sweep_points(scene, sweep, rung):
        sc.check_case(scene, rung, point, path)
        what = ", ".join(f"{k} = {v}" for k, v in point.items())
        estimates.append(check_size(name, scene, rung, point, limits, path, f"scenes.{name} case {what} (rung {rung})"))
    return estimates


#: the campaign keys that bound one case (and the campaign) before anything is built; the CLI's
#: ``--max-particles``, ``--memory-mb`` and ``--max-cpu-hours`` set them, Snakemake's ``--config KEY=V``
LIMIT_KEYS = ("max_particles", "memory_mb", "max_cpu_hours")

#: how to raise each limit, for the refusals
_RAISE = {key: (f"raise it with --{key.replace('_', '-')} {arg} (granflow check-config, plan, render), "
                f"snakemake --config {key}={arg}, or {key} in the campaign file")
          for key, arg in (("max_particles", "N"), ("memory_mb", "MB"), ("max_cpu_hours", "H"))}


def check_limits(limits: dict, source: str = "command line") -> dict:
    """Refuse limits given on the command line without a campaign file (``granflow render``,
    ``check-config`` on a scene file) that the campaign schema would refuse, naming the option
    (``--max-cpu-hours``): the same bounds as in a campaign file. Returns ``limits``."""
    props = load_schema("config")["properties"]
    option = {key: "--" + key.replace("_", "-") for key in LIMIT_KEYS}
    schema = {"type": "object", "properties": {option[k]: props[k] for k in LIMIT_KEYS}}
    given = {option.get(k, k): v for k, v in limits.items()}
    for err in sorted(Validator(schema).iter_errors(given), key=lambda e: list(map(str, e.absolute_path))):
        raise ConfigError(_format_error(err, source))
    return limits


def size_limits(limits: dict | None = None) -> tuple[int, int, float]:
    """``(max_particles, memory budget in MB, max_cpu_hours)`` of one case from ``limits`` (the
    campaign dict, whose ``max_particles``/``memory_mb``/``max_cpu_hours`` the CLI's
    ``--max-particles``/``--memory-mb``/``--max-cpu-hours`` set), else 2 million particles, this
    machine's memory and a week of this machine's cores
    (:func:`granflow.resources.default_max_cpu_hours`)."""
    limits = limits or {}
    max_particles = int(limits.get("max_particles") or resources.DEFAULT_MAX_PARTICLES)
    memory = int(limits.get("memory_mb") or resources.machine_memory_mb() or 0)
    cpu_hours = float(limits.get("max_cpu_hours") or resources.default_max_cpu_hours())
    return max_particles, memory, cpu_hours


def _cpu_hour_limit_text(limits: dict | None) -> str:
    """Where the CPU-hour limit comes from, for messages."""
    if (limits or {}).get("max_cpu_hours"):
        return f"max_cpu_hours = {limits['max_cpu_hours']:g}"
    return resources.default_max_cpu_hours_text()


def _hours(h: float) -> str:
    return f"{h:,.0f}" if h >= 100 else f"{h:.3g}"


def check_size(name: str, scene: dict, rung: str, case: dict | None, limits: dict | None,
               source: str, label: str) -> "resources.Estimate":
    """Refuse a case over the size limits before anything is built; return its estimate.

    ``label`` names the case in the message (e.g. ``scenes.silo.sweep point R = 6``). In order:
    the particles, the scene's :meth:`~granflow.registry.Scene.particle_count` (a formula, no
    arrays; it also refuses a geometry that does not fit); the memory,
    :func:`granflow.resources.memory_mb`; then the deck's parameters are derived (their preflight:
    time step, feasibility) and the CPU-hours priced by :func:`granflow.resources.estimate` from
    the case's workload at the reference rate, as ``granflow plan`` prices a scene without
    measured runs (a fixed rate, so whether a config passes does not change as runs finish).
    Returns that :class:`granflow.resources.Estimate` (``particles``, ``cpu_hours``, ...).
    """
    sc = registry.get(name)
    max_particles, budget, max_cpu_hours = size_limits(limits)
    try:
        n = sc.particle_count(scene, rung, case)
    except ValueError as exc:  # PreflightError (time step, geometry) or a scene's own refusal
        raise ConfigError(f"{source}: {label} is not allowed: {exc}") from None
    mem = resources.memory_mb(n)
    require(n <= max_particles,
            f"{source}: {label} is too large: estimated {n:,} particles (about {mem / 1024:.3g} GB of memory): "
            f"allowed at most {max_particles:,} particles; {_RAISE['max_particles']}")
    try:
        est = resources.estimate(sc.workload(sc.parameters(scene, rung, case)[1]["record"]))
    except ValueError as exc:  # the deck's preflight: time step, feasibility
        raise ConfigError(f"{source}: {label} is not allowed: {exc}") from None
    if budget and mem > budget:
        raise ConfigError(
            f"{source}: {label} is too large: estimated {n:,} particles, {mem:,} MB of memory and "
            f"{est.cpu_hours:.3g} CPU-hours at {est.rate / 1e6:.3g} Matom-step per CPU-second: allowed at most "
            f"{budget:,} MB (this machine's memory unless --memory-mb, snakemake --config memory_mb=MB or memory_mb in the "
            f"campaign file says otherwise)")
    require(est.cpu_hours <= max_cpu_hours,
            f"{source}: {label} is too large: estimated {_hours(est.cpu_hours)} CPU-hours ({est.particles:,} particles, "
            f"{est.atom_steps:.3g} atom-steps at {est.rate / 1e6:.3g} Matom-step per CPU-second, the reference rate "
            f"for its pair style that granflow plan uses without measured runs): allowed at most {_hours(max_cpu_hours)} CPU-hours "
            f"({_cpu_hour_limit_text(limits)}); {_RAISE['max_cpu_hours']}")
    return est


def check_campaign_cpu_hours(estimates: dict[str, list], rung: str, limits: dict | None, source: str) -> float:
    """Refuse a campaign whose cases (``{scene: [Estimate, ...]}``, from :func:`check_size`)
    together are estimated above ``max_cpu_hours``; return the total CPU-hours."""
    _, _, max_cpu_hours = size_limits(limits)
    per_scene = {name: sum(e.cpu_hours for e in ests) for name, ests in estimates.items()}
    total = sum(per_scene.values())
    cases = sum(len(ests) for ests in estimates.values())
    parts = ", ".join(f"{name} {_hours(h)}" for name, h in sorted(per_scene.items(), key=lambda kv: -kv[1]))
    require(total <= max_cpu_hours,
            f"{source}: the campaign at rung {rung} is too large: its {cases} cases are estimated at "
            f"{_hours(total)} CPU-hours together ({parts}; at the reference rate, as granflow plan prices a "
            f"scene without measured runs): allowed at most {_hours(max_cpu_hours)} CPU-hours "
            f"({_cpu_hour_limit_text(limits)}); {_RAISE['max_cpu_hours']}")
    return total


def check_rung(scene: dict, rung: str, source: str = "--rung") -> dict:
    """Return the rung preset, or refuse an unknown rung name."""
    if rung not in scene["rungs"]:
        raise ConfigError(f"{source} = {rung!r} does not exist: allowed {', '.join(scene['rungs'])}")
    return scene["rungs"][rung]
