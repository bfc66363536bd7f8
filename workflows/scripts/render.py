"""Adapter: render one channel case's decks and parameter record."""
import json
import sys

sys.stderr = open(snakemake.log[0], "w")
from granflow.deck import render_case  # noqa: E402

W, phi = float(snakemake.wildcards.W), float(snakemake.wildcards.phi)
scene = json.loads(snakemake.params.scene)
record = render_case(scene, snakemake.params.rung, snakemake.output.params.rsplit("/", 1)[0],
                     {"W": W, "phi_mean": phi})
print(f"rendered W={W:g} phi={phi:g}: {record['parameters']['n_particles']} particles, dt={record['dt']:.4g}",
      file=sys.stderr)
