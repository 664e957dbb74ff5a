"""Frequency-response curves: continuation of periodic orbits in the forcing frequency over a range.

:func:`frequency_response` runs :func:`hybrid.continue_orbits` piece by piece:
the range is cut between consecutive resonances of the linearised initial
mode (:func:`hybrid.model.linear.natural_frequencies`), so that each piece holds
one resonance; each piece is continued upwards from its lower end and, if
that branch stops (or turns back at a fold) before the upper end, downwards
from the upper end as well. What neither run covers is reported as a gap.
Nothing here knows the model: the resonances come from its equations.
"""

from __future__ import annotations

import math
import multiprocessing
import os
import signal
import time
from collections.abc import Callable, Mapping
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass, field

import numpy as np

from ..core.budget import current_deadline, deadline_passed, limit_text
from ..core.budget import restore_deadline as _deadline
from ..core.callbacks import OnPoint, Progress
from ..core.errors import InputError, WorkerError
from ..core.notices import collected
from ..core.options import ContinuationOptions, reject_keywords
from ..core.plain import options_text
from ..core.status import BranchStatus, ResponseStatus
from ..core.tables import Tabular, table_columns
from ..core.threads import with_blas_threads
from ..core.workers import ProcessPool, run_calls, send
from ..integrators.options import SolverOptions
from ..model.linear import natural_frequencies
from ..model.plot_hints import plot_hints
from ..model.system import HybridSystem, shared
from ..orbits.orbit import ORBIT_OPTIONS
from .branch import Branch, forcing_parameter
from .forced import continue_orbits

__all__ = ["FrequencyResponse", "frequency_response", "default_range"]

#: Default range around the resonances of the linearised initial mode, as factors of the lowest/highest one.
RANGE_FACTORS = (0.8, 1.2)


def resonances(system: HybridSystem, params: Mapping[str, float]) -> np.ndarray:
    """The natural frequencies a frequency response is centred on and cut between [rad/s].

    Those of the initial mode linearised at the zero state; where it has none (e.g. every friction
    contact stuck to the ground: nothing moves), those of the first of the model's linear
    references (its ``linear_references`` plot hint, e.g. every contact sliding) that has some.
    """
    w = natural_frequencies(system, params)
    if w.size:
        return w
    for mode in plot_hints(system).get("linear_references", {}).values():
        w = natural_frequencies(system, params, mode)
        if w.size:
            return w
    return w


def default_range(system: HybridSystem, params: Mapping[str, float]) -> tuple[float, float]:
    """The default range of a frequency response: ``(0.8 min, 1.2 max)`` of the natural
    frequencies of :func:`resonances` [rad/s].

    Parameters
    ----------
    system : HybridSystem
        A model with a forcing period.
    params : mapping of str to float
        Its parameter values.

    Returns
    -------
    (float, float)
        The range's ends [rad/s].

    Raises
    ------
    ValueError
        If the linearisations have no oscillating mode (give the range instead).

    Examples
    --------
    >>> import hybrid
    >>> from hybrid.continuation.frc import default_range
    >>> ab = hybrid.resolve_model("absorber")
    >>> lo, hi = default_range(ab, ab.parameter_values({}, preset="standard"))
    >>> 0 < lo < hi
    True
    """
    w = resonances(system, params)
    if w.size == 0:
        raise InputError(
            f"model `{system.name}`: its initial mode linearised at the zero state has no natural "
            "frequency to centre the range on (nor have its linear references); give the range "
            "(--omega-range A B)"
        )
    return RANGE_FACTORS[0] * float(w[0]), RANGE_FACTORS[1] * float(w[-1])


