"""What the README and the pages of docs/ say that a machine can check, checked, so that it cannot drift silently.

The README is the newcomer's five minutes; the rest lives in docs/. Each check reads the
file that holds its fact. The quoted refusal messages have their own test
(test_readme_refusals.py, reading docs/statuses-and-refusals.md). Here: the make targets and
`granflow` commands named anywhere exist, and every one is named somewhere; the README keeps
the two commands with their times, stays within 250 lines and links docs/; docs/README.md
indexes every page and screenshot; every relative link (and its #anchor) resolves; the layout
section (docs/architecture.md) names every module of src/granflow and src/postproc and only
paths that exist; every repository path quoted in any page exists; the status table
(docs/statuses-and-refusals.md) lists exactly the statuses the code declares; the README's
"default campaign" block is config/config.yaml's; the environment variables the code reads are
documented (docs/environment.md); the heap's feed limits per rung (docs/heap.md) are what
``feed_plan`` computes; and the refused snakemake target prints what
docs/statuses-and-refusals.md quotes.
"""
from __future__ import annotations

import math
import re
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from granflow import registry
from granflow.cli import build_parser
from granflow.scene_files import load_scene
from granflow.registry import GENERIC_STATUSES

ROOT = Path(__file__).resolve().parents[2]
DOCS = ROOT / "docs"
#: README.md and every page of docs/, by their path from the project root
PAGES: dict[str, str] = {"README.md": (ROOT / "README.md").read_text(),
                         **{f"docs/{p.name}": p.read_text() for p in sorted(DOCS.glob("*.md"))}}
README = PAGES["README.md"]
EVERYTHING = "\n".join(PAGES.values())

# the page that holds each checked fact
LAYOUT_PAGE = "docs/architecture.md"
STATUSES_PAGE = "docs/statuses-and-refusals.md"
REFUSALS_PAGE = "docs/statuses-and-refusals.md"
ENVIRONMENT_PAGE = "docs/environment.md"
HEAP_PAGE = "docs/heap.md"

README_MAX_LINES = 250  # issue 30: a README a newcomer reads in five minutes


def headings(text: str) -> list[tuple[int, str]]:
    """(level, title) of every Markdown heading of ``text``, code fences skipped."""
    out, fenced = [], False
    for line in text.splitlines():
        if line.startswith("```"):
            fenced = not fenced
        m = None if fenced else re.match(r"^(#+) (.*)$", line)
        if m:
            out.append((len(m.group(1)), m.group(2)))
    return out


def section(title: str, page: str = "README.md") -> str:
    """The text of the section of ``page`` whose heading starts with ``title`` (up to the next heading of its level).

    Lines inside code fences are never headings (a YAML comment starts with ``#`` too).
    """
    lines, out, level, fenced = PAGES[page].splitlines(), None, 0, False
    for line in lines:
        if line.startswith("```"):
            fenced = not fenced
        heading = None if fenced else re.match(r"^(#+) (.*)$", line)
        if out is None:
            if heading and heading.group(2).startswith(title):
                out, level = [], len(heading.group(1))
            continue
        if heading and len(heading.group(1)) <= level:
            break
        out.append(line)
    assert out is not None, f"{page} has no section {title!r}"
    return "\n".join(out)


def anchor(title: str) -> str:
    """GitHub's anchor of a heading: lower case, punctuation dropped (not - or _), spaces to hyphens."""
    return re.sub(r"[^\w\- ]", "", title.strip().lower()).replace(" ", "-")


def test_every_make_target_named_exists():
    makefile = (ROOT / "Makefile").read_text()
    targets = set(re.findall(r"^([a-z][a-z-]*):", makefile, re.M))
    named = set(re.findall(r"\bmake ([a-z][a-z-]+)\b", EVERYTHING))
    assert named, "the README and docs/ name no make target"
    assert named <= targets, f"README or docs/ name make targets the Makefile lacks: {sorted(named - targets)}"
    # and the README or docs/ mention every target a user can run
    assert targets - {"help"} <= named | {"venv"} | {"help"}, sorted(targets - named)


def test_every_granflow_command_named_exists():
    parser = build_parser()
    sub = next(a for a in parser._actions if a.__class__.__name__ == "_SubParsersAction")
    commands = set(sub.choices)
    # as typed: in code (after a backtick or a venv path, or at the start of a line of a code block)
    named = set(re.findall(r"(?:`|bin/|^)granflow ([a-z][a-z-]+)\b", EVERYTHING, re.M))
    assert {"check-config", "render", "run", "plan", "scenes", "cg"} <= named
    assert named <= commands, f"README or docs/ name granflow commands that do not exist: {sorted(named - commands)}"
    assert commands <= named, f"commands neither the README nor docs/ mention: {sorted(commands - named)}"


