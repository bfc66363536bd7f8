"""A ladder toward a paper from the command line, over :mod:`granflow.ladder` (the workflow runs it:
``snakemake ladder_<scene>`` runs every rung and writes the record).

  python tools/ladder.py prepare config/ladders/silo.yaml [--results results]   # price each rung, the command
  python tools/ladder.py record  config/ladders/silo.yaml --results results     # the record from analysed rungs
  python tools/ladder.py record  config/ladders/silo.yaml --results results --keep-committed   # add a rung
  python tools/ladder.py order   config/ladders/silo.yaml        # from_paper into the committed record

``prepare`` prices every rung (``granflow plan --config config/ladders/<scene>.yaml`` prints the same per case)
and prints the Snakemake target that runs them; a rung the scene refuses is said in one line. ``record`` writes
``validation/<scene>/ladder.csv``, ``ladder.md`` and ``figures/ladder.png`` from the rungs analysed under
``--results`` (the rule ``ladder_record`` does the same); with ``--keep-committed`` a rung whose runs are not at
hand keeps its rows of the committed ``ladder.csv`` (state "kept"), so one new rung joins a committed ladder
without running the others again. ``order`` carries the ladder file's ``from_paper`` into
the committed ``ladder.csv`` and ``ladder.md`` without the runs.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "src"))

import pandas as pd  # noqa: E402

from granflow.config import ConfigError  # noqa: E402
from granflow.ladder import (committed_checks, figure, load_ladder, markdown, order_line, plan, rejudge,  # noqa: E402,F401
                             record, rung_campaign, rung_checks, scatter_lines, series_lines, table, with_from_paper)


def cmd_prepare(args) -> int:
    ladder = load_ladder(args.ladder)
    refused = 0
    for rung in ladder["rungs"] + ladder.get("planned", []):
        planned = rung in ladder.get("planned", [])
        try:
            p = plan(ladder, rung, args.results, priced_only=planned)
        except ConfigError as e:   # a rung the scene refuses: said in one line, the other rungs go on
            print(f"# {rung['name']}: {rung['knob']} [refused]: {e}")
            refused += 1
            continue
        tot = p["total"]
        kind = "planned (not run)" if planned else "to run"
        print(f"# {rung['name']}: {rung['knob']} [{kind}]: {tot.get('cpu_hours', float('nan')):.2f} CPU-h upper bound, "
              f"{sum(1 for r in p['rows'] if r.get('state') == 'done')}/{len(p['rows'])} cases done")
    if not refused:
        print(f"snakemake ladder_{ladder['scene']} --cores 1 --set-threads simulate=1   "
              f"# every rung to run, then the record (resumes from its restarts)")
    return 2 if refused else 0


def cmd_record(args) -> int:
    ladder = load_ladder(args.ladder)
    print(record(ladder, args.results, ROOT / "validation" / ladder["scene"] if args.out is None else Path(args.out),
                 keep_committed=args.keep_committed))
    return 0


def cmd_order(args) -> int:
    """Carry the ladder file's ``from_paper`` into the committed record without the runs: the ``from_paper``
    column of ``ladder.csv`` and the order line of ``ladder.md`` (the rest of both as recorded)."""
    ladder = load_ladder(args.ladder)
    out = ROOT / "validation" / ladder["scene"] if args.out is None else Path(args.out)
    df = with_from_paper(pd.read_csv(out / "ladder.csv"), ladder)
    df.to_csv(out / "ladder.csv", index=False, float_format="%.9g")
    text = (out / "ladder.md").read_text()
    head, sep, rest = text.partition("| rung | knob |")
    paragraphs = [p for p in head.split("\n\n") if p and not p.startswith("Order from the paper's setup")]
    (out / "ladder.md").write_text("\n\n".join(paragraphs) + "\n\n" + order_line(ladder) + sep + rest)
    print(order_line(ladder), end="")
    return 0


def cmd_rejudge(args) -> int:
    """The committed ladder judged by today's rules without the runs: each row's verdict (kinds, 'not resolved',
    one run never 'differs') in ``ladder.csv``, and ``ladder.md`` written again from it."""
    ladder = load_ladder(args.ladder)
    out = ROOT / "validation" / ladder["scene"] if args.out is None else Path(args.out)
    df = rejudge(pd.read_csv(out / "ladder.csv"), ladder)
    df.to_csv(out / "ladder.csv", index=False, float_format="%.9g")
    (out / "ladder.md").write_text(markdown(df, ladder))
    print(markdown(df, ladder), end="")
    return 0


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], formatter_class=argparse.RawDescriptionHelpFormatter,
                                     epilog=__doc__.split("\n\n", 1)[1])
    sub = parser.add_subparsers(dest="command", required=True)
    for name, func, helptext in (("prepare", cmd_prepare, "price every rung, print the target that runs them"),
                                 ("record", cmd_record, "the ladder's table and figure from the analysed rungs"),
                                 ("order", cmd_order, "the rungs' from_paper into the committed ladder.csv and .md"),
                                 ("rejudge", cmd_rejudge, "the committed ladder's verdicts by today's rules, no runs")):
        p = sub.add_parser(name, help=helptext)
        p.add_argument("ladder", type=Path, help="ladder file, e.g. config/ladders/silo.yaml")
        if name not in ("order", "rejudge"):
            p.add_argument("--results", type=Path, default=Path("results"), required=name == "record",
                           help="the results directory the rungs run in (their cases under ladders/<scene>/<rung>/)")
        if name == "record":
            p.add_argument("--keep-committed", action="store_true",
                           help="a rung whose runs are not at hand keeps its rows of the committed ladder.csv")
        if name != "prepare":
            p.add_argument("--out", default=None, help="folder of the record (default validation/<scene>)")
        p.set_defaults(func=func)
    args = parser.parse_args(argv)
    try:
        return args.func(args)
    except ConfigError as exc:
        print(f"ladder: refused: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
