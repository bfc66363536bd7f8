"""The report's front page: the campaign as run, how each case ended, its headline numbers
beside the papers' values, and the CPU-hours spent, read at a glance.

Built from the scenes' records (``<validation dir>/<scene>/summary.json``, written by
:func:`granflow.validation.write_record` for the campaign's own rung: every case with its
status, reason, size and CPU-hours; every check with the paper's value, its source, ours
with its statistical error and the verdict). The page is reStructuredText, which
Snakemake's report renders first (the Snakefile's global ``report:`` statement), before the
per-scene sections. Snakemake passes that text through Jinja first; the page is wrapped in
a ``raw`` block so that a brace in a reason or a source cannot be read as a template.

The page is read at a glance: at 1400 px the cases and the headlines fit in one window.
Every case is one line: scene, case, its status with a reason of a few words
(:func:`short_reason`: the status word, and for a case that is not steady the first clause of
its reason cut at a word boundary to :data:`SHORT_REASON` characters), particles and CPU-hours.
The full reason stays in the scene's record and its table (``status_reason`` of
``table.csv``, the scene's section of the report). The headlines are one table, a line each:
scene, quantity, the case it was measured on, ours ± stat ± syst, the paper's value and the verdict in
a few words (:func:`short_verdict`); a scene's headlines are picked from its record's checks by
:func:`headlines` (one a quantity, each from a case that measured it, never from one that could not:
arrested, accelerating, jammed; those compared with a number of the paper first, at most
:data:`HEADLINES_PER_SCENE`), and every check, with its source, note and full verdict, stays in
the validation section (the scene's ``checks.csv``); the page counts them. Where a scene of the
campaign has a committed ladder (``validation/<scene>/ladder.csv``, ``snakemake ladder``: one
setting at a time from the validation case toward the paper), :func:`ladder_section` shows its first
headline at the validation case and at the measured rung nearest the paper's setup (the order its
ladder file declares, ``from_paper``), whatever its number, and, where another rung agrees better with
the paper, that rung too, each row saying which it is, with both errors, the verdict and the rung's
CPU-hours; its figure is in the validation section. The rules here read only the records and ladders:
they never name a scene.
"""
from __future__ import annotations

import csv
import json
import math
import re
from collections import Counter
from pathlib import Path

from .validation import format_with_errors

#: characters with a meaning in reStructuredText inline markup, escaped in table cells
_RST_SPECIAL = "\\`*_|[]<>"


#: Snakemake's report centres the page in a full-height flex box, so a page taller than the
#: window overflows upwards and its top cannot be scrolled to (snakemake/snakemake#3906, open
#: for images; the same for a long description: this page's title sat 5,200 px above the
#: window). The page's own style aligns that box to the top; it lives in this page's HTML
#: only, so the other pages of the report keep Snakemake's layout.
TOP_ALIGN = (".items-center.justify-center.overflow-auto { align-items: flex-start !important; "
             "justify-content: flex-start !important; }")
#: read at a glance: Snakemake sets the page in a column 32 rem wide beside the rule graph, where a
#: table of 5 columns wraps every cell. The page's column takes the width the menu (a fifth of the
#: window) and the rule graph leave at 1400 px (54 rem), its titles are smaller and its tables
#: (class ``glance``) keep each row on one line. The box is also aligned left: a page wider than
#: the window overflows to the right, where it can be scrolled to, not under the menu.
GLANCE = (".prose.max-w-lg { max-width: 54rem; } "
          ".prose h1 { font-size: 1.3em; margin: 0.7em 0 0.2em; } "
          ".prose h1.title { font-size: 1.6em; margin: 0 0 0.3em; } "
          ".prose p { font-size: 0.8rem; line-height: 1.45; margin: 0.3em 0; } "
          ".prose table.glance { font-size: 0.75rem; line-height: 1.35; width: auto; margin: 0.2em 0 0.6em; } "
          ".prose table.glance caption { text-align: left; font-size: 0.75rem; padding-bottom: 0.2em; "
          "white-space: nowrap; } "
          ".prose table.glance th, .prose table.glance td { padding: 0.12em 0.65em 0.12em 0; white-space: nowrap; }")
