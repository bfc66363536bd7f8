"""Adapter: render one case's decks and parameter record (channel, heap or silo)."""
import json
import sys

sys.stderr = open(snakemake.log[0], "w")
from granflow.deck import render_case  # noqa: E402

scene = json.loads(snakemake.params.scene)
w = snakemake.wildcards
if scene["scene"] == "silo":
    case = {"R": float(w.R)}  # orifice radius in r_b
elif scene["scene"] == "heap":
    case = {"mixture": w.mix, "feed_rate": float(w.mdot) / 1000.0}  # directory names carry g/s
else:
    case = {"W": float(w.W), "phi_mean": float(w.phi)}
record = render_case(scene, snakemake.params.rung, snakemake.output.params.rsplit("/", 1)[0], case)
print(f"rendered {scene['scene']} {case}: dt = {record['dt']:.4g}", file=sys.stderr)
