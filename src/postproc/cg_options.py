"""The choices of ``granflow cg`` (:mod:`postproc.cg`): the coordinate and kernel names and defaults,
the frame selection, and the grid and kernel they make (moved out of :mod:`postproc.cg`, which re-exports
them)."""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np

from .cg_output import CGInputError
from .coordinates import CartesianCoordinates, RCoordinates, RZCoordinates
from .kernels import Gaussian, HeavisideBins, Lucy

#: Coordinate choices.
COORDINATES = ("x", "y", "z", "xy", "xz", "yz", "xyz", "r", "rz")
#: Kernel choices.
KERNELS = ("gaussian", "lucy", "heaviside")
#: Default truncation of the Gaussian, in standard deviations.
GAUSSIAN_CUTOFF = 3.0
#: Default node budget (the accumulator keeps ~130 copies of the primitive
#: densities for block errors: 250 000 nodes x 26 primitives is ~7 GB).
DEFAULT_MAX_NODES = 100_000
#: Blocks of consecutive frames for the standard errors.
DEFAULT_BLOCKS = 8


# --------------------------------------------------------------------------- frames


@dataclass(frozen=True)
class FrameSelection:
    """Frames by timestep: ``start <= step <= stop`` and every ``every``-th step from ``start``.

    Parsed from ``START:STOP[:EVERY]`` (:meth:`parse`); an empty part is open.
    """

    start: int | None = None
    stop: int | None = None
    every: int | None = None

    @classmethod
    def parse(cls, text: str | None) -> "FrameSelection":
        if text is None or text == "":
            return cls()
        parts = str(text).split(":")
        if len(parts) not in (2, 3):
            raise CGInputError(f"--frames {text!r} is not START:STOP[:EVERY] (timesteps, STOP included)")
        values = []
        for name, part in zip(("START", "STOP", "EVERY"), parts):
            if part.strip() == "":
                values.append(None)
                continue
            try:
                value = int(part)
            except ValueError:
                raise CGInputError(f"--frames {text!r}: {name} {part!r} is not an integer timestep") from None
            if value < 0:
                raise CGInputError(f"--frames {text!r}: {name} {value} must be >= 0")
            values.append(value)
        values += [None] * (3 - len(values))
        start, stop, every = values
        if start is not None and stop is not None and stop < start:
            raise CGInputError(f"--frames {text!r}: STOP {stop} is before START {start}")
        if every is not None and every < 1:
            raise CGInputError(f"--frames {text!r}: EVERY must be at least 1, got {every}")
        return cls(start, stop, every)

    def __call__(self, timestep: int) -> bool:
        if self.start is not None and timestep < self.start:
            return False
        if self.stop is not None and timestep > self.stop:
            return False
        if self.every is not None and (timestep - (self.start or 0)) % self.every:
            return False
        return True

    def describe(self) -> str:
        if self == FrameSelection():
            return "all frames"
        lo = "first" if self.start is None else f"step {self.start}"
        hi = "last" if self.stop is None else f"step {self.stop}"
        every = "" if self.every is None else f", every {self.every} steps"
        return f"{lo} to {hi} (included){every}"



# --------------------------------------------------------------------------- grid


@dataclass(frozen=True)
class Grid:
    """A regular grid of cells: per coordinate a range ``(lo, hi)`` cut into ``count`` cells.

    Nodes are the cell centres; Heaviside bins are the cells themselves.
    """

    names: tuple[str, ...]
    ranges: tuple[tuple[float, float], ...]
    counts: tuple[int, ...]

    @property
    def spacing(self) -> tuple[float, ...]:
        return tuple((hi - lo) / n for (lo, hi), n in zip(self.ranges, self.counts))

    @property
    def n_nodes(self) -> int:
        return int(np.prod(self.counts))

    @property
    def shape(self) -> tuple[int, ...]:
        return tuple(self.counts)

    def edges(self) -> tuple[np.ndarray, ...]:
        return tuple(np.linspace(lo, hi, n + 1) for (lo, hi), n in zip(self.ranges, self.counts))

    def nodes(self) -> tuple[np.ndarray, ...]:
        return tuple(0.5 * (e[1:] + e[:-1]) for e in self.edges())

    def contains(self, points: np.ndarray) -> np.ndarray:
        """Which points (N, d) lie inside the grid's ranges."""
        inside = np.ones(len(points), dtype=bool)
        for k, (lo, hi) in enumerate(self.ranges):
            inside &= (points[:, k] >= lo) & (points[:, k] <= hi)
        return inside

    def describe(self) -> str:
        return ", ".join(f"{n} in [{lo:g}, {hi:g}] ({c} nodes)" for n, (lo, hi), c in
                         zip(self.names, self.ranges, self.counts))


