"""The variants of bench/bench_decks.py: text edits of a rendered deck and how each variant is launched.

Every edit is a pure function of the deck text (bench/bench_decks.py says what each variant is);
bench_decks.py imports these names and runs the variants.
"""
from __future__ import annotations

import re
from dataclasses import dataclass

#: a printed line that separates the warm-up from the timed run in the log
MARKER = "GRANFLOW_BENCH_TIMED_RUN"
#: the balance settings of the variants that add one: LAMMPS doc's usual threshold and iterations
SHIFT_ARGS = "shift xyz 20 1.02"
THRESHOLD = "1.05"


class DeckFormatError(ValueError):
    """The rendered deck lacks a line a variant edits: the deck format changed."""


# ------------------------------------------------------------------ text edits
# Every edit is a pure function of the deck text; lines are matched on their
# first words, so comments (# ...) are never taken for commands.

def _command(line: str) -> list[str]:
    """The words of a deck line without its comment."""
    return line.split("#", 1)[0].split()


def _indices(lines: list[str], *head: str) -> list[int]:
    """Indices of the lines whose first words are ``head`` (``"fix"``, ``"*"``, ``"balance"`` matches
    ``fix ID group balance``: ``*`` stands for any word)."""
    out = []
    for i, line in enumerate(lines):
        words = _command(line)
        if len(words) >= len(head) and all(h in ("*", w) for h, w in zip(head, words)):
            out.append(i)
    return out


def _one(lines: list[str], what: str, *head: str) -> int:
    """Index of the first line starting with ``head``; :class:`DeckFormatError` if there is none."""
    found = _indices(lines, *head)
    if not found:
        raise DeckFormatError(f"no {what} line ('{' '.join(head)} ...') in the deck: the deck format changed, "
                              f"update bench/bench_decks.py")
    return found[0]


def _line(words: list[str]) -> str:
    """A deck line in the decks' layout: the command padded to 16 columns."""
    return f"{words[0]:<15} {' '.join(words[1:])}\n"


def _balance_lines(lines: list[str]) -> list[int]:
    return sorted(_indices(lines, "balance") + _indices(lines, "fix", "*", "*", "balance"))


def strip_output(text: str) -> str:
    """The deck without dumps and restart files (``dump``, ``dump_modify``, ``undump``,
    ``restart``, ``write_restart``, ``write_data``, ``write_dump``)."""
    drop = {"dump", "dump_modify", "undump", "restart", "write_restart", "write_data", "write_dump"}
    kept, dropping = [], False
    for line in text.splitlines(keepends=True):
        if not dropping:
            dropping = (_command(line) or [""])[0] in drop
        if not dropping:
            kept.append(line)
        # a command continues on the next line after a trailing & (the snapshot's write_dump image)
        dropping = dropping and line.split("#", 1)[0].rstrip().endswith("&")
    return "".join(kept)


def set_run(text: str, steps: int, warmup: int = 0) -> str:
    """Replace the deck's one ``run`` line by ``warmup`` untimed and ``steps`` timed steps.

    The run's options are kept (the heap's ``pre no post no every N "..."`` commands
    are part of its cost); a bare run gets ``pre yes post yes``. Between the two runs
    a ``print`` of :data:`MARKER` marks where the timed run starts in the log.
    """
    lines = text.splitlines(keepends=True)
    runs = _indices(lines, "run")
    if len(runs) != 1:
        raise DeckFormatError(f"expected exactly one run line in the deck, found {len(runs)}: "
                              f"the deck format changed, update bench/bench_decks.py")
    i = runs[0]
    words = _command(lines[i])
    if len(words) < 2:
        raise DeckFormatError(f"run line without a step count: {lines[i].strip()!r}")
    options = lines[i].split("#", 1)[0].strip().split(None, 2)[2:]  # keep the options verbatim (quotes)
    options = options[0] if options else "pre yes post yes"
    new = []
    if warmup > 0:
        new.append(f"run             {warmup} {options}\n")
    new.append(f'print           "{MARKER}"\n')
    new.append(f"run             {steps} {options}\n")
    return "".join(lines[:i] + new + lines[i + 1:])


def set_neighbor_style(text: str, style: str) -> str:
    """``neighbor <skin> bin`` -> ``neighbor <skin> <style>`` (the skin kept)."""
    lines = text.splitlines(keepends=True)
    i = _one(lines, "neighbor", "neighbor")
    words = _command(lines[i])
    if len(words) != 3:
        raise DeckFormatError(f"neighbor line is not 'neighbor <skin> <style>': {lines[i].strip()!r}")
    lines[i] = f"neighbor        {words[1]} {style}\n"
    return "".join(lines)


