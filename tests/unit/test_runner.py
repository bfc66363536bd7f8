"""Runner pieces that need no LAMMPS: log parsing, error lines, resumable thermo."""
import json
import shutil

import pandas as pd
import pytest

from granflow.runner import CaseRunner, error_line, loop_cost, parse_thermo, performance


def test_parse_thermo_and_performance(root):
    log = root / "tests" / "data" / "segment_two_runs.log"
    th = parse_thermo(log)
    assert list(th["Step"]) == [0, 2, 4]
    assert th["f_fwavg"].iloc[-1] == 0.5
    assert performance(log.read_text()) == [0.171]
    # "Loop time of 0.01 on 1 procs for 4 steps with 428 atoms": wall seconds and atom-steps
    assert loop_cost(log.read_text()) == (0.01, 4 * 428)


def test_loop_cost_sums_the_short_runs_of_run_every():
    text = ("Loop time of 0.5 on 2 procs for 50 steps with 100 atoms\n"
            "Loop time of 0.25 on 2 procs for 50 steps with 120 atoms\n")
    assert loop_cost(text) == (0.75, 50 * 100 + 50 * 120)


def test_error_line_quotes_lammps_error_not_echoed_commands(root):
    text = (root / "tests" / "data" / "segment_two_runs.log").read_text()
    assert error_line(text) is None  # an echoed `print "GRANFLOW_ERROR..."` command is not an error
    bad = text + "ERROR: Lost atoms: original 428 current 403 (src/thermo.cpp:494)\n"
    assert error_line(bad).startswith("ERROR: Lost atoms")
    assert error_line("GRANFLOW_ERROR: packed column top 9.9 reaches ...\n").startswith("GRANFLOW_ERROR")


def test_thermo_ignores_killed_segments(root, tmp_path):
    """A segment killed part-way (log but no restart) must not feed steady detection."""
    (tmp_path / "params.json").write_text(json.dumps({"protocol": {}}))
    logs = tmp_path / "run" / "logs"
    logs.mkdir(parents=True)
    src = root / "tests" / "data" / "segment_two_runs.log"
    for name in ("flow_001", "flow_002"):
        shutil.copy(src, logs / f"{name}.log")
    (tmp_path / "run" / "flow_001.restart").write_text("complete")
    runner = CaseRunner(tmp_path)
    th = runner.thermo("flow")
    assert set(th["segment"]) == {"flow_001"}
    assert runner.thermo("flow", upto=0).empty
    assert isinstance(th, pd.DataFrame) and len(th) == 3


def test_cpu_of_lammps_descendants_is_recorded_per_segment(tmp_path):
    """The runner charges a segment the CPU time of every process under mpirun (here a fake
    mpirun whose child burns 0.3 CPU-seconds), and keeps it beside the segment's log."""
    import stat
    import sys

    from granflow.runner import Tools

    fake = tmp_path / "mpirun"
    fake.write_text(
        f"#!{sys.executable}\n"
        "import subprocess, sys\n"
        "burn = 'import time\\nwhile time.process_time() < 0.3: pass'\n"
        "subprocess.run([sys.executable, '-c', burn], check=True)\n"
    )
    fake.chmod(fake.stat().st_mode | stat.S_IEXEC)
    (tmp_path / "params.json").write_text(json.dumps({"protocol": {}}))
    (tmp_path / "run").mkdir()
    runner = CaseRunner(tmp_path, tools=Tools(lmp="lmp", mpirun=str(fake)))
    runner._lammps("init.lmp", "init", {})
    usage = json.loads((tmp_path / "run" / "logs" / "init.usage.json").read_text())
    assert usage["cpu_s"] >= 0.3 and usage["peak_rss_mb"] > 0 and usage["wall_s"] >= usage["cpu_s"] * 0.5
    total = runner.usage()
    assert total["cpu_seconds"] == usage["cpu_s"] and total["peak_rss_mb"] == usage["peak_rss_mb"]


