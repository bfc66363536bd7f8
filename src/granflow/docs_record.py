"""Numbers of the validation record in the documents, taken from the record itself.

A page of ``docs/`` (or the README) that quotes a number the committed record holds marks it, and
:func:`render` fills the mark from ``validation/<scene>/summary.json``, so the page cannot drift from
the record. Two marks, each an HTML comment pair that Markdown does not show:

- inline, one check: ``<!-- record: SCENE | QUANTITY | CASE | FORM -->…<!-- /record -->``. QUANTITY
  is the start of the check's quantity (an exact quantity wins over longer ones it starts), CASE its
  case directory (``sweep`` for a fit over the cases; may be left out when only one check matches),
  FORM one of :data:`FORMS` (default ``full``): ``value`` is ``ours ± stat ± syst`` with the unit
  (:func:`granflow.validation.format_with_errors`), ``verdict`` the verdict in a few words
  (:func:`granflow.overview.short_verdict`), ``full`` both, ``value, verdict``.
- a table, on lines of its own: ``<!-- record-table: SCENE -->`` … ``<!-- /record-table -->``: the
  scene's headline comparisons (:func:`granflow.overview.headlines`, as the report's front page
  picks them) with the record's commit, cases and CPU-hours; ``*`` for every scene of the record.

``tools/docs_record.py`` rewrites every mark of the pages (:func:`refresh`); the unit test
``tests/unit/test_docs_record.py`` fails, naming the page and the mark, while a mark differs from
the record (:func:`stale_marks`), and where a phrase that quotes the record (:data:`RECORD_PHRASES`)
is followed by a number typed by hand (:func:`unmarked_quotes`). The module names no scene: it
reads whatever the record holds.
"""
from __future__ import annotations

import json
import re
from dataclasses import dataclass
from pathlib import Path

from .overview import headlines, short_verdict
from .validation import format_with_errors

#: the forms of an inline mark, and what each shows
FORMS = ("full", "value", "verdict")
#: an inline mark: its arguments and its body
INLINE = re.compile(r"<!-- record: (?P<args>[^>]*?) -->(?P<body>.*?)<!-- /record -->", re.S)
#: a table mark: its scene (or ``*``) and its body, the marks on lines of their own
TABLE = re.compile(r"<!-- record-table: (?P<args>[^>]*?) -->\n(?P<body>.*?)<!-- /record-table -->", re.S)
#: phrases that announce a number of the record: the number after one must be a mark
RECORD_PHRASES = ("the validation record has", "the record says", "the record now says", "the record has",
                  "the committed record has", "the record gives")
#: how far after a phrase its number may come (characters, marks excluded)
PHRASE_REACH = 120


class RecordMarkError(ValueError):
    """A mark that names no check of the record, or more than one, or an unknown form or scene."""


@dataclass
class Mark:
    """One mark of a page: ``kind`` (``record`` or ``record-table``), its arguments as written, its body
    now, the body the record gives (``want``) and the line it starts on."""

    kind: str
    args: str
    body: str
    want: str
    line: int


def load_record(validation: Path) -> dict[str, dict]:
    """``{scene: summary}`` from every ``validation/<scene>/summary.json``, in the folders' order.

    Parameters
    ----------
    validation : Path
        The record's folder (``validation/`` of the project).
    """
    return {p.parent.name: json.loads(p.read_text()) for p in sorted(Path(validation).glob("*/summary.json"))}


def _summary(record: dict[str, dict], scene: str) -> dict:
    if scene not in record:
        raise RecordMarkError(f"no record of scene {scene!r} (the record has {', '.join(record) or 'none'})")
    return record[scene]


