"""``granflow new-scene`` and ``granflow check-scene`` (issue 30): a new scene written from the skeleton
(granflow/scaffold) into a project root meets the scene contract, its scene file and schema are complete,
and its smoke decks set up in LAMMPS with the bed its scene file asks for; a bad name, a project that is
not one, or a file already there is refused in one line with nothing written; check-scene names every
required part a package lacks (the registry's own check) and notes the optional ones."""
import importlib
import os
import re
import shutil
from pathlib import Path

import pytest

from granflow import registry, scaffold
from granflow.cli import EXIT_BAD_INPUT, build_parser, main
from granflow.config import load_yaml
from granflow.scene_files import validate_scene
from granflow.deck import STAGES, render_case

ROOT = Path(__file__).resolve().parents[2]


def tree(root: Path) -> dict:
    """Every file and folder under ``root`` with its content (files): what a refusal must leave as it was."""
    return {str(p.relative_to(root)): (p.read_bytes() if p.is_file() else None) for p in sorted(root.rglob("*"))}


@pytest.fixture
def project(tmp_path) -> Path:
    """A project root as new-scene needs it: src/granflow/scenes/ and config/ (the rest is created)."""
    (tmp_path / "src" / "granflow" / "scenes").mkdir(parents=True)
    (tmp_path / "config").mkdir()
    return tmp_path


def new_scene(project: Path, name: str = "bed") -> int:
    return main(["new-scene", name, "--dir", str(project)])


def package(project: Path, name: str = "bed") -> Path:
    return project / "src" / "granflow" / "scenes" / name


