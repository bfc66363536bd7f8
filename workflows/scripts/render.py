"""Adapter: render one case's decks and parameter record (the case comes from its directory name)."""
import json
import sys

sys.stderr = open(snakemake.log[0], "w")
from granflow import registry  # noqa: E402
from granflow.deck import render_case  # noqa: E402

scene = json.loads(snakemake.params.scene)
case = registry.get(scene["scene"]).case_from_dir(snakemake.wildcards.case)
record = render_case(scene, snakemake.params.rung, snakemake.output.params.rsplit("/", 1)[0], case)
print(f"rendered {scene['scene']} {case}: dt = {record['dt']:.4g}", file=sys.stderr)
