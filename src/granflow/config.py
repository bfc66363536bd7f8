"""Load, override and validate granflow configuration.

Two kinds of file are validated against JSON schemas in ``config/schema``:
the campaign (``config/config.yaml``) and the scene files
(``config/scenes/<scene>.yaml``). Every refusal is a :class:`ConfigError` whose
message names the dotted key, the offending value and the allowed range, so a
user can fix the file without reading the schema.
"""
from __future__ import annotations

import copy
import functools
import math
import re
from pathlib import Path
from typing import Any, Iterable

import jsonschema
import yaml

from . import registry, resources

#: Root of the project (``src/granflow/config.py`` -> project root).
PROJECT_ROOT = Path(__file__).resolve().parents[2]
SCHEMA_DIR = PROJECT_ROOT / "config" / "schema"
RUNGS = ("smoke", "demo", "study", "paper", "validation")


class _Loader(yaml.SafeLoader):
    """Safe loader that reads ``1e5`` and ``1.0e5`` as floats (YAML 1.2), not strings."""


_Loader.add_implicit_resolver(
    "tag:yaml.org,2002:float",
    re.compile(r"""^(?:[-+]?(?:[0-9][0-9_]*)\.[0-9_]*(?:[eE][-+]?[0-9]+)?
    |[-+]?(?:[0-9][0-9_]*)(?:[eE][-+]?[0-9]+)
    |\.[0-9_]+(?:[eE][-+]?[0-9]+)?
    |[-+]?\.(?:inf|Inf|INF)
    |\.(?:nan|NaN|NAN))$""", re.X),
    list("-+0123456789."),
)


#: plain scalars that YAML 1.1 (PyYAML, Snakemake) and YAML 1.2 read differently, by resolved tag:
#: booleans other than true/false (on, off, yes, no, y, n), integers with a leading zero (octal in
#: 1.1, decimal in 1.2), a 0b or 0o prefix, digit-group underscores, and base-60 numbers (1:30 = 90)
_AMBIGUOUS = {
    "tag:yaml.org,2002:bool": (re.compile(r"^(?!(?:true|True|TRUE|false|False|FALSE)$).*"),
                               "write true or false"),
    "tag:yaml.org,2002:int": (re.compile(r"^[-+]?(?:0[0-9_]+|0[bo].*|.*_.*|.*:.*)$"),
                              "write the number in plain decimal digits, or quote it to keep a string"),
    "tag:yaml.org,2002:float": (re.compile(r"^[-+]?(?:.*:.*|.*_.*)$"),
                                "write the number in plain decimal digits, or quote it to keep a string"),
}


#: longest number literal read (Python refuses to convert integers of more than 4300 digits)
MAX_NUMBER_CHARS = 64


def _yaml12(value: str):
    """What YAML 1.2's core schema reads from one of the :data:`_AMBIGUOUS` forms."""
    return int(value, 10) if re.fullmatch(r"[-+]?0[0-9]+", value) else value


def _check_unambiguous(node, path: list, source: str, key: bool = False) -> None:
    """Refuse a plain scalar that YAML 1.1 and 1.2 read differently (see :data:`_AMBIGUOUS`)."""
    if isinstance(node, yaml.MappingNode):
        for k, value in node.value:
            _check_unambiguous(k, path, source, key=True)
            _check_unambiguous(value, path + [k.value if isinstance(k, yaml.ScalarNode) else "?"], source)
    elif isinstance(node, yaml.SequenceNode):
        for i, item in enumerate(node.value):
            _check_unambiguous(item, path + [i], source)
    elif (isinstance(node, yaml.ScalarNode) and node.style is None and len(node.value) > MAX_NUMBER_CHARS
          and node.tag in ("tag:yaml.org,2002:int", "tag:yaml.org,2002:float")):
        what = f"the key {node.value[:20]}..." if key else f"{_dotted(path) if path else 'the value'} = {node.value[:20]}..."
        raise ConfigError(f"{source}: {what} (line {node.start_mark.line + 1}) has {len(node.value)} characters: "
                          f"allowed a number of at most {MAX_NUMBER_CHARS} characters")
    elif isinstance(node, yaml.ScalarNode) and node.style is None and node.tag in _AMBIGUOUS:
        pattern, fix = _AMBIGUOUS[node.tag]
        if pattern.match(node.value):
            read = yaml.load(node.value, Loader=yaml.SafeLoader)
            where = f" of {_dotted(path)}" if path else ""
            what = (f"the key {node.value}{where}" if key
                    else f"{_dotted(path)} = {node.value}" if path else node.value)
            raise ConfigError(
                f"{source}: {what} (line {node.start_mark.line + 1}) is ambiguous YAML: "
                f"YAML 1.1 (PyYAML, Snakemake) reads it as {read!r}, YAML 1.2 as {_yaml12(node.value)!r}; "
                f"allowed: {fix}")


