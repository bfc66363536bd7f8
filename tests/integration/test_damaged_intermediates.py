"""Damaged intermediates through Snakemake (issue 31, item 3), on one tiny smoke channel case.

Junk in analysis/scalars.json used to be unseen ("Nothing to be done"), and a forced table then
failed with a JSONDecodeError traceback and lost the good table.csv; junk in run/status.json lost
the earlier analysis/. Now the next call refuses in one line naming the file and the command that
rebuilds it, that command works, and the last good table and analysis stay in place."""
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = pytest.mark.lammps
BIN = Path(sys.executable).parent


def refusal(proc: subprocess.CompletedProcess, path: Path) -> list[str]:
    """The one line naming ``path``; returns its rebuild command as words (run from our venv)."""
    assert proc.returncode == 1, proc.stderr[-3000:]
    lines = [line for line in proc.stderr.splitlines() if line.startswith("granflow: damaged intermediate:")]
    assert len(lines) == 1 and f"{path}: " in lines[0], proc.stderr[-3000:]
    assert "Traceback" not in proc.stderr
    words = shlex.split(lines[0].split("rebuild it with: ", 1)[1].split(";")[0])
    assert words[0] == "snakemake"
    return [str(BIN / "snakemake")] + words[1:]


def test_damaged_scalars_and_status_are_refused_by_name_and_rebuilt(tmp_path, root, scenes_off, short_channel_file):
    results = tmp_path / "results"
    # a shorter smoke rung (the whole test stays under a minute): 4 + 3 time units, 6 frames
    short_channel_file(tmp_path / "channel.yaml")
    cfg = tmp_path / "config.yaml"
    cfg.write_text(f"rung: smoke\nresults_dir: {results}\nscenes:\n" + scenes_off(keep=("channel",))
                   + "  channel:\n    enabled: true\n"
                   f"    scene_file: {tmp_path / 'channel.yaml'}\n    sweep:\n      W: [10]\n      phi_mean: [0.58]\n")
    scene = results / "channel" / "smoke"
    case = scene / "W~10" / "phi~0.58"
    table, scalars, status = scene / "table.csv", case / "analysis" / "scalars.json", case / "run" / "status.json"
    targets = [str(table), f"{table}.sha256"]
    base = [str(BIN / "snakemake"), "--snakefile", str(root / "Snakefile"), "--directory", str(tmp_path),
            "--configfile", str(cfg), "--cores", "2"]

    def snakemake(cmd):
        return subprocess.run(cmd + targets, capture_output=True, text=True, timeout=600)

    first = snakemake(base)
    assert first.returncode == 0, first.stderr[-3000:]
    good_table = table.read_bytes()
    good_analysis = {p.name: p.read_bytes() for p in scalars.parent.iterdir()}

    # junk in scalars.json: the next call sees it (its time stamp) and the table refuses it
    scalars.write_text("junk")
    proc = snakemake(base)
    rebuild = refusal(proc, scalars)
    assert f"the last good {table} stays in place" in proc.stderr
    assert table.read_bytes() == good_table and not Path(f"{table}.sha256").exists()
    assert "Traceback" not in (scene / "logs" / "table.log").read_text()
    # the table stays due (its checksum file, written last, is missing): the refusal repeats
    # at every call until the analysis is rebuilt
    dry = snakemake(base + ["--dry-run"])
    assert f"Missing output files: {table}.sha256" in dry.stdout + dry.stderr, dry.stdout[-3000:]
    # the command the refusal names rebuilds the analysis and the table
    fixed = snakemake(rebuild)
    assert fixed.returncode == 0, fixed.stderr[-3000:]
    assert table.read_bytes() == good_table  # the same dumps, the same numbers
    assert {p.name: p.read_bytes() for p in scalars.parent.iterdir()} == good_analysis

    # junk in status.json: the analysis refuses it and the last good analysis/ stays
    status.write_text('{"status": "steady", "dum')
    proc = snakemake(base)
    rebuild = refusal(proc, status)
    assert f"the last good {case / 'analysis'} stays in place" in proc.stderr
    assert scalars.read_bytes() == good_analysis["scalars.json"]
    assert (case / "analysis" / "profile.csv").read_bytes() == good_analysis["profile.csv"]
    assert table.read_bytes() == good_table
    # the named command reruns the simulate job (the run resumes after its last complete segment,
    # so LAMMPS does not run again), then the analysis and the table: a dry run here, to stay
    # under a minute
    dry = snakemake(rebuild + ["--dry-run"])
    assert dry.returncode == 0, dry.stderr[-3000:]
    plan = dry.stdout + dry.stderr
    assert "rule simulate:" in plan and "Forced execution" in plan and "rule analyse:" in plan, plan[-3000:]
