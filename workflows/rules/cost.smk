# Error-versus-cost study (`snakemake --cores 2 cost`): per scene, one fidelity knob at
# a time around a base case (config: the campaign's `cost` section). Simulation knobs
# get their own run; averaging time and bin/kernel width re-analyse the base run.
import json

from granflow.cost import paper_reference

COST = f"{RESULTS}/cost"
COST_STUDIES = CAMPAIGN.get("cost_studies", {})
COST_SECTION = CAMPAIGN.get("cost") or {}
COST_RUN = COST + "/{scene}/runs/{run}"
COST_POINT = COST + "/{scene}/points/{point}"


wildcard_constraints:
    scene="|".join(registry.names()),
    # exactly the study's runs and points (granflow.targets refuses others on the command line by name)
    run="|".join(sorted({re.escape(r) for cs in COST_STUDIES.values() for r in cs.runs()})) or "no-run",
    point="|".join(sorted({re.escape(p) for cs in COST_STUDIES.values() for p in cs.points()})) or "no-point",


def cost_targets():
    out = []
    for name in COST_STUDIES:
        out += [f"{COST}/{name}/{f}" for f in ("within.csv", "error_vs_cost.png")]
    return out


def cost_run_scene_json(wildcards):
    """The scene of one run (base or one knob changed): a change to it reruns that run only."""
    return json.dumps(COST_STUDIES[wildcards.scene].scenes[wildcards.run], sort_keys=True)


def cost_rung(wildcards):
    return COST_STUDIES[wildcards.scene].rung


def cost_point_run(wildcards):
    return COST_STUDIES[wildcards.scene].point(wildcards.point)["run"]


def cost_point_inputs(wildcards):
    run = f"{COST}/{wildcards.scene}/runs/{cost_point_run(wildcards)}"
    return {"params": f"{run}/params.json", "status": f"{run}/run/status.json", "thermo": f"{run}/run/thermo.csv"}


def cost_point_json(wildcards):
    return json.dumps(COST_STUDIES[wildcards.scene].point(wildcards.point), sort_keys=True)


def cost_collect_inputs(wildcards):
    cs = COST_STUDIES[wildcards.scene]
    base = f"{COST}/{wildcards.scene}"
    return {
        "observables": [f"{base}/points/{p}/observables.json" for p in cs.points()],
        "post_bench": [f"{base}/points/{p}/benchmark.tsv" for p in cs.points()],
        "sim_bench": [f"{base}/runs/{r}/benchmark.tsv" for r in cs.runs()],
    }


def cost_study_json(wildcards):
    cs = COST_STUDIES[wildcards.scene]
    r = cs.base["rungs"][cs.rung]
    note = registry.get(wildcards.scene).cost_note(cs.base, cs.rung)
    return json.dumps({
        "rung": cs.rung, "base_note": note, "base_values": cs.base_values, "base_dt_fraction": r["dt_fraction"],
        "finest": {k: cs.finest(k) for k in cs.knobs}, "units": {k: cs.unit(k) for k in cs.knobs},
        "noise_sigmas": COST_SECTION.get("noise_sigmas", 2), "tolerances": COST_SECTION.get("tolerances", [0.05, 0.1]),
        "paper": paper_reference(wildcards.scene, cs.base),
    }, sort_keys=True)


rule cost_render:
    output:
        params=COST_RUN + "/params.json",
    params:
        scene=cost_run_scene_json,
        rung=cost_rung,
    benchmark:
        COST_RUN + "/benchmarks/cost_render.tsv"
    log:
        COST_RUN + "/logs/render.log",
    script:
        "../scripts/cost_render.py"


rule cost_simulate:
    input:
        params=rules.cost_render.output.params,
    output:
        status=COST_RUN + "/run/status.json",
        thermo=COST_RUN + "/run/thermo.csv",
    threads: 1
    benchmark:
        COST_RUN + "/benchmark.tsv"
    log:
        COST_RUN + "/logs/simulate.log",
    script:
        "../scripts/simulate.py"


rule cost_analyse:
    input:
        unpack(cost_point_inputs),
    output:
        observables=COST_POINT + "/observables.json",
    params:
        point=cost_point_json,
        n_blocks=COST_SECTION.get("n_blocks", 4),
    threads: 1
    benchmark:
        COST_POINT + "/benchmark.tsv"
    log:
        COST_POINT + "/analyse.log",
    script:
        "../scripts/cost_analyse.py"


rule cost_collect:
    input:
        unpack(cost_collect_inputs),
    output:
        records=COST + "/{scene}/records.csv",
        errors=COST + "/{scene}/errors.csv",
        within=report(COST + "/{scene}/within.csv", caption="../report/cost_table.rst", category="cost"),
        figure=report(COST + "/{scene}/error_vs_cost.png", caption="../report/cost_figure.rst", category="cost"),
        summary=COST + "/{scene}/summary.json",
    params:
        study=cost_study_json,
    benchmark:
        COST + "/{scene}/benchmarks/cost_collect.tsv"
    log:
        COST + "/{scene}/logs/collect.log",
    script:
        "../scripts/cost_collect.py"