def insert_after_neighbor(text: str, new: list[str]) -> str:
    """Insert lines after the ``neighbor`` line and its ``neigh_modify`` lines (which
    follow ``read_restart``: comm settings given before ``read_restart`` are reset by it)."""
    lines = text.splitlines(keepends=True)
    rr = _one(lines, "read_restart", "read_restart")
    i = _one(lines, "neighbor", "neighbor")
    if i < rr:
        raise DeckFormatError("the neighbor line comes before read_restart: the deck format changed")
    while i + 1 < len(lines) and (_command(lines[i + 1]) or [""])[0] == "neigh_modify":
        i += 1
    return "".join(lines[:i + 1] + [l + "\n" for l in new] + lines[i + 1:])


def set_processors(text: str, grid: str | None) -> str:
    """The processor grid: replace the ``processors`` line(s) by ``processors <grid>``, inserted
    before ``read_restart`` when there is none (it must precede the box); ``None`` removes
    them (LAMMPS's default grid)."""
    lines = text.splitlines(keepends=True)
    rr = _one(lines, "read_restart", "read_restart")
    found = _indices(lines, "processors")
    if any(i > rr for i in found):
        raise DeckFormatError("a processors line after read_restart: the deck format changed")
    keep = [l for i, l in enumerate(lines) if i not in found]
    if grid is None:
        return "".join(keep)
    rr = _one(keep, "read_restart", "read_restart")
    return "".join(keep[:rr] + [f"processors      {grid}\n"] + keep[rr:])


def set_balance(text: str, mode: str, every: int) -> str:
    """Static ``balance`` and dynamic ``fix balance``: ``none`` removes them; ``shift`` keeps
    the deck's own or adds ``shift xyz`` ones; ``rcb`` turns the deck's own (or added
    ones) into ``rcb`` and switches to ``comm_style tiled`` (which resets comm settings,
    so ``comm_modify vel yes``, needed by the granular pair styles, follows it).
    Added lines go just before the run, after every fix is defined.
    """
    if mode not in ("none", "shift", "rcb"):
        raise ValueError(f"balance mode {mode!r}: none, shift or rcb")
    lines = text.splitlines(keepends=True)
    found = _balance_lines(lines)
    if mode == "none":
        return "".join(l for i, l in enumerate(lines) if i not in found)
    if not found:
        run = _one(lines, "run", "run")
        lines[run:run] = [f"balance         {THRESHOLD} {SHIFT_ARGS}\n",
                          f"fix             bench_balance all balance {every} {THRESHOLD} {SHIFT_ARGS}\n"]
        found = _balance_lines(lines)
    if mode == "shift":
        return "".join(lines)
    for i in found:
        words = _command(lines[i])
        style = words.index("shift") if "shift" in words else words.index("rcb") if "rcb" in words else None
        if style is None:
            raise DeckFormatError(f"balance line with neither shift nor rcb: {lines[i].strip()!r}")
        # shift takes dimstr Niter stopthresh; keywords after them (weight, out) are kept
        rest = words[style + 4:] if words[style] == "shift" else words[style + 1:]
        lines[i] = _line(words[:style] + ["rcb"] + rest)
    return insert_after_neighbor("".join(lines), ["comm_style      tiled", "comm_modify     vel yes"])


def newton_pair(text: str) -> bool:
    """The deck's effective newton pair setting: its last ``newton`` line before
    ``read_restart``, else LAMMPS's default (on). ``read_restart`` warns about, but does
    not restore, the restart's setting (the flow logs show ``newton on`` after an
    ``init`` run with ``newton off``)."""
    lines = text.splitlines(keepends=True)
    rr = _one(lines, "read_restart", "read_restart")
    found = [i for i in _indices(lines, "newton") if i < rr]
    if not found:
        return True
    words = _command(lines[found[-1]])
    return words[1] in ("on", "yes", "true")


def set_newton(text: str, on: bool) -> str:
    """``newton on|off`` (pair and bond alike) before ``read_restart``, replacing the deck's own."""
    lines = text.splitlines(keepends=True)
    found = _indices(lines, "newton")
    keep = [l for i, l in enumerate(lines) if i not in found]
    rr = _one(keep, "read_restart", "read_restart")
    return "".join(keep[:rr] + [f"newton          {'on' if on else 'off'}\n"] + keep[rr:])


