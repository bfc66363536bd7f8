"""Screenshots of report.html in headless Chromium: the front page and one scene section. By hand.

  python tools/report_screenshots.py report.html docs/ --scene silo

Needs Playwright and a Chromium, neither a granflow dependency (only the docs use
this): e.g. ``python3 -m venv /tmp/pw && /tmp/pw/bin/pip install playwright`` and
Debian's ``chromium`` (``apt-get install chromium``), then run it with that venv's
python. Writes ``report_front_page.png`` (the page Snakemake's report opens on: the
campaign's front page, rule overview) and ``report_scene_section.png`` (the scene's
category, opened on its particle snapshots).
"""
from __future__ import annotations

import argparse
from pathlib import Path


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("report", type=Path, help="the report.html to photograph")
    ap.add_argument("out", type=Path, help="directory for the PNG files")
    ap.add_argument("--scene", default="silo", help="the scene section to open (its report category)")
    ap.add_argument("--chromium", default="/usr/bin/chromium", help="the Chromium executable")
    ap.add_argument("--width", type=int, default=1400)
    ap.add_argument("--height", type=int, default=1000)
    args = ap.parse_args()

    from playwright.sync_api import sync_playwright

    args.out.mkdir(parents=True, exist_ok=True)
    flags = ["--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
             "--disable-background-networking", "--disable-component-update", "--disable-sync"]
    with sync_playwright() as pw:
        browser = pw.chromium.launch(executable_path=args.chromium, headless=True, args=flags)
        page = browser.new_page(viewport={"width": args.width, "height": args.height})
        page.goto(args.report.resolve().as_uri())
        page.wait_for_timeout(3000)
        # the report may open scrolled (an anchor, a focused element): show the page from its top
        page.evaluate("() => { window.scrollTo(0, 0); document.querySelectorAll('*').forEach(e => { "
                      "if (e.scrollTop) e.scrollTop = 0; }); }")
        page.wait_for_timeout(500)
        page.screenshot(path=str(args.out / "report_front_page.png"), full_page=False)
        # the scene's category, then its particle snapshots
        page.get_by_text(args.scene, exact=True).first.click()
        page.wait_for_timeout(1500)
        snapshots = page.get_by_text("particle snapshots", exact=False)
        if snapshots.count():
            snapshots.first.click()
            page.wait_for_timeout(1500)
        items = page.locator("table a, table button, tr td a")
        if items.count():  # open the first result of the list (a case's snapshot strip)
            items.first.click()
            page.wait_for_timeout(2500)
        page.screenshot(path=str(args.out / "report_scene_section.png"), full_page=False)
        browser.close()
    for name in ("report_front_page.png", "report_scene_section.png"):
        print(args.out / name)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
