"""A generic pseudo-arclength predictor-corrector on ``F(u) = 0``, ``u`` in R^(n+1), ``F`` in R^n.

Used for autonomous periodic orbits (``u = (y, T, p)`` or ``(y, p)``) by
:mod:`hybrid.continuation.autonomous`. The problem gives ``evaluate(u) -> (F, dF/du, info)``; the corrector
is Newton's method on ``[F(u); t . (u - u_pred)] = 0`` (``t`` the unit tangent), the next tangent
the null vector of ``dF/du`` with the sense of the last one. The step doubles after an easy
correction (at most 3 iterations) and halves after a failure. Its settings are a
:class:`hybrid.ContinuationOptions` (``ds``, ``ds_min``, ``ds_max``, ``max_points``, ``newton``).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from ..core.errors import GrazingSwitchError
from ..core.options import ContinuationOptions

__all__ = ["follow", "correct_point", "tangent", "RETRY"]

#: What ``accept`` returns for a point that lies beyond a boundary of the branch (e.g. where the
#: solution changes kind): it is discarded and approached with half the step, down to ``ds_min``
#: (then the branch ends with the reason ``"boundary"``).
RETRY = "retry"


def tangent(J: np.ndarray, previous: np.ndarray) -> np.ndarray:
    """Unit null vector of ``J`` (n x (n+1)) with a positive projection on ``previous``."""
    A = np.vstack([J, previous])
    b = np.zeros(A.shape[0])
    b[-1] = 1.0
    t = np.linalg.lstsq(A, b, rcond=None)[0]
    t /= np.linalg.norm(t)
    return t if t @ previous >= 0 else -t


def follow(
    evaluate: Callable,
    u0: np.ndarray,
    t0: np.ndarray,
    settings: ContinuationOptions,
    *,
    index: int,
    p_range: tuple[float, float],
    accept: Callable | None = None,
) -> tuple[list, str]:
    """Follow the curve ``F(u) = 0`` from the solution ``u0`` in the direction ``t0``.

    Parameters
    ----------
    evaluate : callable
        ``u -> (F, J, info)``; may raise ``RuntimeError``, :class:`hybrid.core.errors.GrazingSwitchError`
        or ``ZeroDivisionError`` (a failed evaluation: the step is shortened).
    u0 : ndarray, shape (n+1,)
        A solution (it is corrected first along ``t0``'s normal hyperplane).
    t0 : ndarray, shape (n+1,)
        The initial direction.
    settings : ContinuationOptions
        ``ds``, ``ds_min``, ``ds_max``: first, smallest and largest arclength step (in ``u``'s
        units); ``max_points``; ``newton``: the corrector's iterations per step and its tolerance
        on ``max |F|`` and on the last update (relative to ``max(1, max |u|)``).
    index : int
        Position of the continued parameter in ``u``.
    p_range : (float, float)
        The branch ends when the parameter leaves this interval.
    accept : callable, optional
        ``(u, info) -> str | None`` for each corrected point: a reason to stop after it, None, or
        :data:`RETRY` (the point is discarded and the step halved).

    Returns
    -------
    points : list of (ndarray, info, ndarray)
        Each point, what ``evaluate`` said of it, and the unit tangent there.
    reason : str
        ``"range"``, ``"max_points"``, ``"stalled"``, ``"boundary"`` or the reason given by ``accept``.
    """
    st = settings
    t = np.asarray(t0, dtype=float) / np.linalg.norm(t0)
    u = np.asarray(u0, dtype=float)
    points: list = []
    ds = 0.0  # the start: corrected on its own hyperplane
    lo, hi = p_range
    while len(points) < st.max_points:
        got = correct_point(evaluate, u + ds * t, t, st)
        if got is None:
            if ds == 0.0:
                return points, "stalled"
            ds *= 0.5
            if ds < st.ds_min:
                return points, "stalled"
            continue
        u_new, J, info, iters = got
        why = accept(u_new, info) if accept is not None else None
        if why == RETRY:  # a point beyond a boundary of the branch: approach it with shorter steps
            ds *= 0.5
            if ds < st.ds_min:
                return points, "boundary"
            continue
        t = tangent(J, t)
        u = u_new
        points.append((u.copy(), info, t.copy()))
        if not lo <= u[index] <= hi:
            return points, "range"
        if why:
            return points, why
        ds = st.ds if ds == 0.0 else (min(2.0 * ds, st.ds_max) if iters <= 3 else ds)
    return points, "max_points"


def correct_point(evaluate, u, t, st: ContinuationOptions):
    """Newton's method on ``[F(u); t . (u - u_pred)]`` from ``u_pred = u``; ``(u, J, info,
    iterations)`` or None (a failed evaluation, a parameter outside its domain, no convergence)."""
    u_pred = u.copy()
    tol = st.newton.tol
    for it in range(st.newton.max_iter):
        try:
            F, J, info = evaluate(u)
        except (RuntimeError, ValueError, GrazingSwitchError, ZeroDivisionError, np.linalg.LinAlgError):
            return None  # (ValueError: a parameter outside its domain, e.g. a negative belt speed)
        if not np.all(np.isfinite(F)):
            return None
        A = np.vstack([J, t])
        rhs = -np.concatenate([F, [t @ (u - u_pred)]])
        du = np.linalg.lstsq(A, rhs, rcond=None)[0]
        scale = max(1.0, float(np.max(np.abs(u))))
        if float(np.max(np.abs(F))) <= tol * scale and float(np.max(np.abs(du))) <= 10 * tol * scale:
            return u, J, info, it
        u = u + du
    return None
