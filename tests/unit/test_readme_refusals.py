"""The table of refusals (docs/statuses-and-refusals.md, linked from the README) is what the code prints:
every command runs, exits 2 and prints the quoted message (``...`` stands for text left out), with no
traceback and nothing written."""
import re
import shlex
from pathlib import Path

import pytest

from granflow.cli import main

ROOT = Path(__file__).resolve().parents[2]

#: the page that holds the table (it moved there from the README, issue 30) and the table's section
PAGE = ROOT / "docs" / "statuses-and-refusals.md"
SECTION = "### Bad input we refuse (before anything runs)"


def section_text(text: str, heading: str) -> str:
    """The lines under ``heading`` up to the next heading of its level or above (code fences skipped)."""
    level = len(heading.split()[0])
    lines = text.splitlines()
    start = lines.index(heading) + 1
    out, fenced = [], False
    for line in lines[start:]:
        if line.startswith("```"):
            fenced = not fenced
        m = None if fenced else re.match(r"^(#+) ", line)
        if m and len(m.group(1)) <= level:
            break
        out.append(line)
    return "\n".join(out)


def table_rows() -> list[tuple[str, str]]:
    section = section_text(PAGE.read_text(), SECTION)
    rows = []
    for line in section.splitlines():
        m = re.match(r"^\| `(granflow [^`]*)` \| `([^`]*)`", line)
        if m:
            rows.append((m.group(1), m.group(2)))
    return rows


ROWS = table_rows()


def test_the_table_has_its_rows():
    assert len(ROWS) >= 15, ROWS


@pytest.mark.parametrize("command, message", ROWS, ids=[r[0][9:60] for r in ROWS])
def test_readme_refusal_is_what_the_code_prints(capsys, monkeypatch, command, message):
    monkeypatch.chdir(ROOT)
    argv = shlex.split(command)[1:]
    assert main(argv) == 2, command
    err = capsys.readouterr().err
    assert "Traceback" not in err
    prefix = "granflow: refused: "
    assert err.startswith(prefix), err
    pattern = ".*?".join(re.escape(part) for part in message.split("..."))
    assert re.search(pattern, err[len(prefix):], re.S), f"{PAGE.name} quotes\n  {message}\nthe code prints\n  {err}"
