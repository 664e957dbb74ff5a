"""Cold starts that find the orbit: a fallback for :func:`hybrid.periodic_orbit` when Newton fails.

From rest, a short transient leaves a weakly damped system (Floquet multipliers 0.999 and
more, near a resonance) far from its periodic orbit, and Newton's method from there can fail.
The fallback follows a route that cannot wander: a continuation in the forcing parameter
(:func:`hybrid.forcing_parameter`) from a start where a cold start does converge, to the
requested value, then a correction at exactly that value.

* Starts are tried on the side of the nearest *anchor*, then on the other: the anchors are the
  ends of the default frequency range (:func:`hybrid.continuation.frc.default_range`) and the midpoints
  between consecutive natural frequencies of the linearised initial mode (where a
  frequency-response curve is cut into pieces, :func:`hybrid.frequency_response`); a start is
  at the fractions :data:`FRACTIONS` of the way from the requested value to the anchor, nearest
  first (far from a resonance the response settles fast, and Newton from a transient
  converges).
* :func:`hybrid.continue_orbits` from the start towards the requested value (its first orbit is a
  cold start there); the branch passes the value, or it stops (a fold turns it back, it stalls,
  it grows without bound, a budget).
* The orbit at exactly the requested value: Newton's method (no transient) from the branch's
  point nearest to it, the section time kept at the same phase of the period.

Nothing here knows the model: the forcing parameter comes from the period's expression, the
anchors from the initial mode's linearisation. The effort is bounded: at most
:data:`MAX_POINTS` orbits per branch, :data:`FALLBACK_SECONDS` of wall-clock time in all (and
any :func:`hybrid.time_limit` of the caller), every run within its own budget; a branch is given
up after :data:`MAX_FAILURES` failed steps in a row or when it grows :data:`MAX_GROWTH` times
larger than its first orbit. No fallback is tried when no Newton iteration failed (the transient
or a run failed: its budget, a grazing switch; the residual is not finite), nor for a model
without a forcing parameter or without a natural frequency of its initial mode; a fallback that
fails returns Newton's result with what it tried added to the message.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import replace

from ..core.budget import deadline_passed, time_limit
from ..core.options import ContinuationOptions, ShootingOptions
from ..integrators.options import SolverOptions
from ..model.system import HybridSystem
from ..orbits.orbit import PeriodicOrbit
from ..orbits.shooting import shoot_orbit
from .branch import Branch, forcing_parameter
from .forced import continue_orbits
from .frc import _cuts, default_range, resonances

__all__ = ["find_by_continuation", "anchors", "FRACTIONS", "MAX_POINTS", "FALLBACK_SECONDS"]

#: Starts tried on each side, as fractions of the way from the requested value to the anchor.
FRACTIONS = (0.005, 0.02, 0.1, 0.35, 1.0)
#: Orbits computed at most on one branch of the fallback.
MAX_POINTS = 100
#: Wall-clock limit of the whole fallback [s] (a caller's earlier time_limit wins).
FALLBACK_SECONDS = 120.0
#: A fallback branch whose state grows by this factor over its first orbit's is declared unbounded.
MAX_GROWTH = 1e2
#: Failed corrector steps in a row before a fallback branch is given up.
MAX_FAILURES = 4
#: Samples per period of the branch's orbits (only the final orbit keeps the caller's count).
BRANCH_SAMPLES = 16


def anchors(system: HybridSystem, params: Mapping[str, float]) -> list[float]:
    """Ends of the default frequency range and the cuts between its resonances [rad/s], ascending.

    Raises
    ------
    ValueError
        If the initial mode linearised at the zero state has no natural frequency.
    """
    lo, hi = default_range(system, params)
    w = resonances(system, params)
    pts = {lo, hi}
    for a, b, _ in _cuts(lo, hi, w):
        pts.update((a, b))
    return sorted(pts)


def _starts(p: float, marks: list[float]) -> list[tuple[float, float]]:
    """``(start, anchor)`` pairs: the side of the nearest anchor first, nearest start first."""
    below = [a for a in marks if a < p]
    above = [a for a in marks if a > p]
    sides = []
    if below:
        sides.append(max(below))
    if above:
        sides.append(min(above))
    sides.sort(key=lambda a: abs(a - p))
    return [(p + f * (a - p), a) for a in sides for f in FRACTIONS]


def _bracket(branch: Branch, p: float) -> list:
    """The branch's orbits beside the first crossing of ``p``, nearest to ``p`` first."""
    ps = branch.values
    for k in range(1, ps.size):
        if (ps[k - 1] - p) * (ps[k] - p) <= 0:
            pair = [branch.points[k - 1], branch.points[k]]
            return sorted(pair, key=lambda o: abs(o.params[branch.parameter] - p))
    return []