PAGE_STYLE = [".. raw:: html", "", f"   <style>{TOP_ALIGN} {GLANCE}</style>", ""]


def rst_text(value) -> str:
    """One table cell: a single line with reStructuredText's inline markup escaped."""
    text = " ".join(str(value).split())
    out = "".join("\\" + ch if ch in _RST_SPECIAL else ch for ch in text)
    return out or "–"


#: a case's short reason: the first clause of its reason cut to at most this many characters
SHORT_REASON = 40
#: the status of a case that ran as it should (steady, then averaged): its status word says it all
STEADY = "steady"
#: where a reason's first clause ends: ``;`` ``:`` ``,`` or ``.`` before a space, a space before
#: ``(``, or a dash between spaces (a comma or point inside a number such as 27,727 or 0.3 does not)
_CLAUSE_END = re.compile(r"[;:,.](?=\s)|\s(?=\()|\s[–—-]\s")


def cut(text, limit: int) -> str:
    """``text`` on one line, cut at a word boundary to at most ``limit`` characters with an ellipsis."""
    text = " ".join(str(text).split())
    if len(text) <= limit:
        return text
    space = text.rfind(" ", 0, limit + 1)
    head = text[:space] if space > 0 else text[:limit]
    return head.rstrip(" ,;:.([–—-") + "…"


def first_clause(text) -> str:
    """The words of ``text`` up to its first clause boundary (:data:`_CLAUSE_END`)."""
    text = " ".join(str(text or "").split())
    end = _CLAUSE_END.search(text)
    return text[:end.start()].strip() if end else text


def short_reason(status, reason) -> str:
    """How a case ended in a few words: ``steady``, or the status word and the first clause of
    its reason cut to :data:`SHORT_REASON` characters, e.g. ``jammed: wall friction holds``."""
    status = str(status or "unknown")
    clause = cut(first_clause(reason), SHORT_REASON)
    return status if status == STEADY or not clause else f"{status}: {clause}"


#: at most this many of a scene's checks on the front page (:func:`headlines`); its record has them all
HEADLINES_PER_SCENE = 3
#: a headline's quantity and the paper's value, cut at a word boundary to these many characters
QUANTITY_CHARS = 26
PAPER_CHARS = 22


def measured(check: dict) -> bool:
    """Whether a check holds a number of ours: a case that was not averaged (arrested, accelerating,
    jammed, unstable...) leaves ``ours`` empty or NaN, its verdict ``not measured``."""
    ours = check.get("ours")
    return isinstance(ours, (int, float)) and not isinstance(ours, bool) and math.isfinite(ours)


def headlines(summary: dict) -> list[dict]:
    """A scene's headline numbers on the front page, by rule from its record's checks, in the
    scene's order: one comparison per quantity (never a consistency check or a diagnostic), taken from a
    case that measured it (:func:`measured`; a
    quantity no case measured is not a headline), the first compared with a number of the paper, then
    the first from a steady case or the whole sweep, else the first; quantities compared with a number
    before those compared in words, at most :data:`HEADLINES_PER_SCENE`. Readings of one quantity told
    apart only by a parenthesis (``exponent a (orifice plane)``, ``exponent a (kernel node)``) count as
    one quantity."""
    status = {c.get("dir"): c.get("status") for c in summary.get("cases", [])}

    def rank(c: dict) -> tuple[bool, bool]:      # False first: a number of the paper, a steady case
        return c.get("paper_range") is None, status.get(c.get("case")) not in (None, STEADY)

    first: dict[str, dict] = {}
    # only a comparison with the paper is a headline: a consistency check or a diagnostic carries no verdict
    compared = [c for c in summary.get("checks", []) if (c.get("kind") or "comparison") == "comparison"]
    for c in filter(measured, compared):
        q = c.get("quantity", "").split(" (")[0]
        if q not in first or rank(c) < rank(first[q]):
            first[q] = c
    return sorted(first.values(), key=lambda c: c.get("paper_range") is None)[:HEADLINES_PER_SCENE]