def _per_coordinate(values, names: Sequence[str], option: str) -> list:
    values = list(values) if isinstance(values, (list, tuple)) else [values]
    if len(values) == 1:
        return values * len(names)
    if len(values) != len(names):
        raise CGInputError(f"{option} gives {len(values)} values but the coordinates {''.join(names)!r} "
                           f"have {len(names)}: give one for all or one per coordinate, in the order "
                           f"{', '.join(names)}")
    return values


def parse_numbers(text: str, option: str) -> list[float]:
    """``"0.1,0.2"`` -> [0.1, 0.2], refusing anything that is not a finite number."""
    out = []
    for part in str(text).split(","):
        try:
            value = float(part)
        except ValueError:
            raise CGInputError(f"{option} {text!r}: {part!r} is not a number") from None
        if not math.isfinite(value):
            raise CGInputError(f"{option} {text!r}: {part!r} is not finite")
        out.append(value)
    return out


def parse_ranges(text: str | None) -> list[tuple[float, float]] | None:
    """``"LO:HI[,LO:HI,...]"`` -> [(lo, hi), ...]; None for None."""
    if text is None:
        return None
    out = []
    for part in str(text).split(","):
        bounds = part.split(":")
        if len(bounds) != 2:
            raise CGInputError(f"--range {text!r}: {part!r} is not LO:HI")
        lo, hi = (parse_numbers(b, "--range")[0] for b in bounds)
        out.append((lo, hi))
    return out


def make_coordinates(coords: str, axis):
    if coords in ("r", "rz"):
        cls = RCoordinates if coords == "r" else RZCoordinates
        return cls(axis)
    return CartesianCoordinates(coords)


def _default_range(name: str, box: np.ndarray, axis) -> tuple[float, float]:
    if name == "r":
        x0, y0 = axis
        return 0.0, float(min(x0 - box[0, 0], box[0, 1] - x0, y0 - box[1, 0], box[1, 1] - y0))
    k = "xyz".index(name)
    return float(box[k, 0]), float(box[k, 1])


def make_grid(names: Sequence[str], spacing, ranges, box: np.ndarray, axis=None,
              kernel: str = "gaussian") -> tuple[Grid, list[str]]:
    """The grid of ``spacing`` over ``ranges`` (default from the box); notes on adjusted spacings."""
    spacing = _per_coordinate(spacing, names, "--spacing")
    ranges = _per_coordinate(ranges, names, "--range") if ranges is not None else [None] * len(names)
    out_ranges, counts, notes = [], [], []
    for name, h, rng in zip(names, spacing, ranges):
        if not (h > 0 and math.isfinite(h)):
            raise CGInputError(f"--spacing {h} for {name} must be a positive finite length")
        lo, hi = rng if rng is not None else _default_range(name, box, axis)
        if not hi > lo:
            source = "--range" if rng is not None else f"the box (from the first frame) gives {name} range"
            raise CGInputError(f"{source} {lo:g}:{hi:g} for {name} is empty: HI must exceed LO")
        if name == "r" and lo < 0:
            raise CGInputError(f"--range {lo:g}:{hi:g} for r starts below 0; the radius is >= 0")
        n = max(1, int(round((hi - lo) / h)))
        if abs(n * h - (hi - lo)) > 1e-9 * (hi - lo):
            notes.append(f"spacing along {name} adjusted from {h:g} to {(hi - lo) / n:g} "
                         f"for a whole number of cells in [{lo:g}, {hi:g}]")
        if kernel != "heaviside" and n < 2:
            raise CGInputError(f"--spacing {h:g} gives a single node along {name} in [{lo:g}, {hi:g}]; "
                               f"a smooth kernel needs at least 2 nodes per coordinate")
        out_ranges.append((float(lo), float(hi)))
        counts.append(n)
    return Grid(tuple(names), tuple(out_ranges), tuple(counts)), notes


def make_kernel(kernel: str, grid: Grid, width: float | None, cutoff: float | None):
    if kernel == "heaviside":
        return HeavisideBins(grid.edges())
    if kernel == "gaussian":
        return Gaussian(width, cutoff if cutoff is not None else GAUSSIAN_CUTOFF * width, grid.nodes())
    return Lucy(width, grid.nodes())

