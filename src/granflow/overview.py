"""The report's front page: the campaign as run, how each case ended, its headline numbers
beside the papers' values, and the CPU-hours spent.

Built from the scenes' records (``<validation dir>/<scene>/summary.json``, written by
:func:`granflow.validation.write_record` for the campaign's own rung: every case with its
status, reason, size and CPU-hours; every check with the paper's value, its source, ours
with its statistical error and the verdict). The page is reStructuredText, which
Snakemake's report renders first (the Snakefile's global ``report:`` statement), before the
per-scene sections. Snakemake passes that text through Jinja first; the page is wrapped in
a ``raw`` block so that a brace in a reason or a source cannot be read as a template.
"""
from __future__ import annotations

import json
import math
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
TOP_ALIGN = [".. raw:: html", "",
             "   <style>.items-center.justify-center.overflow-auto { align-items: flex-start !important; }</style>",
             ""]


def rst_text(value) -> str:
    """One table cell: a single line with reStructuredText's inline markup escaped."""
    text = " ".join(str(value).split())
    out = "".join("\\" + ch if ch in _RST_SPECIAL else ch for ch in text)
    return out or "–"


def _hours(x) -> str:
    return f"{x:.2f}" if isinstance(x, (int, float)) and math.isfinite(x) else "–"


def _table(title: str, header: list[str], rows: list[list[str]], widths: list[int]) -> list[str]:
    out = [f".. list-table:: {rst_text(title)}", "   :header-rows: 1",
           "   :widths: " + " ".join(str(w) for w in widths), ""]
    for row in [header, *rows]:
        out.append(f"   * - {rst_text(row[0])}")
        out.extend(f"     - {rst_text(cell)}" for cell in row[1:])
    return out + [""]


def overview_rst(summaries: list[dict], rung: str) -> str:
    """The front page from the scenes' records of one campaign at ``rung``."""
    cases = [(s["scene"], c) for s in summaries for c in s.get("cases", [])]
    hours = sum(c["cpu_hours"] for _, c in cases
                if isinstance(c.get("cpu_hours"), (int, float)) and math.isfinite(c["cpu_hours"]))
    statuses = Counter(c.get("status") or "unknown" for _, c in cases)
    title = f"granflow campaign at rung {rung}"
    lines = ["{% raw %}", *TOP_ALIGN, title, "=" * len(title), ""]
    lines += [rst_text(
        f"What ran: {len(summaries)} scene(s), {len(cases)} case(s), {hours:.2f} CPU-hours of LAMMPS "
        f"(all ranks, user + system). How the cases ended: "
        + ", ".join(f"{n} {s}" for s, n in sorted(statuses.items())) + "."), ""]
    if rung != "validation":
        lines += [rst_text(
            f"Every number on this page is from rung {rung}, whose cases are smaller, shorter or softer "
            "than the papers': a difference from the paper here is not a verdict on granflow. The committed "
            "validation record (section validation) compares the validation rung with the papers."), ""]
    lines += ["Cases", "-----", ""]
    rows = [[scene, c.get("dir", ""), c.get("status", ""), c.get("reason", ""),
             f"{c['particles']:,}" if isinstance(c.get("particles"), int) else "–", _hours(c.get("cpu_hours"))]
            for scene, c in cases]
    lines += _table(f"Each case of the campaign (rung {rung})",
                    ["scene", "case", "status", "reason", "particles", "CPU-h"], rows, [8, 12, 10, 50, 8, 6])
    lines += ["Headline numbers against the papers", "-----------------------------------", ""]
    for s in summaries:
        checks = s.get("checks", [])
        if not checks:
            why = s.get("note") or "no headline number could be measured in this campaign."
            lines += [rst_text(f"{s['scene']}: {why}"), ""]
            continue
        rows = []
        for c in checks:
            unit = f" {c['unit']}" if c.get("unit") else ""
            rows.append([c["quantity"], f"{c['paper']}{unit} ({c['source']})",
                         format_with_errors(c.get("ours"), c.get("error"), _finite_or_none(c.get("syst"))) + unit,
                         c.get("case", ""), c.get("verdict", "")])
        lines += _table(f"{s['scene']} (rung {s.get('rung', rung)}): {s.get('paper', '')}",
                        ["quantity", "paper (source)", "ours ± stat (± syst)", "case", "verdict"], rows,
                        [16, 34, 14, 12, 24])
    lines += [rst_text("The scenes' sections follow: their tables, figures and provenance; the "
                       "validation section holds the committed record."), "", "{% endraw %}", ""]
    return "\n".join(lines)


def _finite_or_none(x):
    """A JSON number (a summary's ``syst``, null when not computed) as a float or None."""
    return float(x) if isinstance(x, (int, float)) and math.isfinite(x) else None


def write_overview(summary_paths: list[Path], rung: str, out: Path) -> str:
    """Write the front page ``out`` (reStructuredText) from the scenes' ``summary.json`` files."""
    summaries = [json.loads(Path(p).read_text()) for p in summary_paths]
    text = overview_rst(summaries, rung)
    Path(out).parent.mkdir(parents=True, exist_ok=True)
    Path(out).write_text(text)
    return text
