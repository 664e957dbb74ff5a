"""Brent's bounded minimisation (hybrid.core.scalar) against scipy's fminbound and closed forms."""

import math

import numpy as np
import pytest
from scipy.optimize import minimize_scalar

from hybrid.core.scalar import bounded_minimum

CASES = [
    (lambda x: (x - 0.3) ** 2, 0.0, 1.0, 0.3),  # interior parabola
    (lambda x: -math.sin(x), 0.0, 3.0, 0.5 * math.pi),  # smooth, not a parabola
    (lambda x: math.cosh(x - 2.0) + 0.1 * x, 0.0, 5.0, 2.0 - math.asinh(0.1)),
    (lambda x: abs(x - 0.7) ** 1.5, 0.0, 1.0, 0.7),  # not smooth at its minimum
    (lambda x: x, 1.0, 2.0, 1.0),  # minimum at the lower bound
    (lambda x: -(x**3), -1.0, 4.0, 4.0),  # minimum at the upper bound
]


@pytest.mark.parametrize("k", range(len(CASES)))
def test_matches_closed_form_and_scipy(k):
    f, a, b, x_true = CASES[k]
    xatol = 1e-10 * (b - a)
    x, fx = bounded_minimum(f, a, b, xatol)
    ref = minimize_scalar(f, bounds=(a, b), method="bounded", options={"xatol": xatol})
    assert fx == f(x)
    # the same iterates as scipy's implementation of Brent's method
    assert x == pytest.approx(float(ref.x), rel=0, abs=1e-12 * (b - a))
    assert fx == pytest.approx(float(ref.fun), rel=1e-12, abs=1e-15)
    # and the true minimiser, to the tolerance (the bounds themselves are never evaluated)
    assert abs(x - x_true) <= 1e-6 * (b - a)


def test_counts_evaluations():
    calls = []

    def f(x):
        calls.append(x)
        return math.cosh(x - 0.25)

    bounded_minimum(f, 0.0, 1.0, 1e-10, max_evaluations=7)
    assert len(calls) == 7
    assert all(0.0 < c < 1.0 for c in calls)


def test_raises_what_f_raises():
    with pytest.raises(ZeroDivisionError):
        bounded_minimum(lambda x: 1.0 / 0.0, 0.0, 1.0, 1e-10)


def test_finite_on_noisy_plateau():
    rng = np.random.default_rng(1)
    x, fx = bounded_minimum(lambda x: 1.0 + 1e-16 * rng.standard_normal(), 0.0, 1.0, 1e-10)
    assert 0.0 < x < 1.0
    assert math.isfinite(fx)
