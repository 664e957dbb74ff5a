"""Special points of a branch of autonomous orbits: the probes of :mod:`hybrid.continuation.special`
on the pseudo-arclength corrector of :mod:`hybrid.continuation.palc`, and the end of a branch at a
grazing.

:class:`Locator` offers what :func:`hybrid.continuation.special.locate` asks of a continuer (a point
at arclength ``s`` of a step, the scale of the parameter, the integrator), so that folds, period
doublings, Neimark-Sacker and branch points, and changes of the mode sequence between two orbits
of an autonomous branch are located, with their intervals, as on a branch of forced orbits.

:func:`locate_end` locates where a branch ends at a grazing: the orbit ceases to exist (the belt's
stick-slip cycle whose return to stick becomes tangential) or loses a phase. Its test function is
the one that vanishes there: the least rate ``|dh/dt|`` at which the orbit's switches cross their
guards (a switch becoming tangential: it vanishes like the square root of the distance), or the
shortest phase (a phase that vanishes); the interval runs from the nearest orbit computed to the
zeros extrapolated from the probes (:func:`hybrid.continuation.special.power_bounds`).
"""

from __future__ import annotations

import math
import types

import numpy as np

from ..core.errors import GrazingSwitchError, SimulationError
from ..core.status import LocateStatus
from ..orbits.flowmap import FlowMap
from ..orbits.orbit import local_fractions, mode_fractions
from .palc import correct_point, tangent
from .special import SpecialPoint, interval_fields, phases, power_bounds, thin

__all__ = ["Locator", "AutoPoint", "locate_end", "transversality"]

#: What a failed probe raises.
FAILURES = (RuntimeError, ArithmeticError, np.linalg.LinAlgError, GrazingSwitchError)


class AutoPoint:
    """A point of an autonomous branch: the unknowns ``u`` (state, [period], parameter), the unit
    tangent there, its orbit."""

    def __init__(self, u: np.ndarray, t: np.ndarray, orbit):
        self.u = np.asarray(u, dtype=float)
        self.tangent = np.asarray(t, dtype=float)
        self.orbit = orbit
        self.p = float(self.u[-1])

    def view(self):
        return self.orbit


class _Summary:
    """Events and mode fractions of a run (what a phase's duration is read from)."""

    def __init__(self, tr, period: float, system):
        self.trajectory = tr
        self.system = system
        self.mode_fractions = mode_fractions(tr, period)
        self.local_fractions = local_fractions(system, self.mode_fractions)


class Locator:
    """The corrector of an autonomous branch as :mod:`hybrid.continuation.special` uses a continuer.

    Parameters
    ----------
    evaluate : callable
        ``u -> (F, dF/du, info)`` of the branch.
    make_orbit : callable
        ``(u, info) -> PeriodicOrbit``.
    settings : ContinuationOptions
    fm : FlowMap
        The branch's flow map (its integrator and tolerances).
    """

    #: The arclength is in the unknowns' own units (the parameter's among them).
    sp = 1.0

    def __init__(self, evaluate, make_orbit, settings, fm: FlowMap):
        self.evaluate, self.make_orbit, self.settings, self.fm = evaluate, make_orbit, settings, fm
        self.sh = types.SimpleNamespace(method=fm.method, noise_rtol=fm.method.noise_rtol)

    def correct(self, a: AutoPoint, s: float, samples=None, light: bool = False, polish: bool = False):
        """The point at arclength ``s`` along ``a``'s tangent, corrected on the normal hyperplane."""
        got = correct_point(self.evaluate, a.u + s * a.tangent, a.tangent, self.settings)
        if got is None:
            raise SimulationError(f"the corrector failed at arclength {s:.6g} from {a.p:.10g}")
        u, J, info, _ = got
        return AutoPoint(u, tangent(J, a.tangent), self.make_orbit(u, info))

    def between(self, q1: AutoPoint, q2: AutoPoint, lam: float) -> AutoPoint:
        """The point ``lam`` of the way along the chord from ``q1`` to ``q2``, the chord's direction its
        tangent (see :meth:`hybrid.continuation.forced.OrbitContinuer.between`)."""
        t = q2.u - q1.u
        return AutoPoint(q1.u + lam * t, t / max(float(np.linalg.norm(t)), 1e-300), None)

    def coords(self, pt: AutoPoint) -> np.ndarray:
        """The point's unknowns (the units of the branch's arclength)."""
        return pt.u

    def rerun(self, pt: AutoPoint, factor: float = 100.0):
        """One period from ``pt``'s orbit at tolerances ``factor`` times tighter (IDA), as a summary;
        None on the exact integrator or if the run fails."""
        tight = self.sh.method.tightened(factor)
        if tight is None:
            return None
        o = pt.orbit
        opts = self.fm.options.with_method(tight)
        try:
            tr = FlowMap(self.fm.system, o.params, opts, o.period).run(
                o.x0, o.mode0, o.period * (1.0 - 1e-10)
            )
        except FAILURES:
            return None
        return _Summary(tr, o.period, self.fm.system) if tr.success else None


def transversality(fm: FlowMap, orbit) -> float:
    """The least cosine of the angle at which the orbit's switches (those not chained) cross their
    guards, ``|dh/dt| / (|dh/dy| |dy/dt| + |dh/dt|_explicit)``: zero where a switch becomes
    tangential."""
    rates = []
    for e in orbit.trajectory.events:
        if e.chained:
            continue
        cm = fm.mode(e.source)
        k = next((g.index for g in cm.guards if g.name == e.guard), None)
        if k is None:
            continue
        grad, ht = cm.guard_gradient(k, e.t, e.x_minus)
        f = cm.derivatives(e.t, e.x_minus)
        scale = float(np.linalg.norm(grad) * np.linalg.norm(f)) + abs(ht)
        if scale > 0:
            rates.append(abs(float(grad @ f + ht)) / scale)
    return min(rates) if rates else math.nan


