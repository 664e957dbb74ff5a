"""Closed forms of the classic friction oscillators' bifurcations, derived again here without `hybrid`.

* :func:`den_hartog_boundary`: the forcing frequency where Den Hartog's non-stop motion (viscous
  damping, one friction level) starts to stick (``friction_oscillator.toml``, preset ``denhartog``);
* :func:`shaw_half_map`, :func:`shaw_branch_point`: Shaw's oscillator (static friction above
  kinetic, no damping; preset ``shaw``): the map from one stuck position to the next, folded by the
  symmetry ``x -> -x``, ``t -> t + T/2``; its fixed point is the symmetric two-stop orbit, and the
  orbit's nontrivial Floquet multiplier is the square of the half map's derivative, so a
  multiplier crosses +1 (a symmetry-breaking pitchfork) where the derivative is -1;
* :func:`belt_grazing_speed`: the belt speed where the damped belt oscillator's stick-slip cycle
  grazes (``belt.toml`` with ``c > 0``: the slip phase returns to the belt's speed tangentially).

Each is written with the linear pieces' exact solutions and SciPy's root finders (brentq to
rounding); units as in the models (m, kg, N, s).

References
----------
.. [1] J. P. Den Hartog, "Forced vibrations with combined Coulomb and viscous friction", Trans.
   ASME 53 (1931) 107-115.
.. [2] S. W. Shaw, "On the dynamic response of a system with dry friction", J. Sound Vib. 108
   (1986) 305-325.
"""

from __future__ import annotations

import cmath
import math

import numpy as np
from scipy.optimize import brentq, fsolve

__all__ = [
    "den_hartog_boundary",
    "den_hartog_nonstop",
    "shaw_half_map",
    "shaw_half_map_derivative",
    "shaw_symmetric_orbit",
    "shaw_branch_point",
    "belt_grazing_speed",
]


def _forced_piece(m: float, c: float, k: float, F: float, W: float):
    """``(t0, x0, v0, Q) -> t -> (x, v)``: the exact solution of ``m x'' + c x' + k x = F sin(W t) + Q``
    (underdamped) from ``(x0, v0)`` at ``t0``."""
    X = F / complex(k - m * W * W, c * W)
    s = c / (2.0 * m)
    wd = math.sqrt(k / m - s * s)

    def flow(t0: float, x0: float, v0: float, Q: float):
        e0 = cmath.exp(1j * W * t0)
        A = x0 - ((X * e0).imag + Q / k)
        B = (v0 - (1j * W * X * e0).imag + s * A) / wd

        def at(t: float) -> tuple[float, float]:
            tau = t - t0
            d, co, si = math.exp(-s * tau), math.cos(wd * tau), math.sin(wd * tau)
            e = cmath.exp(1j * W * t)
            return (
                (X * e).imag + Q / k + d * (A * co + B * si),
                (1j * W * X * e).imag + d * ((wd * B - s * A) * co - (s * B + wd * A) * si),
            )

        return at

    return flow


# ----------------------------------------------------------------------------
def den_hartog_nonstop(
    m: float, k: float, c: float, R: float, F: float, W: float
) -> tuple[float, float, float]:
    """Den Hartog's symmetric non-stop orbit: ``(X, t0, g)``.

    The mass turns at ``x = -X`` (``v = 0``) at ``t0`` and slides forward (friction ``-R``) for
    half a period to ``x = X``. ``g = k X + F sin(W t0) - R``: the friction force the mass would
    need to stay at rest at its turning point, less ``R``; the motion is non-stop where ``g > 0``.
    """
    flow = _forced_piece(m, c, k, F, W)
    half = math.pi / W
    X0 = F / abs(complex(k - m * W * W, c * W))

    def res(z):
        X, t0 = z
        x, v = flow(t0, -X, 0.0, -R)(t0 + half)
        return [x - X, v]

    best = None
    for t_guess in np.linspace(-half, half, 9):
        z, info, _, _ = fsolve(res, [X0, t_guess], full_output=True, xtol=1e-15)
        if z[0] > 0 and max(abs(v) for v in info["fvec"]) < 1e-12:
            X, t0 = z
            # the orbit slides forward all the half period (where it exists: past the boundary the
            # equations' solution is not a motion, and g < 0 says so)
            forward = all(flow(t0, -X, 0.0, -R)(t0 + f * half)[1] > 0 for f in (0.25, 0.5, 0.75))
            if best is None or forward:
                best = (float(X), float(t0))
            if forward:
                break
    if best is None:
        raise ValueError(f"no non-stop orbit found at W = {W!r}")
    X, t0 = best
    return X, t0, k * X + F * math.sin(W * t0) - R


def den_hartog_boundary(
    m: float, k: float, c: float, R: float, F: float, bracket: tuple[float, float]
) -> float:
    """The forcing frequency [rad/s] in ``bracket`` where the non-stop motion starts to stick
    (``g`` of :func:`den_hartog_nonstop` through zero); brentq to rounding."""
    return brentq(
        lambda W: den_hartog_nonstop(m, k, c, R, F, W)[2], *bracket, xtol=1e-16, rtol=8.9e-16, maxiter=200
    )


