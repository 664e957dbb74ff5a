"""Special points of a branch of periodic orbits: detection between two points and location.

Between two consecutive points ``a`` and ``b`` of a branch (see :func:`hybrid.continue_orbits`):

* ``fold``: the parameter component of the tangent changes sign;
* ``period-doubling``: ``det(M + I)`` (the product of ``mu + 1`` over the Floquet multipliers)
  changes sign;
* ``neimark-sacker``: ``prod_{i<j} (mu_i mu_j - 1)`` changes sign with a complex pair;
* ``branch-point``: ``det(M - I)`` changes sign without a fold (a multiplier through +1 where the
  branch does not turn: a pitchfork or a transcritical point, where another branch crosses);
* ``mode-gained`` / ``mode-lost`` / ``grazing`` / ``sequence-change``: the orbit's signature
  changes (the modes occupied for a positive time, the number of switch instants, their cyclic
  order);
* ``nonsmooth``: multipliers jump through -1 or the unit circle *at* a change of the mode
  sequence (the map is only piecewise smooth there: no smooth bifurcation is claimed).

The smooth ones are reported only where the signature is the same at both ends. They are located
by regula falsi (Illinois) on their test function along the arclength of the step; a change of
signature by bisection of the signature's change, accelerated by the zero of the vanishing phase's
duration extrapolated from the probes that still have it.

Every point carries an ``interval`` that holds it (the :class:`hybrid.core.status.LocateStatus`
says how well it is known):

* a fold's parameter is extremal: every computed orbit lies on the branch's side of it, so the
  interval runs from the most extreme probe to the intersection of the branch's tangent lines at
  the two probes that bracket the turn (a bound where the branch is concave there, as it is near a
  quadratic fold), widened by half its length;
* a sign change of a smooth test function is bracketed by the two probes around it;
* a phase that vanishes is bracketed by the last probe that has it and the first that does not,
  widened by what the runs cannot resolve: a phase shorter than the integrator's resolution of a
  switch time (rounding for the exact flow, :data:`EXACT_PHASE_RESOLUTION`) may be missing from a
  probe that has it, so the interval reaches as far past the last probe without it as the phase's
  duration, falling towards zero at least linearly, allows; it is narrowed to the zeros of the
  duration extrapolated from the nearest probes with a square-root and a linear law (the point
  lies between them for every power in between, :func:`power_bounds`);
* on a noisy map (IDA) a phase near the point may be missing from a probe or shown where it is
  not: the interval is the bracket of the signatures widened to the same extrapolated zeros, from
  the nearest probes whose durations exceed their integration errors, estimated by rerunning each
  at tolerances :data:`hybrid.continuation.forced.TIGHTER` times tighter; then widened by how far
  the tolerances move the point itself (:func:`orbit_error_margin`: the orbit is the fixed point
  of the computed map, and its phase near the point is off by more than one run's error).

On the exact flow the intervals of mode changes, period doublings and Neimark-Sacker points are
then widened by what rounding leaves unresolved (:func:`rounding_margin`): the computed orbits are
right to rounding times the conditioning of the periodic-orbit problem, not exactly, and a probe
next to the point may sit on the wrong side of it by that much.

A point is ``located`` when its interval's half-width (with that margin) is below the caller's
tolerance (``ContinuationOptions.locate_tol`` times the range), else ``bracketed``.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field

import numpy as np

from ..core.options import ShootingOptions
from ..core.status import SPECIAL_KINDS, LocateStatus
from ..orbits.newton import NewtonMap
from ..orbits.shooting import shoot_orbit

__all__ = [
    "SpecialPoint",
    "signature",
    "detect",
    "locate",
    "phases",
    "power_bounds",
    "thin",
    "interval_fields",
    "SPECIAL_KINDS",
    "fold_integration_error",
]


@dataclass(frozen=True)
class SpecialPoint:
    """A bifurcation, mode-sequence change or end of a branch.

    Attributes
    ----------
    kind : str
        One of :data:`hybrid.core.status.SPECIAL_KINDS`: ``"fold"``, ``"period-doubling"``,
        ``"neimark-sacker"``, ``"branch-point"``, ``"mode-gained"``, ``"mode-lost"``,
        ``"grazing"``, ``"sequence-change"``, ``"nonsmooth"`` or ``"unbounded"`` (the branch grows
        without bound: it ends there); on a branch of equilibria ``"hopf"``, ``"real-eigenvalue"``
        or ``"boundary-equilibrium"``.
    index : int
        Index in ``Branch.points`` of the orbit (or equilibrium) at (or nearest to) the point.
    parameter : float
        Parameter value at the point (for ``bracketed``, inside ``interval``; for
        ``"not located"``, the end of the known side).
    amplitude : dict
        ``max |x|`` per variable and output of that orbit (of an equilibrium: ``|x|`` per variable).
    description : str
        What changes there (and, if not located, why).
    status : LocateStatus
        ``"located"``: ``parameter`` is within ``accuracy`` of the point, to the tolerance the
        caller asked for (``ContinuationOptions.locate_tol``); ``"bracketed"``: the point lies in
        ``interval``, wider than the tolerance; ``"not located"``: only one side is known
        (``interval`` is half-infinite).
    accuracy : float
        Largest distance from ``parameter`` to the ends of ``interval`` (``inf`` if not located).
        A fold's (forced orbits, IDA) includes the runs' integration error, estimated by a rerun at
        tighter tolerances (:func:`fold_integration_error`: a Duffing fold found to 3e-14 on the
        branch as computed at rtol 1e-8 lies 3.7e-10 from the exact fold; its interval is widened
        by 1.4e-9); a mode change's includes it too. For the other smooth kinds on IDA (period
        doubling, Neimark-Sacker, branch point, and folds of autonomous orbits) it bounds the
        error of ``parameter`` as a point of the branch *as computed* only; the exact integrator
        or a tighter ``rtol`` removes the rest. On the exact integrator a mode change's, a period
        doubling's and a Neimark-Sacker point's include the rounding margin
        (:func:`rounding_margin`: ``4 eps |p|`` times the condition number of ``I - M``, 6e-13
        to 2e-11 on the dampers' band edges); a fold's and a branch point's do not (``I - M`` is
        singular there).
    interval : tuple of float
        Parameter values that hold the point.
    """

    kind: str
    index: int
    parameter: float
    amplitude: dict
    description: str
    status: LocateStatus = LocateStatus.LOCATED
    accuracy: float = math.nan
    interval: tuple = field(default=(math.nan, math.nan))

    def __post_init__(self):
        object.__setattr__(self, "status", LocateStatus(self.status))

    def contains(self, value: float) -> bool:
        """Whether ``value`` lies in :attr:`interval` (ends included)."""
        return bool(self.interval[0] <= value <= self.interval[1])

    def __repr__(self) -> str:
        lo, hi = self.interval
        if self.status == LocateStatus.LOCATED:
            where = f"at {self.parameter:.10g} (located, +-{self.accuracy:.2g})"
        elif self.status == LocateStatus.BRACKETED:
            where = f"in [{lo:.10g}, {hi:.10g}] (bracketed)"
        else:
            where = f"in [{lo:.10g}, {hi:.10g}] (not located)"
        return f"SpecialPoint({self.kind} {where}, point {self.index}: {self.description})"


def interval_fields(p: float, lo: float, hi: float) -> tuple[float, float, tuple[float, float]]:
    """``(parameter, accuracy, interval)`` of a point known to lie in ``[lo, hi]`` and reported at
    ``p`` (clipped into it)."""
    lo, hi = min(lo, hi), max(lo, hi)
    p = min(max(p, lo), hi)
    return p, max(p - lo, hi - p), (lo, hi)


# ----------------------------------------------------------------------
def _cyclic(seq: list[str]) -> tuple[str, ...]:
    """Smallest rotation of a cyclic sequence with consecutive repeats merged."""
    out = [m for k, m in enumerate(seq) if k == 0 or m != seq[k - 1]]
    if len(out) > 1 and out[0] == out[-1]:
        out.pop()
    if not out:
        return ()
    rots = [tuple(out[k:] + out[:k]) for k in range(len(out))]
    return min(rots)


def signature(o) -> tuple:
    """Switch instants per period, the modes occupied for a positive time, and their cyclic order.

    A mode passed through at one instant (a chained switch) does not count, so the loss of a
    phase is seen; the cyclic order does not depend on where the section lies. For a system with
    components, modes are those of its parts (``component.mode``, see
    :attr:`hybrid.HybridSystem.local_mode_names`) and the order is each part's own: two components
    that switch in the other order (a crossing of their switch times) change neither.
    """
    instants = sum(1 for e in o.trajectory.events if not e.chained)
    ivs = [m for a, b, m in o.trajectory.mode_intervals() if b > a]
    system = o.system
    if not system.components:
        return instants, frozenset(m for m, f in o.mode_fractions.items() if f > 0), _cyclic(ivs)
    parts = [system.local_modes_of(m) for m in ivs]
    order = tuple(_cyclic([p[k] for p in parts]) for k in range(1 + len(system.components)))
    return instants, frozenset(m for m, f in o.local_fractions.items() if f > 0), order


def _fractions(o) -> dict:
    """Time fractions of the modes :func:`signature` counts: the system's, or its parts' local modes."""
    return o.local_fractions if o.system.components else o.mode_fractions


def _order_text(sig: tuple) -> str:
    """A signature's cyclic order as text (for a system with components, each part's, joined by ``;``)."""
    if sig[2] and isinstance(sig[2][0], tuple):
        return "; ".join(" ".join(part) for part in sig[2])
    return " ".join(sig[2])


def _orders(sa: tuple, sb: tuple) -> str:
    """The cyclic orders of two signatures, where they differ (for a system with components, the
    parts whose order changes)."""
    if not sa[2] or not isinstance(sa[2][0], tuple):
        return f"modes {' '.join(sa[2])} -> {' '.join(sb[2])}"
    diff = [(a, b) for a, b in zip(sa[2], sb[2], strict=True) if a != b][:3]
    return "; ".join(f"{' '.join(a)} -> {' '.join(b)}" for a, b in diff) or "the same modes"


def phases(o) -> list[tuple[str, float]]:
    """The orbit's phases over one period as ``(mode, fraction of the period)``, in order; a phase
    cut by the section (the first and the last interval, in one mode) counted once."""
    tr = o.trajectory
    ivs = [(b - a, m) for a, b, m in tr.mode_intervals() if b > a]
    span = tr.t_final - tr.t_start
    if not ivs or not span > 0:
        return []
    if len(ivs) > 1 and ivs[0][1] == ivs[-1][1]:
        ivs[0] = (ivs[0][0] + ivs[-1][0], ivs[0][1])
        ivs.pop()
    return [(m, d / span) for d, m in ivs]


def tests(o, isolated: bool = False) -> tuple[float, float, float] | None:
    """``(det(M + I), prod over pairs (mu_i mu_j - 1), det(M - I))`` on the Floquet multipliers
    (real parts); None on a family (a neutral multiplier 1), unless ``isolated`` (a branch point's
    probe, whose multiplier 1 is the branch point's, not a family's)."""
    if o.family and not isolated:
        return None
    # (a branch point's neutral multiplier is its own: kept)
    lam = o.multipliers[np.array([k != "structural" for k in o.multiplier_kinds], dtype=bool)]
    if not isolated:
        lam = o.floquet_multipliers
    pd = float(np.real(np.prod(lam + 1.0)))
    bp = float(np.real(np.prod(lam - 1.0)))
    ns = 1.0 + 0j
    for i in range(lam.size):
        for j in range(i + 1, lam.size):
            ns *= lam[i] * lam[j] - 1.0
    return pd, float(np.real(ns)), bp


#: The smooth kinds, located by regula falsi on their test function, and its index in :func:`tests`.
SMOOTH = {"fold": None, "period-doubling": 0, "neimark-sacker": 1, "branch-point": 2}


def detect(a, b) -> list[tuple[str, str]]:
    """Special points between two points of a branch (``ContinuationPoint`` with orbit and tangent)."""
    out = []
    oa, ob = a.orbit, b.orbit
    fold = a.tangent.size == b.tangent.size and a.tangent[-1] * b.tangent[-1] < 0
    if fold:
        out.append(("fold", "the branch turns back in the parameter (a multiplier crosses +1)"))
    sa, sb = signature(oa), signature(ob)
    ta, tb = tests(oa), tests(ob)
    jumps = []
    if ta is not None and tb is not None:
        if ta[0] * tb[0] < 0:
            jumps.append(("period-doubling", "a multiplier crosses -1"))
        if ta[1] * tb[1] < 0 and np.any(np.abs(ob.floquet_multipliers.imag) > 1e-9):
            jumps.append(("neimark-sacker", "a complex pair of multipliers crosses the unit circle"))
        if ta[2] * tb[2] < 0 and not fold:
            jumps.append(
                (
                    "branch-point",
                    "a multiplier crosses +1 without a fold: another branch crosses here "
                    "(a pitchfork or a transcritical point)",
                )
            )
    if sa == sb:
        out += jumps
    else:
        gained, lost = sb[1] - sa[1], sa[1] - sb[1]
        if gained:
            out.append(("mode-gained", f"mode(s) {', '.join(sorted(gained))} appear(s) in the orbit"))
        elif lost:
            out.append(("mode-lost", f"mode(s) {', '.join(sorted(lost))} leave(s) the orbit"))
        elif sa[0] != sb[0]:
            out.append(
                (
                    "grazing",
                    f"switches per period change from {sa[0]} to {sb[0]} ({_orders(sa, sb)})",
                )
            )
        else:
            out.append(("sequence-change", f"the order of the modes changes: {_orders(sa, sb)}"))
        for kind, desc in jumps:
            if kind == "branch-point":
                desc = "a multiplier crosses +1"
            out.append(("nonsmooth", f"{desc.replace('crosses', 'jumps across')} at the change of modes"))
    return out


# ----------------------------------------------------------------------
class _Located:
    """The result of :func:`locate`: the point's orbit, status, parameter, interval, accuracy."""

    def __init__(
        self, point, status: str, p: float, interval: tuple, note: str = "", tol: float | None = None
    ):
        self.point = point  # a ContinuationPoint (None: no orbit computed inside the step)
        self.parameter, self.accuracy, self.interval = interval_fields(p, *interval)
        self.status = LocateStatus(status)
        if tol is not None:  # the status follows from the interval
            self.status = LocateStatus.LOCATED if self.accuracy <= tol else LocateStatus.BRACKETED
            if self.status == LocateStatus.BRACKETED and not note:
                note = "not located to the tolerance"
        self.note = note if self.status != LocateStatus.LOCATED else ""