def case_label(case: str, cases: list[str]) -> str:
    """A case as the headlines name it: without the parts of its directory that every case of its
    scene shares (``mix~a/mdot~20`` beside ``mix~a/mdot~33``: ``mdot~20``); whole when it is the
    scene's only case or nothing would be left."""
    parts = str(case).split("/")
    shared = set.intersection(*(set(str(c).split("/")) for c in cases)) if len(cases) > 1 else set()
    return "/".join(p for p in parts if p not in shared) or str(case)


def short_verdict(verdict) -> str:
    """A check's verdict (:func:`granflow.validation.verdict`) in a few words: up to its first
    parenthesis, with the number of standard errors where it gives them, e.g.
    ``differs by -2.0 % (8 σ)``; one run's difference reads ``1 run: off by -2.8 % (11 σ)``."""
    text = " ".join(str(verdict or "").split()).replace("one sample: off by", "1 run: off by")
    sigmas = re.search(r"\(([0-9.]+ σ)", text)
    words = text.split(" (")[0]
    return (f"{words} ({sigmas.group(1)})" if sigmas else words) or "–"


def verdict_kind(verdict) -> str:
    """What kind of verdict, without its numbers: ``within error``, ``differs``, ``shape compared``..."""
    return re.split(r" \(| by ", " ".join(str(verdict or "").split()))[0] or "no verdict"


def _hours(x) -> str:
    return f"{x:.2f}" if isinstance(x, (int, float)) and math.isfinite(x) else "–"


def _table(title: str, header: list[str], rows: list[list[str]], widths: list[int] | None = None) -> list[str]:
    """A list-table; without ``widths`` its columns take their contents' widths, one line a row."""
    out = [f".. list-table:: {rst_text(title)}", "   :header-rows: 1",
           "   :widths: " + (" ".join(str(w) for w in widths) if widths else "auto"),
           *([] if widths else ["   :class: glance"]), ""]
    for row in [header, *rows]:
        out.append(f"   * - {rst_text(row[0])}")
        out.extend(f"     - {rst_text(cell)}" for cell in row[1:])
    return out + [""]


def overview_rst(summaries: list[dict], rung: str, ladders: dict[str, Path] | None = None) -> str:
    """The front page from the scenes' records of one campaign at ``rung``, and the committed ladders
    (``ladders``: scene → its ``ladder.csv``) of its scenes."""
    cases = [(s["scene"], c) for s in summaries for c in s.get("cases", [])]
    hours = sum(c["cpu_hours"] for _, c in cases
                if isinstance(c.get("cpu_hours"), (int, float)) and math.isfinite(c["cpu_hours"]))
    statuses = Counter(c.get("status") or "unknown" for _, c in cases)
    title = f"granflow campaign at rung {rung}"
    lines = ["{% raw %}", *PAGE_STYLE, title, "=" * len(title), ""]
    lines += [rst_text(
        f"What ran: {len(summaries)} scene(s), {len(cases)} case(s), {hours:.2f} CPU-hours of LAMMPS "
        f"(all ranks, user + system). How the cases ended: "
        + ", ".join(f"{n} {s}" for s, n in sorted(statuses.items())) + "."), ""]
    if rung != "validation":
        lines += [rst_text(
            f"Rung {rung}: its cases are smaller, shorter or softer than the papers', so a difference from a "
            "paper is not a verdict on granflow; section validation holds the validation rung's record."), ""]
    lines += ["Cases", "-----", ""]
    rows = [[scene, c.get("dir", ""), short_reason(c.get("status"), c.get("reason")),
             f"{c['particles']:,}" if isinstance(c.get("particles"), int) else "–", _hours(c.get("cpu_hours"))]
            for scene, c in cases]
    lines += _table(f"Rung {rung}; each reason in full: the scene's table (status_reason)",
                    ["scene", "case", "status: reason", "particles", "CPU-h"], rows)
    lines += ["Headline numbers against the papers", "-----------------------------------", ""]
    rows, counts, verdicts, silent = [], [], Counter(), []
    for s in summaries:
        checks = s.get("checks", [])
        if not checks or not headlines(s):
            silent.append(rst_text(f"{s['scene']}: " + (s.get("note") or "no headline number could be "
                                                          "measured in this campaign.")))
        if not checks:
            continue
        counts.append(f"{s['scene']} {len(checks)}")
        verdicts.update(verdict_kind(c.get("verdict")) for c in checks)
        for c in headlines(s):
            unit = f" {c['unit']}" if c.get("unit") else ""
            rows.append([s["scene"], cut(c.get("quantity", ""), QUANTITY_CHARS),
                         case_label(c.get("case", ""), [k.get("dir", "") for k in s.get("cases", [])]),
                         format_with_errors(c.get("ours"), c.get("error"), _finite_or_none(c.get("syst"))) + unit,
                         cut(f"{c.get('paper', '')}{unit}", PAPER_CHARS), short_verdict(c.get("verdict"))])
    if rows:
        lines += _table(f"Rung {rung}; at most {HEADLINES_PER_SCENE} a scene, one a quantity, each from a case that "
                        "measured it, those with a number of the paper first",
                        ["scene", "quantity", "case", "ours ± stat ± syst", "paper", "verdict"], rows)
    if counts:
        n = sum(verdicts.values())
        lines += [rst_text(f"All {n} checks ({', '.join(counts)}): "
                           + ", ".join(f"{k} {kind}" for kind, k in verdicts.most_common())
                           + "; each with the paper's source, our note and the full verdict in the validation "
                             "section (the scene's checks.csv)."), ""]
    for line in silent:
        lines += [line, ""]
    lines += ladder_section(ladders or {})
    papers = [f"{s['scene']}: {s['paper']}" for s in summaries if s.get("paper")]
    if papers:
        lines += [rst_text("Papers: " + "; ".join(papers) + "."), ""]
    lines += [rst_text("The scenes' sections follow: their tables, figures and provenance; the "
                       "validation section holds the committed record."), "", "{% endraw %}", ""]
    return "\n".join(lines)


