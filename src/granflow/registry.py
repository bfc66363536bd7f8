"""The scene registry: every scene is one package under :mod:`granflow.scenes`.

A scene package ``granflow/scenes/<name>/`` defines ``SCENE``, an instance of a
:class:`Scene` subclass that declares everything particular to the scene: its
sweep axes, figures with captions, headline numbers, cost-study knobs, and the
functions that derive a case's deck parameters, judge its run, analyse it and
tabulate it. The generic layers (config validation, deck rendering, runner,
Snakemake rules, report, cost study, CLI) find scenes only through
:func:`scenes` and :func:`get` and never name one.

Adding a scene means adding its package (with ``SCENE``), its scene file
``config/scenes/<name>.yaml`` and its schema ``config/schema/<name>.schema.yaml``;
nothing else. Packages are found by :mod:`pkgutil`, so there is no list to edit.

The contract: what a scene must give is :data:`REQUIRED`, checked when its package is
found (:func:`check_package`, every problem of :func:`missing`); a package that fails the check
(or does not import) is refused by name with what it lacks (:class:`SceneError`, exit 2 from any
command that needs it) while the other scenes keep working. ``granflow check-scene`` runs the same
check on one package, anywhere (:func:`package_at`). What it may give is :data:`OPTIONAL`: the generic layers ask
:meth:`Scene.gives` and skip what a scene does not give. Everything else has a default
(:data:`DEFAULTED`).
"""
from __future__ import annotations

import importlib
import math
import pkgutil
import re
import sys
import types
from contextlib import contextmanager
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path
from typing import ClassVar

import pandas as pd
import yaml

from .declarations import FigureSpec, Knob, SnapshotView, Stage, SweepAxis, Workload  # noqa: F401 (re-exported)
from .yamlio import ConfigError

#: Where the scene packages live.
SCENES_PACKAGE = "granflow.scenes"
#: the project's config folder: each scene's schema and scene file
CONFIG_DIR = Path(__file__).resolve().parents[2] / "config"


#: statuses any scene's run can end with (runner and generic verdicts), with their meaning;
#: a scene adds its own in :attr:`Scene.statuses` (the README's status table lists the union,
#: tests/unit/test_readme_facts.py checks it)
GENERIC_STATUSES: dict[str, str] = {
    "steady": "flow steady (drift and fluctuation of the centre-of-mass speed below protocol.steady_*); averaged",
    "jammed": "mean speed below protocol's jam speed over the last window; not averaged",
    "no_steady_state": "still drifting or fluctuating at t_flow_max; the reason gives the numbers",
    "unstable": "a guard stopped LAMMPS (overlap, speed, lost atoms, dangerous neighbour builds)",
    "completed": "a fixed schedule ran to its end (scenes without a steady-state test); the analysis may relabel it",
    "unknown": "no flow segment ran, so there is nothing to judge",
    "interrupted": "SIGINT or SIGTERM stopped the run; a rerun resumes from the last restart",
}


