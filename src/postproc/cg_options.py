"""The choices of ``granflow cg`` (:mod:`postproc.cg`): the coordinate and kernel names and defaults,
the frame selection, the grid and kernel they make, and :class:`CGOptions`, all of them checked once."""
from __future__ import annotations

import math
from dataclasses import dataclass
from types import MappingProxyType
from typing import Mapping, Sequence

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
        """The selection ``START:STOP[:EVERY]`` (timesteps, STOP included; an empty part is open).

        Parameters
        ----------
        text : str or None
            E.g. ``"100000:200000"`` or ``"::1000"``; None or ``""`` selects every frame.

        Returns
        -------
        FrameSelection

        Raises
        ------
        CGInputError
            For text that is not two or three integers >= 0 separated by ``:``, a
            STOP before START, or an EVERY below 1.
        """
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
        """The selection in words, e.g. ``"step 100 to last (included), every 10 steps"`` or ``"all frames"``."""
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
        """Cell size along each coordinate, ``(hi - lo) / count``, in the dump's length unit."""
        return tuple((hi - lo) / n for (lo, hi), n in zip(self.ranges, self.counts))

    @property
    def n_nodes(self) -> int:
        """Number of nodes (cells), the product of the counts."""
        return int(np.prod(self.counts))

    @property
    def shape(self) -> tuple[int, ...]:
        """The counts, as an array shape (C order: the last coordinate fastest)."""
        return tuple(self.counts)

    def edges(self) -> tuple[np.ndarray, ...]:
        """Cell edges along each coordinate, one array of ``count + 1`` values per coordinate."""
        return tuple(np.linspace(lo, hi, n + 1) for (lo, hi), n in zip(self.ranges, self.counts))

    def nodes(self) -> tuple[np.ndarray, ...]:
        """Cell centres (the nodes) along each coordinate, one array of ``count`` values per coordinate."""
        return tuple(0.5 * (e[1:] + e[:-1]) for e in self.edges())

    def contains(self, points: np.ndarray) -> np.ndarray:
        """Which points (N, d) lie inside the grid's ranges.

        Parameters
        ----------
        points : ndarray, shape (N, d)
            Coordinates in the grid's order (e.g. ``r, z``), the unit of its ranges.

        Returns
        -------
        ndarray of bool, shape (N,)
            True where every coordinate lies in its closed range ``[lo, hi]``.
        """
        inside = np.ones(len(points), dtype=bool)
        for k, (lo, hi) in enumerate(self.ranges):
            inside &= (points[:, k] >= lo) & (points[:, k] <= hi)
        return inside

    def describe(self) -> str:
        """The grid in words: per coordinate its range and node count, e.g. ``"z in [0, 10] (20 nodes)"``."""
        return ", ".join(f"{n} in [{lo:g}, {hi:g}] ({c} nodes)" for n, (lo, hi), c in
                         zip(self.names, self.ranges, self.counts))


