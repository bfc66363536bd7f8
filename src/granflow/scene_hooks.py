"""Two groups of a scene's members, mixed into :class:`granflow.registry.Scene`: what its cases are
measured against (the error-versus-cost study and the validation record, both optional: see
:data:`granflow.registry.OPTIONAL`), and how a case is named (its directory from its sweep point)."""
from __future__ import annotations

from pathlib import Path

from .declarations import REPLICATE, SweepAxis  # noqa: F401 (REPLICATE re-exported: case names use it)


class StudyHooks:
    """The optional cost study (:meth:`observables` with the scene's ``knobs`` and ``headline``,
    :meth:`paper_reference`) and validation record (:meth:`validation`) of a scene."""

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

    def profile_checks(self, profiles: dict) -> list:
        """Checks made from the record's own profiles alone (sweep fits over per-case numbers); none by default.

        :meth:`validation` adds them to its checks; a committed record whose runs are gone is judged
        again from its ``profiles/*.csv`` with the same code (``tools/rejudge_record.py``).

        Parameters
        ----------
        profiles : dict of str to pandas.DataFrame
            The record's profiles by name (``profiles/<name>.csv``).

        Returns
        -------
        list of granflow.validation.Check
        """
        return []

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


class CaseNames:
    """How a scene names a case: its directory from its sweep point, and back."""

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
        rel = "/".join(f"{a.label}~{a.to_dir(point[a.key])}" for a in self.sweep)
        # a replicate (the campaign's sweep lists seeds): the same case with another seed, one level deeper
        return f"{rel}/{REPLICATE.label}~{REPLICATE.to_dir(point[REPLICATE.key])}" if REPLICATE.key in point else rel

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
        case = {a.key: a.from_dir(parts[a.label]) for a in self.sweep}
        if REPLICATE.label in parts:
            case[REPLICATE.key] = int(REPLICATE.from_dir(parts[REPLICATE.label]))
        return case

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
        # replicates: every point once per seed the campaign lists (none listed: the scene file's seed, no level)
        seeds = sweep.get(REPLICATE.key) or []
        return [dict(p, **{REPLICATE.key: int(s)}) for p in points for s in seeds] if seeds else points
