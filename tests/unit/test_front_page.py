"""The report's front page read at a glance (granflow.overview), built from the committed records
(validation/<scene>/summary.json): one line per case with a reason of a few words, derived by rule."""
import importlib.util
import json
import math
import re
from html.parser import HTMLParser
from pathlib import Path

import jinja2
import pytest
from docutils.core import publish_parts

from granflow import overview, registry
from granflow.overview import SHORT_REASON, cut, first_clause, overview_rst, short_reason

ROOT = Path(__file__).resolve().parents[2]
RECORDS = sorted((ROOT / "validation").glob("*/summary.json"))


def html_of(text: str) -> str:
    """What Snakemake's report does with the page: Jinja, then docutils' html writer."""
    return publish_parts(jinja2.Environment().from_string(text).render(), writer="html",
                         settings_overrides={"halt_level": 2, "report_level": 2})["html_body"]


class Tables(HTMLParser):
    """Each table of a page: its caption and its rows of cell texts (header row first)."""

    def __init__(self, html: str):
        super().__init__()
        self.tables, self._cell = [], None
        self.feed(html)

    def handle_starttag(self, tag, attrs):
        if tag == "table":
            self.tables.append({"class": dict(attrs).get("class", ""), "caption": "", "rows": []})
        elif tag == "tr":
            self.tables[-1]["rows"].append([])
        elif tag in ("td", "th", "caption"):
            self._cell = []

    def handle_endtag(self, tag):
        if tag in ("td", "th") and self._cell is not None:
            self.tables[-1]["rows"][-1].append(" ".join("".join(self._cell).split()))
            self._cell = None
        elif tag == "caption" and self._cell is not None:
            self.tables[-1]["caption"] = " ".join("".join(self._cell).split())
            self._cell = None

    def handle_data(self, data):
        if self._cell is not None:
            self._cell.append(data)


@pytest.fixture(scope="module")
def records():
    assert RECORDS, "no committed records under validation/"
    return [json.loads(p.read_text()) for p in RECORDS]


@pytest.fixture(scope="module")
def page(records):
    html = html_of(overview_rst(records, "validation"))
    return html, Tables(html).tables


def cases_table(tables):
    (table,) = [t for t in tables if t["rows"] and t["rows"][0][:3] == ["scene", "case", "status: reason"]]
    return table


# ------------------------------------------------------------------ the rule
def test_a_steady_case_is_its_status_word():
    assert short_reason("steady", "from t = 80 to 200: relative fluctuation 2.16% (< 5.00%)") == "steady"


def test_another_status_adds_the_first_clause_of_its_reason():
    assert short_reason("jammed", "wall friction holds; mean speed 1e-5 over the last 50") == \
        "jammed: wall friction holds"
    assert short_reason("arrested", "the bed stopped, the paper's arrested regime (below theta_stop)") == \
        "arrested: the bed stopped"
    assert short_reason("clogged", "outflow 0.0123 kg/s in the last segment is below 2 % of Beverloo") == \
        "clogged: outflow 0.0123 kg/s in the last segment…"
    # a comma or point inside a number is no clause boundary
    assert first_clause("27,727 particles at t = 0.3 s (fill)") == "27,727 particles at t = 0.3 s"
    assert short_reason("unstable", "") == "unstable" and short_reason(None, None) == "unknown"


def test_the_clause_is_cut_at_a_word_boundary_with_an_ellipsis():
    text = "mean speed 0.000123 over the last 50 time units is below jam_speed 0.001"
    out = cut(text, SHORT_REASON)
    assert out == "mean speed 0.000123 over the last 50…"
    assert len(out) <= SHORT_REASON + 1 and text.startswith(out[:-1])
    assert cut("short enough", SHORT_REASON) == "short enough"
    assert cut("x" * 60, SHORT_REASON) == "x" * SHORT_REASON + "…"     # no boundary: cut at the limit


# ------------------------------------------------------------------ the committed records
def test_every_case_is_one_row_with_a_reason_of_a_few_words(records, page):
    _, tables = page
    rows = cases_table(tables)["rows"][1:]
    cases = [(s["scene"], c) for s in records for c in s["cases"]]
    assert len(rows) == len(cases)
    for row, (scene, case) in zip(rows, cases):
        assert row[:2] == [scene, case["dir"]]
        status, _, reason = row[2].partition(": ")
        assert status == case["status"]
        assert len(reason) <= SHORT_REASON or (len(reason) == SHORT_REASON + 1 and reason.endswith("…"))
        assert row[2] == short_reason(case["status"], case["reason"])


