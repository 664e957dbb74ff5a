"""Worker processes owned by their parent, and the one loop that hands them work (issue 29 item 5).

* :func:`die_with_parent` starts every worker (a pool's initializer, the first call of a forked
  worker): the kernel ends the worker when its parent dies, whatever killed the parent
  (``SIGKILL`` included; Linux), a terminal's Ctrl-C is left to the parent (which stops the
  workers itself), and ``SIGTERM``/``SIGHUP`` end the worker at once.
* :func:`signals_as_interrupts` makes ``SIGTERM`` and ``SIGHUP`` to the parent an interrupt
  (:class:`Terminated`, a ``KeyboardInterrupt``): the parent's clean-up runs as on Ctrl-C, its
  workers are stopped and what it finished is kept.
* :class:`ProcessPool` is a ``ProcessPoolExecutor`` of such workers whose :meth:`ProcessPool.kill`
  ends them now (the work in progress is dropped; the results already returned are kept). Its
  tasks run with the BLAS threads limited (:mod:`hybrid.core.threads`); where it forks, a task may
  :func:`send` messages (progress, partial results) that the parent reads with
  :meth:`ProcessPool.receive`, in the order each worker sent them.
* :func:`run_calls` runs calls on an executor (a :class:`ProcessPool`, a Dask client, any object
  with ``submit``) and hands each result, failure and message to the caller in this thread; it
  stops when the caller says so (a deadline) and withdraws what has not started. The frequency
  responses' pieces (:func:`hybrid.frequency_response`) and the sweeps' points
  (:func:`hybrid.sweep`) both run through it.
* :func:`cap_workers`: no more workers than there is work, nor than there are CPUs.
"""

from __future__ import annotations

import multiprocessing
import os
import pickle
import queue
import select
import signal
import struct
import threading
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import Future, ProcessPoolExecutor
from contextlib import contextmanager

from .errors import InputTypeError, WorkerError
from .threads import blas_threads, new_process

__all__ = [
    "die_with_parent",
    "Terminated",
    "signals_as_interrupts",
    "ProcessPool",
    "send",
    "run_calls",
    "cap_workers",
    "cpus",
]

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


class _Channel:
    """Messages from the workers of a forked pool to its parent, through one pipe.

    A worker writes each message whole (pickled, its length first) under a lock shared by the
    workers; the parent reads without ever blocking, so a message left half-written by a worker
    killed while writing it (the pool breaks, an interrupt) cannot hang it: it is never read.
    """

    _HEAD = struct.Struct("!Q")

    def __init__(self, ctx):
        self.read_fd, self.write_fd = os.pipe()
        os.set_blocking(self.read_fd, False)
        self.lock = ctx.Lock()
        self._buffer = bytearray()

    def put(self, message) -> None:
        """(In a worker.) Send ``message``; waits while the pipe is full (the parent reads it)."""
        data = pickle.dumps(message, protocol=pickle.HIGHEST_PROTOCOL)
        frame = memoryview(self._HEAD.pack(len(data)) + data)
        with self.lock:
            while frame:
                frame = frame[os.write(self.write_fd, frame) :]

    def get_all(self, timeout: float) -> list:
        """(In the parent.) The messages whole in the pipe, after waiting up to ``timeout`` seconds
        for the first byte (none: ``[]``)."""
        if timeout > 0:
            select.select([self.read_fd], [], [], timeout)
        while True:
            try:
                chunk = os.read(self.read_fd, 1 << 20)
            except BlockingIOError:
                break
            if not chunk:
                break
            self._buffer += chunk
        out, head = [], self._HEAD.size
        while len(self._buffer) >= head:
            n = self._HEAD.unpack_from(self._buffer)[0]
            if len(self._buffer) < head + n:
                break
            out.append(pickle.loads(self._buffer[head : head + n]))
            del self._buffer[: head + n]
        return out

    def close(self) -> None:
        for fd in (self.read_fd, self.write_fd):
            try:
                os.close(fd)
            except OSError:
                pass
        self.read_fd = self.write_fd = -1


