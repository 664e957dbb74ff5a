"""The closed forms of issue 23 (hybrid_models.classics, hybrid_models.linear.band_edges) checked
against their own definitions: fixed points, derivatives by differences, sign changes."""

from __future__ import annotations

import math

import pytest

import hybrid_models
from hybrid_models.classics import (
    belt_grazing_speed,
    den_hartog_boundary,
    den_hartog_nonstop,
    shaw_branch_point,
    shaw_half_map,
    shaw_half_map_derivative,
    shaw_symmetric_orbit,
)
from hybrid_models.linear import band_edges, limit_amplitude, stick_amplitudes, stick_eigenfrequencies


def test_shaw_symmetric_orbit_is_a_fixed_point_of_the_half_map_and_its_derivative_is_exact():
    for W in (0.42, 0.45, 0.463):
        xs, d = shaw_symmetric_orbit(W)
        assert xs < 0
        assert abs(shaw_half_map(xs, W)[0] - xs) <= 1e-13
        h = 1e-6
        fd = (shaw_half_map(xs + h, W)[0] - shaw_half_map(xs - h, W)[0]) / (2 * h)
        assert abs(fd - d) <= 1e-7
        assert abs(shaw_half_map_derivative(xs, W) - d) == 0.0


def test_shaw_branch_point_is_where_the_half_maps_derivative_is_minus_one():
    W = shaw_branch_point((0.46, 0.465))
    assert 0.46 < W < 0.465
    assert abs(shaw_symmetric_orbit(W)[1] + 1.0) <= 1e-10
    # the multiplier h'^2 is below 1 on one side and above on the other
    assert (shaw_symmetric_orbit(W - 1e-4)[1] ** 2 - 1) * (shaw_symmetric_orbit(W + 1e-4)[1] ** 2 - 1) < 0


def test_den_hartog_boundary_is_where_the_turning_point_force_reaches_the_friction_level():
    W = den_hartog_boundary(1.0, 1.0, 0.1, 0.3, 1.0, (0.45, 0.55))
    assert abs(den_hartog_nonstop(1.0, 1.0, 0.1, 0.3, 1.0, W)[2]) <= 1e-12
    g = [den_hartog_nonstop(1.0, 1.0, 0.1, 0.3, 1.0, W + s * 1e-3)[2] for s in (-1, 1)]
    assert g[0] * g[1] < 0


def test_belt_grazing_speed_is_where_the_slip_velocity_returns_tangentially_to_the_belts():
    # an independent check: the slip phase from the break-away integrated by solve_ivp; its velocity's
    # first maximum after its minimum is the belt speed at V, below it just above V, above just below
    import numpy as np
    from scipy.integrate import solve_ivp

    m, k, c, Fs, Fk = 1.0, 1.0, 0.05, 1.0, 0.5
    V = belt_grazing_speed(m, k, c, Fs, Fk, (0.8, 0.86))

    def excess(vb: float) -> float:
        t = np.linspace(0.0, 2.5 * math.pi, 25001)
        sol = solve_ivp(
            lambda _, y: [y[1], (Fk - k * y[0] - c * y[1]) / m],
            (0.0, t[-1]),
            [(Fs - c * vb) / k, vb],
            t_eval=t,
            rtol=1e-12,
            atol=1e-14,
        )
        v = sol.y[1]
        i = int(np.argmin(v))
        return float(np.max(v[i:]) - vb)

    assert abs(excess(V)) <= 1e-7
    assert excess(V + 1e-3) < 0 < excess(V - 1e-3)


@pytest.mark.parametrize("model", ["absorber", "isolator"])
def test_band_edges_are_where_the_stick_amplitude_meets_the_limit(model):
    p = getattr(hybrid_models, model)().preset("standard")
    for w_res in stick_eigenfrequencies(p):
        lo, hi = band_edges(model, p, 0.9 * w_res, 1.1 * w_res)
        assert lo < w_res < hi
        for w in (lo, hi):
            a = abs(float(stick_amplitudes(p, w)[0]))
            assert abs(a - float(limit_amplitude(model, p, w))) <= 1e-12 * max(a, 1.0)
    with pytest.raises(ValueError, match="no stick eigenfrequency"):
        band_edges(model, p, 10.0, 11.0)
    assert not math.isnan(lo)
