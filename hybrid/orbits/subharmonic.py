"""The period of the attractor a transient reaches, in forcing periods: :func:`attractor_period`.

A periodically forced system need not settle on an orbit of the forcing period: a contact that
lifts off, an impact, a period doubling leave it on an orbit of ``k`` forcing periods (a
subharmonic), or on none. Shooting for an orbit of one period from such a transient converges, if
at all, to an unstable orbit the run never showed. So the transient is checked: its state at the
last forcing periods' ends is compared with the state ``k`` periods earlier, ``k = 1 ... MAX_K``;
the first ``k`` at which it repeats (to :data:`REPEAT_TOL` of its size, and far better than it
repeats after one period, :data:`CONTRAST`) is the period found. A transient that has not settled
(no such ``k``) is run on for :data:`EXTRA_PERIODS` more periods when the orbit found from it is
unstable (then it is not the attractor, and the question matters). The section state is compared on
the variables that are not quadratures (the energy integrals grow without repeating).
"""

from __future__ import annotations

import warnings

import numpy as np

from ..core.budget import deadline_passed
from ..core.errors import BudgetExceeded, SimulationError

__all__ = [
    "MAX_K",
    "REPEAT_TOL",
    "CONTRAST",
    "EXTRA_PERIODS",
    "strobe_times",
    "attractor_period",
    "settle",
    "notice",
]

#: Largest period [forcing periods] looked for.
MAX_K = 8
#: A state repeats after k periods when it returns to within this fraction of its size.
REPEAT_TOL = 1e-4
#: ... and this many times closer than it returns after one period.
CONTRAST = 1e3


def strobe_times(t_start: float, t_end: float, period: float, max_k: int = MAX_K) -> np.ndarray:
    """The ends of the last ``max_k`` forcing periods of a run, and the run's end [s] (ascending, all
    within ``[t_start, t_end]``)."""
    ks = np.arange(max_k, -1, -1)
    t = t_end - ks * period
    return t[t >= t_start - 1e-12 * max(1.0, abs(t_start))]


def attractor_period(t: np.ndarray, y: np.ndarray, period: float, keep: np.ndarray) -> tuple[int, float]:
    """The period of the state the samples ``(t, y)`` end on, in forcing periods.

    Parameters
    ----------
    t : ndarray, shape (n,)
        Sample times [s] (ascending); those at the ends of the last forcing periods
        (:func:`strobe_times`) are used.
    y : ndarray, shape (n, n_vars)
        Samples of the state.
    period : float
        Forcing period [s].
    keep : ndarray of int
        Indices of the variables compared (the quadratures left out).

    Returns
    -------
    k : int
        ``1`` (the state repeats after one period, or too few periods to say), ``2 ... MAX_K`` (it
        repeats after ``k``, not after one), or ``0`` (it repeats after none of them: not settled,
        quasi-periodic or chaotic).
    mismatch : float
        ``max |y(t_end) - y(t_end - T)|`` relative to the state's size.
    """
    t_end = float(t[-1])
    rows = []
    for k in range(MAX_K + 1):
        tk = t_end - k * period
        i = int(np.argmin(np.abs(t - tk)))
        if abs(t[i] - tk) > 1e-9 * max(1.0, abs(tk)):
            break
        rows.append(y[i, keep])
    if len(rows) < 2:
        return 1, 0.0
    Y = np.array(rows)
    scale = float(np.max(np.abs(Y))) or 1.0
    d = [float(np.max(np.abs(Y[0] - Y[k]))) / scale for k in range(1, len(rows))]
    if d[0] <= REPEAT_TOL:
        return 1, d[0]
    for k in range(2, len(rows)):
        if d[k - 1] <= REPEAT_TOL and d[k - 1] * CONTRAST <= d[0]:
            return k, d[0]
    return 0, d[0]


#: Forcing periods run on from a transient that had not settled, when the orbit found is unstable.
EXTRA_PERIODS = 100


def settle(run, t1: float, y1: np.ndarray, mode1: str, period: float, keep: np.ndarray) -> tuple[int, float]:
    """:func:`attractor_period` after :data:`EXTRA_PERIODS` more forcing periods from ``(t1, y1, mode1)``
    (``run(t0, t1, y0, mode0, t_eval)`` a run of the system returning a Trajectory; ``(0, nan)`` if it
    fails, meets its budget, or the deadline has passed)."""
    if deadline_passed():
        return 0, float("nan")
    t2 = t1 + EXTRA_PERIODS * period
    try:
        tr = run(t1, t2, y1, mode1, strobe_times(t1, t2, period))
    except (BudgetExceeded, SimulationError, ArithmeticError):  # a question, not the orbit: left open
        return 0, float("nan")
    if not tr.success:
        return 0, float("nan")
    return attractor_period(tr.t, tr.y, period, keep)


def notice(attractor: int, mismatch: float, transient: int, periods: int) -> None:
    """Warn that a transient of ``transient`` forcing periods settled on an orbit of ``attractor``
    periods, where orbits of ``periods`` are sought (nothing if ``attractor`` divides ``periods``)."""
    if attractor > 1 and periods % attractor:
        warnings.warn(
            f"the transient of {transient} forcing periods settled on an orbit of {attractor} forcing periods "
            f"(a subharmonic: its state after one period differs by {mismatch:.2g} of its size), not of "
            f"{periods}; the orbit sought here is not that attractor. Ask for orbits of {attractor} periods: "
            f"ShootingOptions(periods={attractor}), CLI --subharmonic {attractor}",
            RuntimeWarning,
            stacklevel=3,
        )