# ------------------------------------------------------------------------- the MPI launcher
def fake_program(path, record):
    """An executable that writes its argv and OMP_NUM_THREADS to ``record`` (a stand-in for srun)."""
    import stat
    import sys

    path.write_text(f"#!{sys.executable}\n"
                    "import json, os, sys\n"
                    f"open({str(record)!r}, 'w').write(json.dumps({{'argv': sys.argv, "
                    "'omp': os.environ.get('OMP_NUM_THREADS')}))\n")
    path.chmod(path.stat().st_mode | stat.S_IEXEC)
    return path


def test_launcher_forms_give_the_ranks_of_the_case(tmp_path):
    """Every accepted form becomes `<prog> -np N` (mpirun) or `srun [--mpi=T] -n N`, N from the case."""
    from granflow.runner import launcher_argv

    venv_mpirun = fake_program(tmp_path / "mpirun", tmp_path / "unused.json")
    assert launcher_argv("mpirun", 3, bindir=tmp_path) == [str(venv_mpirun), "-np", "3"]  # the venv's
    assert launcher_argv(f"{venv_mpirun} -np {{ranks}}", 3) == [str(venv_mpirun), "-np", "3"]
    assert launcher_argv("/opt/mpich/bin/mpiexec.hydra -n {ranks}", 2) == ["/opt/mpich/bin/mpiexec.hydra", "-np", "2"]
    assert launcher_argv("/usr/bin/srun --mpi=pmi2", 4) == ["/usr/bin/srun", "--mpi=pmi2", "-n", "4"]
    assert launcher_argv("/usr/bin/srun --mpi=pmix -n {ranks}", 4) == ["/usr/bin/srun", "--mpi=pmix", "-n", "4"]
    assert launcher_argv("/usr/bin/srun --ntasks={ranks}", 1) == ["/usr/bin/srun", "-n", "1"]
    # a path with a space is one program, never split
    (tmp_path / "my mpi").mkdir()
    spaced = fake_program(tmp_path / "my mpi" / "mpirun", tmp_path / "unused.json")
    assert launcher_argv(str(spaced), 2) == [str(spaced), "-np", "2"]


@pytest.mark.parametrize("spec, named", [
    ("bash -c 'lmp'", "'bash' is not mpirun, mpiexec or srun"),
    ("srun --mpi=pmi2; rm -rf ~", "--mpi=pmi2;"),            # never a shell: ';' is part of a word
    ("mpirun -np 4", "must be followed by {ranks}"),          # the case decides the ranks
    ("srun -n 8", "must be followed by {ranks}"),
    ("srun --mpi=bogus", "--mpi=bogus"),
    ("srun --overlap --mpi=pmi2", "--overlap"),
    ("mpirun --oversubscribe", "--oversubscribe"),
    ("srun $(reboot)", "$(reboot)"),
    ("", "empty"),
    ("srun 'unclosed", "cannot be split"),
])
def test_launcher_refuses_anything_else_naming_the_value(spec, named):
    from granflow.runner import LauncherError, launcher_argv

    with pytest.raises(LauncherError) as exc:
        launcher_argv(spec, 2)
    assert repr(spec) in str(exc.value) and named in str(exc.value)


def test_bad_launcher_is_refused_before_anything_runs(tmp_path):
    from granflow.runner import LauncherError, Tools

    (tmp_path / "params.json").write_text(json.dumps({"protocol": {}}))
    with pytest.raises(LauncherError, match="'sh -c true'"):
        CaseRunner(tmp_path, 2, tools=Tools(lmp="lmp", mpirun="mpirun", launcher="sh -c true"))
    assert not (tmp_path / "run").exists()


