"""Output folders and files: one writer per folder, files written whole and renamed into place.

Every command that writes a folder holds the folder's lock for the whole run (:class:`FolderLock`):
a second run in the same folder is refused at once (:class:`FolderInUse`, naming the run that holds
it). The lock is the kernel's (``flock`` on ``.hybrid.lock`` in the folder): it is released on any
exit, even ``SIGKILL``, so a lock left behind by a killed run is detected as stale and taken over,
and what that run left half-written (its staging folder, its temporary files) is removed.

Files are written whole and renamed into place, never through an entry planted in the folder:

* :func:`write_atomic` writes one file to a temporary file beside it and renames it;
* :class:`OutputFiles` holds a command's files: checked before the run (an existing entry that is
  not a regular file, e.g. a symbolic link, a FIFO or a folder, is refused with its path named),
  written into a staging folder inside the output folder while the command runs (so a row
  written as it is computed is never lost, and the results of the previous run stay whole), and
  renamed into place when it ends, by success, budget or interrupt; the files of the previous run
  of that command that this one did not write are removed then, so the folder never mixes two
  runs. A write that fails (a full disk) leaves the previous results as they were.

An :class:`OSError` of a write becomes an :class:`OutputError` whose message is one line naming the
path, the cause and what to do (:func:`os_error_text`).
"""

from __future__ import annotations

import errno
import itertools
import json
import os
import shutil
import socket
import stat
import threading
import time
from collections.abc import Iterable
from pathlib import Path

from .errors import FolderInUse, InputError, OutputError

try:  # POSIX
    import fcntl
except ImportError:  # pragma: no cover - Windows: an O_EXCL lock file with the holder's pid
    fcntl = None

__all__ = [
    "FolderLock",
    "FolderInUse",
    "OutputFiles",
    "write_atomic",
    "check_target",
    "os_error_text",
    "LOCK_NAME",
    "MIN_FREE_BYTES",
]

#: The lock file of an output folder.
LOCK_NAME = ".hybrid.lock"
#: Prefix of a run's staging folder inside its output folder (``.hybrid-run-PID-N``).
STAGING_PREFIX = ".hybrid-run-"
#: Suffix of the temporary files of :func:`write_atomic` (``.NAME.PID-N.tmp``).
TMP_SUFFIX = ".tmp"
#: Seconds a run waits for a folder whose recorded holder has died while processes it started
#: (its workers, still exiting) hold the lock on, before it is refused.
DEAD_HOLDER_WAIT = 10.0

_serial = itertools.count()


def unique_tag() -> str:
    """``PID-N``: a name part no other write of this process or of any live process uses (``N``
    counts per process, so two threads never share it); :meth:`FolderLock._clean` reads the
    ``PID`` back to tell a dead run's leftovers from a live run's."""
    return f"{os.getpid()}-{next(_serial)}"


def _owner_pid(name: str) -> int | None:
    """The pid that wrote a staging folder or temporary file named ``name`` (None if unreadable):
    ``.hybrid-run-PID[-N]`` or ``.NAME.PID[-N].tmp``."""
    if name.startswith(STAGING_PREFIX):
        tag = name[len(STAGING_PREFIX) :]
    else:
        tag = name[: -len(TMP_SUFFIX)].rsplit(".", 1)[-1]
    head = tag.split("-", 1)[0]
    return int(head) if head.isdigit() else None


#: A folder with less free space than this is refused before any computation [bytes].
MIN_FREE_BYTES = 64 * 1024