def test_the_full_reason_is_not_on_the_page_but_in_the_record_and_the_scenes_table(records, page):
    html, _ = page
    text = " ".join(re.sub(r"<[^>]+>", " ", html).split())
    full = [c["reason"] for s in records for c in s["cases"]]
    assert any(len(r) > 80 for r in full)
    for reason in full:
        assert " ".join(reason.split()) not in text
    assert "the scene's table (status_reason)" in text
    # the scene's table keeps the reason as the record has it (one row per case, status_reason)
    table = registry.Scene().table([{"status": "jammed", "status_reason": r} for r in full])
    assert list(table["status_reason"]) == full


def test_no_scene_is_named_in_the_front_pages_code():
    source = Path(overview.__file__).read_text()
    names = set(registry.names()) | {p.parent.name for p in RECORDS}
    assert names
    for name in names:
        assert not re.search(rf"\b{re.escape(name)}\b", source, re.IGNORECASE), name


# ------------------------------------------------------------------ the headlines
def headline_table(tables):
    (table,) = [t for t in tables if t["rows"] and t["rows"][0][:2] == ["scene", "quantity"]]
    return table


def check(quantity, case="a", paper_range=(1.0, 1.0), verdict="within error (0.5 σ)", **kw):
    return {"quantity": quantity, "paper": "1", "source": "Fig. 1", "ours": 1.0, "error": 0.1, "case": case,
            "paper_range": paper_range, "unit": "", "verdict": verdict, **kw}


def test_headlines_one_per_quantity_numbers_first_at_most_a_few():
    summary = {"scene": "x", "cases": [{"dir": "a"}, {"dir": "b"}], "checks": [
        check("shape only", paper_range=None, verdict="shape compared (see note)"),
        check("per case", case="a", paper_range=None, verdict="shape compared (see note)"),
        check("per case", case="b"),                      # the first of its quantity compared with a number
        check("per case", case="c"),
        check("fit", case="sweep"),
        check("another", case="b"), check("and another")]}
    picked = overview.headlines(summary)
    assert [(c["quantity"], c["case"]) for c in picked] == [("per case", "b"), ("fit", "sweep"), ("another", "b")]
    assert len(picked) == overview.HEADLINES_PER_SCENE
    only_shapes = {"checks": [check("s1", paper_range=None), check("s2", paper_range=None)]}
    assert [c["quantity"] for c in overview.headlines(only_shapes)] == ["s1", "s2"]
    assert overview.headlines({"checks": []}) == []


def test_verdicts_in_a_few_words():
    from granflow.validation import verdict

    def short(*args, **kw):
        return overview.short_verdict(verdict(*args, **kw)[0])

    assert short(1.343, 0.003, (1.37, 1.40), syst=0.001) == "1 run: off by -2.0 % (9 σ)"
    assert short(1.343, 0.003, (1.37, 1.40), syst=0.001, n_replicates=2) == "differs by -2.0 % (9 σ)"
    assert short(2.886, 0.029, (3.0, 3.0), syst=0.11) == "within error (1.0 σ)"
    assert short(0.628, 0.002, (0.63, 0.63), syst=0.0023) == "within the systematic error"
    assert short(0.59, 0.002, (0.58, 0.62)) == "within the paper's range"
    assert short(0.087, 0.001, None) == "shape compared"
    assert short(-0.184, 0.047, (0.0, 0.0), syst=0.02) == "1 run: off by -0.184 (4 σ)"
    assert short(float("nan"), 0.1, (1.0, 1.0)) == "not measured"
    assert overview.short_verdict(None) == "–"
    assert overview.verdict_kind("differs by -2.0 % (8 σ with stat and syst)") == "differs"
    assert overview.verdict_kind("within error (1.0 σ)") == "within error"


def test_a_headlines_case_drops_what_every_case_of_its_scene_shares():
    cases = ["mix~a/mdot~20", "mix~a/mdot~33"]
    assert overview.case_label("mix~a/mdot~33", cases) == "mdot~33"
    assert overview.case_label("sweep", cases) == "sweep"
    assert overview.case_label("W~60/phi~0.61", ["W~60/phi~0.61"]) == "W~60/phi~0.61"   # the only case


