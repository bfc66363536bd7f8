"""Reading granflow's YAML: bounded work, one spelling per value, each key once.

Every campaign, scene and schema file is read by :func:`load_yaml` (and a ``--set`` value by
:func:`yaml_load`): at most :data:`MAX_DOCUMENT_BYTES`, :data:`MAX_NODES` with aliases expanded and
:data:`MAX_DEPTH` levels; a key given twice, a file that is not UTF-8 and a YAML 1.1 form that
YAML 1.2 reads otherwise (``on``, ``0123``, ``1:30``) are refused with a :class:`ConfigError`
naming the file, the key and its line. Moved out of :mod:`granflow.config`, which re-exports it.
"""
from __future__ import annotations

import re
from pathlib import Path
from typing import Iterable

import yaml


#: largest YAML document read, in bytes (the largest shipped file, a scene schema, has 10 kB; PyYAML's
#: pure-Python reader, needed for the checks below, takes about 2 s for this many on one core)
MAX_DOCUMENT_BYTES = 256 * 1024
#: most nodes (mappings, lists, scalars, keys) a document may hold with every alias expanded: an alias
#: counts as many nodes as the value it repeats, so nested anchors (an "alias bomb") cannot make the
#: checks and the schema validation that walk the data do exponential work (shipped files: at most 918)
MAX_NODES = 100_000
#: deepest nesting of mappings and lists, aliases expanded (shipped files: at most 11)
MAX_DEPTH = 32


class _Loader(yaml.SafeLoader):
    """Safe loader that reads ``1e5`` and ``1.0e5`` as floats (YAML 1.2), not strings, and bounds
    its work: while composing it refuses a document nested deeper than :data:`MAX_DEPTH`, one
    that expands through its aliases to more than :data:`MAX_NODES` nodes (each node's expanded
    size is summed from its children's, so a bomb is refused at the first value that exceeds the
    bound, without expanding it), and an alias inside the value it names (a cycle)."""

    def __init__(self, stream, source: str = "YAML"):
        super().__init__(stream)
        self.source = source
        self._nesting = 0
        #: id(node) -> (expanded nodes, expanded depth) of every completed node
        self._extent: dict[int, tuple[int, int]] = {}

    def compose_node(self, parent, index):
        event = self.peek_event()
        alias = event.anchor if isinstance(event, yaml.AliasEvent) else None
        mark = event.start_mark
        where = f"{self.source}: line {mark.line + 1}, column {mark.column + 1}"
        self._nesting += 1
        try:
            if self._nesting > MAX_DEPTH:
                raise ConfigError(f"{where}: the document is nested more than {MAX_DEPTH} levels deep: "
                                  f"allowed at most {MAX_DEPTH} levels of mappings and lists")
            node = super().compose_node(parent, index)
        finally:
            self._nesting -= 1
        if id(node) in self._extent:
            return node
        if alias:
            raise ConfigError(f"{where}: the alias *{alias} is inside the value its anchor names "
                              f"(a value that contains itself): allowed aliases of complete values only")
        children = (node.value if isinstance(node, yaml.SequenceNode) else
                    [n for pair in node.value for n in pair] if isinstance(node, yaml.MappingNode) else [])
        extents = [self._extent[id(c)] for c in children]
        nodes = 1 + sum(n for n, _ in extents)
        depth = 1 + max((d for _, d in extents), default=0)
        named = self.anchor_of(node) if nodes > MAX_NODES or depth > MAX_DEPTH else None
        line = (f"{self.source}: the value {'&' + named + ' ' if named else ''}at line {node.start_mark.line + 1}, "
                f"column {node.start_mark.column + 1}")
        if nodes > MAX_NODES:
            raise ConfigError(f"{line} holds {nodes:,} nodes, an alias counting as many as the value it repeats: "
                              f"allowed at most {MAX_NODES:,} nodes in a document (use fewer aliases or values)")
        if depth > MAX_DEPTH:
            raise ConfigError(f"{line} is nested {depth} levels deep with its aliases expanded: allowed at most "
                              f"{MAX_DEPTH} levels of mappings and lists")
        self._extent[id(node)] = (nodes, depth)
        return node

    def anchor_of(self, node) -> str | None:
        """The anchor naming ``node`` (for messages)."""
        return next((name for name, n in self.anchors.items() if n is node), None)


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


