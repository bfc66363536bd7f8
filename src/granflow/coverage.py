"""How much of its paper a scene's validation record compares.

A scene with a paper lists every quantitative result the paper states in ``paper_results.yaml`` in its
package (found through :mod:`granflow.registry`): an ``id``, the ``result`` as the paper states it,
``where`` (section, figure, equation), the ``form`` it is stated in, and either ``compared_by`` (the
``quantity`` of each check of the record that tests it) or ``not_compared`` (why none does). An item of ``compared_by`` may name a row of the scene's ladder
instead of the record (``{quantity, ladder: <rung or pool>}``, a row of ``validation/<scene>/ladder.csv``):
a result that only runs beside the record can measure (a pool across feed rates, say) is compared there. A mapping
whose rows are forced by a definition (``kind: consistency``) or read a measurement choice
(``kind: diagnostic``) is kept, with its reason, but does not count as compared; ``kind`` may be given
for the whole entry or for one item of ``compared_by``.

:func:`coverage` counts, against the checks of a record (``summary.json``'s ``checks``), the results
at least one *comparison* check compares: a check counts when its ``kind`` is ``comparison`` or
absent (a record written before checks had kinds). :func:`coverage_line` gives the line
``validation/README.md`` prints per scene; a scene without the file has none.
"""
from __future__ import annotations

import math

from pathlib import Path

import jsonschema

from . import registry
from .yamlio import ConfigError, dotted_path, load_yaml

#: the file, in a scene's package, that lists its paper's results
FILE_NAME = "paper_results.yaml"
#: what a check or a mapping is (STYLE.md, "Comparing with a paper"): only a comparison can fail
#: against the paper; a consistency check is forced by a definition or an identity of our own code;
#: a diagnostic reads a measurement choice
KINDS = ("comparison", "consistency", "diagnostic")
#: how a paper states a result
FORMS = ("value", "range", "bound", "law", "scaling", "trend", "shape", "collapse", "identity")

_TEXT = {"type": "string", "minLength": 1}
_ROW = {"anyOf": [
    {**_TEXT, "description": "the quantity of a check row"},
    {"type": "object", "required": ["quantity"], "additionalProperties": False,
     "anyOf": [{"required": ["kind"]}, {"required": ["ladder"]}],
     "properties": {"quantity": {**_TEXT, "description": "the quantity of a check row"},
                    "kind": {"enum": list(KINDS), "description": "what this row is for this result"},
                    "ladder": {**_TEXT, "description": "the rung or pool of the scene's ladder whose row of "
                                                       "validation/<scene>/ladder.csv this is (not the record's)"}}},
]}
#: the schema of one entry; the rules between keys are :func:`_entry_problems`'
ENTRY_SCHEMA = {
    "type": "object",
    "required": ["id", "result", "where", "form"],
    "additionalProperties": False,
    "properties": {
        "id": {"type": "string", "pattern": "^[a-z][a-z0-9_]*$",
               "description": "short name, unique in the file: lower case, digits, underscores"},
        "result": {**_TEXT, "description": "the value or law as the paper states it"},
        "where": {**_TEXT, "description": "section, figure or equation of the paper"},
        "form": {"enum": list(FORMS), "description": "how the paper states it"},
        "compared_by": {"type": "array", "minItems": 1, "items": _ROW,
                        "description": "the checks of the record that test it"},
        "kind": {"enum": list(KINDS), "description": "what every row of compared_by is (default comparison)"},
        "not_compared": {**_TEXT, "description": "why no comparison of the record tests it"},
        "note": {**_TEXT, "description": "anything else a reader needs"},
    },
}
#: the schema of the file
SCHEMA = {
    "type": "object",
    "required": ["paper", "results"],
    "additionalProperties": False,
    "properties": {
        "paper": {**_TEXT, "description": "the paper, cited by authors, year and title or journal"},
        "results": {"type": "array", "minItems": 1, "items": ENTRY_SCHEMA,
                    "description": "every quantitative result the paper states"},
    },
}


def paper_results_path(scene_name: str) -> Path | None:
    """The scene's ``paper_results.yaml``, or None when the scene has none (or is not registered).

    Parameters
    ----------
    scene_name : str
        A scene of :mod:`granflow.registry`.
    """
    try:
        scene = registry.get(scene_name)
    except KeyError:
        return None
    path = scene.package_dir / FILE_NAME
    return path if path.is_file() else None


def _where(data: dict, path: list) -> str:
    """``results[i] (id 'x'): key`` for a place in the file, naming the entry by its id when it has one."""
    if len(path) >= 2 and path[0] == "results" and isinstance(path[1], int):
        entries = data.get("results")
        entry = entries[path[1]] if isinstance(entries, list) and path[1] < len(entries) else None
        name = entry.get("id") if isinstance(entry, dict) else None
        head = f"results[{path[1]}]" + (f" (id {name!r})" if isinstance(name, str) else "")
        return head + (f": {dotted_path(path[2:])}" if path[2:] else "")
    return dotted_path(path)


