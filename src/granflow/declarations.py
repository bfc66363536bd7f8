"""What a scene declares besides its functions: sweep axes, figures, cost-study knobs, snapshot views
and the workload of a case (stages of steps and segments), each a small dataclass the generic layers read
(:class:`granflow.registry.Scene` holds them; :mod:`granflow.registry` re-exports them)."""
from __future__ import annotations

import importlib
import math
from dataclasses import dataclass
from typing import Callable, ClassVar


@dataclass(frozen=True)
class SweepAxis:
    """One swept case key and how it appears in a case directory name (``<label>~<value>``).

    Parameters
    ----------
    key : str
        Key of the scene file's ``case`` section (and of the campaign's ``sweep``).
    label : str
        Directory label, e.g. ``phi`` for ``phi~0.6``.
    scale : float
        The directory shows ``scale`` x the value (the heap writes kg/s as g/s).
    name : bool
        True for a name from a fixed list (written as is), False for a number.
    """

    key: str
    label: str
    scale: float = 1.0
    name: bool = False

    def to_dir(self, value) -> str:
        """The directory text of ``value``: as is for a name, else ``scale`` x the number in ``%g``.

        Parameters
        ----------
        value : str or float
            A value of the case key, in the units of the scene file.

        Returns
        -------
        str
        """
        return str(value) if self.name else f"{float(value) * self.scale:g}"

    def from_dir(self, text: str):
        """The value of the case key that the directory text ``text`` stands for (inverse of :meth:`to_dir`).

        Parameters
        ----------
        text : str
            The part of a directory name after ``<label>~``.

        Returns
        -------
        str or float
            The text for a name, else the number divided by ``scale``.

        Raises
        ------
        ValueError
            For a number axis whose ``text`` is not a number.
        """
        return text if self.name else float(text) / self.scale


#: the replicate level of a case directory, ``<case>/seed~<seed>``: every scene's ``case`` section has a
#: ``seed``; a campaign that lists ``sweep.seed`` runs each of its points once per seed (written in full,
#: as a name: a seed has up to 9 digits)
REPLICATE = SweepAxis("seed", "seed", name=True)


@dataclass(frozen=True)
class Deferred:
    """A function named by its module and name, imported on its first call.

    A scene declares its figures (and may name its analysis) without importing them: every process
    that only lists the scenes (each workflow job, each ``granflow`` command) then skips matplotlib
    and scipy, about a CPU-second each. Calling it calls the function with the same arguments.

    Parameters
    ----------
    module : str
        The module's full name, e.g. ``granflow.scenes.heap.figures``.
    name : str
        The function's name in it.
    """

    module: str
    name: str

    @property
    def __name__(self) -> str:  # noqa: D401 (what a function's __name__ says)
        return self.name

    def function(self) -> Callable:
        """The function itself (importing its module)."""
        return getattr(importlib.import_module(self.module), self.name)

    def __call__(self, *args, **kwargs):
        return self.function()(*args, **kwargs)


@dataclass(frozen=True)
class FigureSpec:
    """One figure of a scene: the function that draws it and its caption for the report.

    ``draw(cases, path)`` takes the list built by :meth:`Scene.figure_cases` and
    writes a PNG; ``paper`` names the paper figure it is the equivalent of.
    """

    draw: Callable
    paper: str
    caption: str = ""


@dataclass(frozen=True)
class Knob:
    """A fidelity knob of the error-versus-cost study.

    ``keys`` are dotted keys of the scene file (``{r}`` stands for the rung),
    set to the value (``mode="set"``) or scaled by it (``mode="scale"``);
    ``finest`` says which end of the list is the most accurate (``min`` or ``max``).
    """

    keys: tuple[str, ...]
    mode: str
    finest: str
    unit: str


@dataclass(frozen=True)
class SnapshotView:
    """How a scene's particle snapshots look: LAMMPS's own ``write_dump ... image`` (JPEG) at
    the end of every segment of ``stages``, for the report (the effect ``snapshots`` lists
    the rungs that write them).

    ``color`` is ``type`` (one colour per species) or ``speed`` (blue = slowest to red =
    fastest particle of that frame); ``view`` is LAMMPS's ``view theta phi`` in degrees, ``up`` its up vector;
    ``center`` the look-at point as fractions of the box; ``size`` pixels; ``zoom`` LAMMPS's;
    ``slab_y`` (a fraction of the box's width along y, or None for every particle) shows only the
    particles within that distance of the box's mid-plane y = const, a cut through a 3D bed.
    """

    COLORS: ClassVar[tuple[str, ...]] = ("type", "speed")

    color: str = "type"
    view: tuple[float, float] = (90.0, -90.0)
    up: tuple[float, float, float] = (0.0, 0.0, 1.0)
    center: tuple[float, float, float] = (0.5, 0.5, 0.5)
    size: tuple[int, int] = (900, 500)
    zoom: float = 1.5
    stages: tuple[str, ...] = ("init", "flow", "average")
    slab_y: float | None = None

    def __post_init__(self):
        if self.color not in self.COLORS:
            raise ValueError(f"SnapshotView.color = {self.color!r}: allowed {', '.join(self.COLORS)}")
        numbers = (*self.view, *self.up, *self.center, *self.size, self.zoom,
                   *(() if self.slab_y is None else (self.slab_y,)))
        if not all(isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in numbers):
            raise ValueError(f"SnapshotView numbers must be finite: {numbers}")


@dataclass(frozen=True)
class Stage:
    """One stage of a case (init, flow, average): its time steps, atom-steps and LAMMPS invocations."""

    steps: int
    atom_steps: float
    segments: int


@dataclass(frozen=True)
class Workload:
    """The size and length of one case, from its parameter record (:meth:`Scene.workload`).

    ``particles`` is the peak number of atoms LAMMPS holds (for a scene that inserts
    particles over time ``growing`` is true and it is the count at the end);
    ``stages`` maps ``init``, ``flow``, ``average`` to :class:`Stage`, the planned
    maximum; ``pair_style`` is the deck's (:mod:`granflow.resources` prices it);
    ``max_ranks`` the most ranks the deck's domain decomposition uses well (None: no limit).
    """

    scene: str
    particles: int
    stages: dict[str, Stage]
    pair_style: str = "gran/hooke/history"
    growing: bool = False
    max_ranks: int | None = None
    note: str = ""

    @property
    def steps(self) -> int:
        """Time steps of the whole case (all stages)."""
        return sum(s.steps for s in self.stages.values())

    @property
    def atom_steps(self) -> float:
        """Atom-steps of the whole case (all stages)."""
        return float(sum(s.atom_steps for s in self.stages.values()))

    @property
    def segments(self) -> int:
        """LAMMPS invocations of the whole case."""
        return sum(s.segments for s in self.stages.values())

    @property
    def longest_segment_atom_steps(self) -> float:
        """Atom-steps of the longest single invocation (peak particles x its steps: an upper bound)."""
        return max((self.particles * s.steps / s.segments for s in self.stages.values() if s.segments), default=0.0)

    @classmethod
    def constant(cls, scene: str, particles: int, steps: dict[str, tuple[int, int]], **kw) -> "Workload":
        """A workload whose particle count does not change: ``steps`` maps stage -> (steps, segments)."""
        stages = {name: Stage(int(n), float(particles) * int(n), int(k)) for name, (n, k) in steps.items()}
        return cls(scene=scene, particles=int(particles), stages=stages, **kw)