def _number(text) -> float:
    """A ladder.csv cell as a float (nan when empty or not a number)."""
    try:
        return float(text)
    except (TypeError, ValueError):
        return float("nan")


def read_ladder(path: Path) -> list[dict]:
    """The rows of a committed ladder (``validation/<scene>/ladder.csv``, by the rule ``ladder_record``), its
    numbers as floats."""
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    for r in rows:
        for key in ("ours", "stat", "syst", "abs_rel_difference", "cpu_hours", "from_paper"):
            r[key] = _number(r.get(key))
    return rows


#: what a ladder row on the front page is (:func:`ladder_picks`)
VALIDATION_CASE = "validation case"
NEAREST_SETUP = "nearest the paper's setup"
BEST_AGREEMENT = "best agreement"


def _finite_key(value: float) -> float:
    return value if math.isfinite(value) else math.inf


def ladder_picks(rows: list[dict]) -> list[tuple[dict, list[str]]]:
    """The rungs of a ladder the front page shows, each with what it is, for the ladder's first quantity
    compared with the paper:
    its first rung (:data:`VALIDATION_CASE`); the measured rung nearest the paper's setup by the order its
    ladder file declares (``from_paper``, the smallest; the first of equals), whatever its number
    (:data:`NEAREST_SETUP`); and the measured rung with the smallest |difference from the paper|
    (:data:`BEST_AGREEMENT`). A replicate rung (the first rung reseeded) is no step and never picked; a
    rung picked twice is one row with both labels. Without ``from_paper`` no rung is called nearest."""
    run = [r for r in rows if str(r.get("state", "")).startswith("run") and r.get("quantity")]
    if not run:
        return []
    # the first quantity compared with the paper (a consistency check or a diagnostic has no verdict to show)
    judged = [r for r in run if not str(r.get("verdict", "")).endswith("no verdict against the paper")] or run
    mine = [r for r in run if r["quantity"] == judged[0]["quantity"]]
    steps = [r for r in mine if str(r.get("replicate", "")).lower() != "true" and math.isfinite(r["ours"])]
    placed = [r for r in steps if math.isfinite(r.get("from_paper", math.nan))]
    nearest = min(placed, key=lambda r: r["from_paper"], default=None)
    best = min(steps, key=lambda r: _finite_key(r["abs_rel_difference"]), default=None)
    picks: list[tuple[dict, list[str]]] = [(mine[0], [VALIDATION_CASE])]
    for row, label in ((nearest, NEAREST_SETUP), (best, BEST_AGREEMENT)):
        if row is None or (label == BEST_AGREEMENT and not math.isfinite(row["abs_rel_difference"])):
            continue
        same = [labels for r, labels in picks if r is row]
        if same:
            same[0].append(label)
        else:
            picks.append((row, [label]))
    return picks


