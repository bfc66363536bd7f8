"""Each paper's results as data (granflow.coverage): every scene's table loads, names only checks its
committed record holds, and is counted as the record compares it."""
import csv
from pathlib import Path

import pytest
import yaml

from granflow import coverage, registry
from granflow.yamlio import ConfigError

ROOT = Path(__file__).resolve().parents[2]
#: the scenes whose package lists its paper's results
TABLES = {name: coverage.paper_results_path(name) for name in registry.names()}
WITH_TABLE = sorted(name for name, path in TABLES.items() if path is not None)


def record_quantities(scene_name: str) -> set[str]:
    """The ``quantity`` of every row of the committed ``validation/<scene>/checks.csv``."""
    with open(ROOT / "validation" / scene_name / "checks.csv", newline="", encoding="utf-8") as f:
        return {row["quantity"] for row in csv.DictReader(f)}


def test_every_scene_with_a_paper_lists_its_results():
    # a scene that names a paper owes the list of what the paper states (STYLE.md: every result is either
    # compared or listed with the reason it is not)
    with_paper = sorted(name for name, scene in registry.scenes().items() if scene.paper)
    assert with_paper and [name for name in with_paper if TABLES[name] is None] == []


@pytest.mark.parametrize("scene_name", WITH_TABLE)
def test_the_table_loads_with_unique_ids(scene_name):
    entries = coverage.load(TABLES[scene_name])["results"]
    ids = [e["id"] for e in entries]
    assert len(ids) == len(set(ids))


@pytest.mark.parametrize("scene_name", WITH_TABLE)
def test_every_compared_by_quantity_is_a_row_of_the_record(scene_name):
    # keeps the table and the record in step: a renamed or dropped check must be renamed or dropped here
    held = record_quantities(scene_name)
    entries = coverage.load(TABLES[scene_name])["results"]
    missing = [(e["id"], q) for e in entries for q, _ in coverage.rows(e) if q not in held]
    assert missing == []


@pytest.mark.parametrize("scene_name", WITH_TABLE)
def test_the_record_is_counted_and_gives_one_line(scene_name):
    with open(ROOT / "validation" / scene_name / "checks.csv", newline="", encoding="utf-8") as f:
        checks = list(csv.DictReader(f))
    n, m, not_compared = coverage.coverage(scene_name, checks)
    assert 0 <= n <= m and len(not_compared) == m - n
    assert coverage.coverage_line(scene_name, checks) == f"coverage: {n} of {m} results of the paper compared"


SYNTHETIC = {
    "paper": "A. Author (2000), a paper",
    "results": [
        {"id": "plain", "result": "x = 1", "where": "§1", "form": "value", "compared_by": ["x"]},
        {"id": "second_row", "result": "y ∝ z", "where": "§2", "form": "scaling",
         "compared_by": ["y exponent (old)", "y exponent"]},
        {"id": "row_absent", "result": "w = 2", "where": "§3", "form": "value", "compared_by": ["w"]},
        {"id": "row_relabelled", "result": "v = 3", "where": "§4", "form": "value", "compared_by": ["v"]},
        {"id": "forced", "result": "a = 3", "where": "eq. 1", "form": "law", "compared_by": ["a"],
         "kind": "consistency", "not_compared": "forced by a definition"},
        {"id": "mixed", "result": "b ∝ √R", "where": "fig. 2", "form": "scaling",
         "compared_by": [{"quantity": "b (kernel)", "kind": "diagnostic"}, "b (plane)"]},
        {"id": "only_diagnostic", "result": "c = 4", "where": "fig. 3", "form": "value",
         "compared_by": [{"quantity": "c", "kind": "diagnostic"}], "not_compared": "a kernel reading"},
        {"id": "unmeasured", "result": "d falls", "where": "fig. 4", "form": "trend",
         "not_compared": "not in our output"},
    ],
}
CHECKS = [
    {"quantity": "x"},                                  # a record without kinds: a comparison
    {"quantity": "x", "kind": "comparison"},            # the same quantity in another case
    {"quantity": "y exponent", "kind": "comparison"},
    {"quantity": "v", "kind": "diagnostic"},            # relabelled: no longer compares the paper
    {"quantity": "a", "kind": "comparison"},            # compared by the record, but the table says forced
    {"quantity": "b (kernel)", "kind": "comparison"},   # the table takes this row as a diagnostic
    {"quantity": "b (plane)", "kind": ""},              # an empty kind (a csv cell): a comparison
    {"quantity": "c", "kind": "comparison"},
    {"quantity": "unrelated", "kind": "comparison"},
]