@dataclass
class Piece:
    """One part of the range and the branches computed on it.

    Attributes
    ----------
    lo, hi : float
        Bounds of the part [rad/s].
    resonance : float or None
        The natural frequency inside the part.
    branches : list of Branch
        The upward run (after a failed start at ``lo``, the runs started a little inside), then
        (if needed) the downward run from ``hi``.
    gaps : list of (float, float)
        Parts of ``(lo, hi)`` not covered by any branch.
    timed_out : bool
        The deadline of :func:`hybrid.time_limit` passed while it was computed.
    """

    lo: float
    hi: float
    resonance: float | None
    branches: list = field(default_factory=list)
    gaps: list = field(default_factory=list)
    timed_out: bool = False

    @property
    def gap(self) -> tuple | None:
        """The first gap (None if the piece is covered)."""
        return self.gaps[0] if self.gaps else None


@dataclass
class FrequencyResponse(Tabular):
    """Result of :func:`frequency_response`.

    Attributes
    ----------
    system : HybridSystem
    params : dict
        Parameter values (the continued one at the start of the range).
    parameter : str
        The continued parameter (by default the forcing frequency, the parameter the period
        depends on).
    p_range : tuple of float
    resonances : ndarray
        Natural frequencies of the linearised initial mode [rad/s] (where it has none, of the
        model's first linear reference that has: :func:`resonances`).
    pieces : list of Piece
    status : ResponseStatus
        ``"complete"`` (every part of the range covered, every branch with a point) or
        ``"incomplete"``.
    reason : str
        Why it is incomplete, a code of :data:`hybrid.core.status.RESPONSE_REASONS`
        (``"time-limit"``: the deadline of :func:`hybrid.time_limit` passed and what was not
        computed is a gap; ``"gaps"``; ``"empty-branch"``); ``""`` if complete.
        :meth:`messages` says the same in words.
    limit : str
        Where the deadline in force came from (e.g. ``"hybrid.time_limit; CLI --max-time"``),
        named by :meth:`messages` when it stopped the computation.
    options : SolverOptions or None
        The solver options it was computed with (given, or the default :data:`hybrid.ORBIT_OPTIONS`
        in their place); with :attr:`settings`, :attr:`params` and :attr:`p_range` they repeat it.
    settings : ContinuationOptions or None
        The continuation options it was computed with (given, or ``ContinuationOptions()``).
    """

    system: HybridSystem
    params: dict
    parameter: str
    p_range: tuple
    resonances: np.ndarray
    pieces: list = field(default_factory=list)
    status: ResponseStatus = ResponseStatus.COMPLETE
    reason: str = ""
    #: Where the deadline that stopped it comes from (:func:`hybrid.core.budget.limit_text`).
    limit: str = "hybrid.time_limit; CLI --max-time"
    options: SolverOptions | None = None
    settings: ContinuationOptions | None = None

    def table(self) -> dict[str, list]:
        """One row per orbit of every branch, in order of the range: the branch's number
        (``branch``) and :meth:`hybrid.Branch.to_rows`'s columns (for :meth:`to_numpy`,
        :meth:`to_pandas`)."""
        return table_columns({"branch": k, **r} for k, b in enumerate(self.branches) for r in b.to_rows())

    @property
    def branches(self) -> list[Branch]:
        """Every branch of every piece, in order of the range."""
        return [b for pc in self.pieces for b in pc.branches]

    @property
    def gaps(self) -> list[tuple[float, float]]:
        """The parts of the range where no orbit was computed, ``(lo, hi)`` each."""
        return [g for pc in self.pieces for g in pc.gaps]

    def conclude(self) -> None:
        """Set :attr:`status` and :attr:`reason` from the pieces (and :attr:`limit` from the deadline in
        force)."""
        self.limit = limit_text()
        if any(pc.timed_out for pc in self.pieces):
            self.status, self.reason = ResponseStatus.INCOMPLETE, "time-limit"
        elif self.gaps:
            self.status, self.reason = ResponseStatus.INCOMPLETE, "gaps"
        elif not all(b.points for b in self.branches):
            self.status, self.reason = ResponseStatus.INCOMPLETE, "empty-branch"
        else:
            self.status, self.reason = ResponseStatus.COMPLETE, ""

    def messages(self) -> list[str]:
        """What stopped a branch, and the gaps left."""
        out = [
            f"branch {k} ({_span(b)}): {b.message}"
            for k, b in enumerate(self.branches)
            if b.status != BranchStatus.COMPLETED
        ]
        out += [
            f"no periodic orbit computed for {self.parameter} in ({a:.8g}, {b:.8g})" for a, b in self.gaps
        ]
        if self.reason == "time-limit":
            out.append(f"time limit reached ({self.limit}): the gaps were not computed")
        return out

    @property
    def rows(self) -> list[dict]:
        """One dict per orbit of every branch (``branch`` index first), in branch order."""
        rows = []
        for k, b in enumerate(self.branches):
            for row in b.to_rows():
                rows.append({"branch": k, **row})
        return rows

    @property
    def special_rows(self) -> list[dict]:
        """One dict per special point; ``row`` is its index in :attr:`rows`."""
        rows = []
        offset = 0
        for k, b in enumerate(self.branches):
            for sp in b.special:
                row = {
                    "branch": k,
                    "row": offset + sp.index,
                    "kind": sp.kind,
                    self.parameter: sp.parameter,
                    "status": sp.status,
                    "accuracy": sp.accuracy,
                    "interval_lo": sp.interval[0],
                    "interval_hi": sp.interval[1],
                    "stability": b.points[sp.index].stability,
                    "description": sp.description,
                }
                row.update({f"amplitude_{n}": v for n, v in sp.amplitude.items()})
                rows.append(row)
            offset += len(b.points)
        return rows

    def __repr__(self) -> str:
        lo, hi = self.p_range
        n = sum(len(b.points) for b in self.branches)
        ns = sum(len(b.special) for b in self.branches)
        return (
            f"FrequencyResponse({self.system.name} in {self.parameter} from {lo:.6g} to {hi:.6g}: "
            f"{_count(len(self.branches), 'branch', 'branches')}, {_count(n, 'orbit', 'orbits')}, "
            f"{_count(ns, 'special point', 'special points')}, {_count(len(self.gaps), 'gap', 'gaps')}; "
            f"{self.status}" + (f" ({self.reason})" if self.reason else "") + "; "
            f"options={options_text(self.options)}, settings={options_text(self.settings)})"
        )