# ------------------------------------------------------------------------------------------ new-scene
def test_new_scene_writes_a_scene_that_check_scene_passes(project, capsys):
    assert new_scene(project) == 0
    out = capsys.readouterr().out
    written = {str(p.relative_to(project)) for p in project.rglob("*") if p.is_file()}
    assert written == {dest.format(name="bed") for dest in scaffold.FILES.values()}
    assert "granflow check-scene bed" in out and "config/schema/bed.schema.yaml" in out
    assert not list(project.glob(".new-scene-*"))  # the temporary folder is gone

    assert main(["check-scene", str(package(project))]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert [line.split()[0] for line in lines[1:-1]] == ["ok"] + ["note"] * len(registry.OPTIONAL), lines
    assert lines[1].startswith("  ok      smoke rung renders init.lmp, flow.lmp, average.lmp and params.json "
                               "(300 particles"), lines[1]
    assert lines[-1].startswith("bed: complete: it gives every part of granflow.registry.REQUIRED")


def test_every_key_of_the_new_scene_file_is_commented_and_described_in_its_schema(project):
    """STYLE.md: every key in the YAML has a comment; every key in the schema a type (or const/enum),
    a default and a description."""
    assert new_scene(project) == 0
    text = (project / "config" / "scenes" / "bed.yaml").read_text()
    keys = [line for line in text.splitlines() if line.strip() and not line.lstrip().startswith("#")]
    assert keys and all("#" in line for line in keys), [line for line in keys if "#" not in line]

    def leaves(node, path=()):
        for key, sub in node.get("properties", {}).items():
            if "properties" in sub or isinstance(sub.get("additionalProperties"), dict):
                yield from leaves(sub, path + (key,))
            else:
                yield path + (key,), sub
        ref = node.get("additionalProperties")
        if isinstance(ref, dict) and "$ref" in ref:
            yield from leaves(schema["$defs"][ref["$ref"].rsplit("/", 1)[-1]], path + ("<rung>",))

    schema = load_yaml(project / "config" / "schema" / "bed.schema.yaml")
    found = list(leaves(schema))
    assert len(found) > 20
    for key, spec in found:
        assert {"default", "description"} <= set(spec) and ({"type", "const", "enum"} & set(spec)), key


def test_the_smoke_deck_of_the_new_scene_sets_up_the_bed_its_file_asks_for(project, tmp_path, skiprun):
    """Rendered from the new package (imported by its path, as check-scene does), each stage's deck sets
    up in LAMMPS, and the init stage builds exactly the smoke rung's n_particles of total mass
    n_particles x rho pi d^3/6 (LAMMPS prints both; 10 digits)."""
    assert new_scene(project) == 0
    scene_file = load_yaml(project / "config" / "scenes" / "bed.yaml")
    schema = load_yaml(project / "config" / "schema" / "bed.schema.yaml")
    out = tmp_path / "case"
    with registry.package_at(package(project)) as module:
        declared = importlib.import_module(module).SCENE
        validate_scene(scene_file, "bed.yaml", declared=declared, schema=schema)
        record = render_case(scene_file, "smoke", out, {"friction": 0.2}, declared=declared)
    printed = skiprun(out, STAGES)
    built = re.search(r"GRANFLOW bed: (\d+) particles, mass (\S+)", printed["init"])
    asked = scene_file["rungs"]["smoke"]["n_particles"]
    assert built and int(built.group(1)) == asked == record["parameters"]["n_particles"]
    assert float(built.group(2)) == pytest.approx(asked * scene_file["particles"]["density"] * 3.141592653589793 / 6,
                                                  rel=1e-9)
    assert "variable friction       equal 0.2" in (out / "flow.lmp").read_text()


@pytest.mark.parametrize("name, why", [
    ("Bed", "it is not a lower-case Python identifier"),
    ("2bed", "it is not a lower-case Python identifier"),
    ("my-bed", "it is not a lower-case Python identifier"),
    ("_bed", "it is not a lower-case Python identifier"),
    ("../bed", "it is not a lower-case Python identifier"),
    ("", "it is not a lower-case Python identifier"),
    ("class", "it is a Python keyword"),
    ("chute", "a scene chute exists"),   # registered in this checkout
    ("drum", "a scene drum exists"),     # a package of the target project only
])
def test_a_bad_name_is_refused_in_one_line_with_nothing_written(project, capsys, name, why):
    (package(project, "drum")).mkdir()
    before = tree(project)
    assert new_scene(project, name) == EXIT_BAD_INPUT
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith(f"granflow: refused: NAME = {name!r} is not allowed: {why}"), err
    assert "allowed a lower-case Python identifier" in err and "Traceback" not in err
    assert tree(project) == before


def test_a_project_root_that_is_none_is_refused(tmp_path, capsys):
    assert main(["new-scene", "bed", "--dir", str(tmp_path)]) == EXIT_BAD_INPUT
    err = capsys.readouterr().err
    assert f"--dir {tmp_path} is not a granflow project root: it has no src/granflow/scenes/" in err
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("existing", ["config/scenes/bed.yaml", "tests/unit/test_scene_bed.py",
                                      "config/schema/bed.schema.yaml"])
def test_an_existing_file_is_never_overwritten(project, capsys, existing):
    (project / existing).parent.mkdir(parents=True, exist_ok=True)
    (project / existing).write_text("mine\n")
    before = tree(project)
    assert new_scene(project) == EXIT_BAD_INPUT
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"{existing} exists in {project.resolve()} and new-scene never overwrites a file" in err
    assert tree(project) == before


def test_a_move_that_fails_takes_back_what_it_moved(project, monkeypatch):
    """The files go into place one by one, the package last: when that fails, the others are removed
    again, with the folders made for them."""
    before = tree(project)

    def refuse(src, dest):
        raise PermissionError(13, "Permission denied", str(dest))

    monkeypatch.setattr(scaffold.os, "rename", refuse)
    with pytest.raises(PermissionError):
        scaffold.write_scene("bed", project)
    assert tree(project) == before


def test_the_help_says_what_is_written_where_and_what_comes_next(capsys):
    for command, words in (("new-scene", ("config/scenes/NAME.yaml", "config/schema/NAME.schema.yaml",
                                          "tests/unit/test_scene_NAME.py", "src/granflow/scenes/NAME/",
                                          "granflow check-scene NAME", "granflow render NAME --rung smoke",
                                          "docs/adding-a-scene.md")),
                           ("check-scene", ("granflow.registry.REQUIRED", "granflow.registry.OPTIONAL", "exit",
                                            "granflow render NAME", "docs/adding-a-scene.md"))):
        with pytest.raises(SystemExit) as done:
            build_parser().parse_args([command, "--help"])
        assert done.value.code == 0
        text = " ".join(capsys.readouterr().out.split())
        for word in words:
            assert word in text, (command, word)


# ---------------------------------------------------------------------------------------- check-scene
def test_check_scene_names_every_required_part_a_package_lacks(project, capsys):
    assert new_scene(project) == 0
    scene_py = package(project) / "scene.py"
    scene_py.write_text(scene_py.read_text().replace("def analyse(self", "def analyse_later(self"))
    (project / "config" / "schema" / "bed.schema.yaml").unlink()
    capsys.readouterr()
    assert main(["check-scene", "bed", "--dir", str(project)]) == EXIT_BAD_INPUT
    lines = capsys.readouterr().out.splitlines()
    lacks = [line for line in lines if line.startswith("  lacks")]
    assert lacks == ["  lacks   analyse() (a finished case's tables and scalars)",
                     f"  lacks   schema ({project / 'config' / 'schema' / 'bed.schema.yaml'}: no such file)"], lines
    assert "  note    decks: not rendered until the required parts are there" in lines
    assert lines[-1].startswith("bed: incomplete: 2 required parts missing or broken (exit 2)")


def test_check_scene_names_each_fault_of_the_scene_file(project, capsys):
    assert new_scene(project) == 0
    path = project / "config" / "scenes" / "bed.yaml"
    path.write_text(path.read_text().replace("    n_particles: 300 ", "    n_particles: -3 ")
                    .replace("  e_n: 0.7 ", "  e_n: 1.5 "))
    capsys.readouterr()
    assert main(["check-scene", str(package(project))]) == EXIT_BAD_INPUT
    broken = [line for line in capsys.readouterr().out.splitlines() if line.startswith("  broken")]
    assert len(broken) == 2, broken
    assert "contact.e_n = 1.5 is not allowed: allowed 0 < value <= 1" in broken[0]
    assert "rungs.smoke.n_particles = -3 is not allowed: allowed 1 <= value <= 100000000" in broken[1]


def test_check_scene_of_a_package_that_does_not_import(project, capsys):
    (package(project, "typo")).mkdir()
    (package(project, "typo") / "__init__.py").write_text("import granflow.no_such_module\n")
    assert main(["check-scene", "typo", "--dir", str(project)]) == EXIT_BAD_INPUT
    out = capsys.readouterr().out
    assert "  broken  package: its package does not import (ModuleNotFoundError: No module named " \
           "'granflow.no_such_module')" in out


def test_check_scene_of_shipped_scenes_and_of_the_tests_minimal_scene(monkeypatch, capsys):
    """Registered scenes by their names: complete, every optional part given. The heap's file asks for a
    feed rate its smoke rung cannot deliver: a note, and the demo rung renders instead (as check-config
    takes it). The tests' minimal scene by its path (outside any scenes/ folder, so its files are looked
    for in the working directory's config/): its deck template, schema and scene file are not beside it."""
    monkeypatch.chdir(ROOT)
    assert main(["check-scene", "chute"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert [line.split()[0] for line in lines[1:-1]] == ["ok"], lines
    assert lines[-1].endswith("next: granflow render chute --rung smoke --out /tmp/chute")
    assert main(["check-scene", "heap"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[1].startswith("  note    smoke rung refuses the scene file's case (PreflightError: feed rate"), lines
    assert lines[2].startswith("  ok      demo rung renders init.lmp, flow.lmp, average.lmp and params.json"), lines
    assert lines[-1].endswith("next: granflow render heap --rung demo --out /tmp/heap")
    assert main(["check-scene", "tests/data/minimal_scene"]) == EXIT_BAD_INPUT
    lacks = [line.split()[1] for line in capsys.readouterr().out.splitlines() if line.startswith("  lacks")]
    assert lacks == ["schema", "scene", "deck"]


def test_check_scene_of_a_name_with_no_package_is_refused(project, capsys):
    assert main(["check-scene", "nothing", "--dir", str(project)]) == EXIT_BAD_INPUT
    assert "NAME = 'nothing' is not allowed: " in capsys.readouterr().err


def test_the_new_scenes_tests_hold_the_contract_apart_from_the_skeleton(tmp_path, project_copy):
    """Issue 41: the test new-scene wrote imported the skeleton's helpers at its top, so the first edit
    of the scene broke the collection of the whole suite. Now test_scene_<name>.py checks the contract
    alone and test_scene_<name>_skeleton.py the skeleton: with the skeleton's analysis renamed, the
    contract's tests pass, the suite still collects, and the skeleton's test says what to rewrite."""
    import subprocess
    import sys

    copy = project_copy(tmp_path / "project")
    (copy / "tests").mkdir()
    shutil.copyfile(ROOT / "tests" / "conftest.py", copy / "tests" / "conftest.py")
    assert new_scene(copy, "bedx") == 0
    tests = ["tests/unit/test_scene_bedx.py", "tests/unit/test_scene_bedx_skeleton.py"]

    def pytest_run():
        env = dict(os.environ, PYTHONPATH=str(copy / "src"))
        return subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", *tests], cwd=copy,
                              env=env, capture_output=True, text=True, timeout=600)

    done = pytest_run()
    assert done.returncode == 0 and "10 passed" in done.stdout, done.stdout[-3000:] + done.stderr[-2000:]
    pipeline = copy / "src" / "granflow" / "scenes" / "bedx" / "pipeline.py"
    pipeline.write_text(pipeline.read_text().replace("def packing_profile(", "def density_profile("))
    done = pytest_run()
    assert done.returncode == 1 and "1 failed, 9 passed" in done.stdout, done.stdout[-3000:]
    assert "error" not in done.stdout.lower(), done.stdout[-3000:]  # no collection error
    assert ("the skeleton's packing_profile, bulk_packing (granflow.scenes.bedx.pipeline) is gone" in done.stdout
            and "rewrite its tests for what the scene does now" in done.stdout), done.stdout[-3000:]
    # the node id only: a wide terminal (CI's) appends " - <the reason>" to the summary line
    failed = [line.split()[1] for line in done.stdout.splitlines() if line.startswith("FAILED")]
    assert failed == ["tests/unit/test_scene_bedx_skeleton.py::test_the_profile_of_a_simple_cubic_packing_is_"
                      "pi_over_6"], done.stdout[-3000:]  # the contract's tests all passed
    assert "During handling" not in done.stdout