def test_layout_names_every_module_and_only_real_paths():
    layout = section("Layout", LAYOUT_PAGE)
    block = re.search(r"```\n(.*?)```", layout, re.S).group(1)
    for package in ("granflow", "postproc"):
        modules = {p.name for p in (ROOT / "src" / package).glob("*.py") if p.name != "__init__.py"}
        missing = {m for m in modules if not re.search(rf"(?<![\w/]){re.escape(m)}\b", block)}
        assert not missing, f"the layout section does not name src/{package}/{sorted(missing)}"
    # every path at the start of a line (before its description) exists, <name> standing for any scene
    scenes = sorted(registry.scenes())
    for line in block.splitlines():
        if not line.strip() or line[0].isspace():
            continue  # a package's members, indented under it: checked above
        token = line.split()[0]
        if "/" not in token or token.startswith("("):
            continue
        for name in scenes if "<name>" in token else [None]:
            path = token.replace("<name>", name or "").rstrip(",")
            if "*" in path:
                assert list(ROOT.glob(path)), f"layout: nothing matches {path}"
            else:
                assert (ROOT / path).exists(), f"layout: {path} does not exist"


QUOTED = r"`((?:src|config|workflows|bench|tools|tests|lammps_inputs|profiles|validation|docs)/[^`\s]*)`"


def test_the_pages_quote_repository_paths():
    assert len(set(re.findall(QUOTED, EVERYTHING))) > 20


@pytest.mark.parametrize("page", sorted(PAGES))
def test_every_quoted_repository_path_exists(page):
    quoted = set(re.findall(QUOTED, PAGES[page]))
    scenes = sorted(registry.scenes())
    missing = []
    for path in quoted:
        path = path.rstrip(".,:;)")
        if "<" in path and "<name>" not in path and "<scene>" not in path:
            continue  # a pattern with run-time parts (<rung>, <case>, ...)
        candidates = [path.replace("<name>", s).replace("<scene>", s) for s in scenes] if "<" in path else [path]
        for candidate in candidates:
            if "*" in candidate:
                ok = bool(list(ROOT.glob(candidate)))
            else:
                ok = (ROOT / candidate).exists()
            if not ok:
                missing.append(candidate)
    assert not missing, f"{page} quotes paths that do not exist: {sorted(missing)}"


def test_status_table_lists_exactly_the_declared_statuses():
    declared = dict(GENERIC_STATUSES)
    for name in registry.scenes():
        declared.update(registry.get(name).statuses)
    table = section("Statuses, guards and hard cases", STATUSES_PAGE)
    listed = set(re.findall(r"^\| `([a-z_]+)` \|", table, re.M))
    assert listed == set(declared), (f"{STATUSES_PAGE} lists {sorted(listed - set(declared))} that no code declares, "
                                     f"misses {sorted(set(declared) - listed)}")


def test_default_campaign_block_is_the_shipped_config():
    text = section("The default campaign")
    block = re.search(r"```yaml\n# config/config.yaml \(the default\)\n(.*?)```", text, re.S).group(1)
    shown = yaml.safe_load(block)
    config = yaml.safe_load((ROOT / "config" / "config.yaml").read_text())
    assert shown["rung"] == config["rung"]
    enabled = {k: v for k, v in config["scenes"].items() if v.get("enabled", True)}
    assert set(shown["scenes"]) == set(enabled)
    for name, sc in enabled.items():
        assert shown["scenes"][name]["sweep"] == sc["sweep"], name
    n_cases = sum(math.prod(len(v) for v in sc["sweep"].values()) for sc in enabled.values())
    assert f"{n_cases} cases" in text


def test_sweeps_labelled_default_are_the_default():
    config = yaml.safe_load((ROOT / "config" / "config.yaml").read_text())
    blocks = re.findall(r"```yaml\n# config/config.yaml \(the default\)\n(.*?)```", EVERYTHING, re.S)
    assert len(blocks) >= 3
    for block in blocks:
        for name, sc in yaml.safe_load(block)["scenes"].items():
            assert sc["sweep"] == config["scenes"][name]["sweep"], name
    # a block that is not the default says so
    for label in re.findall(r"```yaml\n# (config/config\.yaml[^\n]*)\n", EVERYTHING):
        assert "(the default)" in label or "example" in label, label


def test_environment_variables_the_code_reads_are_documented():
    read = set()
    for path in [*(ROOT / "src").rglob("*.py"), *(ROOT / "tests" / "slurm").glob("*"), *(ROOT / "tools").rglob("*")]:
        if path.is_file():
            text = path.read_text(errors="ignore")
            read |= set(re.findall(r"environ\.get\(\s*\"(GRANFLOW_\w+)\"", text))
            read |= set(re.findall(r"^ENV\s*=\s*\"(GRANFLOW_\w+)\"", text, re.M))
    assert {"GRANFLOW_PROGRESS_SECONDS", "GRANFLOW_LMP", "GRANFLOW_MPIRUN"} <= read
    table = section("Environment variables and MPI ranks", ENVIRONMENT_PAGE)
    documented = set(re.findall(r"`(GRANFLOW_\w+)`", table))
    assert read <= documented, sorted(read - documented)
    assert documented <= read, sorted(documented - read)