def find_check(summary: dict, quantity: str, case: str = "") -> dict:
    """The one check of ``summary`` whose quantity starts with ``quantity`` (an exact match wins) on
    ``case`` (any case when empty).

    Parameters
    ----------
    summary : dict
        A scene's ``summary.json``.
    quantity : str
        The start of the check's quantity.
    case : str
        The check's case directory, or ``sweep``; empty for any.

    Raises
    ------
    RecordMarkError
        When no check matches, or more than one.
    """
    on_case = [c for c in summary.get("checks", []) if not case or c.get("case") == case]
    found = [c for c in on_case if c.get("quantity") == quantity] or \
        [c for c in on_case if str(c.get("quantity", "")).startswith(quantity)]
    where = f"{summary.get('scene')}: quantity {quantity!r}" + (f" on case {case!r}" if case else "")
    if not found:
        raise RecordMarkError(f"{where}: no such check in the record")
    if len(found) > 1:
        raise RecordMarkError(f"{where}: {len(found)} checks match ("
                              + "; ".join(f"{c.get('quantity')} on {c.get('case')}" for c in found) + ")")
    return found[0]


def value_text(check: dict) -> str:
    """``ours ± stat ± syst`` of a check with its unit (a unit that is a sign, ° or %, without a space).

    Parameters
    ----------
    check : dict
        One check of a ``summary.json``.
    """
    syst = check.get("syst")
    text = format_with_errors(_number(check.get("ours")), _number(check.get("error")),
                              None if syst is None else _number(syst))
    unit = check.get("unit") or ""
    return text + (unit if unit[:1] in ("°", "%") else f" {unit}" if unit else "")


def _number(x) -> float:
    return float("nan") if x is None else float(x)


def inline_text(record: dict[str, dict], args: str) -> str:
    """The body of an inline mark with ``args`` (``SCENE | QUANTITY | CASE | FORM``).

    Parameters
    ----------
    record : dict
        :func:`load_record`'s ``{scene: summary}``.
    args : str
        The mark's arguments as written.
    """
    parts = [p.strip() for p in args.split("|")]
    if len(parts) < 2 or len(parts) > 4:
        raise RecordMarkError(f"record mark {args!r}: SCENE | QUANTITY [| CASE [| FORM]]")
    scene, quantity, case, form = (parts + ["", ""])[:4]
    form = form or "full"
    if form not in FORMS:
        raise RecordMarkError(f"record mark {args!r}: form {form!r} is not one of {', '.join(FORMS)}")
    check = find_check(_summary(record, scene), quantity, case)
    value, verdict = value_text(check), short_verdict(check.get("verdict"))
    return {"value": value, "verdict": verdict, "full": f"{value}, {verdict}"}[form]


def _cell(text) -> str:
    return str(text).replace("|", "\\|").replace("\n", " ")


def table_text(record: dict[str, dict], args: str) -> str:
    """The body of a table mark: the headline comparisons of one scene (``args``) or of every scene
    (``*``), under a line naming each scene's record commit, cases and CPU-hours.

    Parameters
    ----------
    record : dict
        :func:`load_record`'s ``{scene: summary}``.
    args : str
        A scene of the record, or ``*``.
    """
    scene = args.strip()
    summaries = list(record.values()) if scene == "*" else [_summary(record, scene)]
    every = scene == "*"
    header = (["scene"] if every else []) + ["quantity", "case", "ours ± stat ± syst", "paper", "verdict"]
    rows = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    for s in summaries:
        for c in headlines(s):
            cells = ([s["scene"]] if every else []) + [c.get("quantity"), c.get("case"), value_text(c),
                                                       c.get("paper"), short_verdict(c.get("verdict"))]
            rows.append("| " + " | ".join(_cell(x) for x in cells) + " |")
    made = "; ".join(f"{s['scene']}: {len(s.get('cases', []))} case(s), {_number(s.get('cpu_hours')):.2f} CPU-h, "
                     f"written at commit {str(s.get('record_commit') or '?')[:7]}" for s in summaries)
    return (f"\nFrom `validation/{'<scene>' if every else scene}/summary.json` ({made}); every check is in "
            f"`validation/README.md`.\n\n" + "\n".join(rows) + "\n\n")


def _line(text: str, pos: int) -> int:
    return text.count("\n", 0, pos) + 1


