"""How a run starts LAMMPS: the MPI launcher's argv and the executables of a run.

Moved from :mod:`granflow.runner` unchanged; the runner imports it.
"""
from __future__ import annotations

import os
import re
import shlex
import shutil
import sys
from dataclasses import dataclass
from pathlib import Path


class LauncherError(ValueError):
    """An MPI launcher that is not one of the forms :func:`launcher_argv` accepts."""


#: ``srun --mpi=`` plugin types a launcher may name (Slurm's PMI flavours)
SRUN_MPI_TYPES = ("pmi2", "pmix", "pmix_v2", "pmix_v3", "pmix_v4", "pmix_v5", "cray_shasta", "none")
#: program names of the mpirun-like launchers (Debian's alternatives: mpirun.mpich, mpiexec.hydra, ...)
_MPIRUN_NAMES = ("mpirun", "mpiexec")
RANKS = "{ranks}"


def launcher_argv(spec: str, ranks: int, bindir: Path | None = None) -> list[str]:
    """The argv that starts ``ranks`` MPI ranks, from a launcher ``spec``; refuses anything else.

    Accepted forms (the rank count always comes from the case, never from the text):

    - ``mpirun`` or ``mpiexec``, bare or as a path (also ``mpirun.mpich``, ``mpiexec.hydra``, ...),
      optionally followed by ``-np {ranks}`` or ``-n {ranks}``: runs ``<prog> -np N``;
    - ``srun``, bare or as a path, optionally with ``--mpi=TYPE`` (TYPE in :data:`SRUN_MPI_TYPES`)
      and ``-n {ranks}`` / ``--ntasks={ranks}``: runs ``srun [--mpi=TYPE] -n N`` (a job step of
      the allocation it runs in).

    A bare ``mpirun``/``mpiexec`` is the one beside this Python (the venv's) when it exists,
    a bare ``srun`` the one on PATH. The text is split like a shell would split it but never
    run by a shell; any other program, option or word raises :class:`LauncherError` naming it.
    """
    if ranks < 1:
        raise LauncherError(f"MPI launcher {spec!r}: {ranks} ranks requested, at least 1 needed")
    try:
        # a path to an existing program is one word even with spaces in it
        words = [spec] if spec and Path(spec).is_file() else shlex.split(spec or "")
    except ValueError as exc:
        raise LauncherError(f"MPI launcher {spec!r} cannot be split into words: {exc}") from None
    if not words:
        raise LauncherError(f"MPI launcher {spec!r} is empty: use e.g. 'mpirun' or 'srun --mpi=pmi2'")
    prog, rest = words[0], words[1:]
    name = Path(prog).name
    bindir = bindir or Path(sys.executable).parent

    def refuse(why: str) -> LauncherError:
        return LauncherError(
            f"MPI launcher {spec!r} refused: {why}. Accepted: 'mpirun' or 'mpiexec' (a path, optionally "
            f"'-np {{ranks}}'), or 'srun' optionally with '--mpi=TYPE' (TYPE one of {', '.join(SRUN_MPI_TYPES)}) "
            f"and '-n {{ranks}}'")

    def rank_flag(words: list[str], flags: tuple[str, ...]) -> list[str]:
        """Remove one optional ``FLAG {ranks}`` (or ``--ntasks={ranks}``) from the words."""
        out, i = [], 0
        while i < len(words):
            w = words[i]
            if w in flags:
                if i + 1 >= len(words) or words[i + 1] != RANKS:
                    got = words[i + 1] if i + 1 < len(words) else "nothing"
                    raise refuse(f"{w} must be followed by {RANKS} (the case decides the ranks), not {got!r}")
                i += 2
                continue
            if w.startswith("--ntasks="):
                if w != "--ntasks=" + RANKS:
                    raise refuse(f"{w!r}: the rank count must be {RANKS}")
                i += 1
                continue
            out.append(w)
            i += 1
        return out

    if re.fullmatch(r"(mpirun|mpiexec)([._-][A-Za-z0-9_.-]+)?", name):
        left = rank_flag(rest, ("-np", "-n"))
        if left:
            raise refuse(f"unexpected {' '.join(left)!r} after {prog}")
        if "/" not in prog and name in _MPIRUN_NAMES and (bindir / name).exists():
            prog = str(bindir / name)
        elif "/" not in prog:
            prog = shutil.which(prog) or prog
        return [prog, "-np", str(ranks)]
    if name == "srun":
        left = rank_flag(rest, ("-n", "--ntasks"))
        mpi = [w for w in left if w.startswith("--mpi=")]
        other = [w for w in left if not w.startswith("--mpi=")]
        if other:
            raise refuse(f"unexpected {' '.join(other)!r} after srun")
        if len(mpi) > 1 or (mpi and mpi[0].split("=", 1)[1] not in SRUN_MPI_TYPES):
            raise refuse(f"{' '.join(mpi)!r} is not one --mpi=TYPE with a known TYPE")
        if "/" not in prog:
            prog = shutil.which(prog) or prog
        return [prog, *mpi, "-n", str(ranks)]
    raise refuse(f"{prog!r} is not mpirun, mpiexec or srun")


@dataclass
class Tools:
    """The executables of a run: LAMMPS and the MPI launcher (the venv's by default).

    ``mpirun`` is the default launcher: ``GRANFLOW_MPIRUN`` (a path to mpirun, or any form
    :func:`launcher_argv` accepts), else the venv's ``mpirun``. ``launcher``, when given (the
    ``mpi`` resource of a workflow profile, see ``profiles/slurm``), replaces it: e.g.
    ``srun --mpi=pmi2`` inside a SLURM allocation. Either is checked when the runner is built.
    """

    lmp: str
    mpirun: str
    launcher: str | None = None

    @classmethod
    def default(cls, launcher: str | None = None) -> "Tools":
        bindir = Path(sys.executable).parent
        lmp = os.environ.get("GRANFLOW_LMP") or str(bindir / "lmp")
        mpirun = os.environ.get("GRANFLOW_MPIRUN") or str(bindir / "mpirun")
        if not Path(lmp).exists():
            lmp = shutil.which("lmp") or lmp
        if "/" in mpirun and not Path(mpirun).exists():
            mpirun = shutil.which("mpirun") or mpirun
        return cls(lmp=lmp, mpirun=mpirun, launcher=launcher or None)

    @property
    def spec(self) -> str:
        """The launcher in force: the chosen one, else the default mpirun."""
        return self.launcher or self.mpirun

    def launch(self, ranks: int) -> list[str]:
        """argv prefix that starts ``ranks`` ranks (raises :class:`LauncherError` for a bad launcher)."""
        return launcher_argv(self.spec, ranks)

