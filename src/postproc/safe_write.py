"""Write output files so that a failure never costs the earlier ones, and never through a link.

Every file is written under a temporary name in its own directory
(``.<name>.<random>.tmp``, created with ``O_EXCL``, so nothing planted there is
followed) and moved into place with :func:`os.replace` only when all the files of
the set are complete (:class:`StagedFiles`). Until then the earlier files of the
same names stay as they were: a full disk, a crash or Ctrl-C leaves either the old
set or the new one, never a truncated file beside an old one. A rename replaces
whatever sits at the name itself, so a symbolic link there is replaced, never
followed; :func:`output_refusal` lets a caller refuse such a link (or a directory,
a FIFO, a device) before any work is done. A write that fails raises
:class:`OutputWriteError`, which names the file it was writing by its final name.

Used by ``granflow cg`` (:func:`postproc.cg_output.write_result`) and
``granflow render`` (:func:`granflow.deck.render_case`).
"""
from __future__ import annotations

import errno
import os
import stat
import tempfile
from contextlib import contextmanager
from pathlib import Path
from typing import Callable, Iterator


class OutputWriteError(OSError):
    """An output file that could not be written (a full disk, a lost permission, ...).

    ``errno`` and ``strerror`` are the operating system's; ``filename`` is the
    output's final path (not the temporary one); ``str()`` is one line saying
    what happened and that the earlier files are kept.
    """

    def __str__(self) -> str:
        return (f"could not write {self.filename}: {self.strerror} ({errno.errorcode.get(self.errno, self.errno)}); "
                f"nothing was moved into place: the earlier files in {Path(self.filename).parent} are unchanged")


def output_refusal(path: str | os.PathLike) -> str | None:
    """Why ``path`` cannot take an output file, or None when it can (absent, or a regular file).

    Parameters
    ----------
    path : str or os.PathLike
        Where an output file goes.

    Returns
    -------
    str or None
        ``"<path> is a symbolic link to <target>"`` (dangling or not), or
        ``"<path> is a directory"`` (a FIFO, a device, a socket), without advice;
        None for a regular file or nothing there.
    """
    try:
        st = os.lstat(path)
    except FileNotFoundError:
        return None
    if stat.S_ISLNK(st.st_mode):
        target = os.readlink(path)
        dangling = "" if os.path.exists(path) else ", which does not exist"
        return f"{path} is a symbolic link to {target}{dangling}"
    if stat.S_ISREG(st.st_mode):
        return None
    return f"{path} is {describe_mode(st.st_mode)}, not a regular file"


def describe_mode(mode: int) -> str:
    """What a file of ``st_mode`` ``mode`` is, in words (``"a directory"``, ``"a FIFO (named pipe)"`` ...).

    Parameters
    ----------
    mode : int
        ``os.stat(...).st_mode``.

    Returns
    -------
    str
    """
    kinds = ((stat.S_ISDIR, "a directory"), (stat.S_ISFIFO, "a FIFO (named pipe)"),
             (stat.S_ISCHR, "a character device"), (stat.S_ISBLK, "a block device"),
             (stat.S_ISSOCK, "a socket"), (stat.S_ISLNK, "a symbolic link"), (stat.S_ISREG, "a regular file"))
    return next((what for test, what in kinds if test(mode)), f"a special file (mode {mode:o})")


def _umask() -> int:
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


