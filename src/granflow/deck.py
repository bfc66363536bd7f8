"""Render LAMMPS decks from Jinja2 templates in ``lammps_inputs/``.

Templates hold structure (which walls, fixes, computes and dump columns);
every number enters as a ``variable ... equal`` line computed here once from the
validated physical parameters, with its meaning as a comment. Only numbers and
names reach a deck, never free text from the config: :mod:`granflow.deck_guard` checks the
names and numbers before a deck is rendered and every line of it before it is written.
"""
from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path

import jinja2

from postproc.safe_write import write_file, write_text

from . import registry
from .schema import PROJECT_ROOT
from .contact import ContactModel
from .deck_guard import DeckError, check_context, check_deck, check_name, template_commands
from .preflight import PreflightError

#: shared include snippets; each scene's templates live in its package
TEMPLATE_DIR = PROJECT_ROOT / "lammps_inputs"
SCENES_DIR = Path(__file__).resolve().parent / "scenes"
STAGES = ("init", "flow", "average")
SPIN_COLUMNS = ["omegax", "omegay", "omegaz"]
STRESS_COLUMNS = [f"c_stress[{k}]" for k in range(1, 7)]


@dataclass(frozen=True)
class Param:
    """A number written into the deck as ``variable name equal value # comment``."""

    name: str
    value: float | int
    comment: str


def number(value) -> float | int:
    """Refuse anything that is not a finite number (decks take typed values only).

    Every scene's parameters pass each :class:`Param` value through it before the deck is
    rendered, so that a string, a bool, a NaN or an infinity never reaches a deck.

    Parameters
    ----------
    value : int or float
        A deck parameter, in the unit of its :class:`Param` (any).

    Returns
    -------
    int or float
        ``value`` itself, unchanged.

    Raises
    ------
    TypeError
        If ``value`` is a bool, not an int or a float, or not finite.
    """
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise TypeError(f"deck parameter must be a finite number, got {value!r}")
    return value


def environment(package_dir: Path | None = None) -> jinja2.Environment:
    """The decks' Jinja2 environment: the shared includes, then ``package_dir`` (a scene package
    outside :mod:`granflow.scenes`, checked by ``granflow check-scene``), then every scene package."""
    first = [str(package_dir)] if package_dir is not None else []
    return jinja2.Environment(
        loader=jinja2.FileSystemLoader([str(TEMPLATE_DIR)] + first
                                       + sorted(str(p) for p in SCENES_DIR.iterdir() if p.is_dir())),
        undefined=jinja2.StrictUndefined,
        trim_blocks=True,
        lstrip_blocks=True,
        keep_trailing_newline=True,
    )


def species_counts(n: int, fractions: list[float]) -> list[int]:
    """Integer counts per species summing to ``n`` (largest-remainder rounding)."""
    raw = [n * f for f in fractions]
    counts = [int(math.floor(r)) for r in raw]
    for i in sorted(range(len(raw)), key=lambda i: raw[i] - counts[i], reverse=True)[: n - sum(counts)]:
        counts[i] += 1
    return counts


def shared_si_params(model: ContactModel, skin: float, neigh: dict, guards: dict) -> list[Param]:
    """Deck numbers every SI scene writes the same way: tangential spring, friction,
    shortest contact, neighbour lists and guards."""
    return [
        Param("k_t", round(model.k_t, 9), "tangential stiffness k_t = kt_over_kn k_n, N/m"),
        Param("friction", model.friction, "particle-particle sliding friction"),
        Param("wall_friction", model.wall_friction, "particle-wall sliding friction"),
        Param("t_c_min", round(model.stiffest.t_c, 12), f"shortest contact time ({model.stiffest.name}), s"),
        Param("skin", round(skin, 9), "neighbour skin, m"),
        Param("neigh_one", neigh["neigh_one"], f"max neighbours per particle (size ratio {neigh['size_ratio']:.3g})"),
        Param("neigh_page", neigh["neigh_page"], "neighbour page size"),
        Param("max_overlap", guards["max_overlap"], "halt: largest overlap / d_min above this"),
        Param("max_speed", guards["max_speed"], "halt: rms particle speed above this, m/s"),
    ]


