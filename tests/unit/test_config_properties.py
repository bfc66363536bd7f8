"""Bad input never gets through: property-based tests (Hypothesis) over the configuration schemas.

Every numeric key of ``config/schema/*.schema.yaml`` is found by walking each schema over its
real file (rung presets under ``rungs.<rung>``, ``$defs`` references, items of number arrays,
the heap's named mixtures, the campaign's size limits, cost study and sweep values), so a key
added to a schema is covered without editing this file. For every such key, NaN, +-inf, values
just outside its range, huge values and values of the wrong type (strings, lists, mappings,
booleans, null) are applied as a ``--set`` override to the real file and loaded; each must be
refused with a :class:`~granflow.config.ConfigError` (or
:class:`~granflow.preflight.PreflightError`) naming the dotted key and the value, and no other
exception may escape. The command line is checked the same way on drawn keys: exit 2,
"refused" with the key, no traceback, nothing written. Two further properties: a value at
the edge of its range, applied to a case its rung accepts, is either accepted (the loaded
scene holds exactly that value and the deck's numbers are finite) or refused naming the
file, the key or the rung, and the bound; a cost-study knob value meets the bounds of the
scene key it sets.

Fixed lists of cases (every key's NaN, infinities, edges, huge values; the in-range edges)
are each tried once, in a loop. Drawn cases come from Hypothesis with a fixed, seeded budget
in ``make test`` (profile ``granflow``, tests/conftest.py) and 20 times that from a fresh
seed in ``make test-thorough`` (``GRANFLOW_THOROUGH=1``). Run with
``pytest tests/unit/test_config_properties.py --hypothesis-show-statistics`` to see how many
examples each test drew.
"""
from __future__ import annotations

import copy
import hashlib
import json
import math
import os
import re
import shutil
from dataclasses import dataclass
from pathlib import Path

import pytest
from hypothesis import HealthCheck, Phase, given, settings
from hypothesis import strategies as st

from granflow import campaign, config, registry, scene_files, schema
from granflow.campaign import load_campaign
from granflow.cli import EXIT_BAD_INPUT, main
from granflow.config import ConfigError, parse_override
from granflow.resources import check_size
from granflow.scene_files import load_scene
from granflow.cost import POST_KNOBS
from granflow.deck import scene_parameters
from granflow.preflight import PreflightError

ROOT = Path(__file__).resolve().parents[2]
CONFIG_DIR = ROOT / "config"
CAMPAIGN = CONFIG_DIR / "config.yaml"
#: every registered scene, whether the default campaign enables it or not: each scene file is checked
SCENES = registry.names()
REFUSED = (ConfigError, PreflightError)

#: seeded (derandomized) or not, example database and deadline (none) come from the profile
#: loaded by tests/conftest.py; a refusal takes ~4 ms once the files are parsed
PROPERTY = settings(suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])


