"""Worker processes owned by their parent: they die with it, and an interrupt stops them at once.

* :func:`die_with_parent` starts every worker (a pool's initializer, the first call of a forked
  worker): the kernel ends the worker when its parent dies, whatever killed the parent
  (``SIGKILL`` included; Linux), a terminal's Ctrl-C is left to the parent (which stops the
  workers itself), and ``SIGTERM``/``SIGHUP`` end the worker at once.
* :func:`signals_as_interrupts` makes ``SIGTERM`` and ``SIGHUP`` to the parent an interrupt
  (:class:`Terminated`, a ``KeyboardInterrupt``): the parent's clean-up runs as on Ctrl-C, its
  workers are stopped and what it finished is kept.
* :class:`ProcessPool` is a ``ProcessPoolExecutor`` of such workers whose :meth:`ProcessPool.kill`
  ends them now (the work in progress is dropped; the results already returned are kept).
* :func:`cap_workers`: no more workers than there is work, nor than there are CPUs.
"""

from __future__ import annotations

import multiprocessing
import os
import signal
import threading
from collections.abc import Iterator
from concurrent.futures import ProcessPoolExecutor
from contextlib import contextmanager

__all__ = ["die_with_parent", "Terminated", "signals_as_interrupts", "ProcessPool", "cap_workers", "cpus"]

#: Signals turned into :class:`Terminated` by :func:`signals_as_interrupts` (those a batch system,
#: a supervisor or a closed terminal sends), where the platform has them.
TERMINATING = tuple(getattr(signal, n) for n in ("SIGTERM", "SIGHUP") if hasattr(signal, n))


class Terminated(KeyboardInterrupt):
    """A terminating signal (``SIGTERM``, ``SIGHUP``) received by the main process, raised there as
    an interrupt so that it stops as on Ctrl-C (a ``KeyboardInterrupt``: ``except Exception`` does
    not catch it).

    Attributes
    ----------
    signum : int
    exit_code : int
        ``128 + signum``, the shell's convention for a process ended by that signal.
    """

    def __init__(self, signum: int):
        super().__init__(signum)
        self.signum = int(signum)
        self.exit_code = 128 + self.signum

    @property
    def name(self) -> str:
        try:
            return signal.Signals(self.signum).name
        except ValueError:  # pragma: no cover
            return f"signal {self.signum}"


def _raise_terminated(signum, frame) -> None:
    raise Terminated(signum)


@contextmanager
def signals_as_interrupts() -> Iterator[None]:
    """Inside the block, ``SIGTERM`` and ``SIGHUP`` raise :class:`Terminated` in the main thread.

    Outside the main thread (where Python cannot set handlers) the block runs unchanged. The
    previous handlers are restored at the end.
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    old = {}
    for s in TERMINATING:
        try:
            old[s] = signal.signal(s, _raise_terminated)
        except (OSError, ValueError):  # pragma: no cover - a signal the platform refuses
            continue
    try:
        yield
    finally:
        for s, h in old.items():
            signal.signal(s, h)


def die_with_parent(parent: int | None = None) -> None:
    """Make this (worker) process end when its parent dies; leave Ctrl-C to the parent.

    Called first in every worker: the kernel sends it ``SIGKILL`` when its parent dies (Linux's
    ``PR_SET_PDEATHSIG``; elsewhere a worker whose parent was killed outright ends when it next
    talks to it), ``SIGINT`` is ignored (a terminal sends it to the whole process group: the parent
    stops its workers itself) and ``SIGTERM``/``SIGHUP`` take their default action (end the
    worker at once), whatever the parent installed before it forked.

    Parameters
    ----------
    parent : int, optional
        The parent's pid, recorded before the worker started: if the parent is already gone, the
        worker ends at once. Default: the worker's parent when it calls this.
    """
    for s in TERMINATING:
        signal.signal(s, signal.SIG_DFL)
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        import ctypes

        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(1, signal.SIGKILL, 0, 0, 0)  # PR_SET_PDEATHSIG
    except (OSError, AttributeError):  # pragma: no cover - not Linux
        pass
    ppid = os.getppid()
    if (parent is not None and ppid != parent) or ppid == 1:
        os._exit(1)  # the parent died before the call


def cpus() -> int:
    """The CPUs this process may run on (its affinity where the platform tells it)."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except (AttributeError, OSError):  # pragma: no cover - not Linux
        return os.cpu_count() or 1


def cap_workers(requested: int | None, work: int | None, what: str = "tasks") -> tuple[int, str | None]:
    """Worker processes for ``work`` tasks: ``requested`` (default: the CPUs) capped at the work and
    at the CPUs.

    Parameters
    ----------
    requested : int or None
        Asked for (``--workers``); None: as many as the CPUs.
    work : int or None
        Tasks to run (at least one worker is used); None: not known here (capped at the CPUs only).
    what : str
        The tasks, in the note (e.g. ``"points to compute"``).

    Returns
    -------
    (int, str or None)
        The workers, and a note saying why if ``requested`` was capped (None otherwise).

    Examples
    --------
    >>> n, note = cap_workers(300, 1, "point to compute")
    >>> n, note.startswith("note: --workers 300 capped at 1 (1 point to compute")
    (1, True)
    """
    n_cpu = cpus()
    want = n_cpu if requested is None else int(requested)
    n = max(1, min(want, n_cpu, work if work is not None else want))
    note = None
    if requested is not None and n < want:
        why = [f"{work} {what}"] if work is not None and work <= n else []
        why += [f"{n_cpu} CPUs"] if n_cpu <= n else []
        note = f"note: --workers {want} capped at {n} ({', '.join(why)})"
    return n, note


class ProcessPool(ProcessPoolExecutor):
    """A ``ProcessPoolExecutor`` whose workers die with this process and can be ended at once.

    Workers are forked where the platform forks (they start at once and share the parent's
    modules) and start with :func:`die_with_parent`. Used as a context manager, the pool is
    shut down normally when the block ends normally and killed (:meth:`kill`) when it ends by an
    exception or an interrupt.

    Parameters
    ----------
    max_workers : int
    """

    def __init__(self, max_workers: int):
        ctx = (
            multiprocessing.get_context("fork") if "fork" in multiprocessing.get_all_start_methods() else None
        )
        super().__init__(
            max_workers=max_workers, mp_context=ctx, initializer=die_with_parent, initargs=(os.getpid(),)
        )

    def kill(self) -> None:
        """End every worker now (the points or jobs in progress are dropped) and the pool."""
        procs = list((getattr(self, "_processes", None) or {}).values())
        for p in procs:
            try:
                p.kill()
            except (OSError, ValueError, AttributeError):
                pass
        self.shutdown(wait=False, cancel_futures=True)
        for p in procs:
            try:
                p.join(5.0)
            except (OSError, ValueError, AssertionError, AttributeError):
                pass

    def __exit__(self, exc_type, exc, tb):
        if exc_type is None:
            self.shutdown(wait=True)
        else:
            self.kill()
        return False
