"""Recording a run: the sink interface, the engine's sample buffer, and a min/max envelope.

A *sink* receives the samples of a run in blocks and its switches one by one
while the run goes on, so that a long run can be written to disk (see
:class:`hybrid.engine.io.TrajectoryCSVWriter`) or reduced on the fly (see
:class:`Envelope`) in constant memory. Any object with the two methods of
:class:`Sink` is one; :class:`Tee` hands a run to several.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Callable, Mapping, Sequence

import numpy as np

from ..core.errors import InputError, SampleCapReached
from .trajectory import TransitionRecord

__all__ = ["Sink", "Tee", "Envelope", "Recorder", "MAX_SAMPLES", "MAX_STREAMED_SAMPLES"]

#: Samples a trajectory may hold in memory.
MAX_SAMPLES = 2_000_000
#: Samples a run may hand to a sink.
MAX_STREAMED_SAMPLES = 1_000_000_000
#: Samples handed to a sink at once.
BLOCK = 4096


class Sink:
    """Receiver of a run's samples and switches, while it runs (all methods do nothing here).

    Subclass it and override what you need, or give any object with the same
    two methods. Samples arrive in time order, in blocks; switches arrive in
    order, each once its state after the switch is complete. The two streams
    are not interleaved in time: a switch may arrive before the block holding
    the samples that precede it.
    """

    def samples(
        self, t: np.ndarray, y: np.ndarray, mode: np.ndarray, outputs: Mapping[str, np.ndarray]
    ) -> None:
        """A block of ``k`` consecutive samples.

        Parameters
        ----------
        t : ndarray, shape (k,)
            Sample times [s], non-decreasing (a switch sampled on both sides
            appears twice).
        y : ndarray, shape (k, n_vars)
            Every variable at the samples (model units), in the system's
            variable order.
        mode : ndarray of str, shape (k,)
            Mode at each sample.
        outputs : mapping of str to ndarray, shape (k,)
            The system's outputs at the samples (model units).

        The arrays belong to the sink (the engine does not reuse them).
        """

    def event(self, record: TransitionRecord) -> None:
        """One switch of the event log (time [s], modes, transition, states before and after)."""


class Tee(Sink):
    """A sink that hands everything to each of ``sinks``, in order."""

    def __init__(self, *sinks: Sink):
        self.sinks = sinks

    def samples(self, t, y, mode, outputs) -> None:
        for s in self.sinks:
            s.samples(t, y, mode, outputs)

    def event(self, record: TransitionRecord) -> None:
        for s in self.sinks:
            s.event(record)


class Envelope(Sink):
    """Minimum and maximum of some variables or outputs over fixed time buckets, in constant memory.

    The span ``[t0, t1]`` is cut into ``buckets`` equal buckets; each keeps
    the least and the greatest sample of each quantity and when they were
    taken. :meth:`series` joins them in time order: drawn as a line it looks
    like the line through every sample once a bucket is narrower than a
    pixel (a min/max decimation).

    Parameters
    ----------
    names : sequence of str
        Quantities to follow: variables (columns of the samples' ``y``) or outputs.
    variables : sequence of str
        The system's variable names, in state order.
    t_span : (float, float)
        Time span of the run [s], ``t0 < t1``.
    buckets : int
        Number of time buckets (memory: 4 floats per bucket and quantity).
    """

    def __init__(
        self, names: Sequence[str], variables: Sequence[str], t_span: Sequence[float], buckets: int = 2000
    ):
        t0, t1 = (float(v) for v in t_span)
        if not (math.isfinite(t0) and math.isfinite(t1) and t1 > t0):
            raise InputError(f"`t_span` must be finite with t1 > t0, got {t_span!r}")
        if isinstance(buckets, bool) or not isinstance(buckets, int) or buckets < 1:
            raise InputError(f"`buckets` must be an integer >= 1, got {buckets!r}")
        self.names = tuple(names)
        self.variables = tuple(variables)
        self.t0, self.t1, self.buckets = t0, t1, buckets
        self.lo = {n: np.full(buckets, np.inf) for n in self.names}
        self.hi = {n: np.full(buckets, -np.inf) for n in self.names}
        self.t_lo = {n: np.full(buckets, np.nan) for n in self.names}
        self.t_hi = {n: np.full(buckets, np.nan) for n in self.names}
        self.count = 0

    def samples(self, t, y, mode, outputs) -> None:
        t = np.asarray(t, dtype=float)
        if t.size == 0:
            return
        self.count += t.size
        scale = self.buckets / (self.t1 - self.t0)
        b = np.clip(np.floor((t - self.t0) * scale), 0, self.buckets - 1).astype(np.int64)
        starts = np.flatnonzero(np.r_[True, b[1:] != b[:-1]])  # t is non-decreasing: b too
        ub = b[starts]
        for n in self.names:
            v = y[:, self.variables.index(n)] if n in self.variables else np.asarray(outputs[n], dtype=float)
            # extremum of each run of equal buckets, and the index where it is reached
            i_lo = np.lexsort((v, b))[starts]
            i_hi = np.lexsort((-v, b))[starts]
            better = v[i_lo] < self.lo[n][ub]
            self.lo[n][ub[better]] = v[i_lo[better]]
            self.t_lo[n][ub[better]] = t[i_lo[better]]
            better = v[i_hi] > self.hi[n][ub]
            self.hi[n][ub[better]] = v[i_hi[better]]
            self.t_hi[n][ub[better]] = t[i_hi[better]]

    def series(self, name: str) -> tuple[np.ndarray, np.ndarray]:
        """Times [s] and values of the extrema of ``name``, in time order (two per filled bucket)."""
        filled = np.isfinite(self.lo[name])
        tt = np.column_stack([self.t_lo[name][filled], self.t_hi[name][filled]])
        vv = np.column_stack([self.lo[name][filled], self.hi[name][filled]])
        order = np.argsort(tt, axis=1, kind="stable")
        return np.take_along_axis(tt, order, 1).ravel(), np.take_along_axis(vv, order, 1).ravel()

    def bounds(self, name: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Centres [s] of the filled buckets, and the minimum and maximum of ``name`` in each."""
        filled = np.isfinite(self.lo[name])
        width = (self.t1 - self.t0) / self.buckets
        centres = self.t0 + (np.flatnonzero(filled) + 0.5) * width
        return centres, self.lo[name][filled], self.hi[name][filled]


class Recorder:
    """The engine's sample and event buffer.

    Samples are written into a preallocated block (time, state, mode index);
    a full block gets its outputs evaluated and is handed to the sink, then
    kept in memory: all of it without a sink, else only the last ``keep_last``
    seconds of the run (and at most ``max_kept`` samples; older whole blocks
    are dropped as the run goes on, and the rest is cut exactly at the end).
    Events are handed to the sink as they complete and kept by the same rule.

    Parameters
    ----------
    n_vars : int
        Number of variables.
    mode_names : callable
        ``mode_names(m) -> ndarray of str``: the names of the modes with indices ``m`` (an integer
        array), e.g. :meth:`hybrid.model.compiled.CompiledSystem.mode_names_of`.
    evaluate : callable
        ``evaluate(t, y, m) -> {output: ndarray (k,)}`` for a block.
    sink : Sink, optional
        Receiver of the samples and events.
    keep_last : float
        With a sink: seconds at the end of the run whose samples and events
        are kept [s] (0: only the last sample).
    max_kept, max_total : int
        Caps on the samples held in memory and on all samples of the run;
        exceeding one raises :class:`SampleCapReached` (a sink's kept window
        is cut to ``max_kept`` instead).
    block : int, optional
        Samples per block (default :data:`BLOCK`).
    """

    def __init__(
        self,
        n_vars: int,
        mode_names,
        evaluate: Callable[[np.ndarray, np.ndarray, np.ndarray], dict[str, np.ndarray]],
        sink: Sink | None = None,
        keep_last: float = 0.0,
        max_kept: int = MAX_SAMPLES,
        max_total: int = MAX_STREAMED_SAMPLES,
        block: int | None = None,
    ):
        self.mode_names = mode_names
        self.evaluate = evaluate
        self.sink = sink
        self.keep_last = float(keep_last)
        self.max_kept = max_kept
        self.max_total = max_total if sink is not None else min(max_total, max_kept)
        self.block = block = BLOCK if block is None else block
        self._t = np.empty(block)
        self._y = np.empty((block, n_vars))
        self._m = np.empty(block, dtype=np.int32)
        self._k = 0
        self.chunks: deque[tuple[np.ndarray, np.ndarray, np.ndarray, dict[str, np.ndarray]]] = deque()
        self.n_kept = 0
        self.n_total = 0
        self.samples_dropped = 0
        self.cutoff = -math.inf  # samples and events before it are dropped
        self.events: deque[TransitionRecord] = deque()
        self.events_dropped = 0
        self.mode_after_dropped: str | None = None  # target of the last dropped event

    @property
    def n_events(self) -> int:
        """Events received so far (kept and dropped)."""
        return len(self.events) + self.events_dropped

    def add(self, t: float, y: np.ndarray, mode: int) -> None:
        """Record one sample (``y`` is copied)."""
        if self.n_total >= self.max_total:
            where = "handed to a sink" if self.sink is not None else "kept in memory"
            hint = "" if self.sink is not None else "stream them to a sink or "
            raise SampleCapReached(
                f"stopped at t={t!r} after {self.n_total} samples, the most a run may have {where}: "
                f"{hint}sample less (`samples_per_period`, `t_eval`)"
            )
        k = self._k
        self._t[k] = t
        self._y[k] = y
        self._m[k] = mode
        self._k = k + 1
        self.n_total += 1
        if self._k == self.block:
            self.flush()

    def add_many(self, t: np.ndarray, y: np.ndarray, mode: int) -> None:
        """Record samples ``(t[i], y[i])`` of one mode (as :meth:`add` one by one, in blocks)."""
        i, n = 0, t.size
        while i < n:
            if self.n_total >= self.max_total:
                self.add(float(t[i]), y[i], mode)  # raises SampleCapReached
            k = self._k
            j = min(n, i + self.block - k, i + self.max_total - self.n_total)
            self._t[k : k + j - i] = t[i:j]
            self._y[k : k + j - i] = y[i:j]
            self._m[k : k + j - i] = mode
            self._k = k + j - i
            self.n_total += j - i
            i = j
            if self._k == self.block:
                self.flush()

    def add_event(self, record: TransitionRecord) -> None:
        """Record one completed switch."""
        if self.sink is not None:
            self.sink.event(record)
        self.events.append(record)

    def flush(self) -> None:
        """Evaluate the outputs of the buffered samples and hand them on."""
        k = self._k
        if k == 0:
            return
        self._k = 0
        t, y, m = self._t[:k].copy(), self._y[:k].copy(), self._m[:k].copy()
        outputs = self.evaluate(t, y, m)
        if self.sink is not None:
            self.sink.samples(t, y, self.mode_names(m), outputs)
        self.chunks.append((t, y, m, outputs))
        self.n_kept += k
        if self.sink is not None:
            self._trim(float(t[-1]) - self.keep_last)

    def _trim(self, cutoff: float) -> None:
        """Drop whole blocks before ``cutoff`` [s] or beyond ``max_kept``, and the events before them."""
        self.cutoff = max(self.cutoff, cutoff)
        chunks = self.chunks
        while len(chunks) > 1 and chunks[0][0][-1] < self.cutoff:
            self._drop_first()
        while len(chunks) > 1 and self.n_kept - chunks[0][0].size >= self.max_kept:
            self._drop_first()
            self.cutoff = max(self.cutoff, float(chunks[0][0][0]))
        self._drop_events()

    def _drop_first(self) -> None:
        size = self.chunks.popleft()[0].size
        self.n_kept -= size
        self.samples_dropped += size

    def _drop_events(self) -> None:
        while self.events and self.events[0].t < self.cutoff:
            ev = self.events.popleft()
            self.events_dropped += 1
            self.mode_after_dropped = ev.target

    def finish(self, t_final: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, dict[str, np.ndarray]]:
        """Flush, cut the kept window exactly, and return its ``(t, y, mode index, outputs)``.

        Afterwards :attr:`cutoff` is where the kept window starts [s]: the
        samples and events from it on are kept (with a sink: at least the last
        sample, even if the run stopped before ``t_final - keep_last``).
        """
        self.flush()
        t, y, m, out = self._joined()
        start = 0
        if self.sink is not None and t.size:
            self.cutoff = max(self.cutoff, t_final - self.keep_last)
            start = int(np.searchsorted(t, self.cutoff, side="left"))
            if start >= t.size:  # the window holds no sample: keep the last one
                start = t.size - 1
                self.cutoff = float(t[start])
            elif t.size - start > self.max_kept:
                start = t.size - self.max_kept
                self.cutoff = float(t[start])
        if start > 0:
            self.samples_dropped += start
            self.n_kept -= start
            t, y, m = t[start:], y[start:], m[start:]
            out = {o: v[start:] for o, v in out.items()}
        self._drop_events()
        return t, y, m, out

    def _joined(self):
        chunks = list(self.chunks)
        self.chunks.clear()
        if not chunks:
            t, y, m = np.empty(0), np.empty((0, self._y.shape[1])), np.empty(0, dtype=np.int32)
            return t, y, m, self.evaluate(t, y, m)
        if len(chunks) == 1:
            return chunks[0]
        t = np.concatenate([c[0] for c in chunks])
        y = np.concatenate([c[1] for c in chunks])
        m = np.concatenate([c[2] for c in chunks])
        out = {o: np.concatenate([c[3][o] for c in chunks]) for o in chunks[0][3]}
        return t, y, m, out
