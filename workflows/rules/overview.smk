# The report's front page (granflow.overview): the campaign as run, each case's status and
# reason, its headline numbers beside the papers' values, and the CPU-hours. Built from the
# scenes' records at the campaign's rung (validation.smk), so the page and the records agree.
# Included after validation.smk.
OVERVIEW = f"{RESULTS}/report/overview_{RUNG}.rst"


def overview_summaries():
    return [f"{VALIDATION_DIR}/{name}/summary.json" for name in SCENES if scene_cases(name)]


def overview_ladders():
    """The committed ladders (validation/<scene>/ladder.csv, `snakemake ladder`) of the campaign's scenes."""
    found = (Path(workflow.basedir, "validation", name, "ladder.csv") for name in SCENES if scene_cases(name))
    return [str(p) for p in found if p.exists()]


def overview_targets():
    return [OVERVIEW] if overview_summaries() else []


def overview_page():
    """The report's global description: the front page once it is written, else a stand-in."""
    return OVERVIEW if os.path.exists(OVERVIEW) else "workflows/report/workflow.rst"


rule overview:
    """The front page of the report (reStructuredText, rendered by `snakemake --report` first)."""
    input:
        summaries=overview_summaries(),
        ladders=overview_ladders(),
    output:
        page=OVERVIEW,
    params:
        rung=RUNG,
    benchmark:
        f"{RESULTS}/benchmarks/{RUNG}/overview.tsv"
    log:
        f"{RESULTS}/logs/overview_{RUNG}.log",
    script:
        "../scripts/overview.py"
