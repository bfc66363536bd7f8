# The validation record: each scene's headline numbers against its paper (granflow.validation and
# each scene's Scene.validation). `make validate` runs config/validation.yaml and writes the
# committed record validation/<scene>/ and validation/README.md. A campaign at another rung
# writes its record under <results>/validation_<rung>/ instead, so a demo run never overwrites
# the committed one. Included after scenes.smk and provenance.smk.
VALIDATION_DIR = "validation" if RUNG == "validation" else f"{RESULTS}/validation_{RUNG}"


def validation_targets():
    """The record's README (after every enabled scene's record)."""
    return [f"{VALIDATION_DIR}/README.md"] if any(scene_cases(name) for name in SCENES) else []


def scene_figures(wildcards):
    return [f"{RESULTS}/{wildcards.scene}/{RUNG}/figures/{f}.png" for f in SCENES[wildcards.scene].figures]


def scene_figure_checksums(wildcards):
    return [f + ".sha256" for f in scene_figures(wildcards)]


def scene_case_dirs(wildcards):
    return {case: f"{RESULTS}/{wildcards.scene}/{RUNG}/{case}" for case in scene_cases(wildcards.scene)}


rule validation_record:
    """One scene's record: summary.json (checks, cases, commit, LAMMPS version, CPU-hours),
    checks.csv, profiles, figures and key log lines."""
    input:
        table=SCENE_DIR + "/table.csv",
        table_sha256=SCENE_DIR + "/table.csv.sha256",
        provenance=SCENE_DIR + "/provenance.csv",
        analyses=all_analyses,
        scalars=all_scalars,
        figures=scene_figures,
        figure_checksums=scene_figure_checksums,
    output:
        summary=VALIDATION_DIR + "/{scene}/summary.json",
        checks=report(VALIDATION_DIR + "/{scene}/checks.csv", caption="../report/validation.rst",
                      category="validation", subcategory="{scene}"),
    params:
        cases=scene_case_dirs,
        scene_dir=SCENE_DIR,
        rung=RUNG,
    benchmark:
        SCENE_DIR + "/benchmarks/validation_record.tsv"
    log:
        SCENE_DIR + "/logs/validation.log",
    script:
        "../scripts/validation_record.py"


rule validation_readme:
    """validation/README.md: one table over every scene's record (those of this run and any
    committed before), the differences from the papers and the CPU-hours."""
    input:
        summaries=[f"{VALIDATION_DIR}/{name}/summary.json" for name in SCENES if scene_cases(name)],
    output:
        readme=VALIDATION_DIR + "/README.md",
    benchmark:
        f"{RESULTS}/benchmarks/{RUNG}/validation_readme.tsv"
    log:
        f"{RESULTS}/logs/validation_readme_{RUNG}.log",
    script:
        "../scripts/validation_readme.py"


def validation_report_targets():
    """The committed record's check tables, shown in the report of any other campaign (section
    "validation"; the validation campaign's report shows the record it writes itself), and the
    committed ladders' figures (`snakemake ladder`: measured on other runs than the campaign's),
    shown in every campaign's report."""
    ladders = sorted(p.parent.parent.name for p in Path(workflow.basedir, "validation").glob("*/figures/ladder.png"))
    targets = [f"{RESULTS}/report/validation/{name}_ladder.png" for name in ladders]
    # what accuracy costs, per scene with a committed ladder and its ladder file (granflow.accuracy_figure)
    targets += [f"{RESULTS}/report/validation/{name}_accuracy_cost.png" for name in sorted(LADDERS)
                if Path(workflow.basedir, "validation", name, "ladder.csv").exists()]
    if RUNG == "validation":
        return targets
    found = sorted(p.parent.name for p in Path(workflow.basedir, "validation").glob("*/checks.csv"))
    return [f"{RESULTS}/report/validation/{name}.csv" for name in found] + targets


def committed_checks(wildcards):
    """A committed record's checks.csv, in the checkout (whatever the working directory)."""
    return str(Path(workflow.basedir, "validation", wildcards.recorded, "checks.csv"))


rule validation_report:
    """Copy a committed record's checks.csv into the report (the record itself stays as committed)."""
    input:
        checks=committed_checks,
    output:
        checks=report(RESULTS + "/report/validation/{recorded}.csv", caption="../report/validation_record.rst",
                      category="validation", subcategory="{recorded}"),
    wildcard_constraints:
        recorded=r"[a-z_]+",
    benchmark:
        RESULTS + f"/benchmarks/{RUNG}/validation_report_{{recorded}}.tsv"
    shell:
        "cp {input.checks} {output.checks}"


def committed_ladder(wildcards):
    """A committed ladder's figure, in the checkout (whatever the working directory)."""
    return str(Path(workflow.basedir, "validation", wildcards.recorded, "figures", "ladder.png"))


rule validation_ladder_report:
    """Copy a committed ladder's figure (error against the paper vs CPU-hours, one point per rung) into the report."""
    input:
        figure=committed_ladder,
    output:
        figure=report(RESULTS + "/report/validation/{recorded}_ladder.png", caption="../report/ladder.rst",
                      category="validation", subcategory="{recorded}"),
    wildcard_constraints:
        recorded=r"[a-z_]+",
    benchmark:
        RESULTS + f"/benchmarks/{RUNG}/validation_ladder_report_{{recorded}}.tsv"
    shell:
        "cp {input.figure} {output.figure}"


def accuracy_cost_inputs(wildcards):
    """The committed ladder (its table and its file) and, where a cost study of the scene was run in this
    campaign's results, its errors (the picture's faded points)."""
    out = {"record": str(Path(workflow.basedir, "validation", wildcards.recorded, "ladder.csv")),
           "ladder": LADDERS[wildcards.recorded]["file"]}
    errors = Path(f"{RESULTS}/cost/{wildcards.recorded}/errors.csv")
    return dict(out, cost_errors=str(errors)) if errors.exists() else out


rule accuracy_cost_report:
    """What accuracy costs in one picture per scene (granflow.accuracy_figure): |difference from the paper|
    against CPU-hours for every rung of the committed ladder, the series' extrapolation toward the paper's
    size, the smoke cost study's knobs faded where it was run."""
    input:
        unpack(accuracy_cost_inputs),
    output:
        figure=report(RESULTS + "/report/validation/{recorded}_accuracy_cost.png",
                      caption="../report/accuracy_cost.rst", category="validation", subcategory="{recorded}"),
    wildcard_constraints:
        recorded="|".join(LADDERS) or "no-ladder",
    benchmark:
        RESULTS + f"/benchmarks/{RUNG}/accuracy_cost_report_{{recorded}}.tsv"
    log:
        RESULTS + f"/logs/accuracy_cost_{{recorded}}.log",
    script:
        "../scripts/accuracy_cost.py"