#: A located fold's last two probes lie within this fraction of the step in arclength.
FOLD_ARCLENGTH_TOL = 1e-7

#: A fold's interval past the intersection of the tangent lines, as a fraction of its length (the
#: cubic term of the branch near the fold, neglected by the bound).
FOLD_MARGIN = 0.5


def _value(kind: str, pt, a) -> float:
    """Smooth test function of ``kind`` at ``pt`` (sign relative to ``a`` is not applied)."""
    if kind == "fold":
        return float(pt.tangent[-1]) if pt.tangent.size == a.tangent.size else math.nan
    t = tests(pt.orbit, isolated=kind == "branch-point")
    if t is None:
        return math.nan
    return t[SMOOTH[kind]]


def _slope(c, a, pt) -> float:
    """``dp/dsigma`` at ``pt``, ``sigma`` the arclength of the step from ``a`` (the projection on
    ``a``'s scaled tangent, which the corrector holds)."""
    dot = float(a.tangent @ pt.tangent) if pt.tangent.size == a.tangent.size else 0.0
    return c.sp * float(pt.tangent[-1]) / dot if dot > 0 else math.nan


def _fold_interval(c, a, lo: tuple, hi: tuple, known: float) -> tuple[float, float]:
    """An interval that holds the fold turned within ``lo = (s, point)`` .. ``hi``: from ``known``
    (the most extreme parameter computed: a fold's parameter is extremal) to the intersection of the
    tangent lines at the two points (an upper bound of a concave branch), widened by
    :data:`FOLD_MARGIN` of its length."""
    (s1, q1), (s2, q2) = lo, hi
    m1, m2 = _slope(c, a, q1), _slope(c, a, q2)
    if not (math.isfinite(m1) and math.isfinite(m2)) or m1 * m2 >= 0:
        bound = math.nan
    else:
        sx = (q2.p - q1.p + m1 * s1 - m2 * s2) / (m1 - m2)
        bound = q1.p + m1 * (sx - s1)
    up = m1 > 0 if math.isfinite(m1) else q2.p >= q1.p  # a maximum of p along the step
    if not math.isfinite(bound) or (bound < known if up else bound > known):
        # no bound from the tangents (e.g. a corner rather than a fold): the step's extent past it
        bound = known + (1.0 if up else -1.0) * abs(q2.p - q1.p)
    bound += FOLD_MARGIN * (bound - known)
    return (known, bound) if up else (bound, known)


