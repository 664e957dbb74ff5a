"""Bounded minimisation of a scalar function of one variable (Brent's method), in plain Python.

The engine needs it only as a rare fallback when it locates an extremum of an output (see
:class:`hybrid.orbits.orbit._Extrema`); importing ``scipy.optimize`` for it cost about 0.6 s in every
worker process of a frequency response.
"""

from __future__ import annotations

import math
from collections.abc import Callable

__all__ = ["bounded_minimum"]

_GOLDEN = 0.5 * (3.0 - math.sqrt(5.0))
_SQRT_EPS = math.sqrt(2.2e-16)  # as in scipy.optimize.fminbound


def bounded_minimum(
    f: Callable[[float], float], a: float, b: float, xatol: float, max_evaluations: int = 500
) -> tuple[float, float]:
    """A local minimum of ``f`` on ``[a, b]`` by Brent's method (golden sections and parabolas).

    The algorithm of Brent (1973), as in ``scipy.optimize.fminbound``: the bounds themselves are
    never evaluated.

    Parameters
    ----------
    f : callable
        ``f(x) -> float``.
    a, b : float
        Bounds, ``a < b`` (same unit as ``x``).
    xatol : float
        Absolute tolerance on ``x`` (same unit), > 0.
    max_evaluations : int, optional
        Most evaluations of ``f``.

    Returns
    -------
    (x, f(x)) : tuple of float
    """
    a, b = float(a), float(b)
    v = w = x = a + _GOLDEN * (b - a)
    fv = fw = fx = float(f(x))
    d = e = 0.0
    n = 1
    xm = 0.5 * (a + b)
    tol1 = _SQRT_EPS * abs(x) + xatol / 3.0
    tol2 = 2.0 * tol1
    while abs(x - xm) > tol2 - 0.5 * (b - a) and n < max_evaluations:
        golden = True
        if abs(e) > tol1:  # try a parabola through x, w, v
            golden = False
            r = (x - w) * (fx - fv)
            q = (x - v) * (fx - fw)
            p = (x - v) * q - (x - w) * r
            q = 2.0 * (q - r)
            if q > 0.0:
                p = -p
            q = abs(q)
            r, e = e, d
            if abs(p) < abs(0.5 * q * r) and q * (a - x) < p < q * (b - x):
                d = p / q
                u = x + d
                if u - a < tol2 or b - u < tol2:
                    d = tol1 if xm >= x else -tol1
            else:
                golden = True
        if golden:
            e = (a - x) if x >= xm else (b - x)
            d = _GOLDEN * e
        u = x + (math.copysign(1.0, d) if d != 0.0 else 1.0) * max(abs(d), tol1)
        fu = float(f(u))
        n += 1
        if fu <= fx:
            if u >= x:
                a = x
            else:
                b = x
            v, fv = w, fw
            w, fw = x, fx
            x, fx = u, fu
        else:
            if u < x:
                a = u
            else:
                b = u
            if fu <= fw or w == x:
                v, fv = w, fw
                w, fw = u, fu
            elif fu <= fv or v == x or v == w:
                v, fv = u, fu
        xm = 0.5 * (a + b)
        tol1 = _SQRT_EPS * abs(x) + xatol / 3.0
        tol2 = 2.0 * tol1
    return x, fx
