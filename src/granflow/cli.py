"""The ``granflow`` command line.

Examples
--------
Validate the campaign (and every scene file it uses), trying one change::

    granflow check-config config/config.yaml --set scenes.channel.sweep.phi_mean=[0.59,0.61]

Write the decks and parameter record of one channel case without running it::

    granflow render channel --rung smoke --out /tmp/channel --set case.phi_mean=0.61

List the registered scenes::

    granflow scenes

Run (or resume) a rendered case on 2 MPI ranks::

    granflow run /tmp/channel --np 2

Plan the campaign at the study rung: particles, CPU-hours, memory, ranks, runtime per case, what is done::

    granflow plan --rung study

Write a new scene from granflow's skeleton, then check it against the scene contract::

    granflow new-scene drum
    granflow check-scene drum

Write a campaign of one scene (an overlay with every other scene disabled) and run it::

    granflow campaign --only chute --out /tmp/chute_only.yaml
    snakemake --cores 2 --configfile /tmp/chute_only.yaml

Coarse-grain any LAMMPS dump (see ``granflow cg --help``)::

    granflow cg dump.bin --coords rz --axis 0.05,0.05 --width 0.002 --spacing 0.002 --out cg
"""
from __future__ import annotations

import argparse
import errno
import json
import math
import os
import shlex
import sys
import traceback
from pathlib import Path

from postproc import cg_cli
from postproc.safe_write import OutputWriteError

from . import one_scene, registry
from .campaign import load_campaign
from .config import ConfigError, load_yaml
from .resources import LIMIT_KEYS, check_limits, check_size
from .scene_files import check_rung, load_scene
from .schema import PROJECT_ROOT
from .preflight import PreflightError, check_ranks, read_record

from .scene_commands import EXIT_BAD_INPUT, EXIT_FAILED, EXIT_OK, cmd_check_scene, cmd_new_scene  # noqa: F401


class UsageError(ConfigError):
    """A command line that cannot be carried out as given (exit 2, no traceback)."""


def _add_set(p: argparse.ArgumentParser) -> None:
    p.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                   help="override a value by its dotted path (repeatable), validated exactly like the "
                        "file; VALUE is read as YAML, e.g. --set case.phi_mean=0.61 or "
                        "--set scenes.channel.sweep.W=[20,30]; a name holding a dot goes in quotes: "
                        "--set 'particles.mixtures.\"mono1.5\".diameters=[1.6e-3]'")


def _add_limits(p: argparse.ArgumentParser) -> None:
    p.add_argument("--max-particles", type=int, default=None, metavar="N",
                   help="refuse a case estimated above N particles (default: the campaign's "
                        "max_particles, else 2,000,000)")
    p.add_argument("--memory-mb", type=float, default=None, metavar="MB",
                   help="refuse a case estimated above MB of memory (default: the campaign's "
                        "memory_mb, else this machine's memory)")
    p.add_argument("--max-cpu-hours", type=float, default=None, metavar="H",
                   help="refuse a case, or a campaign's cases together, estimated above H CPU-hours "
                        "(default: the campaign's max_cpu_hours, else a week of this machine's cores, "
                        "7 x 24 x os.cpu_count())")


def _limit_overrides(args) -> list[str]:
    """``--max-particles``/``--memory-mb``/``--max-cpu-hours`` as campaign overrides (validated with the file)."""
    out = []
    if getattr(args, "max_particles", None) is not None:
        out.append(f"max_particles={args.max_particles}")
    for key in ("memory_mb", "max_cpu_hours"):
        value = getattr(args, key, None)
        if value is not None:  # as YAML: nan and inf are .nan and .inf there (refused as not finite)
            out.append(f"{key}={value!r}" if math.isfinite(value) else f"{key}={'-' * (value < 0)}.{abs(value)!r}")
    return out


def _limits(args) -> dict:
    """The limits given on the command line, checked against the campaign schema's bounds."""
    given = {key: getattr(args, key, None) for key in LIMIT_KEYS}
    return check_limits({k: v for k, v in given.items() if v is not None})


