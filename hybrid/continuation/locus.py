"""Two-parameter continuation of a special point: its locus in a parameter plane (:func:`continue_locus`).

A special point of a one-parameter branch (a fold, a period doubling, a Neimark-Sacker or branch
point, a change of the mode sequence, the grazing that ends an autonomous branch, a Hopf point of
equilibria) is followed as a second parameter moves. Each point of the locus is a special point of
the same kind, located on a short one-parameter branch through the predicted point, across the
locus: in the branch's parameter where the locus runs more along the second one, else in the
second parameter. So every point carries the located point's interval and status
(:class:`hybrid.core.status.LocateStatus`), with the exact integrator located to the tolerance.

The predictor is the secant of the last two points in the plane (each parameter scaled by its
range); the step grows after an easy location and halves after a failed one. This is a
natural-parameter continuation of the locus, switching the parameter it holds fixed where the
locus turns, rather than the pseudo-arclength continuation of a minimally augmented system
(COCO, BifurcationKit, AUTO): it needs nothing of a kind but its location on a branch, so the
discontinuity-induced points are followed like the smooth ones.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace

import numpy as np

from ..core.callbacks import Progress
from ..core.errors import HybridError, InputError, InputTypeError
from ..core.notices import collected
from ..core.options import ContinuationOptions, reject_keywords
from ..core.status import BranchStatus, LocateStatus
from ..core.tables import Tabular, table_columns
from ..integrators.options import SolverOptions
from ..orbits.autonomous import autonomous_orbit
from ..orbits.equilibria import equilibrium, locate_hopf
from ..orbits.orbit import ORBIT_OPTIONS
from .autonomous import AUTONOMOUS_CONTINUATION, orbit_branch
from .branch import Branch
from .forced import continue_orbits

__all__ = ["Locus", "LocusPoint", "continue_locus", "LOCUS_KINDS"]

#: The kinds followed, by the kind of branch they lie on.
LOCUS_KINDS = {
    "forced-orbits": (
        "fold",
        "period-doubling",
        "neimark-sacker",
        "branch-point",
        "mode-gained",
        "mode-lost",
        "grazing",
        "sequence-change",
    ),
    "autonomous-orbits": ("grazing", "fold", "mode-gained", "mode-lost"),
    "equilibria": ("hopf", "real-eigenvalue"),
}


@dataclass
class LocusPoint:
    """One point of a locus.

    Attributes
    ----------
    values : dict
        The two parameters' values at the point.
    located : str
        The parameter it was located in (the other one held fixed).
    status : LocateStatus
        Of the location (as :class:`hybrid.SpecialPoint`'s).
    accuracy : float
        In ``located``.
    interval : tuple of float
        In ``located``: it holds the point.
    description : str
    solution : object
        The orbit or equilibrium at the point (not written to files).
    """

    values: dict
    located: str
    status: LocateStatus
    accuracy: float
    interval: tuple
    description: str
    solution: object = None


@dataclass
class Locus(Tabular):
    """The locus of a special point in a parameter plane (:func:`continue_locus`).

    Attributes
    ----------
    kind : str
    system : HybridSystem
    params : dict
        The other parameters' values.
    parameters : tuple of str
        ``(first, second)``: the branch's parameter and the second one.
    points : list of LocusPoint
        Along the locus, from one end to the other (the start among them).
    branch : Branch
        The one-parameter branch it came from.
    start : int
        Index in ``points`` of the branch's own special point.
    status : BranchStatus
        ``"completed"`` (both ends left the second parameter's range, or reached ``max_points``)
        or ``"stopped"``.
    message : str
        How each end ended.
    wall_time : float
        Seconds it took.
    """

    kind: str
    system: object
    params: dict
    parameters: tuple
    points: list = field(default_factory=list)
    branch: Branch | None = None
    start: int = 0
    status: BranchStatus = BranchStatus.COMPLETED
    message: str = ""
    wall_time: float = 0.0

    def values(self, name: str) -> np.ndarray:
        """The parameter ``name``'s value at every point."""
        return np.array([q.values[name] for q in self.points], dtype=float)

    def table(self) -> dict[str, list]:
        """The columns of :meth:`to_rows` (for :meth:`to_numpy`, :meth:`to_pandas`)."""
        return table_columns(self.to_rows())

    def to_rows(self) -> list[dict]:
        """One dict per point (for CSV)."""
        p1, p2 = self.parameters
        return [
            {
                "kind": self.kind,
                p1: q.values[p1],
                p2: q.values[p2],
                "located_in": q.located,
                "status": q.status,
                "accuracy": q.accuracy,
                "interval_lo": q.interval[0],
                "interval_hi": q.interval[1],
                "start": k == self.start,
                "description": q.description,
            }
            for k, q in enumerate(self.points)
        ]

    def __repr__(self) -> str:
        p1, p2 = self.parameters
        if not self.points:
            return f"Locus({self.kind} of {getattr(self.system, 'name', '?')} in ({p1}, {p2}): no point)"
        a, b = self.values(p2)[[0, -1]]
        return (
            f"Locus({self.kind} of {self.system.name} in ({p1}, {p2}): {len(self.points)} points, {p2} from "
            f"{a:.6g} to {b:.6g}; {self.status})"
        )


class _Lost(HybridError, RuntimeError):
    """The point was not found near the prediction."""


@collected
def continue_locus(
    branch: Branch,
    index: int,
    parameter: str,
    p_range: tuple[float, float],
    *,
    step: float = 0.02,
    max_points: int = 200,
    window: float | None = None,
    options: SolverOptions | None = None,
    settings: ContinuationOptions | None = None,
    progress: Progress | None = None,
    on_point: Callable[[LocusPoint], None] | None = None,
    **unexpected,
) -> Locus:
    """Follow special point ``index`` of ``branch`` as ``parameter`` moves over ``p_range``.

    Parameters
    ----------
    branch : Branch
        The one-parameter branch (forced orbits, autonomous orbits, equilibria).
    index : int
        Position in ``branch.special`` of a kind of :data:`LOCUS_KINDS`.
    parameter : str
        The second parameter.
    p_range : (float, float)
        Its range: the locus is followed from the branch's value both ways until it leaves it.
    step : float
        First step along the locus, in the plane of the two parameters each scaled by its range
        (the branch's span for the first); it grows to ``4 step`` and halves down to
        ``step / 256``.
    max_points : int
        Points per half of the locus at most.
    window : float, optional
        Half-width of the one-parameter branch that locates a point, relative to the first
        parameter's scale (default: four times the step's).
    options, settings
        Of the one-parameter branches (default: :data:`hybrid.ORBIT_OPTIONS` and those of the
        branch's kind; use the branch's own).
    progress : callable, optional
        ``progress(fraction)`` of the second parameter's range covered.
    on_point : callable, optional
        ``on_point(point)`` with every :class:`LocusPoint` as it is found.

    Returns
    -------
    Locus

    Raises
    ------
    hybrid.core.errors.InputError
        ``index`` is not a point of a kind followed, ``parameter`` is unknown or the branch's own,
        or the range does not contain the branch's value of ``parameter``.
    """
    reject_keywords("continue_locus", unexpected, options=SolverOptions, settings=ContinuationOptions)
    if not isinstance(branch, Branch):
        raise InputTypeError(f"`branch` must be a Branch, got {type(branch).__name__}")
    if not (isinstance(index, int | np.integer) and -len(branch.special) <= index < len(branch.special)):
        raise InputError(
            f"`index` must be the position of a special point of the branch (0 to {len(branch.special) - 1}), "
            f"got {index!r}"
        )
    sp = branch.special[index]
    kinds = LOCUS_KINDS.get(branch.kind, ())
    if sp.kind not in kinds:
        raise InputError(
            f"special point {index} is a {sp.kind}: on a branch of {branch.kind} the loci of "
            f"{', '.join(kinds)} are followed"
        )
    system = branch.system
    p1 = branch.parameter
    if parameter not in system.parameter_names or parameter == p1:
        raise InputError(
            f"the second parameter must be one of the model's other than `{p1}` "
            f"({', '.join(n for n in system.parameter_names if n != p1)}), got {parameter!r}"
        )
    lo2, hi2 = sorted(float(v) for v in p_range)
    v2 = float(branch.points[sp.index].params[parameter])
    if not (math.isfinite(lo2) and math.isfinite(hi2) and lo2 < hi2 and lo2 <= v2 <= hi2):
        raise InputError(
            f"`p_range` must be two different finite numbers around the branch's {parameter} = {v2:g}, "
            f"got {p_range!r}"
        )
    if not (step > 0 and math.isfinite(step)):
        raise InputError(f"`step` must be a positive number, got {step!r}")
    if not (isinstance(max_points, int) and max_points >= 1):
        raise InputError(f"`max_points` must be an integer >= 1, got {max_points!r}")
    options = ORBIT_OPTIONS if options is None else options
    t_start = time.perf_counter()
    vals = branch.values
    span1 = float(np.ptp(vals)) if vals.size > 1 else abs(sp.parameter) or 1.0
    scale = {p1: max(span1, 1e-12), parameter: hi2 - lo2}
    reloc = _relocator(branch, sp, options, settings)
    start = LocusPoint(
        {p1: sp.parameter, parameter: v2},
        p1,
        sp.status,
        sp.accuracy,
        sp.interval,
        sp.description,
        branch.points[sp.index],
    )
    if on_point is not None:
        on_point(start)
    halves, notes = [], []
    done = [0.0, 0.0]
    for h, sense in enumerate((1.0, -1.0)):

        def report(frac: float, h=h) -> None:
            done[h] = frac
            if progress is not None:
                progress(min(1.0, 0.5 * (done[0] + done[1])))

        pts, why = _trace(
            reloc, start, p1, parameter, (lo2, hi2), sense, scale, step, max_points, window, on_point, report
        )
        halves.append(pts)
        notes.append(f"{parameter} {'up' if sense > 0 else 'down'}: {why}")
    points = halves[1][::-1] + [start] + halves[0]
    locus = Locus(
        sp.kind,
        system,
        {k: v for k, v in branch.points[sp.index].params.items() if k not in (p1, parameter)},
        (p1, parameter),
        points,
        branch,
        len(halves[1]),
    )
    ended = [n for n in notes if "left the range" not in n and "max_points" not in n]
    if ended:
        locus.status = BranchStatus.STOPPED
    locus.message = "; ".join(notes)
    locus.wall_time = time.perf_counter() - t_start
    return locus


def _trace(reloc, start, p1, p2, rng2, sense, scale, step, max_points, window, on_point, report):
    """One half of the locus from ``start`` with ``p2`` moving by ``sense`` first."""
    pts: list[LocusPoint] = []
    prev, cur = None, start
    h = step
    miss, h_last = math.inf, step  # the last prediction's error (scaled) and its step
    lo2, hi2 = rng2
    for _ in range(max_points):
        if prev is None:
            t = np.array([0.0, sense])
        else:
            t = np.array(
                [
                    (cur.values[p1] - prev.values[p1]) / scale[p1],
                    (cur.values[p2] - prev.values[p2]) / scale[p2],
                ]
            )
            t /= max(float(np.linalg.norm(t)), 1e-300)
        found = None
        while found is None:
            pred = {p1: cur.values[p1] + h * t[0] * scale[p1], p2: cur.values[p2] + h * t[1] * scale[p2]}
            across, fixed = (p1, p2) if abs(t[1]) >= abs(t[0]) else (p2, p1)
            if window is not None:
                w = window * scale[across]
            else:  # four times the last prediction's error (scaled by the step), within 1e-4 .. 4 steps
                w = min(4.0 * h, max(1e-4 * h, 4.0 * miss * (h / max(h_last, 1e-300)) ** 2)) * scale[across]
            try:
                found = reloc(cur, fixed, pred[fixed], across, pred[across], w, t, scale[across])
            except (_Lost, HybridError, ArithmeticError, RuntimeError, ValueError) as exc:
                h *= 0.5
                if h < step / 256.0:
                    return pts, f"lost at {p2} = {cur.values[p2]:.8g} ({exc})"
                continue
            # a point only bracketed, its interval wider than a hundredth of the step (the short
            # branch met another point, or jumped): a shorter step first; accepted (with its honest
            # interval) only when the step is down to a sixteenth
            if (
                found.status != LocateStatus.LOCATED
                and not found.accuracy <= 0.01 * h * scale[across]
                and h >= step / 16.0
            ):
                found = None
                h *= 0.5
        miss = abs(found.values[across] - pred[across]) / scale[across]
        h_last = h
        v = found.values[p2]
        if not lo2 <= v <= hi2:
            end = _at_the_end(reloc, cur, found, p1, p2, hi2 if v > hi2 else lo2, t, scale, h)
            if end is not None:
                pts.append(end)
                if on_point is not None:
                    on_point(end)
            return pts, f"left the range at {p2} = {v:.8g}"
        pts.append(found)
        if on_point is not None:
            on_point(found)
        report(abs(v - start.values[p2]) / max(hi2 - lo2, 1e-300))
        prev, cur = cur, found
        h = min(4.0 * step, 1.5 * h)
    return pts, f"reached max_points = {max_points}"


def _at_the_end(reloc, cur: LocusPoint, found: LocusPoint, p1, p2, bound: float, t, scale, h: float):
    """The locus's point at ``p2 = bound`` (the end of the range it just left between ``cur`` and
    ``found``), located in ``p1``; None where that fails or the point is bracketed more loosely
    than an inner point is accepted (a hundredth of the step ``h``: e.g. only by the rounding
    margin of the exact flow, :func:`hybrid.continuation.special.rounding_margin`, is fine)."""
    s = (bound - cur.values[p2]) / (found.values[p2] - cur.values[p2])
    if not 0.0 < s < 1.0:
        return None
    guess = cur.values[p1] + s * (found.values[p1] - cur.values[p1])
    # (not narrower than 1e-4 of the first parameter's scale: on a locus nearly parallel to the
    # second parameter's axis the step moves the first by ~1e-13, and a branch over so short a
    # window located the isolator's band edge at c3 = 300 1.7e-13 off, outside its interval)
    w = max(abs(found.values[p1] - cur.values[p1]), 1e-4 * scale[p1])
    # located twice, from windows of two sizes: the end point is not checked by its neighbours on
    # the locus, so its interval is the union of the two (on the absorber's band edge at R = 0.55
    # one window's interval missed the closed form by 3e-13)
    ends = []
    for grow in (1.0, 2.5):
        try:
            end = reloc(cur, p2, float(bound), p1, guess, grow * w, t, scale[p1])
        except (_Lost, HybridError, ArithmeticError, RuntimeError, ValueError):
            return None
        if end.status != LocateStatus.LOCATED and not end.accuracy <= 0.01 * h * scale[p1]:
            return None
        ends.append(end)
    lo = min(e.interval[0] for e in ends)
    hi = max(e.interval[1] for e in ends)
    end = ends[0]
    acc = max(end.values[p1] - lo, hi - end.values[p1])
    status = (
        LocateStatus.LOCATED
        if all(e.status == LocateStatus.LOCATED for e in ends)
        else LocateStatus.BRACKETED
    )
    return replace(end, interval=(lo, hi), accuracy=acc, status=status)


# ----------------------------------------------------------------------------
def _relocator(branch: Branch, sp, options, settings):
    """``reloc(prev, fixed, value, across, guess, width, t) -> LocusPoint``: the special point of
    ``sp``'s kind on a branch in ``across`` through ``guess`` +- ``width`` at ``fixed = value``."""
    if branch.kind == "forced-orbits":
        return _ForcedRelocator(branch, sp, options, settings)
    if branch.kind == "equilibria":
        return _HopfRelocator(branch, sp)
    return _GrazingRelocator(branch, sp, options, settings)


#: Kinds that are one point seen from either side (a phase that sets in one way ends the other).
_SAME = {"mode-gained": ("mode-gained", "mode-lost"), "mode-lost": ("mode-gained", "mode-lost")}


def _nearest(br: Branch, kind: str, guess: float):
    cands = [q for q in br.special if q.kind in _SAME.get(kind, (kind,))]
    if not cands:
        raise _Lost(f"no {kind} on the branch over {br.values.min():.8g} .. {br.values.max():.8g}")
    return min(cands, key=lambda q: abs(q.parameter - guess))


def _existence(reloc, across: str, t: np.ndarray) -> float:
    """The side of the locus in ``across`` where the relocator's orbits exist (+1 above; +1 also
    where either side will do), from its normal (``reloc.normal``, in the plane (first, second),
    turned with the locus's tangent ``t``)."""
    if reloc.normal is None:
        return 1.0
    n = np.array([-t[1], t[0]])
    n = n if n @ reloc.normal >= 0 else -n
    reloc.normal = n
    return 1.0 if n[0 if across == reloc.p1 else 1] >= 0 else -1.0


def _side(branch: Branch, sp) -> float:
    """For a fold, the side of the first parameter where the branch exists (+1 above)."""
    p = branch.values
    k = sp.index
    nb = [p[j] for j in (k - 1, k + 1) if 0 <= j < p.size and p[j] != sp.parameter]
    return 1.0 if nb and np.mean(nb) > sp.parameter else -1.0


class _ForcedRelocator:
    def __init__(self, branch, sp, options, settings):
        self.branch, self.kind, self.options = branch, sp.kind, options
        self.settings = settings if settings is not None else ContinuationOptions()
        self.p1 = branch.parameter
        o = branch.points[sp.index]
        self.periods = max(1, round(o.period / branch.system.period_value(o.params)))
        # a fold: the normal to the locus, in the plane (first, second), towards the side where the
        # orbits exist; it follows the locus's turns
        self.normal = np.array([_side(branch, sp), 0.0]) if sp.kind == "fold" else None

    def __call__(self, prev: LocusPoint, fixed, value, across, guess, width, t, scale) -> LocusPoint:
        o = prev.solution
        system = self.branch.system
        params = {**o.params, fixed: value}
        sign = _existence(self, across, t)
        last = None
        # from the side where the orbits exist (a fold), else from below; Newton from the last
        # point's orbit, else after a transient; a wider window
        for grow, transient in ((1.0, 0), (1.0, self.settings.transient_periods), (3.0, 0), (9.0, 0)):
            a, b = guess + sign * grow * width, guess - sign * grow * width
            if self.normal is None:
                a, b = min(a, b), max(a, b)
            phase = o.t0 / o.period
            T = self.periods * system.period_value({**params, across: a})
            try:
                br = continue_orbits(
                    system,
                    params,
                    across,
                    (a, b),
                    x0=o.x0,
                    mode0=o.mode0,
                    t0=phase * T,
                    periods=self.periods,
                    options=self.options,
                    # the tolerance relative to the locus's scale of `across`, not the window's
                    settings=replace(
                        self.settings,
                        transient_periods=transient,
                        locate_tol=min(0.1, self.settings.locate_tol * scale / abs(b - a)),
                    ),
                )
                if not br.points:
                    raise _Lost(br.message)
                q = _nearest(br, self.kind, guess)
            except (_Lost, HybridError, ArithmeticError, RuntimeError, ValueError) as exc:
                last = exc
                continue
            return LocusPoint(
                {fixed: value, across: q.parameter},
                across,
                q.status,
                q.accuracy,
                q.interval,
                q.description,
                br.points[q.index],
            )
        raise _Lost(f"no {self.kind} near {across} = {guess:.8g} at {fixed} = {value:.8g}: {last}")


class _HopfRelocator:
    def __init__(self, branch, sp):
        self.branch, self.kind = branch, sp.kind
        eq = branch.points[sp.index]
        self.mode = eq.mode

    def __call__(self, prev: LocusPoint, fixed, value, across, guess, width, t, scale) -> LocusPoint:
        e = prev.solution
        params = {**e.params, fixed: value}
        system = self.branch.system
        last = None
        for grow in (1.0, 3.0, 9.0):
            a, b = guess - grow * width, guess + grow * width
            try:
                ea = equilibrium(system, {**params, across: a}, self.mode, e.x)
                eb = equilibrium(system, {**params, across: b}, self.mode, e.x)
                if not (ea.converged and eb.converged):
                    raise _Lost("no equilibrium at an end of the window")
                if ea.eigenvalues[0].real * eb.eigenvalues[0].real > 0:
                    raise _Lost("no change of stability in the window")
                hp = locate_hopf(system, params, self.mode, across, (a, b), ea.x)
            except (_Lost, HybridError, ArithmeticError, RuntimeError, ValueError) as exc:
                last = exc
                continue
            desc = f"{hp.kind}: frequency {hp.frequency:.9g} rad/s"
            return LocusPoint(
                {fixed: value, across: hp.parameter},
                across,
                LocateStatus(hp.status),
                hp.accuracy,
                tuple(hp.interval),
                desc,
                hp.equilibrium,
            )
        raise _Lost(f"no {self.kind} near {across} = {guess:.8g} at {fixed} = {value:.8g}: {last}")


class _GrazingRelocator:
    """The grazing (or fold, or change of modes) of an autonomous branch: the orbit from the previous
    point's, continued in ``across`` from inside the window (the side the branch came from) to
    past its other end."""

    def __init__(self, branch, sp, options, settings):
        self.branch, self.kind, self.options = branch, sp.kind, options
        self.settings = settings if settings is not None else AUTONOMOUS_CONTINUATION
        p = branch.values
        self.p1 = branch.parameter
        # the orbits exist on the side the branch came from: a normal of the locus towards them
        came_from = -1.0 if p.size < 2 or p[-1] >= p[0] else 1.0
        if sp.kind == "fold":
            came_from = _side(branch, sp)
        self.normal = np.array([came_from, 0.0])

    def __call__(self, prev: LocusPoint, fixed, value, across, guess, width, t, scale) -> LocusPoint:
        o = prev.solution
        params = {**o.params, fixed: value}
        last = None
        side = _existence(self, across, t)
        for grow in (1.0, 3.0, 9.0):
            a = guess + side * grow * width  # inside, where the orbit exists
            b = guess - side * grow * width
            try:
                orbit = autonomous_orbit(
                    self.branch.system, {**params, across: a}, o.x0, o.mode0, options=self.options
                )
                if not orbit.converged:
                    raise _Lost(f"no orbit at {across} = {a:.8g}: {orbit.message}")
                st = replace(
                    self.settings,
                    ds=0.25 * abs(b - a),
                    ds_max=0.5 * abs(b - a),
                    locate_tol=min(0.1, self.settings.locate_tol * scale / abs(b - a)),
                )
                br = orbit_branch(
                    orbit,
                    across,
                    (min(a, b), max(a, b)),
                    direction=1 if b > a else -1,
                    options=self.options,
                    settings=st,
                )
                q = _nearest(br, self.kind, guess)
            except (_Lost, HybridError, ArithmeticError, RuntimeError, ValueError) as exc:
                last = exc
                continue
            return LocusPoint(
                {fixed: value, across: q.parameter},
                across,
                q.status,
                q.accuracy,
                q.interval,
                q.description,
                br.points[q.index],
            )
        raise _Lost(f"no {self.kind} near {across} = {guess:.8g} at {fixed} = {value:.8g}: {last}")