#: A probe farther than this from the chord of its bracket, relative to the chord's length, is
#: taken for a point of another branch (one that crosses this one at a branch point).
CHORD_DEVIATION = 0.25


def _on_branch(c, lo: tuple, hi: tuple, s: float, pt) -> bool:
    """Whether ``pt`` (at arclength ``s``) lies as near the chord between the bracket's ends ``lo``
    and ``hi`` (``(s, point)``) as a point of their branch does: within the chord's sagitta that the
    turn of their tangents allows (four times it), or :data:`CHORD_DEVIATION` of its length if
    smaller."""
    (s1, q1), (s2, q2) = lo, hi
    if s2 == s1:
        return True
    x1, x2, x = c.coords(q1), c.coords(q2), c.coords(pt)
    length = float(np.linalg.norm(x2 - x1))
    if not length > 0:
        return True
    chord = x1 + (s - s1) / (s2 - s1) * (x2 - x1)
    turn = float(np.linalg.norm(q2.tangent - q1.tangent)) if q1.tangent.size == q2.tangent.size else 1.0
    allowed = min(CHORD_DEVIATION, 0.5 * turn + 1e-9) * length
    return float(np.linalg.norm(x - chord)) <= allowed


def locate(c, a, b, kind: str, ds: float, settings, fail_types) -> _Located:
    """Locate the special point of ``kind`` between ``a`` (arclength 0) and ``b`` (``ds``).

    ``c.correct(a, s)`` gives the point at arclength ``s`` of the step from ``a``.
    """
    tol_p = settings.locate_tol * c.sp
    # On the exact flow the search goes on to the integrator's accuracy (cheap, and the tolerance's
    # 1e-10 of the range left the isolator's band edges 1.9e-11 to 3.3e-11 off; issue 30); the
    # status is still judged against the caller's tolerance.
    search = min(tol_p, EXACT_SEARCH_TOL * max(abs(a.p), abs(b.p))) if c.sh.method.flows_exact else tol_p
    if not settings.locate:
        return _unlocated(c, a, b, kind, ds)
    if kind in SMOOTH:
        return _illinois(c, a, b, kind, ds, settings, tol_p, fail_types, search)
    return _mode_change(c, a, b, ds, settings, tol_p, fail_types, search)


def _unlocated(c, a, b, kind: str, ds: float) -> _Located:
    """The interval that the step itself gives (``locate=False``)."""
    note = "not located (locate=False)"
    if kind == "fold":
        known = max(a.p, b.p) if _slope(c, a, a) > 0 else min(a.p, b.p)
        iv = _fold_interval(c, a, (0.0, a), (ds, b), known)
        return _Located(None, "bracketed", known, iv, note)
    if kind in SMOOTH:
        m = (
            rounding_margin((a, b), 0.5 * (a.p + b.p))
            if c.sh.method.flows_exact and kind in ROUNDED_KINDS
            else 0.0
        )
        return _Located(None, "bracketed", 0.5 * (a.p + b.p), (min(a.p, b.p) - m, max(a.p, b.p) + m), note)
    rule = _PhaseRule(signature(a.view()), signature(b.view()))
    w, o = ((0.0, a), (ds, b)) if rule.with_a else ((ds, b), (0.0, a))
    probes = [(w[0], w[1].p, rule.measure(w[1].view()), w[1])] if rule.measure else []
    lo, hi, why = _phase_interval(c, rule, w, o, probes)
    m = rounding_margin((a, b), 0.5 * (lo + hi)) if c.sh.method.flows_exact else 0.0
    return _Located(
        None, "bracketed", 0.5 * (lo + hi), (lo - m, hi + m), "; ".join(x for x in (note, why) if x)
    )