class Scene:
    """Base class of a scene declaration; a scene package sets ``SCENE = MyScene()``.

    Must give (:data:`REQUIRED`, checked at discovery): ``name``, ``summary`` (one line),
    ``sweep`` (tuple of :class:`SweepAxis`), ``figures`` (name -> :class:`FigureSpec`, may be
    empty), :meth:`parameters`, :meth:`analyse` and, with figures, :meth:`figure_cases`.
    May give (:data:`OPTIONAL`, see :meth:`gives`): :meth:`validation` with ``paper``; a cost
    study (``knobs``, ``headline``, :meth:`observables`) with :meth:`paper_reference`;
    ``snapshot``. Everything else has a default here (:data:`DEFAULTED`).
    """

    name: ClassVar[str] = ""
    summary: ClassVar[str] = ""
    paper: ClassVar[str] = ""
    sweep: ClassVar[tuple[SweepAxis, ...]] = ()
    figures: ClassVar[dict[str, FigureSpec]] = {}
    table_caption: ClassVar[str] = ""
    table_sort: ClassVar[tuple[str, ...]] = ()
    headline: ClassVar[tuple[tuple[str, str], ...]] = ()
    knobs: ClassVar[dict[str, Knob]] = {}
    #: statuses of :meth:`flow_verdict` that end the flow stage at once (besides steady and jammed)
    stop_statuses: ClassVar[tuple[str, ...]] = ()
    #: statuses particular to this scene (name -> meaning), besides :data:`GENERIC_STATUSES`
    statuses: ClassVar[dict[str, str]] = {}
    #: the unit of its simulated time, as figures and snapshots label it
    time_unit: ClassVar[str] = "simulation units"
    #: how its particle snapshots look (None: the scene writes none, whatever its effects say)
    snapshot: ClassVar[SnapshotView | None] = None

    # -- what it gives ------------------------------------------------------------------
    def gives(self, hook: str) -> bool:
        """Whether the scene gives the optional ``hook``.

        The generic layers skip what it does not give.

        Parameters
        ----------
        hook : str
            A key of :data:`OPTIONAL`: ``validation``, ``cost_study`` (``knobs``,
            ``headline`` and :meth:`observables`, all three), ``paper_reference`` or
            ``snapshots``.

        Returns
        -------
        bool

        Raises
        ------
        KeyError
            For a ``hook`` that is not a key of :data:`OPTIONAL`.
        """
        if hook == "cost_study":
            return bool(self.knobs) and bool(self.headline) and _overrides(self, "observables")
        if hook == "snapshots":
            return self.snapshot is not None
        if hook in ("validation", "paper_reference"):
            return _overrides(self, hook)
        raise KeyError(f"no optional hook {hook!r}: allowed {', '.join(OPTIONAL)}")

    # -- where its files are ----------------------------------------------------------
    @property
    def package_dir(self) -> Path:
        """The scene package's folder (its deck templates and captions live there)."""
        return Path(importlib.import_module(type(self).__module__).__file__).parent

    def captions(self) -> dict:
        """``captions.yaml`` of the package: ``table`` and ``figures`` (name -> caption)."""
        path = self.package_dir / "captions.yaml"
        return yaml.safe_load(path.read_text()) if path.exists() else {"table": "", "figures": {}}

    def figure_caption(self, name: str) -> str:
        """The report caption of figure ``name`` (its spec's, else the package's captions.yaml).

        Parameters
        ----------
        name : str
            A key of :attr:`figures`.

        Returns
        -------
        str
            Empty when neither gives one.

        Raises
        ------
        KeyError
            For a ``name`` that is not one of the scene's figures.
        """
        return self.figures[name].caption or self.captions()["figures"].get(name, "")

    def table_caption_text(self) -> str:
        """The report caption of the scene's table (``table_caption``, else the package's captions.yaml).

        Returns
        -------
        str
            Empty when neither gives one.
        """
        return self.table_caption or self.captions().get("table", "")

    # -- particle snapshots -------------------------------------------------------------
    #: rungs that write snapshots when the scene file's effects do not say (the default campaign's)
    SNAPSHOT_RUNGS: ClassVar[tuple[str, ...]] = ("demo",)

    def snapshots_at(self, scene: dict, rung: str) -> SnapshotView | None:
        """The scene's :class:`SnapshotView` at ``rung``, or None when no image is written there.

        The view is given if the scene file's effect ``snapshots`` (a list of rungs,
        default ``SNAPSHOT_RUNGS``) names ``rung``, else None: no image is written.

        Parameters
        ----------
        scene : dict
            The scene file's contents (``config/scenes/<name>.yaml``, checked).
        rung : str
            Name of the rung.

        Returns
        -------
        SnapshotView or None
            Always None for a scene without ``snapshot``.
        """
        if self.snapshot is None:
            return None
        rungs = scene.get("effects", {}).get("snapshots", self.SNAPSHOT_RUNGS)
        return self.snapshot if rung in rungs else None

    # -- configuration ------------------------------------------------------------------
    def check(self, scene: dict, source: str) -> None:
        """Cross-field checks of a scene file beyond its schema; raise ``ConfigError``.

        Parameters
        ----------
        scene : dict
            The scene file's contents, already checked against its schema.
        source : str
            Where the scene comes from (its file), to name in the messages.

        Raises
        ------
        ConfigError
            For a scene file the scene refuses; the default accepts every one.
        """

    def check_case(self, scene: dict, rung: str, case: dict, source: str) -> None:
        """Refuse a sweep point that cannot run at ``rung`` (``ConfigError``); default: accept.

        Parameters
        ----------
        scene : dict
            The scene file's contents.
        rung : str
            Name of the rung.
        case : dict
            The sweep point, ``{case key: value}`` (:meth:`sweep_points`).
        source : str
            Where the campaign comes from (its file), to name in the messages.

        Raises
        ------
        ConfigError
            For a sweep point the scene refuses at ``rung``.
        """

    def case_values(self, scene: dict, rung: str, case: dict | None = None) -> dict:
        """The scene file's default case with a sweep point's values on top.

        Parameters
        ----------
        scene : dict
            The scene file's contents; its ``case`` section is the default case.
        rung : str
            Name of the rung (unused by the default; a scene may depend on it).
        case : dict, optional
            The sweep point, ``{case key: value}``, in the units of the scene file.

        Returns
        -------
        dict
            A new dict: ``scene["case"]`` updated with ``case``.
        """
        return dict(scene["case"], **(case or {}))

    # -- decks --------------------------------------------------------------------------
    def parameters(self, scene: dict, rung: str, case: dict | None = None):
        """``(params, context)``: the deck numbers and the template context (with ``record``).

        Parameters
        ----------
        scene : dict
            The scene file's contents.
        rung : str
            Name of the rung.
        case : dict, optional
            The sweep point, ``{case key: value}``; None for the default case.

        Returns
        -------
        params : list of granflow.deck.Param
            The deck's numbers, in the units of the scene's deck.
        context : dict
            The template context; ``context["record"]`` is the parameter record
            written to ``params.json``.

        Raises
        ------
        NotImplementedError
            From this base class: every scene must define it (:data:`REQUIRED`).
        """
        raise NotImplementedError(f"scene {self.name!r} does not define parameters()")

    def particle_count(self, scene: dict, rung: str, case: dict | None = None) -> int:
        """Most particles the case holds, estimated *before* anything is built (the size check
        refuses an oversize case with it). Default: :meth:`workload` of the parameter record;
        a scene whose :meth:`parameters` allocates per-particle arrays overrides this with a formula.

        Parameters
        ----------
        scene : dict
            The scene file's contents.
        rung : str
            Name of the rung.
        case : dict, optional
            The sweep point; None for the default case.

        Returns
        -------
        int
            Number of particles (peak, for a scene that inserts them).
        """
        return int(self.workload(self.parameters(scene, rung, case)[1]["record"]).particles)

    def describe(self, record: dict) -> str:
        """One line for ``granflow render``: the case's size and main numbers.

        Parameters
        ----------
        record : dict
            The case's parameter record (``params.json``); the default reads
            ``record["parameters"]["n_particles"]``.

        Returns
        -------
        str
        """
        return f"{record['parameters'].get('n_particles', '?')} particles"

    def workload(self, record: dict):
        """The case's size and length for planning (:class:`Workload`; :mod:`granflow.resources` prices it).

        Default, for a deck whose particle count does not change: ``n_particles``
        (or ``n_particles_estimate``) particles; the init stage runs its settling
        steps ``n_fall + n_settle + n_relax`` (those present; halts that end it
        early are ignored, so this is an upper bound); ``n_flow_segments`` and
        ``n_average_segments`` segments of ``n_segment`` steps (all of them: the
        runner may stop earlier). The pair style is the deck template's
        ``<name>.lmp.j2`` (with the shared includes it names): ``granular`` if
        any ``pair_style granular``. Override where the deck runs more or other
        steps, or inserts particles.

        Parameters
        ----------
        record : dict
            The case's parameter record (``params.json``): ``parameters`` (with
            ``n_particles``, ``n_segment`` in time steps, ``n_fall``, ``n_settle``,
            ``n_relax``), ``n_flow_segments``, ``n_average_segments`` and, optionally,
            ``n_particles_estimate`` and ``contact_law.pair_style``.

        Returns
        -------
        Workload
            Stage lengths in time steps and atom-steps.

        Raises
        ------
        OSError
            When the package has no deck template ``<name>.lmp.j2``.
        """
        template = (self.package_dir / f"{self.name}.lmp.j2").read_text()
        shared = Path(__file__).resolve().parents[2] / "lammps_inputs"  # the decks' shared includes
        for name in re.findall(r"{%\s*include\s+[\"']([^\"']+)[\"']", template):
            if (shared / name).is_file():
                template += (shared / name).read_text()
        styles = re.findall(r"^\s*pair_style\s+(\S+)", template, flags=re.M)
        prm = record["parameters"]
        n = int(prm.get("n_particles", record.get("n_particles_estimate", 0)))
        seg = int(prm.get("n_segment", 0))
        init = sum(int(prm.get(k, 0)) for k in ("n_fall", "n_settle", "n_relax"))
        n_flow, n_average = int(record.get("n_flow_segments", 0)), int(record.get("n_average_segments", 0))
        return Workload.constant(
            self.name, n, {"init": (init, 1), "flow": (n_flow * seg, n_flow), "average": (n_average * seg, n_average)},
            pair_style=record.get("contact_law", {}).get("pair_style")
            or ("granular" if "granular" in styles else (styles[0] if styles else "gran/hooke/history")))

    def simulate_ranks(self, rung: str, cores: int) -> int:
        """MPI ranks of one run: 1 for the small rungs (cases run side by side), all cores above.

        Parameters
        ----------
        rung : str
            Name of the rung.
        cores : int
            Cores available to the run.

        Returns
        -------
        int
        """
        return 1 if rung in ("smoke", "demo") else cores

    # -- running ------------------------------------------------------------------------
    def flow_verdict(self, steady, thermo: pd.DataFrame, record: dict):
        """Rename or replace the generic steady-state verdict of the flow stage (default: keep it).

        Called by the runner after every flow segment.

        Parameters
        ----------
        steady : postproc.steady.SteadyState
            The generic verdict (:func:`postproc.steady.detect_steady_state` of the
            centre-of-mass speed).
        thermo : pandas.DataFrame
            The thermo output of the flow stage so far (columns ``Time``, in the
            scene's :attr:`time_unit`, ``v_ucm``, ``segment``, ...).
        record : dict
            The case's parameter record (``params.json``).

        Returns
        -------
        postproc.steady.SteadyState
            The verdict to act on: its ``status`` ends the flow stage when it is
            ``steady``, ``jammed`` or one of :attr:`stop_statuses`.
        """
        return steady

    def after_segment(self, segment_thermo: pd.DataFrame | None, record: dict) -> tuple[str, str] | None:
        """A named reason ``(status, reason)`` to end the averaging early, or None to go on.

        Called by the runner after every averaging segment.

        Parameters
        ----------
        segment_thermo : pandas.DataFrame or None
            The thermo rows of the segment just run (None when there are none).
        record : dict
            The case's parameter record (``params.json``).

        Returns
        -------
        tuple of (str, str) or None
            The status and the reason; the default always goes on.
        """
        return None

    # -- analysis -----------------------------------------------------------------------
    def analyse(self, case_dir: Path) -> tuple[dict[str, pd.DataFrame], dict]:
        """``(tables, scalars)`` of one finished case; scalars carry ``status`` and ``provenance``.

        Parameters
        ----------
        case_dir : pathlib.Path
            The case directory (``results/<scene>/<rung>/<case>/``) with ``run/`` and
            ``params.json``.

        Returns
        -------
        tables : dict of str to pandas.DataFrame
            Written as ``analysis/<name>.csv``.
        scalars : dict
            Written as ``analysis/scalars.json``; numbers in the units the scene
            states (its deck's, as a rule).

        Raises
        ------
        NotImplementedError
            From this base class: every scene must define it (:data:`REQUIRED`).
        """
        raise NotImplementedError(f"scene {self.name!r} does not define analyse()")

    def table(self, rows: list[dict]) -> pd.DataFrame:
        """One row per case (the scalars), sorted by the sweep axes.

        Parameters
        ----------
        rows : list of dict
            The scalars of each case (``analysis/scalars.json``).

        Returns
        -------
        pandas.DataFrame
            Sorted by ``table_sort``, else by the sweep keys (those present).
        """
        table = pd.DataFrame(rows)
        keys = [k for k in (self.table_sort or [a.key for a in self.sweep]) if k in table]
        return table.sort_values(keys) if keys and not table.empty else table

    def analyse_threads(self, cores: int) -> int:
        """Threads of one case's analysis (the compiled coarse-graining uses them); default 1.

        Parameters
        ----------
        cores : int
            Cores available to the analysis.

        Returns
        -------
        int
        """
        return 1

    def figure_cases(self, cases: list[tuple[dict, dict[str, pd.DataFrame]]]) -> list[dict]:
        """The figure functions' cases from each case's ``(scalars, tables)``.

        Parameters
        ----------
        cases : list of tuple of (dict, dict of str to pandas.DataFrame)
            Each case's scalars and tables (:meth:`analyse`).

        Returns
        -------
        list of dict
            What the ``draw`` of every :class:`FigureSpec` takes.

        Raises
        ------
        NotImplementedError
            From this base class: a scene with figures must define it (:data:`REQUIRED`).
        """
        raise NotImplementedError(f"scene {self.name!r} does not define figure_cases()")

    # -- the error-versus-cost study ----------------------------------------------------
    def observables(self, case_dir: Path, record: dict, t_average: float,
                    block: tuple[float, float] | None = None) -> tuple[dict, tuple[float, float]]:
        """The headline numbers of one case, and the window they were measured over.

        Optional, with ``knobs`` and ``headline`` the cost study (:data:`OPTIONAL`):
        headline numbers (``{key: value}``, NaN where not measurable) over the
        first ``t_average`` of the averaging stage, or over ``block`` of its window;
        and the window ``(t0, t1)`` used.

        The generic study splits the returned window into equal blocks for the errors.

        Parameters
        ----------
        case_dir : pathlib.Path
            The finished, analysed case directory.
        record : dict
            The case's parameter record (``params.json``).
        t_average : float
            Length of the averaging window, in the scene's :attr:`time_unit`, from
            the start of the averaging stage.
        block : tuple of (float, float), optional
            A part ``(t0, t1)`` of the window to measure over instead, same unit
            and origin.

        Returns
        -------
        values : dict
            ``{key: value}`` for every key of ``headline``, in the units its label states.
        window : tuple of (float, float)
            The window ``(t0, t1)`` measured over.

        Raises
        ------
        NotImplementedError
            From this base class: a scene without a cost study has none.
        """
        raise NotImplementedError(f"scene {self.name!r} has no headline observables")

    def averaged_window(self, measure, case_dir: Path, record: dict, t_average: float,
                        block: tuple[float, float] | None = None) -> tuple[dict, tuple[float, float]]:
        """:meth:`observables` for scenes that measure over a time window of the averaging stage.

        ``measure(case_dir, record, t_window=...)`` over ``block`` or the first
        ``t_average``, NaN for what it does not return.

        Parameters
        ----------
        measure : callable
            ``measure(case_dir, record, t_window=(t0, t1)) -> dict`` of headline values.
        case_dir : pathlib.Path
            The finished, analysed case directory.
        record : dict
            The case's parameter record (``params.json``).
        t_average : float
            Length of the averaging window, in the scene's :attr:`time_unit`.
        block : tuple of (float, float), optional
            A part ``(t0, t1)`` of the window to measure over instead.

        Returns
        -------
        values : dict
            Every key of ``headline``: the measured value, else NaN.
        window : tuple of (float, float)
            ``block``, else ``(0, t_average)``.
        """
        window = block or (0.0, t_average)
        return dict(self.nan_observables(), **measure(case_dir, record, t_window=window)), window

    # -- the validation record ----------------------------------------------------------
    def validation(self, scene_dir: Path, cases: dict[str, Path]):
        """Optional (:data:`OPTIONAL`): compare the finished cases of ``scene_dir`` with the paper.

        Parameters
        ----------
        scene_dir : pathlib.Path
            The rung's directory (``results/<scene>/<rung>``), with the rung's
            figures under ``scene_dir/figures``.
        cases : dict of str to pathlib.Path
            ``{case dir name: path}`` of the analysed cases.

        Returns
        -------
        granflow.validation.ValidationResult
            One ``Check`` per quantity (the paper's value and where it is stated,
            ours with its statistical error), the profiles and figures to keep, and
            what differs from the paper's set-up.

        Raises
        ------
        NotImplementedError
            From this base class: a scene without a validation has none.
        """
        raise NotImplementedError(f"scene {self.name!r} has no validation (Scene.validation)")

    def paper_reference(self, scene: dict) -> dict:
        """Optional: particle count and simulated time of the paper rung (for the cost extrapolation).

        Parameters
        ----------
        scene : dict
            The scene file's contents (with its ``paper`` rung).

        Returns
        -------
        dict
            ``n_particles``, ``sim_time`` (the scene's :attr:`time_unit`), ``dt``,
            ``dt_fraction`` and ``how`` (what ``sim_time`` adds up).

        Raises
        ------
        NotImplementedError
            From this base class: a scene without a paper reference has none.
        """
        raise NotImplementedError(f"scene {self.name!r} has no paper reference")

    def cost_note(self, scene: dict, rung: str) -> str:
        """One line naming the cost study's base case in the figures' footers.

        Parameters
        ----------
        scene : dict
            The scene file's contents.
        rung : str
            The rung of the study's base case.

        Returns
        -------
        str
        """
        return f"rung {rung}"

    def nan_observables(self) -> dict:
        """Every key of ``headline`` with the value NaN (:meth:`observables` when nothing can be measured).

        Returns
        -------
        dict of str to float
        """
        return {key: float("nan") for key, _ in self.headline}

    # -- naming a case ------------------------------------------------------------------
    def case_dir(self, point: dict) -> str:
        """Relative directory of a sweep point, e.g. ``W~20/phi~0.6``.

        Parameters
        ----------
        point : dict
            The sweep point, ``{case key: value}``; needs every key of ``sweep``.

        Returns
        -------
        str
            ``<label>~<value>`` per sweep axis, joined by ``/`` (:meth:`SweepAxis.to_dir`).
        """
        return "/".join(f"{a.label}~{a.to_dir(point[a.key])}" for a in self.sweep)

    def case_from_dir(self, rel: str) -> dict:
        """Inverse of :meth:`case_dir`.

        Parameters
        ----------
        rel : str
            A case directory relative to the rung's, e.g. ``W~20/phi~0.6``.

        Returns
        -------
        dict
            ``{case key: value}``, numbers divided back by each axis' ``scale``.

        Raises
        ------
        KeyError
            When ``rel`` lacks the label of a sweep axis.
        ValueError
            When a part has no ``~``, or a number does not read as one.
        """
        parts = dict(p.split("~", 1) for p in rel.strip("/").split("/"))
        return {a.key: a.from_dir(parts[a.label]) for a in self.sweep}

    def sweep_points(self, scene: dict, sweep: dict, rung: str) -> list[dict]:
        """Every combination of the campaign's sweep lists (a missing list: the default case's value).

        Parameters
        ----------
        scene : dict
            The scene file's contents.
        sweep : dict
            The campaign's sweep of the scene, ``{case key: list of values}``.
        rung : str
            Name of the rung.

        Returns
        -------
        list of dict
            One ``{case key: value}`` per combination, the first axis slowest.
        """
        points = [{}]
        for axis in self.sweep:
            values = sweep.get(axis.key) or [self.case_values(scene, rung)[axis.key]]
            points = [dict(p, **{axis.key: v}) for p in points for v in values]
        return points


