"""The schemas in ``config/schema`` and the refusals they make, and the campaign's own keys.

Two kinds of file are validated against JSON schemas in ``config/schema``: the campaign
(``config/config.yaml``) and the scene files (``config/scenes/<scene>.yaml``). Every refusal is a
:class:`~granflow.yamlio.ConfigError` whose message names the dotted key, the offending value and
the allowed range (:func:`format_error`), so a user can fix the file without reading the schema.
A campaign's own keys are checked here (:func:`check_campaign_keys`; then its ``results_dir`` against the
project root, :func:`granflow.campaign.check_results_dir`), and each scene's sweep against that scene's schema
once the scene is resolved (:func:`check_sweep`).
"""
from __future__ import annotations

import copy
import functools
import math
from pathlib import Path
from typing import Iterable

import jsonschema

from .declarations import REPLICATE, SweepAxis
from .yamlio import ConfigError, dotted_path, load_yaml, refuse_templating

#: Root of the project (``src/granflow/schema.py`` -> project root).
PROJECT_ROOT = Path(__file__).resolve().parents[2]
SCHEMA_DIR = PROJECT_ROOT / "config" / "schema"


def load_schema(name: str) -> dict:
    """Schema ``config/schema/<name>.schema.yaml`` as a dict (a copy: parsed once per process)."""
    return copy.deepcopy(_schema(name))


@functools.lru_cache(maxsize=None)
def _schema(name: str) -> dict:
    return load_yaml(SCHEMA_DIR / f"{name}.schema.yaml")


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


def format_error(err: jsonschema.ValidationError, source: str) -> str:
    """One schema error as a refusal: ``source``, the dotted key, the value and what is allowed."""
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
        raise ConfigError("\n".join(format_error(e, source) for e in errors))


def require(cond: bool, msg: str) -> None:
    """Refuse with ``msg`` (a :class:`ConfigError` naming key, value and allowed range) unless ``cond``."""
    if not cond:
        raise ConfigError(msg)


def check_campaign_keys(data: dict, source: str = "config") -> dict:
    """The campaign's own keys: a copy of ``data`` validated against the campaign schema. Returns the
    copy; its ``results_dir`` is judged next, against the project root
    (:func:`granflow.campaign.check_results_dir`)."""
    data = copy.deepcopy(data)
    validate(data, "config", source=source)
    return data


def check_sweep(name: str, sweep: dict, axes: Iterable[SweepAxis], source: str) -> None:
    """A campaign's sweep of scene ``name`` (``scenes.<name>.sweep``): every key one of the scene's
    ``axes`` (or the seed of its replicates, :data:`REPLICATE`, where its case has one), every value
    within the scene schema's bounds of its case key, and no two values of an axis naming the same
    result directory. Its points are then checked by the scene (:meth:`~granflow.registry.Scene.check_case`)."""
    axes = tuple(axes)
    case_schema = load_schema(name)["properties"]["case"]["properties"]
    # the scene's axes, and the seed of its replicates (REPLICATE) where its case has one
    keys = {a.key for a in axes} | ({REPLICATE.key} & set(case_schema))
    for key, values in sweep.items():
        require(key in keys, f"{source}: unknown key scenes.{name}.sweep.{key} (value {values!r}); "
                             f"allowed keys here: {', '.join(sorted(keys))}")
        schema = {k: v for k, v in case_schema[key].items() if k != "default"}
        if isinstance(schema.get("type"), list):  # a sweep lists values: null (= the rung's default) is not one
            schema["type"] = [t for t in schema["type"] if t != "null"]
        validator = Validator(schema)
        for i, value in enumerate(values):
            for err in validator.iter_errors(value):
                err.path.appendleft(i)
                for part in reversed(("scenes", name, "sweep", key)):
                    err.path.appendleft(part)
                raise ConfigError(format_error(err, source))
    for axis in axes:  # one result directory per value, and the value the directory names
        seen = {}
        for value in sweep.get(axis.key) or []:
            label = f"{axis.label}~{axis.to_dir(value)}"
            if label in seen:
                raise ConfigError(f"{source}: scenes.{name}.sweep.{axis.key} = {seen[label]!r} and {value!r} name the "
                                  f"same result directory {label}: allowed values that differ within 6 significant digits")
            seen[label] = value
            if not axis.name:
                back = axis.from_dir(axis.to_dir(value))
                if not math.isclose(back, float(value), rel_tol=1e-12, abs_tol=1e-300):
                    raise ConfigError(f"{source}: scenes.{name}.sweep.{axis.key} = {value!r} has more digits than its "
                                      f"result directory {label} keeps (it would run as {back:g}): allowed at most 6 "
                                      f"significant digits")