#: In a worker of a forked :class:`ProcessPool`: its channel to the parent (:func:`send`).
_CHANNEL: _Channel | None = None


def _start_worker(parent: int, channel: _Channel | None) -> None:
    """A pool's worker starts: it dies with its parent (:func:`die_with_parent`), keeps the channel
    of :func:`send`, and limits its BLAS threads afresh (not nested in the parent's limit)."""
    global _CHANNEL
    die_with_parent(parent)
    _CHANNEL = channel
    new_process()


def send(message) -> None:
    """Send ``message`` (picklable) from a task running in a worker of a forked :class:`ProcessPool`
    to the parent, which reads it with :meth:`ProcessPool.receive` (those of one worker in the
    order sent, each before the result of the task that sent it).

    Raises
    ------
    hybrid.core.errors.WorkerError
        Not in a worker of a forked :class:`ProcessPool` (a task that reports must be run there).
    """
    if _CHANNEL is None:
        raise WorkerError(
            "hybrid.core.workers.send: called outside a worker of a forked ProcessPool; run the task on "
            "one (run_calls with on_message)"
        )
    _CHANNEL.put(message)


def _call(fn: Callable, args: tuple, kwargs: dict):
    """A task of a :class:`ProcessPool`, in its worker: ``fn(*args, **kwargs)`` with BLAS limited."""
    with blas_threads():
        return fn(*args, **kwargs)


class ProcessPool(ProcessPoolExecutor):
    """A ``ProcessPoolExecutor`` whose workers die with this process and can be ended at once.

    Workers are forked where the platform forks (they start at once, all of them with the first
    task, and share the parent's modules) and start with :func:`die_with_parent`; each task runs
    with the BLAS threads limited (:func:`hybrid.core.threads.blas_threads`). Where it forks, a
    task may :func:`send` messages to this process (:meth:`receive`). Used as a context manager,
    the pool is shut down normally when the block ends normally and killed (:meth:`kill`) when it
    ends by an exception or an interrupt.

    Parameters
    ----------
    max_workers : int
    """

    def __init__(self, max_workers: int):
        forks = "fork" in multiprocessing.get_all_start_methods()
        ctx = multiprocessing.get_context("fork") if forks else None
        self._channel = _Channel(ctx) if forks else None
        super().__init__(
            max_workers=max_workers,
            mp_context=ctx,
            initializer=_start_worker,
            initargs=(os.getpid(), self._channel),
        )
        self._workers: dict = {}  # every worker started, by pid (their exit codes once ended)

    @property
    def forks(self) -> bool:
        """The workers are forked (and tasks may :func:`send`)."""
        return self._channel is not None

    def submit(self, fn, /, *args, **kwargs) -> Future:
        """``fn(*args, **kwargs)`` in a worker, with the BLAS threads limited there."""
        fut = super().submit(_call, fn, args, kwargs)
        self._workers.update(getattr(self, "_processes", None) or {})
        return fut

    def receive(self, timeout: float = 0.0) -> list:
        """The messages the tasks have sent (:func:`send`) and this process has not received, after
        waiting up to ``timeout`` seconds for one; ``[]`` if none (or the pool does not fork)."""
        if self._channel is None or self._channel.read_fd < 0:
            return []
        return self._channel.get_all(timeout)

    def exit_codes(self, wait: float = 0.0) -> dict[int, int]:
        """``{pid: exit code}`` of the workers that have ended (negative: the signal that ended it),
        after waiting up to ``wait`` seconds for each to end (a broken pool ends them all)."""
        out = {}
        for pid, p in list(self._workers.items()):
            try:
                if wait > 0:
                    p.join(wait)
                code = p.exitcode
            except (OSError, ValueError, AssertionError, AttributeError):  # pragma: no cover
                continue
            if code is not None:
                out[pid] = code
        return out

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
        self._close_channel()

    def _close_channel(self) -> None:
        if self._channel is not None:
            self._channel.close()

    def __exit__(self, exc_type, exc, tb):
        if exc_type is None:
            self.shutdown(wait=True)
            self._close_channel()
        else:
            self.kill()
        return False