# -------------------------------------------------------------------- the contract
#: what every scene must give, checked when its package is found (:func:`missing`)
REQUIRED: dict[str, str] = {
    "SCENE": "the package's SCENE, an instance of a granflow.registry.Scene subclass",
    "name": "the package's name",
    "summary": "one line saying what it simulates",
    "sweep": "its sweep axes: one SweepAxis or more, each a key of its schema's case section",
    "figures": "its figures, name -> FigureSpec (may be empty)",
    "parameters()": "a case's deck numbers and template context (with its parameter record)",
    "analyse()": "a finished case's tables and scalars",
    "figure_cases()": "the figure functions' cases (when figures is not empty)",
    "schema": "config/schema/<name>.schema.yaml",
    "scene file": "config/scenes/<name>.yaml",
    "deck template": "<name>.lmp.j2 in its package",
}

#: what a scene may give (:meth:`Scene.gives`), and what the generic layers do without it
OPTIONAL: dict[str, str] = {
    "validation": "validation(), with paper: its checks against the paper; without it the validation record "
                  "lists the cases and says 'no validation declared'",
    "cost_study": "knobs, headline and observables(), all three: the error-versus-cost study; without it there "
                  "is none, and a campaign's cost entry for the scene is refused",
    "paper_reference": "paper_reference(): the paper's size for the cost study's extrapolation; without it the "
                       "study's table says there is no extrapolation",
    "snapshots": "snapshot (a SnapshotView): particle images in the report; without it, none",
}

