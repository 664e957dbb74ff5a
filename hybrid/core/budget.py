"""Budgets of a run: a step limit and a wall-clock limit per integration, and a command deadline.

Every integration (one :func:`hybrid.simulate` run, one variational run over a
period) gets a :class:`Budget` from its :class:`hybrid.SolverOptions`:
``max_steps`` (IDA's work, counted in residual evaluations over all modes and
calls) and ``max_wall_time`` [s]. A whole computation (an orbit, a
continuation, a frequency-response curve) can be given a deadline with
:func:`time_limit`; every integration loop checks it.
"""

from __future__ import annotations

import math
import time
from collections.abc import Iterator
from contextlib import contextmanager
from contextvars import ContextVar

from .errors import BudgetExceeded, InputError

__all__ = ["time_limit", "Budget", "deadline_passed", "limit_text", "check_deadline", "no_deadline"]

#: The deadline in force: (clock time, seconds of its time_limit, the option that set it).
_DEADLINE: ContextVar[tuple[float, float, str] | None] = ContextVar("hybrid_deadline", default=None)

#: A run that has used this fraction of its step budget (and at least PROJECTION_MIN residual
#: evaluations: a start is slow) is stopped early if, at its rate so far, it needs more than
#: PROJECTION_FACTOR times the budget to reach the end of its time span.
PROJECTION_AFTER = 0.02
PROJECTION_MIN = 20_000
PROJECTION_FACTOR = 4.0

_clock = time.monotonic  # module-level so that tests can drive it


@contextmanager
def time_limit(seconds: float, option: str = "--max-time") -> Iterator[None]:
    """Deadline for every integration started inside the block (nested limits: the earliest wins).

    The set-up of a large model started inside the block (compiling functions of thousands of
    operations, assembling a residual of hundreds of rows) raises :class:`BudgetExceeded` when the
    deadline passes during it (:func:`check_deadline`).
    A run that reaches it stops with ``Status.TIME_LIMIT``; :func:`hybrid.periodic_orbit`
    returns a failed orbit (``reason`` ``"budget"``), a continuation branch stops (``reason``
    ``"budget"``), and :func:`hybrid.continuation.frc.frequency_response` returns what it has
    (``reason`` ``"time-limit"``), each with the details in its message.

    Parameters
    ----------
    seconds : float
        From now [s], finite and > 0.
    option : str
        The command-line option that sets this limit, named in the messages of the runs it stops
        (default ``"--max-time"``; a sweep's per-point limit is ``"--point-time-limit"``).

    Examples
    --------
    >>> import hybrid
    >>> with hybrid.time_limit(600):
    ...     pass  # orbits, continuations, simulations
    """
    if (
        isinstance(seconds, bool)
        or not isinstance(seconds, int | float)
        or not (math.isfinite(seconds) and seconds > 0)
    ):
        raise InputError(f"`time_limit` needs a finite number of seconds > 0, got {seconds!r}")
    deadline = _clock() + float(seconds)
    outer = _DEADLINE.get()
    token = _DEADLINE.set(
        (deadline, float(seconds), option) if outer is None or deadline < outer[0] else outer
    )
    try:
        yield
    finally:
        _DEADLINE.reset(token)


@contextmanager
def no_deadline() -> Iterator[None]:
    """No deadline inside the block, whatever is in force outside: for writing what a computation
    stopped by its deadline has (its files, its figure), which must not be stopped in turn."""
    token = _DEADLINE.set(None)
    try:
        yield
    finally:
        _DEADLINE.reset(token)


def limit_text(deadline: tuple | None = None) -> str:
    """Where the deadline in force (or ``deadline``) comes from, for messages:
    ``"hybrid.time_limit; CLI --max-time"``."""
    d = _DEADLINE.get() if deadline is None else deadline
    option = d[2] if d is not None and len(d) > 2 else "--max-time"
    return f"hybrid.time_limit; CLI {option}"


def current_deadline() -> tuple[float, float, str] | None:
    """The deadline in force here, ``(clock time, seconds of its time_limit, its option)``, or None (to be set
    again in a worker process with :func:`restore_deadline`)."""
    return _DEADLINE.get()


@contextmanager
def restore_deadline(deadline: tuple[float, float, str] | None) -> Iterator[None]:
    """The deadline ``deadline`` (from :func:`current_deadline`) in force inside the block (the
    clock is the system's monotonic clock, shared by forked processes)."""
    token = _DEADLINE.set(deadline)
    try:
        yield
    finally:
        _DEADLINE.reset(token)


