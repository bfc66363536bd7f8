# One set of rules for every scene of the registry: render -> simulate -> analyse per
# case, then one table and the figures of the whole sweep. A case directory is named
# by its sweep values, e.g. results/channel/demo/W~20/phi~0.6 (each scene's sweep axes).
import re

SCENE_DIR = RESULTS + "/{scene}/" + RUNG
CASE = SCENE_DIR + "/{case}"


wildcard_constraints:
    scene="|".join(SCENES) or "no-scene-enabled",
    # exactly the campaign's cases (granflow.targets refuses others on the command line by name)
    case="|".join(re.escape(c) for name in SCENES for c in scene_cases(name)) or "no-case",
    figure="|".join(sorted({f for s in SCENES.values() for f in s.figures})) or "no-figure",


def scene_targets():
    """Each enabled scene's table and figures (a scene whose sweep is empty has none)."""
    out = []
    for name, scene in SCENES.items():
        if scene_cases(name):
            base = f"{RESULTS}/{name}/{RUNG}"
            out += [f"{base}/table.csv"] + [f"{base}/figures/{f}.png" for f in scene.figures]
    return out


def all_analyses(wildcards):
    """The analysis folders of every case of the scene, in sweep order."""
    return [f"{RESULTS}/{wildcards.scene}/{RUNG}/{case}/analysis" for case in scene_cases(wildcards.scene)]


def table_caption(wildcards):
    return SCENES[wildcards.scene].table_caption_text()


def figure_caption(wildcards):
    return SCENES[wildcards.scene].figure_caption(wildcards.figure)


rule render:
    output:
        params=CASE + "/params.json",
    params:
        scene=scene_json,
        rung=RUNG,
    benchmark:
        CASE + "/benchmarks/render.tsv"
    log:
        CASE + "/logs/render.log",
    script:
        "../scripts/render.py"


rule simulate:
    input:
        params=rules.render.output.params,
    output:
        status=CASE + "/run/status.json",
        thermo=CASE + "/run/thermo.csv",
    threads: simulate_threads
    resources:
        tasks=simulate_tasks,
        mem_mb=simulate_mem_mb,
        runtime=simulate_runtime,
    benchmark:
        CASE + "/benchmarks/simulate.tsv"
    log:
        CASE + "/logs/simulate.log",
    script:
        "../scripts/simulate.py"


rule analyse:
    input:
        status=rules.simulate.output.status,
        thermo=rules.simulate.output.thermo,
        params=rules.render.output.params,
    output:
        analysis=directory(CASE + "/analysis"),
    threads: analyse_threads
    benchmark:
        CASE + "/benchmarks/analyse.tsv"
    log:
        CASE + "/logs/analyse.log",
    script:
        "../scripts/analyse.py"


rule table:
    input:
        analyses=all_analyses,
    output:
        table=report(SCENE_DIR + "/table.csv", caption="../report/table.rst", category="{scene}"),
    params:
        caption=table_caption,
    benchmark:
        SCENE_DIR + "/benchmarks/table.tsv"
    log:
        SCENE_DIR + "/logs/table.log",
    script:
        "../scripts/table.py"


rule figure:
    input:
        analyses=all_analyses,
    output:
        figure=report(SCENE_DIR + "/figures/{figure}.png", caption="../report/figure.rst", category="{scene}"),
    params:
        caption=figure_caption,
    benchmark:
        SCENE_DIR + "/benchmarks/figure_{figure}.tsv"
    log:
        SCENE_DIR + "/logs/{figure}.log",
    script:
        "../scripts/figure.py"