#: what every scene has from :class:`Scene` and may override
DEFAULTED: dict[str, str] = {
    "checks": "check(), check_case(), case_values(): no checks beyond the schema; the case over the file's",
    "sizes": "describe(), workload(), particle_count(), simulate_ranks(), analyse_threads()",
    "run policy": "flow_verdict(), after_segment(), stop_statuses, statuses: the generic steady-state test",
    "report": "table(), table_sort, table_caption (or captions.yaml), time_unit, cost_note()",
}


class SceneError(ConfigError):
    """A scene package that does not meet the contract: named with what it lacks (exit 2)."""


def _overrides(scene: Scene, method: str) -> bool:
    """Whether ``scene``'s class defines ``method`` itself instead of taking :class:`Scene`'s."""
    return getattr(type(scene), method, None) is not getattr(Scene, method)


def _case_keys(schema: Path) -> set | None:
    """Keys of a schema's ``case`` section (None when the file does not read as a schema)."""
    try:
        data = yaml.load(schema.read_text(), Loader=getattr(yaml, "CSafeLoader", yaml.SafeLoader))
        return set(data["properties"]["case"]["properties"])
    except (OSError, yaml.YAMLError, KeyError, TypeError):
        return None


def missing(scene, package: str, config_dir: Path | None = None) -> list[str]:
    """What ``scene``, the ``SCENE`` of package ``package``, lacks of :data:`REQUIRED`, one
    phrase each (empty when it meets the contract); files are looked for in ``config_dir``
    (default :data:`CONFIG_DIR`) and its package."""
    if not isinstance(scene, Scene):
        return [f"SCENE ({REQUIRED['SCENE']}; found {type(scene).__name__})"]
    config_dir = Path(CONFIG_DIR if config_dir is None else config_dir)
    out = []
    if scene.name != package:
        out.append(f"name (SCENE.name = {scene.name!r}: must be the package's name {package!r})")
    if not (isinstance(scene.summary, str) and scene.summary.strip()):
        out.append(f"summary ({REQUIRED['summary']})")
    axes_ok = (isinstance(scene.sweep, (tuple, list)) and bool(scene.sweep)
               and all(isinstance(a, SweepAxis) for a in scene.sweep))
    if not axes_ok:
        out.append(f"sweep ({REQUIRED['sweep']})")
    if not (isinstance(scene.figures, dict) and all(isinstance(f, FigureSpec) and callable(f.draw)
                                                   for f in scene.figures.values())):
        out.append(f"figures ({REQUIRED['figures']})")
    for method in ("parameters", "analyse") + (("figure_cases",) if scene.figures else ()):
        if not _overrides(scene, method):
            out.append(f"{method}() ({REQUIRED[method + '()']})")
    schema = config_dir / "schema" / f"{package}.schema.yaml"
    keys = _case_keys(schema) if schema.is_file() else None
    if keys is None:
        out.append(f"schema ({schema}: {'no case section' if schema.is_file() else 'no such file'})")
    elif axes_ok and any(a.key not in keys for a in scene.sweep):
        out.append(f"sweep (axes {', '.join(a.key for a in scene.sweep if a.key not in keys)} are not keys of "
                   f"the case section of {schema})")
    scene_file = config_dir / "scenes" / f"{package}.yaml"
    if not scene_file.is_file():
        out.append(f"scene file ({scene_file}: no such file)")
    template = scene.package_dir / f"{package}.lmp.j2"
    if not template.is_file():
        out.append(f"deck template ({template}: no such file)")
    if scene.knobs and not scene.gives("cost_study"):
        out.append("headline and observables() (its knobs declare a cost study, which needs all three)")
    return out


