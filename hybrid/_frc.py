"""Frequency-response curves: continuation of periodic orbits in the forcing frequency over a range.

:func:`frequency_response` runs :func:`hybrid.continuation` piece by piece:
the range is cut between consecutive resonances of the linearised initial
mode (:func:`hybrid._linear.natural_frequencies`), so that each piece holds
one resonance; each piece is continued upwards from its lower end and, if
that branch stops (or turns back at a fold) before the upper end, downwards
from the upper end as well. What neither run covers is reported as a gap.
Nothing here knows the model: the resonances come from its equations.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field

import numpy as np

from ._budget import deadline_passed
from ._continuation import Branch, continuation, forcing_parameter
from ._linear import natural_frequencies
from ._system import HybridSystem

__all__ = ["FrequencyResponse", "frequency_response", "default_range"]

#: Default range around the resonances of the linearised initial mode, as factors of the lowest/highest one.
RANGE_FACTORS = (0.8, 1.2)


def default_range(system: HybridSystem, params: Mapping[str, float]) -> tuple[float, float]:
    """``(0.8 min, 1.2 max)`` of the natural frequencies of the initial mode at the zero state [rad/s].

    Raises
    ------
    ValueError
        If that linearisation has no oscillating mode.
    """
    w = natural_frequencies(system, params)
    if w.size == 0:
        raise ValueError(
            f"model `{system.name}`: its initial mode linearised at the zero state has no natural "
            "frequency to centre the range on; give the range (--omega-range A B)"
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
    """

    lo: float
    hi: float
    resonance: float | None
    branches: list = field(default_factory=list)
    gaps: list = field(default_factory=list)

    @property
    def gap(self) -> tuple | None:
        """The first gap (None if the piece is covered)."""
        return self.gaps[0] if self.gaps else None


@dataclass
class FrequencyResponse:
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
        Natural frequencies of the linearised initial mode [rad/s].
    pieces : list of Piece
    timed_out : bool
        The deadline of :func:`hybrid.time_limit` passed: what was not computed is a gap.
    """

    system: HybridSystem
    params: dict
    parameter: str
    p_range: tuple
    resonances: np.ndarray
    pieces: list = field(default_factory=list)
    timed_out: bool = False

    @property
    def branches(self) -> list[Branch]:
        return [b for pc in self.pieces for b in pc.branches]

    @property
    def gaps(self) -> list[tuple[float, float]]:
        return [g for pc in self.pieces for g in pc.gaps]

    @property
    def complete(self) -> bool:
        return not self.gaps and all(b.points for b in self.branches)

    def messages(self) -> list[str]:
        """What stopped a branch, and the gaps left."""
        out = [
            f"branch {k} ({_span(b)}): {b.message}"
            for k, b in enumerate(self.branches)
            if b.status != "completed"
        ]
        out += [
            f"no periodic orbit computed for {self.parameter} in ({a:.8g}, {b:.8g})" for a, b in self.gaps
        ]
        if self.timed_out:
            out.append("time limit reached (hybrid.time_limit; CLI --max-time): the gaps were not computed")
        return out

    def rows(self) -> list[dict]:
        """One dict per orbit of every branch (``branch`` index first), in branch order."""
        rows = []
        for k, b in enumerate(self.branches):
            for row in b.to_rows():
                rows.append({"branch": k, **row})
        return rows

    def special_rows(self) -> list[dict]:
        """One dict per special point; ``row`` is its index in :meth:`rows`."""
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
    p = b.p
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


def frequency_response(
    system: HybridSystem,
    params: Mapping[str, float],
    p_range: tuple[float, float],
    *,
    parameter: str | None = None,
    progress: Callable[[float], None] | None = None,
    on_point: Callable[[int, object], None] | None = None,
    **continuation_options,
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
    progress : callable, optional
        Called with the fraction of the range covered (0 to 1).
    on_point : callable, optional
        Called as ``on_point(branch_index, orbit)`` with every orbit as it is accepted (e.g. to
        write it at once: an interrupted computation keeps what it did).
    **continuation_options
        Passed on to :func:`hybrid.continuation` (``settings``, ``options``, ``ds``, ...).

    Returns
    -------
    FrequencyResponse

    Examples
    --------
    >>> import hybrid
    >>> from hybrid.cli import resolve_model
    >>> system = resolve_model("coulomb")
    >>> params = system.presets["forced"]
    >>> fr = hybrid.frequency_response(system, params, (0.6, 0.7))  # doctest: +SKIP
    """
    if parameter is None:
        parameter = forcing_parameter(system)
    lo, hi = (float(v) for v in p_range)
    if not (math.isfinite(lo) and math.isfinite(hi) and 0 < lo < hi):
        raise ValueError(f"the frequency range must satisfy 0 < A < B, got {lo!r}, {hi!r}")
    res = natural_frequencies(system, params)
    out = FrequencyResponse(system, dict(params), parameter, (lo, hi), res)

    def sink() -> Callable | None:
        if on_point is None:
            return None
        k = len(out.branches)  # the index of the branch about to be computed
        return lambda orbit: on_point(k, orbit)

    total = hi - lo
    done = 0.0

    def report(base: float, length: float) -> Callable[[float], None] | None:
        if progress is None:
            return None
        return lambda f: progress(min(1.0, (base + f * length) / total))

    for a, b, w in _cuts(lo, hi, res):
        piece = Piece(a, b, w)
        out.pieces.append(piece)
        if deadline_passed():
            out.timed_out, piece.gaps = True, [(a, b)]
            continue

        def run(start: float, end: float, covered: float, piece=piece) -> Branch:
            """A branch from ``start`` towards ``end`` (``covered``: range done before it, for progress)."""
            br = continuation(
                system,
                params,
                parameter,
                (start, end),
                progress=report(covered, abs(end - start)),
                on_point=sink(),
                **continuation_options,
            )
            piece.branches.append(br)
            out.timed_out = out.timed_out or (br.status == "stopped" and deadline_passed())
            return br

        # A start that fails at the end of the range (e.g. a degenerate orbit there), or a branch
        # that stalls at its first point, is retried a little inside it; what lies before is a gap.
        for start in [a] + [a + f * (b - a) for f in NO_START_RETRY]:
            up = run(start, b, done + (start - a))
            stuck = up.reason == "no-start" or (up.reason == "stalled" and len(up.points) <= 1)
            if not stuck or deadline_passed():
                break
        reach = float(np.max(up.p)) if up.points else a
        if reach < b and deadline_passed():
            out.timed_out = True
        elif reach < b:
            run(b, reach, done + (reach - a))
        piece.gaps = _uncovered(
            a, b, [(float(np.min(br.p)), float(np.max(br.p))) for br in piece.branches if br.points]
        )
        done += b - a
        if progress is not None:
            progress(done / total)
    return out