def yaml_load(text: str, source: str = "YAML", path: Iterable = ()):
    """Parse YAML text with :class:`_Loader`, refusing the YAML 1.1 forms that 1.2 reads otherwise
    (``on``/``off``/``yes``/``no``, ``0123``, ``1:30``, ``1_000``) with a :class:`ConfigError`
    naming the key (under ``path``, e.g. the key of a ``--set``), its line and the unambiguous spelling."""
    loader = _Loader(text)
    try:
        node = loader.get_single_node()
        if node is None:
            return None
        _check_unambiguous(node, list(path), source)
        return loader.construct_document(node)
    finally:
        loader.dispose()


#: keys that make a file a template Snakemake evaluates as Python (YTE) when it loads it
TEMPLATING_KEYS = ("__use_yte__",)


def refuse_templating(data, source: str) -> None:
    """Refuse a file that asks to be a YTE template: Snakemake runs its Python while loading it,
    before granflow sees a value (even under ``-n``), so no check could come first."""
    for key in TEMPLATING_KEYS:
        if isinstance(data, dict) and key in data:
            raise ConfigError(
                f"{source}: {key} = {data[key]!r} is not allowed: it makes the file a YTE template, and "
                f"Snakemake evaluates a template's Python expressions when it loads the file, before any "
                f"check and even under -n; granflow reads plain YAML only: remove {key} and write the "
                f"values out")


class ConfigError(ValueError):
    """Invalid configuration; the message names key, value and allowed range."""


def load_yaml(path: str | Path) -> dict:
    path = Path(path)
    if not path.is_file():
        raise ConfigError(f"config file not found: {path}")
    try:
        data = yaml_load(path.read_text(), str(path))
    except yaml.YAMLError as exc:
        raise ConfigError(f"{path}: not valid YAML: {exc}") from None
    if not isinstance(data, dict):
        raise ConfigError(f"{path}: top level must be a mapping, got {type(data).__name__}")
    refuse_templating(data, str(path))
    return data


def load_schema(name: str) -> dict:
    """Schema ``config/schema/<name>.schema.yaml`` as a dict (a copy: parsed once per process)."""
    return copy.deepcopy(_schema(name))


@functools.lru_cache(maxsize=None)
def _schema(name: str) -> dict:
    return load_yaml(SCHEMA_DIR / f"{name}.schema.yaml")


# --------------------------------------------------------------------- overrides
def parse_override(text: str) -> tuple[list[str], Any]:
    """Split ``a.b.c=VALUE`` into a key path and a YAML-parsed value.

    ``VALUE`` is read as YAML, so ``0.6`` is a number, ``[20, 30]`` a list and
    ``true`` a boolean; anything else stays a string and meets the schema's type.
    """
    if "=" not in text:
        raise ConfigError(f"--set {text!r}: expected KEY=VALUE with a dotted KEY, e.g. case.phi_mean=0.61")
    key, raw = text.split("=", 1)
    parts = [p for p in key.strip().split(".") if p]
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
                raise ConfigError(f"--set {text}: {'.'.join(parts[:i])} is not a mapping")
            node = node.setdefault(p, {})
        if not isinstance(node, dict):
            raise ConfigError(f"--set {text}: {'.'.join(parts[:-1])} is not a mapping")
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


def _dotted(path: Iterable) -> str:
    out = ""
    for p in path:
        out += f"[{p}]" if isinstance(p, int) else (f".{p}" if out else str(p))
    return out or "(top level)"


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
    key = _dotted(err.absolute_path)
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


def validate(data: dict, schema_name: str, source: str = "config") -> None:
    """Validate ``data`` against a named schema; raise :class:`ConfigError` listing every problem."""
    refuse_templating(data, source)
    schema = load_schema(schema_name)
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