@dataclass(frozen=True)
class PackageCheck:
    """One scene package checked against the contract: its ``SCENE`` (None when the package does not
    import or has no usable one) and every problem found, one phrase each (:func:`check_package`).

    ``import_error`` says why the package does not import (then nothing else was checked);
    ``lacks`` lists what it lacks of :data:`REQUIRED` (:func:`missing`), all of it, not the first.
    """

    scene: Scene | None
    lacks: tuple[str, ...] = ()
    import_error: str = ""

    @property
    def ok(self) -> bool:
        return not self.import_error and not self.lacks

    @property
    def refusal(self) -> str:
        """Why discovery refuses the package (``''`` when it meets the contract)."""
        return self.import_error or ("it lacks " + "; ".join(self.lacks) if self.lacks else "")


def check_package(module: str, package: str, config_dir: Path | None = None) -> PackageCheck:
    """Import the scene package ``module`` (its folder named ``package``) and check its ``SCENE``
    (:func:`missing`, files looked for in ``config_dir``). A package that does not import, has no
    ``SCENE`` or lacks a required part gives a :class:`PackageCheck` that says so, with every problem;
    any error of the package's own code is caught and named (it refuses that package only)."""
    try:
        imported = importlib.import_module(module)
    except Exception as exc:  # noqa: BLE001 - any error of a scene's code refuses that scene only
        return PackageCheck(None, import_error=f"its package does not import ({type(exc).__name__}: {exc})")
    scene = getattr(imported, "SCENE", None)
    try:
        lacks = missing(scene, package, config_dir)
    except Exception as exc:  # noqa: BLE001 - e.g. a member that is not what its name says
        lacks = [f"a SCENE that can be checked ({type(exc).__name__}: {exc})"]
    return PackageCheck(scene if isinstance(scene, Scene) else None, tuple(lacks))


