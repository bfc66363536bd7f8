# Where the campaign's time goes (granflow.timing): every job's `benchmark:` file (Snakemake's wall
# time, CPU seconds and peak memory) summed per rule and per phase of `make demo` (install, rendering,
# LAMMPS, analysis, figures, report), with the install and `--report` times the Makefile records.
# The rule waits for every other target of `all`, so it runs last; it cannot time itself nor the
# `snakemake --report` that follows it (the table says so). Included last.
TIMING = f"{RESULTS}/timing/{RUNG}"


def timing_targets():
    """The campaign's timing tables (none when no enabled scene has a case)."""
    return [f"{TIMING}/timing.csv"] if any(scene_cases(name) for name in SCENES) else []


def timed_targets(wildcards):
    """Every other target of `all`: the timing tables are written once the whole campaign is done."""
    mine = set(timing_targets())
    return [str(f) for f in rules.all.input if str(f) not in mine]


def timed_dirs(wildcards):
    """The campaign's job directories (each enabled scene's and each of its cases'): benchmark files
    of a case no longer in the sweep are left out of the table."""
    out = []
    for name in SCENES:
        base = f"{RESULTS}/{name}/{RUNG}"
        if scene_cases(name):
            out += [base] + [f"{base}/{case}" for case in scene_cases(name)]
    return out


rule timing:
    """Where the campaign's time went: per rule (timing.csv) and per phase (phases.csv), both in the
    report, and the same as Markdown (timing.md, for the README)."""
    input:
        timed_targets,
    output:
        rules=report(TIMING + "/timing.csv", caption="../report/timing.rst", category="timing",
                     labels={"table": "per rule"}),
        phases=report(TIMING + "/phases.csv", caption="../report/timing.rst", category="timing",
                      labels={"table": "per phase"}),
        markdown=TIMING + "/timing.md",
    params:
        results=RESULTS,
        rung=RUNG,
        dirs=timed_dirs,
        # written by make when it installs .venv (see the Makefile)
        install=os.path.relpath(os.path.join(workflow.basedir, ".venv", ".install_seconds")),
    log:
        f"{RESULTS}/logs/timing_{RUNG}.log",
    script:
        "../scripts/timing.py"