def deadline_passed() -> bool:
    """True inside a :func:`time_limit` block whose deadline has passed."""
    d = _DEADLINE.get()
    return d is not None and _clock() >= d[0]


def check_deadline(what: str) -> None:
    """Raise :class:`BudgetExceeded` (``kind`` ``"time"``) if the deadline in force has passed:
    for the set-up of a model (reading, compiling), which no integration's budget covers.

    Parameters
    ----------
    what : str
        What was being done, for the message (e.g. ``"compiling the model's residual"``).
    """
    d = _DEADLINE.get()
    if d is not None and _clock() >= d[0]:
        raise BudgetExceeded(
            "time",
            f"time limit reached: the computation's limit of {d[1]:g} s ({limit_text(d)}) ran out while "
            f"{what}; give it more time ({d[2]}) or a smaller model",
        )


class Budget:
    """The step and wall-clock budget of one integration over ``[t0, t1]``.

    Parameters
    ----------
    options : SolverOptions
        ``max_steps`` and ``max_wall_time``.
    t0, t1 : float
        The integration's time span (for progress and the rate projection).
    """

    def __init__(self, options, t0: float, t1: float):
        self.max_steps = int(options.max_steps)
        self.wall = float(options.max_wall_time)
        self.start = _clock()
        own = self.start + self.wall
        cmd = _DEADLINE.get()
        self.command = cmd is not None and cmd[0] < own
        self.deadline = cmd[0] if self.command else own
        self.command_seconds = cmd[1] if cmd is not None else None
        self.command_option = cmd[2] if cmd is not None else "--max-time"
        self.t0, self.t1 = float(t0), float(t1)
        self.used = 0  # residual evaluations charged so far (by callers that keep the count here)

    def _where(self, t: float) -> str:
        frac = (t - self.t0) / (self.t1 - self.t0) if self.t1 > self.t0 else 1.0
        return f"at t={t!r} ({100.0 * frac:.3g} % of the time span)"

    def overdue(self, used: int) -> bool:
        """Whether :meth:`check` would stop a run for its steps or its time now (``used`` residual
        evaluations; the rate projection aside): for a watch inside a long call into the solver."""
        return used >= self.max_steps or _clock() >= self.deadline

    @property
    def call_allowance(self) -> int:
        """Residual evaluations one call into the solver may take before :meth:`check` is due again
        (where the rate projection starts to apply: ``max(PROJECTION_AFTER * max_steps,
        PROJECTION_MIN)``)."""
        return int(max(PROJECTION_AFTER * self.max_steps, PROJECTION_MIN))

    def check(self, used: int, t: float, where: str = "") -> None:
        """Raise :class:`BudgetExceeded` if ``used`` residual evaluations or the time exhaust the budget.

        ``where`` (e.g. ``" in mode `a`"``) is added to the message.
        """
        now = _clock()
        if now >= self.deadline:
            if self.command:
                msg = (
                    f"time limit reached: the computation's limit of {self.command_seconds:g} s "
                    f"(hybrid.time_limit; CLI {self.command_option}) ran out {self._where(t)}{where}; "
                    f"give it more time ({self.command_option}) or ask for less"
                )
            else:
                msg = (
                    f"time limit reached: {now - self.start:.3g} s of wall-clock time "
                    f"(SolverOptions.max_wall_time = {self.wall:g} s; CLI --max-time) {self._where(t)}{where}; "
                    "raise max_wall_time (--max-time) or shorten the run"
                )
            raise BudgetExceeded("time", msg)
        if used >= self.max_steps:
            raise BudgetExceeded(
                "steps",
                f"step limit reached: {used} IDA residual evaluations (SolverOptions.max_steps = "
                f"{self.max_steps}; CLI --max-steps) {self._where(t)}{where}; raise max_steps "
                "(--max-steps) or shorten the run",
            )
        if used >= max(PROJECTION_AFTER * self.max_steps, PROJECTION_MIN) and self.t1 > t > self.t0:
            need = used * (self.t1 - self.t0) / (t - self.t0)
            if need > PROJECTION_FACTOR * self.max_steps:
                raise BudgetExceeded(
                    "projected",
                    f"step limit: at its rate so far this run needs about {need:.2g} IDA residual "
                    f"evaluations, over its budget SolverOptions.max_steps = {self.max_steps} "
                    f"(CLI --max-steps): stopped after {used} {self._where(t)}{where}",
                )