def _count(n: int, one: str, many: str) -> str:
    return f"{n} {one if n == 1 else many}"


#: Where a branch is started again, as fractions of its piece, when it cannot start at the piece's end.
NO_START_RETRY = (1e-3, 2e-2)


def _uncovered(a: float, b: float, spans: list[tuple[float, float]]) -> list[tuple[float, float]]:
    """Parts of ``(a, b)`` outside every span."""
    out, at = [], a
    for lo, hi in sorted(spans):
        if lo > at:
            out.append((at, min(lo, b)))
        at = max(at, hi)
        if at >= b:
            break
    if at < b:
        out.append((at, b))
    return [(x, y) for x, y in out if y > x]


def _span(b: Branch) -> str:
    if not b.points:
        return "no point"
    p = b.values
    return f"{b.parameter} {p[0]:.6g} to {p[-1]:.6g}"


def _cuts(lo: float, hi: float, w: np.ndarray) -> list[tuple[float, float, float | None]]:
    """Split ``[lo, hi]`` between consecutive natural frequencies inside it."""
    inside = [float(x) for x in w if lo < x < hi]
    edges = [lo] + [0.5 * (a + b) for a, b in zip(inside, inside[1:], strict=False)] + [hi]
    out = []
    for a, b in zip(edges, edges[1:], strict=False):
        res = [x for x in inside if a < x < b]
        out.append((a, b, res[0] if res else None))
    return out