def _isolate(pt) -> None:
    """A branch point's orbit is no member of a family: its multiplier 1 (classified ``neutral``
    by the singular value of ``I - M``) is a Floquet multiplier (issue 30)."""
    o = pt.orbit
    if o is not None and o.family:
        kinds = tuple("floquet" if k == "neutral" else k for k in o.multiplier_kinds)
        pt.orbit = dataclasses.replace(o, family=False, multiplier_kinds=kinds)


#: The exact flow's special points are searched down to this fraction of the parameter's value
#: (the status is judged against ``ContinuationOptions.locate_tol``). Its phases are resolved to
#: :data:`EXACT_PHASE_RESOLUTION` of the period: a search down to 1e-13 of the range narrowed Den
#: Hartog's boundary (range 0.03) to +-1e-14, 3e-14 from the closed form, below what the phases
#: resolve.
EXACT_SEARCH_TOL = 1e-12

#: Rounding of a smooth test function on the exact flow, in units of ``eps`` times the largest
#: multiplier's modulus (its monodromy is right to rounding times the saltations' products).
TEST_ROUNDING = 64.0


def _test_margin(kind: str, q_lo, q_hi, a, p: float) -> float:
    """How far [parameter units] the rounding of the test function of ``kind`` may move its zero
    between the probes ``q_lo`` and ``q_hi`` on the exact flow: :data:`TEST_ROUNDING` ``eps
    max |mu|`` over the test function's slope between them, plus ``4 eps |p|``. (Shaw's branch
    point located to 1e-14 missed the closed form by 5e-16 without it; issue 30.)"""
    eps = float(np.finfo(float).eps)
    g1, g2 = _value(kind, q_lo, a), _value(kind, q_hi, a)
    dp = abs(q_hi.p - q_lo.p)
    slope = abs(g2 - g1) / dp if dp > 0 and math.isfinite(g1) and math.isfinite(g2) else 0.0
    size = max(float(np.max(np.abs(q.orbit.multipliers), initial=1.0)) for q in (q_lo, q_hi))
    if not slope > 0:
        return EXACT_ROUNDING_FALLBACK * abs(p)
    return TEST_ROUNDING * eps * size / slope + 4.0 * eps * abs(p)


def _illinois(c, a, b, kind, ds, settings, tol_p, fail_types, search: float | None = None) -> _Located:
    search = tol_p if search is None else search
    s_lo, s_hi = 0.0, ds
    g_lo, g_hi = _value(kind, a, a), _value(kind, b, a)
    q_lo, q_hi = a, b  # the points at the bracket's ends
    best, side = None, 0
    s_prev = math.inf
    samples = settings.samples_per_period
    up = kind == "fold" and _slope(c, a, a) > 0
    extreme = max((a, b), key=lambda q: q.p if up else -q.p)  # a fold's most extreme computed point
    rounded = c.sh.method.flows_exact and kind in ROUNDED_KINDS

    def result(status_note: str, located: bool = False) -> _Located:
        nonlocal best
        if kind == "fold":  # reported at the most extreme orbit computed (a fold's p is extremal)
            iv = _fold_interval(c, a, (s_lo, q_lo), (s_hi, q_hi), extreme.p)
            # the runs' integration error moves the fold of the computed branch off the true one
            e = fold_integration_error(c, extreme)
            if e > 0:
                iv = (iv[0] - e, iv[1] + e)
            # the orbit reported is the regula falsi's last probe, whose arclength has settled (on a
            # noisy map the most extreme parameter computed may lie far along the branch, p being
            # flat there: the Duffing oscillator's upper fold on IDA at rtol 1e-9, 3.8e-4 off in the
            # state against 6e-9 for the last probe); the interval is widened to hold it
            if best is None:
                best = extreme
            iv = (min(iv[0], best.p), max(iv[1], best.p))
            p = best.p
        else:
            iv = (min(q_lo.p, q_hi.p), max(q_lo.p, q_hi.p))
            p = best.p if best is not None else 0.5 * (q_lo.p + q_hi.p)
            if rounded:  # what rounding leaves unresolved on the exact flow
                m = rounding_margin((q_lo, q_hi), p)
                iv = (iv[0] - m, iv[1] + m)
            elif kind == "branch-point" and c.sh.method.flows_exact:
                m = _test_margin(kind, q_lo, q_hi, a, p)
                iv = (iv[0] - m, iv[1] + m)
        if kind == "branch-point" and best is not None:
            _isolate(best)
        out = _Located(best, "bracketed", p, iv, status_note, tol=tol_p if located else None)
        return out

    for _ in range(settings.locate_max_iter):
        if not (math.isfinite(g_lo) and math.isfinite(g_hi)) or g_lo * g_hi > 0:
            break
        s = (s_lo * g_hi - s_hi * g_lo) / (g_hi - g_lo)
        w = s_hi - s_lo
        s = min(max(s, s_lo + 1e-3 * w), s_hi - 1e-3 * w)
        pt, why = None, ""
        # the regula falsi's probe, else the bracket's middle and quarters; at a branch point from
        # the chord of the bracket (the corrector is singular at the point, and from a's tangent
        # may land on the branch that crosses this one: the chord is nearer this one)
        for x in (s, s_lo + 0.5 * w, s_lo + 0.25 * w, s_lo + 0.75 * w):
            try:
                if kind == "branch-point":
                    q = c.correct(
                        c.between(q_lo, q_hi, (x - s_lo) / w),
                        0.0,
                        samples,
                        polish=c.sh.method.flows_exact,
                        isolated=True,
                    )
                else:
                    q = c.correct(a, x, samples, polish=c.sh.method.flows_exact)
            except fail_types as exc:
                why = f"corrector failed: {exc}"
                continue
            if kind == "branch-point" and not _on_branch(c, (s_lo, q_lo), (s_hi, q_hi), x, q):
                why = f"the corrector found a point of another branch at {q.p:.10g}"
                continue
            if kind == "branch-point" and signature(q.view()) not in (
                signature(q_lo.view()),
                signature(q_hi.view()),
            ):
                # (within 3e-9 of Shaw's branch point a probe converged to an orbit with a stick
                # phase, whose det(M - I) is -1: the regula falsi crept towards it; issue 30)
                why = f"the corrector found an orbit with other modes at {q.p:.10g}"
                continue
            pt, s = q, x
            break
        if pt is None:
            return result(why)
        g = _value(kind, pt, a)
        if not math.isfinite(g):
            return result("test function undefined")
        p_prev = best.p if best is not None else None
        best = pt
        if kind == "fold" and (extreme is None or ((pt.p > extreme.p) if up else (pt.p < extreme.p))):
            extreme = pt
        if g == 0.0:
            if kind == "fold":
                s_lo = s_hi = s
                q_lo = q_hi = pt
                return result("", located=True)
            if rounded:
                s_lo = s_hi = s
                q_lo = q_hi = best = pt
                return result("", located=True)
            return _Located(pt, "located", pt.p, (pt.p, pt.p))
        if g * g_lo > 0:
            s_lo, g_lo, q_lo = s, g, pt
            if side == -1:
                g_hi *= 0.5  # Illinois: the end that stays is weighted down
            side = -1
        else:
            s_hi, g_hi, q_hi = s, g, pt
            if side == 1:
                g_lo *= 0.5
            side = 1
        # At a fold the parameter is quadratic in the arclength: its tolerance is met long before
        # the orbit (the state, the multiplier 1) is, so the arclength must settle too.
        err = abs(q_hi.p - q_lo.p)
        settled = True
        if kind == "fold":
            iv = _fold_interval(c, a, (s_lo, q_lo), (s_hi, q_hi), extreme.p)
            err = abs(iv[1] - iv[0])
            settled = p_prev is not None and abs(s - s_prev) <= FOLD_ARCLENGTH_TOL * ds
        s_prev = s
        if (err <= search and settled) or s_hi - s_lo <= 1e-14 * ds:
            return result("", located=True)
    return result("not located to the tolerance")


