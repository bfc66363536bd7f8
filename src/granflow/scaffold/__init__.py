"""``granflow new-scene``: write a new scene package that meets the scene contract.

The files come from the skeleton kept beside this module (``skeleton/*.tmpl``, Python's
:class:`string.Template` with the delimiter ``@@``, so that neither Jinja2's ``{{ }}`` nor
LAMMPS's ``${}`` in them needs escaping): a scene that gives what
:data:`granflow.registry.REQUIRED` asks and nothing optional, as ``tests/data/minimal_scene``
does, with its own deck, parameters, analysis and figure (a bed of spheres rained onto a floor
and settled), so that it renders, runs and is analysed before it is changed into the new scene.

:func:`write_scene` refuses a name that is not a lower-case identifier, is a Python keyword or
an existing scene, and a project where any of the files exists; it writes every file into a
temporary folder under the project root and moves them into place only when all are written,
never over an existing file (a failed move takes back the ones already moved).
"""
from __future__ import annotations

import errno
import keyword
import os
import re
import shutil
import string
import tempfile
from pathlib import Path

from ..yamlio import ConfigError

#: the skeleton's templates
SKELETON = Path(__file__).resolve().parent / "skeleton"
#: where scene packages live, from a project root
SCENES_DIR = Path("src", "granflow", "scenes")
#: each template of the skeleton -> the file it becomes, from the project root (``{name}``: the scene's)
FILES = {
    "__init__.py.tmpl": "src/granflow/scenes/{name}/__init__.py",
    "scene.py.tmpl": "src/granflow/scenes/{name}/scene.py",
    "parameters.py.tmpl": "src/granflow/scenes/{name}/parameters.py",
    "deck.lmp.j2.tmpl": "src/granflow/scenes/{name}/{name}.lmp.j2",
    "pipeline.py.tmpl": "src/granflow/scenes/{name}/pipeline.py",
    "figures.py.tmpl": "src/granflow/scenes/{name}/figures.py",
    "captions.yaml.tmpl": "src/granflow/scenes/{name}/captions.yaml",
    "scene.yaml.tmpl": "config/scenes/{name}.yaml",
    "schema.yaml.tmpl": "config/schema/{name}.schema.yaml",
    "test_scene.py.tmpl": "tests/unit/test_scene_{name}.py",
    "test_skeleton.py.tmpl": "tests/unit/test_scene_{name}_skeleton.py",
}
#: what a scene's name may be
NAME_RULE = ("a lower-case Python identifier (letters a-z, digits and _, starting with a letter) that is "
             "neither a Python keyword nor an existing scene")
_NAME = re.compile(r"[a-z][a-z0-9_]*\Z")


class _Skeleton(string.Template):
    delimiter = "@@"


def project_root(path: str | Path, option: str = "--dir") -> Path:
    """``path`` if it is a granflow project root (it has ``src/granflow/scenes/``), else a refusal
    naming ``option``, the path and what is allowed."""
    root = Path(path)
    if not (root / SCENES_DIR).is_dir():
        raise ConfigError(f"{option} {path} is not a granflow project root: it has no {SCENES_DIR}/: allowed the "
                          f"root of a granflow checkout (default: the working directory)")
    return root


def existing_scenes(root: Path, registered: tuple[str, ...] = ()) -> list[str]:
    """The scenes a new one may not be named after: ``registered`` (the running granflow's, refused
    ones included) and every package or module under the project's ``src/granflow/scenes/``."""
    found = {p.name.split(".")[0] for p in (root / SCENES_DIR).iterdir()
             if not p.name.startswith((".", "_")) and (p.is_dir() or p.suffix == ".py")}
    return sorted(found | set(registered))


