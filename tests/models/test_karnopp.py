"""Tests of the Karnopp reference model (hybrid_models.karnopp)."""

from __future__ import annotations

import math

import numpy as np
import pytest

import hybrid_models
from hybrid_models.karnopp import (
    KarnoppResult,
    mechanical_energy,
    rhs,
    simulate_karnopp,
)
from hybrid_models.linear import stick_response

# The paper's standard sets, from the model files' presets (checked against the paper in test_dampers.py).
ABSORBER = hybrid_models.absorber().preset("standard")
ISOLATOR = hybrid_models.isolator().preset("standard")
PARAMS = {"absorber": ABSORBER, "isolator": ISOLATOR}
# Large initial displacements put the standard dampers into stick-slip despite F = 0.01 N.
Y0_STICK_SLIP = {"absorber": [5.0, 0.0, 5.0, 0.0, 5.0], "isolator": [2.0, 0.0, 2.0, 0.0, 0.0]}
PERIOD = 2 * math.pi / 0.854


@pytest.mark.parametrize("model", ["absorber", "isolator"])
@pytest.mark.parametrize("w0", [0.0, 0.3])
def test_never_slipping_matches_stick_response(model, w0):
    p = dict(PARAMS[model], R=1e6)
    t = np.linspace(0.0, 5 * PERIOD, 401)
    ref = stick_response(model, p, t, w0)
    res = simulate_karnopp(model, p, (0.0, 5 * PERIOD), ref[0], rtol=1e-11, atol=1e-13, t_eval=t)
    assert res.success
    assert res.sticking.all()
    np.testing.assert_array_equal(res.D, 0.0)
    scale = np.abs(ref).max(axis=0)  # per-component amplitude (~30 m at this resonance)
    assert np.all(np.abs(res.y - ref) <= 1e-7 * scale)
    # Work of the excitation equals the change of mechanical energy when nothing slips.
    energy = mechanical_energy(model, p, res.y)
    np.testing.assert_allclose(res.W, energy - energy[0], rtol=0, atol=1e-7 * energy.max())


@pytest.fixture(scope="module", params=["absorber", "isolator"])
def stick_slip_run(request) -> tuple[str, KarnoppResult]:
    model = request.param
    res = simulate_karnopp(
        model, PARAMS[model], (0.0, 20 * PERIOD), Y0_STICK_SLIP[model], rtol=1e-10, atol=1e-12
    )
    return model, res


def test_energy_balance_stick_slip(stick_slip_run):
    """W - D = E(t) - E(0) holds exactly for the ODE; only integration error remains.

    The balance error scales like rtol (measured ~3e-9 E(0) at rtol = 1e-10 and ~3e-7 E(0) at
    the default rtol = 1e-8), so 1e-7 E(0) leaves a margin of ~30. A sign error in the
    dissipation or in the power of the excitation changes the balance by 2 D or 2 |W|, which
    are 0.08 E(0) or more here.
    """
    model, res = stick_slip_run
    p = PARAMS[model]
    assert res.success
    energy = mechanical_energy(model, p, res.y)
    balance = res.W - res.D - (energy - energy[0])
    assert np.abs(balance).max() <= 1e-7 * energy[0]
    # The run really is stick-slip, dissipates, and the dissipation never decreases.
    assert res.sticking.any()
    assert (~res.sticking).any()
    assert res.D[-1] > 0.04 * energy[0]
    assert np.all(np.diff(res.D) >= -1e-15)
    # Slipping happens at the breakaway force (overshoot limited by the solver tolerance).
    slipping = ~res.sticking
    np.testing.assert_allclose(np.abs(res.H[slipping]), p["R"], rtol=1e-5)
    assert np.all(np.sign(res.H[slipping]) * res.v_r[slipping] > 0)


def test_energy_balance_default_tolerances():
    for model in ("absorber", "isolator"):
        p = PARAMS[model]
        res = simulate_karnopp(model, p, (0.0, 20 * PERIOD), Y0_STICK_SLIP[model])
        energy = mechanical_energy(model, p, res.y)
        balance = res.W - res.D - (energy - energy[0])
        assert np.abs(balance).max() <= 1e-5 * energy[0]