class StagedFiles:
    """Files of one directory written under temporary names and moved into place together.

    :meth:`write` writes one file through a writer given its temporary path;
    :meth:`commit` moves every file into place (:func:`os.replace`, which
    replaces a link at the name instead of following it); :meth:`discard` removes
    the temporary files. :func:`staged_files` commits on success and discards on
    any exception. Files get the permissions of a newly created file (0666 less
    the umask) and are flushed to disk before they are moved.

    Parameters
    ----------
    directory : str or os.PathLike
        Where the files go; created (with its parents) if absent.
    """

    def __init__(self, directory: str | os.PathLike) -> None:
        self.directory = Path(directory)
        self._staged: dict[str, Path] = {}

    def write(self, name: str, writer: Callable[[Path], object]) -> Path:
        """Write the file ``name`` by calling ``writer(temporary_path)``.

        Parameters
        ----------
        name : str
            The file's name in :attr:`directory` (no directory part).
        writer : callable
            ``writer(path)`` writes the whole file at ``path`` (a new, empty file
            with the final name's suffix).

        Returns
        -------
        pathlib.Path
            The final path (the file is there only after :meth:`commit`).

        Raises
        ------
        OutputWriteError
            When the directory cannot be made or ``writer`` raises an
            :class:`OSError`, naming the final path; the temporary file is removed.
        """
        if Path(name).name != name or name in ("", ".", ".."):
            raise ValueError(f"output name {name!r} must be a file name without a directory part")
        final = self.directory / name
        try:
            self.directory.mkdir(parents=True, exist_ok=True)
            fd, tmp = tempfile.mkstemp(dir=self.directory, prefix=f".{name}.", suffix=".tmp" + Path(name).suffix)
        except OSError as exc:
            raise OutputWriteError(exc.errno, exc.strerror, str(final)) from None
        tmp = Path(tmp)
        os.close(fd)
        self._staged[name] = tmp
        try:
            writer(tmp)
            os.chmod(tmp, 0o666 & ~_umask())
            with open(tmp, "rb+") as fh:
                os.fsync(fh.fileno())
        except OSError as exc:
            self._staged.pop(name)
            tmp.unlink(missing_ok=True)
            raise OutputWriteError(exc.errno, exc.strerror or str(exc), str(final)) from None
        return final

    def commit(self) -> dict[str, Path]:
        """Move every written file into place, in the order written.

        Returns
        -------
        dict of str to pathlib.Path
            The final path of each file, by name.

        Raises
        ------
        OutputWriteError
            When a rename fails (the files not yet moved are removed).
        """
        done = {}
        try:
            for name, tmp in list(self._staged.items()):
                final = self.directory / name
                try:
                    os.replace(tmp, final)
                except OSError as exc:
                    raise OutputWriteError(exc.errno, exc.strerror, str(final)) from None
                self._staged.pop(name)
                done[name] = final
        finally:
            self.discard()
        _sync_directory(self.directory)
        return done

    def discard(self) -> None:
        """Remove the temporary files not moved into place."""
        for tmp in self._staged.values():
            tmp.unlink(missing_ok=True)
        self._staged.clear()


def _sync_directory(directory: Path) -> None:
    """Flush the directory's entries (the renames) to disk, where the system allows it."""
    try:
        fd = os.open(directory, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


@contextmanager
def staged_files(directory: str | os.PathLike) -> Iterator[StagedFiles]:
    """A :class:`StagedFiles` for ``directory``, committed when the block ends normally, else discarded.

    Parameters
    ----------
    directory : str or os.PathLike

    Yields
    ------
    StagedFiles
    """
    files = StagedFiles(directory)
    try:
        yield files
    except BaseException:
        files.discard()
        raise
    files.commit()


def write_file(path: str | os.PathLike, writer: Callable[[Path], object]) -> Path:
    """Write one file by ``writer(temporary_path)`` and move it into place (replacing a link there, never following it).

    Parameters
    ----------
    path : str or os.PathLike
        The file's final path.
    writer : callable
        ``writer(path)`` writes the whole file at ``path``.

    Returns
    -------
    pathlib.Path
        ``path``.

    Raises
    ------
    OutputWriteError
        When it cannot be written (the earlier file stays).
    """
    path = Path(path)
    with staged_files(path.parent) as files:
        files.write(path.name, writer)
    return path


def write_text(path: str | os.PathLike, text: str) -> Path:
    """Write one text file in UTF-8 under a temporary name and move it into place (:func:`write_file`).

    Parameters
    ----------
    path : str or os.PathLike
    text : str

    Returns
    -------
    pathlib.Path

    Raises
    ------
    OutputWriteError
        When it cannot be written (the earlier file stays).
    """
    return write_file(path, lambda tmp: tmp.write_text(text, encoding="utf-8"))


__all__ = ["OutputWriteError", "StagedFiles", "describe_mode", "output_refusal", "staged_files", "write_file",
           "write_text"]
