"""Tests of the exact Coulomb-oscillator free response (hybrid_models.coulomb_exact)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from hybrid_models.coulomb_exact import free_response, half_cycles, stop_position, stop_time

CASES = [
    # m [kg], k [N/m], R [N], x0 [m]
    (1.0, 1.0, 0.1, 1.05),
    (2.0, 5.0, 0.7, -3.3),
    (0.3, 40.0, 2.0, 0.49),
]


def _reference_turning_points(m, k, R, x0, n_max=50):
    """Turning points from solve_ivp with a fixed friction sign per half cycle.

    Each half cycle integrates ``m x'' + k x + R s = 0`` (``s = -sign(x)`` at the turning point
    it starts from) until the velocity returns to zero; the motion stops when ``|k x| <= R``.
    """
    t0, x = 0.0, x0
    points = [(t0, x)]
    segments = []
    period = 2 * math.pi * math.sqrt(m / k)
    for _ in range(n_max):
        if abs(k * x) <= R:
            break
        s = -math.copysign(1.0, x)  # sign of the velocity in this half cycle

        def f(t, y, s=s):
            return [y[1], -(k * y[0] + R * s) / m]

        def back_at_rest(t, y, s=s):
            return y[1]

        back_at_rest.terminal = True
        back_at_rest.direction = -s  # v leaves 0 with sign s and returns to it
        sol = solve_ivp(
            f,
            (t0, t0 + period),
            [x, 0.0],
            method="DOP853",
            rtol=1e-12,
            atol=1e-14,
            events=back_at_rest,
            dense_output=True,
        )
        t_end = float(sol.t_events[0][0])
        segments.append((t0, t_end, sol.sol))
        t0, x = t_end, float(sol.y_events[0][0][0])
        points.append((t0, x))
    return points, segments


@pytest.mark.parametrize(("m", "k", "R", "x0"), CASES)
def test_matches_piecewise_ode_reference(m, k, R, x0):
    points, segments = _reference_turning_points(m, k, R, x0)
    scale = abs(x0)
    # Turning points, stop time and stop position.
    assert half_cycles(m, k, R, x0) == len(segments)
    assert stop_time(m, k, R, x0) == pytest.approx(points[-1][0], rel=1e-12)
    assert stop_position(m, k, R, x0) == pytest.approx(points[-1][1], abs=1e-11 * scale)
    # Inside each half cycle the closed form equals the ODE solution.
    omega = math.sqrt(k / m)
    for t_a, t_b, dense in segments:
        t = np.linspace(t_a, t_b, 101)[1:-1]
        x, v = free_response(m, k, R, x0, t)
        ref = dense(t)
        np.testing.assert_allclose(x, ref[0], rtol=0, atol=1e-11 * scale)
        np.testing.assert_allclose(v, ref[1], rtol=0, atol=1e-11 * scale * omega)


@pytest.mark.parametrize(("m", "k", "R", "x0"), CASES)
def test_satisfies_ode_and_continuity(m, k, R, x0):
    omega = math.sqrt(k / m)
    t_stop = stop_time(m, k, R, x0)
    n = int(half_cycles(m, k, R, x0))
    # ODE residual with the analytic acceleration of a cosine about s d: x'' = -omega^2 (x - s d)
    # where s = -sign(v); check it via a centred difference of v inside the pieces.
    t = np.linspace(0.0, t_stop, 4000)
    t = t[(np.abs(np.sin(omega * t)) > 1e-3)]  # away from the turning points
    x, v = free_response(m, k, R, x0, t)
    h = 1e-6 / omega
    _, vp = free_response(m, k, R, x0, t + h)
    _, vm = free_response(m, k, R, x0, t - h)
    acc = (vp - vm) / (2 * h)
    residual = m * acc + k * x + R * np.sign(v)
    assert np.abs(residual).max() <= 1e-6 * k * abs(x0)
    # Continuity of x and v at every turning point (incl. the final one).
    eps = 1e-9 / omega
    for i in range(1, n + 1):
        t_i = i * math.pi / omega
        x_l, v_l = free_response(m, k, R, x0, t_i - eps)
        x_r, v_r = free_response(m, k, R, x0, t_i + eps)
        assert abs(x_r - x_l) <= 1e-14 * abs(x0)
        assert abs(v_r - v_l) <= 2 * eps * (k * abs(x0) + R) / m + 1e-12
        assert abs(v_l) <= 1e-8 * omega * abs(x0)


@pytest.mark.parametrize(("m", "k", "R", "x0"), CASES)
def test_rest_after_stop(m, k, R, x0):
    t_stop = stop_time(m, k, R, x0)
    x_stop = stop_position(m, k, R, x0)
    assert abs(k * x_stop) <= R
    t = t_stop + np.array([0.0, 1e-3, 1.0, 1e3])
    x, v = free_response(m, k, R, x0, t)
    np.testing.assert_allclose(x, x_stop, rtol=0, atol=1e-14 * abs(x0))
    np.testing.assert_array_equal(v, 0.0)
    # Energy: everything lost went into friction, R times the path between turning points.
    omega = math.sqrt(k / m)
    turning, _ = free_response(m, k, R, x0, np.arange(int(half_cycles(m, k, R, x0)) + 1) * math.pi / omega)
    path = np.abs(np.diff(turning)).sum()
    assert 0.5 * k * (x0**2 - x_stop**2) == pytest.approx(R * path, rel=1e-12)


def test_hand_computed_stop():
    # d = R/k = 0.1: turning points 1.05, -0.85, 0.65, -0.45, 0.25, -0.05 -> 5 half cycles.
    assert half_cycles(1.0, 1.0, 0.1, 1.05) == 5
    assert stop_time(1.0, 1.0, 0.1, 1.05) == pytest.approx(5 * math.pi, rel=1e-15)
    assert stop_position(1.0, 1.0, 0.1, 1.05) == pytest.approx(-0.05, rel=1e-12)
    # Exactly on the stick boundary after one half cycle: 0.3 -> -0.1, |k x| = R sticks.
    assert half_cycles(1.0, 1.0, 0.1, 0.3) == 1
    assert stop_position(1.0, 1.0, 0.1, 0.3) == pytest.approx(-0.1, rel=1e-12)
    # Exact float equality with the band edge: 3 -> -1 with d = 1 sticks at -1.
    assert half_cycles(1.0, 1.0, 1.0, 3.0) == 1
    assert stop_position(1.0, 1.0, 1.0, 3.0) == -1.0
    # Starting inside the stick band: never moves.
    x, v = free_response(1.0, 1.0, 0.1, -0.08, [0.0, 1.0, 10.0])
    np.testing.assert_array_equal(x, -0.08)
    np.testing.assert_array_equal(v, 0.0)
    assert stop_time(1.0, 1.0, 0.1, -0.08) == 0.0


def test_frictionless_limit_and_shapes():
    t = np.linspace(0.0, 20.0, 60).reshape(3, 20)
    x, v = free_response(2.0, 8.0, 0.0, 0.4, t)
    assert x.shape == v.shape == (3, 20)
    np.testing.assert_allclose(x, 0.4 * np.cos(2.0 * t), rtol=0, atol=1e-14)
    np.testing.assert_allclose(v, -0.8 * np.sin(2.0 * t), rtol=0, atol=1e-14)
    assert stop_time(2.0, 8.0, 0.0, 0.4) == math.inf
    assert math.isnan(stop_position(2.0, 8.0, 0.0, 0.4))
    x0, v0 = free_response(1.0, 1.0, 0.5, 2.0, 0.0)
    assert x0.shape == ()
    assert float(x0) == 2.0
    assert float(v0) == 0.0


@pytest.mark.parametrize(
    ("args", "name"),
    [((0.0, 1.0, 0.1, 1.0), "m"), ((1.0, -1.0, 0.1, 1.0), "k"), ((1.0, 1.0, -0.1, 1.0), "R")],
)
def test_bad_inputs(args, name):
    with pytest.raises(ValueError, match=f"^{name} must"):
        free_response(*args, [0.0])
    with pytest.raises(ValueError, match=f"^{name} must"):
        stop_time(*args)
    with pytest.raises(ValueError, match=f"^{name} must"):
        stop_position(*args)
    with pytest.raises(ValueError, match="t must"):
        free_response(1.0, 1.0, 0.1, 1.0, [-1.0, 0.0])