def _is_pair(value) -> bool:
    """Whether ``value`` is one ``(lo, hi)`` of two numbers rather than a sequence of them."""
    return (isinstance(value, (list, tuple)) and len(value) == 2
            and all(isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, bool) for v in value))


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
    """``"0.1,0.2"`` -> [0.1, 0.2], refusing anything that is not a finite number.

    Parameters
    ----------
    text : str
        Comma-separated numbers.
    option : str
        The option they were given to, named in the message.

    Returns
    -------
    list of float

    Raises
    ------
    CGInputError
        For a part that is not a number or not finite.
    """
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
    """``"LO:HI[,LO:HI,...]"`` -> [(lo, hi), ...]; None for None.

    Parameters
    ----------
    text : str or None
        Comma-separated ``LO:HI`` pairs.

    Returns
    -------
    list of tuple of (float, float) or None

    Raises
    ------
    CGInputError
        For a part that is not ``LO:HI`` of finite numbers.
    """
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
    """The coordinate system of a ``coords`` choice.

    Parameters
    ----------
    coords : str
        One of :data:`COORDINATES`.
    axis : tuple of (float, float) or None
        :math:`(x_0, y_0)` of the vertical axis, for ``r`` and ``rz``, in the dump's
        length unit.

    Returns
    -------
    CartesianCoordinates, RCoordinates or RZCoordinates

    Raises
    ------
    ValueError
        For a ``coords`` that is not a Cartesian choice, ``r`` or ``rz``.
    """
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
    """The grid of ``spacing`` over ``ranges`` (default from the box); notes on adjusted spacings.

    Parameters
    ----------
    names : sequence of str
        Coordinate names (``x``, ``y``, ``z``, ``r``).
    spacing : float or sequence of float
        Node spacing, one for all coordinates or one per coordinate, in the dump's
        length unit.
    ranges : sequence of (float, float), optional
        ``(lo, hi)`` per coordinate (one for all), same unit; default the box
        along a Cartesian axis, and from 0 to the nearest side wall for ``r``.
    box : ndarray, shape (3, 2)
        The box of the first frame.
    axis : tuple of (float, float), optional
        :math:`(x_0, y_0)` of the axis of ``r``.
    kernel : str
        One of :data:`KERNELS`; a smooth kernel needs two nodes per coordinate.

    Returns
    -------
    grid : Grid
    notes : list of str
        One per spacing adjusted to a whole number of cells.

    Raises
    ------
    CGInputError
        For a number of values that is neither one nor one per coordinate, a
        spacing that is not positive and finite, an empty range, a radius range
        below 0, or a single node with a smooth kernel.
    """
    spacing = _per_coordinate(spacing, names, "--spacing")
    if ranges is not None and _is_pair(ranges):  # one (lo, hi) for every coordinate, as documented
        ranges = [tuple(ranges)]
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
    """The kernel of a ``kernel`` choice on ``grid``: bins on its cells, or a radial kernel on its nodes.

    Parameters
    ----------
    kernel : str
        One of :data:`KERNELS`.
    grid : Grid
    width : float or None
        Gaussian standard deviation, or Lucy's range, in the dump's length unit
        (unused by ``heaviside``).
    cutoff : float or None
        Gaussian truncation radius, same unit; default :data:`GAUSSIAN_CUTOFF`
        widths.

    Returns
    -------
    HeavisideBins, Gaussian or Lucy

    Raises
    ------
    ValueError
        For a width or cutoff that is not positive (:class:`CGOptions` refuses
        them before).
    """
    if kernel == "heaviside":
        return HeavisideBins(grid.edges())
    if kernel == "gaussian":
        return Gaussian(width, cutoff if cutoff is not None else GAUSSIAN_CUTOFF * width, grid.nodes())
    return Lucy(width, grid.nodes())



# --------------------------------------------------------------------------- options


