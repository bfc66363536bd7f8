"""What ``granflow cg`` (:mod:`postproc.cg`) checks of its inputs before it trusts their numbers.

:func:`check_input_files` says what an input is when it is not a readable, non-empty
regular file (missing, a dangling link, a directory, a FIFO, a device, empty,
unreadable) and refuses one file given twice; :func:`check_box` refuses a frame
whose box has a bound that is not finite or a low bound not below its high one;
:class:`StepOrder` refuses (or, when asked, drops and counts) a frame whose
timestep is not after the one before it, across files, so that no frame is
counted twice.
"""
from __future__ import annotations

import os
import stat
from typing import Sequence

import numpy as np

from .cg_output import CGInputError
from .safe_write import describe_mode

_BOUNDS = ("xlo", "xhi", "ylo", "yhi", "zlo", "zhi")


def _kind_refusal(path: str, role: str) -> str | None:
    """Why ``path`` cannot be read as a dump, or None when it is a readable, non-empty regular file."""
    try:
        st = os.stat(path)
    except FileNotFoundError:
        if os.path.islink(path):
            return f"{role} {path} is a symbolic link to {os.readlink(path)}, which does not exist"
        return f"{role} {path} does not exist"
    except OSError as exc:
        return f"{role} {path} cannot be looked at: {exc.strerror}"
    if not stat.S_ISREG(st.st_mode):
        return (f"{role} {path} is {describe_mode(st.st_mode)}, not a regular file: granflow cg reads each dump "
                f"more than once (the first frames, then all of them); give a dump file")
    if st.st_size == 0:
        return f"{role} {path} is empty (0 bytes): it holds no frame"
    if not os.access(path, os.R_OK):
        return f"{role} {path} cannot be read: permission denied"
    return None


def check_input_files(paths: Sequence[str], contact_paths: Sequence[str]) -> None:
    """Refuse an input that is not a readable, non-empty regular file, or a file given twice.

    Parameters
    ----------
    paths : sequence of str
        The atom dumps.
    contact_paths : sequence of str
        The contact dumps.

    Raises
    ------
    CGInputError
        Naming the file and what it is (missing, a symbolic link to nothing, a
        directory, a FIFO, a character or block device such as ``/dev/zero``, a
        socket, empty, unreadable), or the two places a file is given (by its
        name or another name of it: a link, a hard link); its frames would be
        counted twice.
    """
    seen: dict[tuple[int, int], tuple[str, str]] = {}
    inputs = [(p, "dump file", f"atom dump {k + 1}") for k, p in enumerate(paths)]
    inputs += [(p, "contact dump file", f"contact dump {k + 1}") for k, p in enumerate(contact_paths)]
    for path, kind, place in inputs:
        why = _kind_refusal(path, kind)
        if why:
            raise CGInputError(why)
        st = os.stat(path)
        first_path, first_place = seen.setdefault((st.st_dev, st.st_ino), (path, place))
        if first_place != place:
            named = "" if first_path == path else f" ({first_path}, another name of the same file)"
            raise CGInputError(f"{path} is given twice, as {first_place}{named} and as {place}: its frames would "
                               f"be counted twice; give each dump once")


def box_refusal(box) -> str | None:
    """Why a frame's box is impossible, or None.

    Parameters
    ----------
    box : array_like, shape (3, 2)
        ``[[xlo, xhi], [ylo, yhi], [zlo, zhi]]``, length units.

    Returns
    -------
    str or None
        Names the bound: one that is NaN or infinite, or a low bound that is
        not below its high bound (an inverted or empty box).
    """
    box = np.asarray(box, dtype=float).reshape(3, 2)
    flat = box.ravel()
    bad = np.flatnonzero(~np.isfinite(flat))
    if bad.size:
        k = int(bad[0])
        return f"box bound {_BOUNDS[k]} = {flat[k]:g} is not allowed: allowed a finite number"
    for axis, (lo, hi) in zip("xyz", box):
        if not lo < hi:
            return (f"box bounds {axis}lo = {lo:g}, {axis}hi = {hi:g} are not allowed: allowed {axis}lo < {axis}hi "
                    f"(the box is inverted or empty)")
    return None


def check_box(path: str, box, timestep: int, what: str = "frame") -> None:
    """Refuse a frame whose box is impossible (:func:`box_refusal`).

    Parameters
    ----------
    path : str
        The dump, to name.
    box : array_like, shape (3, 2)
    timestep : int
        The frame's step, to name.
    what : str
        What the frame is (``"frame"``, ``"contact frame"``).

    Raises
    ------
    CGInputError
        Naming the file, the step and the bound.
    """
    why = box_refusal(box)
    if why:
        raise CGInputError(f"{path}: {what} at step {timestep}: {why}")


class StepOrder:
    """The timesteps of a sequence of frames, which must increase from frame to frame and file to file.

    :meth:`admit` refuses a frame whose step is not after the last admitted one
    (a step repeated or going back: a dump given twice under two names, dumps
    out of time order, or a restarted run's dump overlapping the one before), or
    with ``drop`` leaves it out and counts it: the frame first read for a step
    is kept.

    Parameters
    ----------
    drop : bool
        Leave such frames out instead of refusing them.
    what : str
        What a frame is, in messages (``"frame"``, ``"contact frame"``).

    Attributes
    ----------
    dropped : int
        Frames left out.
    first_dropped : dict or None
        ``{"path", "step", "after_step"}`` of the first one left out.
    """

    def __init__(self, drop: bool, what: str = "frame") -> None:
        self.drop = drop
        self.what = what
        self.dropped = 0
        self.first_dropped: dict | None = None
        self._last: tuple[str, int] | None = None

    def admit(self, path: str, timestep: int) -> bool:
        """Whether the frame at ``timestep`` of ``path`` is kept (True), or left out (False, with ``drop``).

        Parameters
        ----------
        path : str
            Its dump.
        timestep : int
            Its step.

        Returns
        -------
        bool

        Raises
        ------
        CGInputError
            Without ``drop``, for a step not after the last one kept, naming both
            frames and their files.
        """
        step = int(timestep)
        if self._last is None or step > self._last[1]:
            self._last = (path, step)
            return True
        last_path, last_step = self._last
        if not self.drop:
            where = "" if last_path == path else f" of {last_path}"
            how = "repeats" if step == last_step else "goes back from"
            raise CGInputError(
                f"{path}: {self.what} at step {step} {how} step {last_step}{where}: timesteps must increase from "
                f"frame to frame and from file to file (a dump given twice, dumps out of time order, or a "
                f"restarted run's dump overlapping the one before would count frames twice); "
                f"--drop-repeated-steps leaves such frames out and counts them")
        self.dropped += 1
        if self.first_dropped is None:
            self.first_dropped = {"path": path, "step": step, "after_step": last_step}
        return False

    def record(self) -> dict:
        """What was left out, for ``meta.json``: ``{"frames": n, "first": {...} or None}``."""
        return {"frames": self.dropped, "first": self.first_dropped}


__all__ = ["StepOrder", "box_refusal", "check_box", "check_input_files"]
