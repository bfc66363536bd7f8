"""Every public function and method of ``postproc`` and of the scene interface has a numpydoc docstring.

Public: a module-level function of ``src/postproc/*.py``, or a method of a module-level class there,
whose name has no leading underscore, in a class whose name has none either (with the methods a
public class inherits from a private base of the same module, e.g. ``_Cylindrical``); and the
public methods of :class:`granflow.registry.Scene` (scene_base.py, with the member groups of scene_hooks.py). Each needs a docstring, and each that takes
parameters (other than ``self``/``cls``) a ``Parameters`` section naming every one of them
(``Other Parameters`` counts too). Read with :mod:`ast`, nothing is imported: well under a second.
"""
from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[2] / "src"
POSTPROC = sorted((SRC / "postproc").glob("*.py"))
#: the scene interface: the Scene base class and the member groups it mixes in
INTERFACE = {SRC / "granflow" / "scene_base.py": ("Scene",),
             SRC / "granflow" / "scene_hooks.py": ("StudyHooks", "CaseNames")}

_SECTION = re.compile(r"^(Parameters|Other Parameters)\n-{3,}\n(.*?)(?=^\S[^\n]*\n-{3,}\n|\Z)", re.M | re.S)
_FUNCTIONS = (ast.FunctionDef, ast.AsyncFunctionDef)


def _public(name: str) -> bool:
    return not name.startswith("_")


def _parameters(fn) -> list[str]:
    a = fn.args
    names = [x.arg for x in (*a.posonlyargs, *a.args, *a.kwonlyargs)]
    names += [x.arg for x in (a.vararg, a.kwarg) if x is not None]
    return [n for n in names if n not in ("self", "cls")]


def _methods(cls: ast.ClassDef, classes: dict[str, ast.ClassDef], seen=()) -> list:
    """Public methods of ``cls`` and of its private bases defined in the same module."""
    out = [n for n in cls.body if isinstance(n, _FUNCTIONS) and _public(n.name)]
    for base in cls.bases:
        name = base.id if isinstance(base, ast.Name) else None
        if name in classes and not _public(name) and name not in seen:
            out += _methods(classes[name], classes, (*seen, cls.name))
    return out


def _postproc_functions(path: Path) -> list[tuple[str, ast.AST]]:
    tree = ast.parse(path.read_text(), filename=str(path))
    classes = {n.name: n for n in tree.body if isinstance(n, ast.ClassDef)}
    out = [(n.name, n) for n in tree.body if isinstance(n, _FUNCTIONS) and _public(n.name)]
    for cls in classes.values():
        if _public(cls.name):
            out += [(f"{cls.name}.{m.name}", m) for m in _methods(cls, classes)]
    return [(f"{path.stem}.{name}", node) for name, node in out]


def _scene_methods() -> list[tuple[str, ast.AST]]:
    out = []
    for path, names in INTERFACE.items():
        tree = ast.parse(path.read_text(), filename=str(path))
        for cls in (n for n in tree.body if isinstance(n, ast.ClassDef) and n.name in names):
            out += [(f"{path.stem}.{cls.name}.{n.name}", n) for n in cls.body if isinstance(n, _FUNCTIONS) and _public(n.name)]
    assert len({name.split(".")[1] for name, _ in out}) == sum(map(len, INTERFACE.values())), "a class of the interface is gone"
    return out


FUNCTIONS = [item for path in POSTPROC for item in _postproc_functions(path)] + _scene_methods()


def _problems(name: str, node) -> list[str]:
    doc = ast.get_docstring(node)
    if not doc:
        return [f"{name}: no docstring"]
    wanted = _parameters(node)
    if not wanted:
        return []
    sections = _SECTION.findall(doc)
    if not any(title == "Parameters" for title, _ in sections):
        return [f"{name}: no 'Parameters' section (parameters {', '.join(wanted)})"]
    listed = " ".join(body for _, body in sections)
    absent = [p for p in wanted if not re.search(rf"(?<![\w*]){re.escape(p)}\b", listed)]
    return [f"{name}: 'Parameters' does not name {', '.join(absent)}"] if absent else []


def test_the_walk_finds_the_interface():
    names = {name for name, _ in FUNCTIONS}
    assert len(POSTPROC) > 20
    assert {"cg.coarse_grain", "fields.FieldAccumulator.accumulate", "coordinates.RZCoordinates.local_vectors",
            "scene_base.Scene.analyse", "scene_base.Scene.gives", "scene_hooks.StudyHooks.validation",
            "scene_hooks.CaseNames.case_dir"} <= names
    assert not any(name.split(".")[-1].startswith("_") for name in names)


@pytest.mark.parametrize("path", POSTPROC + list(INTERFACE), ids=lambda p: p.name)
def test_every_public_function_has_a_numpydoc_docstring(path):
    problems = [p for name, node in FUNCTIONS if name.startswith(f"{path.stem}.") for p in _problems(name, node)]
    assert not problems, "\n".join(problems)


def test_every_source_file_compiles_without_a_warning():
    """A docstring with ``\\s`` in LaTeX but no ``r`` prefix is an invalid escape: a DeprecationWarning in
    every run today, a SyntaxError in a later Python. Every tracked .py under src/, tools/ and bench/
    compiles with warnings as errors."""
    import warnings

    root = SRC.parent
    files = [p for d in ("src", "tools", "bench") for p in sorted((root / d).rglob("*.py"))]
    assert len(files) > 50
    bad = []
    for path in files:
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            try:
                compile(path.read_text(encoding="utf-8"), str(path), "exec")
            except (SyntaxError, Warning) as exc:
                bad.append(f"{path.relative_to(root)}: {exc}")
    assert not bad, "\n".join(bad)
