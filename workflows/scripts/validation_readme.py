"""Adapter: validation/README.md from every scene record in its folder (granflow.validation.write_readme)."""
import sys
from pathlib import Path

sys.stderr = open(snakemake.log[0], "w")
from granflow import validation  # noqa: E402

text = validation.write_readme(Path(snakemake.output.readme).parent)
print(text, file=sys.stderr)
