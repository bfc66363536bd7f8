"""A ladder toward a paper: one knob at a time from the validation case, error against the paper vs CPU-hours.

  python tools/ladder.py prepare config/ladders/silo.yaml --results /work/keep/ladders
  python tools/ladder.py record  config/ladders/silo.yaml --results /work/keep/ladders
  python tools/ladder.py order   config/ladders/silo.yaml        # from_paper into the committed record

A ladder file (``config/ladders/<scene>.yaml``) names a scene, its rung, a sweep and a list of
rungs, each a set of scene-file changes (``set:``, dotted keys as ``--set``) or of sweep values
(``sweep:``, replacing the ladder's for that key) with the knob it turns in words; ``planned:`` rungs are only priced.
A rung with ``replicate: true`` runs the first rung's cases again with another random seed and nothing else:
the record reads it as the first rung's second sample (:func:`scatter_lines`), the run-to-run scatter each
other rung's shift is set beside. A ``series:`` entry names rungs that turn one knob by steps and reads the
straight line through them at chosen points, such as the paper's size (:func:`series_lines`). Every rung, planned or
run, declares ``from_paper``: its order from the paper's setup (0 is the paper's; a larger number is farther; equal
numbers are as far; ``from_paper_order`` says in words how the ladder orders them), which ``ladder.csv`` carries for
the report's front page to show the measured rung nearest the paper's setup, whatever its number; a replicate
has its first rung's order (a reseed is no step). ``prepare`` writes, per rung, the changed
scene file (validated by the scene's schema and pre-run checks exactly as a campaign's) and a
one-scene campaign under ``<results>/<scene>/<rung>/``, prices it with the cost model
(``granflow plan``) and prints the Snakemake command that runs it (every run resumes from its
restarts, so a rung may take several sittings). ``record`` runs the scene's own validation
(:meth:`granflow.registry.Scene.validation`, as ``make validate``) on each rung's analysed
cases, keeps the ladder's headline checks and writes ``validation/<scene>/ladder.csv``,
``ladder.md`` and ``figures/ladder.png``: |difference from the paper| (relative, with the
combined stat ⊕ syst error) against the rung's measured CPU-hours, the planned rungs at their
priced CPU-hours. ``order`` carries the ladder file's ``from_paper`` into the committed ``ladder.csv`` and
``ladder.md`` without the runs. Nothing here tunes anything: each rung is what the physics gives.
"""
from __future__ import annotations

import argparse
import shlex
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "src"))

import pandas as pd  # noqa: E402

from granflow.ladder import (committed_checks, figure, load_ladder, markdown, order_line, plan,  # noqa: E402,F401
                             rung_checks, scatter_lines, series_lines, table, targets, with_from_paper, write_rung)
from granflow.yamlio import ConfigError  # noqa: E402


def cmd_prepare(args) -> int:
    ladder = load_ladder(args.ladder)
    refused = 0
    for rung in ladder["rungs"] + ladder.get("planned", []):
        try:
            _, campaign = write_rung(ladder, rung, args.results)
            p = plan(campaign, priced_only=rung in ladder.get("planned", []))
        except ConfigError as e:   # a rung the scene refuses: said in one line, the other rungs go on
            print(f"# {rung['name']}: {rung['knob']} [refused]: {e}")
            refused += 1
            continue
        tot = p["total"]
        kind = "planned (not run)" if rung in ladder.get("planned", []) else "to run"
        print(f"# {rung['name']}: {rung['knob']} [{kind}]: {tot.get('cpu_hours', float('nan')):.2f} CPU-h upper bound, "
              f"{sum(1 for r in p['rows'] if r.get('state') == 'done')}/{len(p['rows'])} cases done")
        if rung not in ladder.get("planned", []):
            print("snakemake " + " ".join(shlex.quote(t) for t in targets(p))
                  + f" --configfile {shlex.quote(str(campaign))} --cores 1 --set-threads simulate=1")
    return 2 if refused else 0


def cmd_record(args) -> int:
    ladder = load_ladder(args.ladder)
    df = table(ladder, args.results)
    out = ROOT / "validation" / ladder["scene"] if args.out is None else Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    df.to_csv(out / "ladder.csv", index=False, float_format="%.6g")
    (out / "ladder.md").write_text(markdown(df, ladder))
    figure(df, ladder, out / "figures" / "ladder.png")
    print(markdown(df, ladder))
    return 0


def cmd_order(args) -> int:
    """Carry the ladder file's ``from_paper`` into the committed record without the runs: the ``from_paper``
    column of ``ladder.csv`` and the order line of ``ladder.md`` (the rest of both as recorded)."""
    ladder = load_ladder(args.ladder)
    out = ROOT / "validation" / ladder["scene"] if args.out is None else Path(args.out)
    df = with_from_paper(pd.read_csv(out / "ladder.csv"), ladder)
    df.to_csv(out / "ladder.csv", index=False, float_format="%.6g")
    text = (out / "ladder.md").read_text()
    head, sep, rest = text.partition("| rung | knob |")
    paragraphs = [p for p in head.split("\n\n") if p and not p.startswith("Order from the paper's setup")]
    (out / "ladder.md").write_text("\n\n".join(paragraphs) + "\n\n" + order_line(ladder) + sep + rest)
    print(order_line(ladder), end="")
    return 0


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], formatter_class=argparse.RawDescriptionHelpFormatter,
                                     epilog=__doc__.split("\n\n", 1)[1])
    sub = parser.add_subparsers(dest="command", required=True)
    for name, func, helptext in (("prepare", cmd_prepare, "write the rungs' scene files and campaigns, price them"),
                                 ("record", cmd_record, "the ladder's table and figure from the analysed rungs"),
                                 ("order", cmd_order, "the rungs' from_paper into the committed ladder.csv and .md")):
        p = sub.add_parser(name, help=helptext)
        p.add_argument("ladder", type=Path, help="ladder file, e.g. config/ladders/silo.yaml")
        if name != "order":
            p.add_argument("--results", type=Path, required=True, help="where the rungs' runs live")
        if name != "prepare":
            p.add_argument("--out", default=None, help="folder of the record (default validation/<scene>)")
        p.set_defaults(func=func)
    args = parser.parse_args(argv)
    return args.func(args)


if __name__ == "__main__":
    sys.exit(main())