def test_profile_launcher_runs_lammps_and_is_recorded(tmp_path, monkeypatch):
    """The launcher a profile chooses (resource `mpi`) starts LAMMPS on the case's ranks, one
    OpenMP thread each whatever Snakemake exported; status.json names the host and launcher."""
    import socket

    from granflow.runner import Tools

    record = tmp_path / "argv.json"
    srun = fake_program(tmp_path / "srun", record)
    (tmp_path / "params.json").write_text(json.dumps({"protocol": {}, "guards": {"report_overlap": 0.01}}))
    (tmp_path / "run").mkdir()
    monkeypatch.setenv("OMP_NUM_THREADS", "3")  # as Snakemake sets it for a 3-thread job
    # inside an sbatch job of 3 CPUs, as SLURM's environment says
    monkeypatch.setenv("SLURM_JOB_ID", "41")
    monkeypatch.setenv("SLURM_CPUS_ON_NODE", "3")
    monkeypatch.setenv("SLURM_JOB_PARTITION", "debug")
    runner = CaseRunner(tmp_path, 3, tools=Tools.default(launcher=f"{srun} --mpi=pmi2"))
    runner._lammps("init.lmp", "init", {"segment": 0})
    seen = json.loads(record.read_text())
    assert seen["argv"][:5] == [str(srun), "--mpi=pmi2", "-n", "3", runner.tools.lmp]
    assert seen["argv"][5:7] == ["-in", str(tmp_path / "init.lmp")] and seen["omp"] == "1"
    status = runner._conclude(None, 0, 0, None)
    assert status["launcher"] == f"{srun} --mpi=pmi2 -n 3" and status["nprocs"] == 3
    assert status["host"] == socket.gethostname()
    assert status["slurm"] == {"job_id": "41", "cpus_on_node": 3, "partition": "debug"}
    assert json.loads((tmp_path / "run" / "status.json").read_text())["launcher"] == status["launcher"]
    # and the code that ran: this checkout's commit
    from granflow.provenance import git_state
    assert status["granflow_commit"] == git_state()["commit"] and len(status["granflow_commit"]) == 40


def test_granflow_mpirun_still_chooses_the_default_launcher(tmp_path, monkeypatch):
    from granflow.runner import Tools

    record = tmp_path / "argv.json"
    mpirun = fake_program(tmp_path / "mpirun", record)
    monkeypatch.setenv("GRANFLOW_MPIRUN", str(mpirun))
    tools = Tools.default()
    assert tools.launch(2) == [str(mpirun), "-np", "2"]
    # a profile's launcher wins over it
    assert Tools.default(launcher="srun --mpi=pmi2").launch(2)[-3:] == ["--mpi=pmi2", "-n", "2"]


def test_no_slurm_allocation_outside_slurm(monkeypatch):
    from granflow.runner import slurm_allocation

    for var in ("SLURM_JOB_ID", "SLURM_CPUS_ON_NODE", "SLURM_JOB_PARTITION"):
        monkeypatch.delenv(var, raising=False)
    assert slurm_allocation() is None


# ------------------------------------------------------------- thermo blocks with interjections
#: Two runs of a log. The first prints LAMMPS's lost-atoms warning (``thermo_modify lost warn``,
#: the two lines verbatim as LAMMPS 22 Jul 2025 prints them in the stock funnel example), a
#: second warning and a fix halt message between its rows; the second run follows as usual.
LOG_WITH_WARNINGS = """\
LAMMPS (22 Jul 2025 - Update 4)
thermo_modify   flush yes lost warn
run             4000
Per MPI rank memory allocation (min/avg/max) = 18.15 | 19.31 | 20.47 Mbytes
   Step          CPU          Atoms        KinEng    
    224000   38.290181           2000   1245.6525    
    225000   38.587386           2000   1296.5979    
WARNING: Lost atoms: original 2000 current 1998
For more information see https://docs.lammps.org/err0008 (src/src/thermo.cpp:532)
    226000   38.898249           1998   1342.9602    
    227000   39.199411           1998   1396.6773    
WARNING: Lost atoms: original 1998 current 1997
For more information see https://docs.lammps.org/err0008 (src/src/thermo.cpp:532)
    228000   39.525993           1997   1449.0657    
Fix halt condition for fix-id settled met on step 228000 with value 9.399460806170515e-05
Loop time of 39.6 on 2 procs for 4000 steps with 1997 atoms

Performance: 100.0 tau/day, 400.0 timesteps/s, 0.171 Matom-step/s
WARNING: Lost atoms: original 1997 current 1990 (src/thermo.cpp:494)
   Step          CPU          Atoms        KinEng    
    228000   0                   1997   1449.0657    
    229000   0.30399             1989   1467.4693    
Loop time of 0.3 on 2 procs for 1000 steps with 1989 atoms
"""


