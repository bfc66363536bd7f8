"""The record's numbers in README.md and docs/ are the record's: every mark says what validation/ holds.

A page quotes a number of the validation record through a mark that ``tools/docs_record.py`` fills
from ``validation/<scene>/summary.json`` (:mod:`granflow.docs_record`). Here: every mark of every page
is what the record gives now, so a record rewritten without ``python tools/docs_record.py`` fails,
naming the page, the line and the mark; a phrase that quotes the record ("the record says ...") is
followed by a mark, not by a number typed by hand; and the generator itself on a tiny hand-made
record: a check found by its quantity's start and its case (ambiguity and absence refused, naming
the quantity), the three forms, the table, and a refresh that changes only the marks' bodies.
"""
from __future__ import annotations

import json
from pathlib import Path

import pytest

from granflow import docs_record as dr

ROOT = Path(__file__).resolve().parents[2]
RECORD = dr.load_record(ROOT / "validation")
PAGES = dr.pages(ROOT)


def test_the_pages_hold_marks():
    assert ROOT / "README.md" in PAGES and len(PAGES) > 10
    assert sum(len(dr.marks(p.read_text(), RECORD)) for p in PAGES) >= 5


@pytest.mark.parametrize("page", PAGES, ids=lambda p: str(p.relative_to(ROOT)))
def test_every_mark_is_what_the_record_gives(page):
    stale = dr.stale_marks(page.read_text(), RECORD)
    assert not stale, (f"{page.relative_to(ROOT)}: marks differ from the record (run python tools/docs_record.py): "
                       + "; ".join(f"line {m.line} <!-- {m.kind}: {m.args} --> says {m.body.strip()!r}, the record "
                                   f"{m.want.strip()!r}" for m in stale))


@pytest.mark.parametrize("page", PAGES, ids=lambda p: str(p.relative_to(ROOT)))
def test_a_number_quoted_as_the_records_is_a_mark(page):
    found = dr.unmarked_quotes(page.read_text())
    assert not found, (f"{page.relative_to(ROOT)}: a number typed by hand after a phrase that quotes the record "
                       "(mark it: <!-- record: SCENE | QUANTITY | CASE | FORM -->…<!-- /record -->, or date it and "
                       "drop the phrase): " + "; ".join(f"line {line}: {phrase!r}" for line, phrase in found))


# ------------------------------------------------------------------ the generator on a hand-made record
def _check(quantity, case, ours, error, syst=None, verdict="within error (1.0 σ)", unit="", kind="comparison"):
    return {"quantity": quantity, "case": case, "ours": ours, "error": error, "syst": syst, "verdict": verdict,
            "unit": unit, "kind": kind, "paper": "1.37–1.40", "paper_range": [1.37, 1.40]}


@pytest.fixture
def record(tmp_path):
    summary = {"scene": "box", "record_commit": "0123456789abcdef", "cpu_hours": 0.5,
               "cases": [{"dir": "a~1", "status": "steady"}, {"dir": "a~2", "status": "steady"}],
               "checks": [_check("ratio", "a~1", 1.33204, 0.00323, 0.00081,
                                 "one sample: off by -2.8 % (11 σ with stat and syst); 'differs' needs two"),
                          _check("ratio", "a~2", 1.343, 0.003, 0.001),
                          _check("ratio of the drift", "a~1", 0.01, 0.02, kind="diagnostic",
                                 verdict="diagnostic: no verdict against the paper"),
                          _check("angle (middle)", "a~1", 26.76, 0.14, 0.14, unit="°")]}
    (tmp_path / "box").mkdir()
    (tmp_path / "box" / "summary.json").write_text(json.dumps(summary))
    return dr.load_record(tmp_path)


def test_a_mark_names_one_check_by_its_quantity_and_case(record):
    # the exact quantity wins over a longer one it starts ("ratio of the drift")
    assert dr.inline_text(record, "box | ratio | a~1 | value") == "1.33204 ± 0.00323 ± 0.00081"
    assert dr.inline_text(record, "box | ratio | a~1 | verdict") == "1 run: off by -2.8 % (11 σ)"
    assert dr.inline_text(record, "box | ratio | a~2") == "1.3430 ± 0.0030 ± 0.0010, within error (1.0 σ)"
    assert dr.inline_text(record, "box | angle | | value") == "26.76 ± 0.14 ± 0.14°"
    with pytest.raises(dr.RecordMarkError, match="'ratio'.*2 checks match"):
        dr.inline_text(record, "box | ratio")
    with pytest.raises(dr.RecordMarkError, match="'slip' on case 'a~1': no such check"):
        dr.inline_text(record, "box | slip | a~1")
    with pytest.raises(dr.RecordMarkError, match="no record of scene 'drum'"):
        dr.inline_text(record, "drum | ratio | a~1")
    with pytest.raises(dr.RecordMarkError, match="form 'long'"):
        dr.inline_text(record, "box | ratio | a~1 | long")


def test_the_table_holds_the_headline_comparisons(record):
    text = dr.table_text(record, "box")
    assert "0.50 CPU-h, written at commit 0123456" in text and "2 case(s)" in text
    assert "| ratio | a~1 | 1.33204 ± 0.00323 ± 0.00081 | 1.37–1.40 | 1 run: off by -2.8 % (11 σ) |" in text
    assert "drift" not in text       # a diagnostic is never a headline
    assert "| box | ratio |" in dr.table_text(record, "*")


def test_refresh_rewrites_only_the_marks_and_a_stale_one_is_named(record, tmp_path):
    page = tmp_path / "page.md"
    page.write_text("The record has <!-- record: box | ratio | a~1 | value -->1.28<!-- /record --> at W = 60.\n\n"
                    "<!-- record-table: box -->\nold table\n<!-- /record-table -->\nAfter.\n")
    stale = dr.stale_marks(page.read_text(), record)
    assert [(m.kind, m.line, m.body) for m in stale] == [("record", 1, "1.28"), ("record-table", 3, "old table\n")]
    assert dr.refresh([page], record) == [page]
    text = page.read_text()
    assert text.startswith("The record has <!-- record: box | ratio | a~1 | value -->1.33204 ± 0.00323 ± 0.00081"
                           "<!-- /record --> at W = 60.\n\n<!-- record-table: box -->\n")
    assert text.endswith("<!-- /record-table -->\nAfter.\n")
    assert not dr.stale_marks(text, record)
    assert dr.refresh([page], record) == []        # a second refresh changes nothing


def test_a_mark_shown_as_code_is_not_a_mark(record):
    text = ("Syntax: `<!-- record: SCENE | QUANTITY -->…<!-- /record -->`.\n"
            "```\n<!-- record: box | nothing -->1<!-- /record -->\n```\n")
    assert dr.marks(text, record) == [] and dr.render(text, record) == text


def test_a_hand_typed_number_after_a_record_phrase_is_caught():
    text = ("Demo 1.17 (the validation record has 1.28 and 1.30 at W = 60).\n"
            "```\nthe record says 3\n```\n"                               # code is not prose
            "Now the record says <!-- record: box | ratio | a~1 -->x<!-- /record --> at W = 60.\n"
            "The record has every check of the campaign.\n")                # no number quoted: fine
    assert dr.unmarked_quotes(text) == [(1, "the validation record has")]
