# granflow campaign: YAML cases -> LAMMPS runs -> fields -> figures and report.
# Entry point: `snakemake --cores 2` (or `make demo`). Edit config/config.yaml
# (campaign, sweep) or config/scenes/<scene>.yaml (physics, rungs) and rerun:
# only the cases whose parameters changed run again.
import os

from snakemake.utils import min_version

min_version("8.0")


configfile: os.path.join(workflow.basedir, "config", "config.yaml")


include: "workflows/rules/common.smk"
include: "workflows/rules/scenes.smk"
include: "workflows/rules/cost.smk"
include: "workflows/rules/provenance.smk"
include: "workflows/rules/validation.smk"
include: "workflows/rules/overview.smk"
include: "workflows/rules/snapshots.smk"
include: "workflows/rules/timing.smk"
include: "workflows/rules/ladders.smk"


check_command_line_targets()


report: overview_page()


rule all:
    """The report's front page, every enabled scene's table, figures and provenance (scenes are found
    through granflow's registry), and the committed validation record's tables for the report."""
    input:
        overview_targets(),
        scene_targets(),
        snapshot_targets(),
        provenance_targets(),
        validation_report_targets(),
        timing_targets(),


rule cost:
    """Error-versus-cost study of every scene in the campaign's `cost` section (not part of `all`)."""
    input:
        cost_targets(),


rule ladder:
    """Every rung of every ladder (config/ladders/<scene>.yaml) run with the campaign's rules, then each
    ladder's record validation/<scene>/ladder.csv, ladder.md and figures/ladder.png (not part of `all`;
    one scene's: `snakemake ladder_<scene>`)."""
    input:
        ladder_targets(),


rule validate:
    """The validation record (validation/<scene>/, validation/README.md): run with
    `make validate`, i.e. --configfile config/validation.yaml (not part of `all`)."""
    input:
        validation_targets(),
