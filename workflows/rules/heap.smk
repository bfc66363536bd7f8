# Heap scene (Fan, Umbanhowar, Ottino & Lueptow 2013): render -> simulate -> analyse
# per case (mixture x feed rate), then one table and the figures of the whole sweep.
import json

HEAP = f"{RESULTS}/heap/{RUNG}"
HEAP_CASE = HEAP + "/mix~{mix}/mdot~{mdot}"
# figure name -> paper figure; captions in workflows/report/heap_figure.rst
HEAP_FIGURES = {
    "fig03_segregation": "3(c)",
    "fig04_surface": "4",
    "fig05_velocity": "5",
    "fig06_streamwise": "6",
    "fig07_collapse": "7",
    "fig08_normal": "8",
    "fig09_all_cases": "9",
    "fig10_scaled": "10",
    "fig11_qstar": "11",
}
HEAP_TABLES = ["per_x", "profile", "collapse", "surface", "alpha_t", "rise_by_x", "phi_columns", "deposit"]


wildcard_constraints:
    mix=r"[a-z0-9.-]+",
    mdot=r"[0-9.]+",


def heap_targets():
    if not heap_cases():
        return []
    return [f"{HEAP}/table.csv"] + [f"{HEAP}/figures/{name}.png" for name in HEAP_FIGURES]


def heap_scene_json(wildcards):
    """The validated scene file as JSON: a change to it reruns the affected cases."""
    return json.dumps(CAMPAIGN["scenes"]["heap"]["scene"], sort_keys=True)


def heap_all_scalars(wildcards):
    return [f"{heap_case_dir(mix, mdot)}/analysis/scalars.json" for mix, mdot in heap_cases()]


def heap_all_tables(wildcards):
    """Every case's analysis tables, grouped by table name (name-major, then case)."""
    return [f"{heap_case_dir(mix, mdot)}/analysis/{name}.csv" for name in HEAP_TABLES for mix, mdot in heap_cases()]


rule heap_render:
    output:
        decks=multiext(HEAP_CASE + "/", "init.lmp", "flow.lmp", "average.lmp"),
        params=HEAP_CASE + "/params.json",
    params:
        scene=heap_scene_json,
        rung=RUNG,
    log:
        HEAP_CASE + "/logs/render.log",
    script:
        "../scripts/render.py"


rule heap_simulate:
    input:
        decks=rules.heap_render.output.decks,
        params=rules.heap_render.output.params,
    output:
        status=HEAP_CASE + "/run/status.json",
        thermo=HEAP_CASE + "/run/thermo.csv",
    threads: heap_simulate_threads
    log:
        HEAP_CASE + "/logs/simulate.log",
    script:
        "../scripts/simulate.py"


rule heap_analyse:
    input:
        status=rules.heap_simulate.output.status,
        thermo=rules.heap_simulate.output.thermo,
        params=rules.heap_render.output.params,
    output:
        scalars=HEAP_CASE + "/analysis/scalars.json",
        tables=[HEAP_CASE + f"/analysis/{name}.csv" for name in HEAP_TABLES],
    log:
        HEAP_CASE + "/logs/analyse.log",
    script:
        "../scripts/analyse_heap.py"


rule heap_table:
    input:
        scalars=heap_all_scalars,
    output:
        table=report(HEAP + "/table.csv", caption="../report/heap_table.rst", category="heap"),
    log:
        HEAP + "/logs/table.log",
    script:
        "../scripts/heap_table.py"


rule heap_figure:
    input:
        scalars=heap_all_scalars,
        tables=heap_all_tables,
    output:
        figure=report(HEAP + "/figures/{figure}.png", caption="../report/heap_figure.rst", category="heap"),
    wildcard_constraints:
        figure="|".join(HEAP_FIGURES),
    log:
        HEAP + "/logs/{figure}.log",
    script:
        "../scripts/heap_figure.py"
