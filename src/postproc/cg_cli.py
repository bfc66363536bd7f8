"""The ``granflow cg`` command: coarse-grain LAMMPS dumps into continuum fields.

Also runnable without granflow's CLI as ``python -m postproc.cg_cli``. The work
is done by :class:`postproc.cg.CoarseGraining`; this module parses and reports.
"""
from __future__ import annotations

import argparse
import os
import shlex
import sys
import textwrap
from pathlib import Path

from .cg import (COORDINATES, DEFAULT_BLOCKS, DEFAULT_MAX_NODES, GAUSSIAN_CUTOFF, KERNELS, OUTPUT_NAMES,
                 CGInputError, CGOptions, CoarseGraining, check_outputs, describe_dropped, parse_numbers, parse_ranges,
                 write_result)
from .cg_frames import input_paths
from .safe_write import OutputWriteError

#: Exit statuses of ``granflow cg``: done; the outputs could not be written (a full disk, a lost
#: permission: the earlier outputs stay as they were); an input or a choice refused (nothing written).
EXIT_OK, EXIT_NOT_WRITTEN, EXIT_REFUSED = 0, 1, 2

DESCRIPTION = """\
Coarse-grain LAMMPS `dump custom` files (text, gzipped text or binary, told
apart by their content; columns in any order) into time-averaged continuum
fields on a regular grid: volume fraction, mass density, velocity, kinetic
stress, and with `dump local` contacts the contact stress, each with its
standard error over blocks of frames. Writes DIR/fields.csv (one row per
node), DIR/meta.json (inputs with SHA-256, frames, choices, units, warnings)
and DIR/fields.vtr (open it in ParaView)."""

EPILOG = f"""\
The dump needs x y z (or xu yu zu, xs ys zs), vx vy vz, radius or diameter,
and mass (or --density); id for --contacts, type for --species. A value
that starts with a minus sign needs '=': --range=-20:50, --axis=-3,4.
An atom with a mass, radius or diameter <= 0 is refused, and so is one with
a NaN or infinite position, velocity, spin, mass or radius unless
--drop-nonfinite leaves it out (counted in the output and meta.json); the
refusal names the file, the step, the atom id and the column. So is a box
bound that is not finite or a low bound not below its high one; a timestep
not after the previous frame's (a dump given twice, dumps out of time order,
a restarted run's overlap) unless --drop-repeated-steps leaves such frames out
(counted); a contact with a NaN or infinite id, force or branch value, or a
branch longer than the box; an input that is not a non-empty regular file; a
line over 1 MiB; a gzip stream expanding more than 200 times.

The outputs never replace an input and never go through a symbolic link;
they are written under temporary names and moved into place together when
complete, so --overwrite keeps the earlier ones until then. Exit status: 0
done, 2 refused (nothing written), 1 the outputs could not be written (e.g. a
full disk; one line names the file, the earlier outputs stay as they were).

coordinates: x y z xy xz yz xyz resolve those axes and integrate over the rest
  of the box; r is the distance from the vertical axis --axis X0,Y0 (default
  the box centre), rz adds the height. Components are x y z, or r t z.
kernels: gaussian (--width = standard deviation, cut at --cutoff, default
  {GAUSSIAN_CUTOFF:g} widths), lucy (--width = its range), heaviside (bins of
  the grid spacing; --exact-volume splits each sphere exactly over slabs).

example: a hopper with its axis at x = y = 0.05 m, steps 100000 to 200000:
  granflow cg dump.hopper.bin --coords rz --axis 0.05,0.05 \\
      --kernel gaussian --width 0.002 --spacing 0.002 \\
      --contacts dump.contacts --frames 100000:200000 --out cg_hopper
"""