def examples(n: int) -> int:
    """A drawing test's budget: ``n`` examples in ``make test`` (the ``granflow`` profile's
    ``max_examples`` is 100), 20 times as many in ``make test-thorough``."""
    return max(1, n * settings.default.max_examples // 100)

NONFINITE = (math.nan, math.inf, -math.inf)
#: huge magnitudes, float and integer (the largest double last): the first two are tried at
#: every key, all of them are drawn
HUGE = (1e300, 10**30, -1e300, -10**30, 1.7976931348623157e308)
#: an integer no double can hold (``math.isfinite`` raises OverflowError on it)
BEYOND_FLOAT = 10**400
#: raise the first failure as it is, without shrinking (a longer literal is no simpler case)
FIRST_FAILURE = {"report_multiple_bugs": False, "phases": (Phase.explicit, Phase.generate)}


def _yaml_data(path: Path):
    """A file as the loaders read it (granflow's YAML 1.2 reading)."""
    return config.yaml_load(path.read_text(), str(path))


#: the scenes and the cost studies the default campaign lists (a registered scene need not be among them)
CAMPAIGN_SCENES = tuple(_yaml_data(CAMPAIGN)["scenes"])
COST_SCENES = tuple((_yaml_data(CAMPAIGN).get("cost") or {}).get("scenes") or {})


# ------------------------------------------------------------------------------ the keys
@dataclass(frozen=True, repr=False)
class NumericKey:
    """One numeric leaf of a configuration file.

    Parameters
    ----------
    file : str
        ``"config"`` (the campaign) or a scene name: the file the key lives in.
    path : tuple
        Instance path from the file's top level; ``int`` entries index arrays.
    spec : dict
        The schema the value must satisfy (for sweep and cost ``set`` values: the scene
        schema's, which the campaign applies after its own).
    kind : str
        ``scene``, ``campaign``, ``sweep`` (``scenes.<s>.sweep.<key>[i]``) or ``set``
        (``cost.scenes.<s>.set.<dotted scene key>``).
    declared : str
        Pointer to the schema's declaration of the key (``#/$defs/rung/properties/W`` for
        ``rungs.<any rung>.W``).
    """

    file: str
    path: tuple
    spec: dict
    kind: str
    declared: str

    @property
    def dotted(self) -> str:
        """The key as refusals name it: ``rungs.smoke.W``, ``particles.diameters[1]``."""
        out = ""
        for p in self.path:
            out += f"[{p}]" if isinstance(p, int) else (f".{p}" if out else str(p))
        return out

    @property
    def integer(self) -> bool:
        return "integer" in _types(self.spec)

    @property
    def nullable(self) -> bool:
        return "null" in _types(self.spec)

    def needles(self, value) -> list[str]:
        """What a refusal of ``value`` must say: the dotted key with the value (``key = value``).

        A cost study's ``set`` value is refused either by the campaign schema (under its full
        key) or by the scene schema after it is applied (``cost.scenes.<s>.set: <scene key> = ...``);
        both messages hold the two parts below.
        """
        shown = repr(value) if len(repr(value)) <= 64 else repr(value)[:20]  # a long literal is cut
        if self.kind == "set":
            return [".".join(self.path[:4]), f"{self.path[4]} = {shown}"]
        return [f"{self.dotted} = {shown}"]

    def __str__(self) -> str:
        return f"{self.file}:{self.dotted}"

    __repr__ = __str__  # a failing example's arguments are printed: the key, not its schema

    def _repr_pretty_(self, printer, cycle) -> None:  # Hypothesis's printer
        printer.text(str(self))


class ParsedFiles(dict):
    """The parsed real files by file name (``config`` or the scene); printed by name only."""

    def __repr__(self) -> str:
        return f"<parsed {', '.join(self)}>"


def _types(spec: dict) -> set:
    t = spec.get("type", [])
    return {t} if isinstance(t, str) else set(t)


def _numeric(spec: dict) -> bool:
    return bool(_types(spec) & {"number", "integer"})


def _resolve(spec: dict, root: dict) -> dict:
    """Follow local ``$ref`` s (``#/$defs/rung``)."""
    while "$ref" in spec:
        assert spec["$ref"].startswith("#/"), spec
        node = root
        for part in spec["$ref"][2:].split("/"):
            node = node[part]
        spec = node
    return spec


def _leaves(spec: dict, root: dict, instance, path: tuple, pointer: str):
    """``(path, leaf schema, schema pointer)`` of every numeric leaf of ``instance``.

    Named properties are visited whether or not the file sets them; a section the file
    lacks is visited only if it could hold a single key (no ``required`` list: e.g. the
    campaign's ``limits``, not an absent ``rungs.validation``). ``additionalProperties``
    are visited for the names the file uses; of a number array, the first and last item.
    The pointer names the declaration: through a ``$ref``, the definition referred to.
    """
    pointer = spec.get("$ref", pointer)
    spec = _resolve(spec, root)
    if _numeric(spec):
        yield path, spec, pointer
        return
    if "properties" in spec or "additionalProperties" in spec:
        inst = instance if isinstance(instance, dict) else {}
        props = spec.get("properties", {})
        for name, sub in props.items():
            target = _resolve(sub, root)
            if name not in inst and not _numeric(target) and target.get("required"):
                continue
            yield from _leaves(sub, root, inst.get(name), path + (name,), f"{pointer}/properties/{name}")
        extra = spec.get("additionalProperties")
        if isinstance(extra, dict):
            for name in inst:
                if name not in props:
                    yield from _leaves(extra, root, inst[name], path + (name,), f"{pointer}/additionalProperties")
    if isinstance(spec.get("items"), dict) and _numeric(_resolve(spec["items"], root)):
        n = len(instance) if isinstance(instance, list) else 0
        for i in sorted({0, max(n - 1, 0)}):
            yield path + (i,), _resolve(spec["items"], root), f"{pointer}/items"


def numeric_leaf_pointers(spec: dict, root: dict, pointer: str = "#"):
    """Schema pointer of every numeric leaf the schema declares (to check the walk reached it)."""
    pointer = spec.get("$ref", pointer)
    spec = _resolve(spec, root)
    if _numeric(spec):
        yield pointer
        return
    for name, sub in spec.get("properties", {}).items():
        yield from numeric_leaf_pointers(sub, root, f"{pointer}/properties/{name}")
    if isinstance(spec.get("additionalProperties"), dict):
        yield from numeric_leaf_pointers(spec["additionalProperties"], root, f"{pointer}/additionalProperties")
    if isinstance(spec.get("items"), dict):
        yield from numeric_leaf_pointers(spec["items"], root, f"{pointer}/items")


def _scene_spec(root: dict, dotted: str) -> dict | None:
    """The leaf of a dotted scene-file key (``rungs.smoke.W``) in the scene schema ``root``, or None."""
    spec = root
    for part in dotted.split("."):
        spec = _resolve(spec, root)
        props = spec.get("properties", {})
        if part in props:
            spec = props[part]
        elif isinstance(spec.get("additionalProperties"), dict):
            spec = spec["additionalProperties"]
        else:
            return None
    return _resolve(spec, root)


def _without_null(spec: dict) -> dict:
    """A sweep lists values: null (the rung's default) is not one (as the campaign check does)."""
    spec = {k: v for k, v in spec.items() if k != "default"}
    if isinstance(spec.get("type"), list):
        spec["type"] = [t for t in spec["type"] if t != "null"]
    return spec


def enumerate_keys() -> tuple[dict, dict]:
    """``({file: [NumericKey]}, {file: (declared numeric leaves, leaves reached)})``."""
    keys, reach = {}, {}
    schemas = {name: schema.load_schema(name) for name in SCENES}
    for scene in SCENES:
        root = schemas[scene]
        found = list(_leaves(root, root, _yaml_data(CONFIG_DIR / "scenes" / f"{scene}.yaml"), (), "#"))
        keys[scene] = [NumericKey(scene, path, spec, "scene", ptr) for path, spec, ptr in found]
        reach[scene] = (set(numeric_leaf_pointers(root, root)), {ptr for _, _, ptr in found})
    root = schema.load_schema("config")
    found = list(_leaves(root, root, _yaml_data(CAMPAIGN), (), "#"))
    out = []
    for path, spec, ptr in found:
        if path[:1] == ("scenes",) and path[2:3] == ("sweep",):
            case = schemas[path[1]]["properties"]["case"]["properties"].get(path[3])
            if case is not None and _numeric(case):  # the heap's mixture axis is a name
                out.append(NumericKey("config", path, _without_null(case), "sweep", ptr))
        elif path[:1] == ("cost",) and path[3:4] == ("set",):
            target = _scene_spec(schemas[path[2]], path[4])
            if target is not None and _numeric(target):  # protocol.average_unsteady is a boolean
                out.append(NumericKey("config", path, target, "set", ptr))
        else:
            out.append(NumericKey("config", path, spec, "campaign", ptr))
    keys["config"] = out
    reach["config"] = (set(numeric_leaf_pointers(root, root)), {ptr for _, _, ptr in found})
    return keys, reach


KEYS_BY_FILE, REACHED = enumerate_keys()
ALL_KEYS = [k for keys in KEYS_BY_FILE.values() for k in keys]
SCENE_KEYS = [k for k in ALL_KEYS if k.kind == "scene"]


# ---------------------------------------------------------------------- bad values
def bounds(spec: dict):
    """``(low, low is exclusive, high, high is exclusive)``; None where unbounded."""
    lo = spec.get("minimum", spec.get("exclusiveMinimum"))
    hi = spec.get("maximum", spec.get("exclusiveMaximum"))
    return lo, "minimum" not in spec and lo is not None, hi, "maximum" not in spec and hi is not None


def just_outside(key: NumericKey) -> list:
    """The nearest refused values on each side: the bound itself if exclusive, else one ulp
    (or, for an integer, one) beyond it."""
    lo, lo_x, hi, hi_x = bounds(key.spec)
    out = []
    if hi is not None:
        out.append(hi if hi_x else (int(hi) + 1 if key.integer else math.nextafter(float(hi), math.inf)))
    if lo is not None:
        out.append(lo if lo_x else (int(lo) - 1 if key.integer else math.nextafter(float(lo), -math.inf)))
    return out


def fixed_bad_values(key: NumericKey) -> list:
    """NaN, +-inf, just outside both bounds, a huge float and a huge integer, a boolean (not
    a number in JSON Schema, though Python's ``True == 1``) and a quoted number."""
    return [*NONFINITE, *just_outside(key), *HUGE[:2], True, "1"]


def out_of_range(key: NumericKey) -> st.SearchStrategy:
    """Finite numbers (floats and integers) anywhere beyond either bound, and huge ones."""
    lo, lo_x, hi, hi_x = bounds(key.spec)
    parts = [st.sampled_from(HUGE)]
    if hi is not None:
        first_int = int(hi) if (hi_x and float(hi).is_integer()) else math.floor(hi) + 1
        parts.append(st.integers(min_value=first_int, max_value=10**18))
        if not key.integer:
            parts.append(st.floats(min_value=hi, exclude_min=not hi_x, allow_infinity=False))
    if lo is not None:
        last_int = int(lo) if (lo_x and float(lo).is_integer()) else math.ceil(lo) - 1
        parts.append(st.integers(min_value=-10**18, max_value=last_int))
        if not key.integer:
            parts.append(st.floats(max_value=lo, exclude_max=not lo_x, allow_infinity=False))
    return st.one_of(parts)


#: text that a user could type; control characters are left to PyYAML's own refusal
_TEXT = st.text(st.characters(min_codepoint=32, max_codepoint=0x2FF, exclude_categories=("Cc", "Cs")), max_size=8)


def wrong_type(key: NumericKey) -> st.SearchStrategy:
    """Values of a type the key does not take: strings, booleans (not numbers in JSON
    Schema), lists and mappings of valid numbers, null unless allowed, and for an integer
    key a non-integral number within the range."""
    lo, _, hi, _ = bounds(key.spec)
    inside = st.floats(min_value=lo, max_value=hi, allow_nan=False, allow_infinity=False,
                       exclude_min=True, exclude_max=True)
    parts = [st.booleans(), _TEXT, st.lists(inside, max_size=3),
             st.dictionaries(st.text("abcxyz_", min_size=1, max_size=4), inside, max_size=2)]
    if not key.nullable:
        parts.append(st.none())
    if key.integer:
        parts.append(inside.filter(lambda v: not v.is_integer()))
    return st.one_of(parts)


def bad_value(key: NumericKey) -> st.SearchStrategy:
    """Any of the above."""
    return st.one_of(st.sampled_from(fixed_bad_values(key)), out_of_range(key), wrong_type(key))


# ------------------------------------------------------------------- applying a value
def to_yaml(value) -> str:
    """Flow-style YAML that reads back as exactly ``value`` (strings always quoted, so that
    ``'1e5'`` stays a string; non-finite floats in YAML's spelling)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if value is None:
        return "null"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        if math.isnan(value):
            return ".nan"
        if math.isinf(value):
            return ".inf" if value > 0 else "-.inf"
        return repr(value)
    if isinstance(value, str):
        return json.dumps(value)
    if isinstance(value, list):
        return "[" + ", ".join(to_yaml(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{" + ", ".join(f"{json.dumps(str(k))}: {to_yaml(v)}" for k, v in value.items()) + "}"
    raise TypeError(value)


def _get(tree, path):
    for p in path:
        tree = tree[p]
    return tree


def _put(tree, path, value):
    """Set ``tree[path] = value``, creating mappings and extending lists on the way."""
    for i, p in enumerate(path[:-1]):
        new = list if isinstance(path[i + 1], int) else dict
        if isinstance(p, int):
            while len(tree) <= p:
                tree.append(new())
        elif tree.get(p) is None:
            tree[p] = new()
        tree = tree[p]
    if isinstance(path[-1], int):
        while len(tree) <= path[-1]:
            tree.append(None)
    tree[path[-1]] = value


def _cut(key: NumericKey) -> int:
    """Length of the part of ``key.path`` that ``--set`` can address (dotted mapping names)."""
    return next((j for j, p in enumerate(key.path) if isinstance(p, int) or "." in p), len(key.path))


def override(data: dict, key: NumericKey, value) -> str:
    """A ``--set KEY=VALUE`` that puts ``value`` at ``key`` in ``data``.

    ``--set`` addresses mappings by dotted names, so a key below an array item or a name
    with a dot in it (the heap's ``mono1.5``, a cost ``set`` key) is reached by setting the
    nearest addressable ancestor to its whole content with the one value changed.
    """
    cut = _cut(key)
    if cut == len(key.path):
        target, text = key.path, to_yaml(value)
    else:
        target = key.path[:cut]
        try:
            sub = copy.deepcopy(_get(data, target))
        except (KeyError, IndexError, TypeError):
            sub = [] if isinstance(key.path[cut], int) else {}
        _put(sub, key.path[cut:], value)
        text = to_yaml(sub)
    return f"{'.'.join(target)}={text}"


def _file(key: NumericKey) -> Path:
    return CAMPAIGN if key.file == "config" else CONFIG_DIR / "scenes" / f"{key.file}.yaml"


def _speedups(key: NumericKey) -> list[str]:
    """For a sweep or cost ``set`` value, switch the other scenes off: the value is checked
    by its own scene, after every enabled scene before it in the file (~250 ms for all four)."""
    scene = key.path[1] if key.kind == "sweep" else key.path[2]
    out = [f"scenes.{s}.enabled=false" for s in CAMPAIGN_SCENES if s != scene]
    if key.kind == "set":
        out += [f"cost.scenes.{s}.enabled=false" for s in COST_SCENES if s != scene]
    return out


def load(key: NumericKey, overrides: list[str]):
    if key.file == "config":
        deep = key.kind in ("sweep", "set")
        return load_campaign(CAMPAIGN, overrides + (_speedups(key) if deep else []), root=ROOT)
    return load_scene(_file(key), overrides)


def assert_refused(key: NumericKey, value, file_data: dict) -> str:
    """``value`` at ``key`` is refused by the loader with the key and the value named."""
    text = override(file_data, key, value)
    with pytest.raises(REFUSED) as info:
        load(key, [text])  # any other exception escapes and fails the test
    msg = str(info.value)
    for needle in key.needles(value):
        assert needle in msg, f"--set {text}: {needle!r} not in the refusal:\n{msg}"
    return msg


def check_each(cases: list, check) -> None:
    """``check(key, value)`` on every case, each once; fail naming every case that failed. An
    exception other than an AssertionError stops at once, chained to the case it escaped from."""
    failed = []
    for key, value in cases:
        try:
            check(key, value)
        except AssertionError as exc:
            failed.append(f"{key} = {value!r}: {exc}")
        except Exception as exc:  # noqa: BLE001 - named with its case, then failed
            raise AssertionError(f"{key} = {value!r}: {type(exc).__name__} escaped: {exc}") from exc
    assert not failed, f"{len(failed)} of {len(cases)} cases failed:\n" + "\n".join(failed)


# ------------------------------------------------------------------------------ fixtures
def _tree_digest(path: Path) -> dict:
    return {str(p.relative_to(path)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(path.rglob("*")) if p.is_file()}


@pytest.fixture(scope="module", autouse=True)
def config_untouched():
    """Nothing the tests refuse writes to (or anywhere under) config/."""
    before = _tree_digest(CONFIG_DIR)
    yield
    assert _tree_digest(CONFIG_DIR) == before, "a refused configuration changed a file under config/"


@pytest.fixture(scope="module")
def file_data() -> dict:
    """The parsed real files, by file name (``config`` or the scene)."""
    return ParsedFiles(config=_yaml_data(CAMPAIGN),
                       **{s: _yaml_data(CONFIG_DIR / "scenes" / f"{s}.yaml") for s in SCENES})


@pytest.fixture(scope="module")
def parsed_files() -> dict:
    return {}


@pytest.fixture
def parse_once(monkeypatch, parsed_files):
    """Parse each scene and campaign file once per module, and share each schema.

    Pure-Python PyYAML takes ~30 ms per scene file and :func:`granflow.schema.load_schema`
    ~3 ms to copy a parsed schema, against ~3 ms for the validation itself. The loaders
    still apply each override to a fresh copy (``apply_overrides``) and run every check;
    they only read a schema. The command-line tests below load everything for real.
    """
    real_yaml, real_schema = scene_files.load_yaml, schema.load_schema

    def load_yaml(path):
        path = Path(path).resolve()
        if path not in parsed_files:
            parsed_files[path] = real_yaml(path)
        return parsed_files[path]

    def load_schema(name):
        if name not in parsed_files:
            parsed_files[name] = real_schema(name)
        return parsed_files[name]

    monkeypatch.setattr(scene_files, "load_yaml", load_yaml)
    monkeypatch.setattr(campaign, "load_yaml", load_yaml)
    monkeypatch.setattr(schema, "load_schema", load_schema)
    monkeypatch.setattr(scene_files, "load_schema", load_schema)


# --------------------------------------------------------------------------- the walk
#: at least this many numeric keys per file (counted on the files of this commit: channel 89,
#: heap 131, silo 92, chute 86, config 73); fewer means the walk lost a part of a schema
MIN_KEYS = {"channel": 80, "heap": 80, "silo": 80, "chute": 70, "config": 50}


def test_every_numeric_key_is_found():
    counts = {f: len(keys) for f, keys in KEYS_BY_FILE.items()}
    for f, n in MIN_KEYS.items():
        assert counts[f] >= n, counts
    for f, (declared, reached) in REACHED.items():
        assert declared <= reached, f"{f}: numeric keys of the schema the walk did not reach: {declared - reached}"
    kinds = {k.kind for k in ALL_KEYS}
    assert kinds == {"scene", "campaign", "sweep", "set"}, kinds
    # the forms the issue names: per-rung keys, array items, $defs-referenced campaign values
    names = {str(k) for k in ALL_KEYS}
    for example in ("channel:rungs.smoke.W", "chute:rungs.paper.k_n", "heap:particles.mixtures.mono1.5.diameters[0]",
                    "silo:cg.w_scan[2]", "config:cost.noise_sigmas", "config:cost.scenes.silo.knobs.stiffness[0]",
                    "config:scenes.chute.sweep.theta_deg[3]", "config:cost.scenes.channel.set.rungs.smoke.W",
                    "config:max_particles"):
        assert example in names, example


def test_every_numeric_key_is_bounded():
    """Both ends bounded, so no huge value passes as 'in range' (the sweep and cost ``set``
    values by their scene key's bounds)."""
    unbounded = [str(k) for k in ALL_KEYS if None in (bounds(k.spec)[0], bounds(k.spec)[2])]
    assert not unbounded, unbounded


#: a case each rung accepts with the files as they stand: the scene's own case, except where it
#: does not fit the smoke rung (the heap's 0.033 kg/s overfills its feed region, the silo's
#: R = 6 r_b does not fit its R_c = 6 r_b); the integration tests' smoke runs use these values
BASE_CASES = {("heap", "smoke"): {"feed_rate": 0.003}, ("silo", "smoke"): {"R": 4.0}}
#: size limits every rung of the real files meets (the default, a week of this machine's cores,
#: refuses the channel's and the silo's paper rungs on 2 cores), so that a refusal in
#: test_in_range_extremes_are_accepted_or_refused is the edge value's doing
LIMITS = {"max_cpu_hours": 1e5, "memory_mb": 10**7}


def _particles(estimate) -> int:
    """The particle count of what :func:`check_size` returns (an estimate, or the count itself)."""
    return getattr(estimate, "particles", estimate)


def test_the_real_files_are_valid(file_data, parse_once):
    """The values the refusals are measured against are themselves accepted: each loader hands
    back every numeric value of its file unchanged (value and type), and every rung of every
    scene passes the size check and gives finite deck numbers at its base case."""
    for scene in SCENES:
        path = CONFIG_DIR / "scenes" / f"{scene}.yaml"
        loaded = load_scene(path)
        for key in KEYS_BY_FILE[scene]:
            _assert_same_value(loaded, file_data[scene], key)
        for rung in loaded["rungs"]:
            case = BASE_CASES.get((scene, rung))
            n = _particles(check_size(scene, loaded, rung, case, LIMITS, str(path), f"{scene} at rung {rung}"))
            assert isinstance(n, int) and n > 0, (scene, rung, n)
            _assert_finite_deck(*scene_parameters(loaded, rung, case), f"{scene} at rung {rung}")
    loaded = load_campaign(CAMPAIGN, root=ROOT)
    for key in KEYS_BY_FILE["config"]:
        _assert_same_value(loaded, file_data["config"], key)


def _assert_same_value(loaded: dict, data: dict, key: NumericKey) -> None:
    """The loaded tree holds the file's value at ``key`` (or lacks it, as the file does)."""
    try:
        want = _get(data, key.path)
    except (KeyError, IndexError, TypeError):
        return
    got = _get(loaded, key.path)
    assert got == want and type(got) is type(want), f"{key}: file {want!r}, loaded {got!r}"


def _assert_finite_deck(params, context, label: str) -> None:
    """Every deck number is a finite int or float, and the parameter record (params.json) holds no NaN."""
    for p in params:
        assert type(p.value) in (int, float) and math.isfinite(p.value), f"{label}: deck variable {p.name} = {p.value!r}"

    def nans(node, where):
        if isinstance(node, dict):
            for k, v in node.items():
                yield from nans(v, f"{where}.{k}")
        elif isinstance(node, (list, tuple)):
            for i, v in enumerate(node):
                yield from nans(v, f"{where}[{i}]")
        elif isinstance(node, float) and math.isnan(node):
            yield where

    found = list(nans(context["record"], "record"))
    assert not found, f"{label}: NaN in the parameter record at {found}"


# ------------------------------------------------------------------- the properties
@settings(PROPERTY, max_examples=examples(300))
@given(data=st.data())
def test_overrides_carry_the_drawn_value(data, file_data):
    """The ``--set`` text the tests build reads back as exactly the drawn value at the key
    (so a refusal below is the refusal of that value, not of a mangled one)."""
    key = data.draw(st.sampled_from(ALL_KEYS), label="key")
    value = data.draw(bad_value(key), label="value")
    text = override(file_data[key.file], key, value)
    parts, parsed = parse_override(text)
    cut = _cut(key)
    assert tuple(parts) == key.path[:cut], text
    assert repr(_get(parsed, key.path[cut:])) == repr(value), (text, value)


def _declarations() -> dict:
    """The keys grouped by declaration: same file, same schema declaration, same bounds (the
    five rungs' ``W``, the heap's ten mixture diameters, the 40 cost-knob values), each group
    named by its first key and how many more share it."""
    groups = {}
    for k in ALL_KEYS:
        groups.setdefault((k.file, k.declared, json.dumps(k.spec, sort_keys=True)), []).append(k)
    return {str(g[0]) + (f"(+{len(g) - 1})" if len(g) > 1 else ""): g for g in groups.values()}


DECLARATIONS = _declarations()


def _fixed_cases(keys: list) -> list:
    """Every fixed bad value at the first key; NaN and one step outside each bound at every
    other key of the declaration (its type check and its range check at that place)."""
    cases = [(keys[0], v) for v in fixed_bad_values(keys[0])]
    return cases + [(k, v) for k in keys[1:] for v in (math.nan, *just_outside(k))]


@pytest.mark.parametrize("keys", DECLARATIONS.values(), ids=DECLARATIONS.keys())
def test_nonfinite_edge_and_huge_values_are_refused(keys, file_data, parse_once):
    """NaN, +inf, -inf, one step outside each bound, 1e300, 10**30, ``true`` and ``"1"``, at
    every key (see :func:`_fixed_cases`), each once."""
    check_each(_fixed_cases(keys), lambda key, value: assert_refused(key, value, file_data[key.file]))


@pytest.mark.parametrize("keys", DECLARATIONS.values(), ids=DECLARATIONS.keys())
@settings(PROPERTY, max_examples=examples(5))
@given(data=st.data())
def test_out_of_range_and_wrong_types_are_refused(keys, data, file_data, parse_once):
    """Drawn, at a drawn key of the declaration: finite or huge numbers anywhere outside the
    range, strings, booleans, lists, mappings, null (unless allowed), non-integral numbers
    for an integer key. A sweep or cost ``set`` value meets the bounds of the scene key it
    sets (a campaign validation each)."""
    key = data.draw(st.sampled_from(keys), label="key")
    value = data.draw(st.one_of(out_of_range(key), wrong_type(key)), label="value")
    assert_refused(key, value, file_data[key.file])


BEYOND_FLOAT_CASES = [(keys[0], sign * BEYOND_FLOAT) for keys in DECLARATIONS.values() for sign in (1, -1)]


def test_integers_beyond_the_float_range_are_refused(file_data, parse_once):
    """YAML reads ``1`` followed by 400 zeros as a Python int, larger than any double: refused
    at the first key of every declaration, either sign (every case once)."""
    check_each(BEYOND_FLOAT_CASES, lambda key, value: assert_refused(key, value, file_data[key.file]))


DIRECT_KEYS = [keys[0] for keys in DECLARATIONS.values() if _cut(keys[0]) == len(keys[0].path)]


@settings(PROPERTY, max_examples=examples(10), **FIRST_FAILURE)
@given(data=st.data(), digits=st.integers(min_value=4301, max_value=20000), in_file=st.booleans())
def test_integer_literals_too_long_to_read_are_refused(data, digits, in_file, tmp_path, file_data, parse_once):
    """An integer literal longer than Python converts (4300 digits), in the file or in ``--set``:
    refused naming the key, like any other bad value."""
    key = data.draw(st.sampled_from(DIRECT_KEYS), label="key")
    literal = "1" + "0" * digits
    if in_file:  # the file with the literal in place of a placeholder value
        path = tmp_path / _file(key).name
        text = to_yaml(config.apply_overrides(file_data[key.file], [f"{key.dotted}=123456789.5"]))
        path.write_text(text.replace("123456789.5", literal))
        overrides = []
    else:
        path, overrides = _file(key), [f"{key.dotted}={literal}"]
    with pytest.raises(REFUSED) as info:
        if key.file == "config":
            load_campaign(path, overrides, root=ROOT)
        else:
            load_scene(path, overrides)
    assert key.dotted in str(info.value), str(info.value)[:500]


# ------------------------------------------------------------- in range: never a crash
def in_range_extremes(key: NumericKey) -> list:
    """The smallest and largest allowed values (the smallest double above an exclusive 0),
    and above an exclusive 0 also 1e-12: tiny, yet in range."""
    lo, lo_x, hi, hi_x = bounds(key.spec)
    if key.integer:
        return [int(lo) + lo_x, int(hi) - hi_x]
    low = (5e-324 if lo == 0 else math.nextafter(float(lo), math.inf)) if lo_x else lo
    high = math.nextafter(float(hi), -math.inf) if hi_x else hi
    return [low, high] + ([1e-12] if lo_x and lo == 0 else [])


# The crashes these properties found (tiny time steps, densities and V_c; ints beyond a double;
# over-long literals; unchecked post-processing knobs) are fixed: every in-range edge must pass.
def _in_range_params() -> list:
    return [pytest.param(keys, id=name) for name, keys in DECLARATIONS.items() if keys[0].kind == "scene"]


def _names_key(msg: str, key: NumericKey) -> bool:
    """The refusal names the key: its own name (``t_segment``, ``number_fractions`` for an
    item of that array) as a word, as cross-key refusals do (``dump_interval = 1.0: allowed <=
    t_average = 1e-12``)."""
    name = next(p for p in reversed(key.path) if isinstance(p, str))
    return re.search(rf"(?<!\w){re.escape(name)}(?!\w)", msg) is not None


def assert_in_range_outcome(key: NumericKey, value, file_data: dict) -> None:
    """What ``granflow render`` does before it writes (load, size check, deck parameters with
    their preflight), at the key's rung (else demo) and a case that rung accepts unchanged
    (:data:`BASE_CASES`), with ``value`` at ``key``: either accepted, and then the loaded scene
    holds exactly ``value`` (same type) and the deck's numbers are finite; or refused with a
    ConfigError or PreflightError that names the bound ("allowed" or "limit") and the file and
    the key (load), the scene at its rung (size check) or the key (deck parameters). No other
    exception."""
    rung = key.path[1] if key.path[0] == "rungs" else "demo"
    case, label = BASE_CASES.get((key.file, rung)), f"{key.file} at rung {rung}"
    text = override(file_data, key, value)
    try:
        scene = load_scene(_file(key), [text])
    except REFUSED as exc:
        msg = str(exc)
        assert msg.startswith(f"{_file(key)}: ") and ("allowed" in msg or "limit" in msg), msg
        assert _names_key(msg, key), f"the load refusal does not name {key}: {msg}"
        return
    got = _get(scene, key.path)
    assert got == value and type(got) is type(value), f"--set {text} loaded as {got!r}"
    try:
        n = _particles(check_size(key.file, scene, rung, case, LIMITS, str(_file(key)), label))
    except REFUSED as exc:
        msg = str(exc)
        assert label in msg and ("allowed" in msg or "limit" in msg), msg
        return
    assert isinstance(n, int) and n > 0, f"--set {text}: {n!r} particles"
    try:  # the size check derives the parameters of most scenes already; the silo's counts by formula
        params, context = scene_parameters(scene, rung, case)
    except REFUSED as exc:
        msg = str(exc)
        assert ("allowed" in msg or "limit" in msg) and _names_key(msg, key), msg
        return
    _assert_finite_deck(params, context, f"--set {text}")


@pytest.mark.parametrize("keys", _in_range_params())
def test_in_range_extremes_are_accepted_or_refused(keys, file_data, parse_once):
    """The edge of the range is a value too: each of :func:`in_range_extremes` at the first key
    of the declaration, once, gives one of the outcomes of :func:`assert_in_range_outcome`."""
    key = keys[0]
    check_each([(key, v) for v in in_range_extremes(key)],
               lambda key, value: assert_in_range_outcome(key, value, file_data[key.file]))


@pytest.mark.parametrize("scene", SCENES)
@pytest.mark.parametrize("knob", POST_KNOBS)
def test_cost_post_processing_knobs_meet_their_scene_bounds(scene, knob, file_data, parse_once):
    """A cost-study knob value is a value of a scene key: ten times that key's largest allowed
    value (well inside the knob schema's 1e12) is refused, naming the knob. A scene without a
    cost study, or whose study the default campaign does not hold, is skipped, saying so."""
    sc = registry.get(scene)
    if not sc.gives("cost_study"):
        pytest.skip(f"the {scene} scene declares no cost study")
    if scene not in COST_SCENES:
        pytest.skip(f"the default campaign holds no cost study of the {scene} scene")
    target = sc.knobs[knob].keys[0].format(r=file_data["config"]["cost"]["scenes"][scene]["base_rung"])
    spec = _scene_spec(schema.load_schema(scene), target)
    value = 10.0 * bounds(spec)[2]
    values = [*file_data["config"]["cost"]["scenes"][scene]["knobs"][knob], value]
    others = [f"scenes.{s}.enabled=false" for s in CAMPAIGN_SCENES if s != scene]
    others += [f"cost.scenes.{s}.enabled=false" for s in COST_SCENES if s != scene]
    with pytest.raises(REFUSED) as info:
        load_campaign(CAMPAIGN, [f"cost.scenes.{scene}.knobs.{knob}={to_yaml(values)}", *others], root=ROOT)
    assert f"cost.scenes.{scene}.knobs.{knob}" in str(info.value), str(info.value)


# ---------------------------------------------------------------------- the command line
@pytest.fixture(scope="module")
def workdir(tmp_path_factory) -> Path:
    """A copy of config/ to run the command line in (its campaign finds its scene files
    relative to the working directory); the tests check that it stays as it is."""
    base = tmp_path_factory.mktemp("cli")
    shutil.copytree(CONFIG_DIR, base / "config")
    return base


def _run(capsys, argv) -> tuple[int, str]:
    capsys.readouterr()
    rc = main(argv)
    return rc, capsys.readouterr().err


def _assert_cli_refused(rc, err, key, value, argv):
    assert rc == EXIT_BAD_INPUT, (argv, rc, err)
    assert "granflow: refused:" in err and "Traceback" not in err, err
    for needle in key.needles(value):
        assert needle in err, (needle, err)


@settings(PROPERTY, max_examples=examples(25))
@given(data=st.data(), in_file=st.booleans())
def test_check_config_refuses_and_writes_nothing(data, in_file, capsys, monkeypatch, workdir, file_data):
    """``granflow check-config FILE --set KEY=VALUE``, or the value written into the file:
    exit 2, 'refused' with the key and the value, no traceback, the directory unchanged."""
    key = data.draw(st.sampled_from(ALL_KEYS), label="key")
    value = data.draw(bad_value(key), label="value")
    monkeypatch.chdir(workdir)
    rel = _file(key).relative_to(ROOT)
    text = override(file_data[key.file], key, value)
    if in_file:  # the same value, read from a file by the YAML loader
        bad = workdir / "bad" / rel.name
        bad.parent.mkdir(exist_ok=True)
        bad.write_text(to_yaml(config.apply_overrides(file_data[key.file], [text])))
        argv, target = ["check-config", str(bad)], bad
    else:
        argv, target = ["check-config", str(rel), "--set", text], None
    before = _tree_digest(workdir)
    rc, err = _run(capsys, argv)
    _assert_cli_refused(rc, err, key, value, argv)
    assert _tree_digest(workdir) == before, "check-config wrote a file"
    if target:
        target.unlink()


@settings(PROPERTY, max_examples=examples(25))
@given(data=st.data())
def test_render_refuses_and_writes_nothing(data, capsys, monkeypatch, tmp_path, file_data):
    """``granflow render SCENE --rung smoke --out DIR --set KEY=VALUE``: refused, DIR not created."""
    key = data.draw(st.sampled_from(SCENE_KEYS), label="key")
    value = data.draw(bad_value(key), label="value")
    here = tmp_path / f"example{len(list(tmp_path.iterdir()))}"
    here.mkdir()
    monkeypatch.chdir(here)
    out = here / "x"
    text = override(file_data[key.file], key, value)
    argv = ["render", key.file, "--rung", "smoke", "--out", str(out), "--set", text]
    rc, err = _run(capsys, argv)
    _assert_cli_refused(rc, err, key, value, argv)
    assert not out.exists() or not any(out.iterdir()), f"render wrote {list(out.iterdir())}"
    assert os.listdir(here) == [], f"render wrote {os.listdir(here)} into the working directory"