def contact_law_params(model: ContactModel) -> list[Param]:
    """Deck variables of the contact law that the shared macros (``include/granular.lmp.j2``) read.

    Every law: ``x_t``, the tangential damping as a fraction of the normal one. A per-pair law
    also: ``kn_<key>``, ``kt_<key>``, ``en_<key>`` of every type pair (``<key>`` = ``i_j``) and
    every type against the walls (``w<i>``).
    """
    out = [Param("x_t", round(model.xi_t_ratio, 12), "tangential damping / normal damping (granular x_gamma,t)")]
    for p in model.type_pairs:
        what = f"types {p.i}-{p.j}" if p.j is not None else f"type {p.i}-wall"
        out += [Param(f"kn_{p.key}", _sig(p.k_n), f"normal stiffness, {what} (t_c {p.t_c:.4g} at mean m_eff)"),
                Param(f"kt_{p.key}", _sig(p.k_t), f"tangential stiffness, {what}"),
                Param(f"en_{p.key}", number(p.e_n), f"normal restitution, {what}")]
    return out


def contact_law_context(model: ContactModel) -> dict:
    """Template context of the contact macros: the law and its type pairs (structure only; numbers
    are the deck variables of :func:`contact_law_params`)."""
    return {"law": model.law, "per_pair": model.per_pair, "description": model.record()["description"],
            "pairs": [{"i": p.i, "j": p.j, "key": p.key} for p in model.type_pairs if p.j is not None],
            "walls": [{"type": p.i, "key": p.key} for p in model.type_pairs if p.j is None]}


def _sig(x: float) -> float:
    """A float rounded to 10 significant digits (deck variables)."""
    return float(f"{number(x):.10g}")


def record_head(scene_name: str, rung_name: str, case: dict, rung: dict, params: list[Param],
                model: ContactModel, schedule: str = "fixed") -> dict:
    """The first keys of every parameter record: what ran, at which rung, with which numbers and contacts."""
    return {
        "scene": scene_name,
        "rung": rung_name,
        "case": case,
        "rung_knobs": rung,
        "schedule": schedule,
        "parameters": {prm.name: prm.value for prm in params},
        "contacts": [{"name": c.name, "m_eff": c.m_eff, "t_c": c.t_c, "e_n": c.e_n} for c in model.contacts],
        "contact_law": model.record(),
    }


@dataclass(frozen=True)
class StepClock:
    """Times of a deck in whole time steps ``dt``.

    ``steps(t)`` rounds a time to steps (at least one); ``thermo_multiple(t)`` to a
    whole number of thermo intervals, so that segments and dumps end on thermo rows
    (every row then closes a full interval of an every-step average).
    """

    dt: float
    thermo_interval: float | None = None

    def steps(self, t: float) -> int:
        return max(1, int(round(t / self.dt)))

    @property
    def n_thermo(self) -> int:
        return self.steps(self.thermo_interval)

    def thermo_multiple(self, t: float) -> int:
        n = self.n_thermo
        return n * max(1, int(round(t / self.dt / n)))


