# The ladders toward the papers (config/ladders/<scene>.yaml, granflow.ladder): `snakemake ladder` runs every
# rung of every ladder, `snakemake ladder_<scene>` one scene's. Each rung's cases are jobs of the campaign's own
# render / simulate / analyse rules (scenes.smk; their scene and rung from common.smk's SETUPS), under
# <results>/ladders/<scene>/<rung>/: resumable, priced by `granflow plan --config config/ladders/<scene>.yaml`,
# run through a profile like any case. Then one rule writes the record, validation/<scene>/ladder.csv,
# ladder.md and figures/ladder.png. Planned rungs (`planned:`) are priced in the record, never run.
LADDER_RECORD = "validation/{scene}"


def ladder_targets(scene=None):
    """The record of every ladder (or of ``scene``'s): its table, markdown and figure."""
    return [f"{LADDER_RECORD.format(scene=s)}/{f}" for s in LADDERS if scene in (None, s)
            for f in ("ladder.csv", "ladder.md", "figures/ladder.png")]


def ladder_analyses(wildcards):
    """Every case of every rung the scene's ladder runs: its analysis/SHA256SUMS (written last)."""
    return [f"{d}/analysis/SHA256SUMS" for d in ladder_case_dirs(wildcards.scene)]


def ladder_scalars(wildcards):
    return [f"{d}/analysis/scalars.json" for d in ladder_case_dirs(wildcards.scene)]


def ladder_file(wildcards):
    return LADDERS[wildcards.scene]["file"]


rule ladder_record:
    """A ladder's record from its rungs' analysed cases (granflow.ladder.record): each rung's headline checks by
    the scene's own validation, the planned rungs priced, |difference from the paper| against CPU-hours."""
    input:
        ladder=ladder_file,
        sums=ladder_analyses,
        scalars=ladder_scalars,
    output:
        table=LADDER_RECORD + "/ladder.csv",
        markdown=LADDER_RECORD + "/ladder.md",
        figure=LADDER_RECORD + "/figures/ladder.png",
    params:
        results=RESULTS,
    wildcard_constraints:
        scene="|".join(LADDERS) or "no-ladder",
    benchmark:
        RESULTS + "/ladders/{scene}/benchmarks/ladder_record.tsv"
    log:
        RESULTS + "/ladders/{scene}/logs/ladder_record.log",
    script:
        "../scripts/ladder_record.py"


# one target per scene with a ladder: `snakemake ladder_heap`
for _scene in LADDERS:

    rule:
        name:
            f"ladder_{_scene}"
        input:
            ladder_targets(_scene),