@pytest.mark.parametrize("model", ["absorber", "isolator"])
def test_rhs_slip_keeps_friction_force_constant(model):
    """In slip dH/dt = 0 and D' = H v_r; in stick the element does not move."""
    p = PARAMS[model]
    f = rhs(model, p, 1e-6)
    c1, c2, c3, R = p["c1"], p["c2"], p["c3"], p["R"]
    rng = np.random.default_rng(1)
    for _ in range(20):
        x1, v1, x2, v2 = rng.normal(size=4)
        if model == "absorber":
            # Choose u with H = +-R (slightly beyond, against rounding); then slipping requires
            # sign(H) (v2 - v1) > 0.
            sgn = math.copysign(1.0, v2 - v1)
            u = (sgn * R * (1 + 1e-12) + c2 * x1 + c3 * x2) / (c2 + c3)
            d = f(0.3, np.array([x1, v1, x2, v2, u, 0.0, 0.0]))
            dh = c2 * (d[4] - d[0]) - c3 * (d[2] - d[4])
            vr = c2 * (v2 - v1) / (c2 + c3)
            assert d[4] == pytest.approx((c2 * v1 + c3 * v2) / (c2 + c3), rel=1e-14)
        else:
            sgn = math.copysign(1.0, v1)
            u = (c1 * x1 - sgn * R * (1 + 1e-12)) / (c1 + c3)
            d = f(0.3, np.array([x1, v1, x2, v2, u, 0.0, 0.0]))
            dh = c1 * (d[0] - d[4]) - c3 * d[4]
            vr = c1 * v1 / (c1 + c3)
        assert dh == pytest.approx(0.0, abs=1e-14)
        assert d[6] == pytest.approx(sgn * R * vr, rel=1e-11)
        assert d[5] == pytest.approx(p["F"] * math.sin(p["Omega"] * 0.3) * v1, rel=1e-14)
        # Same state but with a smaller (stuck) force: no dissipation, u follows the stick rule.
        u_stick = u - 0.5 * sgn * R / (c2 + c3) if model == "absorber" else u + 0.5 * sgn * R / (c1 + c3)
        d = f(0.3, np.array([x1, v1, x2, v2, u_stick, 0.0, 0.0]))
        assert d[6] == 0.0
        assert d[4] == (v2 if model == "absorber" else 0.0)


def test_mechanical_energy_shapes_and_values():
    y = np.array([1.0, 2.0, 3.0, 4.0, 0.5])
    e_abs = 0.5 * (1 * 4 + 0.1 * 16) + 0.5 * (1 * 1 + 0.1 * 0.25 + 10 * 6.25)
    e_iso = 0.5 * (1 * 4 + 0.1 * 16) + 0.5 * (1 * 0.25 + 100 * 0.25 + 0.1 * 4)
    assert mechanical_energy("absorber", ABSORBER, y) == pytest.approx(e_abs, rel=1e-15)
    assert mechanical_energy("isolator", ISOLATOR, y) == pytest.approx(e_iso, rel=1e-15)
    stacked = mechanical_energy("absorber", ABSORBER, np.stack([y, 2 * y, y]))
    assert stacked.shape == (3,)
    np.testing.assert_allclose(stacked, [e_abs, 4 * e_abs, e_abs], rtol=1e-15)


def test_result_layout():
    t = np.linspace(0.0, PERIOD, 11)
    res = simulate_karnopp("absorber", ABSORBER, (0.0, PERIOD), Y0_STICK_SLIP["absorber"], t_eval=t)
    assert res.t.shape == (11,)
    assert res.y.shape == (11, 5)
    for arr in (res.W, res.D, res.H, res.v_r, res.sticking):
        assert arr.shape == (11,)
    assert res.sticking.dtype == np.bool_
    assert res.W[0] == 0.0
    assert res.D[0] == 0.0
    assert res.nfev > 0
    assert isinstance(res.message, str)
    with pytest.raises(AttributeError):
        res.nfev = 0  # frozen


@pytest.mark.parametrize("bad", ["damper", "Absorber", ""])
def test_bad_model(bad):
    with pytest.raises(ValueError, match="model must be one of"):
        simulate_karnopp(bad, ABSORBER, (0.0, 1.0), np.zeros(5))
    with pytest.raises(ValueError, match="model must be one of"):
        rhs(bad, ABSORBER, 1e-6)
    with pytest.raises(ValueError, match="model must be one of"):
        mechanical_energy(bad, ABSORBER, np.zeros(5))


@pytest.mark.parametrize("nu", [0.0, -1e-6, math.nan, math.inf])
def test_bad_nu(nu):
    with pytest.raises(ValueError, match="nu must be"):
        simulate_karnopp("isolator", ISOLATOR, (0.0, 1.0), np.zeros(5), nu=nu)
    with pytest.raises(ValueError, match="nu must be"):
        rhs("absorber", ABSORBER, nu)


def test_bad_state_and_params():
    with pytest.raises(ValueError, match="y0"):
        simulate_karnopp("absorber", ABSORBER, (0.0, 1.0), np.zeros(7))
    with pytest.raises(ValueError, match="missing"):
        simulate_karnopp("absorber", {"m1": 1.0}, (0.0, 1.0), np.zeros(5))
    with pytest.raises(ValueError, match="y must"):
        mechanical_energy("absorber", ABSORBER, np.zeros((2, 4)))
