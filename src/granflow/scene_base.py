"""The base class of a scene declaration (:class:`Scene`) and its contract: what every scene must give
(:data:`REQUIRED`), may give (:data:`OPTIONAL`) and has by default (:data:`DEFAULTED`). The registry
(:mod:`granflow.registry`, which re-exports all of it) finds the scene packages and checks them against it."""
from __future__ import annotations

import importlib
import re
from pathlib import Path
from typing import ClassVar

import pandas as pd
import yaml

from .declarations import FigureSpec, Knob, SnapshotView, SweepAxis, Workload
from .scene_hooks import CaseNames, StudyHooks


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


class Scene(StudyHooks, CaseNames):
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
    #: the kind of each check of its validation that is not a ``comparison`` with the paper
    #: (quantity -> ``consistency`` or ``diagnostic``, :data:`granflow.verdicts.KINDS`): applied to its
    #: record by the generic layer, so a rewritten record and a re-judged one say the same
    check_kinds: ClassVar[dict[str, str]] = {}

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
            return bool(self.knobs) and bool(self.headline) and overrides(self, "observables")
        if hook == "snapshots":
            return self.snapshot is not None
        if hook in ("validation", "paper_reference"):
            return overrides(self, hook)
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
    def rendered_parameters(self, scene: dict, rung: str, case: dict | None = None):
        """``(params, context)`` as ``granflow render`` writes them: :meth:`parameters`, and the
        particle snapshot view at ``rung`` (:meth:`snapshots_at`) in the context (``snapshot``)
        and in the record (``snapshots``: its colour and stages, or None). ``granflow plan``
        compares a case's ``params.json`` with this record.

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
            The deck's numbers.
        context : dict
            The template context; its ``record`` is the case's ``params.json``.
        """
        params, context = self.parameters(scene, rung, case)
        view = self.snapshots_at(scene, rung)
        context["snapshot"] = view
        context["record"]["snapshots"] = None if view is None else {"color": view.color, "stages": list(view.stages)}
        return params, context

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
    "record": "check_kinds: every check of validation() a comparison with the paper",
}


def overrides(scene: Scene, method: str) -> bool:
    """Whether ``scene``'s class defines ``method`` itself instead of taking :class:`Scene`'s."""
    return getattr(type(scene), method, None) is not getattr(Scene, method)