def validate_scene(scene: dict, source: str = "scene") -> dict:
    """Schema plus cross-field checks of a scene file; returns it unchanged."""
    name = scene.get("scene")
    if name not in registry.names():
        raise ConfigError(f"{source}: scene = {name!r} is not allowed: allowed one of "
                          f"{', '.join(map(repr, registry.names()))}")
    validate(scene, name, source)
    registry.get(name).check(scene, source)
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
    scene (schema bounds of the swept key, then the scene's own feasibility checks).
    Returns a copy with each enabled scene's validated content under ``scenes.<name>.scene``.
    """
    data = copy.deepcopy(data)
    path = source
    validate(data, "config", source=source)
    for name, sc in data.get("scenes", {}).items():
        require(name in registry.names(), f"{path}: scenes.{name} is not allowed: allowed one of "
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
        _check_sweep(name, sc.get("sweep") or {}, scene, rung, path, data)
        sc["scene"] = scene
    return data


def _check_sweep(name: str, sweep: dict, scene: dict, rung: str, path: str, limits: dict | None = None) -> None:
    """Every value of the sweep within the scene schema's bounds of its case key, every point feasible."""
    sc = registry.get(name)
    axes = {a.key for a in sc.sweep}
    case_schema = load_schema(name)["properties"]["case"]["properties"]
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
    for point in sc.sweep_points(scene, sweep, rung):
        sc.check_case(scene, rung, point, path)
        what = ", ".join(f"{k} = {v}" for k, v in point.items())
        check_size(name, scene, rung, point, limits, path, f"scenes.{name} case {what} (rung {rung})")


def size_limits(limits: dict | None = None) -> tuple[int, int]:
    """``(max_particles, memory budget in MB)`` of one case from ``limits`` (the campaign dict, whose
    ``max_particles``/``memory_mb`` the CLI's ``--max-particles``/``--memory-mb`` set), else 2 million
    particles and this machine's memory."""
    limits = limits or {}
    max_particles = int(limits.get("max_particles") or resources.DEFAULT_MAX_PARTICLES)
    memory = int(limits.get("memory_mb") or resources.machine_memory_mb() or 0)
    return max_particles, memory


def check_size(name: str, scene: dict, rung: str, case: dict | None, limits: dict | None,
               source: str, label: str) -> int:
    """Refuse a case over the size limits before anything is built; return its particle estimate.

    ``label`` names the case in the message (e.g. ``scenes.silo.sweep point R = 6``). The estimate
    is the scene's :meth:`~granflow.registry.Scene.particle_count` (a formula, no arrays); memory
    is :func:`granflow.resources.memory_mb`; CPU-hours come from the case's workload at the
    reference rate (named when the memory budget refuses a case).
    """
    sc = registry.get(name)
    max_particles, budget = size_limits(limits)
    try:
        n = sc.particle_count(scene, rung, case)
    except ValueError as exc:  # PreflightError (time step, geometry) or a scene's own refusal
        raise ConfigError(f"{source}: {label} is not allowed: {exc}") from None
    mem = resources.memory_mb(n)
    raise_it = ("raise it with --max-particles N (granflow check-config, plan, render), "
                "snakemake --config max_particles=N, or max_particles in the campaign file")
    require(n <= max_particles,
            f"{source}: {label} is too large: estimated {n:,} particles (about {mem / 1024:.3g} GB of memory): "
            f"allowed at most {max_particles:,} particles; {raise_it}")
    if budget and mem > budget:
        work = sc.workload(sc.parameters(scene, rung, case)[1]["record"])
        est = resources.estimate(work)
        raise ConfigError(
            f"{source}: {label} is too large: estimated {n:,} particles, {mem:,} MB of memory and "
            f"{est.cpu_hours:.3g} CPU-hours at {est.rate / 1e6:.3g} Matom-step per CPU-second: allowed at most "
            f"{budget:,} MB (this machine's memory unless --memory-mb, snakemake --config memory_mb=MB or memory_mb in the "
            f"campaign file says otherwise)")
    return n


def check_rung(scene: dict, rung: str, source: str = "--rung") -> dict:
    """Return the rung preset, or refuse an unknown rung name."""
    if rung not in scene["rungs"]:
        raise ConfigError(f"{source} = {rung!r} does not exist: allowed {', '.join(scene['rungs'])}")
    return scene["rungs"][rung]