def _masked(text: str) -> str:
    """``text`` with its code (fenced blocks, and spans in backticks on one line) blanked, its length and
    lines kept: a mark written in code to show the syntax is not a mark."""
    text = re.sub(r"```.*?```", lambda m: re.sub(r"[^\n]", " ", m.group(0)), text, flags=re.S)
    return re.sub(r"`[^`\n]+`", lambda m: " " * len(m.group(0)), text)


def _found(pattern: re.Pattern, text: str) -> list[tuple[int, int, str]]:
    """``(start, end, args)`` of each match of ``pattern`` outside code (:func:`_masked`)."""
    return [(m.start(), m.end(), text[m.start("args"):m.end("args")]) for m in pattern.finditer(_masked(text))]


def marks(text: str, record: dict[str, dict]) -> list[Mark]:
    """Every mark of a page's ``text`` with the body the record gives it.

    Parameters
    ----------
    text : str
        The page.
    record : dict
        :func:`load_record`'s ``{scene: summary}``.
    """
    out = []
    for kind, pattern, fill in (("record", INLINE, inline_text), ("record-table", TABLE, table_text)):
        for start, end, args in _found(pattern, text):
            body = pattern.fullmatch(text[start:end])["body"]
            out.append(Mark(kind, args, body, fill(record, args), _line(text, start)))
    return sorted(out, key=lambda m: m.line)


def stale_marks(text: str, record: dict[str, dict]) -> list[Mark]:
    """The marks of ``text`` whose body is not what the record gives (:func:`marks`).

    Parameters
    ----------
    text : str
        The page.
    record : dict
        :func:`load_record`'s ``{scene: summary}``.
    """
    return [m for m in marks(text, record) if m.body != m.want]


def render(text: str, record: dict[str, dict]) -> str:
    """``text`` with every mark's body the record's.

    Parameters
    ----------
    text : str
        The page.
    record : dict
        :func:`load_record`'s ``{scene: summary}``.
    """
    spans = [(start, end, f"<!-- record: {args} -->{inline_text(record, args)}<!-- /record -->")
             for start, end, args in _found(INLINE, text)]
    spans += [(start, end, f"<!-- record-table: {args} -->\n{table_text(record, args)}<!-- /record-table -->")
              for start, end, args in _found(TABLE, text)]
    for start, end, new in sorted(spans, reverse=True):    # from the end, so earlier positions hold
        text = text[:start] + new + text[end:]
    return text


def unmarked_quotes(text: str) -> list[tuple[int, str]]:
    """``(line, phrase)`` of each phrase of :data:`RECORD_PHRASES` in ``text`` (code blocks skipped)
    after which a number is typed by hand, within :data:`PHRASE_REACH` characters and before any mark
    (a phrase that quotes no number passes).

    Parameters
    ----------
    text : str
        The page.
    """
    text = _masked(text)
    found = {}
    for phrase in RECORD_PHRASES:
        for m in re.finditer(re.escape(phrase), text, re.I):
            after = text[m.end():m.end() + PHRASE_REACH]
            mark = re.search(r"<!-- record(?:-table)?: ", after)
            if re.search(r"\d", after[:mark.start()] if mark else after):
                found.setdefault(m.end(), (_line(text, m.start()), phrase))
    return sorted(found.values())


def pages(root: Path) -> list[Path]:
    """The pages whose marks are kept: ``README.md`` and every ``docs/*.md`` of the project at ``root``.

    Parameters
    ----------
    root : Path
        The project's folder.
    """
    root = Path(root)
    return [p for p in [root / "README.md", *sorted((root / "docs").glob("*.md"))] if p.exists()]


def refresh(paths: list[Path], record: dict[str, dict]) -> list[Path]:
    """Rewrite the marks of each page of ``paths`` from the record; return the pages that changed.

    Parameters
    ----------
    paths : list of Path
        The pages (:func:`pages`).
    record : dict
        :func:`load_record`'s ``{scene: summary}``.
    """
    changed = []
    for path in paths:
        text = Path(path).read_text()
        new = render(text, record)
        if new != text:
            Path(path).write_text(new)
            changed.append(Path(path))
    return changed