def test_parse_thermo_skips_warnings_inside_a_block(tmp_path):
    """Warnings LAMMPS prints between the rows of a run do not end the block: every row is kept,
    with its values, and the next run's block is read too. The warning after ``Loop time`` (between
    blocks) is ignored as well."""
    log = tmp_path / "warned.log"
    log.write_text(LOG_WITH_WARNINGS)
    th = parse_thermo(log)
    assert list(th.columns) == ["Step", "CPU", "Atoms", "KinEng"]
    # 5 rows of the first run (two lost-atoms warnings and a halt message among them), 2 of the second
    assert list(th["Step"]) == [224000, 225000, 226000, 227000, 228000, 228000, 229000]
    assert list(th["Atoms"]) == [2000, 2000, 1998, 1998, 1997, 1997, 1989]
    assert list(th["KinEng"]) == [1245.6525, 1296.5979, 1342.9602, 1396.6773, 1449.0657, 1449.0657, 1467.4693]
    assert th["CPU"].iloc[3] == 39.199411 and th["CPU"].iloc[5] == 0.0


def test_parse_thermo_of_a_run_cut_short_keeps_its_rows(tmp_path):
    """A killed run has no ``Loop time``: its rows up to the end of the log are kept, a torn last line
    (fewer words than the header) and an ERROR line are not rows."""
    text = LOG_WITH_WARNINGS.split("Loop time of 0.3")[0]
    log = tmp_path / "killed.log"
    log.write_text(text + "    230000   0.6\nERROR: Lost atoms: original 1989 current 1980 (src/thermo.cpp:494)\n")
    th = parse_thermo(log)
    assert list(th["Step"]) == [224000, 225000, 226000, 227000, 228000, 228000, 229000]


def test_thermo_of_segments_keeps_rows_after_a_warning(tmp_path):
    """The runner's view of completed segments (steady detection, thermo.csv) keeps the rows after
    a warning; the repeated first step of the second run is dropped as for any segment."""
    (tmp_path / "params.json").write_text(json.dumps({"protocol": {}}))
    logs = tmp_path / "run" / "logs"
    logs.mkdir(parents=True)
    (logs / "flow_001.log").write_text(LOG_WITH_WARNINGS)
    (tmp_path / "run" / "flow_001.restart").write_text("complete")
    th = CaseRunner(tmp_path).thermo("flow")
    assert list(th["Step"]) == [224000, 225000, 226000, 227000, 228000, 229000]
    assert th["Atoms"].iloc[-1] == 1989


def test_loop_totals_counts_every_run_and_skips_lines_without_atoms():
    """Seconds, steps and atom-steps summed over each run's loop line; a line that names no atoms adds steps
    but no atom-steps; a line inside other text (not at a line's start) is not LAMMPS's."""
    from granflow.runner import loop_totals

    text = ("Loop time of 0.5 on 1 procs for 50 steps with 100 atoms\n"
            "Loop time of 0.25 on 2 procs for 30 steps\n"
            "log: Loop time of 9 on 1 procs for 999 steps with 9 atoms\n"
            "Loop time of 0.25 on 1 procs for 50 steps with 120 atoms\n")
    assert loop_totals(text) == (1.0, 130.0, 50 * 100 + 50 * 120)
    assert loop_totals("no runs\n") == (0.0, 0.0, 0.0)
