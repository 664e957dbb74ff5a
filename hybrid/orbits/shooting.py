"""Shooting for periodic orbits of periodically forced hybrid systems, with an exact monodromy.

The stroboscopic map ``P: y(t0) -> y(t0 + T)`` over one forcing period is
evaluated by an event-driven run (:func:`hybrid.simulate`); its Jacobian, the
monodromy matrix, by the variational equations of each mode and the
saltation matrix of each switch (:mod:`hybrid.engine.variational`). Newton's method
solves ``P(y) = y`` on the differential variables of the section's mode (its
slave variables are solved from their algebraic equations at the section).

Choices that make this work for stick-slip systems:

* the section phase is put in the middle of the longest mode interval of the
  guess, so that the map is smooth near the orbit and the mode at ``t0 + T``
  equals the mode at ``t0`` (a converged orbit is checked for it);
* Newton steps are least-squares steps: ``I - M`` is singular on a family of
  orbits (a neutral multiplier 1, e.g. the free offset of a stuck friction
  element) and nearly singular for weakly damped orbits (multipliers 0.99 and
  above). On a family the model's ``orbit.gauge`` expression (= 0 at the
  section) picks the member; without one the member nearest the guess is kept;
* the accuracy is reported: the Newton residual and the condition number of
  ``I - M``, whose product with the integration tolerance bounds the error
  of the orbit's state.

The map is :class:`hybrid.orbits.shooter.Shooter`, Newton's method :mod:`hybrid.orbits.newton`;
the result and what is read off it (amplitudes, multipliers, verdict) are in :mod:`hybrid.orbits.orbit`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import replace

import numpy as np

from ..core.errors import BudgetExceeded, GrazingSwitchError, InputError
from ..core.options import ShootingOptions
from ..core.threads import with_blas_threads
from ..engine.simulate import check_initial_state, check_time_range, initial_state, run_compiled
from ..engine.trajectory import Status
from ..integrators.options import SolverOptions
from ..model.system import HybridSystem
from .newton import newton
from .orbit import (
    ORBIT_OPTIONS,
    PeriodicOrbit,
    check_orbit_inputs,
    failed_orbit,
)
from .section import _choose_section
from .shooter import Shooter
from .subharmonic import EXTRA_PERIODS, attractor_period, notice, settle, strobe_times

__all__ = ["shoot_orbit", "solve_orbit"]


# ----------------------------------------------------------------------


# ----------------------------------------------------------------------


@with_blas_threads
def shoot_orbit(
    system: HybridSystem,
    params: Mapping[str, float],
    x0=None,
    mode0: str | None = None,
    *,
    t0: float | None = None,
    options: SolverOptions | None = None,
    settings: ShootingOptions | None = None,
) -> PeriodicOrbit:
    """Periodic orbit by Newton shooting from a guess, with its monodromy and Floquet multipliers.

    The shooting core of :func:`hybrid.periodic_orbit` (which adds the cold-start fallback and
    autonomous models): a transient of ``transient_periods`` forcing periods from the guess, the
    section in the middle of the longest mode interval of its last period, then Newton's method
    (:func:`newton`). Arguments as for :func:`hybrid.periodic_orbit`; the model must declare a
    forcing ``period``.

    Returns
    -------
    PeriodicOrbit
        ``status`` ``"failed"`` (``reason`` its code, ``message`` in words) where Newton's method
        failed.

    Raises
    ------
    ValueError
        Bad input (before any integration).
    """
    options = ORBIT_OPTIONS if options is None else options
    settings = ShootingOptions() if settings is None else settings
    check_orbit_inputs(system, options, settings, forced=True)
    transient_periods = settings.transient_periods
    mode0 = mode0 if mode0 is not None else system.default_mode
    if mode0 is None:
        raise InputError(f"`mode0` is required: model `{system.name}` declares no initial mode")
    system.mode(mode0)
    shooter = Shooter(system, params, options, periods=settings.periods)
    if x0 is None:
        x0 = np.zeros(len(system.variable_names))
    y = initial_state(system, x0, mode0)
    start = 0.0 if t0 is None else float(t0)
    if not math.isfinite(start):
        raise InputError(f"`t0` must be finite, got {t0!r}")
    check_time_range(shooter.cs, options, start, start + (transient_periods + 1) * shooter.period)
    check_initial_state(shooter.cs, mode0, start, y)
    return solve_orbit(
        shooter,
        y,
        mode0,
        start,
        transient_periods,
        settings.newton.tol,
        settings.newton.max_iter,
        settings.samples_per_period,
    )


@with_blas_threads
def solve_orbit(
    shooter: Shooter,
    y: np.ndarray,
    mode0: str,
    t_start: float,
    transient_periods: int,
    tol: float,
    max_iter: int,
    samples: int,
) -> PeriodicOrbit:
    """Newton shooting from a guess (see :func:`periodic_orbit`).

    A budget exhausted (``SolverOptions.max_steps``, ``max_wall_time``, :func:`hybrid.time_limit`),
    a grazing switch, a division by zero in the model's equations where only the monodromy
    evaluates them, or IDA failing in the variational equations comes back as a failed orbit with
    its ``reason`` (``"budget"``, ``"grazing"``, ``"evaluation-failed"``, ``"monodromy-failed"``).
    """
    at = [y, mode0, t_start, 0]  # last section state, mode, time and iteration (for a failure report)
    orbit = _solve_any(shooter, y, mode0, t_start, transient_periods, tol, max_iter, samples, at)
    return orbit if orbit.periods == shooter.periods else replace(orbit, periods=shooter.periods)


def _solve_any(shooter, y, mode0, t_start, transient_periods, tol, max_iter, samples, at) -> PeriodicOrbit:
    """:func:`solve_orbit`'s work, its failures as failed orbits."""
    try:
        return _solve_orbit(shooter, y, mode0, t_start, transient_periods, tol, max_iter, samples, at)
    except BudgetExceeded as exc:
        return failed_orbit(shooter, at[0], at[1], at[2], at[3], math.inf, str(exc), "budget")
    except GrazingSwitchError as exc:  # no saltation matrix, no monodromy
        return failed_orbit(
            shooter,
            at[0],
            at[1],
            at[2],
            at[3],
            math.inf,
            f"{exc}; write the guard to cross zero at a nonzero rate "
            "(e.g. `v` rather than `sign(v)`), or, at a true grazing, try a nearby parameter value",
            "grazing",
        )
    except ZeroDivisionError as exc:  # the model's equations (e.g. a reset's derivative): not a grazing
        why = f"evaluating the model's equations failed: ZeroDivisionError: {exc}"
        return failed_orbit(shooter, at[0], at[1], at[2], at[3], math.inf, why, "evaluation-failed")
    except RuntimeError as exc:  # IDA failed in the variational equations (IntegratorError)
        return failed_orbit(
            shooter, at[0], at[1], at[2], at[3], math.inf, f"monodromy failed: {exc}", "monodromy-failed"
        )