def _check_case(scene: dict, rung: str, limits: dict, source: str) -> None:
    """What ``granflow render`` checks before it writes anything, also run by ``check-config`` on a
    scene file: the rung exists, and the case (the file's ``case:``) fits the limits, its geometry
    and its time step (:func:`granflow.resources.check_size`, which derives the deck's parameters)."""
    check_rung(scene, rung)
    check_size(scene["scene"], scene, rung, None, limits, source, f"{scene['scene']} at rung {rung}")


def cmd_check_config(args) -> int:
    """A campaign file: every case of the campaign, as Snakemake validates it (``--rung`` sets its
    rung). A scene file: its schema and cross-field rules, then its case at ``--rung`` with the
    checks ``granflow render`` runs (:func:`_check_case`: size limits, geometry, time step),
    refused as render would refuse it; without ``--rung`` at every rung of the file, refused only
    if no rung can render it, the rungs that cannot listed with the reason."""
    path = Path(args.file)
    data = load_yaml(path)
    if "scene" in data:
        scene = load_scene(path, args.overrides)
        limits = _limits(args)
        rungs = [args.rung] if args.rung else list(scene["rungs"])
        refused = {}
        for rung in rungs:
            try:
                _check_case(scene, rung, limits, str(path))
            except (ConfigError, PreflightError) as exc:
                if args.rung:
                    raise
                refused[rung] = str(exc)
        ok = [rung for rung in rungs if rung not in refused]
        if not ok:
            raise ConfigError(f"{path}: its case cannot be rendered at any rung (--rung R checks one):\n  "
                              + "\n  ".join(refused.values()))
        print(f"{path}: valid {scene['scene']} scene file; its case renders at rung{'s' * (len(ok) > 1)} "
              f"{', '.join(ok)}")
        for rung, why in refused.items():
            print(f"  not at rung {rung} (render and check-config --rung {rung} refuse it): {why}")
    else:
        overrides = [*([f"rung={args.rung}"] if args.rung else []), *args.overrides, *_limit_overrides(args)]
        cfg = load_campaign(path, overrides, root=Path.cwd())
        scenes = [n for n, s in cfg["scenes"].items() if s.get("enabled", True)]
        print(f"{path}: valid campaign, rung {cfg['rung']}, scenes: {', '.join(scenes) or 'none'}")
    return 0


def _check_out(out: str, record, force: bool) -> Path:
    """Refuse an output directory that would lose a user's files: ``''``, a file, a non-empty
    directory granflow did not render into, or one holding a run of other parameters (unless
    ``--force``); and one that cannot be written. ``record()`` gives the new parameter record
    (computed only when a run is there to compare with)."""
    if not out.strip():
        raise UsageError("--out '' is not allowed: allowed a directory path (it is created if missing)")
    path = Path(out)
    if path.exists() and not path.is_dir():
        raise UsageError(f"--out {out} is a file: allowed a directory (new, empty, or rendered by granflow)")
    if path.is_dir() and any(path.iterdir()) and not force:
        params = path / "params.json"
        try:
            old = json.loads(params.read_text())
            ours = isinstance(old, dict) and {"scene", "rung", "parameters"} <= set(old)
        except (OSError, ValueError):
            old, ours = None, False
        if not ours:
            raise UsageError(f"--out {out} is not empty and was not rendered by granflow (no params.json of a "
                             f"case): allowed a new or empty directory; pass --force to write into it anyway")
        if (path / "run").exists() and json.loads(json.dumps(record(), sort_keys=True)) != old:
            raise UsageError(f"--out {out} holds a run of other parameters (run/ and a different params.json): "
                             f"rendering would make it resume with new decks; allowed another directory, "
                             f"or --force")
    target = path if path.is_dir() else next((q for q in path.parents if q.exists()), Path("."))
    if not os.access(target, os.W_OK | os.X_OK):
        raise UsageError(f"--out {out}: {target} is not writable: allowed a directory you can write to")
    return path


