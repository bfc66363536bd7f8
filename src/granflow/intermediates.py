"""Intermediates that say when they are damaged, and outputs that survive a failed rebuild.

Every JSON and CSV file a workflow rule reads goes through :func:`read_json`,
:func:`read_csv` or :func:`verify_folder`. A file that is missing, empty, cut short,
not JSON, not a table, or not the file its producer wrote (its SHA-256 differs from
the checksum written beside it) raises :class:`DamagedIntermediate`, whose message is
one line: the file, what is wrong with it, and the Snakemake command that rebuilds it.
:func:`report_plainly` makes an adapter script print that line (to the rule's log and
to the terminal) instead of a traceback.

Checksums use the format of ``sha256sum``, so ``sha256sum -c`` checks them by hand:
a folder (a case's ``analysis/``) holds ``SHA256SUMS`` over its files; a single file
``x.csv`` has ``x.csv.sha256`` beside it. Both are written last, so a folder or file
without its checksum was not finished.

Outputs are written under a temporary name beside their place and moved there only
when complete (:func:`replacing`, :func:`replacing_folder`): a rebuild that fails
leaves the last good file where it was.
"""
from __future__ import annotations

import csv
import io
import json
import os
import shlex
import shutil
import sys
from collections.abc import Iterable, Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path

import pandas as pd

from .provenance import sha256  # noqa: F401 (the checksums' hash; scripts import it from here)

#: the checksum list of a folder (``sha256sum`` format, names relative to the folder)
SUMS = "SHA256SUMS"
#: environment variable holding the snakemake command of the running campaign, without targets
#: (set by the workflow when it is read, so the rebuild command names the same campaign)
COMMAND_ENV = "GRANFLOW_SNAKEMAKE_COMMAND"
DEFAULT_COMMAND = "snakemake --cores 2"


class DamagedIntermediate(Exception):
    """A file a rule reads is missing, cut short, not parseable or not what its producer wrote.

    Parameters
    ----------
    path : the damaged file.
    what : what is wrong with it, e.g. ``not JSON: Expecting value (line 1, column 1)``.
    rebuild : the output of the rule that writes ``path`` (``path`` itself when it is a
        declared output), forced by the suggested command.
    """

    def __init__(self, path: str | Path, what: str, rebuild: str | Path | None = None):
        self.path, self.what = str(path), what
        self.rebuild = str(rebuild if rebuild is not None else path)
        super().__init__(f"{self.path}: {what}; rebuild it with: {rebuild_command(self.rebuild)}")


def rebuild_command(target: str | Path) -> str:
    """The command that reruns the rule writing ``target`` (and then whatever reads it).

    ``--forcerun=FILE`` reruns the job whose output FILE is (written with ``=``, so that targets
    added after it stay targets); the campaign's options come from :data:`COMMAND_ENV` (see
    :func:`snakemake_command`).
    """
    return f"{os.environ.get(COMMAND_ENV) or DEFAULT_COMMAND} --forcerun={shlex.quote(str(target))}"


def snakemake_command(snakefile: str | Path, workdir: str | Path, cores: int | None,
                      configfiles: Iterable[str | Path] = (), config_args: Iterable[str] = ()) -> str:
    """The snakemake command of a campaign without its targets: ``snakemake --cores N``, with
    ``--snakefile``/``--directory`` when the working directory is not the Snakefile's, and the
    campaign's own ``--configfile`` and ``--config`` options."""
    words = ["snakemake", "--cores", str(cores or 2)]
    snakefile, workdir = Path(snakefile).resolve(), Path(workdir).resolve()
    if snakefile != workdir / "Snakefile":
        words += ["--snakefile", str(snakefile), "--directory", str(workdir)]
    for f in configfiles:
        words += ["--configfile", str(Path(f).resolve())]
    config_args = list(config_args)
    if config_args:
        words += ["--config", *config_args]
    return shlex.join(words)


def _read_bytes(path: Path, rebuild) -> bytes:
    try:
        return path.read_bytes()
    except FileNotFoundError:
        raise DamagedIntermediate(path, "missing", rebuild) from None
    except IsADirectoryError:
        raise DamagedIntermediate(path, "a folder where a file was expected", rebuild) from None


