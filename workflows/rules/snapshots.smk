# Particle snapshots (granflow.snapshots): LAMMPS's own images of each case at a few moments,
# for the report beside the scene's fields. Only for scenes whose effect `snapshots` names the
# campaign's rung (on at demo by default, off in the cost study and the tests' smoke rung).


def snapshot_scenes():
    return [name for name, scene in SCENES.items()
            if scene_cases(name) and scene.snapshots_at(CAMPAIGN["scenes"][name]["scene"], RUNG)]


def snapshot_targets():
    """Each case's snapshots.png and its checksum file (missing after a failed rebuild: the rule is due again)."""
    return [f"{RESULTS}/{name}/{RUNG}/{case}/snapshots.png{ext}" for name in snapshot_scenes()
            for case in scene_cases(name) for ext in ("", ".sha256")]


rule snapshots:
    """The case's particle snapshots side by side: first image, end of the flow stage, last image."""
    input:
        status=rules.simulate.output.status,
        thermo=rules.simulate.output.thermo,
        params=rules.render.output.params,
    output:
        # kept in place if a rebuild fails (update, see scenes.smk); its checksum is written last
        png=update(report(CASE + "/snapshots.png", caption="../report/snapshots.rst", category="{scene}",
                          subcategory="particle snapshots", labels={"case": "{case}"})),
        sha256=CASE + "/snapshots.png.sha256",
    benchmark:
        CASE + "/benchmarks/snapshots.tsv"
    log:
        CASE + "/logs/snapshots.log",
    script:
        "../scripts/snapshots.py"