def cmd_render(args) -> int:
    from .deck import STAGES, render_case, scene_parameters

    registry.get(args.scene)  # a refused scene: what it lacks, before its files are read
    scene_file = Path(args.config or PROJECT_ROOT / "config" / "scenes" / f"{args.scene}.yaml")
    scene = load_scene(scene_file, args.overrides)
    if scene["scene"] != args.scene:
        raise UsageError(f"--config {scene_file} describes the {scene['scene']} scene: allowed a {args.scene} "
                         f"scene file (or render {scene['scene']})")
    _check_case(scene, args.rung, _limits(args), str(scene_file))
    _check_out(args.out, lambda: scene_parameters(scene, args.rung)[1]["record"], args.force)
    record = render_case(scene, args.rung, args.out)
    prm = record["parameters"]
    written = {p.stem for p in Path(args.out).glob("*.lmp")}
    stages = ",".join([s for s in STAGES if s in written] + sorted(written - set(STAGES)))
    what = registry.get(scene["scene"]).describe(record)
    print(f"wrote {args.out}/{{{stages}}}.lmp and params.json: {scene['scene']}, rung {args.rung}, "
          f"{what}, dt = {record['dt']:.4g} ({record['dt'] / prm['t_c_min']:.3g} t_c_min), "
          f"contact law {record['contact_law']['law']}")
    return 0


def cmd_scenes(args) -> int:
    """One line per registered scene: name, what it simulates, and its sweep axes; then one line per
    scene package refused at discovery, with what it lacks (the others work as usual)."""
    for name, scene in registry.scenes().items():
        axes = ", ".join(a.key for a in scene.sweep)
        print(f"{name:10s} {scene.summary} [sweep: {axes}]")
    for name, why in registry.refused().items():
        print(f"{name:10s} refused: {why}")
    return 0


def _check_case_dir(case_dir: str) -> Path:
    """A rendered case: a directory with a granflow params.json and its decks, writable."""
    path = Path(case_dir)
    if not path.is_dir():
        raise UsageError(f"case directory {case_dir} does not exist: allowed a directory written by "
                         f"`granflow render` (or a case under results/)")
    params = path / "params.json"
    if not params.is_file():
        raise UsageError(f"{case_dir} is not a rendered case: it has no params.json; write one with "
                         f"`granflow render SCENE --rung RUNG --out {case_dir}`")
    try:
        record = json.loads(params.read_text())
    except ValueError as exc:
        raise UsageError(f"{params} is not valid JSON ({exc}): render the case again") from None
    if not isinstance(record, dict) or not {"scene", "rung", "parameters"} <= set(record):
        raise UsageError(f"{params} is not a granflow parameter record (needs scene, rung, parameters): "
                         f"render the case again")
    if record["scene"] in registry.refused():
        name = record["scene"]
        raise registry.refusal(name, f"{params}: scene = {name!r}: {registry.refused()[name]}")
    if record["scene"] not in registry.names():
        raise UsageError(f"{params}: scene = {record['scene']!r} is not allowed: allowed one of "
                         f"{', '.join(registry.names())}")
    if not (path / "init.lmp").is_file():
        raise UsageError(f"{case_dir} lacks its first deck init.lmp: render the case again")
    if not os.access(path, os.W_OK | os.X_OK) or ((path / "run").exists() and not os.access(path / "run", os.W_OK)):
        raise UsageError(f"{case_dir} is not writable: the run writes its restarts and logs under "
                         f"{case_dir}/run; allowed a directory you can write to")
    return path


def cmd_run(args) -> int:
    from .runner import RunError, StoppedByOS, run_case

    if args.np < 1:
        raise UsageError(f"--np {args.np} is not allowed: allowed 1 <= np")
    path = _check_case_dir(args.case_dir)
    # a user's --np only: the workflow's ranks come from the scene and the machine
    check_ranks(read_record(path), args.np)  # a hand-edited params.json is refused naming its key
    try:
        status = run_case(path, args.np)
    except StoppedByOS as exc:  # disk full and the like: not refused, not a failure of the run's physics
        print(f"granflow: interrupted: {exc}", file=sys.stderr)
        return EXIT_FAILED
    except RunError as exc:
        print(f"granflow run: failed: {exc}\n  logs: {path / 'run' / 'logs'}; a rerun resumes after the last "
              f"complete segment", file=sys.stderr)
        return EXIT_FAILED
    print(json.dumps(status, indent=2))
    return EXIT_OK