def read_json(path: str | Path, rebuild: str | Path | None = None, keys: Sequence[str] = ()) -> object:
    """The JSON value in ``path``; ``keys`` must be present (the value then is an object).

    Raises
    ------
    DamagedIntermediate
        if the file is missing, empty, not UTF-8, not JSON, or lacks one of ``keys``.
    """
    path = Path(path)
    raw = _read_bytes(path, rebuild)
    if not raw.strip():
        raise DamagedIntermediate(path, "empty", rebuild)
    try:
        value = json.loads(raw.decode("utf-8"))
    except UnicodeDecodeError as exc:
        raise DamagedIntermediate(path, f"not UTF-8 text (byte {exc.start})", rebuild) from None
    except json.JSONDecodeError as exc:
        raise DamagedIntermediate(path, f"not JSON: {exc.msg} (line {exc.lineno}, column {exc.colno})",
                                  rebuild) from None
    if keys and not isinstance(value, dict):
        raise DamagedIntermediate(path, f"JSON {type(value).__name__} where an object was expected", rebuild)
    missing = [k for k in keys if k not in value]
    if missing:
        raise DamagedIntermediate(path, f"lacks {', '.join(map(repr, missing))}", rebuild)
    return value


def read_csv(path: str | Path, rebuild: str | Path | None = None, sep: str = ",",
             allow_empty: bool = False) -> pd.DataFrame:
    """The table in ``path``, after checking that it is whole.

    Our writers end every row with a line end and give every row as many fields as the
    header; a file cut short (a row without its line end, or with fewer fields) is
    refused rather than read with NaN in the missing places. ``allow_empty`` accepts an
    empty file (a case that was not averaged writes empty tables) as an empty table.

    Raises
    ------
    DamagedIntermediate
        if the file is missing, empty (unless allowed), cut short, ragged or not text.
    """
    path = Path(path)
    raw = _read_bytes(path, rebuild)
    if not raw.strip():
        if allow_empty:
            return pd.DataFrame()
        raise DamagedIntermediate(path, "empty", rebuild)
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise DamagedIntermediate(path, f"not UTF-8 text (byte {exc.start})", rebuild) from None
    if not text.endswith("\n"):
        raise DamagedIntermediate(path, f"cut short: line {text.count(chr(10)) + 1} has no line end", rebuild)
    rows = csv.reader(io.StringIO(text), delimiter=sep)
    width = len(next(rows))
    for number, row in enumerate(rows, start=2):
        if row and len(row) != width:
            raise DamagedIntermediate(path, f"line {number} has {len(row)} fields where the header has {width}",
                                      rebuild)
    try:
        return pd.read_csv(io.StringIO(text), sep=sep)
    except (pd.errors.ParserError, pd.errors.EmptyDataError, ValueError) as exc:
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise DamagedIntermediate(path, f"not a table ({first})", rebuild) from None


def _sums_line(digest: str, name: str) -> str:
    return f"{digest}  {name}\n"


def _parse_sums(path: Path, rebuild) -> dict[str, str]:
    raw = _read_bytes(path, rebuild)
    out = {}
    try:
        lines = raw.decode("ascii").splitlines()
    except UnicodeDecodeError:
        lines = [""]
    for number, line in enumerate(lines, start=1):
        digest, sep, name = line.partition("  ")
        if not sep or len(digest) != 64 or any(c not in "0123456789abcdef" for c in digest) or not name:
            raise DamagedIntermediate(path, f"line {number} is not '<sha256>  <file>'", rebuild)
        out[name] = digest
    if not out:
        raise DamagedIntermediate(path, "empty", rebuild)
    return out


def write_checksum(path: str | Path) -> Path:
    """Write ``<path>.sha256`` (``sha256sum`` format); call it once ``path`` is complete."""
    path = Path(path)
    out = path.with_name(path.name + ".sha256")
    with replacing(out) as tmp:
        tmp.write_text(_sums_line(sha256(path), path.name))
    return out


def verify_checksum(path: str | Path, rebuild: str | Path | None = None) -> Path:
    """Check ``path`` against ``<path>.sha256``; returns ``path``.

    Raises
    ------
    DamagedIntermediate
        if either file is missing or damaged, or the file changed after its producer wrote it.
    """
    path = Path(path)
    sums = path.with_name(path.name + ".sha256")
    expected = _parse_sums(sums, rebuild or path)
    if set(expected) != {path.name}:
        raise DamagedIntermediate(sums, f"names {', '.join(sorted(expected))}, not {path.name}", rebuild or path)
    if not path.exists():
        raise DamagedIntermediate(path, "missing", rebuild)
    if sha256(path) != expected[path.name]:
        raise DamagedIntermediate(path, f"changed after it was written (its SHA-256 differs from {sums.name})",
                                  rebuild)
    return path