def ladder_rows(scene: str, rows: list[dict]) -> tuple[list[list[str]], str]:
    """A scene's ladder on the front page (:func:`ladder_picks`): its first quantity at each picked rung,
    what the rung is, its order from the paper's setup, ours ± stat ± syst, the verdict and the rung's
    measured CPU-hours; and a sentence counting the rungs run and naming the costliest planned one."""
    picks = ladder_picks(rows)
    if not picks:
        return [], ""
    run = [r for r in rows if str(r.get("state", "")).startswith("run") and r.get("quantity")]
    planned = [r for r in rows if str(r.get("state", "")).startswith("planned")]
    table = [[scene, cut(r["quantity"], QUANTITY_CHARS), r["rung"], "; ".join(labels),
              f"{r['from_paper']:g}" if math.isfinite(r.get("from_paper", math.nan)) else "–",
              format_with_errors(r["ours"], r["stat"], _finite_or_none(r["syst"])),
              short_verdict(r.get("verdict")), _hours(r["cpu_hours"])] for r, labels in picks]
    rungs = list(dict.fromkeys(r["rung"] for r in run))
    costliest = max(planned, key=lambda r: r["cpu_hours"] if math.isfinite(r["cpu_hours"]) else -1, default=None)
    words = f"{scene}: {len(rungs)} rung(s) run, {len(planned)} planned"
    if costliest is not None:
        words += f"; the costliest planned, {costliest['rung']}, {costliest['cpu_hours']:.3g} CPU-h (cost model)"
    if not any(NEAREST_SETUP in labels for _, labels in picks):
        words += "; its ladder declares no order from the paper's setup (from_paper), so no rung is called nearest"
    return table, words + "."


def ladder_section(ladders: dict[str, Path]) -> list[str]:
    """The front page's ladders: per scene with a committed ladder, :func:`ladder_rows`."""
    rows, sentences = [], []
    for scene, path in ladders.items():
        table, words = ladder_rows(scene, read_ladder(path))
        rows += table
        sentences += [words] if words else []
    if not rows:
        return []
    lines = ["Toward the papers, one knob at a time", "-" * 37, ""]
    lines += _table("The committed ladders (validation/<scene>/ladder.csv), each at its first headline",
                    ["scene", "quantity", "rung", "which", "from paper", "ours ± stat ± syst", "verdict", "CPU-h"], rows)
    lines += [rst_text("Each ladder at its validation case, at the measured rung nearest the paper's setup whatever "
                       "its number, and at the rung that agrees best where that is another; from paper: the rung's "
                       "order from the paper's setup as its ladder file declares it (0 is the paper's; a reseed has "
                       "its rung's). " + " ".join(sentences) + " Every rung and headline, and the figure of error "
                       "against CPU-hours: the validation section (the scene's ladder)."), ""]
    return lines


def _finite_or_none(x):
    """A JSON number (a summary's ``syst``, null when not computed) as a float or None."""
    return float(x) if isinstance(x, (int, float)) and math.isfinite(x) else None


def write_overview(summary_paths: list[Path], rung: str, out: Path, ladder_paths: list[Path] = ()) -> str:
    """Write the front page ``out`` (reStructuredText) from the scenes' ``summary.json`` files and the
    committed ladders ``ladder_paths`` (``<validation>/<scene>/ladder.csv``: the scene is its folder's name)."""
    summaries = [json.loads(Path(p).read_text()) for p in summary_paths]
    text = overview_rst(summaries, rung, {Path(p).parent.name: Path(p) for p in ladder_paths})
    Path(out).parent.mkdir(parents=True, exist_ok=True)
    Path(out).write_text(text)
    return text
