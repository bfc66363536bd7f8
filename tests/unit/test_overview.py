"""The report's front page (granflow.overview): cases, statuses, CPU-hours, checks against the papers."""
import html
import json
import re
import subprocess
import sys
from pathlib import Path

import jinja2
from docutils.core import publish_parts

from granflow.overview import overview_rst, rst_text, write_overview

SUMMARIES = [
    {"scene": "alpha", "rung": "demo", "paper": "Doe et al. (2020)",
     "cases": [{"dir": "W~20/phi~0.58", "status": "steady", "reason": "drift 0.7 % {{ not a template }}",
                "particles": 2161, "cpu_hours": 0.25},
               {"dir": "W~20/phi~0.6", "status": "no_steady_state", "reason": "drift *6.5 %* over\nthe last 100",
                "particles": 2161, "cpu_hours": 0.5}],
     "checks": [{"quantity": "u_max/u_slip", "paper": "1.37–1.40", "source": "fig. 5(c)", "ours": 1.19706,
                 "error": 0.00634, "case": "W~20/phi~0.58", "unit": "", "verdict": "differs by -13 %"},
                {"quantity": "h_c exponent", "paper": "1", "source": "fig. 8", "ours": 1.171, "error": 0.088,
                 "syst": 0.263, "case": "sweep", "unit": "", "verdict": "within the systematic error"}]},
    {"scene": "beta", "rung": "demo", "paper": "Roe (2013)",
     "cases": [{"dir": "R~4.5", "status": "completed", "reason": "fixed schedule {{ not a template }}",
                "particles": 8087,
                "cpu_hours": 1.125},
               {"dir": "R~5.5", "status": "unstable", "reason": "lost atoms", "particles": None,
                "cpu_hours": None}],
     "checks": []},
]


def render(text):
    """What Snakemake does with the page: Jinja, then docutils; any docutils warning fails."""
    html = publish_parts(jinja2.Environment().from_string(text).render(), writer="html",
                         settings_overrides={"halt_level": 2, "report_level": 2})["html_body"]
    return html


def test_page_lists_every_case_with_status_and_the_cpu_hours():
    text = overview_rst(SUMMARIES, "demo")
    assert text.startswith("{% raw %}\n") and text.rstrip().endswith("{% endraw %}")
    # 0.25 + 0.5 + 1.125 (a case without CPU-hours adds nothing)
    assert "2 scene(s), 4 case(s), 1.88 CPU-hours" in text
    assert "How the cases ended: 1 completed, 1 no\\_steady\\_state, 1 steady, 1 unstable." in text
    html = render(text)
    # one line per case: a steady case is its status word, another adds its reason's first clause
    for cell in ("W~20/phi~0.58", "steady", "no_steady_state: drift *6.5 %* over the last 100", "8,087", "1.12",
                 "0.50", "unstable: lost atoms", "R~5.5", "completed: fixed schedule {{ not a template }}"):
        assert f"<p>{cell}</p>" in html or f">{cell}<" in html, cell
    # the full reason of a steady case is in the scene's table, not here
    assert "drift 0.7 %" not in html
    assert "rung demo" in html and "is not a verdict on granflow" in html


def test_checks_sit_beside_the_papers_values():
    html = render(overview_rst(SUMMARIES, "demo"))
    assert "1.1971 ± 0.0063" in html                     # two significant digits of the error
    assert "1.171 ± 0.088 ± 0.263" in html               # and the systematic error where there is one
    assert ">1.37–1.40<" in html or "<p>1.37–1.40</p>" in html   # the paper's source is in the record
    assert "differs by -13 %" in html and "within the systematic error" in html
    assert "beta: no headline number could be measured in this campaign." in html
    assert "Papers: alpha: Doe et al. (2020); beta: Roe (2013)." in html
    assert "All 2 checks (alpha 2): 1 differs, 1 within the systematic error" in html


def test_the_validation_rung_has_no_caveat(tmp_path):
    paths = []
    for s in SUMMARIES:
        p = tmp_path / s["scene"] / "summary.json"
        p.parent.mkdir()
        p.write_text(json.dumps(dict(s, rung="validation")))
        paths.append(p)
    out = tmp_path / "report" / "overview_validation.rst"
    text = write_overview(paths, "validation", out)
    assert out.read_text() == text
    assert "is not a verdict" not in text and "granflow campaign at rung validation" in render(text)