def write_sums(folder: str | Path) -> Path:
    """Write ``folder/SHA256SUMS`` over every file in ``folder`` (not hidden ones); call it last."""
    folder = Path(folder)
    files = sorted(p for p in folder.iterdir() if p.is_file() and p.name != SUMS and not p.name.startswith("."))
    with replacing(folder / SUMS) as tmp:
        tmp.write_text("".join(_sums_line(sha256(p), p.name) for p in files))
    return folder / SUMS


def verify_folder(folder: str | Path, rebuild: str | Path | None = None) -> list[Path]:
    """Check every file listed in ``folder/SHA256SUMS``; returns them, in the listed order.

    ``rebuild`` defaults to the ``SHA256SUMS`` file (an output of the rule that writes the folder).

    Raises
    ------
    DamagedIntermediate
        if the list is missing (the folder was not finished) or damaged, or a listed file is
        missing or changed after it was written.
    """
    folder = Path(folder)
    rebuild = rebuild or folder / SUMS
    out = []
    for name, digest in _parse_sums(folder / SUMS, rebuild).items():
        path = folder / name
        if not path.is_file():
            raise DamagedIntermediate(path, f"missing (listed in {SUMS})", rebuild)
        if sha256(path) != digest:
            raise DamagedIntermediate(path, f"changed after it was written (its SHA-256 differs from {SUMS})",
                                      rebuild)
        out.append(path)
    return out


@contextmanager
def replacing(path: str | Path) -> Iterator[Path]:
    """A temporary name beside ``path`` (same suffix, so writers that go by it still work),
    moved onto ``path`` only if the block ends without an error; else removed.

    The last good ``path`` thus stays in place until its replacement is complete.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.stem}.partial{path.suffix}")
    tmp.unlink(missing_ok=True)
    try:
        yield tmp
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)


@contextmanager
def replacing_folder(path: str | Path) -> Iterator[Path]:
    """A new, empty folder beside ``path``, put in its place only if the block ends without an
    error (the old folder is then removed); else removed, leaving the old folder untouched."""
    path = Path(path)
    new, old = path.with_name(f".{path.name}.partial"), path.with_name(f".{path.name}.old")
    for stale in (new, old):
        if stale.exists():
            shutil.rmtree(stale)
    new.mkdir(parents=True)
    try:
        yield new
        if path.exists():
            os.replace(path, old)
        os.replace(new, path)
        shutil.rmtree(old, ignore_errors=True)
    finally:
        if new.exists():
            shutil.rmtree(new)


def report_plainly(kept: Iterable[str | Path] = ()) -> None:
    """Make an uncaught :class:`DamagedIntermediate` print one line, to ``sys.stderr`` (the rule's
    log) and to the terminal, instead of a traceback; the script still exits with status 1.

    ``kept`` are the rule's outputs: those that exist when it fails are named as kept in
    place (Snakemake's ``update()`` flag keeps them; the scripts write them by
    :func:`replacing`). Other exceptions keep their traceback.
    """
    previous = sys.excepthook
    kept = [Path(k) for k in kept]

    def hook(kind, exc, tb):
        if not isinstance(exc, DamagedIntermediate):
            previous(kind, exc, tb)
            return
        there = [str(k) for k in kept if k.exists()]
        line = f"granflow: damaged intermediate: {exc}" + (
            f"; the last good {', '.join(there)} stay{'s' if len(there) == 1 else ''} in place" if there else "")
        for stream in dict.fromkeys([sys.stderr, sys.__stderr__]):
            if stream is not None:
                print(line, file=stream, flush=True)

    sys.excepthook = hook


__all__ = ["COMMAND_ENV", "SUMS", "DamagedIntermediate", "read_csv", "read_json", "rebuild_command",
           "replacing", "replacing_folder", "report_plainly", "sha256", "snakemake_command", "verify_checksum",
           "verify_folder", "write_checksum", "write_sums"]