def _shortest_phase(orbit) -> float:
    return min((f for _, f in phases(orbit)), default=math.nan)


#: Iterations of :func:`locate_end` at most.
END_ITER = 30


def locate_end(
    loc: Locator, pts: list, beyond: float | None, tol: float, kind_hint: str = ""
) -> tuple[SpecialPoint | None, list]:
    """Locate the grazing just past the branch's last point.

    Parameters
    ----------
    loc : Locator
    pts : list of AutoPoint
        The branch's points (the last ones are used).
    beyond : float or None
        The parameter of an orbit of another kind found past the end, if any (a bound of the point
        on the exact integrator).
    tol : float
        Half-width below which the point is located.

    Returns
    -------
    (SpecialPoint or None, list of PeriodicOrbit)
        The point (its ``index`` relative to the end of ``pts``: 0 is the last point, k the k-th
        probe appended) and the probes' orbits to append to the branch. None if no test function
        vanishes ahead.
    """
    if len(pts) < 2:
        return None, []
    fm = loc.fm
    last = pts[-1]
    t = last.tangent
    towards = 1.0 if (last.p - pts[-2].p) >= 0 else -1.0
    measures = {
        "a switch becomes tangential": lambda o: transversality(fm, o),
        "a phase vanishes": _shortest_phase,
    }
    best = None
    for what, fn in measures.items():
        hist = []
        for q in pts[-4:]:
            f = fn(q.orbit)
            if math.isfinite(f) and f > 0:
                hist.append((float(t @ (q.u - last.u)), q.p, f, q))
        if len(hist) < 2 or not hist[-1][2] < hist[-2][2]:
            continue
        (s1, _, f1, _), (s2, _, f2, _) = hist[-2], hist[-1]
        ahead = s2 - f2**2 * (s2 - s1) / (f2**2 - f1**2)  # the square-root law's zero, in arclength
        if ahead > s2 and (best is None or ahead < best[2]):
            best = (what, fn, ahead, hist)
    if best is None:
        return None, []
    what, fn, _, hist = best
    exact = loc.sh.method.flows_exact
    floor = 0.0 if exact else 10.0 * loc.sh.noise_rtol
    probes_out: list = []
    eps = 0.1 * tol

    def rated(h: list) -> list:
        out = []
        for s, p, f, q in h:
            if exact:
                err = 1e-12
            else:
                tight = loc.rerun(q)
                if tight is None:
                    continue
                # the rerun's phases; for the rates, the run's own events
                g = fn(
                    types.SimpleNamespace(trajectory=tight.trajectory, mode_fractions=tight.mode_fractions)
                )
                err = 3.0 * abs(f - g) + floor if math.isfinite(g) else math.inf
            if f > 3.0 * err:
                out.append((s, p, f, err))
        return out

    def bounds() -> tuple[float, float] | None:
        pw = power_bounds(rated(thin(hist)[-4:]), towards)
        if pw is None:
            return None
        lo, hi = pw
        if exact and beyond is not None:  # an orbit of another kind past the end bounds it
            if towards > 0 and lo <= beyond < hi:
                hi = beyond
            elif towards < 0 and lo < beyond <= hi:
                lo = beyond
        return lo, hi

    iv = bounds()
    note = ""
    for _ in range(END_ITER):
        if iv is not None and 0.5 * (iv[1] - iv[0]) <= tol:
            break
        th = thin(hist)
        if len(th) < 2:
            break
        (s1, _, f1, _), (s2, _, f2, _) = th[-2], th[-1]
        g1, g2 = f1**2, f2**2
        if g1 == g2:
            break
        s_star = s2 - g2 * (s2 - s1) / (g2 - g1)
        step = max(eps, 0.1 * abs(s_star - s2))
        s = s_star - step if s_star - step > s2 else s2 + 0.5 * (s_star - s2)
        pt = None
        for x in (s, s2 + 0.5 * (s - s2), s2 + 0.1 * (s - s2)):
            try:
                pt = loc.correct(last, x)
            except FAILURES:
                continue
            if frozenset(pt.orbit.mode_sequence) != frozenset(last.orbit.mode_sequence):
                if exact and (pt.p - last.p) * towards > 0:
                    beyond = pt.p if beyond is None else (min if towards > 0 else max)(beyond, pt.p)
                pt = None
                continue
            s = x
            break
        if pt is None:
            note = "the corrector failed nearer the point"
            break
        f = fn(pt.orbit)
        if not (math.isfinite(f) and f > 0):
            break
        hist.append((s, pt.p, f, pt))
        hist.sort(key=lambda h: h[0])
        probes_out.append(pt)
        new = bounds()
        if new is not None:
            iv = new
    if iv is None:
        p0 = hist[-1][1]
        iv = (p0, math.inf) if towards > 0 else (-math.inf, p0)
        status = LocateStatus.UNLOCATED
        note = note or "the test function's zero could not be bounded"
        p, acc = p0, math.inf
    else:
        p, acc, iv = interval_fields(0.5 * (iv[0] + iv[1]), *iv)
        status = LocateStatus.LOCATED if acc <= tol else LocateStatus.BRACKETED
    nearest = max(hist, key=lambda h: h[0])[3]
    index = 0 if nearest is last else 1 + probes_out.index(nearest)
    desc = f"grazing: {what} (the branch ends there)"
    if status != LocateStatus.LOCATED and note:
        desc += f"; {note}"
    amp = dict(nearest.orbit.amplitude)
    return SpecialPoint("grazing", index, p, amp, desc, status, acc, iv), [q.orbit for q in probes_out]
