# Channel scene (Debnath, Kesava Rao & Kumaran 2022): render -> simulate -> analyse
# per case, then one table and the figures of the whole sweep.
import json

CHANNEL = f"{RESULTS}/channel/{RUNG}"
CHANNEL_CASE = CHANNEL + "/W~{W}/phi~{phi}"
# figure name -> paper figure; captions in workflows/report/channel_figure.rst
CHANNEL_FIGURES = {
    "fig04_velocity": "4",
    "fig05c_ratio": "5(c)",
    "fig06_stress": "6",
    "fig08_phi_shear_T": "8",
    "fig11_rheology": "11",
}


wildcard_constraints:
    W=r"[0-9.]+",
    phi=r"[0-9.]+",


def channel_targets():
    if not channel_cases():
        return []
    return [f"{CHANNEL}/table.csv"] + [f"{CHANNEL}/figures/{name}.png" for name in CHANNEL_FIGURES]


def channel_scene_json(wildcards):
    """The validated scene file as JSON: a change to it reruns the affected cases."""
    return json.dumps(CAMPAIGN["scenes"]["channel"]["scene"], sort_keys=True)


def channel_all_scalars(wildcards):
    return [f"{channel_case_dir(W, phi)}/analysis/scalars.json" for W, phi in channel_cases()]


def channel_all_profiles(wildcards):
    return [f"{channel_case_dir(W, phi)}/analysis/profile.csv" for W, phi in channel_cases()]


rule channel_render:
    output:
        decks=multiext(CHANNEL_CASE + "/", "init.lmp", "flow.lmp", "average.lmp"),
        params=CHANNEL_CASE + "/params.json",
    params:
        scene=channel_scene_json,
        rung=RUNG,
    log:
        CHANNEL_CASE + "/logs/render.log",
    script:
        "../scripts/render.py"


rule channel_simulate:
    input:
        decks=rules.channel_render.output.decks,
        params=rules.channel_render.output.params,
    output:
        status=CHANNEL_CASE + "/run/status.json",
        thermo=CHANNEL_CASE + "/run/thermo.csv",
    threads: simulate_threads
    log:
        CHANNEL_CASE + "/logs/simulate.log",
    script:
        "../scripts/simulate.py"


rule channel_analyse:
    input:
        status=rules.channel_simulate.output.status,
        thermo=rules.channel_simulate.output.thermo,
        params=rules.channel_render.output.params,
    output:
        profile=CHANNEL_CASE + "/analysis/profile.csv",
        scalars=CHANNEL_CASE + "/analysis/scalars.json",
    log:
        CHANNEL_CASE + "/logs/analyse.log",
    script:
        "../scripts/analyse_channel.py"


rule channel_table:
    input:
        scalars=channel_all_scalars,
    output:
        table=report(CHANNEL + "/table.csv", caption="../report/table.rst", category="channel"),
    log:
        CHANNEL + "/logs/table.log",
    script:
        "../scripts/channel_table.py"


rule channel_figure:
    input:
        scalars=channel_all_scalars,
        profiles=channel_all_profiles,
    output:
        figure=report(CHANNEL + "/figures/{figure}.png",
                      caption="../report/channel_figure.rst", category="channel"),
    wildcard_constraints:
        figure="|".join(CHANNEL_FIGURES),
    log:
        CHANNEL + "/logs/{figure}.log",
    script:
        "../scripts/channel_figure.py"
