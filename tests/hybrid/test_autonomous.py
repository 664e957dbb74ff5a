"""Autonomous periodic orbits, equilibria and Hopf points against closed forms (issue 11).

Engine tests on the Stuart-Landau oscillator, whose limit cycle r = 1 has period 2 pi / w and
the nontrivial multiplier exp(-2 T) (BifurcationKit's test), and on a slave-variable variant.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import hybrid
from hybrid import (
    IDA,
    HybridSystem,
    Mode,
    ModelError,
    SolverOptions,
    autonomous_orbit,
    equilibrium,
    periodic_orbit,
    system_from_dict,
)
from hybrid.orbits.flowmap import FlowMap

TIGHT = SolverOptions(method=IDA(rtol=1e-12, atol=1e-14))


def stuart_landau(period_guess: str | None = "2*pi/w", section: bool = False) -> HybridSystem:
    """r' = r (a - r^2), theta' = w in Cartesian form; with ``section`` a switch on y = 0 upwards."""
    modes = [
        Mode("one", derivatives={"x": "a*x - w*y - x*(x**2 + y**2)", "y": "w*x + a*y - y*(x**2 + y**2)"})
    ]
    transitions = []
    if section:
        modes.append(
            Mode("two", derivatives={"x": "a*x - w*y - x*(x**2 + y**2)", "y": "w*x + a*y - y*(x**2 + y**2)"})
        )
        from hybrid import Transition

        transitions = [
            Transition("one", "two", "y", direction=1, name="up"),
            Transition("two", "one", "y", direction=-1, name="down"),
        ]
    orbit = {"period_guess": period_guess} if period_guess else {}
    if section:
        orbit["section"] = "up"
    return HybridSystem(
        name="stuart_landau",
        variables=["x", "y"],
        parameters=["a", "w"],
        modes=modes,
        transitions=transitions,
        initial_mode="one",
        orbit=orbit,
    )


@pytest.mark.parametrize("section", [False, True])
def test_stuart_landau_period_and_multipliers(section):
    sys_ = stuart_landau(section=section)
    a, w = 1.0, 2.5
    orbit = autonomous_orbit(
        sys_,
        {"a": a, "w": w},
        {"x": 0.3, "y": 0.0},
        period=2.0,
        options=TIGHT,
        settings=hybrid.ShootingOptions(newton=hybrid.NewtonOptions(tol=1e-11)),
    )
    assert orbit.converged, orbit.message
    T = 2 * math.pi / w
    assert abs(orbit.period - T) <= 1e-9 * T
    kinds = orbit.multiplier_kinds
    triv = orbit.multipliers[kinds.index("trivial")]
    assert abs(triv - 1.0) <= 1e-8
    other = orbit.multipliers[[k == "floquet" for k in kinds]]
    assert other.size == 1
    assert abs(other[0] - math.exp(-2 * a * T)) <= 1e-8
    assert orbit.stability == "stable"
    # the cycle is the unit circle: half peak-to-peak of x is sqrt(a)
    assert abs(orbit.half_peak_to_peak["x"] - math.sqrt(a)) <= 1e-9


def test_monodromy_matches_finite_differences():
    sys_ = stuart_landau()
    p = {"a": 1.0, "w": 2.5}
    fm = FlowMap(sys_, p, TIGHT, 2.5)
    y0, T = np.array([0.7, 0.2]), 2.1
    J = fm.timed(y0, "one", T).jacobian
    h = 1e-6
    fd = np.column_stack(
        [
            (
                fm.timed(y0 + h * e, "one", T, derivatives=False).end
                - fm.timed(y0 - h * e, "one", T, derivatives=False).end
            )
            / (2 * h)
            for e in np.eye(2)
        ]
    )
    assert np.max(np.abs(J - fd)) <= 1e-7


def test_periodic_orbit_dispatches_to_autonomous():
    orbit = periodic_orbit(stuart_landau(), {"a": 1.0, "w": 2.0}, {"x": 0.5, "y": 0.0}, options=TIGHT)
    assert orbit.converged, orbit.message
    assert abs(orbit.period - math.pi) <= 1e-9 * math.pi


def test_equilibrium_eigenvalues_of_the_origin():
    eq = equilibrium(stuart_landau(), {"a": -0.5, "w": 2.0}, "one", {"x": 0.1, "y": -0.1})
    assert eq.converged, eq.message
    assert np.max(np.abs(eq.x)) <= 1e-12
    ev = sorted(eq.eigenvalues, key=lambda z: z.imag)
    assert np.allclose(ev, [-0.5 - 2j, -0.5 + 2j], rtol=0, atol=1e-12)
    assert eq.stability == "stable"


def test_bad_input_is_refused_before_any_run():
    sys_ = stuart_landau(period_guess=None)
    with pytest.raises(ValueError, match="period_guess"):
        autonomous_orbit(sys_, {"a": 1.0, "w": 2.0})
    with pytest.raises(ValueError, match="`phase` must be"):
        autonomous_orbit(sys_, {"a": 1.0, "w": 2.0}, period=3.0, phase="nowhere")
    with pytest.raises(ValueError, match="`period` must be"):
        autonomous_orbit(sys_, {"a": 1.0, "w": 2.0}, period=-1.0)
    forced = HybridSystem(
        name="f",
        variables=["x"],
        parameters=["w"],
        modes=[Mode("m", derivatives={"x": "cos(w*t)"})],
        transitions=[],
        period="2*pi/w",
        initial_mode="m",
    )
    with pytest.raises(ValueError, match="periodically forced"):
        autonomous_orbit(forced, {"w": 1.0})


def test_orbit_hints_are_validated():
    base = {
        "model": {"name": "h", "initial_mode": "m"},
        "variables": {"x": {}},
        "parameters": {"a": {}},
        "equations": {"x": "-a*x"},
        "modes": {"m": {}},
    }
    with pytest.raises(ModelError, match="is not a transition"):
        system_from_dict({**base, "orbit": {"section": "nope"}})
    with pytest.raises(ModelError, match="parameters only"):
        system_from_dict({**base, "orbit": {"period_guess": "x + a"}})
