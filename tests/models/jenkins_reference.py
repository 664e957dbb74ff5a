"""An EPMC backbone of the Jenkins oscillator written independently of the library (issue 31).

``m x'' + k x + f_J = xi m x'`` with the Jenkins element (spring ``kt`` in series with a slider of
slip force ``Fs``) to ground. The orbit is symmetric, so half a period suffices: from the top
``x = a, v = 0`` (the slider has just stopped, the element force ``kt (x - u) = Fs``), the element
sticks (``u = a - Fs/kt``) until its force reaches ``-Fs`` at ``x = a - 2 Fs/kt``, then slides
with the force ``-Fs`` until ``v = 0``, which must be at ``x = -a``. Each phase is affine, its flow
the matrix exponential of the augmented system ``(x, v, 1)``; the unknowns ``(xi, t1, t2)`` solve
the three conditions by MINPACK's hybrid method. ``omega = pi / (t1 + t2)``.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.linalg import expm
from scipy.optimize import fsolve


def _flow(A: np.ndarray, z0: np.ndarray, t: float) -> np.ndarray:
    return expm(A * t) @ z0


def _phases(a, xi, m, k, kt, Fs):
    u0 = a - Fs / kt
    stick = np.array([[0.0, 1.0, 0.0], [-(k + kt) / m, xi, kt * u0 / m], [0.0, 0.0, 0.0]])
    slip = np.array([[0.0, 1.0, 0.0], [-k / m, xi, Fs / m], [0.0, 0.0, 0.0]])
    return stick, slip


def _residual(p, a, m, k, kt, Fs):
    xi, t1, t2 = p
    stick, slip = _phases(a, xi, m, k, kt, Fs)
    z1 = _flow(stick, np.array([a, 0.0, 1.0]), t1)
    z2 = _flow(slip, z1, t2)
    return [(z1[0] - (a - 2 * Fs / kt)) / a, (z2[0] + a) / a, z2[1] / a]


def describing_function(a, m=1.0, k=1.0, kt=1.0, Fs=0.1):
    """Single-harmonic (describing-function) EPMC estimate ``(omega, xi)`` (approximate).

    The first harmonic of the element's hysteresis loop at amplitude ``a > Fs/kt``:
    ``k_eq = kt/pi (beta - sin(2 beta)/2)`` with ``cos beta = 1 - 2 Fs/(kt a)``; energy per cycle
    ``4 Fs (a - Fs/kt)``; ``omega^2 = (k + k_eq)/m``, ``xi m omega pi a^2 = 4 Fs (a - Fs/kt)`` (the work of ``xi m v``
    over a period of ``a cos(omega t)``).
    """
    if a <= Fs / kt:
        return math.sqrt((k + kt) / m), 0.0
    beta = math.acos(1 - 2 * Fs / (kt * a))
    keq = kt / math.pi * (beta - 0.5 * math.sin(2 * beta))
    w = math.sqrt((k + keq) / m)
    xi = 4 * Fs * (a - Fs / kt) / (math.pi * m * w * a * a)
    return w, xi


def jenkins_epmc(a, m=1.0, k=1.0, kt=1.0, Fs=0.1, guess=None):
    """``(omega [rad/s], xi [1/s], (xi, t1, t2))`` of the EPMC orbit of amplitude ``a > Fs/kt``."""
    if guess is None:
        ws = math.sqrt((k + kt) / m)
        c = kt * (a - Fs / kt) / (k + kt)
        t1 = math.acos(max(-1.0, min(1.0, (a - 2 * Fs / kt - c) / (a - c)))) / ws
        w, xi = describing_function(a, m, k, kt, Fs)
        guess = (xi, t1, max(math.pi / w - t1, 1e-3))
    sol, info, ier, msg = fsolve(_residual, guess, args=(a, m, k, kt, Fs), xtol=1e-15, full_output=True)
    if ier != 1 and max(abs(r) for r in info["fvec"]) > 1e-13:
        raise RuntimeError(f"reference EPMC did not converge at a = {a}: {msg}")
    xi, t1, t2 = sol
    # the phases as assumed: stuck while moving down, sliding until the first stop
    stick, slip = _phases(a, xi, m, k, kt, Fs)
    for s in np.linspace(0, 1, 41)[1:-1]:
        zs = _flow(stick, np.array([a, 0.0, 1.0]), s * t1)
        assert zs[1] < 0 and kt * (zs[0] - (a - Fs / kt)) > -Fs
        z1 = _flow(stick, np.array([a, 0.0, 1.0]), t1)
        assert _flow(slip, z1, s * t2)[1] < 0
    return math.pi / (t1 + t2), xi, tuple(sol)
