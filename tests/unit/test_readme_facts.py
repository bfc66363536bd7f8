"""What the README says that a machine can check, checked, so that it cannot drift silently.

The quoted refusal messages have their own test (test_readme_refusals.py). Here:
the make targets and `granflow` commands it names exist; its layout section names
every module of src/granflow and src/postproc and only paths that exist; every
repository path it quotes exists; its status table lists exactly the statuses the
code declares; its "default campaign" block is config/config.yaml's; the environment
variables the code reads are documented; the heap's feed limits per rung are what
``feed_plan`` computes; and the refused snakemake target prints what it quotes.
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
from granflow.config import load_scene
from granflow.registry import GENERIC_STATUSES

ROOT = Path(__file__).resolve().parents[2]
README = (ROOT / "README.md").read_text()


def section(title: str) -> str:
    """The text of the README section whose heading starts with ``title`` (up to the next heading of its level).

    Lines inside code fences are never headings (a YAML comment starts with ``#`` too).
    """
    lines, out, level, fenced = README.splitlines(), None, 0, False
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
    assert out is not None, f"README has no section {title!r}"
    return "\n".join(out)


def test_every_make_target_named_exists():
    makefile = (ROOT / "Makefile").read_text()
    targets = set(re.findall(r"^([a-z][a-z-]*):", makefile, re.M))
    named = set(re.findall(r"\bmake ([a-z][a-z-]+)\b", README))
    assert named, "the README names no make target"
    assert named <= targets, f"README names make targets the Makefile lacks: {sorted(named - targets)}"
    # and the README mentions every target a user can run
    assert targets - {"help"} <= named | {"venv"} | {"help"}, sorted(targets - named)


def test_every_granflow_command_named_exists():
    parser = build_parser()
    sub = next(a for a in parser._actions if a.__class__.__name__ == "_SubParsersAction")
    commands = set(sub.choices)
    # as typed: in code (after a backtick or a venv path, or at the start of a line of a code block)
    named = set(re.findall(r"(?:`|bin/|^)granflow ([a-z][a-z-]+)\b", README, re.M))
    assert {"check-config", "render", "run", "plan", "scenes", "cg"} <= named
    assert named <= commands, f"README names granflow commands that do not exist: {sorted(named - commands)}"
    assert commands <= named, f"commands the README never mentions: {sorted(commands - named)}"


def test_layout_names_every_module_and_only_real_paths():
    layout = section("Layout")
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


def test_every_quoted_repository_path_exists():
    quoted = set(re.findall(r"`((?:src|config|workflows|bench|tools|tests|lammps_inputs|profiles|validation|docs)/[^`\s]*)`", README))
    assert len(quoted) > 20
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
    assert not missing, f"README quotes paths that do not exist: {sorted(missing)}"


def test_status_table_lists_exactly_the_declared_statuses():
    declared = dict(GENERIC_STATUSES)
    for name in registry.scenes():
        declared.update(registry.get(name).statuses)
    table = section("Statuses, guards and hard cases")
    listed = set(re.findall(r"^\| `([a-z_]+)` \|", table, re.M))
    assert listed == set(declared), (f"README lists {sorted(listed - set(declared))} that no code declares, "
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
    blocks = re.findall(r"```yaml\n# config/config.yaml \(the default\)\n(.*?)```", README, re.S)
    assert len(blocks) >= 3
    for block in blocks:
        for name, sc in yaml.safe_load(block)["scenes"].items():
            assert sc["sweep"] == config["scenes"][name]["sweep"], name
    # a block that is not the default says so
    for label in re.findall(r"```yaml\n# (config/config\.yaml[^\n]*)\n", README):
        assert "(the default)" in label or "example" in label, label


def test_environment_variables_the_code_reads_are_documented():
    read = set()
    for path in [*(ROOT / "src").rglob("*.py"), *(ROOT / "tests" / "slurm").glob("*"), *(ROOT / "tools").rglob("*")]:
        if path.is_file():
            text = path.read_text(errors="ignore")
            read |= set(re.findall(r"environ\.get\(\s*\"(GRANFLOW_\w+)\"", text))
            read |= set(re.findall(r"^ENV\s*=\s*\"(GRANFLOW_\w+)\"", text, re.M))
    assert {"GRANFLOW_PROGRESS_SECONDS", "GRANFLOW_LMP", "GRANFLOW_MPIRUN"} <= read
    table = section("Environment variables and MPI ranks")
    documented = set(re.findall(r"`(GRANFLOW_\w+)`", table))
    assert read <= documented, sorted(read - documented)
    assert documented <= read, sorted(documented - read)


def test_heap_feed_limits_per_rung_are_what_feed_plan_computes():
    from granflow.preflight import PreflightError
    from granflow.scenes.heap.parameters import feed_plan

    scene = load_scene(ROOT / "config" / "scenes" / "heap.yaml")
    text = section("The bounded heap")
    rows = re.findall(r"^\| (\w+) \| [^|]+\| [^|]+\| [^|]+\| ([0-9., ]+) g/s", text, re.M)
    assert {r for r, _ in rows} == set(scene["rungs"])
    for rung, numbers in rows:
        quoted = [float(x) for x in numbers.split(",")]
        for mixture, value in zip(["mono1.5", "bi1-2", "bi1-3"], quoted):
            with pytest.raises(PreflightError) as err:
                feed_plan(scene, rung, dict(scene["case"], mixture=mixture, feed_rate=10.0))
            largest = 1000 * float(re.search(r"largest feasible rate ([0-9.e+-]+)", str(err.value)).group(1))
            assert value == pytest.approx(largest, abs=0.051), (rung, mixture)  # as rounded in the table


def test_refused_snakemake_target_prints_what_the_readme_quotes():
    m = re.search(r"`snakemake -n (results/\S+)` prints\n`(invalid target, nothing was run: .*?)`\nand exits 2",
                  README, re.S)
    assert m, "README no longer quotes the refused target"
    target, quoted = m.group(1), " ".join(m.group(2).split())
    snakemake = Path(sys.executable).with_name("snakemake")
    proc = subprocess.run([str(snakemake), "-n", "--cores", "1", target], cwd=ROOT, capture_output=True, text=True,
                          timeout=300)
    out = " ".join((proc.stdout + proc.stderr).split())
    assert proc.returncode == 2, out[-2000:]
    pattern = ".*?".join(re.escape(part.strip()) for part in quoted.split("..."))
    assert re.search(pattern, out), f"README quotes\n  {quoted}\nsnakemake prints\n  {out[-1500:]}"
