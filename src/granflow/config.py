"""Load, override and validate granflow configuration.

Two kinds of file are validated against JSON schemas in ``config/schema``:
the campaign (``config/config.yaml``) and the scene files
(``config/scenes/<scene>.yaml``). Every refusal is a :class:`ConfigError` whose
message names the dotted key, the offending value and the allowed range, so a
user can fix the file without reading the schema.
"""
from __future__ import annotations

import copy
import math
import re
from pathlib import Path
from typing import Any, Iterable

import jsonschema
import yaml

#: Root of the project (``src/granflow/config.py`` -> project root).
PROJECT_ROOT = Path(__file__).resolve().parents[2]
SCHEMA_DIR = PROJECT_ROOT / "config" / "schema"
SCENES = ("channel", "heap", "silo")
RUNGS = ("smoke", "demo", "study", "paper")


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


def yaml_load(text: str):
    """Parse YAML text with :class:`_Loader`."""
    return yaml.load(text, Loader=_Loader)


class ConfigError(ValueError):
    """Invalid configuration; the message names key, value and allowed range."""


def load_yaml(path: str | Path) -> dict:
    path = Path(path)
    if not path.is_file():
        raise ConfigError(f"config file not found: {path}")
    try:
        data = yaml_load(path.read_text())
    except yaml.YAMLError as exc:
        raise ConfigError(f"{path}: not valid YAML: {exc}") from None
    if not isinstance(data, dict):
        raise ConfigError(f"{path}: top level must be a mapping, got {type(data).__name__}")
    return data


def load_schema(name: str) -> dict:
    """Schema ``config/schema/<name>.schema.yaml`` as a dict."""
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
        value = yaml_load(raw)
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
    if err.validator == "type":
        return f"{source}: {key} = {err.instance!r} has the wrong type: allowed {_allowed(err.schema)}{tail}"
    return f"{source}: {key} = {err.instance!r}: {err.message}{tail}"


def validate(data: dict, schema_name: str, source: str = "config") -> None:
    """Validate ``data`` against a named schema; raise :class:`ConfigError` listing every problem."""
    schema = load_schema(schema_name)
    validator = jsonschema.Draft202012Validator(schema)
    errors = sorted(validator.iter_errors(data), key=lambda e: (list(map(str, e.absolute_path)), e.validator))
    if errors:
        raise ConfigError("\n".join(_format_error(e, source) for e in errors))


def _check(cond: bool, msg: str) -> None:
    if not cond:
        raise ConfigError(msg)


def _check_channel(scene: dict, source: str) -> None:
    p = scene["particles"]
    _check(len(p["diameters"]) == len(p["number_fractions"]),
           f"{source}: particles.number_fractions has {len(p['number_fractions'])} entries, "
           f"particles.diameters has {len(p['diameters'])}: allowed only equal lengths")
    total = sum(p["number_fractions"])
    _check(math.isclose(total, 1.0, abs_tol=1e-6),
           f"{source}: particles.number_fractions sum to {total:g}: allowed sum = 1")
    for name, r in scene["rungs"].items():
        W = r["W"]
        _check(2 * r["wall_bin_width"] + r["bin_width"] <= W,
               f"{source}: rungs.{name}.W = {W} leaves no interior bin: allowed W >= "
               f"2*wall_bin_width + bin_width = {2 * r['wall_bin_width'] + r['bin_width']}")
        _check(r["t_segment"] <= r["t_flow_max"],
               f"{source}: rungs.{name}.t_segment = {r['t_segment']}: allowed <= t_flow_max = {r['t_flow_max']}")