def test_rst_cells_escape_inline_markup():
    assert rst_text("a_b *c* `d` |e|") == "a\\_b \\*c\\* \\`d\\` \\|e\\|"
    assert rst_text("") == "–" and rst_text("two\n lines") == "two lines"


def test_the_default_campaign_builds_the_front_page(tmp_path):
    """`rule all` asks for the page (dry run of the default campaign into an empty results dir)."""
    out = subprocess.run([sys.executable, "-m", "snakemake", "-n", "--cores", "1", "--config",
                          f"results_dir={tmp_path}"], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr[-2000:] + out.stdout[-2000:]
    assert f"{tmp_path}/report/overview_demo.rst" in out.stdout
    assert "rule overview:" in out.stdout
    # every committed ladder's figure goes into the report's validation section
    for figure in sorted(Path(__file__).resolve().parents[2].glob("validation/*/figures/ladder.png")):
        assert f"{tmp_path}/report/validation/{figure.parent.parent.name}_ladder.png" in out.stdout


LADDER = """rung,knob,from_paper,state,quantity,paper,ours,stat,syst,verdict,abs_rel_difference,rel_error,cases,particles,cpu_hours,replicate
base,the validation case,3,run,u_max/u_slip,1.37–1.40,1.343,0.003,0.001,differs by -2.0 % (8 σ with stat and syst),0.0196,0.0023,1,"4,120",0.58
base,the validation case,3,run,second quantity,1,0.5,0.1,,differs by -50 % (5 σ),0.5,0.1,1,"4,120",0.58
B10,depth B 5 → 10 d_p,2,run,u_max/u_slip,1.37–1.40,1.356,0.004,0.001,differs by -1.0 % (3 σ with stat and syst),0.0100,0.0029,1,"8,240",1.26
B15,depth B 5 → 15 d_p,1,run,u_max/u_slip,1.37–1.40,1.33,0.004,0.001,differs by -3.0 % (7 σ),0.0300,0.0029,1,"8,240",1.9
B18,depth B 5 → 18 d_p,1,run,u_max/u_slip,1.37–1.40,1.32,0.004,0.001,differs by -3.6 % (8 σ),0.0360,0.0029,1,"8,240",2.0
B30,depth B 5 → 30 d_p,0.5,run,u_max/u_slip,1.37–1.40,,,,not measured,,,1,"8,240",3.0
B20,depth B 5 → 20 d_p,0.5,not run,,,,,,,,,,,
seed2,the base reseeded,3,run,u_max/u_slip,1.37–1.40,1.369,0.003,0.001,within error (0.3 σ),0.0007,0.0023,1,"4,120",0.6,True
B40,depth B 40,0.2,"planned (cost model, not run)",,,,,,,,,1,"32,959",25.2
paper,the paper's channel,0,"planned (cost model, not run)",,,,,,,,,1,"99,000",230
"""


def ladder_cells(html: str) -> list[list[str]]:
    """The rows of the page's ladder table, as lists of cell texts."""
    rows = re.findall(r"<tr><td>(.*?)</tr>", html.split("one knob at a time")[1], re.S)
    return [re.findall(r"<td>(.*?)</td>", "<td>" + r) for r in rows]


def ladder_page(tmp_path, text: str) -> str:
    """The page (HTML, its entities read) of the campaign with ``text`` as scene alpha's ladder.csv."""
    path = tmp_path / "alpha" / "ladder.csv"
    path.parent.mkdir(exist_ok=True)
    path.write_text(text)
    return html.unescape(render(overview_rst(SUMMARIES, "demo", {"alpha": path})))


def test_the_page_shows_the_rung_nearest_the_papers_setup_not_the_best_number(tmp_path):
    """A ladder whose best-agreeing rung (B10, -1.0 %) is not the measured rung nearest the paper's setup
    (B15, order 1, -3.0 %): the page shows the validation case, B15 as the nearest and B10 as the best
    agreement, each labelled. B18 is as near as B15 and comes later; B30 (order 0.5) measured nothing and
    B20 did not run; seed2, nearer the paper's number still, is the base reseeded: no step at all."""
    page = ladder_page(tmp_path, LADDER)
    cells = ladder_cells(page)
    assert [c[2:5] for c in cells] == [["base", "validation case", "3"], ["B15", "nearest the paper's setup", "1"],
                                       ["B10", "best agreement", "2"]]
    assert cells[0][5:] == ["1.3430 ± 0.0030 ± 0.0010", "differs by -2.0 % (8 σ)", "0.58"]
    assert cells[1][5:] == ["1.3300 ± 0.0040 ± 0.0010", "differs by -3.0 % (7 σ)", "1.90"]
    assert cells[2][5:] == ["1.3560 ± 0.0040 ± 0.0010", "differs by -1.0 % (3 σ)", "1.26"]
    assert "second quantity" not in page                     # one headline a scene: the ladder's first
    assert "alpha: 6 rung(s) run, 2 planned; the costliest planned, paper, 230 CPU-h (cost model)." in page
    assert "the measured rung nearest the paper's setup whatever its number" in page
    # without ladders the page has no such section
    assert "one knob at a time" not in overview_rst(SUMMARIES, "demo")


def test_a_rung_both_nearest_and_best_is_one_row_with_both_labels(tmp_path):
    text = LADDER.replace("B15,depth B 5 → 15 d_p,1,", "B15,depth B 5 → 15 d_p,2.5,").replace(
        "B18,depth B 5 → 18 d_p,1,", "B18,depth B 5 → 18 d_p,2.5,")
    cells = ladder_cells(ladder_page(tmp_path, text))
    assert [c[2:4] for c in cells] == [["base", "validation case"], ["B10", "nearest the paper's setup; best agreement"]]
    # the validation case nearest the paper's setup: its row says both
    text = LADDER.replace("base,the validation case,3,", "base,the validation case,0.1,")
    cells = ladder_cells(ladder_page(tmp_path, text))
    assert [c[2:4] for c in cells] == [["base", "validation case; nearest the paper's setup"],
                                       ["B10", "best agreement"]]


def test_a_ladder_without_an_order_from_the_paper_calls_no_rung_nearest(tmp_path):
    """A ladder.csv of before from_paper: the validation case and the best agreement, labelled, and a sentence
    that the ladder declares no order."""
    lines = [line.split(",", 3) for line in LADDER.splitlines()]
    text = "\n".join(",".join(parts[:2] + parts[3:]) for parts in lines) + "\n"   # the from_paper column dropped
    page = ladder_page(tmp_path, text)
    assert [c[2:5] for c in ladder_cells(page)] == [["base", "validation case", "–"], ["B10", "best agreement", "–"]]
    assert "declares no order from the paper's setup (from_paper), so no rung is called nearest." in page


def test_page_starts_at_its_top_in_snakemakes_report():
    """A page taller than the window must not overflow upwards (snakemake#3906): the page aligns
    its container to the top, in raw HTML inside the {% raw %} block, before the title."""
    text = overview_rst(SUMMARIES, "demo")
    head = text.split("granflow campaign at rung demo")[0]
    assert head.startswith("{% raw %}")
    assert ".. raw:: html" in head and "align-items: flex-start" in head
    import docutils.core
    from docutils.writers.html5_polyglot import Writer

    html = docutils.core.publish_parts(text.replace("{% raw %}", "").replace("{% endraw %}", ""),
                                       writer=Writer())["body"]
    assert "<style>" in html and "flex-start" in html


def test_a_ladders_diagnostic_first_quantity_is_passed_over():
    diag = {"rung": "base", "state": "run", "quantity": "pure power law", "ours": 0.68, "from_paper": 2,
            "abs_rel_difference": 0.37, "replicate": False, "verdict": "diagnostic: no verdict against the paper"}
    comp = dict(diag, quantity="curvature", ours=0.1, verdict="within error (1.1 σ)", abs_rel_difference=0.1)
    from granflow.overview import ladder_picks

    picks = ladder_picks([diag, comp])
    assert [r["quantity"] for r, _ in picks] == ["curvature"]
