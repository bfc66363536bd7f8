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

Coarse-grain any LAMMPS dump (see ``granflow cg --help``)::

    granflow cg dump.bin --coords rz --axis 0.05,0.05 --width 0.002 --spacing 0.002 --out cg
"""
from __future__ import annotations

import argparse
import json
import shlex
import sys
from pathlib import Path

from postproc import cg_cli

from . import registry
from .campaign import load_campaign
from .config import PROJECT_ROOT, ConfigError, load_scene, load_yaml
from .preflight import PreflightError


def _add_set(p: argparse.ArgumentParser) -> None:
    p.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                   help="override a value by its dotted path (repeatable), validated exactly like the "
                        "file; VALUE is read as YAML, e.g. --set case.phi_mean=0.61 or "
                        "--set scenes.channel.sweep.W=[20,30]")


def cmd_check_config(args) -> int:
    path = Path(args.file)
    data = load_yaml(path)
    if "scene" in data:
        load_scene(path, args.overrides)
        print(f"{path}: valid {data['scene']} scene file")
    else:
        cfg = load_campaign(path, args.overrides, root=Path.cwd())
        scenes = [n for n, s in cfg["scenes"].items() if s.get("enabled", True)]
        print(f"{path}: valid campaign, rung {cfg['rung']}, scenes: {', '.join(scenes) or 'none'}")
    return 0


def cmd_render(args) -> int:
    from .deck import STAGES, render_case

    scene_file = Path(args.config or PROJECT_ROOT / "config" / "scenes" / f"{args.scene}.yaml")
    scene = load_scene(scene_file, args.overrides)
    record = render_case(scene, args.rung, args.out)
    prm = record["parameters"]
    written = {p.stem for p in Path(args.out).glob("*.lmp")}
    stages = ",".join([s for s in STAGES if s in written] + sorted(written - set(STAGES)))
    what = registry.get(scene["scene"]).describe(record)
    print(f"wrote {args.out}/{{{stages}}}.lmp and params.json: {scene['scene']}, rung {args.rung}, "
          f"{what}, dt = {record['dt']:.4g} ({record['dt'] / prm['t_c_min']:.3g} t_c_min)")
    return 0


def cmd_scenes(args) -> int:
    """One line per registered scene: name, what it simulates, and its sweep axes."""
    for name, scene in registry.scenes().items():
        axes = ", ".join(a.key for a in scene.sweep)
        print(f"{name:10s} {scene.summary} [sweep: {axes}]")
    return 0


def cmd_run(args) -> int:
    from .runner import run_case

    status = run_case(args.case_dir, args.np)
    print(json.dumps(status, indent=2))
    return 0


def cmd_plan(args) -> int:
    from .resources import format_plan, plan_campaign

    path = Path(args.config or PROJECT_ROOT / "config" / "config.yaml")
    root = path.resolve().parent.parent
    overrides = ([f"rung={args.rung}"] if args.rung else []) + list(args.overrides)
    cfg = load_campaign(path, overrides, root=root)
    results = Path(cfg.get("results_dir", "results"))
    if not results.is_absolute():
        results = root / results
    plan = plan_campaign(cfg, results, max_ranks=args.max_ranks, runtime_limit_min=round(60 * args.runtime_limit_h))
    print(json.dumps(plan, indent=2) if args.json else format_plan(plan))
    return 0


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
               "config is valid.",
    )
    sub = ap.add_subparsers(dest="command", required=True)

    p = sub.add_parser("check-config", help="validate a campaign or scene YAML file",
                       description="Validate FILE (config/config.yaml or config/scenes/<scene>.yaml) "
                                   "against its JSON schema and cross-field rules; exit 1 with a message "
                                   "naming key, value and allowed range if it is invalid.")
    p.add_argument("file", help="campaign or scene YAML file")
    _add_set(p)
    p.set_defaults(func=cmd_check_config)

    p = sub.add_parser("render", help="write the decks and parameter record of one case",
                       description="Render the LAMMPS decks (init, flow, average) and params.json of "
                                   "one case of SCENE at RUNG into DIR, without running LAMMPS. The time "
                                   "step is checked against the stiffest contact first.")
    p.add_argument("scene", choices=registry.names(), help="scene name (see `granflow scenes`)")
    p.add_argument("--rung", required=True, help="fidelity rung: smoke, demo, study or paper")
    p.add_argument("--out", required=True, help="output directory")
    p.add_argument("--config", help="scene YAML (default config/scenes/SCENE.yaml)")
    _add_set(p)
    p.set_defaults(func=cmd_render)

    p = sub.add_parser("scenes", help="list the registered scenes, one line each",
                       description="List every scene package under granflow/scenes with what it simulates "
                                   "and the case keys a campaign can sweep.")
    p.set_defaults(func=cmd_scenes)

    p = sub.add_parser("run", help="run or resume a rendered case",
                       description="Run the rendered case in CASE_DIR under mpirun, in segments with "
                                   "restart files; a rerun resumes after the last complete segment.")
    p.add_argument("case_dir")
    p.add_argument("--np", type=int, default=1, help="MPI ranks (default 1)")
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
               "  granflow plan --rung paper --max-ranks 128 --json > plan.json\n"
               "  granflow plan --set scenes.channel.sweep.W=[60,100] --rung paper\n\n"
               "Numbers are upper bounds: flow until t_flow_max, every averaging segment.\n"
               "granflow.resources holds the constants and their sources.",
        formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--config", help="campaign YAML (default config/config.yaml)")
    p.add_argument("--rung", help="fidelity rung (default: the campaign's), e.g. study or paper")
    p.add_argument("--max-ranks", type=int, default=None, metavar="N",
                   help="most MPI ranks per case (default 64)")
    p.add_argument("--runtime-limit-h", type=float, default=24.0, metavar="H",
                   help="flag simulate jobs longer than this (default 24 h, a common partition limit)")
    p.add_argument("--json", action="store_true", help="print the plan as JSON")
    _add_set(p)
    p.set_defaults(func=cmd_plan)

    p = sub.add_parser("cg", help="coarse-grain any LAMMPS dump into continuum fields (CSV, JSON, VTK)",
                       description=cg_cli.DESCRIPTION, epilog=cg_cli.EPILOG,
                       formatter_class=argparse.RawDescriptionHelpFormatter)
    cg_cli.add_arguments(p)
    p.set_defaults(func=cmd_cg)
    return ap


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    args = build_parser().parse_args(argv)
    args._argv = argv
    try:
        return args.func(args)
    except (ConfigError, PreflightError) as exc:
        print(f"granflow: refused: {exc}", file=sys.stderr)
        return 1


if __name__ == "__main__":
    sys.exit(main())