def run_calls(
    executor,
    fn: Callable,
    calls: Sequence[tuple],
    *,
    on_result: Callable[[int, object], None],
    on_error: Callable[[int, Exception], None],
    on_message: Callable[[object], None] | None = None,
    stop: Callable[[], bool] | None = None,
    started: Callable[[], None] | None = None,
    poll: float = 0.2,
) -> list[int]:
    """Run ``fn(*calls[i])`` for every ``i`` on ``executor`` and hand each outcome over here, in
    this thread, as it comes.

    Parameters
    ----------
    executor : object
        ``executor.submit(fn, *args)`` returning futures with ``add_done_callback``, ``result``
        and ``cancel`` (a :class:`ProcessPool`, a ``ProcessPoolExecutor``, a ``distributed.Client``).
    fn : callable
        Picklable (a module's function).
    calls : sequence of tuple
        The arguments of each call, submitted in this order.
    on_result : callable
        ``on_result(i, value)`` with the value of call ``i``.
    on_error : callable
        ``on_error(i, exc)`` with the exception that call ``i`` raised, or the executor's for a call
        it lost (a worker that died: ``BrokenProcessPool``); what it raises stops the run.
    on_message : callable, optional
        ``on_message(message)`` with every message the calls :func:`send` (``executor`` must be a
        forked :class:`ProcessPool`); all those a call sent come before its result.
    stop : callable, optional
        Called about every ``poll`` seconds and before each outcome is handed over: True stops the
        run there (a deadline passed); what it raises stops it too.
    started : callable, optional
        Called once, when every call is submitted (a forked pool has then forked its workers).
    poll : float
        Seconds between two calls of ``stop`` at most [s].

    Returns
    -------
    list of int
        The calls whose outcome was not handed over (``stop`` stopped the run), in order; ``[]``
        after a complete run.

    Raises
    ------
    hybrid.core.errors.InputTypeError
        ``on_message`` with an executor that is not a forked :class:`ProcessPool`.

    Notes
    -----
    On any exit (an interrupt included) the calls not started are withdrawn (``cancel``); those
    in progress are the caller's to end (:meth:`ProcessPool.kill`, or the ``ProcessPool``'s
    context). The calls run concurrently: whatever order the caller needs, it restores from ``i``.
    """
    receive = None
    if on_message is not None:
        if not getattr(executor, "forks", False):
            raise InputTypeError(
                f"run_calls: `on_message` needs a forked ProcessPool as executor, got {type(executor).__name__}"
            )
        receive = executor.receive
    done: queue.Queue = queue.Queue()
    pending: dict = {}
    try:
        for i, args in enumerate(calls):
            fut = executor.submit(fn, *args)
            pending[fut] = i
            fut.add_done_callback(done.put)
        if started is not None:
            started()
        while pending:
            finished = _wait(done, receive, on_message, poll)
            if stop is not None and stop():
                return sorted(pending.values())
            for fut in finished:
                i = pending.pop(fut, None)
                if i is None:
                    continue
                try:
                    value = fut.result()
                except Exception as exc:  # the call raised, or the executor lost it
                    on_error(i, exc)
                    continue
                on_result(i, value)
    finally:  # stopped early (a deadline, an interrupt, an error): the calls not started are withdrawn
        for fut in pending:
            try:
                fut.cancel()
            except Exception:  # (an executor already shut down, a cluster gone: nothing to withdraw)
                pass
    return []


def _wait(done: queue.Queue, receive, on_message, poll: float) -> list:
    """The futures finished (maybe none) after waiting up to ``poll`` seconds, or up to 0.05 s
    for a message; the messages received handed to ``on_message`` first (those sent by a task
    before it returned included)."""
    finished = []
    if receive is None:
        try:
            finished.append(done.get(timeout=poll))
        except queue.Empty:
            pass
    else:
        for m in receive(0.05):
            on_message(m)
    while True:
        try:
            finished.append(done.get_nowait())
        except queue.Empty:
            break
    if finished and receive is not None:  # a task's messages are in the pipe before its result
        for m in receive(0.0):
            on_message(m)
    return finished
