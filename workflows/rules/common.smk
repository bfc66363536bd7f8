# Helpers shared by the rule files: config validation (before any rule runs)
# and the list of parameter points. No lambdas in rules; functions live here.
import sys
from itertools import product
from pathlib import Path

sys.path.insert(0, str(Path(workflow.basedir) / "src"))

from granflow.config import ConfigError, load_campaign  # noqa: E402

try:
    CAMPAIGN = load_campaign(Path(workflow.basedir) / "config" / "config.yaml",
                             root=Path(workflow.basedir)) if not config else None
    if config:
        import json as _json, tempfile as _tempfile, yaml as _yaml
        # validate the config Snakemake actually uses (file plus any --config overrides)
        with _tempfile.NamedTemporaryFile("w", suffix=".yaml", delete=False,
                                          dir=Path(workflow.basedir) / "config") as _f:
            _yaml.safe_dump(_json.loads(_json.dumps(config)), _f)
        try:
            CAMPAIGN = load_campaign(_f.name, root=Path(workflow.basedir))
        finally:
            Path(_f.name).unlink()
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

    Measured on 2 cores: a 2161-particle demo channel runs at 2.5-3.0
    Matom-step/s on 2 ranks but 3.2-4 on 1 rank while a second case runs
    beside it, so small cases go one rank each, in parallel. Override with
    `--set-threads channel_simulate=N`.
    """
    return 1 if RUNG in ("smoke", "demo") else workflow.cores