#: What to do, by errno, after the path and the cause.
_ADVICE = {
    errno.ENOSPC: "free some space (or choose a folder on another disk with --out) and run again",
    errno.EDQUOT: "free some of your quota (or choose another folder with --out) and run again",
    errno.EACCES: "choose a folder you may write (--out) or change its permissions",
    errno.EPERM: "choose a folder you may write (--out) or change its permissions",
    errno.EROFS: "the file system is read-only: choose another folder (--out)",
    errno.ENAMETOOLONG: "the name is too long for the file system: choose a shorter --out",
    errno.EISDIR: "a folder stands where the file goes: remove or rename it, or choose another --out",
    errno.ENOTDIR: "a part of the path is a file, not a folder: choose another --out",
    errno.ELOOP: "a symbolic link stands where the file goes: remove it, or choose another --out",
    errno.EIO: "the device failed: check it, or choose another folder (--out)",
    errno.EFBIG: "the file is larger than the file system allows: choose another folder (--out)",
    errno.EMFILE: "too many open files: raise the limit (ulimit -n) and run again",
}


def os_error_text(exc: OSError, path: str | Path | None = None, advice: str | None = None) -> str:
    """One line for an :class:`OSError`: the path, the cause (with its errno name) and what to do.

    Parameters
    ----------
    exc : OSError
    path : str or Path, optional
        The path written (default: the exception's ``filename``).
    advice : str, optional
        What to do (default: by errno, e.g. "free some space ... and run again").

    Examples
    --------
    >>> import errno
    >>> os_error_text(OSError(errno.ENOSPC, "No space left on device"), "out/x/frc.csv")
    "cannot write 'out/x/frc.csv': No space left on device (ENOSPC): free some space (or choose a folder on another disk with --out) and run again"
    """
    where = path if path is not None else exc.filename
    code = exc.errno
    cause = exc.strerror or str(exc) or type(exc).__name__
    name = errno.errorcode.get(code) if code is not None else None
    text = f"cannot write {str(where)!r}: {cause}" if where is not None else f"cannot write: {cause}"
    if name:
        text += f" ({name})"
    advice = advice if advice is not None else _ADVICE.get(code)
    return text + (f": {advice}" if advice else "")


def _kind(mode: int) -> str | None:
    """What a non-regular entry is, in words (None for a regular file)."""
    if stat.S_ISREG(mode):
        return None
    if stat.S_ISLNK(mode):
        return "a symbolic link"
    if stat.S_ISDIR(mode):
        return "a folder"
    if stat.S_ISFIFO(mode):
        return "a FIFO (named pipe)"
    if stat.S_ISSOCK(mode):
        return "a socket"
    return "a device or special file"


def check_target(path: str | Path) -> None:
    """Refuse a file to be written whose path holds anything but a regular file (or nothing).

    hybrid never writes through a symbolic link, into a FIFO or over a folder that stands where
    one of its files goes (it could overwrite a file outside the output folder, or block for ever).

    Raises
    ------
    InputError
        The entry at ``path`` is a symbolic link, a folder, a FIFO, a socket or a device (the
        message names it and says what to do); or ``path`` cannot be examined.
    """
    path = Path(path)
    try:
        st = os.lstat(path)
    except FileNotFoundError:
        return
    except OSError as exc:
        raise InputError(os_error_text(exc, path)) from None
    kind = _kind(st.st_mode)
    if kind is not None:
        extra = ""
        if stat.S_ISLNK(st.st_mode):
            try:
                extra = f" (to {os.readlink(path)!r})"
            except OSError:
                pass
        raise InputError(
            f"{str(path)!r} is {kind}{extra}, where hybrid writes a file: it writes only regular files of "
            "its own; remove or rename it, or choose another output folder (--out)"
        )


def write_atomic(path: str | Path, data: str | bytes) -> Path:
    """Write ``data`` to ``path`` whole: to a temporary file beside it, flushed to disk, then renamed.

    A reader sees the old file or the new one, never a part; a pre-existing symbolic link at
    ``path`` is replaced, not followed. If the write fails, the temporary file is removed and
    ``path`` is left as it was.

    Parameters
    ----------
    path : str or Path
    data : str or bytes
        Text is written as UTF-8.

    Returns
    -------
    Path

    Raises
    ------
    OutputError
        The write or the rename failed (a full disk, no permission, a folder at ``path``, ...).
    """
    path = Path(path)
    tmp = path.with_name(f".{path.name}.{unique_tag()}{TMP_SUFFIX}")
    raw = data.encode() if isinstance(data, str) else bytes(data)
    try:
        fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_NOFOLLOW", 0), 0o644)
        try:
            view = memoryview(raw)
            while view:
                view = view[os.write(fd, view) :]
            os.fsync(fd)
        finally:
            os.close(fd)
        _replace(tmp, path)
    except OSError as exc:
        try:
            tmp.unlink()
        except OSError:
            pass
        if isinstance(exc, OutputError):
            raise
        raise OutputError(os_error_text(exc, path), exc.errno) from None
    return path