def _solve_orbit(shooter, y, mode0, t_start, transient_periods, tol, max_iter, samples, at) -> PeriodicOrbit:
    T = shooter.period
    t_sec, mode = t_start, mode0
    attractor = None
    if transient_periods > 0:
        t_end = t_start + transient_periods * T
        Tf = T / shooter.periods  # the forcing period
        grid = np.linspace(t_start + (transient_periods - 1) * T, t_end, 257)
        strobe = strobe_times(t_start, t_end, Tf)
        tr = run_compiled(
            shooter.cs,
            shooter.options,
            t_start,
            t_end,
            y,
            shooter.cs.mode_id(mode0),
            np.unique(np.concatenate([grid, strobe[:-1]])),
            True,
        )
        shooter.nfev += tr.nfev
        if tr.status == Status.STEP_LIMIT and tr.reason == "projected":
            return failed_orbit(
                shooter,
                y,
                mode0,
                t_start,
                0,
                math.inf,
                f"transient failed: {tr.message}; fewer transient periods (transient_periods; CLI --transient) "
                "or a better guess (--x0) cost less",
                "transient-failed",
            )
        if not tr.success:
            return failed_orbit(
                shooter, y, mode0, t_start, 0, math.inf, f"transient failed: {tr.message}", "transient-failed"
            )
        keep = np.array([i for i, n in enumerate(shooter.names) if n not in shooter.system.quadratures])
        attractor, mismatch = attractor_period(tr.t, tr.y, Tf, keep)
        last = (tr.t_final, tr.y_final, tr.mode_final)
        t_sec, y, mode = _choose_section(tr, T)
    t_sec = t_sec - math.floor(t_sec / T) * T
    at[:] = [y, mode, t_sec, 0]
    orbit = newton(shooter, y, mode, t_sec, tol, max_iter, samples, at)
    if attractor is not None:
        n = transient_periods * shooter.periods
        if attractor == 0 and orbit.converged and orbit.stability == "unstable":

            def run(a, b, y0, m0, t_eval):
                return run_compiled(
                    shooter.cs, shooter.options, a, b, y0, shooter.cs.mode_id(m0), t_eval, True
                )

            attractor, mismatch = settle(run, *last, Tf, keep)
            n += EXTRA_PERIODS
        notice(attractor, mismatch, n, shooter.periods)
    return replace(orbit, periods=shooter.periods, attractor_periods=attractor)