def _message(err: jsonschema.ValidationError) -> str:
    if err.validator == "anyOf":
        return (f"{err.instance!r} is neither a quantity (a string) nor {{quantity, kind}} with kind one of {KINDS} "
                f"nor {{quantity, ladder}} naming a rung or pool of the scene's ladder")
    if err.validator == "additionalProperties":
        allowed = sorted(err.schema.get("properties", {}))
        extra = sorted(set(err.instance) - set(allowed))
        return f"unknown key {', '.join(extra)}; allowed keys: {', '.join(allowed)}"
    return err.message


def rows(entry: dict) -> list[tuple[str, str]]:
    """``(quantity, kind)`` of every check an entry names, the entry's ``kind`` (default ``comparison``)
    for an item that gives none.

    Parameters
    ----------
    entry : dict
        One entry of ``results``.
    """
    default = entry.get("kind", "comparison")
    return [(item, default) if isinstance(item, str) else (item["quantity"], item.get("kind", default))
            for item in entry.get("compared_by", []) if isinstance(item, str) or "ladder" not in item]


def ladder_rows(entry: dict) -> list[tuple[str, str, str]]:
    """``(quantity, kind, rung)`` of every row an entry names in the scene's ladder (an item of
    ``compared_by`` with ``ladder``: a row of ``validation/<scene>/ladder.csv`` whose ``rung`` is that rung or
    pool), the entry's ``kind`` (default ``comparison``) for an item that gives none.

    Parameters
    ----------
    entry : dict
        One entry of ``results``.
    """
    default = entry.get("kind", "comparison")
    return [(item["quantity"], item.get("kind", default), item["ladder"])
            for item in entry.get("compared_by", []) if isinstance(item, dict) and "ladder" in item]


def _entry_problems(entry: dict) -> list[tuple[str, str]]:
    """``(key, problem)`` for each rule between an entry's keys that it breaks."""
    out = []
    compares = [q for q, kind in rows(entry) if kind == "comparison"]
    compares += [f"{q} (ladder {rung})" for q, kind, rung in ladder_rows(entry) if kind == "comparison"]
    if "kind" in entry and "compared_by" not in entry:
        out.append(("kind", "given without compared_by (kind says what the rows of compared_by are)"))
    if not entry.get("compared_by") and "not_compared" not in entry:
        out.append(("compared_by", "neither compared_by nor not_compared: say which checks compare the "
                                   "result, or why none does"))
    elif compares and "not_compared" in entry:
        out.append(("not_compared", f"given beside comparison rows ({'; '.join(compares)}): a result is "
                                    f"either compared or not (mark the rows kind: consistency or diagnostic)"))
    elif entry.get("compared_by") and not compares and "not_compared" not in entry:
        out.append(("not_compared", "missing: every row of compared_by is a consistency or diagnostic "
                                    "reading, so the result is not compared; say why"))
    return out


def validate(data, source: str) -> None:
    """Check a loaded ``paper_results.yaml`` against :data:`SCHEMA` and the rules between keys; raise
    :class:`~granflow.yamlio.ConfigError` listing every problem, one a line, each naming the file,
    the entry (index and id) and the key.

    Parameters
    ----------
    data : object
        The file's content.
    source : str
        The file's name, for the messages.
    """
    problems = []
    errors = sorted(jsonschema.Draft202012Validator(SCHEMA).iter_errors(data),
                    key=lambda e: [str(p) for p in e.absolute_path])
    for err in errors:
        problems.append(f"{source}: {_where(data, list(err.absolute_path))}: {_message(err)}")
    entries = data.get("results") if isinstance(data, dict) else None
    # an entry whose rows do not read as rows is not checked further (its schema errors say why)
    unread = {e.absolute_path[1] for e in errors if len(e.absolute_path) >= 3 and e.absolute_path[0] == "results"
              and e.absolute_path[2] in ("compared_by", "kind")}
    seen: dict[str, int] = {}
    for i, entry in enumerate(entries if isinstance(entries, list) else []):
        if not isinstance(entry, dict) or i in unread:
            continue
        for key, problem in _entry_problems(entry):
            problems.append(f"{source}: {_where(data, ['results', i, key])}: {problem}")
        name = entry.get("id")
        if isinstance(name, str) and name in seen:
            problems.append(f"{source}: {_where(data, ['results', i, 'id'])}: the id of results[{seen[name]}] "
                            f"too: ids must be unique")
        elif isinstance(name, str):
            seen[name] = i
    if problems:
        raise ConfigError("\n".join(problems))


def load(path: str | Path) -> dict:
    """A ``paper_results.yaml`` read and validated (:func:`validate`).

    Parameters
    ----------
    path : str or Path
        The file.
    """
    data = load_yaml(path)
    validate(data, str(path))
    return data


