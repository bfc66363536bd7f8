# Helpers shared by the rule files: config validation (before any rule runs)
# and the list of parameter points. No lambdas in rules; functions live here.
import sys
from itertools import product
from pathlib import Path

sys.path.insert(0, str(Path(workflow.basedir) / "src"))

from granflow.config import ConfigError, validate_campaign  # noqa: E402

try:
    # the config Snakemake actually uses: the file plus any --configfile/--config overrides
    CAMPAIGN = validate_campaign(dict(config), root=Path(workflow.basedir), source="config")
except ConfigError as exc:
    raise WorkflowError(f"invalid configuration, nothing was run:\n{exc}")

RESULTS = CAMPAIGN.get("results_dir", "results")
RUNG = CAMPAIGN["rung"]


def fmt(value):
    """Directory-name form of a number: 20.0 -> '20', 0.6 -> '0.6'."""
    return f"{float(value):g}"


def channel_cases():
    """(W, phi) wildcard strings of every channel sweep point."""
    sc = CAMPAIGN["scenes"].get("channel")
    if not sc or not sc.get("enabled", True):
        return []
    scene = sc["scene"]
    Ws = sc["sweep"].get("W") or [scene["rungs"][RUNG]["W"]]
    phis = sc["sweep"].get("phi_mean") or [scene["case"]["phi_mean"]]
    return [(fmt(W), fmt(phi)) for W, phi in product(Ws, phis)]


def channel_case_dir(W, phi):
    return f"{RESULTS}/channel/{RUNG}/W~{W}/phi~{phi}"


def simulate_threads(wildcards):
    """MPI ranks per run: 1 for the small smoke/demo cases, all cores above.

    Measured on 2 cores with bench/bench_channel.py (2089-particle demo
    channel, flow / averaging stages): one case on 2 ranks 17.6 / 11.2
    Matom-step/s; two cases side by side on 1 rank each 12.5 + 13.0 / 7.0 + 7.2.
    A campaign of small cases thus runs ~1.3-1.45x faster one rank per case.
    Override with `--set-threads channel_simulate=N`.
    """
    return 1 if RUNG in ("smoke", "demo") else workflow.cores


def heap_simulate_threads(wildcards):
    """MPI ranks per heap run: all cores from demo up (one large case, balanced along x).

    Measured on 2 cores (demo heap, 11k particles, 3000 steps): 6.7 s on 2 ranks
    with the x cuts balanced; the heap is the longest job of the demo campaign.
    """
    return 1 if RUNG == "smoke" else workflow.cores


def heap_cases():
    """(mixture, feed rate in g/s) wildcard strings of every heap sweep point."""
    sc = CAMPAIGN["scenes"].get("heap")
    if not sc or not sc.get("enabled", True):
        return []
    scene = sc["scene"]
    mixes = sc["sweep"].get("mixture") or [scene["case"]["mixture"]]
    rates = sc["sweep"].get("feed_rate") or [scene["case"]["feed_rate"]]
    return [(mix, fmt(1000.0 * rate)) for mix, rate in product(mixes, rates)]


def heap_case_dir(mix, mdot):
    return f"{RESULTS}/heap/{RUNG}/mix~{mix}/mdot~{mdot}"


def silo_simulate_threads(wildcards):
    """MPI ranks per silo run: 1 for smoke and demo (several orifice sizes run side by side), all cores above."""
    return 1 if RUNG in ("smoke", "demo") else workflow.cores


def silo_cases():
    """Orifice radius (in r_b) wildcard strings of every silo sweep point."""
    sc = CAMPAIGN["scenes"].get("silo")
    if not sc or not sc.get("enabled", True):
        return []
    scene = sc["scene"]
    return [fmt(R) for R in (sc["sweep"].get("R") or [scene["case"]["R"]])]


def silo_case_dir(R):
    return f"{RESULTS}/silo/{RUNG}/R~{R}"


def silo_w_scan():
    """Kernel widths (in r_b) of the kinetic-pressure scan, as directory-name strings."""
    sc = CAMPAIGN["scenes"].get("silo")
    if not sc or not sc.get("enabled", True):
        return []
    return [fmt(w) for w in sc["scene"]["cg"]["w_scan"]]