def test_the_headline_table_has_one_row_per_headline_of_each_summary(records, page):
    html, tables = page
    rows = headline_table(tables)["rows"]
    assert rows[0] == ["scene", "quantity", "case", "ours ± stat ± syst", "paper", "verdict"]
    expected = [(s["scene"], c) for s in records for c in overview.headlines(s)]
    assert len(rows) - 1 == len(expected)
    assert {s["scene"] for s in records if s["checks"]} == {scene for scene, _ in expected}
    for row, (scene, c) in zip(rows[1:], expected):
        assert row[0] == scene
        assert row[1] == overview.cut(c["quantity"], overview.QUANTITY_CHARS)
        assert c["quantity"].startswith(row[1].rstrip("…"))
        assert row[3].split(" ± ")[0] in overview.format_with_errors(c["ours"], c["error"], c.get("syst"))
        assert row[5] == overview.short_verdict(c["verdict"]) and len(row[5]) <= 30
        assert c["verdict"].replace("one sample: off by", "1 run: off by").startswith(row[5].split(" (")[0])
    # every check is counted, and is in the validation section
    n = sum(len(s["checks"]) for s in records)
    assert f"All {n} checks (" in html and "the scene's checks.csv" in html


def test_the_cases_and_the_headlines_of_the_validation_campaign_make_one_short_page(records, page):
    """One line a row: the two tables hold the cases and the headlines, and nothing else long."""
    html, tables = page
    cases, heads = cases_table(tables), headline_table(tables)
    assert "glance" in cases["class"] and "glance" in heads["class"]
    assert len(cases["rows"]) - 1 == sum(len(s["cases"]) for s in records)
    assert len(heads["rows"]) - 1 <= overview.HEADLINES_PER_SCENE * len(records)
    # no cell longer than a status word and a short reason (the full reasons ran to 366 characters)
    widest = max(len(cell) for t in (cases, heads) for row in t["rows"] for cell in row)
    assert widest <= len("no_steady_state: ") + overview.SHORT_REASON + 1, widest
    assert len(tables) == 2


# ------------------------------------------------------------------ headlines from a case that measured them
def chute_like_campaign():
    """A sweep whose first case stopped (arrested) and last kept speeding up (accelerating): neither was
    averaged, so their checks hold NaN and say "not measured"; the two between measured every quantity."""
    nan = float("nan")
    cases = [{"dir": "theta~18", "status": "arrested", "reason": "the bed stopped"},
             {"dir": "theta~22", "status": "steady", "reason": "steady"},
             {"dir": "theta~25", "status": "steady", "reason": "steady"},
             {"dir": "theta~30", "status": "accelerating", "reason": "u_cm still rising"}]
    checks = []
    for case in cases:
        value = 0.99 if case["status"] == "steady" else nan
        verdict = "within error (0.5 σ)" if case["status"] == "steady" else "not measured"
        checks += [check("stress ratio / tan θ", case=case["dir"], ours=value, verdict=verdict),
                   check("σ_zz / weight above - 1", case=case["dir"], ours=value, verdict=verdict),
                   check("Bagnold R²", case=case["dir"], ours=value, paper_range=None,
                         verdict="shape compared" if case["status"] == "steady" else "not measured")]
    return {"scene": "x", "cases": cases, "checks": checks}


def test_a_campaign_with_an_arrested_case_shows_headlines_from_a_case_that_measured_them():
    summary = chute_like_campaign()
    picked = overview.headlines(summary)
    assert [(c["quantity"], c["case"]) for c in picked] == [("stress ratio / tan θ", "theta~22"),
                                                           ("σ_zz / weight above - 1", "theta~22"),
                                                           ("Bagnold R²", "theta~22")]
    html = html_of(overview_rst([summary], "validation"))
    rows = headline_table(Tables(html).tables)["rows"][1:]
    assert [row[2] for row in rows] == ["theta~22"] * 3          # each line says which case it shows
    assert not any("not measured" in row[5] or row[3].startswith("–") for row in rows)
    # a steady case first in the list wins over a later one; a measured reading of an unsteady case only
    # stands in where no steady case measured the quantity
    summary["cases"][1]["status"] = "unsteady"
    assert {c["case"] for c in overview.headlines(summary)} == {"theta~25"}


def test_a_scene_that_measured_nothing_has_no_headline_and_says_so():
    summary = chute_like_campaign()
    summary["checks"] = [c for c in summary["checks"] if c["case"] in ("theta~18", "theta~30")]
    assert overview.headlines(summary) == []
    html = html_of(overview_rst([summary], "validation"))
    assert "x: no headline number could be measured in this campaign." in html
    assert not [t for t in Tables(html).tables if t["rows"] and t["rows"][0][:2] == ["scene", "quantity"]]
    assert "All 6 checks (x 6)" in html                           # still counted, with their verdicts


def test_the_committed_records_headlines_were_measured(records):
    for s in records:
        status = {c["dir"]: c["status"] for c in s["cases"]}
        for c in overview.headlines(s):
            assert overview.measured(c), (s["scene"], c["quantity"])
            assert status.get(c["case"], "steady") == "steady", (s["scene"], c["case"])