def _check_heap(scene: dict, source: str) -> None:
    for name, mix in scene["particles"]["mixtures"].items():
        d, f = mix["diameters"], mix["volume_fractions"]
        _check(len(d) == len(f), f"{source}: particles.mixtures.{name}.volume_fractions has {len(f)} entries, "
                                 f"diameters has {len(d)}: allowed only equal lengths")
        _check(math.isclose(sum(f), 1.0, abs_tol=1e-6),
               f"{source}: particles.mixtures.{name}.volume_fractions sum to {sum(f):g}: allowed sum = 1")
        _check(list(d) == sorted(d), f"{source}: particles.mixtures.{name}.diameters = {d}: "
                                     f"allowed only increasing (species 1 is the small one)")
    mix = scene["case"]["mixture"]
    _check(mix in scene["particles"]["mixtures"],
           f"{source}: case.mixture = {mix!r} is not allowed: allowed one of "
           f"{', '.join(map(repr, scene['particles']['mixtures']))}")
    for name, r in scene["rungs"].items():
        _check(r["feed_width"] < r["W"], f"{source}: rungs.{name}.feed_width = {r['feed_width']}: "
                                         f"allowed < W = {r['W']}")


def _check_silo(scene: dict, source: str) -> None:
    f = scene["particles"]["radius_fractions"]
    _check(list(f) == sorted(f) and len(set(f)) == len(f),
           f"{source}: particles.radius_fractions = {f}: allowed only strictly increasing (type 1 is the smallest)")
    _check(set(scene["effects"]["walls"]) == {"side", "floor"},
           f"{source}: effects.walls = {scene['effects']['walls']}: allowed [side, floor] (the silo needs both)")
    _check(not scene["effects"]["reinsert"] or scene["effects"]["deletion"],
           f"{source}: effects.reinsert = true needs effects.deletion = true: allowed reinsert only with deletion")


def validate_scene(scene: dict, source: str = "scene") -> dict:
    """Schema plus cross-field checks of a scene file; returns it unchanged."""
    name = scene.get("scene")
    if name not in SCENES:
        raise ConfigError(f"{source}: scene = {name!r} is not allowed: allowed one of {', '.join(map(repr, SCENES))}")
    validate(scene, name, source)
    {"channel": _check_channel, "heap": _check_heap, "silo": _check_silo}[name](scene, source)
    for rname, r in scene["rungs"].items():
        _check(r["dump_interval"] <= r["t_average"],
               f"{source}: rungs.{rname}.dump_interval = {r['dump_interval']}: allowed <= t_average = {r['t_average']}")
        _check(r["thermo_interval"] <= r["t_segment"],
               f"{source}: rungs.{rname}.thermo_interval = {r['thermo_interval']}: allowed <= t_segment = {r['t_segment']}")
    return scene


def load_scene(path: str | Path, overrides: Iterable[str] = ()) -> dict:
    """Load, override and validate a scene file."""
    data = apply_overrides(load_yaml(path), overrides)
    return validate_scene(data, source=str(path))


def load_campaign(path: str | Path, overrides: Iterable[str] = (), root: Path | None = None) -> dict:
    """Load, override and validate the campaign file and every enabled scene file.

    Returns the campaign dict with each enabled scene's validated file content
    under ``scenes.<name>.scene``.
    """
    data = apply_overrides(load_yaml(path), overrides)
    root = Path(root) if root else Path(path).resolve().parent.parent
    return validate_campaign(data, root, source=str(path))


def validate_campaign(data: dict, root: Path, source: str = "config") -> dict:
    """Validate a campaign dict (e.g. Snakemake's ``config``) and load its scene files.

    Scene file paths are relative to ``root``. Returns a copy with each enabled
    scene's validated content under ``scenes.<name>.scene``.
    """
    data = copy.deepcopy(data)
    path = source
    validate(data, "config", source=source)
    for name, sc in data.get("scenes", {}).items():
        if not sc.get("enabled", True):
            continue
        scene_path = Path(sc["scene_file"])
        if not scene_path.is_absolute():
            scene_path = root / scene_path
        scene = load_scene(scene_path)
        rung = data["rung"]
        _check(rung in scene["rungs"],
               f"{path}: rung = {rung!r} is not defined in {scene_path}: allowed {', '.join(scene['rungs'])}")
        if name == "channel":
            _check_channel_sweep(sc, scene, rung, path)
        elif name == "heap":
            _check_heap_sweep(sc, scene, rung, path)
        elif name == "silo":
            _check_silo_sweep(sc, scene, rung, path)
        sc["scene"] = scene
    if data.get("cost"):
        data["cost_studies"] = _cost_studies(data, root, source)
    return data