def cmd_plan(args) -> int:
    from .resources import format_plan, plan_campaign

    if args.target:   # what accuracy costs, from the committed ladders (granflow.planner)
        from .planner import answer, format_answers

        if args.cores is not None and args.cores < 1:
            raise ConfigError(f"--cores = {args.cores}: allowed a whole number of cores >= 1")
        found = [answer(t, args.cores or os.cpu_count() or 1) for t in args.target]
        print(json.dumps(found, indent=2, default=float) if args.json else format_answers(found))
        return 0
    # the project root is the working directory, as for check-config and snakemake: scene files and a
    # relative results_dir are found from there, wherever the campaign file lies
    root = Path.cwd()
    path = Path(args.config or "config/config.yaml")
    if {"rungs", "scene_file"} <= set(load_yaml(path)):   # a ladder (config/ladders/<scene>.yaml): every rung priced
        from .ladder import ladder_plan, load_ladder

        if args.rung or args.overrides:
            raise ConfigError(f"--config = {str(path)!r} is a ladder: --rung and --set are not allowed with it "
                              f"(each rung says its own; change config/ladders/<scene>.yaml)")
        results = Path(load_yaml(root / "config/config.yaml").get("results_dir", "results"))
        plan = ladder_plan(load_ladder(path), results if results.is_absolute() else root / results, root,
                           max_ranks=args.max_ranks, runtime_limit_min=round(60 * args.runtime_limit_h))
        print(json.dumps(plan, indent=2) if args.json else format_plan(plan))
        return 0
    overrides = ([f"rung={args.rung}"] if args.rung else []) + list(args.overrides) + _limit_overrides(args)
    cfg = load_campaign(path, overrides, root=root)
    results = Path(cfg.get("results_dir", "results"))
    if not results.is_absolute():
        results = root / results
    plan = plan_campaign(cfg, results, max_ranks=args.max_ranks, runtime_limit_min=round(60 * args.runtime_limit_h))
    print(json.dumps(plan, indent=2) if args.json else format_plan(plan))
    return 0


def cmd_campaign(args) -> int:
    """A campaign of one scene: the overlay written and checked by :func:`granflow.one_scene.write_overlay`."""
    done = one_scene.write_overlay(args.only, args.config, args.out, root=Path.cwd(), force=args.force)
    print(f"wrote {args.out}: a campaign of {done.only} alone (rung {done.rung}, {done.cases} "
          f"case{'s' * (done.cases != 1)}), disabled: {', '.join(done.disabled)}\nrun it (a target goes before "
          f"--configfile):\n  {done.command}")
    return EXIT_OK


def cmd_cg(args) -> int:
    argv = getattr(args, "_argv", sys.argv[1:])
    return cg_cli.run(args, command=" ".join(["granflow", *map(shlex.quote, argv)]))