def build_parser(prog: str = "granflow cg", add_help: bool = True) -> argparse.ArgumentParser:
    """The argument parser of ``granflow cg`` (:func:`add_arguments`, with the description and the epilog).

    Parameters
    ----------
    prog : str
        The program name its usage line shows.
    add_help : bool
        Whether it has ``-h``/``--help``.

    Returns
    -------
    argparse.ArgumentParser
    """
    ap = argparse.ArgumentParser(prog=prog, description=DESCRIPTION, epilog=EPILOG, add_help=add_help,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    add_arguments(ap)
    return ap


def add_arguments(ap: argparse.ArgumentParser) -> None:
    """Add the arguments of ``granflow cg`` to ``ap`` (granflow's CLI adds them to its ``cg`` subcommand).

    Lengths (``--width``, ``--cutoff``, ``--spacing``, ``--range``, ``--axis``) are
    in the dump's length unit, ``--density`` in its mass per volume; ``--frames``
    takes timesteps.

    Parameters
    ----------
    ap : argparse.ArgumentParser
    """
    ap.add_argument("dumps", nargs="+", metavar="DUMP", help="dump custom files, in time order")
    ap.add_argument("--coords", required=True, choices=COORDINATES, help="coordinates resolved")
    ap.add_argument("--axis", metavar="X0,Y0", help="vertical axis of r and rz (default: box centre)")
    ap.add_argument("--kernel", default="gaussian", choices=KERNELS, help="coarse-graining function (default gaussian)")
    ap.add_argument("--width", type=float, metavar="W", help="kernel width, dump length units (gaussian, lucy)")
    ap.add_argument("--cutoff", type=float, metavar="C",
                    help=f"gaussian truncation radius (default {GAUSSIAN_CUTOFF:g} x width)")
    ap.add_argument("--spacing", required=True, metavar="H[,H2,...]",
                    help="node spacing: one for all coordinates or one per coordinate")
    ap.add_argument("--range", dest="ranges", metavar="LO:HI[,LO:HI,...]",
                    help="grid range per coordinate (default: the box; r from 0 to the nearest side wall)")
    ap.add_argument("--contacts", nargs="+", default=[], metavar="LOCAL_DUMP",
                    help="dump local files of compute pair/local + property/local (same steps as the atoms)")
    ap.add_argument("--contact-columns", metavar="ROLE=COLUMN,...",
                    help="contact column roles when the header does not name them, e.g. "
                         "id1=c_ids[1],id2=c_ids[2],dx=c_pl[1],dy=c_pl[2],dz=c_pl[3],fx=c_pl[4],fy=c_pl[5],fz=c_pl[6]")
    ap.add_argument("--species", nargs="?", const="auto", metavar="T1,T2,...",
                    help="per-type partial fields (types of the first frame, or the ids given)")
    ap.add_argument("--frames", metavar="START:STOP[:EVERY]", help="timesteps to use, STOP included (default all)")
    ap.add_argument("--density", type=float, metavar="RHO", help="particle density, when the dump has no mass")
    ap.add_argument("--exact-volume", action="store_true",
                    help="heaviside along one axis: volume fraction from each sphere's exact split over the bins")
    ap.add_argument("--blocks", type=int, default=DEFAULT_BLOCKS, metavar="N",
                    help=f"blocks of frames for standard errors (default {DEFAULT_BLOCKS})")
    ap.add_argument("--max-nodes", type=int, default=DEFAULT_MAX_NODES, metavar="N",
                    help=f"refuse grids with more nodes (default {DEFAULT_MAX_NODES})")
    ap.add_argument("--allow-truncated", action="store_true",
                    help="on a truncated dump keep the fields of the complete frames")
    ap.add_argument("--drop-nonfinite", action="store_true",
                    help="leave out atoms with a NaN or infinite position, velocity, spin, mass or radius "
                         "(counted in the output and meta.json) instead of refusing the dump")
    ap.add_argument("--drop-repeated-steps", action="store_true",
                    help="leave out frames whose timestep is not after the previous frame's (repeated or going "
                         "back; the first read is kept), counted in the output and meta.json, instead of refusing")
    ap.add_argument("--overwrite", action="store_true",
                    help="replace the outputs already in DIR (kept until the new ones are complete)")
    ap.add_argument("--quiet", action="store_true", help="no progress line")
    ap.add_argument("--out", required=True, metavar="DIR", help="output directory")


def _roles(text: str | None) -> dict[str, str] | None:
    if not text:
        return None
    roles = {}
    for part in text.split(","):
        role, sep, column = part.partition("=")
        if not sep or not role.strip() or not column.strip():
            raise CGInputError(f"--contact-columns {text!r}: {part!r} is not ROLE=COLUMN")
        roles[role.strip()] = column.strip()
    return roles


def _species(text: str | None):
    if text is None or text == "auto":
        return text
    try:
        ids = [int(t) for t in text.split(",")]
    except ValueError:
        raise CGInputError(f"--species {text!r} is not a comma-separated list of type ids") from None
    return ids


def run(args: argparse.Namespace, command: str | None = None) -> int:
    """Run a parsed ``granflow cg``; 0 on success, 2 when the input is refused.

    ``command`` (the command line) is recorded in ``meta.json``.

    Parameters
    ----------
    args : argparse.Namespace
        Parsed by a parser with :func:`add_arguments`.
    command : str, optional
        The command line, recorded as ``meta["command"]``.

    Returns
    -------
    int
        :data:`EXIT_OK`; :data:`EXIT_REFUSED` for a refusal
        (:class:`~postproc.cg_output.CGInputError`, printed to stderr as
        ``granflow: refused: ...``, nothing written); :data:`EXIT_NOT_WRITTEN`
        when an output cannot be written (one line, ``granflow: could not write
        PATH: ...``; the earlier outputs stay as they were).
    """
    out = Path(args.out)
    try:
        check_outputs(out, [*args.dumps, *args.contacts])
        held = [name for name in OUTPUT_NAMES if os.path.lexists(out / name)]
        if held and not args.overwrite:
            raise CGInputError(f"--out {out} already holds {held[0]} from an earlier run; choose another "
                               f"--out or pass --overwrite")
        axis = None
        if args.axis is not None:
            axis = parse_numbers(args.axis, "--axis")
            if len(axis) != 2:
                raise CGInputError(f"--axis {args.axis!r} needs two numbers X0,Y0")
        spacing, ranges = parse_numbers(args.spacing, "--spacing"), parse_ranges(args.ranges)
        roles, species = _roles(args.contact_columns), _species(args.species)
        dumps, contacts = input_paths(args.dumps, args.contacts)  # a missing file before the choices
        options = CGOptions(
            coords=args.coords, spacing=spacing, axis=axis, kernel=args.kernel, width=args.width,
            cutoff=args.cutoff, ranges=ranges, contact_roles=roles, species=species,
            frames=args.frames, density=args.density, volume="exact" if args.exact_volume else "centre",
            n_blocks=args.blocks, max_nodes=args.max_nodes, allow_truncated=args.allow_truncated,
            drop_nonfinite=args.drop_nonfinite, drop_repeated_steps=args.drop_repeated_steps,
        )
        result = CoarseGraining(options).compute(dumps, contacts, progress=None if args.quiet else sys.stderr)
    except CGInputError as exc:
        print(f"granflow: refused: {exc}", file=sys.stderr)
        return EXIT_REFUSED
    result.meta["command"] = command
    try:
        paths = write_result(result, out)
    except CGInputError as exc:  # an output changed into a link or an input since the check
        print(f"granflow: refused: {exc}", file=sys.stderr)
        return EXIT_REFUSED
    except OutputWriteError as exc:
        print(f"granflow: {exc}", file=sys.stderr)
        return EXIT_NOT_WRITTEN
    meta = result.meta
    frames = meta["frames"]
    print(f"granflow cg: {frames['count']} frames (steps {frames['first_step']}..{frames['last_step']}), "
          f"{frames['particle_frames']} particle-frames, {result.grid.describe()}")
    print(f"  kernel {meta['kernel']['name']}"
          + (f" width {meta['kernel']['width']:g}" if meta['kernel']['width'] else "")
          + f"; {meta['elapsed_s']:.1f} s, {meta['particle_frames_per_s'] / 1e6:.2f} M particle-frames/s")
    if frames["dropped_nonfinite"] is not None:
        print(f"  --drop-nonfinite: left out {describe_dropped(frames['dropped_nonfinite'], frames['count'])}")
    if frames["dropped_repeated_steps"] is not None:
        print(f"  --drop-repeated-steps: left out {describe_repeated(frames['dropped_repeated_steps'])}")
    for w in result.warnings:
        print(textwrap.fill(f"warning: {w}", width=100, subsequent_indent="  "), file=sys.stderr)
    print("  wrote " + ", ".join(str(p) for p in paths.values()))
    return 0


def describe_repeated(dropped: dict) -> str:
    """``meta["frames"]["dropped_repeated_steps"]`` in words.

    Parameters
    ----------
    dropped : dict
        ``atom_frames`` and ``contact_frames``, each ``{"frames": n, "first": {"path", "step", "after_step"}}``.

    Returns
    -------
    str
    """
    parts = []
    for key, noun in (("atom_frames", "atom frame"), ("contact_frames", "contact frame")):
        n, first = dropped[key]["frames"], dropped[key]["first"]
        if n:
            parts.append(f"{n} {noun}{'s' if n != 1 else ''} (the first at step {first['step']} of {first['path']}, "
                         f"after step {first['after_step']})")
    return " and ".join(parts) or "no frame (every step was after the one before)"


def main(argv: list[str] | None = None) -> int:
    """``python -m postproc.cg_cli``: parse ``argv`` and :func:`run` it.

    Parameters
    ----------
    argv : list of str, optional
        The arguments; default ``sys.argv[1:]``.

    Returns
    -------
    int
        The exit status of :func:`run` (argparse exits with 2 on bad usage).
    """
    argv = sys.argv[1:] if argv is None else list(argv)
    prog = "python -m postproc.cg_cli"
    return run(build_parser(prog=prog).parse_args(argv), command=" ".join([prog, *map(shlex.quote, argv)]))


if __name__ == "__main__":
    sys.exit(main())
