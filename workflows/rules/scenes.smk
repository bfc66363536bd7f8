# One set of rules for every scene of the registry: render -> simulate -> analyse per
# case, then one table and the figures of the whole sweep. A case directory is named
# by its sweep values, e.g. results/channel/demo/W~20/phi~0.6 (each scene's sweep axes).
#
# Damaged intermediates (granflow.intermediates): every JSON/CSV a script reads is checked,
# and a damaged one stops the rule with one line naming it and the command that rebuilds it.
# analysis/ is checked against the SHA256SUMS that analyse writes last, table.csv and each
# figure and snapshot against <file>.sha256. Outputs flagged update() are not deleted before
# their rule runs (Snakemake restores them if it fails): the last good table, figure,
# snapshot or analysis stays in place; their checksum files are ordinary outputs, so a
# failed rule is still due at the next call and the refusal repeats until it is rebuilt.
import re

from snakemake.exceptions import WorkflowError

from granflow.intermediates import COMMAND_ENV, snakemake_command

SCENE_DIR = RESULTS + "/{scene}/" + RUNG
# a case of the campaign (prefix the results directory, level its rung) or of a ladder's rung (prefix
# <results>/ladders/<scene>/<rung>, level the rung's scene rung): the same rules build both (common.smk SETUPS)
CASE = "{prefix}/{scene}/{level}/{case}"
ANALYSIS = CASE + "/analysis"


def campaign_command():
    """This campaign's snakemake command without targets, for the rebuild command a refusal names."""
    try:
        cores = workflow.cores
    except WorkflowError:  # a dry run without --cores
        cores = None
    return snakemake_command(workflow.main_snakefile, os.getcwd(), cores, workflow.overwrite_configfiles,
                             workflow.config_settings.config_args or ())


# read by the scripts (they run in this process's environment): not a rule parameter, which
# would rerun every job when the command line changes
os.environ[COMMAND_ENV] = campaign_command()


wildcard_constraints:
    scene="|".join(SCENES) or "no-scene-enabled",
    # exactly the campaign's and the ladders' cases (granflow.targets refuses others on the command line by name)
    case="|".join(sorted({re.escape(c) for name in SCENES for c in scene_cases(name)}
                         | {re.escape(c) for lad in LADDERS.values() for s in lad["rungs"].values()
                            for c in rung_cases(lad["ladder"], s)})) or "no-case",
    prefix="|".join(sorted({re.escape(p) for p, _ in SETUPS})) or "no-prefix",
    level="|".join(sorted({re.escape(s["rung"]) for s in SETUPS.values()})) or "no-level",
    figure="|".join(sorted({f for s in SCENES.values() for f in s.figures})) or "no-figure",


def scene_targets():
    """Each enabled scene's table and figures, each with its checksum file (written last: missing
    after a failed rebuild, so the rule is due again); a scene whose sweep is empty has none."""
    out = []
    for name, scene in SCENES.items():
        if scene_cases(name):
            base = f"{RESULTS}/{name}/{RUNG}"
            for f in [f"{base}/table.csv"] + [f"{base}/figures/{f}.png" for f in scene.figures]:
                out += [f, f + ".sha256"]
    return out


def all_analyses(wildcards):
    """Every case's analysis/SHA256SUMS (the checksums of its analysis folder), in sweep order."""
    return [f"{RESULTS}/{wildcards.scene}/{RUNG}/{case}/analysis/SHA256SUMS" for case in scene_cases(wildcards.scene)]


def all_scalars(wildcards):
    """Every case's analysis/scalars.json, in sweep order (an input: a change to one reruns its readers)."""
    return [f"{RESULTS}/{wildcards.scene}/{RUNG}/{case}/analysis/scalars.json" for case in scene_cases(wildcards.scene)]


def table_caption(wildcards):
    return SCENES[wildcards.scene].table_caption_text()


def figure_caption(wildcards):
    return SCENES[wildcards.scene].figure_caption(wildcards.figure)


def case_rung(wildcards):
    """The scene rung of the case's set (the campaign's, or a ladder rung's own: a ladder at rung validation
    run beside a demo campaign renders validation decks)."""
    return SETUPS[(wildcards.prefix, wildcards.scene)]["rung"]


rule render:
    output:
        params=CASE + "/params.json",
    params:
        scene=scene_json,
        rung=case_rung,
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
        # the folder's other files (one CSV per table) are listed in SHA256SUMS
        scalars=update(ANALYSIS + "/scalars.json"),
        sums=ANALYSIS + "/SHA256SUMS",
    threads: analyse_threads
    benchmark:
        CASE + "/benchmarks/analyse.tsv"
    log:
        CASE + "/logs/analyse.log",
    script:
        "../scripts/analyse.py"


rule table:
    input:
        scalars=all_scalars,
        sums=all_analyses,
    output:
        table=update(report(SCENE_DIR + "/table.csv", caption="../report/table.rst", category="{scene}")),
        sha256=SCENE_DIR + "/table.csv.sha256",
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
        scalars=all_scalars,
        sums=all_analyses,
    output:
        figure=update(report(SCENE_DIR + "/figures/{figure}.png", caption="../report/figure.rst",
                             category="{scene}")),
        sha256=SCENE_DIR + "/figures/{figure}.png.sha256",
    params:
        caption=figure_caption,
    benchmark:
        SCENE_DIR + "/benchmarks/figure_{figure}.tsv"
    log:
        SCENE_DIR + "/logs/{figure}.log",
    script:
        "../scripts/figure.py"