def build_parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(
        prog="granflow",
        description="granflow: YAML cases -> LAMMPS granular simulations -> continuum fields and figures. "
                    "The whole campaign runs with `snakemake --cores 2`; these subcommands check, "
                    "render or run single cases.",
        epilog="Config errors name the key, the value and the allowed range; nothing runs until the "
               "config is valid. Exit codes: 0 done, 2 bad input (nothing ran), 1 failed run.",
    )
    ap.add_argument("--debug", action="store_true", help="show Python tracebacks of errors")
    sub = ap.add_subparsers(dest="command", required=True)

    p = sub.add_parser("check-config", help="validate a campaign or scene YAML file",
                       description="Validate FILE (config/config.yaml or config/scenes/<scene>.yaml) "
                                   "against its JSON schema and cross-field rules; exit 2 with a message "
                                   "naming key, value and allowed range if it is invalid. A campaign: "
                                   "every case, as Snakemake validates it (sizes, and all cases together "
                                   "against --max-cpu-hours). A scene file: its case with the checks "
                                   "`granflow render` runs (size limits, geometry, time step) at --rung, "
                                   "else at every rung (refused if no rung can render it; the rungs that "
                                   "cannot are listed with the reason).")
    p.add_argument("file", help="campaign or scene YAML file")
    p.add_argument("--rung", help="a campaign: its rung (default: the file's); a scene file: the one rung "
                                  "to check, refused as render refuses it (default: every rung)")
    _add_set(p)
    _add_limits(p)
    p.set_defaults(func=cmd_check_config)

    p = sub.add_parser("render", help="write the decks and parameter record of one case",
                       description="Render the LAMMPS decks (init, flow, average) and params.json of "
                                   "one case of SCENE at RUNG into DIR, without running LAMMPS. The time "
                                   "step is checked against the stiffest contact first.")
    # a refused scene is a choice too: render names what it lacks (exit 2)
    p.add_argument("scene", choices=registry.names() + tuple(registry.refused()),
                   help="scene name (see `granflow scenes`)")
    p.add_argument("--rung", required=True, help="fidelity rung: smoke, demo, study, paper or validation")
    p.add_argument("--out", required=True, help="output directory")
    p.add_argument("--config", help="scene YAML (default config/scenes/SCENE.yaml)")
    p.add_argument("--force", action="store_true",
                   help="write into a non-empty directory granflow did not render (files of the same "
                        "names are replaced)")
    _add_set(p)
    _add_limits(p)
    p.set_defaults(func=cmd_render)

    p = sub.add_parser("scenes", help="list the registered scenes, one line each",
                       description="List every scene package under granflow/scenes with what it simulates "
                                   "and the case keys a campaign can sweep; a package refused at discovery "
                                   "is listed with what it lacks.")
    p.set_defaults(func=cmd_scenes)

    p = sub.add_parser("run", help="run or resume a rendered case",
                       description="Run the rendered case in CASE_DIR under mpirun, in segments with "
                                   "restart files; a rerun resumes after the last complete segment.")
    p.add_argument("case_dir")
    p.add_argument("--np", type=int, default=1,
                   help="MPI ranks (default 1; at most one per 100 particles of the case)")
    p.set_defaults(func=cmd_run)

    p = sub.add_parser(
        "plan", help="what the campaign costs before submitting: per case and in total",
        description="For every enabled scene and sweep point of the campaign (validated as the Snakefile\n"
                    "does): the case directory, particles, atom-steps, estimated CPU-hours, MPI ranks, wall\n"
                    "hours, the simulate job's runtime and memory, and whether the case is already done\n"
                    "(run/status.json with a final status); totals per scene and overall; the rates used\n"
                    "(measured from the finished runs in the results directory, else the reference rate).\n"
                    "Nothing is written and LAMMPS is not needed.",
        epilog="examples:\n"
               "  granflow plan --rung study\n"
               "  granflow plan --rung paper --max-ranks 128 --max-cpu-hours 5000 --json > plan.json\n"
               "  granflow plan --set scenes.channel.sweep.W=[60,100] --rung paper --max-cpu-hours 5000\n"
               "  granflow plan --config config/ladders/heap.yaml     (every rung of a ladder)\n"
               "  granflow plan --target 'channel:u_max:1%' --cores 64 [--json]\n\n"
               "Numbers are upper bounds: flow until t_flow_max, every averaging segment.\n"
               "A case, or the campaign's cases together, above --max-cpu-hours (default a week of\n"
               "this machine's cores, 7 x 24 x os.cpu_count()) is refused, as by check-config and snakemake.\n"
               "granflow.resources holds the constants and their sources.",
        formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--config", help="campaign YAML (default config/config.yaml); its scene files and a relative "
                                    "results_dir are found from the working directory, as for check-config")
    p.add_argument("--rung", help="fidelity rung (default: the campaign's), e.g. study or paper")
    p.add_argument("--max-ranks", type=int, default=None, metavar="N",
                   help="most MPI ranks per case (default 64)")
    p.add_argument("--runtime-limit-h", type=float, default=24.0, metavar="H",
                   help="flag simulate jobs longer than this (default 24 h, a common partition limit)")
    p.add_argument("--json", action="store_true", help="print the plan as JSON")
    p.add_argument("--target", action="append", metavar="SCENE:QUANTITY:P%",
                   help="what brings QUANTITY (a unique part of its name) within P %% of the paper, from the "
                        "committed ladders (granflow.planner): a measured rung, an extrapolation, or why neither")
    p.add_argument("--cores", type=int, metavar="N", help="with --target: wall-hours on N cores (default this machine's)")
    _add_set(p)
    _add_limits(p)
    p.set_defaults(func=cmd_plan)

    p = sub.add_parser(
        "new-scene", help="write a new scene's package, scene file, schema and tests from granflow's skeleton",
        description="Write the skeleton of a new scene NAME into the project root DIR (default: the working\n"
                    "directory), every file into a temporary folder first, moved into place when all are written:\n\n"
                    "  src/granflow/scenes/NAME/        __init__.py (SCENE), scene.py (the Scene subclass: name,\n"
                    "                                   summary, sweep, figures, parameters(), analyse(), figure_cases()),\n"
                    "                                   parameters.py (the deck numbers), NAME.lmp.j2 (the deck\n"
                    "                                   template), pipeline.py (the analysis), figures.py, captions.yaml\n"
                    "  config/scenes/NAME.yaml          the scene file, every key commented\n"
                    "  config/schema/NAME.schema.yaml   its schema: type, bounds, default, description of every key\n"
                    "  tests/unit/test_scene_NAME.py    its contract: registered, every rung renders, the smoke\n"
                    "                                   decks set up in LAMMPS (-skiprun); keep it as the scene changes\n"
                    "  tests/unit/test_scene_NAME_skeleton.py  the skeleton's own tests (the bed LAMMPS builds,\n"
                    "                                   the analysis on a known packing): rewrite them as you change it\n\n"
                    "The skeleton is a whole scene that gives what granflow.registry.REQUIRED asks and nothing\n"
                    "optional (like tests/data/minimal_scene): a bed of spheres rained onto a floor and settled,\n"
                    "its packing fraction against the swept friction. It renders, runs and is analysed as it is;\n"
                    "change it into your scene from there.",
        epilog="NAME: a lower-case Python identifier (a-z, 0-9, _; starting with a letter), not a Python\n"
               "keyword, not an existing scene. A bad NAME, or any of the files already there, is refused in\n"
               "one line (exit 2) and nothing is written: an existing file is never overwritten.\n\n"
               "next steps:\n"
               "  granflow check-scene NAME                        the contract, the scene file, the smoke decks\n"
               "  granflow render NAME --rung smoke --out /tmp/NAME\n"
               "  pytest tests/unit/test_scene_NAME.py\n"
               "  docs/adding-a-scene.md                           what each part is, how a scene was added",
        formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("name", metavar="NAME", help="the new scene's name, e.g. drum")
    p.add_argument("--dir", metavar="DIR", help="the project root to write into (default: the working directory)")
    p.set_defaults(func=cmd_new_scene)

    p = sub.add_parser(
        "check-scene", help="what a scene package lacks of the scene contract, one line each",
        description="Check the scene package NAME (src/granflow/scenes/NAME under DIR, default the working\n"
                    "directory) or the package folder PATH against the scene contract, one line each:\n\n"
                    "  lacks    a part of granflow.registry.REQUIRED it does not give (what discovery refuses it for)\n"
                    "  broken   its schema (config/schema/NAME.schema.yaml) or scene file (config/scenes/NAME.yaml)\n"
                    "           fails, or its smoke rung does not render\n"
                    "  note     a part of granflow.registry.OPTIONAL it does not give (the campaign runs without it\n"
                    "           and says what it skipped)\n"
                    "  ok       its smoke rung renders its decks (into a temporary folder: nothing is written);\n"
                    "           when the scene refuses the file's case at smoke (too large, infeasible), that is\n"
                    "           a note and the first rung that renders it is the ok line\n\n"
                    "Exit 0 when every required part is there and the decks render; 2 when something\n"
                    "required is missing or broken. A package that is not this granflow's own (a PATH, or\n"
                    "another DIR) is imported for the check alone, its files read from its project's config/.",
        epilog="examples:\n"
               "  granflow check-scene drum\n"
               "  granflow check-scene ../other-checkout/src/granflow/scenes/drum\n\n"
               "next steps: granflow render NAME --rung smoke --out /tmp/NAME; granflow scenes;\n"
               "docs/adding-a-scene.md (the contract, part by part)",
        formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("target", metavar="NAME|PATH",
                   help="a scene's name, or the path of a scene package folder (with a /, e.g. ./mypkg)")
    p.add_argument("--dir", metavar="DIR", help="the project root whose src/granflow/scenes and config/ hold the "
                                               "scene (default: the working directory; for a PATH, the project "
                                               "it lies in)")
    p.set_defaults(func=cmd_check_scene)

    p = sub.add_parser("campaign", help="write a campaign of one scene: an overlay disabling every other scene",
                       description=one_scene.DESCRIPTION, epilog=one_scene.EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--only", required=True, metavar="SCENE", help="the one scene to run (see `granflow scenes`)")
    p.add_argument("--config", default="config/config.yaml",
                   help="the campaign the overlay goes over (default config/config.yaml, Snakemake's own)")
    p.add_argument("--out", required=True, metavar="FILE", help="the overlay to write (YAML)")
    p.add_argument("--force", action="store_true", help="replace a file granflow campaign did not write")
    p.set_defaults(func=cmd_campaign)

    p = sub.add_parser("cg", help="coarse-grain any LAMMPS dump into continuum fields (CSV, JSON, VTK)",
                       description=cg_cli.DESCRIPTION, epilog=cg_cli.EPILOG,
                       formatter_class=argparse.RawDescriptionHelpFormatter)
    cg_cli.add_arguments(p)
    p.set_defaults(func=cmd_cg)
    return ap


#: OS errors of the machine, not of the input: a full disk or quota, an I/O error, no memory. They end a
#: command with exit 1 and "stopped", never "refused" (exit 2 says the input was wrong)
MACHINE_ERRNOS = frozenset({errno.ENOSPC, errno.EDQUOT, errno.EIO, errno.ENOMEM})


def _machine_error_text(exc: OSError) -> str:
    """One line: what stopped the command and where (an :class:`OutputWriteError` says that the earlier
    files are kept)."""
    if isinstance(exc, OutputWriteError):
        return str(exc)
    where = f" ({exc.filename})" if getattr(exc, "filename", None) else ""
    return f"{exc.strerror or exc} ({errno.errorcode.get(exc.errno, exc.errno)}){where}"


def main(argv: list[str] | None = None) -> int:
    """Run one subcommand. Exit codes: 0 done, 2 bad input (refused before anything ran, no
    traceback), 1 a run or step that failed; ``--debug`` shows the traceback of any error."""
    argv = sys.argv[1:] if argv is None else list(argv)
    args = build_parser().parse_args(argv)
    args._argv = argv
    try:
        return args.func(args)
    except (ConfigError, PreflightError) as exc:
        if args.debug:
            traceback.print_exc()
        print(f"granflow: refused: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except KeyboardInterrupt:
        print("granflow: interrupted; a rerun resumes after the last complete segment", file=sys.stderr)
        return 130
    except OSError as exc:
        if args.debug:
            traceback.print_exc()
        if exc.errno in MACHINE_ERRNOS:  # the machine stopped it (a full disk, ...), not the user's input
            print(f"granflow: stopped: {_machine_error_text(exc)}; free the space (or the device) and rerun",
                  file=sys.stderr)
            return EXIT_FAILED
        where = f" ({exc.filename})" if getattr(exc, "filename", None) else ""
        print(f"granflow: refused: {exc.strerror or exc}{where}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except Exception as exc:  # a bug, not the user's mistake: say so, traceback only with --debug
        if args.debug:
            raise
        print(f"granflow: failed: {type(exc).__name__}: {exc}\n  (this is granflow's fault, not your input; "
              f"rerun with --debug for the traceback and report it)", file=sys.stderr)
        return EXIT_FAILED


if __name__ == "__main__":
    sys.exit(main())
