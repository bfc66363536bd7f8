"""A minimal scene, for the tests of the scene contract: only what granflow.registry.REQUIRED asks
(name, summary, sweep, figures, parameters(), analyse(), figure_cases()) and nothing optional: no
validation, no cost study, no paper reference, no snapshots, no checks of its own.

Its decks, analysis and figure are the chute's under another name. The tests copy this file as
the ``__init__.py`` of a package ``<name>`` (``tests/conftest.py``: ``minimal_scene``), with the
chute's deck template, schema and scene file renamed beside it; the scene takes its package's name.
"""
from granflow.registry import FigureSpec, Scene, SweepAxis
from granflow.scenes.chute import analysis, figures
from granflow.scenes.chute.parameters import chute_parameters


class MinimalScene(Scene):
    name = __name__.rsplit(".", 1)[-1]
    summary = "a minimal test scene: the chute's deck and analysis under another name, nothing optional"
    sweep = (SweepAxis("theta_deg", "theta"),)
    figures = {"fig_regimes": FigureSpec(figures.fig_regimes, "none")}

    def parameters(self, scene, rung, case=None):
        params, context = chute_parameters(scene, rung, case)
        context["scene"] = context["record"]["scene"] = self.name  # its own template and records
        return params, context

    def analyse(self, case_dir):
        return analysis.analyse_case(case_dir)

    def figure_cases(self, cases):
        return [{"scalars": scalars, "profile": tables.get("profile")} for scalars, tables in cases]


SCENE = MinimalScene()
