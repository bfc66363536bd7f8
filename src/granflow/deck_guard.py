"""What may reach a LAMMPS deck, checked before the deck is written.

A deck is a program: LAMMPS runs every line of it, and a line such as ``shell touch x`` runs a
program of the user's machine. Two guards keep a deck to what granflow's templates write:

- **Names and numbers.** Every name that enters a deck (the scene, the rung, the stage) is an
  identifier, :data:`NAME` matched on the whole string (no space, no newline, nothing after it);
  every deck variable is a LAMMPS variable name with a finite number; every other string of the
  template context (enumerated choices of the schema, comments written by the scene's code) is
  one line of printable ASCII. :func:`check_name`, :func:`check_context`.
- **Lines.** A rendered deck holds printable ASCII lines only, and every command in it, read as
  LAMMPS reads it (lines split at ``\\n`` only, a line ending in ``&`` joined to the next, an
  unquoted ``#`` starting a comment, the quoted commands of ``if`` and ``run ... every``), is
  one that the scene's templates write (:func:`template_commands`, found in the templates
  themselves) and none of :data:`FORBIDDEN`. :func:`check_deck`.

Each refusal is a :class:`DeckError` (a user's input, exit 2 from the CLI) naming the value or
the line; nothing is written.
"""
from __future__ import annotations

import dataclasses
import math
import numbers
import re
import unicodedata

import jinja2

from .yamlio import ConfigError

#: a name that may enter a deck (scene, rung, stage): the campaign schema's rule for scene names,
#: matched on the whole string with :meth:`re.Pattern.fullmatch`
NAME = re.compile(r"[a-z][a-z0-9_]{0,31}")
#: a deck variable's name (``variable NAME equal VALUE``)
VARIABLE = re.compile(r"[A-Za-z][A-Za-z0-9_]{0,63}")
#: what a LAMMPS command's name looks like
COMMAND = re.compile(r"[a-z_][a-z0-9_/]*")
#: one line of printable ASCII (space to tilde)
ONE_LINE = re.compile(r"[ -~]*")
#: commands that reach outside LAMMPS (a program, Python, another file, a log elsewhere, a library)
FORBIDDEN = {"shell": "runs a program", "python": "runs Python code", "include": "reads another input file",
             "log": "moves the log to another file", "plugin": "loads a shared library"}
#: the templates a scene's deck comes from
TEMPLATE_SUFFIX = ".lmp.j2"
#: a Jinja tag that brings in another template; group 1: what follows its keyword
_REFERENCE = re.compile(r"\{%-?\s*(?:import|include|from|extends)\b(.*?)-?%\}", re.S)


class DeckError(ConfigError):
    """A name that may not enter a deck, or a deck line the templates could not have written (exit 2)."""


# ------------------------------------------------------------------------------- names and numbers
def check_name(what: str, value) -> str:
    """Return ``value`` if it is a name that may enter a deck (:data:`NAME`, the whole string).

    Raises
    ------
    DeckError
        Naming ``what`` and the value: a newline, a space, a ``;`` or any other character
        outside a-z, 0-9 and _ (or a first character that is not a letter).
    """
    if not isinstance(value, str) or not NAME.fullmatch(value):
        raise DeckError(f"{what} = {value!r} is not allowed in a deck: allowed a name of a-z, 0-9 and _, "
                        f"starting with a letter, at most 32 characters (nothing else, no newline)")
    return value


def _strings(value, path: str):
    """Every ``(path, leaf)`` of a template context: strings, numbers and what else it holds."""
    if isinstance(value, dict):
        for key, item in value.items():
            yield f"{path}.{key}", key
            yield from _strings(item, f"{path}.{key}")
    elif isinstance(value, (list, tuple, set, frozenset)):
        for i, item in enumerate(value):
            yield from _strings(item, f"{path}[{i}]")
    elif dataclasses.is_dataclass(value) and not isinstance(value, type):
        for field in dataclasses.fields(value):
            yield from _strings(getattr(value, field.name), f"{path}.{field.name}")
    else:
        yield path, value