# ----------------------------------------------------------------------
#: Resolution of a phase's duration on the exact flow, as a fraction of the period: its switch
#: times are right to rounding (measured: 1e-13 s in a period of 12.4 s on Den Hartog's
#: oscillator, 1e-14 of the period); a hundred times that.
EXACT_PHASE_RESOLUTION = 1e-12

#: A mode change on a noisy map (IDA) is bracketed down to this multiple of rtol (relative to the
#: parameter): on the absorber's bands at rtol 1e-10 the next probes, 2e-8 from the point, fail
#: at a grazing after several Newton attempts and the bracket gains little.
NOISY_FLOOR = 1e3

#: Safety factor of :func:`rounding_margin` over ``eps |p| cond``.
EXACT_ROUNDING_SAFETY = 4.0

#: The rounding margin, relative to ``|p|``, where no orbit next to the point gives a finite
#: condition number (e.g. an autonomous orbit, or a family without a gauge).
EXACT_ROUNDING_FALLBACK = 1e-12

#: The kinds whose intervals on the exact flow get :func:`rounding_margin` (at a fold or a branch
#: point ``I - M`` is singular: their condition number says nothing of the augmented problem).
ROUNDED_KINDS = (
    "period-doubling",
    "neimark-sacker",
    "mode-gained",
    "mode-lost",
    "grazing",
    "sequence-change",
)


def rounding_margin(pts, p: float) -> float:
    """How far [parameter units] rounding may move a point at ``p`` located on the exact flow from
    the orbits ``pts`` next to it (the two ends of the last bracket): ``eps |p|`` (the parameter's
    rounding scale) times the largest condition number of ``I - M`` on their section states
    (:attr:`hybrid.PeriodicOrbit.condition`), times :data:`EXACT_ROUNDING_SAFETY`;
    :data:`EXACT_ROUNDING_FALLBACK` ``|p|`` where none of them gives a finite one.

    The exact flow's switch times are right to rounding, but each orbit is the fixed point of the
    computed map, right only to rounding times the conditioning of ``I - M``: the orbit computed at
    ``p`` is the true one at ``p + delta``, and a probe next to a mode change may show the phase on
    the wrong side of it (the probes' durations then extrapolate consistently to the shifted zero,
    so no extrapolation bound covers it). Measured against ``band_edges`` (right to 5e-16, checked
    with mpmath) on the dampers' band edges, exact integrator, before this margin: 5 of the 182
    points of the four plane loci missed the closed form by 2.8e-14 to 1.07e-13 (absolute;
    ``p`` 0.85 to 1.17); in 265 relocations of 68 of these points (windows of 1e-7 to 1e-4 around
    it, the loci's tolerance 1e-12) 13 located ones missed it by 1.8e-14 to 5.3e-13, at most 0.94
    ``eps |p| cond`` (cond 800 to 19000 there, ``eps |p| cond`` 1.5e-13 to 4e-12; the next largest
    0.17). The safety factor is four times the largest. (One bracketed point there, the
    isolator's at R = 3 on a window of 1e-7, missed by 2.8e-10: not rounding, not covered.)

    Parameters
    ----------
    pts : iterable
        The points next to it, each with an ``orbit`` (a :class:`hybrid.PeriodicOrbit`).
    p : float
        The point's parameter value.

    Returns
    -------
    float
        The margin [parameter units], added to each side of the point's interval.
    """
    eps = float(np.finfo(float).eps)
    cond = 0.0
    for pt in pts:
        try:  # (a probe's orbit is made on first use: its sampled run)
            orbit = pt.orbit
        except (ArithmeticError, RuntimeError, ValueError):  # its run failed: no condition number
            orbit = None
        k = math.nan if orbit is None else orbit.condition
        if k is None or not math.isfinite(k):
            return EXACT_ROUNDING_FALLBACK * abs(p)
        cond = max(cond, float(k))
    if not cond > 0:
        return EXACT_ROUNDING_FALLBACK * abs(p)
    return EXACT_ROUNDING_SAFETY * eps * abs(p) * max(cond, 1.0)


class _PhaseRule:
    """Which side of a change of signature has the vanishing phase (``with_a``), how long it is on
    an orbit (``measure``: a fraction of the period; None where no phase vanishes, a change of order
    only) and on which side a probe lies (``side``: ``"with"``, ``"without"`` or None)."""

    def __init__(self, sa: tuple, sb: tuple):
        self.sa, self.sb = sa, sb
        changed = sa[1] ^ sb[1]
        if changed:
            self.with_a = bool(changed & sa[1])
            modes = changed & (sa[1] if self.with_a else sb[1])
            self.measure = lambda v: float(sum(_fractions(v).get(m, 0.0) for m in modes))
            self._side = lambda v: "with" if self.measure(v) > 0 else "without"
        elif sa[0] != sb[0]:
            self.with_a = sa[0] > sb[0]
            n_with, n_without = max(sa[0], sb[0]), min(sa[0], sb[0])
            self.measure = lambda v: min((f for _, f in phases(v)), default=0.0)

            def side(v):
                n = signature(v)[0]
                return "with" if n == n_with else ("without" if n == n_without else None)

            self._side = side
        else:
            self.with_a = True
            self.measure = None
            sig_w, sig_o = sa, sb
            self._side = lambda v: (
                "with" if signature(v) == sig_w else ("without" if signature(v) == sig_o else None)
            )

    def side(self, view) -> str | None:
        return self._side(view)


