"""The one entry point for a periodic orbit: :func:`periodic_orbit`.

Forced models: Newton shooting from a transient (:mod:`hybrid.orbits.shooting`) and, where it
fails, the cold start by continuation (:mod:`hybrid.continuation.coldstart`); autonomous models:
:func:`hybrid.orbits.autonomous.autonomous_orbit`. It lives in the continuation layer because
its fallback is a continuation.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import replace

from ..core.budget import deadline_passed
from ..core.notices import collected
from ..core.options import ShootingOptions, reject_keywords
from ..integrators.options import SolverOptions
from ..model.system import HybridSystem
from ..orbits.autonomous import autonomous_orbit
from ..orbits.orbit import ORBIT_OPTIONS, PeriodicOrbit, with_options
from ..orbits.shooting import shoot_orbit
from .coldstart import find_by_continuation

__all__ = ["periodic_orbit"]


@collected
def periodic_orbit(
    system: HybridSystem,
    params: Mapping[str, float],
    x0=None,
    mode0: str | None = None,
    *,
    t0: float | None = None,
    options: SolverOptions | None = None,
    settings: ShootingOptions | None = None,
    **unexpected,
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
        Time of the guess [s]. If given with ``settings.transient_periods=0``, the
        section is ``(t0, x0, mode0)`` as given (e.g. the previous point of a
        continuation); otherwise a transient of ``transient_periods`` forcing
        periods is run from the guess and the section is put in the middle of
        the longest mode interval of its last period.
    options : SolverOptions, optional
        Tolerances (default :data:`ORBIT_OPTIONS`, rtol 1e-10).
    settings : ShootingOptions, optional
        Newton's method (``newton``: tolerance on ``max |P(x) - x| / max |x|``, iterations),
        the transient (``transient_periods``) and the samples of the returned one-period
        trajectory (``samples_per_period``); default ``ShootingOptions()`` (1e-9, 30, 10, 512).
        If Newton's method from the transient fails (``transient_periods > 0``), the orbit is
        sought by a route that cannot wander: a continuation in the forcing parameter from a
        value where a cold start converges, then a correction at exactly the requested value
        (:mod:`hybrid.continuation.coldstart`); ``route`` says which route found it.

    Returns
    -------
    PeriodicOrbit
        ``status`` ``"failed"`` (``reason`` its code, ``message`` in words) if Newton's method
        failed, e.g. when the response grows without bound (no bounded periodic orbit) or a run
        failed, and the fallback did not find it either (what it tried is in ``message``).

    Raises
    ------
    ValueError
        Bad input (before any integration).
    TypeError
        A keyword that is a field of ``options`` or ``settings`` (the message says which).
    """
    reject_keywords(
        "periodic_orbit",
        unexpected,
        options=options if isinstance(options, SolverOptions) else SolverOptions,
        settings=settings if isinstance(settings, ShootingOptions) else ShootingOptions,
    )
    settings = ShootingOptions() if settings is None else settings
    if isinstance(system, HybridSystem) and system.period is None:
        if isinstance(settings, ShootingOptions) and settings.transient_periods < 1:
            settings = replace(settings, transient_periods=1)
        return autonomous_orbit(system, params, x0, mode0, options=options, settings=settings)
    options = ORBIT_OPTIONS if options is None else options  # (what shoot_orbit takes for None)
    orbit = shoot_orbit(system, params, x0, mode0, t0=t0, options=options, settings=settings)
    if not (orbit.converged or settings.transient_periods == 0 or deadline_passed()):
        # Newton from the transient failed: a route that cannot wander.
        orbit = find_by_continuation(system, params, orbit, options=options, settings=settings)
    return with_options(orbit, options, settings)
