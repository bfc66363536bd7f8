# Provenance with every result: per case, after its run, <case>/provenance.json (granflow
# commit and dirtiness, LAMMPS version, SHA-256 of the rendered inputs, seeds, rung, ranks,
# wall and CPU seconds, host); per scene, provenance.csv with one row per case, in the report.
# Reads the run's files only: it never reruns a simulation. Included after scenes.smk.


def provenance_targets():
    """Each enabled scene's provenance table (a scene whose sweep is empty has none)."""
    return [f"{RESULTS}/{name}/{RUNG}/provenance.csv" for name in SCENES if scene_cases(name)]


def all_provenance(wildcards):
    """The provenance record of every case of the scene, in sweep order."""
    return [f"{RESULTS}/{wildcards.scene}/{RUNG}/{case}/provenance.json" for case in scene_cases(wildcards.scene)]


rule provenance:
    input:
        status=rules.simulate.output.status,
        params=rules.render.output.params,
    output:
        provenance=CASE + "/provenance.json",
    benchmark:
        CASE + "/benchmarks/provenance.tsv"
    log:
        CASE + "/logs/provenance.log",
    script:
        "../scripts/provenance.py"


rule provenance_table:
    input:
        records=all_provenance,
    output:
        # its own report category: a subcategory under the scene's would file the scene's
        # table and figures (no subcategory) under "Other"
        table=report(SCENE_DIR + "/provenance.csv", caption="../report/provenance.rst",
                     category="provenance", subcategory="{scene}"),
    benchmark:
        SCENE_DIR + "/benchmarks/provenance_table.tsv"
    log:
        SCENE_DIR + "/logs/provenance.log",
    script:
        "../scripts/provenance.py"