@dataclass(frozen=True, kw_only=True)
class CGOptions:
    """Every choice of a coarse-graining (:class:`postproc.cg.CoarseGraining`), checked once, on construction.

    Raises :class:`~postproc.cg_output.CGInputError` for a choice refused whatever the dumps hold
    (the messages of :func:`postproc.cg.coarse_grain`); the choices that depend on the dumps (the
    axis, the grid, the width against the radii, the node budget) are checked against the first
    selected frame when the frames are read. Lists given are held as tuples, ``frames`` as a
    :class:`FrameSelection`, ``contact_roles`` as a read-only mapping.

    Attributes
    ----------
    coords : str
        One of :data:`COORDINATES` (:mod:`postproc.cg`).
    spacing : float or sequence of float
        Node spacing, one for all coordinates or one per coordinate.
    axis : (float, float), optional
        :math:`(x_0, y_0)` of the vertical axis of ``r`` and ``rz``; default the
        centre of the box in :math:`x, y` (recorded in the meta and a warning).
    kernel : str
        One of :data:`KERNELS`.
    width : float
        Gaussian standard deviation, or Lucy's range; required for both, at least
        the smallest particle radius.
    cutoff : float, optional
        Gaussian truncation radius (default :data:`GAUSSIAN_CUTOFF` widths).
    ranges : (lo, hi) or sequence of (lo, hi), optional
        Grid range per coordinate (:mod:`postproc.cg` for the default).
    contact_roles : mapping, optional
        Column name of each role (``id1 id2 dx dy dz fx fy fz`` ...), when the
        header does not say (:func:`postproc.contacts.read_contact_dump`).
    species : "auto" or sequence of int, optional
        Per-type partial fields; ``"auto"`` takes the types of the first frame
        holding atoms.
    frames : str or FrameSelection, optional
        ``START:STOP[:EVERY]`` in timesteps, STOP included.
    density : float, optional
        Particle material density, when the dump has no mass column.
    volume : {"centre", "exact"}
        Volume fraction from whole spheres at their centres, or (Heaviside bins
        along one Cartesian axis) from each sphere's exact split over the bins.
    n_blocks : int
        Blocks of consecutive frames for the standard errors.
    max_nodes : int
        Node budget; a larger grid is refused before reading.
    allow_truncated : bool
        On a truncated dump, keep the fields of the complete frames (with a
        warning) instead of refusing.
    drop_nonfinite : bool
        Leave out the atoms with a NaN or infinite position, velocity, spin,
        mass or radius (counted in ``meta["frames"]["dropped_nonfinite"]``:
        atom-frames, frames, the first step, per column) instead of refusing the
        input. A mass or radius :math:`\\le 0` is refused either way.
    drop_repeated_steps : bool
        Leave out the atom and contact frames whose timestep is not after the
        previous one's (repeated or going back; the frame read first is kept),
        counted in ``meta["frames"]["dropped_repeated_steps"]``, instead of
        refusing the input (:class:`~postproc.cg_checks.StepOrder`).
    method : {"auto", "compiled", "numpy"}
        Deposit path (the compiled one is used for Gaussian ``rz`` by default).
    """

    coords: str = "z"
    spacing: float | Sequence[float]
    axis: tuple[float, float] | None = None
    kernel: str = "gaussian"
    width: float | None = None
    cutoff: float | None = None
    ranges: Sequence[tuple[float, float]] | None = None
    contact_roles: Mapping[str, str] | None = None
    species: str | Sequence[int] | None = None
    frames: FrameSelection | str | None = None
    density: float | None = None
    volume: str = "centre"
    n_blocks: int = DEFAULT_BLOCKS
    max_nodes: int = DEFAULT_MAX_NODES
    allow_truncated: bool = False
    drop_nonfinite: bool = False
    drop_repeated_steps: bool = False
    method: str = "auto"

    def __post_init__(self):
        coords, kernel, width, cutoff = self.coords, self.kernel, self.width, self.cutoff
        if coords not in COORDINATES:
            raise CGInputError(f"--coords {coords!r} is not one of {', '.join(COORDINATES)}")
        if kernel not in KERNELS:
            raise CGInputError(f"--kernel {kernel!r} is not one of {', '.join(KERNELS)}")
        if kernel != "heaviside":
            if width is None:
                raise CGInputError(f"--width is required for the {kernel} kernel "
                                   f"({'standard deviation' if kernel == 'gaussian' else 'range, where it falls to zero'})")
            if not (math.isfinite(width) and width > 0):
                raise CGInputError(f"--width {width} must be a positive finite length")
            if cutoff is not None and kernel == "gaussian" and not (math.isfinite(cutoff) and cutoff > 0):
                raise CGInputError(f"--cutoff {cutoff} must be a positive finite length")
        if self.volume not in ("centre", "exact"):
            raise CGInputError(f"volume {self.volume!r} is not 'centre' or 'exact'")
        if self.volume == "exact" and not (kernel == "heaviside" and coords in ("x", "y", "z")):
            raise CGInputError("--exact-volume needs --kernel heaviside and one Cartesian coordinate (x, y or z); "
                               f"got --kernel {kernel} --coords {coords}")
        if self.density is not None and not (math.isfinite(self.density) and self.density > 0):
            raise CGInputError(f"--density {self.density} must be a positive finite number")
        if int(self.n_blocks) < 2:
            raise CGInputError(f"--blocks {self.n_blocks} must be at least 2 for standard errors")
        frames = self.frames if isinstance(self.frames, FrameSelection) else FrameSelection.parse(self.frames)
        object.__setattr__(self, "frames", frames)
        for name in ("spacing", "ranges", "species"):  # held, not shared with the caller
            if isinstance(getattr(self, name), list):
                object.__setattr__(self, name, tuple(getattr(self, name)))
        if self.contact_roles is not None:
            object.__setattr__(self, "contact_roles", MappingProxyType(dict(self.contact_roles)))

    @property
    def kernel_cutoff(self) -> float | None:
        """The cutoff as recorded in the meta: the one given, or the kernel's default (Lucy's: its width)."""
        if self.kernel != "heaviside" and self.cutoff is None:
            return GAUSSIAN_CUTOFF * self.width if self.kernel == "gaussian" else self.width
        return self.cutoff