#: the parent under which :func:`package_at` imports a scene package found by its path
CHECKED_PARENT = "_granflow_checked_scene"


@contextmanager
def package_at(path: str | Path):
    """Import the scene package folder ``path`` (anywhere, not only under :mod:`granflow.scenes`) for
    the duration: yields its module name, ``_granflow_checked_scene.<folder name>``, for
    :func:`check_package`. Its relative imports work as in place; afterwards its modules are
    forgotten (another package of the same name can be checked next)."""
    path = Path(path).resolve()
    parent = types.ModuleType(CHECKED_PARENT)
    parent.__path__ = [str(path.parent)]

    def forget():
        for name in [m for m in sys.modules if m == CHECKED_PARENT or m.startswith(CHECKED_PARENT + ".")]:
            del sys.modules[name]

    forget()
    sys.modules[CHECKED_PARENT] = parent
    importlib.invalidate_caches()
    try:
        yield f"{CHECKED_PARENT}.{path.name}"
    finally:
        forget()


@dataclass(frozen=True)
class Found:
    """The scene packages of one discovery: the usable ones by name, the refused ones with why."""

    scenes: dict
    refused: dict


def discover(package: str = SCENES_PACKAGE, config_dir: Path | None = None) -> Found:
    """Import every subpackage of ``package`` and check its ``SCENE`` (:func:`check_package`). A package
    that does not import, has no ``SCENE`` or lacks a required part is refused with the reason;
    the others are found, by name (sorted)."""
    scenes, refused = {}, {}
    for info in sorted(pkgutil.iter_modules(importlib.import_module(package).__path__), key=lambda m: m.name):
        if not info.ispkg:
            continue
        checked = check_package(f"{package}.{info.name}", info.name, config_dir)
        if checked.ok:
            scenes[info.name] = checked.scene
        else:
            refused[info.name] = checked.refusal
    return Found(scenes, refused)