@collected
@with_blas_threads
def frequency_response(
    system: HybridSystem,
    params: Mapping[str, float],
    p_range: tuple[float, float],
    *,
    parameter: str | None = None,
    options: SolverOptions | None = None,
    settings: ContinuationOptions | None = None,
    progress: Progress | None = None,
    on_point: OnPoint | None = None,
    workers: int = 1,
    while_computing: Callable[[], None] | None = None,
    **unexpected,
) -> FrequencyResponse:
    """Periodic orbits over a range of the forcing frequency, one piece per resonance.

    Parameters
    ----------
    system : HybridSystem
    params : mapping
        All parameter values.
    p_range : (float, float)
        ``lo < hi``.
    parameter : str, optional
        The forcing frequency's parameter (default: the one parameter the model's period
        depends on, :func:`hybrid.forcing_parameter`).
    options : SolverOptions, optional
        Tolerances and budgets of the runs (default :data:`hybrid.ORBIT_OPTIONS`), e.g.
        ``SolverOptions(method=Exact())``.
    settings : ContinuationOptions, optional
        Steps, tolerances, location of special points, limits of a branch (default
        ``ContinuationOptions()``).
    progress : callable, optional
        ``progress(fraction)`` with the fraction of the range covered (0 to 1).
    on_point : callable, optional
        ``on_point(branch_index, orbit)`` with every orbit as it is accepted (e.g. to write it
        at once: an interrupted computation keeps what it did), branch after branch
        (:mod:`hybrid.core.callbacks`).
    workers : int
        Pieces computed at once, each in a process forked from this one (where the platform
        forks; else one after the other). The result is the same as with one: each piece is
        computed by the same code from the same start. ``on_point`` is called here, in branch
        order: the orbits of a piece are passed on as soon as the pieces before it are done.
    while_computing : callable, optional
        With worker processes: called once here, after the last of them has started (nothing is
        forked after it), e.g. to start importing in a thread what the caller needs afterwards
        while the workers compute. Not called when the pieces are computed in this process.

    Returns
    -------
    FrequencyResponse

    Raises
    ------
    hybrid.core.errors.WorkerError
        A worker process failed (its exception's type and message in this one's) or ended
        without a result.
    hybrid.core.errors.InputError
        Bad input (before any integration).
    hybrid.core.errors.InputTypeError
        A keyword that is a field of ``options`` or ``settings`` (the message says which: e.g.
        ``integrator="exact"`` belongs in ``options=SolverOptions(method=Exact())``).

    Examples
    --------
    >>> import hybrid
    >>> from hybrid import resolve_model
    >>> system = resolve_model("coulomb")
    >>> params = system.presets["forced"]
    >>> fr = hybrid.frequency_response(system, params, (0.6, 0.7))  # doctest: +SKIP
    """
    reject_keywords(
        "frequency_response",
        unexpected,
        options=options if isinstance(options, SolverOptions) else SolverOptions,
        settings=settings if isinstance(settings, ContinuationOptions) else ContinuationOptions,
    )
    if parameter is None:
        parameter = forcing_parameter(system)
    lo, hi = (float(v) for v in p_range)
    if not (math.isfinite(lo) and math.isfinite(hi) and 0 < lo < hi):
        raise InputError(f"the frequency range must satisfy 0 < A < B, got {lo!r}, {hi!r}")
    if not (isinstance(workers, int) and not isinstance(workers, bool) and workers >= 1):
        raise InputError(f"`workers` must be an integer >= 1, got {workers!r}")
    options = ORBIT_OPTIONS if options is None else options  # (what continue_orbits takes for None)
    settings = ContinuationOptions() if settings is None else settings
    res = resonances(system, params)
    out = FrequencyResponse(system, dict(params), parameter, (lo, hi), res, options=options)
    out.settings = settings
    cuts = _cuts(lo, hi, res)
    job = _PieceJob(system, dict(params), parameter, options, settings)
    if workers > 1 and len(cuts) > 1 and "fork" in multiprocessing.get_all_start_methods():
        out.pieces = _parallel(
            job, cuts, min(workers, len(cuts)), lo, hi, progress, on_point, while_computing
        )
    else:
        out.pieces = _serial(job, cuts, lo, hi, progress, on_point)
    out.conclude()
    return out