# ------------------------------------------------------------------ variants
@dataclass(frozen=True)
class Launch:
    """How a variant is started: MPI ranks, OpenMP threads per rank, ``-sf omp`` or not."""

    ranks: int
    threads: int = 1
    omp: bool = False

    @property
    def cores(self) -> int:
        return self.ranks * self.threads

    def lmp_args(self) -> list[str]:
        return ["-sf", "omp", "-pk", "omp", str(self.threads)] if self.omp else []

    def __str__(self) -> str:
        return f"{self.ranks}x{self.threads}" + (" omp" if self.omp else "")


@dataclass
class Variant:
    """One deck text and launch; ``same_as`` names the variant it duplicates (then it is not run)."""

    name: str
    deck: str
    launch: Launch
    same_as: str | None = None


_GRIDS = {"grid-default": None, "grid-x": "* 1 1", "grid-y": "1 * 1", "grid-z": "1 1 *"}


def default_variants(cores: int) -> list[str]:
    """The default variant list for ``cores`` cores: one setting changed at a time."""
    omp = [f"omp-1x{cores}", f"omp-{cores}x1"] if cores > 1 else ["omp-1x1"]
    return ["ours", "serial", *omp, "multi", "multi-comm", "multi-reduce", *_GRIDS,
            "balance-none", "balance-shift", "balance-rcb", "newton"]


def apply_token(token: str, text: str, launch: Launch, balance_every: int) -> tuple[str, Launch, str]:
    """Apply one variant token to (deck text, launch); returns them and the token's display name."""
    if token == "ours":
        return text, launch, token
    if token == "serial":
        return text, Launch(1, 1, launch.omp), token
    m = re.fullmatch(r"(omp|mpi)-(\d+)x(\d+)", token)
    if m:
        ranks, threads = int(m[2]), int(m[3])
        if m[1] == "mpi" and threads != 1:
            raise ValueError(f"{token}: threads without -sf omp run nothing in parallel; use omp-{ranks}x{threads}")
        return text, Launch(ranks, threads, m[1] == "omp"), token
    if token == "multi":
        return set_neighbor_style(text, "multi"), launch, token
    if token == "multi-comm":
        return insert_after_neighbor(set_neighbor_style(text, "multi"), ["comm_modify     mode multi"]), launch, token
    if token == "multi-reduce":
        text = set_newton(set_neighbor_style(text, "multi"), True)
        return insert_after_neighbor(text, ["comm_modify     mode multi reduce/multi"]), launch, token
    if token in _GRIDS:
        return set_processors(text, _GRIDS[token]), launch, token
    if token == "balance-rcb" and newton_pair(text):
        # the granular history styles with newton pair on need a reverse communication
        # CommTiled lacks: "ERROR: Reverse comm fix variable not yet supported by CommTiled"
        return set_newton(set_balance(text, "rcb", balance_every), False), launch, "balance-rcb+newton-off"
    if token.startswith("balance-"):
        return set_balance(text, token.split("-", 1)[1], balance_every), launch, token
    if token in ("newton", "newton-on", "newton-off"):
        on = (not newton_pair(text)) if token == "newton" else token == "newton-on"
        return set_newton(text, on), launch, f"newton-{'on' if on else 'off'}"
    raise ValueError(f"unknown variant {token!r}; known: ours, serial, omp-RxT, mpi-Rx1, multi, multi-comm, "
                     f"multi-reduce, {', '.join(_GRIDS)}, balance-none|shift|rcb, newton[-on|-off], joined by '+'")


def build_variants(deck: str, names: list[str], cores: int, steps: int, warmup: int,
                   balance_every: int) -> list[Variant]:
    """The variants ``names`` of a rendered deck, ready to run; ``ours`` always first.

    Each is the deck with its tokens applied in order, then without output and with
    the benchmark's run lines. A variant identical to an earlier one (same deck text,
    same launch) gets ``same_as`` set to that one's name.
    """
    names = ["ours"] + [n for n in names if n != "ours"]
    out: list[Variant] = []
    for name in names:
        text, launch, shown = deck, Launch(cores), []
        for token in name.split("+"):
            text, launch, label = apply_token(token, text, launch, balance_every)
            shown.append(label)
        text = set_run(strip_output(text), steps, warmup)
        v = Variant("+".join(shown), text, launch)
        v.same_as = next((o.name for o in out if o.deck == v.deck and o.launch == v.launch), None)
        out.append(v)
    return out


def deck_diff(ours: str, other: str) -> list[str]:
    """The lines removed (-) and added (+) from ours to other, for ``--list``."""
    import difflib

    return [l.rstrip("\n") for l in difflib.unified_diff(ours.splitlines(True), other.splitlines(True), n=0)
            if l[:1] in "+-" and not l.startswith(("+++", "---"))]