def _replace(src: Path, dst: Path) -> None:
    """``os.replace``, with the error of a folder at ``dst`` named as such (``os.replace`` onto an
    empty folder would replace it)."""
    if dst.is_dir() and not dst.is_symlink():
        raise OutputError(os_error_text(OSError(errno.EISDIR, os.strerror(errno.EISDIR)), dst), errno.EISDIR)
    os.replace(src, dst)


def free_bytes(folder: str | Path) -> tuple[int, int | None]:
    """Bytes free to an unprivileged user on ``folder``'s file system, and free inodes (None if
    the file system does not count them)."""
    if not hasattr(os, "statvfs"):  # pragma: no cover - Windows
        return shutil.disk_usage(folder).free, None
    st = os.statvfs(folder)
    return st.f_bavail * st.f_frsize, (st.f_favail if st.f_files > 0 else None)


# ----------------------------------------------------------------------------------------------
# The lock
#: Folders locked by each thread: (st_dev, st_ino) -> [FolderLock, depth] (the lock is re-entrant
#: within a thread: the command holds it and :func:`hybrid.sweep` takes it again; another thread,
#: another run, is refused as another process is).
_THREAD = threading.local()
#: Descriptors of every lock this process holds (closed in a forked child: a worker never keeps its
#: parent's folder locked once the parent is gone).
_FDS: set[int] = set()


def _held() -> dict[tuple[int, int], list]:
    held = getattr(_THREAD, "held", None)
    if held is None:
        held = _THREAD.held = {}
    return held


def _after_fork_in_child() -> None:
    for fd in list(_FDS):
        try:
            os.close(fd)
        except OSError:
            pass
    _FDS.clear()
    _THREAD.held = {}


if hasattr(os, "register_at_fork"):
    os.register_at_fork(after_in_child=_after_fork_in_child)


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