def check_context(params, context: dict) -> None:
    """Refuse a template context holding anything but names, finite numbers and one-line text.

    ``params``: the deck variables (``name``, ``value``, ``comment``); ``context``: the other
    values the template reads. The scene's and the rung's names must be :data:`NAME`.
    """
    for key in ("scene", "rung"):
        check_name(key, context.get(key))
    for p in params:
        if not isinstance(p.name, str) or not VARIABLE.fullmatch(p.name):
            raise DeckError(f"deck variable {p.name!r} is not allowed: allowed a LAMMPS variable name "
                            f"(a letter, then letters, digits and _)")
        _check_leaf(f"variable {p.name}", p.value, number=True)
        _check_leaf(f"variable {p.name}'s comment", p.comment)
    for path, leaf in _strings(context, "context"):
        _check_leaf(path, leaf)


def _check_leaf(what: str, value, number: bool = False) -> None:
    if isinstance(value, str) and not number:
        if not ONE_LINE.fullmatch(value):
            bad = next(ch for ch in value if not ONE_LINE.fullmatch(ch))
            raise DeckError(f"{what} = {value!r} is not allowed in a deck: it holds {_char(bad)}; "
                            f"allowed one line of printable ASCII")
    elif isinstance(value, numbers.Real) and not isinstance(value, bool):
        if not math.isfinite(value):
            raise DeckError(f"{what} = {value!r} is not allowed in a deck: allowed a finite number")
    elif number:
        raise DeckError(f"{what} = {value!r} is not allowed in a deck: allowed a finite number")


def _char(ch: str) -> str:
    return f"the character U+{ord(ch):04X} ({unicodedata.name(ch, 'a control character')})"


# --------------------------------------------------------------------------------------- lines
def logical_lines(text: str) -> list[tuple[int, int, str]]:
    """The commands of a deck as LAMMPS reads them: ``(first line, last line, text)``.

    Lines split at ``\\n`` only; a line whose last printable character is ``&`` continues on the
    next, joined with nothing between (as LAMMPS does: ``sh&`` then ``ell x`` is ``shell x``).
    """
    out, buf, start = [], None, 0
    lines = text.split("\n")
    for no, line in enumerate(lines, 1):
        if buf is None:
            buf, start = "", no
        if line.rstrip().endswith("&"):
            buf += line.rstrip()[:-1]
            continue
        out.append((start, no, buf + line))
        buf = None
    if buf is not None:
        out.append((start, len(lines), buf))
    return out


def split_command(line: str) -> tuple[list[tuple[str, bool]], bool]:
    """The words of one command, ``(word, quoted)``, and whether it held a ``#`` comment.

    An unquoted ``#`` ends the command; a word opening with ``'`` or ``"`` runs to the same
    quote (quotes removed). Raises :class:`ValueError` on a quote that is not closed.
    """
    words, i, n = [], 0, len(line)
    while i < n:
        ch = line[i]
        if ch.isspace():
            i += 1
        elif ch == "#":
            return words, True
        elif ch in "'\"":
            end = line.find(ch, i + 1)
            if end < 0:
                raise ValueError(f"the quote {ch} at character {i + 1} is not closed")
            words.append((line[i + 1:end], True))
            i = end + 1
        else:
            j = i
            while j < n and not line[j].isspace():
                if line[j] in "'\"":  # a quote inside a word: LAMMPS's comment scan toggles on it too
                    end = line.find(line[j], j + 1)
                    if end < 0:
                        raise ValueError(f"the quote {line[j]} at character {j + 1} is not closed")
                    j = end
                elif line[j] == "#":
                    break
                j += 1
            words.append((line[i:j], False))
            i = j
    return words, False


def commands(line: str) -> list[str]:
    """Every command one deck line would run: its first word and, for ``if`` and ``run ... every``,
    the first word of each quoted command it holds."""
    words, _ = split_command(line)
    if not words:
        return []
    first, *rest = [w for w, _ in words]
    out = [first]
    nested: list[str] = []
    if first == "if":  # if "cond" then "c1" "c2" ... elif "cond" "c" ... else "c" ...
        skip = True  # the condition after `if` and after each `elif`
        for word in rest:
            if skip:
                skip = False
            elif word == "elif":
                skip = True
            elif word not in ("then", "else"):
                nested.append(word)
    elif first == "run" and "every" in rest:  # run N ... every M "c1" "c2" ... (or NULL)
        nested = [w for w in rest[rest.index("every") + 2:] if w != "NULL"]
    for command in nested:
        out += commands(command)
    return out