def _serial(job: _PieceJob, cuts, lo: float, hi: float, progress, on_point) -> list[Piece]:
    """The pieces computed one after the other in this process (progress over the whole range,
    orbits passed on with their index among all the branches)."""
    pieces: list[Piece] = []
    total, done = hi - lo, 0.0
    for a, b, w in cuts:
        k0 = sum(len(pc.branches) for pc in pieces)
        report = (
            None
            if progress is None
            else (lambda f, d=done, a=a, b=b: progress(min(1.0, (d + f * (b - a)) / total)))
        )
        sink = None if on_point is None else (lambda j, o, k0=k0: on_point(k0 + j, o))
        pieces.append(job.piece(a, b, w, report, sink))
        done += b - a
        if progress is not None:
            progress(done / total)
    return pieces


@dataclass
class _PieceJob:
    """What every piece of one frequency response shares (sent to a worker with each piece: its
    model by reference, :func:`hybrid.model.system.shared`)."""

    system: HybridSystem
    params: dict
    parameter: str
    options: SolverOptions | None
    settings: ContinuationOptions | None

    def piece(
        self,
        a: float,
        b: float,
        w: float | None,
        progress: Progress | None,
        on_point: OnPoint | None,
    ) -> Piece:
        """The branches over ``(a, b)`` (``progress``: fraction of it covered; ``on_point(j, orbit)``,
        ``j`` the branch's index in the piece)."""
        piece = Piece(a, b, w)
        if deadline_passed():
            piece.timed_out, piece.gaps = True, [(a, b)]
            return piece

        def run(start: float, end: float) -> Branch:
            """A branch from ``start`` towards ``end``."""
            j = len(piece.branches)
            covered = abs(start - a) if end > start else abs(end - a)
            br = continue_orbits(
                self.system,
                self.params,
                self.parameter,
                (start, end),
                progress=None
                if progress is None
                else (lambda f: progress(min(1.0, (covered + f * abs(end - start)) / (b - a)))),
                on_point=None if on_point is None else (lambda _, o: on_point(j, o)),
                options=self.options,
                settings=self.settings,
            )
            piece.branches.append(br)
            piece.timed_out = piece.timed_out or (br.status == BranchStatus.STOPPED and deadline_passed())
            return br

        # A start that fails at the end of the range (e.g. a degenerate orbit there), or a branch
        # that stalls at its first point, is retried a little inside it; what lies before is a gap.
        for start in [a] + [a + f * (b - a) for f in NO_START_RETRY]:
            up = run(start, b)
            stuck = up.reason == "no-start" or (up.reason == "stalled" and len(up.points) <= 1)
            if not stuck or deadline_passed():
                break
        reach = float(np.max(up.values)) if up.points else a
        if reach < b and deadline_passed():
            piece.timed_out = True
        elif reach < b:
            run(b, reach)
        piece.gaps = _uncovered(
            a, b, [(float(np.min(br.values)), float(np.max(br.values))) for br in piece.branches if br.points]
        )
        return piece


def _grace(seconds: float) -> float:
    """How long after the deadline (of ``seconds``) the parent of :func:`_parallel` waits for its
    workers before it stops them and keeps what is finished [s]: 5 % of the limit, 2 s to 30 s."""
    return min(30.0, max(2.0, 0.05 * seconds))


def _piece_in_worker(job: _PieceJob, index: int, a: float, b: float, w: float | None, deadline) -> Piece:
    """Piece ``index`` in a worker of a :class:`hybrid.core.workers.ProcessPool`: the worker's pid,
    then its progress and its orbits sent to the parent as they come; the piece returned."""
    send(("start", index, os.getpid()))
    with _deadline(deadline):
        return job.piece(
            a,
            b,
            w,
            lambda f: send(("progress", index, f)),
            lambda j, o: send(("point", index, j, o)),
        )


