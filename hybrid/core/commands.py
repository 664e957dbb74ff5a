"""What every subcommand of ``hybrid`` shares, built in or added by an installed package.

A package adds a subcommand through the entry-point group ``hybrid.commands``
(:data:`hybrid.cli.main.COMMAND_GROUP`): ``register(subparsers)`` adds its parser and sets its
``handler``. Such a command takes its arguments, reports and writes its files as the built-in ones
do with what this module holds (the CLI's own helpers, :mod:`hybrid.cli.common`, re-export them):

* :class:`UsageError`: bad input, reported by ``hybrid`` in one line with exit code 2;
* argument types for ``argparse``: :func:`positive_float`, :func:`int_at_least`
  (:data:`positive_int`, :data:`nonnegative_int`);
* :func:`info`: a message on stderr;
* the output folder: :func:`writable_folder` checks it before any computation, :func:`results`
  holds the command's files (locked for the run, renamed into place at its end,
  :class:`hybrid.core.files.OutputFiles`), :func:`folder_note` reports what a killed run left.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
from collections.abc import Callable, Iterable
from pathlib import Path

from .errors import InputError
from .files import MIN_FREE_BYTES, FolderLock, OutputFiles, free_bytes, os_error_text, unique_tag

__all__ = [
    "UsageError",
    "command_line",
    "folder_note",
    "info",
    "int_at_least",
    "nonnegative_int",
    "positive_float",
    "positive_int",
    "results",
    "writable_folder",
]


class UsageError(InputError):
    """Bad command-line input (``hybrid`` reports it in one line on stderr, with exit code 2)."""


def positive_float(text: str) -> float:
    """An ``argparse`` type: a finite number > 0.

    Parameters
    ----------
    text : str
        The argument as typed.

    Returns
    -------
    float

    Raises
    ------
    argparse.ArgumentTypeError
        ``text`` is not a number, or not a finite one > 0 (``argparse`` reports it with the
        option's name).
    """
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not (math.isfinite(value) and value > 0):
        raise argparse.ArgumentTypeError(f"must be a finite number > 0, got {text}")
    return value


def int_at_least(lo: int) -> Callable[[str], int]:
    """An ``argparse`` type: an integer ``>= lo``.

    Parameters
    ----------
    lo : int
        The least value accepted.

    Returns
    -------
    callable
        ``parse(text) -> int``, raising :class:`argparse.ArgumentTypeError` for text that is not
        an integer or is below ``lo``.
    """

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not an integer") from None
        if value < lo:
            raise argparse.ArgumentTypeError(f"must be an integer >= {lo}, got {text}")
        return value

    return parse


#: An ``argparse`` type: an integer >= 1.
positive_int = int_at_least(1)

#: An ``argparse`` type: an integer >= 0.
nonnegative_int = int_at_least(0)


def info(msg: str) -> None:
    """Print ``msg`` on stderr (a command's notes and summaries; stdout holds its results)."""
    print(msg, file=sys.stderr)


def writable_folder(out: Path) -> Path:
    """``out`` (the folder of ``--out``), created and checked writable before any computation.

    A file is created and removed in it, and its device must have at least
    :data:`hybrid.core.files.MIN_FREE_BYTES` free (and a free inode where it counts them).

    Parameters
    ----------
    out : Path
        The folder (created with its parents if missing).

    Returns
    -------
    Path
        ``out``.

    Raises
    ------
    UsageError
        It exists and is not a folder, cannot be created or written (no permission, a read-only
        file system, a name too long), or its device is full; the message names the path, the
        cause and what to do.
    """
    try:
        if out.exists() and not out.is_dir():
            raise UsageError(f"`--out {out}`: exists and is not a folder")
        out.mkdir(parents=True, exist_ok=True)
        probe = out / f".hybrid-write-test-{unique_tag()}"
        fd = os.open(probe, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o644)
        os.close(fd)
        probe.unlink()
        free, inodes = free_bytes(out)
    except OSError as exc:
        raise UsageError(os_error_text(exc, out)) from None
    if free < MIN_FREE_BYTES or inodes == 0:
        what = f"{free} bytes" if free < MIN_FREE_BYTES else "no inode"
        raise UsageError(
            f"cannot write {str(out)!r}: its device has {what} free (ENOSPC): free some space, or choose "
            "a folder on another disk (--out), and run again"
        )
    return out


def command_line() -> str:
    """This command as typed (for the lock of an output folder: who holds it), cut to 200
    characters."""
    text = "hybrid " + " ".join(sys.argv[1:]) if len(sys.argv) > 1 else "hybrid"
    return text if len(text) <= 200 else text[:197] + "..."


def results(out: Path, names: Iterable[str]) -> OutputFiles:
    """The files of a command in ``out`` (:class:`hybrid.core.files.OutputFiles`, a context manager):
    the folder locked for the run (another run there is refused at once), every file's place
    checked, the files written in a staging folder (:meth:`~hybrid.core.files.OutputFiles.path`)
    and renamed into place when the run ends (by success, budget or interrupt); a note on stderr
    when a run killed in this folder left its lock and leftovers (removed).

    Parameters
    ----------
    out : Path
        The output folder (check it first with :func:`writable_folder`).
    names : iterable of str
        The names of the files the command may write there.

    Returns
    -------
    hybrid.core.files.OutputFiles
    """
    return _Results(out, names, command_line())


class _Results(OutputFiles):
    def __enter__(self):
        super().__enter__()
        if self.lock is not None:
            folder_note(self.lock)
        return self


def folder_note(lock: FolderLock) -> None:
    """The note of :func:`results` for a bare :class:`hybrid.core.files.FolderLock`: on stderr,
    which run left the folder without cleaning up and what of it was removed (nothing if the lock
    was not stale)."""
    if lock.stale:
        info(
            f"note: an earlier run in {str(lock.folder)!r} (pid {lock.stale.get('pid')}) ended without "
            "cleaning up" + (f"; removed what it left: {', '.join(lock.removed)}" if lock.removed else "")
        )
