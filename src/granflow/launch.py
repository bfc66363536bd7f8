"""How a run starts LAMMPS: the MPI launcher's argv and the executables of a run.

``GRANFLOW_LMP`` and ``GRANFLOW_MPIRUN`` name the executables; a value that is not an executable
LAMMPS (its ``-h`` banner) or MPI launcher is refused (:class:`ToolError`, exit 2), never replaced by
what is on PATH. The LAMMPS that runs is recorded with its version (``status.json``'s ``lammps``).
"""
from __future__ import annotations

import os
import re
import shlex
import shutil
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

from .preflight import PreflightError


class LauncherError(PreflightError):
    """An MPI launcher that is not one of the forms :func:`launcher_argv` accepts (exit 2)."""


class ToolError(PreflightError):
    """``GRANFLOW_LMP`` or ``GRANFLOW_MPIRUN`` naming no executable LAMMPS or MPI launcher (exit 2)."""


#: the first line of LAMMPS's ``-h`` text, followed by its version (e.g. "22 Jul 2025 - Update 4")
LAMMPS_BANNER = "Large-scale Atomic/Molecular Massively Parallel Simulator - "
#: seconds ``lmp -h`` may take (0.45 s measured for the wheel's lmp on a loaded 2-core machine)
BANNER_TIMEOUT_S = 60.0


def executable(value: str, variable: str) -> str:
    """The program ``value`` (a path, or a name found on PATH) names, if it is an executable regular
    file; else :class:`ToolError` naming ``variable`` and what the value is."""
    path = Path(value) if "/" in value else Path(shutil.which(value) or value)
    where = f"{variable}={value!r}"
    if not path.exists():
        found = "no such file" if "/" in value else "not found on PATH"
        raise ToolError(f"{where}: {found}; give the path of an executable (unset it for the venv's)")
    if not path.is_file():
        raise ToolError(f"{where} is {'a directory' if path.is_dir() else 'not a regular file'}, not an executable")
    if not os.access(path, os.X_OK):
        raise ToolError(f"{where} is not executable (chmod +x it, or name another)")
    return str(path)


def lammps_version(lmp: str, variable: str = "GRANFLOW_LMP") -> str:
    """LAMMPS's version, from the banner of ``lmp -h``; :class:`ToolError` if ``lmp`` prints none."""
    try:
        out = subprocess.run([lmp, "-h"], stdin=subprocess.DEVNULL, capture_output=True, text=True,
                             errors="replace", timeout=BANNER_TIMEOUT_S).stdout
    except subprocess.TimeoutExpired:
        raise ToolError(f"{variable}={lmp!r} is not LAMMPS: '{lmp} -h' did not end within "
                        f"{BANNER_TIMEOUT_S:.0f} s") from None
    except OSError as exc:
        raise ToolError(f"{variable}={lmp!r} cannot be run: {exc.strerror or exc}") from None
    for line in out.splitlines():
        if line.strip().startswith(LAMMPS_BANNER):
            return line.strip()[len(LAMMPS_BANNER):].strip()
    first = next((line.strip() for line in out.splitlines() if line.strip()), "nothing")
    raise ToolError(f"{variable}={lmp!r} is not LAMMPS: '{lmp} -h' printed {first[:80]!r}, not LAMMPS's "
                    f"banner {LAMMPS_BANNER.strip(' -')!r}")


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
    ``version`` is LAMMPS's (from its ``-h`` banner), known when :meth:`default` chose it.
    """

    lmp: str
    mpirun: str
    launcher: str | None = None
    version: str | None = None

    @classmethod
    def default(cls, launcher: str | None = None) -> "Tools":
        """The venv's lmp and mpirun (else those on PATH), or those ``GRANFLOW_LMP`` and
        ``GRANFLOW_MPIRUN`` name, which must be an executable LAMMPS and an MPI launcher
        (:class:`ToolError` otherwise: no fallback to PATH)."""
        bindir = Path(sys.executable).parent
        lmp, mpirun = os.environ.get("GRANFLOW_LMP"), os.environ.get("GRANFLOW_MPIRUN")
        if lmp:
            lmp = executable(lmp, "GRANFLOW_LMP")
        else:
            lmp = str(bindir / "lmp") if (bindir / "lmp").exists() else shutil.which("lmp") or str(bindir / "lmp")
        if mpirun:
            try:
                words = [mpirun] if Path(mpirun).is_file() else shlex.split(mpirun)
            except ValueError:
                words = []  # launcher_argv names the fault
            if words:
                executable(words[0], "GRANFLOW_MPIRUN")
            try:  # an executable that is not an MPI launcher (e.g. /bin/sh) is refused
                launcher_argv(mpirun, 1)
            except LauncherError as exc:
                raise ToolError(f"GRANFLOW_MPIRUN: {exc}") from None
        else:
            mpirun = str(bindir / "mpirun")
            if not Path(mpirun).exists():
                mpirun = shutil.which("mpirun") or mpirun
        version = lammps_version(lmp, "GRANFLOW_LMP" if os.environ.get("GRANFLOW_LMP") else "lmp")
        return cls(lmp=lmp, mpirun=mpirun, launcher=launcher or None, version=version)

    @property
    def spec(self) -> str:
        """The launcher in force: the chosen one, else the default mpirun."""
        return self.launcher or self.mpirun

    def launch(self, ranks: int) -> list[str]:
        """argv prefix that starts ``ranks`` ranks (raises :class:`LauncherError` for a bad launcher)."""
        return launcher_argv(self.spec, ranks)