def test_heap_feed_limits_per_rung_are_what_feed_plan_computes():
    from granflow.preflight import PreflightError
    from granflow.scenes.heap.parameters import feed_plan

    scene = load_scene(ROOT / "config" / "scenes" / "heap.yaml")
    text = section("The bounded heap", HEAP_PAGE)
    rows = re.findall(r"^\| (\w+) \| [^|]+\| [^|]+\| [^|]+\| ([0-9., ]+) g/s", text, re.M)
    assert {r for r, _ in rows} == set(scene["rungs"])
    for rung, numbers in rows:
        quoted = [float(x) for x in numbers.split(",")]
        for mixture, value in zip(["mono1.5", "bi1-2", "bi1-3"], quoted):
            with pytest.raises(PreflightError) as err:
                feed_plan(scene, rung, dict(scene["case"], mixture=mixture, feed_rate=10.0))
            largest = 1000 * float(re.search(r"largest feasible rate ([0-9.e+-]+)", str(err.value)).group(1))
            assert value == pytest.approx(largest, abs=0.051), (rung, mixture)  # as rounded in the table


def test_refused_snakemake_target_prints_what_the_docs_quote():
    m = re.search(r"`snakemake -n (results/\S+)` prints\n`(invalid target, nothing was run: .*?)`\nand exits 2",
                  PAGES[REFUSALS_PAGE], re.S)
    assert m, f"{REFUSALS_PAGE} no longer quotes the refused target"
    target, quoted = m.group(1), " ".join(m.group(2).split())
    snakemake = Path(sys.executable).with_name("snakemake")
    proc = subprocess.run([str(snakemake), "-n", "--cores", "1", target], cwd=ROOT, capture_output=True, text=True,
                          timeout=300)
    out = " ".join((proc.stdout + proc.stderr).split())
    assert proc.returncode == 2, out[-2000:]
    pattern = ".*?".join(re.escape(part.strip()) for part in quoted.split("..."))
    assert re.search(pattern, out), f"{REFUSALS_PAGE} quotes\n  {quoted}\nsnakemake prints\n  {out[-1500:]}"


def test_readme_is_short():
    n = len(README.splitlines())
    assert n <= README_MAX_LINES, f"README.md has {n} lines: at most {README_MAX_LINES}; move the rest to docs/"


def test_readme_keeps_the_two_commands_with_their_times():
    text = section("Two commands")
    block = re.search(r"```bash\n(.*?)```", text, re.S).group(1)
    assert [line.split()[:2] for line in block.splitlines() if line.strip()] == [["make", "demo"], ["make", "test"]]
    assert re.search(r"`make demo` took \*\*\d+ min\*\*", text), "the README no longer says how long make demo takes"
    assert re.search(r"`make test` runs the whole test suite, [\d,]+ tests \([^)]*\d+ min", text), \
        "the README no longer says how long make test takes"


def test_readme_one_case_targets_are_the_campaigns():
    """The snakemake targets the README's commands name are cases the default campaign holds: a dry run takes them."""
    blocks = "\n".join(re.findall(r"```bash\n(.*?)```", README, re.S))
    targets = sorted({t.strip("'") for line in blocks.splitlines() if "snakemake" in line.split("#")[0]
                      for t in line.split("#")[0].split() if t.strip("'").startswith("results/")})
    assert any("/theta~" in t for t in targets), targets  # the one case, end to end
    snakemake = Path(sys.executable).with_name("snakemake")
    proc = subprocess.run([str(snakemake), "-n", "--cores", "1", *targets], cwd=ROOT, capture_output=True, text=True,
                          timeout=300)
    assert proc.returncode == 0, (targets, (proc.stdout + proc.stderr)[-2000:])


def test_docs_index_lists_every_page_and_screenshot():
    index = PAGES["docs/README.md"]
    linked = set(re.findall(r"\]\(([^)#\s]+)(?:#[^)]*)?\)", index))
    pages = {p.name for p in DOCS.glob("*.md")} - {"README.md"}
    pictures = {p.name for p in DOCS.glob("*.png")}
    assert pages <= linked, f"docs/README.md does not link {sorted(pages - linked)}"
    assert pictures <= linked, f"docs/README.md does not link {sorted(pictures - linked)}"
    assert "docs/README.md" in re.findall(r"\]\(([^)#\s]+)\)", README), "the README does not link docs/README.md"


@pytest.mark.parametrize("page", sorted(PAGES))
def test_relative_links_resolve(page):
    """Every relative link and image of a page names a file that exists (paths from docs/ start ../ for the
    project root), and its #anchor, if any, a heading of that file."""
    where = (ROOT / page).parent
    text = re.sub(r"```.*?```", "", PAGES[page], flags=re.S)
    broken = []
    for target in re.findall(r"!?\[[^\]]*\]\(([^)\s]+)\)", text):
        if re.match(r"[a-z]+:", target):
            continue  # https:, mailto:
        path, _, fragment = target.partition("#")
        file = (where / path).resolve() if path else ROOT / page
        if not file.exists():
            broken.append(f"{target}: no file {file}")
        elif fragment and fragment not in {anchor(title) for _, title in headings(file.read_text())}:
            broken.append(f"{target}: no heading with anchor #{fragment} in {file.relative_to(ROOT)}")
    assert not broken, f"{page}: " + "; ".join(broken)
