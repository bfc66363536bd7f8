"""Adapter: render one run of the error-versus-cost study (the base scene with one knob changed)."""
import json
import sys

sys.stderr = open(snakemake.log[0], "w")
from granflow.deck import render_case  # noqa: E402

scene = json.loads(snakemake.params.scene)
record = render_case(scene, snakemake.params.rung, snakemake.output.params.rsplit("/", 1)[0])
print(f"rendered cost run {snakemake.wildcards.scene}/{snakemake.wildcards.run}: dt = {record['dt']:.4g}",
      file=sys.stderr)
