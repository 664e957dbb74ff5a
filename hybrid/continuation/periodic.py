"""The one entry point for a periodic orbit: :func:`periodic_orbit`.

Forced models: Newton shooting from a transient (:mod:`hybrid.orbits.shooting`) and, where it
fails, the cold start by continuation (:mod:`hybrid.continuation.coldstart`); autonomous models:
:func:`hybrid.orbits.autonomous.autonomous_orbit`. It lives in the continuation layer because
its fallback is a continuation.
"""

from __future__ import annotations

from collections.abc import Mapping

from ..core.budget import deadline_passed
from ..core.options import SolverOptions
from ..model.system import HybridSystem
from ..orbits.autonomous import autonomous_orbit
from ..orbits.orbit import PeriodicOrbit
from ..orbits.shooting import shoot_orbit
from .coldstart import find_by_continuation

__all__ = ["periodic_orbit"]


def periodic_orbit(
    system: HybridSystem,
    params: Mapping[str, float],
    x0=None,
    mode0: str | None = None,
    *,
    t0: float | None = None,
    transient_periods: int = 10,
    options: SolverOptions | None = None,
    tol: float = 1e-9,
    max_iter: int = 30,
    samples_per_period: int = 512,
) -> PeriodicOrbit:
    """Periodic orbit by Newton shooting, with its monodromy matrix and Floquet multipliers.

    A periodically forced model's orbit is found by :func:`hybrid.orbits.shooting.shoot_orbit`
    (a transient, then Newton's method), with the cold-start fallback below; a model without a
    forcing ``period`` (self-excited) by :func:`hybrid.orbits.autonomous.autonomous_orbit`, with the
    period an unknown.

    Parameters
    ----------
    system : HybridSystem
        The model (forced: it declares a ``period``; else autonomous).
    params : mapping of str to float
        All parameter values.
    x0 : mapping or array_like, optional
        Guess of the state (default: all 0 in the initial mode).
    mode0 : str, optional
        Mode of the guess (default: the model's initial mode).
    t0 : float, optional
        Time of the guess [s]. If given with ``transient_periods=0``, the
        section is ``(t0, x0, mode0)`` as given (e.g. the previous point of a
        continuation); otherwise a transient of ``transient_periods`` forcing
        periods is run from the guess and the section is put in the middle of
        the longest mode interval of its last period.
    transient_periods : int
        Forcing periods simulated from the guess before Newton's method. If Newton's method
        from the transient fails (``transient_periods > 0``), the orbit is sought by a route
        that cannot wander: a continuation in the forcing parameter from a value where a cold
        start converges, then a correction at exactly the requested value
        (:mod:`hybrid.continuation.coldstart`); ``route`` says which route found it.
    options : SolverOptions, optional
        Tolerances (default :data:`ORBIT_OPTIONS`, rtol 1e-10).
    tol : float
        Newton tolerance on ``max |P(x) - x| / max |x|``.
    max_iter : int
        Newton iterations allowed.
    samples_per_period : int
        Samples of the returned one-period trajectory.

    Returns
    -------
    PeriodicOrbit
        ``converged`` is False (with the reason in ``message``) if Newton's
        method failed, e.g. when the response grows without bound (no bounded
        periodic orbit) or a run failed, and the fallback did not find it either
        (what it tried is in ``message``).

    Raises
    ------
    ValueError
        Bad input (before any integration).
    """
    if isinstance(system, HybridSystem) and system.period is None:
        return autonomous_orbit(
            system,
            params,
            x0,
            mode0,
            transient_periods=max(transient_periods, 1),
            options=options,
            tol=tol,
            max_iter=max_iter,
            samples_per_period=samples_per_period,
        )
    orbit = shoot_orbit(
        system,
        params,
        x0,
        mode0,
        t0=t0,
        transient_periods=transient_periods,
        options=options,
        tol=tol,
        max_iter=max_iter,
        samples_per_period=samples_per_period,
    )
    if orbit.converged or transient_periods == 0 or deadline_passed():
        return orbit
    # Newton from the transient failed: a route that cannot wander.
    return find_by_continuation(
        system,
        params,
        orbit,
        options=options,
        tol=tol,
        max_iter=max_iter,
        transient_periods=transient_periods,
        samples_per_period=samples_per_period,
    )
