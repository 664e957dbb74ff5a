"""Tests of the closed forms of Appendix A (hybrid_models.linear)."""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest

import hybrid_models
from hybrid_models.linear import (
    limit_amplitude,
    slip_eigenfrequencies,
    stick_amplitudes,
    stick_eigenfrequencies,
    stick_response,
)

# The paper's standard sets, from the model files' presets (checked against the paper in test_dampers.py).
ABSORBER = hybrid_models.absorber().preset("standard")
ISOLATOR = hybrid_models.isolator().preset("standard")
PARAMS = {"absorber": ABSORBER, "isolator": ISOLATOR}


def _stick_residuals(model: str, p: dict[str, float], y: np.ndarray, t: np.ndarray):
    """Residuals [N] of the stick equations (1)/(7); accelerations taken analytically.

    For ``x = offset + A sin(Omega t)`` the second derivative is ``-Omega^2 (x - x(0))``.
    """
    om = p["Omega"]
    x1, x2, u = y[:, 0], y[:, 2], y[:, 4]
    acc1 = -(om**2) * (x1 - x1[0])
    acc2 = -(om**2) * (x2 - x2[0])
    force = p["F"] * np.sin(om * t)
    if model == "absorber":
        r1 = p["m1"] * acc1 + p["c1"] * x1 + p["c2"] * (x1 - u) - force
        r2 = p["m2"] * acc2 + p["c2"] * (u - x1)
    else:
        r1 = p["m1"] * acc1 + p["c1"] * (x1 - u) + p["c2"] * (x1 - x2) - force
        r2 = p["m2"] * acc2 + p["c2"] * (x2 - x1)
    scale = max(p["F"], np.abs(p["c1"] * x1).max(), np.abs(p["m1"] * acc1).max())
    return r1, r2, scale


@pytest.mark.parametrize("model", ["absorber", "isolator"])
@pytest.mark.parametrize("omega", [0.3, 0.854, 1.7, 5.0])
@pytest.mark.parametrize("w0", [0.0, 0.002])
def test_stick_response_solves_stick_equations(model, omega, w0):
    p = dict(PARAMS[model], Omega=omega)
    period = 2 * np.pi / omega
    t = np.linspace(0.0, 3 * period, 301)
    y = stick_response(model, p, t, w0)
    assert y.shape == (301, 5)
    r1, r2, scale = _stick_residuals(model, p, y, t)
    assert np.abs(r1).max() <= 1e-12 * scale
    assert np.abs(r2).max() <= 1e-12 * scale
    # Kinematic constraint of the stuck element.
    if model == "absorber":
        np.testing.assert_allclose(y[:, 2] - y[:, 4], w0, rtol=0, atol=1e-12 * scale)
    else:
        np.testing.assert_array_equal(y[:, 4], w0)
    # Velocities: (v/Omega)^2 + (x - x(0))^2 = A^2 exactly, and v = dx/dt numerically.
    a1, a2 = stick_amplitudes(p)
    for xi, vi, amp in ((0, 1, a1), (2, 3, a2)):
        ident = (y[:, vi] / omega) ** 2 + (y[:, xi] - y[0, xi]) ** 2
        np.testing.assert_allclose(ident, amp**2, rtol=1e-12)
        h = 1e-6
        dx = (stick_response(model, p, t + h, w0) - stick_response(model, p, t - h, w0)) / (2 * h)
        np.testing.assert_allclose(dx[:, xi], y[:, vi], rtol=0, atol=1e-8 * abs(amp) * omega)


def test_stick_response_zero_offset_is_eq_a1_a2():
    """With w0 = 0 both dampers give x1 = A1 sin, x2 = A2 sin of Eqs. (A.1)-(A.2)."""
    t = np.linspace(0.0, 10.0, 50)
    a1, a2 = stick_amplitudes(ABSORBER)
    for model in ("absorber", "isolator"):
        y = stick_response(model, PARAMS[model], t)
        np.testing.assert_allclose(y[:, 0], a1 * np.sin(0.854 * t), rtol=1e-14, atol=0)
        np.testing.assert_allclose(y[:, 2], a2 * np.sin(0.854 * t), rtol=1e-14, atol=0)
    np.testing.assert_allclose(a2, a1 * 0.1 / (0.1 - 0.1 * 0.854**2), rtol=1e-14)


def test_stick_amplitudes_vectorised_and_antiresonance():
    omegas = np.array([[0.2, 0.5], [1.0, 3.0]])
    a1, a2 = stick_amplitudes(ABSORBER, omegas)
    assert a1.shape == a2.shape == (2, 2)
    for (i, j), om in np.ndenumerate(omegas):
        b1, b2 = stick_amplitudes(ABSORBER, om)
        assert b1 == a1[i, j]
        assert b2 == a2[i, j]
    # Antiresonance of the primary mass at sqrt(c2/m2) = 1 rad/s; static limit F/c1.
    a1_ar, _ = stick_amplitudes(ABSORBER, 1.0)
    assert abs(a1_ar) < 1e-15
    a1_0, a2_0 = stick_amplitudes(ABSORBER, 0.0)
    assert a1_0 == pytest.approx(0.01)
    assert a2_0 == pytest.approx(0.01)