def check_name(name: str, root: Path, registered: tuple[str, ...] = ()) -> None:
    """Refuse a scene name that breaks :data:`NAME_RULE`, in one line naming the name and the rule."""
    taken = existing_scenes(root, registered)
    why = ""
    if not _NAME.match(name):
        why = "it is not a lower-case Python identifier"
    elif keyword.iskeyword(name):
        why = "it is a Python keyword"
    elif name in taken:
        why = f"a scene {name} exists ({SCENES_DIR / name} or a registered one)"
    if why:
        raise ConfigError(f"NAME = {name!r} is not allowed: {why}; allowed {NAME_RULE} "
                          f"(existing: {', '.join(taken) or 'none'})")


def class_name(name: str) -> str:
    """``my_bed`` -> ``MyBed``: the prefix of the scene's class (``MyBedScene``)."""
    return "".join(part[:1].upper() + part[1:] for part in name.split("_") if part)


def render_skeleton(name: str) -> dict[str, str]:
    """Every file of a new scene ``name``: its path from the project root -> its text."""
    values = {"name": name, "Class": class_name(name)}
    return {dest.format(name=name): _Skeleton((SKELETON / template).read_text()).substitute(values)
            for template, dest in FILES.items()}


def _place(src: Path, dest: Path) -> None:
    """Move the file ``src`` to ``dest``, never over an existing file (``FileExistsError``)."""
    try:
        os.link(src, dest)  # fails if dest exists, whatever appears meanwhile
    except OSError as exc:
        if exc.errno == errno.EEXIST:
            raise FileExistsError(errno.EEXIST, "exists: new-scene never overwrites a file", str(dest)) from None
        with open(src, "rb") as fin, open(dest, "xb") as fout:  # no hard links here (another file system)
            shutil.copyfileobj(fin, fout)
    src.unlink()


def write_scene(name: str, root: str | Path, registered: tuple[str, ...] = ()) -> list[Path]:
    """Write the new scene ``name`` into the project ``root``: its package under
    ``src/granflow/scenes/``, its scene file and schema under ``config/``, its tests under
    ``tests/unit/`` (:data:`FILES`). Returns the files written (paths from ``root``).

    Refused, with nothing written (:class:`~granflow.yamlio.ConfigError`): a name that breaks
    :data:`NAME_RULE` (``registered`` are the running granflow's scenes), or a project where any
    of the files, or the package's folder, exists.
    """
    root = project_root(root)
    check_name(name, root, registered)
    files = render_skeleton(name)
    package = SCENES_DIR / name
    there = [str(p) for p in [package, *map(Path, files)] if (root / p).exists() or (root / p).is_symlink()]
    if there:
        raise ConfigError(f"NAME = {name!r} is not allowed here: {', '.join(there)} exist{'s' * (len(there) == 1)} "
                          f"in {root.resolve()} and new-scene never overwrites a file: allowed a name none of whose "
                          f"files exist (move them away, or choose another name)")
    tmp = Path(tempfile.mkdtemp(prefix=".new-scene-", dir=root))
    placed, made = [], []
    try:
        for rel, text in files.items():
            (tmp / rel).parent.mkdir(parents=True, exist_ok=True)
            (tmp / rel).write_text(text)
        # the scene file, schema and tests first, the package last: a discovery meanwhile finds
        # the package complete or not at all
        for rel in [r for r in files if not Path(r).is_relative_to(package)]:
            parent = (root / rel).parent
            missing_dirs = [d for d in [parent, *parent.parents] if not d.exists() and d.is_relative_to(root)]
            parent.mkdir(parents=True, exist_ok=True)
            made += reversed(missing_dirs)
            _place(tmp / rel, root / rel)
            placed.append(root / rel)
        if (root / package).exists():
            raise FileExistsError(errno.EEXIST, "exists: new-scene never overwrites a file", str(root / package))
        os.rename(tmp / package, root / package)
        placed.append(root / package)
    except BaseException:
        for path in reversed(placed):
            shutil.rmtree(path) if path.is_dir() else path.unlink()
        for folder in reversed(made):
            if folder.is_dir() and not any(folder.iterdir()):
                folder.rmdir()
        raise
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return [Path(rel) for rel in files]


__all__ = ["FILES", "NAME_RULE", "SKELETON", "check_name", "class_name", "project_root", "render_skeleton",
           "write_scene"]
