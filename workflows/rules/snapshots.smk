# Particle snapshots (granflow.snapshots): LAMMPS's own images of each case at a few moments,
# for the report beside the scene's fields. Only for scenes whose effect `snapshots` names the
# campaign's rung (on at demo by default, off in the cost study and the tests' smoke rung).


def snapshot_scenes():
    return [name for name, scene in SCENES.items()
            if scene_cases(name) and scene.snapshots_at(CAMPAIGN["scenes"][name]["scene"], RUNG)]


def snapshot_targets():
    return [f"{RESULTS}/{name}/{RUNG}/{case}/snapshots.png" for name in snapshot_scenes() for case in scene_cases(name)]


rule snapshots:
    """The case's particle snapshots side by side: first image, end of the flow stage, last image."""
    input:
        status=rules.simulate.output.status,
        params=rules.render.output.params,
    output:
        png=report(CASE + "/snapshots.png", caption="../report/snapshots.rst", category="{scene}",
                   subcategory="particle snapshots", labels={"case": "{case}"}),
    benchmark:
        CASE + "/benchmarks/snapshots.tsv"
    log:
        CASE + "/logs/snapshots.log",
    script:
        "../scripts/snapshots.py"
