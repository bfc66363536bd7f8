"""The project dates its numbers by day and commit, never by a count of the periods it was written in.

A note that a number was measured in the so-many-th work period, or a file named for that count, means
nothing to a reader; "2026-11-25, commit 808686a" does. Every file git tracks (its path, and its text
when it is text) is scanned for the word "session" with a number after it (digits, or a number word;
joined by a space, a hyphen, an underscore or nothing, as in a file name) or before it (an ordinal).
The word in its other meanings stays allowed: pytest's ``scope="session"``,
``subprocess.Popen(start_new_session=True)``, a Snakemake or HTTP session. Reads only the index and
the files: about a second.
"""
from __future__ import annotations

import re
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]

#: number words a count could be spelled with (one ... ninety-nine, first ... ninetieth)
_UNITS = "one|two|three|four|five|six|seven|eight|nine"
_TEENS = "ten|eleven|twelve|thirteen|fourteen|fifteen|sixteen|seventeen|eighteen|nineteen"
_TENS = "twenty|thirty|forty|fifty|sixty|seventy|eighty|ninety"
_ORDINALS = ("first|second|third|fourth|fifth|sixth|seventh|eighth|ninth|tenth|eleventh|twelfth|"
             r"\w+teenth|\w+tieth")
_NUMBER_WORD = rf"(?:(?:{_TENS})(?:[- ](?:{_UNITS}))?|{_TEENS}|{_UNITS})"

#: the word with a number after it (digits or a number word; a space, hyphen, underscore, # or nothing
#: between) or an ordinal before it; not after another letter, so start_new_session is no session
WORK_PERIOD = re.compile(
    rf"(?<![a-z])sessions?[ _#-]*(?:\d+|(?:{_NUMBER_WORD})(?![a-z]))"
    rf"|(?<![a-z])(?:\d+(?:st|nd|rd|th)|{_ORDINALS})[ _-]sessions?(?![a-z])",
    re.IGNORECASE)


def tracked_files() -> list[str]:
    """The paths git tracks, from the project root (a file deleted in the working tree is skipped)."""
    out = subprocess.run(["git", "ls-files", "-z"], cwd=ROOT, capture_output=True, check=True).stdout
    return [p for p in out.decode().split("\0") if p and (ROOT / p).is_file()]


def text_of(path: str) -> str | None:
    """The file's text, or None for a binary file (a NUL byte, or not UTF-8)."""
    data = (ROOT / path).read_bytes()
    if b"\0" in data[:8192]:
        return None
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError:
        return None


def findings(path: str, text: str) -> list[str]:
    """``path:line: the match`` for every numbered session in ``text``."""
    out = []
    for number, line in enumerate(text.splitlines(), 1):
        out += [f"{path}:{number}: {m.group(0)!r} in {line.strip()[:120]!r}" for m in WORK_PERIOD.finditer(line)]
    return out


# the examples are built from WORD so that this file does not hold a numbered session itself
WORD = "session"


@pytest.mark.parametrize("text", [
    f"measured in {WORD} 32", f"{WORD.title()} 28 (bench/results/x.txt)", f"two {WORD}-26 runs",
    f"bench/results/bench_cg_{WORD}28.txt", f"{WORD}s 25-28", f"{WORD} #3", f"the 28th {WORD}",
    f"the second {WORD}", f"{WORD} twenty-six", f"{WORD.upper()} 5", f"({WORD} 30, same commit)",
])
def test_a_numbered_session_is_found(text):
    assert WORK_PERIOD.search(text), text


@pytest.mark.parametrize("text", [
    f'@pytest.fixture(scope="{WORD}")', f"@pytest.fixture(scope='{WORD}', autouse=True)",
    f"subprocess.Popen(cmd, start_new_{WORD}=True)", f"a requests.{WORD.title()}() with 3 retries",
    f"one Snakemake {WORD}, 2 cores", f"the {WORD}'s fixtures", f"{WORD}start 2026-11-26",
    "measured 2026-11-25, commit 808686a", f"{WORD}_dir = tmp / 'x'",
])
def test_the_word_in_its_other_meanings_is_allowed(text):
    assert not WORK_PERIOD.search(text), text


def test_no_tracked_file_dates_a_number_by_a_session_count():
    paths = tracked_files()
    assert "tests/unit/test_project_words.py" in paths or len(paths) > 100, "git ls-files found too few files"
    found = []
    for path in paths:
        found += [f"{path}: its name has {m.group(0)!r}" for m in WORK_PERIOD.finditer(path)]
        text = text_of(path)
        if text is not None:
            found += findings(path, text)
    assert not found, ("name the date and the commit instead (git log -S'<text>' --format='%h %ad' --date=short "
                       "finds them):\n  " + "\n  ".join(found[:50]))