# ------------------------------------------------------------------ the committed ladders
LADDERS = sorted((ROOT / "validation").glob("*/ladder.csv"))


def test_each_committed_ladder_shows_its_measured_rung_nearest_the_papers_setup():
    """The row labelled nearest is the measured rung (not a reseed) with the smallest from_paper of its ladder
    file, whatever its number; e.g. a rung one step farther that agrees better is labelled for what it is."""
    import yaml

    assert LADDERS
    for path in LADDERS:
        ladder = yaml.safe_load((ROOT / "config" / "ladders" / f"{path.parent.name}.yaml").read_text())
        order = {r["name"]: r["from_paper"] for r in ladder["rungs"]}
        rows = overview.read_ladder(path)
        first = next(r["quantity"] for r in rows if r["state"].startswith("run") and r["quantity"]
                     and not str(r.get("verdict", "")).endswith("no verdict against the paper"))
        measured = [r for r in rows if r["quantity"] == first and math.isfinite(r["ours"])
                    and r.get("replicate", "False") != "True"]
        nearest = min(measured, key=lambda r: order[r["rung"]])
        picks = {r["rung"]: labels for r, labels in overview.ladder_picks(rows)}
        assert overview.NEAREST_SETUP in picks[nearest["rung"]], path
        assert [r for r, labels in picks.items() if overview.NEAREST_SETUP in labels] == [nearest["rung"]]
        assert overview.VALIDATION_CASE in picks[ladder["rungs"][0]["name"]]
        best = min(measured, key=lambda r: r["abs_rel_difference"])
        if best["rung"] != nearest["rung"]:
            # never nearer the paper's setup than the nearest; as near (a tie of from_paper): the file's first wins
            assert overview.BEST_AGREEMENT in picks[best["rung"]] and order[best["rung"]] >= order[nearest["rung"]]


# ------------------------------------------------------------------ the README's picture of the page
PICTURE = ROOT / "docs" / "figures" / "front_page.png"
_spec = importlib.util.spec_from_file_location("front_page_picture", ROOT / "tools" / "front_page_picture.py")
picture_tool = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(picture_tool)
#: a number as the page prints it: 26.76, -0.028, 1.12e+03, 27,727
NUMBER = re.compile(r"[-+]?\d[\d,]*(?:\.\d+)?(?:e[-+]?\d+)?")


def numbers(page: str) -> list[str]:
    """The numbers of a front page (reStructuredText), its style block left out, in the page's order."""
    return NUMBER.findall(page.split("</style>", 1)[-1])


def test_the_readmes_picture_shows_the_numbers_of_the_record(tmp_path):
    """The picture carries the page it shows (tools/front_page_picture.py writes both): its numbers are the
    page's built now from validation/. If this fails, the record or the page changed: run
    `python tools/front_page_picture.py` and commit docs/figures/front_page.png."""
    assert "docs/figures/front_page.png" in (ROOT / "README.md").read_text()
    shown = picture_tool.page_text(PICTURE)
    assert shown, "docs/figures/front_page.png carries no page text: make it with tools/front_page_picture.py"
    now = picture_tool.front_page(tmp_path / "overview.rst")
    assert numbers(shown) == numbers(now)
    # and every headline number of the record, as the page formats it, is in the picture
    for s in (json.loads(p.read_text()) for p in RECORDS):
        for c in overview.headlines(s):
            value = overview.format_with_errors(c["ours"], c.get("error"), overview._finite_or_none(c.get("syst")))
            assert value in shown.replace("\\", ""), (s["scene"], c["quantity"], value)


def test_the_pictures_stand_in_workflow_names_the_projects_rules():
    rules = set(re.findall(r"^rule (\w+):", "\n".join(p.read_text() for p in (ROOT / "workflows" / "rules")
                                                       .glob("*.smk")), re.M))
    assert set(picture_tool.STAND_IN_RULES) <= rules
    text = picture_tool.stand_in_snakefile(["alpha", "beta"])
    assert 'report: "overview.rst"' in text and '"tables/beta.csv",' in text


def test_a_diagnostic_is_never_a_headline():
    summary = {"cases": [{"dir": "x~1", "status": "steady"}],
               "checks": [{"quantity": "pure power law a", "ours": 0.68, "paper_range": [0.5, 0.5], "case": "sweep",
                           "kind": "diagnostic", "verdict": "diagnostic: no verdict against the paper"},
                          {"quantity": "curvature", "ours": 0.1, "paper_range": [0.0, 0.0], "case": "sweep",
                           "kind": "comparison", "verdict": "within error (1.1 σ)"}]}
    assert [c["quantity"] for c in overview.headlines(summary)] == ["curvature"]