def _extrapolated(probes: list, alpha: float, f1: float | None = None, f2: float | None = None) -> float:
    """The parameter where the phase's duration ``f ~ |p - p*|^alpha``, through the two probes
    nearest the point (the last two; their durations ``f1``, ``f2`` if given), reaches zero."""
    (_, p1, g1), (_, p2, g2) = probes[-2][:3], probes[-1][:3]
    f1 = g1 if f1 is None else f1
    f2 = g2 if f2 is None else f2
    if not (f1 > 0 and f2 >= 0):
        return math.nan
    h1, h2 = f1 ** (1.0 / alpha), f2 ** (1.0 / alpha)
    if h1 == h2 or p1 == p2:
        return math.nan
    return p2 - h2 * (p2 - p1) / (h2 - h1)


def _root_estimate(probes: list) -> tuple[float, float]:
    """``(s*, alpha)``: the arclength where the phase's duration vanishes and its power law
    ``f ~ |s - s*|^alpha``, from the last three probes ``(s, p, f, ...)`` (``alpha`` is nan with
    two: then ``s*`` is the linear extrapolation)."""

    def root(alpha: float) -> float:
        (s1, _, f1), (s2, _, f2) = probes[-2][:3], probes[-1][:3]
        g1, g2 = f1 ** (1.0 / alpha), f2 ** (1.0 / alpha)
        return s2 - g2 * (s2 - s1) / (g2 - g1) if g1 != g2 else math.nan

    s_star = root(1.0)
    if len(probes) < 3:
        return s_star, math.nan
    alpha = 1.0
    (s0, _, f0), (s1, _, f1) = probes[-3][:3], probes[-2][:3]
    for _ in range(40):
        d0, d1 = abs(s_star - s0), abs(s_star - s1)
        if not (math.isfinite(s_star) and d0 > 0 and d1 > 0 and d0 != d1 and f0 > 0 and f1 > 0 and f0 != f1):
            return s_star, math.nan
        a_new = min(max(math.log(f0 / f1) / math.log(d0 / d1), 0.2), 3.0)
        s_new = root(a_new)
        if not math.isfinite(s_new):
            return s_star, math.nan
        done = abs(s_new - s_star) <= 1e-15 * max(abs(s_star), 1e-300) + 1e-300 and abs(a_new - alpha) < 1e-9
        alpha, s_star = a_new, s_new
        if done:
            break
    return s_star, alpha


#: The power laws of a vanishing phase's duration the extrapolated bounds assume: between a square
#: root (a grazing of a smooth guard) and linear (a phase that a transversal guard ends), with this
#: slack on the estimate from the last three probes.
ALPHA_RANGE = (0.45, 1.1)


def power_bounds(probes: list, towards: float) -> tuple[float, float] | None:
    """An interval that holds the zero of a phase's duration ``f ~ |p - p*|^alpha`` (``alpha`` in
    ``[1/2, 1]``) past the last of ``probes`` ``(s, p, f, df)`` (``df`` a bound of the error of
    ``f``): the zero extrapolated with ``f^2`` linear (short of it, as ``f^2`` is convex in ``p``)
    from the durations moved by their errors towards it, and with ``f`` linear (past it, ``f``
    being concave) from them moved away, each widened by half their distance (the power's
    uncertainty) and a tenth of the distance extrapolated over (the law holds to first order).
    None if the last three probes estimate a power outside :data:`ALPHA_RANGE`, or the nearest
    durations are not larger than their errors."""
    probes = thin(probes)
    if len(probes) < 2:
        return None
    if len(probes) >= 3:
        _, alpha = _root_estimate([(q[1], q[1], q[2]) for q in probes])
        if math.isfinite(alpha) and not ALPHA_RANGE[0] <= alpha <= ALPHA_RANGE[1]:
            return None
    (_, _, f1, e1), (_, p2, f2, e2) = probes[-2][:4], probes[-1][:4]
    if not (f2 > e2 and f1 > e1):
        return None
    short = _extrapolated(probes, 0.5, f1 + e1, f2 - e2)
    long_ = _extrapolated(probes, 1.0, f1 - e1, f2 + e2)
    if not (math.isfinite(short) and math.isfinite(long_)):
        return None
    spread = 0.5 * abs(long_ - short)
    lo = short - towards * (spread + 0.1 * abs(short - p2))
    hi = long_ + towards * (spread + 0.1 * abs(long_ - p2))
    if (lo - p2) * towards < 0:
        lo = p2
    return (lo, hi) if towards > 0 else (hi, lo)


def thin(probes: list) -> list:
    """The probes (ordered towards the point) whose durations fall by a fifth at least from one to
    the next nearer: two probes too close together extrapolate their noise."""
    out = []
    for q in reversed(probes):
        if not out or q[2] >= 1.2 * out[-1][2]:
            out.append(q)
    return out[::-1]


#: Safety factor on the integration error of a phase estimated by a rerun at tighter tolerances.
RERUN_SAFETY = 3.0


def fold_integration_error(c, pt) -> float:
    """How far [parameter units] the integration error of the runs moves a fold (IDA; 0 on the
    exact flow, where the map is right to rounding).

    At the fold of the computed map ``G(y, p) = P(y, p) - y`` a perturbation ``delta`` of the map
    moves the fold by ``-psi . delta / psi . dG/dp`` to first order (``psi`` the left null vector
    of ``dG/dy``); ``delta`` is estimated by the run from the fold's section state at tolerances
    :data:`hybrid.continuation.forced.TIGHTER` times tighter, less the run as computed. Times
    :data:`RERUN_SAFETY`. ``inf`` where the rerun fails; 0 where the corrector offers no rerun
    (a branch of autonomous orbits: its fold is then located on the branch as computed only).
    """
    sh = getattr(c, "sh", None)
    if sh is None or sh.method.flows_exact or not hasattr(c, "rerun") or not hasattr(c, "jacobian"):
        return 0.0
    try:
        if c.rerun(pt) is None:  # (makes the tighter map, c.tight)
            return math.inf
        nw = NewtonMap(sh, pt.mode)
        c.at(pt.p)
        t0 = pt.phi * sh.period
        y = nw.project(t0, pt.y)
        tr = sh.run(y, pt.mode, t0)
        tight = c.tight.run(y, pt.mode, t0)
        if not (tr.success and tight.success):
            return math.inf
        delta = nw.residual(tight, y) - nw.residual(tr, y)
        Jy, Jp, _ = c.jacobian(tr, y, pt.p, pt.mode, pt.phi, nw)
        u, _, _ = np.linalg.svd(Jy)
        psi = u[:, -1]
        den = abs(float(psi @ Jp))
        if not den > 0:
            return math.inf
        return RERUN_SAFETY * abs(float(psi @ delta)) / den
    except (ArithmeticError, ValueError, RuntimeError, np.linalg.LinAlgError):
        # a failure of the estimate's runs or algebra: say it is unknown (a budget or a defect
        # of the code is not caught)
        return math.inf