def test_coverage_counts_comparisons_only():
    coverage.validate(SYNTHETIC, "synthetic")
    n, m, not_compared = coverage.count(SYNTHETIC["results"], CHECKS)
    # compared: plain, second_row (one of its rows), mixed (its plane row); not: the rest, in order
    assert (n, m) == (3, 8)
    assert [name for name, _ in not_compared] == ["row_absent", "row_relabelled", "forced", "only_diagnostic",
                                                  "unmeasured"]
    reasons = dict(not_compared)
    assert reasons["forced"] == "forced by a definition" and reasons["unmeasured"] == "not in our output"
    assert reasons["row_absent"] == "no comparison check of the record has its rows: w"
    assert reasons["row_relabelled"] == "no comparison check of the record has its rows: v"


def test_a_comparison_row_without_a_number_compares_nothing():
    # the row is in the record (its quantity a comparison) but was not measured: NaN in summary.json, an empty
    # cell in checks.csv; the result counts as not compared, and says why
    for empty in (float("nan"), "", None, "nan"):
        checks = [{"quantity": "x", "kind": "comparison", "ours": empty}, {"quantity": "y exponent", "ours": 0.5}]
        n, m, not_compared = coverage.count(SYNTHETIC["results"], checks)
        assert n == 1 and dict(not_compared)["plain"] == ("its rows are in the record but not measured (no "
                                                           "number): x")
    n, _, _ = coverage.count(SYNTHETIC["results"], [{"quantity": "x", "ours": "0.9"}, {"quantity": "x", "ours": ""}])
    assert n == 1                                        # one measured row of the quantity is enough


def test_no_checks_compare_nothing():
    n, m, not_compared = coverage.count(SYNTHETIC["results"], [])
    assert (n, m, len(not_compared)) == (0, 8, 8)


def test_coverage_of_a_scene_reads_its_file(tmp_path, monkeypatch):
    path = tmp_path / coverage.FILE_NAME
    path.write_text("paper: A. Author (2000)\nresults:\n"
                    "  - {id: one, result: x = 1, where: §1, form: value, compared_by: [x]}\n"
                    "  - {id: two, result: y = 2, where: §2, form: value, not_compared: needs the paper's size}\n",
                    encoding="utf-8")
    monkeypatch.setattr(coverage, "paper_results_path", lambda name: path if name == "listed" else None)
    assert coverage.coverage("listed", [{"quantity": "x"}]) == (1, 2, [("two", "needs the paper's size")])
    assert coverage.coverage_line("listed", [{"quantity": "x"}]) == "coverage: 1 of 2 results of the paper compared"
    assert coverage.coverage_line("unlisted", [{"quantity": "x"}]) == ""
    with pytest.raises(ConfigError, match="has no paper_results.yaml"):
        coverage.coverage("unlisted", [])


def test_an_unknown_scene_has_no_table():
    assert coverage.paper_results_path("no_such_scene") is None
    assert coverage.coverage_line("no_such_scene", []) == ""


def _refusal(tmp_path, text: str) -> str:
    path = tmp_path / coverage.FILE_NAME
    path.write_text(text, encoding="utf-8")
    with pytest.raises(ConfigError) as err:
        coverage.load(path)
    assert str(path) in str(err.value)
    return str(err.value)


HEAD = "paper: A. Author (2000)\nresults:\n"


@pytest.mark.parametrize("entry, says", [
    ("{id: a_b, result: x, where: §1, form: value}", "results[0] (id 'a_b'): compared_by: neither compared_by nor "
                                                    "not_compared"),
    ("{id: a_b, result: x, where: §1, form: valu, not_compared: r}", "results[0] (id 'a_b'): form: 'valu' is not one"),
    ("{id: a_b, result: x, where: §1, not_compared: r}", "results[0] (id 'a_b'): 'form' is a required property"),
    ("{id: a_b, result: x, where: §1, form: value, not_compared: r, colour: red}",
     "results[0] (id 'a_b'): unknown key colour"),
    ("{id: a_b, result: x, where: §1, form: value, compared_by: [q], not_compared: r}",
     "results[0] (id 'a_b'): not_compared: given beside comparison rows (q)"),
    ("{id: a_b, result: x, where: §1, form: value, compared_by: [q], kind: diagnostic}",
     "results[0] (id 'a_b'): not_compared: missing"),
    ("{id: a_b, result: x, where: §1, form: value, kind: consistency, not_compared: r}",
     "results[0] (id 'a_b'): kind: given without compared_by"),
    ("{id: a_b, result: x, where: §1, form: value, compared_by: [{quantity: q, kind: guess}]}",
     "results[0] (id 'a_b'): compared_by[0]: {'quantity': 'q', 'kind': 'guess'} is neither"),
    ("{id: A-b, result: x, where: §1, form: value, not_compared: r}", "results[0] (id 'A-b'): id: 'A-b' does not match"),
])
def test_a_bad_entry_is_refused_naming_file_entry_and_key(tmp_path, entry, says):
    assert says in _refusal(tmp_path, HEAD + f"  - {entry}\n")