def rain_lattice(n_particles: int, v_mean: float, fill_packing: float, d_max: float,
                 span_1: float, span_2: float) -> tuple[float, float, float, int]:
    """Cells of the lattice gas that rains into a box: ``(a, a_1, a_2, n_layers)``.

    A cell holds about one particle at the volume fraction ``fill_packing``
    (:math:`a = (\\langle v\\rangle/\\phi_{fill})^{1/3}`), never narrower than
    1.02 ``d_max``; the two horizontal spans are divided into whole cells
    (``a_1``, ``a_2``, which the caller checks against ``d_max``), and
    ``n_layers`` layers of cells hold ``n_particles`` sites.
    """
    a = max((v_mean / fill_packing) ** (1 / 3), 1.02 * d_max)
    n_1, n_2 = max(1, int(span_1 // a)), max(1, int(span_2 // a))
    return a, span_1 / n_1, span_2 / n_2, math.ceil(n_particles / (n_1 * n_2))


def time_step(rung: dict, model: ContactModel) -> float:
    """The rung's explicit ``dt`` or ``dt_fraction`` x the shortest contact time."""
    if rung.get("dt") is not None:
        return float(rung["dt"])
    return rung["dt_fraction"] * model.stiffest.t_c


def scene_parameters(scene: dict, rung_name: str, case: dict | None = None,
                     declared: registry.Scene | None = None) -> tuple[list[Param], dict]:
    """Deck numbers and template context of any scene (its registered declaration derives them,
    or ``declared``, a scene not registered), with the scene's particle snapshot view if its effect
    ``snapshots`` names the rung."""
    declared = registry.get(scene["scene"]) if declared is None else declared
    return declared.rendered_parameters(scene, rung_name, case)


def render_case(scene: dict, rung_name: str, outdir: str | Path, case: dict | None = None,
                declared: registry.Scene | None = None) -> dict:
    """Write one deck per stage (the scene's ``stages``, default ``init``, ``flow``, ``average``),
    any data files the scene asks for, and ``params.json`` into ``outdir``.

    The template is ``<scene>.lmp.j2`` in the scene's package; ``context["data_files"]``
    maps file names to functions that write them (e.g. an initial packing). ``declared`` is
    the scene's declaration when it is not registered (a package checked by its path), else
    the registry's. Each file is written under a temporary name and moved into place
    (:mod:`postproc.safe_write`): a link at its name is replaced, never written through.

    The rung's name, every name and number of the context and every line of each deck are
    checked (:mod:`granflow.deck_guard`) before anything is written: a
    :class:`~granflow.deck_guard.DeckError` names what may not reach a deck.

    Returns the parameter record (also written to ``params.json``).
    """
    check_name("rung", rung_name)
    params, context = scene_parameters(scene, rung_name, case, declared)
    record = context.pop("record")
    stages = context.pop("stages", STAGES)
    data_files = context.pop("data_files", {})
    env = environment(None if declared is None else declared.package_dir)
    template = env.get_template(f"{check_name('scene', context['scene'])}.lmp.j2")
    context["template_path"] = template_path(template.filename)
    check_context(params, context)
    allowed = template_commands(env, template.name)
    decks = {}
    for stage in stages:
        decks[stage] = template.render(params=params, stage=check_name("stage", stage), **context)
        check_deck(decks[stage], allowed, f"{stage}.lmp of {context['scene']} at rung {rung_name}")
    outdir = Path(outdir)
    outdir.mkdir(parents=True, exist_ok=True)
    for name, write in data_files.items():
        write_file(outdir / name, write)
    for stage, text in decks.items():
        write_text(outdir / f"{stage}.lmp", text)
    write_text(outdir / "params.json", json.dumps(record, indent=2, sort_keys=True) + "\n")
    return record


def check_case_decks(case_dir: str | Path, record: dict) -> None:
    """Refuse a case whose decks on disk hold a line its scene's templates could not have written.

    ``granflow run`` (:func:`granflow.runner.run_case`) reads every ``<stage>.lmp`` of ``case_dir`` as
    it is, so a deck edited after :func:`render_case` wrote it (a ``shell`` line, a command no
    template writes) would run whatever it holds. Each ``*.lmp`` of ``case_dir`` is checked as a
    freshly rendered one is (:func:`granflow.deck_guard.check_deck`, against the commands of the
    template of ``record["scene"]``, the case's checked ``params.json``), before anything runs.

    Raises
    ------
    DeckError
        Naming the file, the line and why; nothing ran.
    """
    scene = check_name("scene", record["scene"])
    env = environment()
    try:
        template = env.get_template(f"{scene}.lmp.j2")
    except jinja2.TemplateNotFound:
        raise DeckError(f"{Path(case_dir) / 'params.json'}: scene = {scene!r} has no deck template among "
                        f"the scene packages: allowed a case rendered from a registered scene; nothing ran") from None
    allowed = template_commands(env, template.name)
    for deck in sorted(Path(case_dir).glob("*.lmp")):
        text = deck.read_text(encoding="utf-8", errors="replace")
        check_deck(text, allowed, str(deck), outcome="nothing ran: render the case again")


def template_path(filename: str) -> str:
    """Where a scene's template lives, for the deck's header: relative to the project root
    (``src/granflow/scenes/<scene>/<scene>.lmp.j2``), or ``<package>/<file>`` for a package
    outside it."""
    path = Path(filename).resolve()
    try:
        return path.relative_to(PROJECT_ROOT).as_posix()
    except ValueError:
        return f"{path.parent.name}/{path.name}"


__all__ = ["render_case", "scene_parameters", "template_path", "PreflightError", "DeckError", "STAGES"]