def _phase_interval(c, rule: _PhaseRule, w: tuple, o: tuple, probes: list):
    """``(lo, hi, note)``: an interval holding the point where the phase vanishes, from the bracket
    ``w`` (the probe nearest it with the phase) .. ``o`` (the nearest without) and the probes with
    the phase ``(s, p, fraction, point)`` (see the module's docstring)."""
    p_w, p_o = w[1].p, o[1].p
    lo, hi = min(p_w, p_o), max(p_w, p_o)
    if rule.measure is None:
        return lo, hi, ""
    towards = 1.0 if p_o >= p_w else -1.0
    width = abs(p_o - p_w)
    if c.sh.method.flows_exact:
        res = EXACT_PHASE_RESOLUTION
        f_w = rule.measure(w[1].view())
        r = res / f_w if f_w > 0 else math.inf
        if r >= 0.5:
            return lo - width, hi + width, "the phase near the point is at the resolution of the runs"
        # the phase, at least linear in the distance to its end, is longer than the resolution up
        # to r / (1 - r) of the bracket past the probe without it
        end = p_o + towards * width * r / (1.0 - r)
        lo, hi = min(p_w, end), max(p_w, end)
        pw = power_bounds([(q[0], q[1], q[2], res) for q in probes], towards)
        if pw is not None and max(lo, pw[0]) <= min(hi, pw[1]):
            lo, hi = max(lo, pw[0]), min(hi, pw[1])
        return lo, hi, ""
    # A noisy map: probes near the point may miss the phase or show one that is not there. The
    # zeros extrapolated from the nearest probes whose durations exceed their integration errors
    # (each estimated by a rerun at tighter tolerances), with the bracket of the signatures.
    good = []
    for q in reversed(thin(probes)[-RATED:]):  # from the nearest, until three are good
        pt = q[3]
        if not hasattr(pt, "phase_error"):
            tight = c.rerun(pt)
            pt.phase_error = math.nan if tight is None else abs(q[2] - rule.measure(tight))
        if not math.isfinite(pt.phase_error):
            continue
        err = RERUN_SAFETY * pt.phase_error + PHASE_NOISE_FLOOR * c.sh.noise_rtol
        if q[2] > 3.0 * err:
            good.insert(0, (q[0], q[1], q[2], err))
            if len(good) == 3:
                break
    pw = power_bounds(good, towards) if len(good) >= 2 else None
    if pw is None:
        return lo - width, hi + width, "the phases near the point are below the resolution of the runs"
    return min(lo, pw[0]), max(hi, pw[1]), ""


#: How much tighter (rtol and atol) the orbit is re-solved that estimates the error of a vanishing
#: phase on a noisy map (:func:`orbit_error_margin`).
ORBIT_TIGHTER = 100.0


def orbit_error_margin(c, rule: _PhaseRule, w: tuple, o: tuple, probes: list) -> tuple[float, str]:
    """How far [parameter units] the tolerances of a noisy map (IDA) may move a mode change from
    where its probes put it, and a note where that is not known (issue 30).

    A probe's phase is in error by more than one run's integration error (what the corrector's
    ``rerun`` estimates, from the probe's own section state): the orbit is the fixed point of the computed
    map, off by ``cond(I - M)`` times that error, and a phase next to its end is sensitive to the
    state (a stick phase whose breakaway guard starts near its threshold), while the guard band hides
    a phase shorter than what the tolerances resolve. Measured on the tutorial's damper at rtol
    1e-8: each stick phase near the band's lower edge about 3.6e-6 of the period shorter than the
    exact one, whatever its length (1e-3 to 2.5e-6), so that the edge moved by 2.2e-7 rad/s; the
    one-period reruns said 1e-8 to 4e-8. So the probe with the phase nearest the point is re-solved
    (Newton, from its state) at tolerances :data:`ORBIT_TIGHTER` times tighter; the difference of
    its phase, over the phase's rate along the branch (the secant of the two nearest probes with
    it, else of that probe and the nearest without), times :data:`RERUN_SAFETY`. 0 on an exact
    flow, where nothing vanishes (a change of order only), or on a map of several forcing periods
    (not estimated: said in the note)."""
    sh = getattr(c, "sh", None)
    if sh is None or sh.method.flows_exact or rule.measure is None:
        return 0.0, ""
    if getattr(sh, "periods", 1) != 1 or not hasattr(c, "base"):
        return 0.0, "the tolerances' shift of the point is not estimated on this branch"
    tight = sh.method.tightened(ORBIT_TIGHTER)
    if tight is None:
        return 0.0, ""
    pt = w[1]
    f_w = rule.measure(pt.view())
    err = getattr(pt, "orbit_phase_error", None)
    if err is None:
        try:
            orbit = shoot_orbit(
                c.system,
                {**c.base, c.parameter: pt.p},
                pt.y,
                pt.mode,
                t0=pt.phi * sh.period,
                options=sh.options.with_method(tight),
                settings=ShootingOptions(transient_periods=0, samples_per_period=16),
            )
            err = abs(rule.measure(orbit) - f_w) if orbit.converged else math.nan
        except (ArithmeticError, RuntimeError, ValueError, np.linalg.LinAlgError):
            err = math.nan
        pt.orbit_phase_error = err
    width = abs(o[1].p - pt.p)
    if not math.isfinite(err):
        return width, "the orbit at tighter tolerances failed: the interval widened by its bracket"
    near = [q for q in thin(probes)[-2:] if q[1] != pt.p] + [(None, pt.p, f_w, pt)]
    if len(near) >= 2 and near[-2][1] != pt.p:
        rate = abs(near[-2][2] - f_w) / abs(near[-2][1] - pt.p)
    else:
        rate = f_w / width if width > 0 else 0.0
    if not rate > 0:
        return width, ""
    return RERUN_SAFETY * err / rate, ""


#: The probes nearest the point whose phases are rerun at tighter tolerances, at most.
RATED = 8

#: Least error of a phase's duration on a noisy map (a multiple of rtol, fraction of the period),
#: whatever its rerun says.
PHASE_NOISE_FLOOR = 10.0