# ----------------------------------------------------------------------------
def shaw_half_map(
    xs: float, W: float, m: float = 1.0, k: float = 1.0, F: float = 1.0, Rs: float = 0.5, Rk: float = 0.3
):
    """Shaw's oscillator (``m x'' + k x = F sin(W t) + friction``, no damping): from the mass stuck at
    ``xs < 0``, the next stuck position folded by the symmetry: ``(-x_e, t_b, t_e)``.

    The mass breaks away forward when ``k xs - F sin(W t) = -Rs`` (``W t_b = asin((k xs + Rs)/F)``,
    where that force is falling), slides with friction ``-Rk`` and stops at the first ``t_e > t_b``
    where ``v = 0``, at ``x_e``.
    """
    w = math.sqrt(k / m)
    tb = math.asin((k * xs + Rs) / F) / W
    P = F / (k - m * W * W)

    def x(t):
        return P * math.sin(W * t) - Rk / k + A * math.cos(w * (t - tb)) + B * math.sin(w * (t - tb))

    def v(t):
        return P * W * math.cos(W * t) - A * w * math.sin(w * (t - tb)) + B * w * math.cos(w * (t - tb))

    A = xs - (P * math.sin(W * tb) - Rk / k)
    B = -(P * W * math.cos(W * tb)) / w
    h = 2.0 * math.pi / max(W, w) / 400.0
    t = tb + 1e-9
    while v(t) <= 0.0:
        t += 1e-6 * h
    while v(t + h) > 0.0:
        t += h
    te = brentq(v, t, t + h, xtol=1e-16, rtol=8.9e-16, maxiter=200)
    return -x(te), tb, te


def shaw_half_map_derivative(
    xs: float, W: float, m: float = 1.0, k: float = 1.0, F: float = 1.0, Rs: float = 0.5, Rk: float = 0.3
) -> float:
    """``d(-x_e)/d(xs)`` of :func:`shaw_half_map`, exact: ``v(t_e) = 0``, so only the motion's
    dependence on its start (``xs`` and the break-away time ``t_b(xs)``) at fixed ``t_e`` counts."""
    w = math.sqrt(k / m)
    _, tb, te = shaw_half_map(xs, W, m, k, F, Rs, Rk)
    P = F / (k - m * W * W)
    c, sn = math.cos(W * tb), math.sin(W * tb)
    A = xs - (P * sn - Rk / k)
    B = -(P * W * c) / w
    dtb = k / (F * W * c)
    dA = 1.0 - P * W * c * dtb
    dB = P * W * W * sn * dtb / w
    ph = w * (te - tb)
    dx = dA * math.cos(ph) + dB * math.sin(ph) + (A * w * math.sin(ph) - B * w * math.cos(ph)) * dtb
    return -dx


def shaw_symmetric_orbit(W: float, guess: float = -1.3, **params) -> tuple[float, float]:
    """The symmetric two-stop orbit: its stuck position ``x* < 0`` (fixed point of the half map) and
    the half map's derivative there (:func:`shaw_half_map_derivative`); the orbit's nontrivial
    Floquet multiplier is its square."""
    k, F, Rs = params.get("k", 1.0), params.get("F", 1.0), params.get("Rs", 0.5)
    lo = max(guess - 0.3, (-F - Rs) / k + 1e-12)  # (a break-away needs |k xs + Rs| <= F)
    xs = brentq(lambda x: shaw_half_map(x, W, **params)[0] - x, lo, min(guess + 0.3, -1e-9), xtol=1e-16)

    return xs, shaw_half_map_derivative(xs, W, **params)


def shaw_branch_point(bracket: tuple[float, float], guess: float = -1.3, **params) -> float:
    """The forcing frequency in ``bracket`` where the half map's derivative at the symmetric orbit is
    -1 (its multiplier +1 without a fold: the symmetry-breaking pitchfork)."""

    def g(W):
        return shaw_symmetric_orbit(W, guess, **params)[1] + 1.0

    return brentq(g, *bracket, xtol=1e-14, rtol=8.9e-16, maxiter=200)


# ----------------------------------------------------------------------------
def belt_grazing_speed(
    m: float, k: float, c: float, Fs: float, Fk: float, bracket: tuple[float, float]
) -> float:
    """The belt speed in ``bracket`` where the damped belt oscillator's stick-slip cycle grazes.

    From the break-away (``k x + c v_b = Fs``, ``v = v_b``) the mass slides slower than the belt
    (friction ``+Fk``): ``m X'' + c X' + k X = 0`` about ``x = Fk/k``. It sticks again where ``v``
    returns to ``v_b`` from below; the cycle grazes where the first maximum of ``v`` after its
    minimum equals ``v_b``.
    """
    s = c / (2.0 * m)
    wd = math.sqrt(k / m - s * s)

    def g(vb: float) -> float:
        A = (Fs - Fk - c * vb) / k
        B = (vb + s * A) / wd
        # X = e^{-st}(A cos + B sin); V = X' = e^{-st}(C cos + D sin); V' = e^{-st}(E cos + G sin)
        C, D = wd * B - s * A, -wd * A - s * B
        E, G = wd * D - s * C, -wd * C - s * D
        # V' = 0 where tan(wd t) = -E/G: the zeros after t = 0 in order; the second is the maximum
        t1 = math.atan2(-E, G) / wd
        while t1 <= 0.0:
            t1 += math.pi / wd
        t2 = t1 + math.pi / wd
        d = math.exp(-s * t2)
        return d * (C * math.cos(wd * t2) + D * math.sin(wd * t2)) - vb

    return brentq(g, *bracket, xtol=1e-16, rtol=8.9e-16, maxiter=200)