def find_by_continuation(
    system: HybridSystem,
    params: Mapping[str, float],
    failed: PeriodicOrbit,
    *,
    options: SolverOptions | None,
    settings: ShootingOptions,
) -> PeriodicOrbit:
    """The periodic orbit at ``params`` by continuation in the forcing parameter (see the module).

    Parameters
    ----------
    system : HybridSystem
        A periodically forced model.
    params : mapping of str to float
        All parameter values (the forcing parameter at the requested value).
    failed : PeriodicOrbit
        Newton's failed result from the cold start (returned, with what the fallback tried added
        to its message, if the fallback fails too).
    options : SolverOptions or None
        Tolerances and budgets of every run (None: :data:`hybrid.ORBIT_OPTIONS`).
    settings : ShootingOptions
        ``newton``: the tolerance of every Newton iteration (relative residual of the period
        map) and the iterations of the final correction; ``transient_periods``: the transient of
        each start's cold start; ``samples_per_period``: the samples of the returned orbit.

    Returns
    -------
    PeriodicOrbit
        ``failed`` itself if its residual is not finite (no Newton iteration failed: the transient
        or a run failed, e.g. its budget, which every start would meet as well). Else converged, with ``route`` ``"continuation in <parameter> from <start>"``; or ``failed``
        with the fallback's attempts in its message.
    """
    if not math.isfinite(failed.residual):
        # no Newton iteration failed: the transient or a run failed (a budget, a grazing switch):
        # every start's cold start would meet the same
        return failed
    try:
        par = forcing_parameter(system)
    except ValueError as exc:
        return _give_up(failed, [f"none possible: {exc}"])
    try:
        marks = anchors(system, params)
    except ValueError:
        return _give_up(
            failed,
            [
                "none possible: the initial mode linearised at the zero state has no natural frequency to "
                "place starts by (continue from a value of your own: hybrid.continue_orbits, hybrid frc)"
            ],
        )
    p = float(system.parameter_values(params)[par])
    tol = settings.newton.tol
    branch_settings = ContinuationOptions(
        locate=False,
        max_growth=MAX_GROWTH,
        max_failures=MAX_FAILURES,
        max_points=MAX_POINTS,
        newton=replace(ContinuationOptions().newton, tol=tol),
        transient_periods=settings.transient_periods,
        samples_per_period=BRANCH_SAMPLES,
    )
    correction = replace(settings, transient_periods=0)
    tried: list[str] = []
    with time_limit(FALLBACK_SECONDS):
        skip = set()  # anchors whose side has been given up
        for start, anchor in _starts(p, marks):
            if deadline_passed():
                tried.append(f"time limit reached (the fallback's {FALLBACK_SECONDS:g} s, or the caller's)")
                break
            if anchor in skip or start == p:
                continue
            try:
                branch = continue_orbits(
                    system,
                    params,
                    par,
                    (start, p),
                    options=options,
                    settings=branch_settings,
                    periods=settings.periods,  # (a subharmonic's branch spans as many periods)
                )
            except ValueError as exc:  # e.g. a start outside the parameter's domain or time range
                tried.append(f"from {par}={start:.8g}: {exc}")
                continue
            near = _bracket(branch, p)
            if not near:
                if branch.reason == "no-start":
                    tried.append(f"no cold start at {par}={start:.8g}")
                    continue  # a start further away
                why = branch.message or f"the branch ended before {par}={p:.8g}"
                tried.append(f"continuation from {par}={start:.8g}: {why}")
                skip.add(anchor)  # this side is blocked (a fold, a stall, unbounded): the other
                if branch.reason == "budget":
                    break
                continue
            for o in near:
                phase = o.t0 / o.period
                orbit = shoot_orbit(
                    system,
                    params,
                    o.x0,
                    o.mode0,
                    t0=phase * failed.period,
                    options=options,
                    settings=correction,
                )
                if orbit.converged:
                    why = failed.message.split(";")[0].split(" (")[0]
                    note = (
                        f"Newton's method from the transient failed ({why}); found by "
                        f"continuation in {par} from {start:.8g} ({len(branch.points)} orbits), corrected "
                        f"at {par}={p:.8g} from the branch's orbit at {o.params[par]:.8g}"
                    )
                    if tried:
                        note += f" (after {len(tried)} other attempt(s): " + "; ".join(tried) + ")"
                    return replace(
                        orbit,
                        route=f"continuation in {par} from {start:.8g}",
                        message=f"{note}; {orbit.message}",
                    )
                tried.append(
                    f"continuation from {par}={start:.8g}: correction at {par}={p:.8g} from "
                    f"{o.params[par]:.8g} failed: {orbit.message}"
                )
            skip.add(anchor)
    return _give_up(failed, tried)


def _give_up(failed: PeriodicOrbit, tried: list[str]) -> PeriodicOrbit:
    if not tried:
        return failed
    msg = f"{failed.message}; fallback (continuation in the forcing parameter): " + "; ".join(tried)
    return replace(failed, message=msg, route="none")