def _mode_change(c, a, b, ds, settings, tol_p, fail_types, search: float | None = None) -> _Located:
    """Bisection of the change of signature between ``a`` and ``b``, each probe aimed at either side
    of the zero of the vanishing phase's duration extrapolated from the probes that have it (its
    power law estimated from the last three); the interval from :func:`_phase_interval`, and the
    search ends when its half-width is below the tolerance. On the exact flow the interval is then
    widened by :func:`rounding_margin` of the bracket's two ends, and the point is ``located`` only
    if the widened half-width is within the tolerance.

    A phase that disappears at a grazing of a smooth guard shrinks like the square root of the
    distance to the point, one that ends at a transversal one (a stick phase that a breakaway
    guard ends at once: Den Hartog's oscillator) linearly: the power is estimated, not assumed.
    """
    sig_a, sig_b = signature(a.view()), signature(b.view())
    rule = _PhaseRule(sig_a, sig_b)
    samples = settings.samples_per_period
    w, o = ((0.0, a), (ds, b)) if rule.with_a else ((ds, b), (0.0, a))
    toward = 1.0 if o[0] > w[0] else -1.0  # in arclength, from the side with the phase
    probes = [(w[0], w[1].p, rule.measure(w[1].view()), w[1])] if rule.measure else []
    slope = (b.p - a.p) / ds if ds > 0 else 0.0
    search = tol_p if search is None else search
    eps = 0.1 * search / max(abs(slope), 1e-300)  # a tenth of the tolerance, in arclength
    exact = c.sh.method.flows_exact
    floor = 0.0 if exact else NOISY_FLOOR * c.sh.noise_rtol * max(abs(a.p), abs(b.p))
    note = ""
    bisect = False  # the last aimed probes did not halve the interval: bisect once

    def probe(s: float):
        """``((point, side), "")`` at ``s``, or ``(None, why not)``."""
        try:
            pt = c.correct(a, s, samples, light=True, polish=exact)
        except fail_types as exc:
            return None, f"corrector failed: {exc}"
        side = rule.side(pt.view())
        if side is None or (exact and signature(pt.view()) not in (sig_a, sig_b)):
            # Not the branch's: on a noise-free map the phases of a symmetric change go at once; a
            # probe with part of them (e.g. one slip phase of two, of zero length) is another
            # solution the corrector found near a turn of the branch (a grazing member of a neutral
            # family), whose own mode change lies elsewhere (isolator: 3.7e-4 away).
            return None, (
                f"at {pt.p:.10g} the corrector converged to an orbit with other modes than either side "
                f"of the change ({_order_text(signature(pt.view()))}): another solution nearby, not the branch's"
            )
        return (pt, side), ""

    def take(s: float, pt, side: str) -> None:
        nonlocal w, o, probes
        if side == "with":
            w = (s, pt)
            if rule.measure and all(q[0] != s and q[1] != pt.p for q in probes):
                probes.append((s, pt.p, rule.measure(pt.view()), pt))
                probes.sort(key=lambda q: q[0] * toward)
        else:
            o = (s, pt)

    lo, hi, why = _phase_interval(c, rule, w, o, probes)
    stalls = 0  # on a noisy map below its floor: iterations that did not narrow the interval
    for _ in range(settings.locate_max_iter):
        if 0.5 * (hi - lo) <= search or abs(o[0] - w[0]) <= 1e-14 * ds:
            break
        at_floor = floor > tol_p and abs(o[1].p - w[1].p) <= floor
        if at_floor and (stalls >= 2 or not rule.measure):
            # the signatures are below the runs' noise here, and probes further from the point
            # no longer narrow the interval that their durations give
            note = "bracketed to the noise level of the runs"
            break
        inside = min(w[0], o[0]), max(w[0], o[0])
        aims = []
        near = thin(probes)
        if rule.measure and len(near) >= 2 and not bisect:
            s_star, alpha = _root_estimate(near)
            if math.isfinite(alpha):
                short = long_ = s_star
            else:  # two probes: the zeros of the square-root and the linear law
                sq = [(q[0], q[1], q[2] ** 2) for q in near[-2:]]
                short, long_ = _root_estimate(sq)[0], s_star
            if math.isfinite(short) and math.isfinite(long_):
                # just inside the side with the phase, then just past the point; on a noisy map the
                # probe inside a tenth of the way from the last one (the probes nearest the point
                # miss the phase or misjudge it: those a decade or two away bound it)
                step = eps if exact else max(eps, 0.1 * abs(short - near[-1][0]))
                aims = [short - toward * step] + ([] if at_floor else [long_ + toward * eps])
        before = 0.5 * (hi - lo)
        hits, failure = 0, ""
        for k, s in enumerate(aims):
            if not min(w[0], o[0]) < s < max(w[0], o[0]):
                continue
            tries = [s] if k else [s, w[0] + 0.5 * (s - w[0]), w[0] + 0.25 * (s - w[0])]
            for x in tries:  # the aim inside, else nearer the probe with the phase
                got, failure = probe(x)
                if got is not None:
                    take(x, *got)
                    hits += 1
                    break
        if not hits:
            # the midpoint of the bracket, then its quarters
            span = o[0] - w[0]
            for s in (w[0] + 0.5 * span, w[0] + 0.25 * span, w[0] + 0.75 * span):
                if not inside[0] < s < inside[1]:
                    continue
                got, failure = probe(s)
                if got is not None:
                    take(s, *got)
                    hits += 1
                    break
        if not hits:
            note = failure or "no probe inside the bracket"
            break
        lo, hi, why = _phase_interval(c, rule, w, o, probes)
        bisect = 0.5 * (hi - lo) > 0.5 * before and not at_floor
        stalls = stalls + 1 if at_floor and 0.5 * (hi - lo) > 0.7 * before else 0
    b_side = o if rule.with_a else w
    point = b_side[1] if signature(b_side[1].view()) == sig_b else b
    if w[1] is not a and w[1] is not b and signature(w[1].view()) in (sig_a, sig_b):
        point = w[1]  # the probe nearest the point with the phase (both sides meet there)
    if point is a:
        point = b
    # on the exact flow, widened by what rounding leaves unresolved (the bracket is narrowed as
    # before: the margin of the step's ends, farther from the point, may be much larger)
    # on a noisy map, by what its tolerances may move the point (issue 30)
    if exact:
        m = rounding_margin((w[1], o[1]), 0.5 * (lo + hi))
    else:
        m, unknown = orbit_error_margin(c, rule, w, o, probes)
        why = "; ".join(x for x in (why, unknown) if x)
    return _Located(point, "bracketed", 0.5 * (lo + hi), (lo - m, hi + m), note or why, tol=tol_p)
