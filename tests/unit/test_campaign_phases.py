"""load_campaign runs the checking phases itself (so the campaign file is handed only downward) and
validate_campaign runs the same ones on a campaign read elsewhere (Snakemake's config): the two give the
same campaign for every shipped campaign file, with and without a cost study."""
import json
from pathlib import Path

import pytest

from granflow.campaign import load_campaign, validate_campaign
from granflow.config import apply_overrides, load_yaml

ROOT = Path(__file__).resolve().parents[2]


def _dump(campaign: dict) -> str:
    return json.dumps(campaign, default=lambda o: vars(o) if hasattr(o, "__dict__") else repr(o), sort_keys=True)


@pytest.mark.parametrize("name,overrides", [("config.yaml", []), ("validation.yaml", []),
                                            ("config.yaml", ["scenes.heap.enabled=false"])])
def test_loading_and_validating_give_the_same_campaign(name, overrides):
    path = ROOT / "config" / name
    loaded = load_campaign(path, overrides, root=ROOT)
    validated = validate_campaign(apply_overrides(load_yaml(path), overrides), ROOT, source=str(path))
    assert _dump(loaded) == _dump(validated)