def _cost_studies(data: dict, root: Path, source: str) -> dict:
    """Every scene study of the ``cost`` section, its variant scenes validated and preflighted."""
    from .cost import CostStudy  # deferred: cost builds on this module
    from .deck import scene_parameters
    from .preflight import PreflightError

    studies = {}
    for name, study in (data["cost"].get("scenes") or {}).items():
        if not study.get("enabled", True):
            continue
        sc = data.get("scenes", {}).get(name) or {}
        scene_path = Path(sc.get("scene_file") or f"config/scenes/{name}.yaml")
        scene = sc.get("scene") or load_scene(scene_path if scene_path.is_absolute() else root / scene_path)
        cs = CostStudy(name, scene, study, source=f"{source}: cost")
        for run, variant in cs.scenes.items():
            try:
                scene_parameters(variant, cs.rung)
            except (PreflightError, ValueError) as exc:
                raise ConfigError(f"{source}: cost.scenes.{name} run {run!r} is not allowed: {exc}") from None
        studies[name] = cs
    return studies


def _check_channel_sweep(sc: dict, scene: dict, rung: str, path: str) -> None:
    """Every channel sweep point must pass the scene's own case bounds."""
    for W in sc["sweep"].get("W", [None]):
        for phi in sc["sweep"].get("phi_mean", [scene["case"]["phi_mean"]]):
            case = dict(scene["case"], phi_mean=phi, W=W)
            validate(dict(scene, case=case), scene["scene"], source=f"{path} (sweep point W={W}, phi_mean={phi})")
            rW = W if W is not None else scene["rungs"][rung]["W"]
            r = scene["rungs"][rung]
            _check(2 * r["wall_bin_width"] + r["bin_width"] <= rW,
                   f"{path}: scenes.channel.sweep.W = {rW} leaves no interior bin: allowed W >= "
                   f"{2 * r['wall_bin_width'] + r['bin_width']}")


def _check_heap_sweep(sc: dict, scene: dict, rung: str, path: str) -> None:
    """Every heap sweep point: a known mixture, and a feed rate the feed zone can deliver."""
    from .preflight import PreflightError
    from .scenes.heap.parameters import feed_plan  # deferred: the deck package imports this module

    for mix in sc["sweep"].get("mixture", [scene["case"]["mixture"]]):
        _check(mix in scene["particles"]["mixtures"],
               f"{path}: scenes.heap.sweep.mixture = {mix!r} is not allowed: allowed one of "
               f"{', '.join(map(repr, scene['particles']['mixtures']))}")
        for rate in sc["sweep"].get("feed_rate", [scene["case"]["feed_rate"]]):
            case = dict(scene["case"], feed_rate=rate, mixture=mix)
            try:
                feed_plan(scene, rung, case)
            except PreflightError as exc:
                raise ConfigError(f"{path}: scenes.heap.sweep.feed_rate = {rate} (mixture {mix}, rung {rung}) "
                                  f"is not allowed: {exc}") from None


def _check_silo_sweep(sc: dict, scene: dict, rung: str, path: str) -> None:
    """Every orifice radius of the sweep must fit the rung's silo."""
    R_c = scene["rungs"][rung]["R_c"]
    for R in sc["sweep"].get("R", [scene["case"]["R"]]):
        _check(R <= R_c - 2, f"{path}: scenes.silo.sweep.R = {R} (in r_b) does not fit the {rung} silo of "
                             f"R_c = {R_c} r_b: allowed 1 <= R <= R_c - 2 = {R_c - 2}")


def check_rung(scene: dict, rung: str, source: str = "--rung") -> dict:
    """Return the rung preset, or refuse an unknown rung name."""
    if rung not in scene["rungs"]:
        raise ConfigError(f"{source} = {rung!r} does not exist: allowed {', '.join(scene['rungs'])}")
    return scene["rungs"][rung]
