"""Adapter: validation/README.md from every scene record in its folder (granflow.validation.write_readme)."""
import sys
from pathlib import Path

sys.stderr = open(snakemake.log[0], "w")
from granflow import validation  # noqa: E402
from granflow.intermediates import read_json, report_plainly  # noqa: E402

report_plainly()
folder = Path(snakemake.output.readme).parent
# write_readme reads every record in the folder (this campaign's and those committed before)
for summary in sorted(folder.glob("*/summary.json")):
    read_json(summary, keys=("checks", "cases", "rung"))
text = validation.write_readme(folder)
print(text, file=sys.stderr)