def measured(check: dict) -> bool:
    """Whether a check of the record holds a number (``ours`` finite): a row "not measured" compares nothing.
    A check given without ``ours`` (a quantity named, nothing else) is taken as measured."""
    if "ours" not in check:
        return True
    try:
        return math.isfinite(float(check.get("ours")))
    except (TypeError, ValueError):
        return False


def is_comparison(check: dict) -> bool:
    """Whether a check of the record is a comparison: its ``kind`` is ``comparison``, or it has none
    (a record written before checks had kinds).

    Parameters
    ----------
    check : dict
        One check of ``summary.json``'s ``checks`` (or a row of ``checks.csv``).
    """
    kind = check.get("kind")
    return kind is None or kind == "" or kind == "comparison"


def count(entries: list[dict], checks: list[dict], ladder=()) -> tuple[int, int, list[tuple[str, str]]]:
    """How many of a paper's results the checks compare.

    A result is compared when one of its comparison rows (:func:`rows`) is the quantity of a check
    that is a comparison (:func:`is_comparison`) and holds a number (:func:`measured`), or one of its
    ladder rows (:func:`ladder_rows`) is such a row of the ladder's table under that rung or pool.

    Parameters
    ----------
    entries : list of dict
        The ``results`` of a ``paper_results.yaml``.
    checks : list of dict
        The record's checks, each with a ``quantity`` and possibly a ``kind``.
    ladder : iterable of dict
        The rows of ``validation/<scene>/ladder.csv`` (``rung``, ``quantity``, ``ours``, ``kind``).

    Returns
    -------
    n_compared : int
    n_total : int
    not_compared : list of (id, reason)
        In the file's order; the reason is the entry's ``not_compared``, or, for an entry whose
        comparison rows the record lacks or holds as other kinds, says so.
    """
    compared_quantities = {c["quantity"] for c in checks if is_comparison(c) and measured(c)}
    unmeasured = {c["quantity"] for c in checks if is_comparison(c)} - compared_quantities
    on_ladder = {(str(r.get("rung")), r.get("quantity")) for r in ladder if is_comparison(r) and measured(r)}
    n_compared, not_compared = 0, []
    for entry in entries:
        compares = [q for q, kind in rows(entry) if kind == "comparison"]
        rungs = [(rung, q) for q, kind, rung in ladder_rows(entry) if kind == "comparison"]
        if any(q in compared_quantities for q in compares) or any(r in on_ladder for r in rungs):
            n_compared += 1
        elif any(q in unmeasured for q in compares):
            not_compared.append((entry["id"], "its rows are in the record but not measured (no number): "
                                              + "; ".join(q for q in compares if q in unmeasured)))
        elif compares or rungs:
            where = "the record or the ladder" if rungs else "the record"
            not_compared.append((entry["id"], f"no comparison check of {where} has its rows: "
                                              + "; ".join(compares + [f"{q} (ladder {r})" for r, q in rungs])))
        else:
            not_compared.append((entry["id"], entry["not_compared"]))
    return n_compared, len(entries), not_compared


def coverage(scene_name: str, checks: list[dict], ladder=()) -> tuple[int, int, list[tuple[str, str]]]:
    """:func:`count` of the scene's ``paper_results.yaml`` against ``checks`` (and the ladder's rows).

    Parameters
    ----------
    scene_name : str
        A scene with a ``paper_results.yaml`` (else :class:`~granflow.yamlio.ConfigError`).
    checks : list of dict
        The record's checks (``summary.json``'s ``checks``).
    ladder : iterable of dict
        The rows of the scene's ``ladder.csv`` (:func:`count`).
    """
    path = paper_results_path(scene_name)
    if path is None:
        raise ConfigError(f"scene {scene_name!r} has no {FILE_NAME} in its package: its paper's results are "
                          f"not listed")
    return count(load(path)["results"], checks, ladder)


def coverage_line(scene_name: str, checks: list[dict], ladder=()) -> str:
    """``coverage: N of M results of the paper compared`` for the scene, ``''`` when it has no
    ``paper_results.yaml``; when the ladder's rows compare some that the record does not, the line says
    how many (``(K of them by the ladder's rungs)``).

    Parameters
    ----------
    scene_name : str
        A scene of :mod:`granflow.registry`.
    checks : list of dict
        The record's checks (``summary.json``'s ``checks``).
    ladder : iterable of dict
        The rows of the scene's ``ladder.csv`` (:func:`count`).
    """
    if paper_results_path(scene_name) is None:
        return ""
    ladder = list(ladder)
    n_compared, n_total, _ = coverage(scene_name, checks, ladder)
    by_ladder = n_compared - coverage(scene_name, checks)[0]
    tail = f" ({by_ladder} of them by the ladder's rungs)" if by_ladder else ""
    return f"coverage: {n_compared} of {n_total} results of the paper compared{tail}"
