"""Exact free response of the one-degree-of-freedom Coulomb oscillator.

``m x'' + k x + R sign(x') = 0`` released from rest at ``x(0) = x0``. The mass sticks
whenever ``x' = 0`` and ``|k x| <= R``. Between turning points the sign of ``x'`` is fixed, so
each half cycle is a cosine of angular frequency ``omega = sqrt(k/m)`` about the shifted
equilibrium ``+-d`` with ``d = R/k``: the turning-point amplitude drops by ``2 d`` per half
cycle, and the motion stops for good at the first turning point with ``|x| <= d``.

Units: ``m`` [kg], ``k`` [N/m], ``R`` [N], ``x0`` [m], ``t`` [s].

Also the amplitude of the forced oscillator's non-stop steady motion (:func:`den_hartog`).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray


def _check(m: float, k: float, R: float) -> None:
    if not m > 0.0:
        raise ValueError(f"m must be > 0 (mass, kg), got {m!r}")
    if not k > 0.0:
        raise ValueError(f"k must be > 0 (stiffness, N/m), got {k!r}")
    if not R >= 0.0:
        raise ValueError(f"R must be >= 0 (friction force, N), got {R!r}")


def half_cycles(m: float, k: float, R: float, x0: float) -> float:
    """Number of half cycles before the oscillator sticks.

    Parameters
    ----------
    m, k, R, x0 : float
        Mass [kg], stiffness [N/m], friction force [N], initial displacement [m].

    Returns
    -------
    float
        The smallest ``n >= 0`` with ``|x0| - 2 n d <= d`` (``d = R/k``); ``inf`` if ``R == 0``
        and ``x0 != 0``.
    """
    _check(m, k, R)
    a0 = abs(float(x0))
    if a0 == 0.0:
        return 0.0
    if R == 0.0:
        return math.inf
    d = R / k
    n = max(0, math.ceil((a0 / d - 1.0) / 2.0))
    # Guard the rounding of the division at the boundaries of the integer part.
    while n > 0 and a0 - 2.0 * (n - 1) * d <= d:
        n -= 1
    while a0 - 2.0 * n * d > d:
        n += 1
    return float(n)


def stop_time(m: float, k: float, R: float, x0: float) -> float:
    """Time at which the oscillator comes to rest for good.

    Parameters
    ----------
    m, k, R, x0 : float
        Mass [kg], stiffness [N/m], friction force [N], initial displacement [m].

    Returns
    -------
    float
        ``n pi / omega`` [s] with ``n`` from :func:`half_cycles`; ``inf`` if it never stops.
    """
    n = half_cycles(m, k, R, x0)
    return n * math.pi / math.sqrt(k / m) if n > 0 else 0.0


def stop_position(m: float, k: float, R: float, x0: float) -> float:
    """Position at which the oscillator comes to rest for good.

    Parameters
    ----------
    m, k, R, x0 : float
        Mass [kg], stiffness [N/m], friction force [N], initial displacement [m].

    Returns
    -------
    float
        ``(-1)^n sign(x0) (|x0| - 2 n R/k)`` [m], with ``|.| <= R/k``; ``nan`` if ``R == 0`` and
        ``x0 != 0`` (it never stops).
    """
    n = half_cycles(m, k, R, x0)
    if math.isinf(n):
        return math.nan
    a_n = abs(float(x0)) - 2.0 * n * (R / k)
    return math.copysign(1.0, float(x0)) * (-1.0) ** n * a_n


def free_response(
    m: float, k: float, R: float, x0: float, t: ArrayLike
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Exact displacement and velocity of the released Coulomb oscillator.

    Parameters
    ----------
    m, k, R, x0 : float
        Mass [kg], stiffness [N/m], friction force [N], initial displacement [m]; the initial
        velocity is 0.
    t : array_like
        Times [s], ``>= 0``, any shape.

    Returns
    -------
    x, v : ndarray
        Displacement [m] and velocity [m/s] with the shape of ``t``.

    Raises
    ------
    ValueError
        If ``m <= 0``, ``k <= 0``, ``R < 0`` or any ``t < 0``.
    """
    _check(m, k, R)
    tt = np.asarray(t, dtype=float)
    if np.any(tt < 0.0):
        raise ValueError("t must be >= 0 (the release time is 0)")
    omega = math.sqrt(k / m)
    d = R / k
    x0 = float(x0)
    n_stop = half_cycles(m, k, R, x0)
    # Index of the half cycle containing t (clipped to the rest phase).
    n = np.floor(tt * (omega / math.pi))
    if math.isfinite(n_stop):
        n = np.minimum(n, n_stop)
    moving = n < n_stop
    # Start of half cycle n: x_n = s_n a_n, s_n = sign(x0) (-1)^n, a_n = |x0| - 2 n d.
    s_n = math.copysign(1.0, x0) * np.where(n % 2 == 0, 1.0, -1.0)
    a_n = abs(x0) - 2.0 * n * d
    # Velocity has sign -s_n, so the equilibrium of the half cycle is s_n d.
    amp = s_n * (a_n - d)
    phase = omega * (tt - n * (math.pi / omega))
    x = np.where(moving, s_n * d + amp * np.cos(phase), s_n * a_n)
    v = np.where(moving, -amp * omega * np.sin(phase), 0.0)
    return x, v


def den_hartog(m: float, k: float, R: float, F: float, W: float) -> float:
    """Amplitude [m] of the non-stop steady motion of ``m x'' + k x + R sgn(x') = F cos(W t)``.

    Den Hartog (1931), "Forced vibrations with combined Coulomb and viscous friction", Trans.
    ASME APM-53-9, 107-115. Units: ``m`` [kg], ``k`` [N/m], ``R``, ``F`` [N], ``W`` [rad/s].

    Half a period from ``x = -X, x' = 0`` to ``x = X, x' = 0`` with friction ``-R``: the general
    solution ``x = A cos(w t) + B sin(w t) + x_st V cos(W t + phi) - R/k`` (``w^2 = k/m``,
    ``r = W/w``, ``x_st = F/k``, ``V = 1/(1 - r^2)``, ``theta = pi/r``) and the four end
    conditions give ``B = (R/k) sin(theta)/(1 + cos(theta))``, ``x_st V r sin(phi) = B`` and
    ``X = -x_st V cos(phi)``, hence Den Hartog's

        X / x_st = sqrt(V^2 - (R/F)^2 U^2),   U = sin(theta) / (r (1 + cos(theta))).

    The motion does not stop at the turning points if ``k X r^2 > R`` (the force on the mass
    at ``x = -X`` is ``F cos(phi) + k X = k X r^2``).
    """
    w = math.sqrt(k / m)
    r = W / w
    th = math.pi / r
    V = 1.0 / (1.0 - r * r)
    U = math.sin(th) / (r * (1.0 + math.cos(th)))
    return (F / k) * math.sqrt(V * V - (R / F) ** 2 * U * U)