def test_limit_amplitude_absorber_hand_value():
    # Exact rational arithmetic of Eq. (5) at Omega = 0.854, w0 = 0.01:
    om2 = Fraction(854, 1000) ** 2
    m2, c2, c3, R, w0 = Fraction(1, 10), Fraction(1, 10), 10, Fraction(1, 2), Fraction(1, 100)
    expected = abs((m2 * om2 - c2) / (m2 * om2 * c2)) * (R - (c2 + c3) * w0)
    # 0.0270684 / 0.00729316 = 3.7114776..., times 0.5 - 10.1 * 0.01 = 0.399:
    assert float(expected) == pytest.approx(1.48087956387, rel=1e-10)
    got = limit_amplitude("absorber", ABSORBER, 0.854, offset=0.01)
    assert got == pytest.approx(float(expected), rel=1e-14)
    assert limit_amplitude("absorber", ABSORBER, 0.854, offset=-0.01) == got
    # Default Omega is params["Omega"]; vanishes at the antiresonance sqrt(c2/m2) = 1.
    assert limit_amplitude("absorber", ABSORBER, offset=0.01) == got
    assert limit_amplitude("absorber", ABSORBER, 1.0) == 0.0


def test_limit_amplitude_isolator_constant():
    omegas = np.linspace(0.1, 3.0, 7)
    a_l = limit_amplitude("isolator", ISOLATOR, omegas, offset=-0.005)
    assert a_l.shape == omegas.shape
    np.testing.assert_allclose(a_l, (1.5 - 101 * 0.005) / 1.0, rtol=1e-15)  # 0.995 m
    assert limit_amplitude("isolator", ISOLATOR) == pytest.approx(1.5)


def test_limit_amplitude_is_sharp_for_in_phase_stick_force():
    """At A1 = A_L (w0 = 0) the stick force of the stick response peaks exactly at R."""
    for model in ("absorber", "isolator"):
        p = PARAMS[model]
        a1, _ = stick_amplitudes(p)
        # Scale the forcing so that |A1| equals A_L.
        scaled = dict(p, F=p["F"] * float(limit_amplitude(model, p)) / abs(float(a1)))
        t = np.linspace(0.0, 2 * np.pi / p["Omega"], 20001)
        y = stick_response(model, scaled, t)
        x1, x2, u = y[:, 0], y[:, 2], y[:, 4]
        if model == "absorber":
            h = p["c2"] * (u - x1) - p["c3"] * (x2 - u)
        else:
            h = p["c1"] * (x1 - u) - p["c3"] * u
        assert np.abs(h).max() == pytest.approx(p["R"], rel=1e-6)


@pytest.mark.parametrize(
    ("model", "offset"), [("absorber", 0.5 / 10.1 * 1.001), ("isolator", -1.5 / 101 * 1.001)]
)
def test_limit_amplitude_rejects_large_offset(model, offset):
    with pytest.raises(ValueError, match="offset"):
        limit_amplitude(model, PARAMS[model], offset=offset)


def test_bad_model_and_params():
    with pytest.raises(ValueError, match="model"):
        stick_response("damper", ABSORBER, [0.0])
    with pytest.raises(ValueError, match="model"):
        limit_amplitude("Absorber", ABSORBER)
    with pytest.raises(ValueError, match="missing"):
        stick_eigenfrequencies({"m1": 1.0})
    with pytest.raises(ValueError, match="m2"):
        slip_eigenfrequencies("absorber", dict(ABSORBER, m2=0.0))


def _generalized_eigenfrequencies(k: np.ndarray, m: np.ndarray) -> np.ndarray:
    lam = np.linalg.eigvals(np.linalg.solve(m, k))
    return np.sqrt(np.sort(lam.real))


def _condense(k3: np.ndarray) -> np.ndarray:
    """Statically condense the massless last coordinate (u) of a 3x3 stiffness matrix."""
    return k3[:2, :2] - np.outer(k3[:2, 2], k3[2, :2]) / k3[2, 2]


@pytest.mark.parametrize("p", [ABSORBER, ISOLATOR, dict(ABSORBER, m1=2.5, c1=3.0, c3=0.7)])
def test_eigenfrequencies_match_generalized_eigenproblem(p):
    m1, m2, c1, c2, c3 = (p[k] for k in ("m1", "m2", "c1", "c2", "c3"))
    mass = np.diag([m1, m2])
    # Stick: ground -c1- m1 -c2- m2 (for both dampers).
    k_stick = np.array([[c1 + c2, -c2], [-c2, c2]])
    # Slip, coordinates (x1, x2, u): friction force constant, so only springs remain.
    k_abs = np.array([[c1 + c2, 0.0, -c2], [0.0, c3, -c3], [-c2, -c3, c2 + c3]])
    k_iso = np.array([[c1 + c2, -c2, -c1], [-c2, c2, 0.0], [-c1, 0.0, c1 + c3]])
    np.testing.assert_allclose(
        stick_eigenfrequencies(p), _generalized_eigenfrequencies(k_stick, mass), rtol=1e-12
    )
    np.testing.assert_allclose(
        slip_eigenfrequencies("absorber", p),
        _generalized_eigenfrequencies(_condense(k_abs), mass),
        rtol=1e-12,
    )
    np.testing.assert_allclose(
        slip_eigenfrequencies("isolator", p),
        _generalized_eigenfrequencies(_condense(k_iso), mass),
        rtol=1e-12,
    )
    # The stick response is singular at the stick eigenfrequencies.
    w1, w2 = stick_eigenfrequencies(p)
    delta = [m1 * m2 * w**4 - (c1 * m2 + (m1 + m2) * c2) * w**2 + c1 * c2 for w in (w1, w2)]
    np.testing.assert_allclose(delta, 0.0, atol=1e-13 * (c1 * m2 + (m1 + m2) * c2) * w2**2)