class _Relay:
    """The parent's side of :func:`_parallel`: the pieces as they come back, their progress summed
    over the range and their orbits passed on in branch order (those of a piece held until every
    piece before it is done)."""

    def __init__(self, cuts, lo: float, hi: float, progress, on_point, pool: ProcessPool):
        self.cuts, self.lo, self.hi = cuts, lo, hi
        self.progress, self.on_point, self.pool = progress, on_point, pool
        self.pieces: list[Piece | None] = [None] * len(cuts)
        self.held: list[list] = [[] for _ in cuts]  # orbits of pieces whose predecessors are not done
        self.frac = [0.0] * len(cuts)
        self.pids: dict[int, int] = {}  # piece -> pid of the worker computing it
        self.next = 0  # the first piece not passed on completely
        self.offset = 0  # branches of the pieces before it

    def message(self, msg) -> None:
        kind, i = msg[0], msg[1]
        if kind == "start":
            self.pids[i] = msg[2]
        elif kind == "progress":
            self.frac[i] = msg[2]
            if self.progress is not None:
                covered = sum(f * (b - a) for f, (a, b, _) in zip(self.frac, self.cuts, strict=True))
                self.progress(covered / (self.hi - self.lo))
        elif self.on_point is not None:  # "point"
            self.held[i].append((msg[2], msg[3]))
        self._pass_on()

    def done(self, i: int, piece: Piece) -> None:
        self.pieces[i] = piece
        self._pass_on()

    def failed(self, i: int, exc: Exception) -> None:
        if not isinstance(exc, BrokenProcessPool):
            raise WorkerError(
                f"frequency response: the worker of piece {i} failed: {type(exc).__name__}: {exc}"
            )
        codes = self.pool.exit_codes(wait=2.0)  # the worker that died, not those the pool ended after it
        died = [k for k, pid in self.pids.items() if codes.get(pid, -signal.SIGTERM) != -signal.SIGTERM]
        k = died[0] if died else i
        code = codes.get(self.pids.get(k, -1), "unknown")
        raise WorkerError(
            f"frequency response: the worker of piece {k} ended without a result (exit code {code})"
        )

    def give_up(self, left: list[int]) -> None:
        """The pieces ``left`` (not finished by the time limit) become gaps of the time limit,
        their orbits dropped (they belong to no branch kept)."""
        for i in left:
            a, b, w = self.cuts[i]
            self.pieces[i] = Piece(a, b, w, gaps=[(a, b)], timed_out=True)
            self.held[i] = []
        self._pass_on()

    def _pass_on(self) -> None:
        """The orbits of the pieces whose predecessors are done, in branch order."""
        while self.next < len(self.cuts):
            if self.on_point is not None:
                for j, o in self.held[self.next]:
                    self.on_point(self.offset + j, o)
            self.held[self.next] = []
            if self.pieces[self.next] is None:
                break
            self.offset += len(self.pieces[self.next].branches)
            self.next += 1


def _parallel(
    job: _PieceJob, cuts, workers: int, lo: float, hi: float, progress, on_point, while_computing=None
) -> list[Piece]:
    """The pieces computed on a pool of ``workers`` forked processes
    (:func:`hybrid.core.workers.run_calls`); progress and orbits relayed here;
    ``while_computing()`` once the workers have started. On an interrupt or an error every worker
    is stopped."""
    shared(job.system)  # the job and the workers' results refer to it
    deadline = current_deadline()
    calls = [(job, i, a, b, w, deadline) for i, (a, b, w) in enumerate(cuts)]

    def past_grace() -> bool:
        """The deadline passed :func:`_grace` ago and workers still run (one long integration that
        does not see it): stop them (issue 33: an IDA frc of a 12-contact ring ran 60 s past
        --max-time 900 and was stopped from outside, writing nothing)."""
        return deadline is not None and time.monotonic() > deadline[0] + _grace(deadline[1])

    with ProcessPool(workers) as pool:
        relay = _Relay(cuts, lo, hi, progress, on_point, pool)
        left = run_calls(
            pool,
            _piece_in_worker,
            calls,
            on_result=relay.done,
            on_error=relay.failed,
            on_message=relay.message,
            stop=past_grace,
            started=while_computing,
        )
        if left:
            pool.kill()  # the workers still computing: what they did is lost
        relay.give_up(left)
    return relay.pieces
