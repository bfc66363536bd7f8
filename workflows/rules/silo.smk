# Silo scene (Rubio-Largo, Maza & Hidalgo 2016): render -> simulate -> analyse per
# orifice radius, then one table (with the Beverloo fit over the sweep) and the figures.
import json

SILO = f"{RESULTS}/silo/{RUNG}"
SILO_CASE = SILO + "/R~{R}"
# figure name -> paper figure; captions in workflows/report/silo_figure.rst
SILO_FIGURES = {
    "fig02_flow_rate": "2",
    "fig03_fields": "3",
    "fig04_phi_orifice": "4",
    "fig05_vz_orifice": "5",
    "fig06_contact_pressure": "6",
    "fig07_kinetic_pressure_maps": "7",
    "fig08_kinetic_axis": "8",
    "fig09_kinetic_w": "9",
    "fig10_cumulative": "10",
    "fig11_partial": "11",
    "fig12_partial_over_phi": "12",
    "fig13_beverloo": "Beverloo",
}
SILO_TABLES = ["flow", "fields", "contact"]


wildcard_constraints:
    R=r"[0-9.]+",


def silo_targets():
    if not silo_cases():
        return []
    return [f"{SILO}/table.csv"] + [f"{SILO}/figures/{name}.png" for name in SILO_FIGURES]


def silo_scene_json(wildcards):
    """The validated scene file as JSON: a change to it reruns the affected cases."""
    return json.dumps(CAMPAIGN["scenes"]["silo"]["scene"], sort_keys=True)


def silo_all_scalars(wildcards):
    return [f"{silo_case_dir(R)}/analysis/scalars.json" for R in silo_cases()]


def silo_all_tables(wildcards):
    """Every case's analysis tables, grouped by table name (name-major, then case), then the w scan."""
    names = SILO_TABLES + [f"kinetic_w{w}" for w in silo_w_scan()]
    return [f"{silo_case_dir(R)}/analysis/{name}.csv" for name in names for R in silo_cases()]


rule silo_render:
    output:
        decks=multiext(SILO_CASE + "/", "init.lmp", "average.lmp"),
        atoms=SILO_CASE + "/atoms.data",
        params=SILO_CASE + "/params.json",
    params:
        scene=silo_scene_json,
        rung=RUNG,
    log:
        SILO_CASE + "/logs/render.log",
    script:
        "../scripts/render.py"


rule silo_simulate:
    input:
        decks=rules.silo_render.output.decks,
        atoms=rules.silo_render.output.atoms,
        params=rules.silo_render.output.params,
    output:
        status=SILO_CASE + "/run/status.json",
        thermo=SILO_CASE + "/run/thermo.csv",
    threads: silo_simulate_threads
    log:
        SILO_CASE + "/logs/simulate.log",
    script:
        "../scripts/simulate.py"


rule silo_analyse:
    input:
        status=rules.silo_simulate.output.status,
        thermo=rules.silo_simulate.output.thermo,
        params=rules.silo_render.output.params,
    output:
        scalars=SILO_CASE + "/analysis/scalars.json",
        tables=[SILO_CASE + f"/analysis/{name}.csv" for name in SILO_TABLES],
        kinetic=[SILO_CASE + f"/analysis/kinetic_w{w}.csv" for w in silo_w_scan()],
    threads: workflow.cores
    log:
        SILO_CASE + "/logs/analyse.log",
    script:
        "../scripts/analyse_silo.py"


rule silo_table:
    input:
        scalars=silo_all_scalars,
    output:
        table=report(SILO + "/table.csv", caption="../report/silo_table.rst", category="silo"),
    log:
        SILO + "/logs/table.log",
    script:
        "../scripts/silo_table.py"


rule silo_figure:
    input:
        scalars=silo_all_scalars,
        tables=silo_all_tables,
    output:
        figure=report(SILO + "/figures/{figure}.png", caption="../report/silo_figure.rst", category="silo"),
    wildcard_constraints:
        figure="|".join(SILO_FIGURES),
    log:
        SILO + "/logs/{figure}.log",
    script:
        "../scripts/silo_figure.py"
