"""The commands that write and check a scene package, ``granflow new-scene`` and ``granflow check-scene``
(:mod:`granflow.cli` parses their arguments), and the exit codes of every granflow command."""
from __future__ import annotations

from pathlib import Path

from . import registry
from .schema import PROJECT_ROOT

#: exit codes: a user's mistake (bad input, refused before anything runs) and a run that failed
EXIT_OK, EXIT_FAILED, EXIT_BAD_INPUT = 0, 1, 2


def _project_root(option_value: str | None) -> Path:
    """``--dir`` if given, else the working directory: a granflow project root, or a refusal."""
    from .scaffold import project_root

    if option_value is not None:
        return project_root(option_value, "--dir")
    project_root(Path.cwd(), "the working directory")
    return Path(".")  # messages then name its files from there


def _shown(path: Path) -> str:
    """``path`` from the working directory when it lies below it, else absolute."""
    path = Path(path).absolute()
    return str(path.relative_to(Path.cwd())) if path.is_relative_to(Path.cwd()) else str(path)


def _new_scene_next(name: str, root: Path) -> list[str]:
    """What to type after ``granflow new-scene NAME``, for the project root it wrote into."""
    here = root.resolve() == Path.cwd().resolve()
    check = f"granflow check-scene {name}" + ("" if here else f" --dir {_shown(root)}")
    steps = [f"  {check:50s} the contract, the scene file, the smoke decks",
             f"  {f'granflow render {name} --rung smoke --out /tmp/{name}':50s} its decks and params.json",
             f"  {f'pytest tests/unit/test_scene_{name}.py':50s} its contract",
             f"  {f'pytest tests/unit/test_scene_{name}_skeleton.py':50s} the skeleton's tests (rewrite as you change it)"]
    docs = "  docs/adding-a-scene.md says what each file holds and what to change first"
    if root.resolve() == PROJECT_ROOT.resolve():
        return ["next:", *steps, docs]
    if (root / "src" / "granflow" / "registry.py").is_file():  # a checkout of its own
        return [f"next, with the granflow of {_shown(root)} (this one runs from {PROJECT_ROOT / 'src'}; set "
                f"PYTHONPATH={root.resolve() / 'src'} or use its venv):", *steps, docs]
    return [f"next ({'this folder' if here else _shown(root)} holds no granflow code of its own: the scene runs "
            f"once its files are in a checkout):", steps[0], docs]


def cmd_new_scene(args) -> int:
    """Write a new scene's package, scene file, schema and tests (:func:`granflow.scaffold.write_scene`)."""
    from .scaffold import write_scene

    root = _project_root(args.dir)
    name = args.name
    written = write_scene(name, root, registry.names() + tuple(registry.refused()))
    package = [p for p in written if p.parts[:4] == ("src", "granflow", "scenes", name)]
    print(f"wrote the scene {name} under {_shown(root)} ({len(written)} files, moved into place when complete):")
    print(f"  {package[0].parent}/  {', '.join(p.name for p in package)}")
    for path in written:
        if path not in package:
            print(f"  {path}")
    print("\n".join(_new_scene_next(name, root)))
    return 0


def cmd_check_scene(args) -> int:
    """A scene package against the contract, one line per finding (:mod:`granflow.scene_check`); exit 2
    when a required part is missing or broken."""
    from .scene_check import DOCS_PAGE, check_scene, is_own, locate

    by_name = "/" not in args.target and args.target not in (".", "..")
    root = _project_root(args.dir) if (args.dir is not None or by_name) else None
    folder, config_dir = locate(args.target, root)
    name = folder.name
    findings = check_scene(folder, config_dir)
    print(f"check-scene {name}: the package {_shown(folder)}, its files in {_shown(config_dir)}/, "
          f"against granflow.registry.REQUIRED")
    for finding in findings:
        print(finding.line())
    bad = [f for f in findings if f.required]
    if bad:
        print(f"{name}: incomplete: {len(bad)} required part{'s' * (len(bad) > 1)} missing or broken (exit 2); "
              f"{DOCS_PAGE} says what each one is")
        return EXIT_BAD_INPUT
    where = "" if is_own(folder) else " in a checkout that holds it"
    rung = next(f.rung for f in findings if f.kind == "ok")
    print(f"{name}: complete: it gives every part of granflow.registry.REQUIRED and its decks render; "
          f"next{where}: granflow render {name} --rung {rung} --out /tmp/{name}")
    return EXIT_OK