def _check_unambiguous(node, path: list, source: str, key: bool = False, loader: "_Loader | None" = None) -> None:
    """Refuse a plain scalar that YAML 1.1 and 1.2 read differently (see :data:`_AMBIGUOUS`), and a
    key given twice in one mapping (YAML would keep the last without a word; ``loader`` reads the
    keys, so ``1`` and ``1.0``, or ``a`` and ``"a"``, are the same key). The walk visits a node
    as often as aliases repeat it: :class:`_Loader` has bounded that at :data:`MAX_NODES`."""
    if isinstance(node, yaml.MappingNode):
        if loader is not None:
            _refuse_duplicate_keys(node, path, source, loader)
        for k, value in node.value:
            _check_unambiguous(k, path, source, key=True, loader=loader)
            _check_unambiguous(value, path + [k.value if isinstance(k, yaml.ScalarNode) else "?"], source,
                               loader=loader)
    elif isinstance(node, yaml.SequenceNode):
        for i, item in enumerate(node.value):
            _check_unambiguous(item, path + [i], source, loader=loader)
    elif (isinstance(node, yaml.ScalarNode) and node.style is None and len(node.value) > MAX_NUMBER_CHARS
          and node.tag in ("tag:yaml.org,2002:int", "tag:yaml.org,2002:float")):
        what = f"the key {node.value[:20]}..." if key else f"{dotted_path(path) if path else 'the value'} = {node.value[:20]}..."
        raise ConfigError(f"{source}: {what} (line {node.start_mark.line + 1}) has {len(node.value)} characters: "
                          f"allowed a number of at most {MAX_NUMBER_CHARS} characters")
    elif isinstance(node, yaml.ScalarNode) and node.style is None and node.tag in _AMBIGUOUS:
        pattern, fix = _AMBIGUOUS[node.tag]
        if pattern.match(node.value):
            read = yaml.load(node.value, Loader=yaml.SafeLoader)
            where = f" of {dotted_path(path)}" if path else ""
            what = (f"the key {node.value}{where}" if key
                    else f"{dotted_path(path)} = {node.value}" if path else node.value)
            raise ConfigError(
                f"{source}: {what} (line {node.start_mark.line + 1}) is ambiguous YAML: "
                f"YAML 1.1 (PyYAML, Snakemake) reads it as {read!r}, YAML 1.2 as {_yaml12(node.value)!r}; "
                f"allowed: {fix}")


def _refuse_duplicate_keys(node: yaml.MappingNode, path: list, source: str, loader: "_Loader") -> None:
    """Refuse a mapping that gives one key twice, naming the key and both lines (a ``<<`` merge
    key is not compared: the keys written beside it override the merged ones on purpose)."""
    seen = {}
    for k, _ in node.value:
        if not isinstance(k, yaml.ScalarNode) or k.tag == "tag:yaml.org,2002:merge":
            continue
        try:
            key = loader.construct_object(k)
            hash(key)
        except (yaml.YAMLError, TypeError):
            continue  # the constructor refuses it with its own message
        if key in seen:
            where = f" of {dotted_path(path)}" if path else " at the top level"
            first, second = seen[key].start_mark, k.start_mark
            lines = (f"on line {first.line + 1} and line {second.line + 1}" if first.line != second.line else
                     f"on line {first.line + 1} (columns {first.column + 1} and {second.column + 1})")
            raise ConfigError(
                f"{source}: the key {k.value}{where} appears twice, {lines}: allowed each key once in a "
                f"mapping (YAML would keep the last without a word): remove one")
        seen[key] = k