class FolderLock:
    """The exclusive lock of an output folder, held for a run (a context manager).

    Parameters
    ----------
    folder : str or Path
        The folder (created if missing).
    command : str
        What holds it, for the message of a run refused (e.g. ``"hybrid sweep absorber"``).

    Attributes
    ----------
    stale : dict or None
        After :meth:`acquire`: the holder recorded by a run that ended without releasing the lock
        (killed), whose leftovers were removed; None otherwise.
    removed : list of str
        The leftovers removed (staging folders, temporary files).

    Raises
    ------
    FolderInUse
        Another process holds the lock (at :meth:`acquire`).
    OutputError
        The folder or its lock file cannot be created or written.

    Notes
    -----
    On POSIX the lock is ``flock(2)`` on :data:`LOCK_NAME`: the kernel releases it when its holder
    exits, whatever the signal, so a lock file found unlocked is stale. The file is removed when
    the lock is released. Within one process the lock is re-entrant. Elsewhere the lock file is
    created exclusively and holds the holder's pid; a file whose process is gone is stale.
    """

    def __init__(self, folder: str | Path, command: str = "hybrid"):
        self.folder = Path(folder)
        self.command = command
        self.stale: dict | None = None
        self.removed: list[str] = []
        self._fd: int | None = None
        self._key: tuple[int, int] | None = None

    @property
    def path(self) -> Path:
        return self.folder / LOCK_NAME

    def __enter__(self) -> FolderLock:
        self.acquire()
        return self

    def __exit__(self, *exc) -> None:
        self.release()

    def acquire(self) -> FolderLock:
        try:
            self.folder.mkdir(parents=True, exist_ok=True)
            st = os.stat(self.folder)
        except OSError as exc:
            raise OutputError(os_error_text(exc, self.folder), exc.errno) from None
        key = (st.st_dev, st.st_ino)
        held = _held()
        if key in held:
            held[key][1] += 1
            self._key = key
            return self
        try:
            previous = self._lock_posix() if fcntl is not None else self._lock_exclusive()
        except OSError as exc:
            raise OutputError(os_error_text(exc, self.path), exc.errno) from None
        self._key = key
        held[key] = [self, 1]
        self.removed = self._clean()
        if previous and (self.removed or previous.get("pid") != os.getpid()):
            self.stale = previous
        return self

    def _holder(self) -> dict:
        return {
            "pid": os.getpid(),
            "host": socket.gethostname(),
            "command": self.command,
            "started": time.strftime("%Y-%m-%d %H:%M:%S"),
        }

    def _lock_posix(self) -> dict | None:
        """Lock with flock; the holder's record of a killed run found in the file (or None)."""
        flags = os.O_RDWR | os.O_CREAT | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_CLOEXEC", 0)
        for _ in range(10):
            try:
                fd = os.open(self.path, flags | os.O_NONBLOCK, 0o644)
            except OSError as exc:
                if exc.errno == errno.ELOOP:
                    raise InputError(
                        f"{str(self.path)!r} is a symbolic link, where hybrid keeps the folder's lock: "
                        "remove it, or choose another output folder (--out)"
                    ) from None
                raise
            try:
                st = os.fstat(fd)
                if not stat.S_ISREG(st.st_mode):
                    raise InputError(
                        f"{str(self.path)!r} is {_kind(st.st_mode)}, where hybrid keeps the folder's lock: "
                        "remove it, or choose another output folder (--out)"
                    )
                try:
                    self._flock(fd)
                except BlockingIOError:
                    raise FolderInUse(self._in_use(_read_holder(fd))) from None
                try:  # the file may have been removed (and another made) since it was opened
                    now = os.lstat(self.path)
                except FileNotFoundError:
                    now = None
                if now is None or (now.st_dev, now.st_ino) != (st.st_dev, st.st_ino):
                    os.close(fd)
                    continue
                previous = _read_holder(fd)
                os.ftruncate(fd, 0)
                os.pwrite(fd, (json.dumps(self._holder()) + "\n").encode(), 0)
                self._fd = fd
                _FDS.add(fd)
                return previous
            except BaseException:
                if self._fd != fd:
                    os.close(fd)
                raise
        raise FolderInUse(f"{str(self.folder)!r}: its lock keeps changing hands; try again")

    @staticmethod
    def _flock(fd: int) -> None:
        """``flock`` at once; while the holder recorded in the file is a process of this host that
        has ended (its workers still exiting hold the lock), retried for up to
        :data:`DEAD_HOLDER_WAIT` seconds. Raises :class:`BlockingIOError` if still held."""
        end = time.monotonic() + DEAD_HOLDER_WAIT
        while True:
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
                return
            except BlockingIOError:
                holder = _read_holder(fd)
                pid = holder.get("pid")
                dead = (
                    isinstance(pid, int)
                    and holder.get("host", socket.gethostname()) == socket.gethostname()
                    and not _alive(pid)
                )
                if not dead or time.monotonic() >= end:
                    raise
                time.sleep(0.1)

    def _lock_exclusive(self) -> dict | None:  # pragma: no cover - platforms without fcntl
        for _ in range(2):
            try:
                fd = os.open(self.path, os.O_RDWR | os.O_CREAT | os.O_EXCL, 0o644)
            except FileExistsError:
                try:
                    holder = json.loads(self.path.read_text() or "{}")
                except (OSError, ValueError):
                    holder = {}
                pid = holder.get("pid")
                if holder.get("host") == socket.gethostname() and isinstance(pid, int) and not _alive(pid):
                    self.path.unlink(missing_ok=True)
                    previous = holder
                    continue
                raise FolderInUse(self._in_use(holder)) from None
            os.write(fd, (json.dumps(self._holder()) + "\n").encode())
            self._fd = fd
            return locals().get("previous")
        raise FolderInUse(self._in_use({}))

    def _in_use(self, holder: dict) -> str:
        pid = holder.get("pid")
        if (
            isinstance(pid, int)
            and holder.get("host", socket.gethostname()) == socket.gethostname()
            and not _alive(pid)
        ):
            return (
                f"output folder {str(self.folder)!r} is still locked by processes that the run pid {pid}"
                + (f" (`{holder['command']}`)" if holder.get("command") else "")
                + f" started, though that run has ended (waited {DEAD_HOLDER_WAIT:g} s for them): wait for "
                "them to exit (or stop them), or choose another folder (--out)"
            )
        who = ""
        if holder:
            who = f" (pid {holder.get('pid')}" + (
                f" on {holder['host']}" if holder.get("host") not in (None, socket.gethostname()) else ""
            )
            who += f", `{holder['command']}`" if holder.get("command") else ""
            who += f", since {holder['started']})" if holder.get("started") else ")"
        return (
            f"output folder {str(self.folder)!r} is in use by another hybrid run{who}: one run writes a "
            "folder at a time; wait for it to end, or choose another folder (--out)"
        )

    def _clean(self) -> list[str]:
        """Remove what runs killed in this folder left: staging folders and temporary files whose
        process is gone (those of a live process, a run whose lock file was removed under it, stay)."""
        removed = []
        try:
            entries = list(os.scandir(self.folder))
        except OSError:
            return removed
        for e in entries:
            pid = _owner_pid(e.name)
            if pid is not None and _alive(pid):
                continue
            try:
                if e.name.startswith(STAGING_PREFIX) and e.is_dir(follow_symlinks=False):
                    shutil.rmtree(e.path)
                    removed.append(e.name)
                elif (
                    e.name.startswith(".")
                    and e.name.endswith(TMP_SUFFIX)
                    and e.is_file(follow_symlinks=False)
                ):
                    os.unlink(e.path)
                    removed.append(e.name)
            except OSError:
                continue
        return removed

    def release(self) -> None:
        if self._key is None:
            return
        held = _held()
        entry = held.get(self._key)
        self._key, key = None, self._key
        if entry is None:
            return
        entry[1] -= 1
        if entry[1] > 0:
            return
        del held[key]
        owner = entry[0]
        if owner._fd is not None:
            try:  # its own lock file only: another run's, made after this one's was removed, stays
                mine, there = os.fstat(owner._fd), os.lstat(owner.path)
                if (mine.st_dev, mine.st_ino) == (there.st_dev, there.st_ino):
                    os.unlink(owner.path)  # before the lock goes: no one locks a file that is gone
            except OSError:
                pass
            _FDS.discard(owner._fd)
            os.close(owner._fd)
            owner._fd = None