# ------------------------------------------------------------------------- lookup
@lru_cache(maxsize=None)
def _found() -> Found:
    return discover()


def scenes() -> dict[str, Scene]:
    """Every registered scene that meets the contract, by name (sorted)."""
    return dict(_found().scenes)


def names() -> tuple[str, ...]:
    """Names of the usable scenes (sorted); :func:`refused` has the others."""
    return tuple(_found().scenes)


def refused() -> dict[str, str]:
    """Scene packages refused at discovery: name -> what is wrong."""
    return dict(_found().refused)


def get(name: str) -> Scene:
    """The scene called ``name``; :class:`SceneError` naming what a refused one lacks, ``KeyError``
    naming the registered ones for an unknown name."""
    found = _found()
    if name in found.refused:
        raise SceneError(f"scene {name!r} is refused: {found.refused[name]} (granflow.registry.REQUIRED lists "
                         f"what a scene must give)")
    try:
        return found.scenes[name]
    except KeyError:
        raise KeyError(f"no scene {name!r}: registered scenes are {', '.join(found.scenes)}") from None


def finite(value) -> float:
    """``value`` as a float, NaN for anything that is not a finite number."""
    try:
        value = float(value)
    except (TypeError, ValueError):
        return float("nan")
    return value if math.isfinite(value) else float("nan")


__all__ = ["Scene", "SweepAxis", "FigureSpec", "Knob", "Stage", "Workload", "SnapshotView", "SceneError",
           "REQUIRED", "OPTIONAL", "DEFAULTED", "missing", "PackageCheck", "check_package", "package_at", "discover",
           "scenes", "names", "refused", "get", "finite"]