def yaml_load(text: str, source: str = "YAML", path: Iterable = ()):
    """Parse YAML text with :class:`_Loader`, refusing with a :class:`ConfigError` the YAML 1.1
    forms that 1.2 reads otherwise (``on``/``off``/``yes``/``no``, ``0123``, ``1:30``, ``1_000``,
    naming the key under ``path``, e.g. the key of a ``--set``, its line and the unambiguous
    spelling), a key given twice in one mapping (naming it and both lines), and a document over
    the bounds of work: :data:`MAX_DOCUMENT_BYTES` characters, :data:`MAX_NODES` nodes with its
    aliases expanded, :data:`MAX_DEPTH` levels."""
    if len(text) > MAX_DOCUMENT_BYTES:
        raise ConfigError(f"{source}: {len(text):,} characters: allowed a document of at most "
                          f"{MAX_DOCUMENT_BYTES:,} characters")
    loader = _Loader(text, source)
    try:
        node = loader.get_single_node()
        if node is None:
            return None
        _check_unambiguous(node, list(path), source, loader=loader)
        return loader.construct_document(node)
    finally:
        loader.dispose()


def check_extent(data, source: str = "config") -> None:
    """Refuse data (e.g. Snakemake's ``config``, merged from files and ``--config`` values that
    Snakemake parsed itself) holding more than :data:`MAX_NODES` values or nested deeper than
    :data:`MAX_DEPTH`, counting a value as often as it is referred to: the same bounds as
    :func:`yaml_load`, so the validation that walks it does bounded work. Stops at the bound."""
    count = 0
    stack = [(data, 1)]
    while stack:
        value, depth = stack.pop()
        count += 1
        if count > MAX_NODES:
            raise ConfigError(f"{source}: more than {MAX_NODES:,} values, counting each as often as an alias "
                              f"repeats it: allowed at most {MAX_NODES:,}")
        if depth > MAX_DEPTH:
            raise ConfigError(f"{source}: nested more than {MAX_DEPTH} levels deep: allowed at most {MAX_DEPTH} "
                              f"levels of mappings and lists")
        if isinstance(value, dict):
            stack.extend((v, depth + 1) for pair in value.items() for v in pair)
        elif isinstance(value, (list, tuple)):
            stack.extend((v, depth + 1) for v in value)


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


def _read_utf8(path: Path) -> str:
    """The text of a config file: at most :data:`MAX_DOCUMENT_BYTES` bytes of UTF-8, else a
    :class:`ConfigError` naming the size, or the byte offset and line of the first invalid byte."""
    size = path.stat().st_size
    if size > MAX_DOCUMENT_BYTES:
        raise ConfigError(f"{path}: {size:,} bytes: allowed a config file of at most {MAX_DOCUMENT_BYTES:,} bytes")
    raw = path.read_bytes()[:MAX_DOCUMENT_BYTES + 1]  # a file that grew since stat() is cut, then refused
    if len(raw) > MAX_DOCUMENT_BYTES:
        raise ConfigError(f"{path}: more than {MAX_DOCUMENT_BYTES:,} bytes: allowed a config file of at most "
                          f"{MAX_DOCUMENT_BYTES:,} bytes")
    try:
        return raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = raw.count(b"\n", 0, exc.start) + 1
        raise ConfigError(f"{path}: byte {raw[exc.start:exc.start + 1].hex(' ')} at offset {exc.start} "
                          f"(line {line}) is not UTF-8 ({exc.reason}): allowed a file in UTF-8 (ASCII "
                          f"is UTF-8); save it as UTF-8") from None


def load_yaml(path: str | Path) -> dict:
    """A campaign, scene or schema file as a dict, read by :func:`yaml_load` with its bounds and
    refusals; every problem is a :class:`ConfigError` naming the file."""
    path = Path(path)
    if not path.is_file():
        raise ConfigError(f"config file not found: {path}")
    try:
        data = yaml_load(_read_utf8(path), str(path))
    except yaml.YAMLError as exc:
        raise ConfigError(f"{path}: not valid YAML: {exc}") from None
    if not isinstance(data, dict):
        raise ConfigError(f"{path}: top level must be a mapping, got {type(data).__name__}")
    refuse_templating(data, str(path))
    return data


def dotted_path(path: Iterable) -> str:
    out = ""
    for p in path:
        out += f"[{p}]" if isinstance(p, int) else (f".{p}" if out else str(p))
    return out or "(top level)"
