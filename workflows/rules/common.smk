# Helpers shared by the rule files: config validation (before any rule runs), the
# registered scenes of the campaign and their cases. No lambdas in rules; functions live here.
import json
import sys
from pathlib import Path

sys.path.insert(0, str(Path(workflow.basedir) / "src"))

from granflow import registry  # noqa: E402
from granflow.campaign import validate_campaign  # noqa: E402
from granflow.config import ConfigError, check_extent, load_yaml  # noqa: E402
from granflow.ladder import ladder_files, load_ladder, rung_case_dirs, rung_cases, rung_setups  # noqa: E402
from granflow.resources import simulate_resources  # noqa: E402
from granflow.targets import check_targets, cli_targets  # noqa: E402

def refuse(what, exc):
    """A user's mistake: the message naming key, value and allowed range on stderr, exit 2, no
    traceback (as `granflow` does)."""
    print(f"{what}, nothing was run:\n{exc}", file=sys.stderr)
    sys.exit(2)


try:
    # each campaign file read again strictly, by granflow's loader (granflow.config.load_yaml):
    # Snakemake's YAML 1.1 reader takes 0123 for 83 and `on` for true without a word, keeps the
    # last of a key given twice, and evaluates a __use_yte__ template (refused here, too late for
    # what the template ran: `granflow check-config` refuses it before anything runs); the loader
    # also refuses an alias bomb in bounded work (Snakemake's reader shares aliased lists, so a
    # bomb of lists reaches this point at once; one of mappings Snakemake copies out itself first)
    for _file in workflow.configfiles:
        load_yaml(_file)
    # the config Snakemake actually uses: the file plus any --configfile/--config overrides, its
    # size bounded like a file's before anything walks it (a --config value is parsed by Snakemake)
    check_extent(config, "config")
    CAMPAIGN = validate_campaign(dict(config), root=Path(workflow.basedir), source="config")
except ConfigError as exc:
    refuse("invalid configuration", exc)

RESULTS = CAMPAIGN.get("results_dir", "results")
RUNG = CAMPAIGN["rung"]
#: the campaign's enabled scenes, found through the registry
SCENES = {name: registry.get(name) for name, sc in CAMPAIGN["scenes"].items() if sc.get("enabled", True)}

try:
    # every ladder (config/ladders/<scene>.yaml) and each rung it runs, a one-scene campaign checked as the
    # campaign is (granflow.ladder.rung_campaign): its cases are jobs of the same rules (targets `ladder`,
    # `ladder_<scene>`), under <results>/ladders/<scene>/<rung>/
    LADDERS = {}
    for _file in ladder_files(Path(workflow.basedir)):
        _ladder = load_ladder(_file)
        LADDERS[_ladder["scene"]] = {"ladder": _ladder, "file": str(_file),
                                     "rungs": rung_setups(_ladder, RESULTS, Path(workflow.basedir))}
except ConfigError as exc:
    refuse("invalid ladder", exc)

#: where each set of cases lives, (prefix, scene) -> its scene rung and validated scene: the campaign's
#: cases are <results>/<scene>/<rung>/<case>, a ladder rung's <results>/ladders/<scene>/<rung>/<scene>/<rung>/<case>
SETUPS = {(RESULTS, name): {"rung": RUNG, "scene": CAMPAIGN["scenes"][name]["scene"]} for name in SCENES}
SETUPS.update({(setup["results_dir"], scene): {"rung": setup["rung"], "scene": setup["scenes"][scene]["scene"]}
               for scene, lad in LADDERS.items() for setup in lad["rungs"].values()})


def scene_cases(name):
    """Relative case directories (e.g. 'W~20/phi~0.6') of every sweep point of scene `name`."""
    sc = CAMPAIGN["scenes"][name]
    scene = SCENES[name]
    return [scene.case_dir(p) for p in scene.sweep_points(sc["scene"], sc.get("sweep") or {}, RUNG)]


def ladder_case_dirs(scene):
    """Every case directory of every rung the scene's ladder runs, rung by rung."""
    lad = LADDERS[scene]
    return [d for setup in lad["rungs"].values() for d in rung_case_dirs(lad["ladder"], setup)]


