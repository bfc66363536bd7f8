"""Reading a config file: strict YAML and ``--set`` overrides.

Every YAML text is read by :func:`yaml_load` (:mod:`granflow.yamlio`, whose names are re-exported
here) with bounded work (:data:`MAX_DOCUMENT_BYTES`, :data:`MAX_NODES` with aliases expanded,
:data:`MAX_DEPTH`), refusing a key given twice and a file that is not UTF-8. :func:`apply_overrides`
applies ``--set KEY=VALUE`` overrides to what was read; the schemas check it afterwards
(:mod:`granflow.schema`). Every refusal is a :class:`ConfigError` naming the key and the value.
"""
from __future__ import annotations

import copy
from typing import Any, Iterable

import yaml

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
