"""The README's picture of the report's front page (docs/figures/front_page.png), made from the committed record.

  python tools/front_page_picture.py                      # writes docs/figures/front_page.png

Run it whenever the record (``validation/<scene>/summary.json``, ``validation/<scene>/ladder.csv``) or the
page's rules (``granflow.overview``) change; ``tests/unit/test_front_page.py`` fails until the picture
shows the numbers the record holds. Steps: the page is written from the committed record by the
report's own code (:func:`granflow.overview.write_overview`, rung validation, as rule ``overview``
writes it); ``snakemake --report`` of a stand-in workflow in a temporary folder renders it as the
report's front page (the project's rule names for the rule graph beside it, each scene's ``checks.csv``
in its category of the menu; no job runs, nothing of the project's results is read or written); headless
Chromium photographs it at 1400 px wide. The PNG carries the page's text (reStructuredText) in its
``granflow:front_page`` text chunk, which the test reads back and sets against the page built now.

Needs Debian's ``chromium`` (``apt-get install chromium``), which granflow itself does not.
"""
from __future__ import annotations

import argparse
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "src"))

from granflow.overview import write_overview  # noqa: E402

#: the PNG text chunk holding the page the picture shows
TEXT_KEY = "granflow:front_page"
#: the rung of the committed record
RUNG = "validation"
#: the rules of the default campaign (``rule all``), named in the stand-in's rule graph
STAND_IN_RULES = ("render", "simulate", "analyse", "table", "figure", "snapshots", "provenance",
                  "provenance_table", "validation_report", "validation_ladder_report", "overview", "timing")


def record_paths(validation: Path = ROOT / "validation") -> tuple[list[Path], list[Path]]:
    """The committed record's summaries and ladders, in the scenes' order of their folders."""
    return sorted(validation.glob("*/summary.json")), sorted(validation.glob("*/ladder.csv"))


def front_page(out: Path, validation: Path = ROOT / "validation") -> str:
    """Write the front page (reStructuredText) of the committed record to ``out``; return its text."""
    summaries, ladders = record_paths(validation)
    return write_overview(summaries, RUNG, out, ladders)


def stand_in_snakefile(scenes: list[str]) -> str:
    """A workflow whose report opens on ``overview.rst``: one rule per name of :data:`STAND_IN_RULES`,
    rule ``table`` giving each scene's checks (``tables/<scene>.csv``) to its report category."""
    lines = ['report: "overview.rst"', "", "", "rule all:", "    input:",
             *(f'        "{name}.done",' for name in STAND_IN_RULES if name != "table"),
             *(f'        "tables/{scene}.csv",' for scene in scenes), ""]
    for name in STAND_IN_RULES:
        lines += ["", f"rule {name}:", "    output:"]
        lines += (['        report("tables/{scene}.csv", category="{scene}", caption="caption.rst"),']
                  if name == "table" else [f'        "{name}.done",'])
        lines += ['    shell:', '        "touch {output}"', ""]
    return "\n".join(lines)


def render(work: Path, validation: Path = ROOT / "validation") -> tuple[Path, str]:
    """The report of the stand-in workflow in ``work``, its front page written from the record."""
    text = front_page(work / "overview.rst", validation)
    summaries, _ = record_paths(validation)
    scenes = [p.parent.name for p in summaries]
    (work / "tables").mkdir(parents=True, exist_ok=True)
    for scene in scenes:     # present, so the report lists it; the stand-in runs no job
        shutil.copyfile(validation / scene / "checks.csv", work / "tables" / f"{scene}.csv")
    (work / "caption.rst").write_text("The scene's checks from the committed record (validation/<scene>/checks.csv).\n")
    (work / "Snakefile").write_text(stand_in_snakefile(scenes))
    subprocess.run([sys.executable, "-m", "snakemake", "--report", "report.html", "--cores", "1"], cwd=work,
                   check=True, capture_output=True)
    return work / "report.html", text


def photograph(report: Path, png: Path, chromium: str, width: int, height: int) -> None:
    """Headless Chromium's screenshot of ``report`` at ``width`` × ``height`` px."""
    subprocess.run([chromium, "--headless", "--no-sandbox", "--disable-gpu", "--hide-scrollbars",
                    "--no-first-run", "--disable-background-networking", "--disable-component-update",
                    "--disable-sync", f"--window-size={width},{height}", "--virtual-time-budget=8000",
                    f"--screenshot={png}", report.resolve().as_uri()], check=True, capture_output=True)


def stamp(png: Path, out: Path, text: str) -> None:
    """Write ``png`` to ``out`` with the page's text in its :data:`TEXT_KEY` chunk."""
    from PIL import Image
    from PIL.PngImagePlugin import PngInfo

    info = PngInfo()
    info.add_itxt(TEXT_KEY, text)
    out.parent.mkdir(parents=True, exist_ok=True)
    with Image.open(png) as image:       # 128 colours: the page's text and rule graph as shown, a fifth the bytes
        image.convert("RGB").quantize(colors=128, method=Image.Quantize.MEDIANCUT).save(out, pnginfo=info,
                                                                                        optimize=True)


def page_text(png: Path) -> str | None:
    """The page a picture written by :func:`stamp` shows (None for a picture without it)."""
    from PIL import Image

    with Image.open(png) as image:
        return image.text.get(TEXT_KEY)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 epilog=__doc__.split("\n\n", 1)[1], formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", type=Path, default=ROOT / "docs" / "figures" / "front_page.png")
    ap.add_argument("--chromium", default=shutil.which("chromium") or "/usr/bin/chromium")
    ap.add_argument("--width", type=int, default=1400)
    ap.add_argument("--height", type=int, default=1150)
    args = ap.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        report, text = render(Path(tmp))
        raw = Path(tmp) / "shot.png"
        photograph(report, raw, args.chromium, args.width, args.height)
        stamp(raw, args.out, text)
    print(args.out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