def scene_json(wildcards):
    """The validated scene file (the campaign's, or a ladder rung's, changed) as JSON: a change to it reruns
    the affected cases."""
    return json.dumps(SETUPS[(wildcards.prefix, wildcards.scene)]["scene"], sort_keys=True)


def simulate_threads(wildcards):
    """MPI ranks of one run, as the scene decides for the rung (see each scene's simulate_ranks).

    Measured on 2 cores with bench/bench_channel.py (2089-particle demo
    channel, flow / averaging stages): one case on 2 ranks 17.6 / 11.2
    Matom-step/s; two cases side by side on 1 rank each 12.5 + 13.0 / 7.0 + 7.2.
    A campaign of small cases thus runs ~1.3-1.45x faster one rank per case.
    Override with `--set-threads simulate=N`.
    """
    return registry.get(wildcards.scene).simulate_ranks(wildcards.level, workflow.cores)


def analyse_threads(wildcards):
    return registry.get(wildcards.scene).analyse_threads(workflow.cores)


# Resources of one simulate job, from the case itself (granflow.resources.simulate_resources on
# its params.json: one MPI rank per 10k particles, memory, minutes for the whole case). They
# reach a scheduler through a profile (profiles/slurm: sbatch --ntasks/--mem/-t); locally
# `threads` still set the ranks and these only describe the job.
def simulate_tasks(wildcards, input, threads, attempt):
    """MPI tasks of the case; LAMMPS runs on exactly these when a profile sets the `mpi` launcher.

    At least 2: Snakemake's SLURM executor refuses an MPI job of one task ("For MPI jobs,
    'tasks' must be greater than 1"), and a case needing one rank runs no slower on two.
    """
    return max(2, simulate_resources(input.params)["tasks"])


def simulate_mem_mb(wildcards, input, threads, attempt):
    """Memory of the job (runner + LAMMPS ranks + particles, with margin), MB."""
    return simulate_resources(input.params)["mem_mb"]


def simulate_runtime(wildcards, input, threads, attempt):
    """Minutes for every segment of the case in one job (a killed job resumes after its last
    complete segment when resubmitted: the SLURM profile retries)."""
    return simulate_resources(input.params)["runtime"]


def check_command_line_targets():
    """Files named on the snakemake command line get the campaign's validation: a scene, rung,
    case or cost-study run that the campaign does not hold is refused, naming the allowed ones
    (granflow.targets); then one line for each part the targets ask of a scene that it does not
    give (say_skipped). Called by the Snakefile once every rule file is read."""
    if Path(sys.argv[0]).name != "snakemake" and not sys.argv[0].endswith("snakemake/__main__.py"):
        return
    cost = {name: (cs.runs(), cs.points()) for name, cs in CAMPAIGN.get("cost_studies", {}).items()}
    targets = cli_targets(sys.argv[1:])
    try:
        check_targets(targets, RESULTS, RUNG, {name: scene_cases(name) for name in SCENES},
                      registry.names(), cost,
                      ladders={scene: {name: (s["rung"], rung_cases(lad["ladder"], s)) for name, s in lad["rungs"].items()}
                               for scene, lad in LADDERS.items()})
    except ConfigError as exc:
        refuse("invalid target", exc)
    say_skipped(targets)


def say_skipped(targets):
    """One line on stderr for each optional part (granflow.registry.OPTIONAL) that a target named on
    the command line asks of an enabled scene which does not give it: `validate` its validation(),
    `cost` its cost study and paper_reference(). What is skipped is said, not found out later."""
    lines = []
    if "validate" in targets:
        lines += [f"validate: the {name} scene declares no validation(): its record lists its cases and says "
                  f"'no validation declared'" for name, scene in SCENES.items()
                  if scene_cases(name) and not scene.gives("validation")]
    if "cost" in targets:
        lines += [f"cost: the {name} scene declares no cost study (knobs, headline and observables()): "
                  f"none is run for it" for name, scene in SCENES.items() if not scene.gives("cost_study")]
        lines += [f"cost: the {name} scene declares no paper_reference(): its study is not extrapolated to the "
                  f"paper's size" for name in CAMPAIGN.get("cost_studies", {})
                  if not registry.get(name).gives("paper_reference")]
    for line in lines:
        print(line, file=sys.stderr)