def check_deck(text: str, allowed: frozenset, where: str, outcome: str = "no deck was written") -> None:
    """Refuse a rendered deck holding a line granflow's templates could not have written.

    ``allowed``: the commands of the templates (:func:`template_commands`); ``where``: the deck's
    name in the message (e.g. ``init.lmp of chute at rung demo``); ``outcome``: what the refusal
    left undone, the message's last words (a deck checked on disk before a run: nothing ran).

    Raises
    ------
    DeckError
        Naming the line and why: a character other than printable ASCII or a newline (a unicode
        line separator, a carriage return, a control character); a triple quote or an unclosed
        quote; a comment continued with ``&`` (it would hide the next line); a command of
        :data:`FORBIDDEN` or one the templates never write (also inside ``if`` and ``run``).
    """
    for no, line in enumerate(text.split("\n"), 1):
        bad = next((ch for ch in line if not ONE_LINE.fullmatch(ch)), None)
        if bad is not None:
            raise DeckError(f"{where}, line {no}: {line!r} holds {_char(bad)}: allowed printable ASCII "
                            f"only; {outcome}")
    for first, last, line in logical_lines(text):
        at = f"{where}, line {first}" + (f"-{last}" if last > first else "")
        if '"""' in line:
            raise DeckError(f"{at}: {line!r} holds a triple quote, which LAMMPS reads across lines: "
                            f"granflow's templates never write one; {outcome}")
        try:
            words, comment = split_command(line)
            found = commands(line)
        except ValueError as exc:
            raise DeckError(f"{at}: {line!r}: {exc}; {outcome}") from None
        if comment and last > first:
            raise DeckError(f"{at}: {line!r} is a comment continued with &, which hides the line after "
                            f"it: granflow's templates never write one; {outcome}")
        for command in found:
            if command in FORBIDDEN:
                raise DeckError(f"{at}: {line.strip()!r}: the command {command} {FORBIDDEN[command]}, "
                                f"which a deck of granflow never does; {outcome}")
            if command not in allowed or not COMMAND.fullmatch(command):
                raise DeckError(f"{at}: {line.strip()!r}: {command!r} is not a command the scene's templates "
                                f"write: allowed {', '.join(sorted(allowed))}; {outcome}")


# ---------------------------------------------------------------------------- the allow-list
def template_commands(env: jinja2.Environment, name: str) -> frozenset:
    """The LAMMPS commands that template ``name`` and every template it imports or includes write
    (their text with each Jinja tag taken out and each ``{{ value }}`` read as a number), less
    :data:`FORBIDDEN`. A template whose name is computed brings in every ``*.lmp.j2`` there is."""
    sources, todo = {}, [name]
    while todo:
        current = todo.pop()
        if current in sources:
            continue
        sources[current] = source = env.loader.get_source(env, current)[0]
        for tag in _REFERENCE.finditer(source):
            literal = re.match(r"\s*(['\"])([^'\"]+)\1", tag.group(1))
            todo += ([literal.group(2)] if literal
                     else [t for t in env.list_templates() if t.endswith(TEMPLATE_SUFFIX)])
    found = set()
    for source in sources.values():
        text = re.sub(r"\{#.*?#\}|\{%.*?%\}", "", source, flags=re.S)
        text = re.sub(r"\{\{.*?\}\}", "0", text, flags=re.S)
        for _, _, line in logical_lines(text):
            try:
                found.update(c for c in commands(line) if COMMAND.fullmatch(c))
            except ValueError:
                continue
    return frozenset(found - set(FORBIDDEN))


__all__ = ["DeckError", "NAME", "FORBIDDEN", "check_name", "check_context", "check_deck", "template_commands"]