def _read_holder(fd: int) -> dict:
    try:
        data = os.pread(fd, 4096, 0)
        holder = json.loads(data.decode() or "{}")
    except (OSError, ValueError):
        return {}
    return holder if isinstance(holder, dict) else {}


# ----------------------------------------------------------------------------------------------
# A command's files
class OutputFiles:
    """The files one command writes into its output folder (a context manager).

    On entry: the folder is locked (:class:`FolderLock`), each file's place is checked
    (:func:`check_target`) and a staging folder is made inside the output folder. Inside the
    block, :meth:`path` gives where to write a file (in the staging folder). On exit the staged
    files are renamed into place, and the files of ``names`` this run did not write (those of a
    previous run) are removed: the folder holds this run's files only. This happens when the
    block ends normally, by an interrupt (``KeyboardInterrupt``: what was computed is kept) or by
    :meth:`commit` being called; after any other exception (a full disk, an error) the staged
    files are discarded and the previous results left as they were.

    Parameters
    ----------
    folder : str or Path
    names : iterable of str
        The files the command may write (plain names, no folders).
    command : str
        For the lock's message (:class:`FolderLock`).
    lock : bool
        Take the folder's lock (default True).

    Raises
    ------
    InputError
        At entry: a file's place holds a symbolic link, a folder, a FIFO, ... (refused before any
        computation), or another run holds the folder (:class:`FolderInUse`).
    OutputError
        A write, the staging folder or a rename failed.
    """

    def __init__(self, folder: str | Path, names: Iterable[str], command: str = "hybrid", lock: bool = True):
        self.folder = Path(folder)
        self.names = list(dict.fromkeys(names))
        for n in self.names:
            if not n or Path(n).name != n or n.startswith("."):
                raise InputError(f"output file name {n!r}: a plain name, not a path")
        self.lock = FolderLock(self.folder, command) if lock else None
        self.staging: Path | None = None
        self.done = False

    def check(self) -> None:
        """Refuse now a file whose place holds something else than a regular file."""
        for n in self.names:
            check_target(self.folder / n)

    def __enter__(self) -> OutputFiles:
        if self.lock is not None:
            self.lock.acquire()
        try:
            self.check()
            self.staging = self.folder / f"{STAGING_PREFIX}{unique_tag()}"
            try:
                if self.staging.exists():
                    shutil.rmtree(self.staging)
                self.staging.mkdir()
            except OSError as exc:
                raise OutputError(os_error_text(exc, self.staging), exc.errno) from None
        except BaseException:
            if self.lock is not None:
                self.lock.release()
            raise
        return self

    def path(self, name: str) -> Path:
        """Where to write ``name`` (one of ``names``) during the run."""
        if name not in self.names:
            raise InputError(f"{name!r} is not one of the files of this run: {self.names}")
        return self.staging / name

    def final(self, name: str) -> Path:
        """Where ``name`` will be once the run ends."""
        return self.folder / name

    def commit(self) -> list[Path]:
        """Rename the staged files into place; remove the files of ``names`` not written this run.

        Returns
        -------
        list of Path
            The files now in place, in the order of ``names``.
        """
        if self.done or self.staging is None:
            return []
        placed = []
        try:
            for n in self.names:
                src, dst = self.staging / n, self.folder / n
                if os.path.lexists(src):
                    _replace(src, dst)
                    placed.append(dst)
                elif os.path.lexists(dst) and not os.path.isdir(dst):
                    os.unlink(dst)  # a previous run's file this one did not write
            self.done = True
            shutil.rmtree(self.staging, ignore_errors=True)
        except OSError as exc:  # (what could not be put in place is removed: no partial run left)
            self.discard()
            if isinstance(exc, OutputError):
                raise
            raise OutputError(os_error_text(exc, self._shown(exc.filename)), exc.errno) from None
        return placed

    def _shown(self, filename) -> Path:
        """The path to name for a failed write: a staged file by its final place, else the folder."""
        if filename is None:
            return self.folder
        f = Path(filename)
        if self.staging is not None and f.parent == self.staging:
            return self.folder / f.name
        return f

    def discard(self) -> None:
        """Remove the staged files (the folder keeps the previous run's files)."""
        if self.staging is not None:
            shutil.rmtree(self.staging, ignore_errors=True)
        self.done = True

    def __exit__(self, exc_type, exc, tb) -> None:
        try:
            if exc_type is None or issubclass(exc_type, KeyboardInterrupt):
                placed = self.commit()
                if exc is not None:  # what the interrupted run keeps, for its message
                    exc.hybrid_kept = (str(self.folder), [f.name for f in placed])
            else:
                self.discard()
                if isinstance(exc, OSError) and not isinstance(exc, OutputError):
                    raise OutputError(os_error_text(exc, self._shown(exc.filename)), exc.errno) from None
        finally:
            if self.lock is not None:
                self.lock.release()
