"""Periodic orbits of the paper's dampers: stick-slip monodromy, stability, energy, pure stick.

The absorber at ``Omega = 0.854`` (standard preset) is a stick-slip orbit with weakly damped
multipliers (``|mu| ~ 0.995``); its saltation monodromy is checked against central
differences of the period map, its stability against a long simulation. Pure-stick orbits
form a family (the stuck element's offset is free) and must equal the linear closed forms.
"""

from __future__ import annotations

import numpy as np
import pytest

import hybrid
import hybrid_models
from hybrid import IDA, SolverOptions, periodic_orbit, simulate
from hybrid_models.linear import stick_amplitudes

#: Tolerances of the absorber's orbit and of the finite-difference period maps.
TIGHT = SolverOptions(method=IDA(rtol=1e-12, atol=1e-14))


def state_indices(orbit) -> list[int]:
    names = orbit.system.variable_names
    return [names.index(n) for n in orbit.state_names]


def period_map(orbit, y: np.ndarray) -> tuple[np.ndarray, str]:
    """``P(y)`` over ``orbit.state_names`` by :func:`hybrid.simulate` from the orbit's section."""
    idx = state_indices(orbit)
    x = orbit.x0.copy()
    x[idx] = y
    t0, T = orbit.t0, orbit.period
    tr = simulate(
        orbit.system,
        orbit.params,
        (t0, t0 + T),
        x,
        orbit.mode0,
        t_eval=[t0, t0 + T],
        include_events=False,
        options=TIGHT,
    )
    return tr.y_final[idx], tr.mode_final


@pytest.fixture(scope="module")
def absorber_orbit():
    system = hybrid_models.absorber()
    return periodic_orbit(system, system.preset("standard", Omega=0.854), options=TIGHT)


# ----------------------------------------------------------------------------
# Stick-slip absorber at Omega = 0.854
# ----------------------------------------------------------------------------
def test_absorber_orbit_is_stick_slip_and_weakly_damped(absorber_orbit):
    o = absorber_orbit
    assert o.converged, o.message
    assert {"stick", "slip+", "slip-"} <= set(o.mode_sequence)
    assert 0.0 < o.mode_fractions["stick"] < 1.0
    assert not o.family
    assert sum(o.mode_fractions.values()) == pytest.approx(1.0, rel=1e-12)
    assert o.stability == "stable"
    mu_max = float(np.max(np.abs(o.floquet_multipliers)))
    assert 0.99 < mu_max < 1.0


def test_absorber_monodromy_matches_finite_differences(absorber_orbit):
    o = absorber_orbit
    idx = state_indices(o)
    y0 = o.x0[idx]
    slaves = o.system.mode(o.mode0).algebraic
    cols = [j for j, n in enumerate(o.state_names) if n not in slaves]
    assert len(cols) == 5  # the section is in stick: u is differential there
    h = 1e-3 * float(np.max(np.abs(y0)))

    def central(j: int, step: float) -> np.ndarray:
        e = np.zeros(y0.size)
        e[j] = step
        (fp, mp), (fm, mm) = period_map(o, y0 + e), period_map(o, y0 - e)
        assert mp == mm == o.mode0
        return (fp - fm) / (2.0 * step)

    J = np.zeros_like(o.monodromy)
    for j in cols:
        J[:, j] = (4.0 * central(j, 0.5 * h) - central(j, h)) / 3.0  # Richardson, O(h^4)
    M = o.monodromy
    err = np.max(np.abs(J[:, cols] - M[:, cols])) / np.max(np.abs(M))
    assert err <= 1e-6


def test_absorber_energy_balance(absorber_orbit):
    e = absorber_orbit.energy
    assert e["input"] > 0
    assert e["dissipated"] > 0
    assert abs(e["relative_residual"]) <= 1e-8


@pytest.mark.slow
def test_absorber_perturbation_decays_as_the_multipliers_predict(absorber_orbit):
    o = absorber_orbit
    idx = state_indices(o)
    T, t0 = o.period, o.t0
    delta = np.zeros(len(idx))
    delta[o.state_names.index("x1")] = 1e-4
    x = o.x0.copy()
    x[idx] += delta
    checkpoints = np.array([0, 50, 100, 150, 200, 250, 300])
    tr = simulate(
        o.system,
        o.params,
        (t0, t0 + 300 * T),
        x,
        o.mode0,
        t_eval=t0 + checkpoints * T,
        include_events=False,
        options=hybrid.ORBIT_OPTIONS,
    )
    assert tr.success, tr.message
    assert tr.t.size == checkpoints.size
    dev = np.max(np.abs(tr.y[:, idx] - o.x0[idx]), axis=1)
    # Linear prediction by the monodromy: M^N delta. Measured within 16 %: the perturbation is
    # 1e-5 of max |x0| and 300 periods of integration error (rtol 1e-10) add up.
    pred = np.array(
        [np.max(np.abs(np.linalg.matrix_power(o.monodromy, int(n)) @ delta)) for n in checkpoints]
    )
    assert np.all(np.abs(dev / pred - 1.0) <= 0.25)
    # And the decay rate is |mu_max|^N (to the factor of the eigenvector geometry).
    mu_max = float(np.max(np.abs(o.floquet_multipliers)))
    ratio = dev / (dev[0] * mu_max**checkpoints)
    assert np.all((ratio > 0.3) & (ratio < 5.0))
    assert dev[-1] < 0.5 * dev[0]


# ----------------------------------------------------------------------------
# Pure stick: a family of linear orbits
# ----------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("model", "Omega", "gauge"),
    [
        ("absorber", 0.5, "x2 - u"),
        ("absorber", 1.3, "x2 - u"),
        ("isolator", 0.5, "u"),
        ("isolator", 1.3, "u"),
    ],
)
def test_pure_stick_orbit_is_the_linear_closed_form(model, Omega, gauge):
    system = hybrid_models.BUILTIN[model]()
    params = system.preset("standard", Omega=Omega)
    o = periodic_orbit(system, params)
    assert o.converged, o.message
    assert o.mode_sequence == ("stick",)
    assert o.transitions_per_period == 0
    assert o.stability == "neutral"
    assert o.stable is None
    assert o.family
    assert system.orbit["gauge"] == gauge
    g = o.state("x2") - o.state("u") if model == "absorber" else o.state("u")
    assert g == pytest.approx(0.0, abs=1e-12)
    a1, a2 = stick_amplitudes(params)
    assert abs(o.amplitude["x1"] - abs(a1)) <= 1e-7 * abs(a1)
    assert abs(o.amplitude["x2"] - abs(a2)) <= 1e-7 * abs(a2)
    kinds = list(o.multiplier_kinds)
    assert kinds.count("neutral") == 1
    assert abs(o.multipliers[kinds.index("neutral")] - 1.0) <= 1e-8