def test_a_repeated_id_is_refused(tmp_path):
    entry = "{id: same, result: x, where: §1, form: value, not_compared: r}"
    says = _refusal(tmp_path, HEAD + f"  - {entry}\n  - {entry}\n")
    assert "results[1] (id 'same'): id: the id of results[0] too: ids must be unique" in says


def test_every_problem_is_listed_one_a_line(tmp_path):
    says = _refusal(tmp_path, "results:\n  - {id: one, result: x, where: §1, form: value}\n"
                              "  - {id: two, result: x, where: §1, form: trend, compared_by: []}\n")
    lines = says.splitlines()
    # the missing paper, the empty list (its entry then not checked further) and the first entry's lack
    assert len(lines) == 3 and all(line.startswith(str(tmp_path)) for line in lines)
    assert any("(top level): 'paper' is a required property" in line for line in lines)
    assert any("results[1] (id 'two'): compared_by: [] should be non-empty" in line for line in lines)
    assert any("results[0] (id 'one'): compared_by: neither compared_by nor not_compared" in line for line in lines)


def ladder_quantities(scene_name: str) -> set[tuple[str, str]]:
    """``(rung, quantity)`` of every row of the committed ``validation/<scene>/ladder.csv`` (none without one)."""
    path = ROOT / "validation" / scene_name / "ladder.csv"
    if not path.exists():
        return set()
    with open(path, newline="", encoding="utf-8") as f:
        return {(row["rung"], row["quantity"]) for row in csv.DictReader(f)}


@pytest.mark.parametrize("scene_name", WITH_TABLE)
def test_every_ladder_row_named_is_a_row_of_the_committed_ladder(scene_name):
    held = ladder_quantities(scene_name)
    entries = coverage.load(TABLES[scene_name])["results"]
    missing = [(e["id"], rung, q) for e in entries for q, _, rung in coverage.ladder_rows(e) if (rung, q) not in held]
    assert missing == []


def test_a_result_compared_only_by_a_ladder_row_counts_and_the_line_says_so(monkeypatch, tmp_path):
    entries = [
        {"id": "on_record", "result": "x = 1", "where": "§1", "form": "value", "compared_by": ["x"]},
        {"id": "on_ladder", "result": "a ≈ 0.22 across runs", "where": "§2", "form": "scaling",
         "compared_by": [{"quantity": "a", "ladder": "pool"}, {"quantity": "a (one case)", "kind": "diagnostic"}]},
    ]
    coverage.validate({"paper": "A. Author (2000), a paper", "results": entries}, "synthetic")
    checks = [{"quantity": "x", "ours": "1.0"}, {"quantity": "a (one case)", "ours": "0.3", "kind": "diagnostic"}]
    ladder = [{"rung": "pool", "quantity": "a", "ours": "0.24", "kind": "comparison"},
              {"rung": "other", "quantity": "a", "ours": "0.5", "kind": "comparison"}]
    assert coverage.count(entries, checks)[0] == 1
    assert coverage.count(entries, checks, ladder)[0] == 2
    # a ladder row of another rung, or one without a number, or a diagnostic does not count
    for rows in ([ladder[1]], [{**ladder[0], "ours": ""}], [{**ladder[0], "kind": "diagnostic"}]):
        n, _, why = coverage.count(entries, checks, rows)
        assert n == 1 and "ladder pool" in dict(why)["on_ladder"]
    path = tmp_path / "paper_results.yaml"
    path.write_text(yaml.safe_dump({"paper": "A. Author (2000), a paper", "results": entries}, allow_unicode=True))
    monkeypatch.setattr(coverage, "paper_results_path", lambda name: path)
    assert coverage.coverage_line("s", checks, ladder) == ("coverage: 2 of 2 results of the paper compared "
                                                          "(1 of them by the ladder's rungs)")
    assert coverage.coverage_line("s", checks) == "coverage: 1 of 2 results of the paper compared"
    with pytest.raises(ConfigError, match="ladder"):
        coverage.validate({"paper": "p", "results": [{**entries[0], "compared_by": [{"quantity": "x"}]}]}, "bad")
