"""The failures that Newton's method, the continuation and their diagnostics recover from, and
only those (issue 29, item 3): each site that caught every exception now catches what can really
occur there. The intended failure (a slave solve that fails, a singular matrix, a failed run) is
still handled as before; a programming error (a TypeError) now propagates instead of becoming "no
result". The defect is injected by replacing the one function the site calls.
"""

import numpy as np
import pytest
from problems import forced_oscillator

import hybrid
import hybrid.continuation.forced as forced
import hybrid.continuation.special as special
import hybrid.orbits.newton as newton
from hybrid import Exact, HybridSystem, Mode, SolverOptions, periodic_orbit
from hybrid.core.errors import AlgebraicSolveError, GrazingSwitchError, IntegratorError, SimulationError
from hybrid.model.compiled import CompiledSystem
from hybrid.model.linear import fast_dynamics
from hybrid.orbits.shooter import Shooter

EXACT = SolverOptions(method=Exact())
NO_TRANSIENT = hybrid.ShootingOptions(transient_periods=0)


def _defect(*args, **kwargs):
    raise TypeError("a defect of the code: 'NoneType' object is not subscriptable")


def _no_slave_solution(*args, **kwargs):
    raise AlgebraicSolveError("mode `free`: Newton's method did not solve the algebraic equations")


@pytest.fixture(scope="module")
def oscillator():
    """The forced linear oscillator (m = 1, k = 4, c = 0.1): its compiled mode, a shooter on the
    exact flow and the section state of its periodic orbit at t0 = 0 (closed form)."""
    system, params, _, _ = forced_oscillator(k=4.0)
    X = params["F"] / (params["k"] - params["m"] * params["Omega"] ** 2 + 1j * params["c"] * params["Omega"])
    y0 = np.array([X.imag, (1j * params["Omega"] * X).imag])  # x = Im(X e^{i Omega t}) at t = 0
    return system, params, Shooter(system, params, EXACT), y0


# -- newton.py: the guess's projection ------------------------------------------------------------
def test_an_unsolvable_slave_equation_still_gives_a_failed_orbit_inconsistent_guess():
    # 0 = z^2 + 1 has no real root (its Jacobian 2z vanishes at the guess z = 0): a real
    # AlgebraicSolveError, reported as the result's reason, not raised
    system = HybridSystem(
        name="no_slave_root",
        variables=["x", "v", "z"],
        parameters=["Omega"],
        modes=[
            Mode(
                "free",
                derivatives={"x": "v", "v": "sin(Omega*t) - x - 0.1*v + 0*z"},
                algebraic={"z": "z**2 + 1"},
            )
        ],
        transitions=[],
        period="2*pi/Omega",
        initial_mode="free",
    )
    o = periodic_orbit(system, {"Omega": 1.3}, np.zeros(3), "free", settings=NO_TRANSIENT)
    assert not o.converged
    assert o.reason == "inconsistent-guess"
    assert o.message.startswith("guess is not consistent: mode `free`: the algebraic equations are singular")


def test_a_defect_in_the_guess_s_projection_propagates(oscillator, monkeypatch):
    system, params, _, y0 = oscillator
    monkeypatch.setattr(newton.NewtonMap, "project", _defect)
    with pytest.raises(TypeError, match="a defect of the code"):
        periodic_orbit(system, params, y0, "free", options=EXACT, settings=NO_TRANSIENT)


def test_the_orbit_itself_without_a_defect(oscillator):
    # the same call as above without the injected defect: the closed-form orbit (the fixture's y0)
    system, params, _, y0 = oscillator
    o = periodic_orbit(system, params, y0 + 0.1, "free", options=EXACT, settings=NO_TRANSIENT)
    assert o.converged, o.message
    np.testing.assert_allclose(o.x0, y0, rtol=1e-9, atol=1e-12)


# -- newton.py: the switch-time Newton's candidate ------------------------------------------------
def _candidate(oscillator, monkeypatch, project):
    """``_sequence_candidate`` from a point off the orbit, its sequence solve giving the closed-form
    orbit (so that only the projection decides), the projection replaced by ``project``."""
    system, params, sh, y0 = oscillator
    nw = newton.NewtonMap(sh, "free")
    y = y0 + 0.1
    tr = sh.run(y, "free", 0.0)
    monkeypatch.setattr(newton, "sequence_events", lambda *a: [])
    monkeypatch.setattr(newton, "solve_sequence", lambda *a: y0[nw.d].copy())
    if project is not None:
        monkeypatch.setattr(newton.NewtonMap, "project", project)
    return newton._sequence_candidate(sh, nw, tr, y, "free", 0.0, 8, 0.1, 1e-9)


def test_the_sequence_candidate_at_the_orbit_is_taken(oscillator, monkeypatch):
    got = _candidate(oscillator, monkeypatch, None)
    assert got is not None
    np.testing.assert_allclose(got[0], oscillator[3], rtol=0, atol=0)


def test_the_sequence_candidate_without_a_consistent_point_is_none(oscillator, monkeypatch):
    assert _candidate(oscillator, monkeypatch, _no_slave_solution) is None


def test_a_defect_in_the_sequence_candidate_s_projection_propagates(oscillator, monkeypatch):
    with pytest.raises(TypeError, match="a defect of the code"):
        _candidate(oscillator, monkeypatch, _defect)


# -- newton.py: the line search --------------------------------------------------------------------
def _line_search(oscillator, monkeypatch, project):
    """The line search along the step from ``y0 + 0.1`` to the closed-form orbit ``y0`` (the
    projection replaced by ``project``, counted), and the number of projections tried."""
    system, params, sh, y0 = oscillator
    nw = newton.NewtonMap(sh, "free")
    y = y0 + 0.1
    calls = []
    real = newton.NewtonMap.project

    def counted(self, t, yy):
        calls.append(t)
        return (project or real)(self, t, yy)

    monkeypatch.setattr(newton.NewtonMap, "project", counted)
    r0 = nw.residual(sh.run(y, "free", 0.0), y)
    step = y0[nw.d] - y[nw.d]
    found, best = newton._line_search(
        sh, nw, y, "free", 0.0, step, np.eye(2), None, float(np.linalg.norm(r0))
    )
    return found, best, len(calls)


def test_the_line_search_takes_the_full_step_to_the_orbit(oscillator, monkeypatch):
    found, best, n = _line_search(oscillator, monkeypatch, None)
    assert n == 1 and best is None
    y_new, _, lam = found
    assert lam == 1.0
    np.testing.assert_allclose(y_new, oscillator[3], rtol=0, atol=1e-15)


def test_the_line_search_halves_the_step_where_no_consistent_point_exists(oscillator, monkeypatch):
    # as before: each failed projection halves the step; none left: no point, nothing tried
    found, best, n = _line_search(oscillator, monkeypatch, _no_slave_solution)
    assert (found, best, n) == (None, None, newton.MAX_BACKTRACKS)


def test_a_defect_in_the_line_search_s_projection_propagates(oscillator, monkeypatch):
    with pytest.raises(TypeError, match="a defect of the code"):
        _line_search(oscillator, monkeypatch, _defect)


# -- forced.py: the tangent at a moved section -----------------------------------------------------
@pytest.fixture(scope="module")
def continuer(oscillator):
    system, params, _, y0 = oscillator
    c = forced.OrbitContinuer(
        system, params, "Omega", (1.6, 1.8), EXACT, hybrid.ContinuationOptions(samples_per_period=16)
    )
    o = periodic_orbit(system, params, y0, "free", options=EXACT, settings=NO_TRANSIENT)
    assert o.converged, o.message
    return c, forced.ContinuationPoint(o.x0.copy(), params["Omega"], "free", 0.0, orbit=o)


def test_the_tangent_at_a_moved_section_is_a_unit_vector(continuer):
    c, pt = continuer
    new = forced._rephase(c, pt, 1.0)
    assert new is not None and new.p == pt.p
    assert abs(float(np.linalg.norm(new.tangent)) - 1.0) < 1e-12
    assert new.tangent[-1] > 0  # the sense asked for (direction 1)


@pytest.mark.parametrize(
    "failure",
    [
        np.linalg.LinAlgError("SVD did not converge"),
        GrazingSwitchError("a switch grazes"),
        IntegratorError("IDA failed in the variational equations"),
        SimulationError("the run failed"),
        ZeroDivisionError("float division by zero"),
    ],
    ids=type,
)
def test_a_failed_tangent_at_a_moved_section_is_still_none(continuer, monkeypatch, failure):
    def tangent(*args, **kwargs):
        raise failure

    monkeypatch.setattr(forced.OrbitContinuer, "tangent", tangent)
    assert forced._rephase(*continuer, 1.0) is None


def test_a_defect_in_the_tangent_at_a_moved_section_propagates(continuer, monkeypatch):
    monkeypatch.setattr(forced.OrbitContinuer, "tangent", _defect)
    with pytest.raises(TypeError, match="a defect of the code"):
        forced._rephase(*continuer, 1.0)


# -- special.py and linear.py: two diagnostics -----------------------------------------------------
class _Probe:
    """A probe whose orbit, made on first use, fails with ``exc``."""

    def __init__(self, exc: Exception):
        self.exc = exc

    @property
    def orbit(self):
        raise self.exc


def test_a_probe_whose_orbit_fails_gives_the_fallback_rounding_margin(continuer):
    _, pt = continuer
    p = 1.7
    assert special.rounding_margin((pt, _Probe(SimulationError("the run failed"))), p) == (
        special.EXACT_ROUNDING_FALLBACK * p
    )
    # with both orbits there: eps |p| cond x safety, cond the orbit's own
    want = special.EXACT_ROUNDING_SAFETY * np.finfo(float).eps * p * max(pt.orbit.condition, 1.0)
    assert special.rounding_margin((pt, pt), p) == want


def test_a_defect_in_a_probe_s_orbit_propagates_from_the_rounding_margin(continuer):
    with pytest.raises(TypeError, match="a defect of the code"):
        special.rounding_margin((continuer[1], _Probe(TypeError("a defect of the code"))), 1.7)


def test_the_slow_run_diagnosis_names_the_fastest_eigenvalue(oscillator):
    system, params, _, y0 = oscillator
    cm = CompiledSystem(system, params).modes[0]
    msg = fast_dynamics(cm, 0.0, y0, set(), period=None, per_eval=1e-6, max_step=1.0)
    # x'' + 0.1 x' + 4 x: eigenvalues of modulus sqrt(k/m) = 2
    assert "an eigenvalue of modulus 2 1/s" in msg


def test_the_slow_run_diagnosis_without_a_consistent_point_is_left_out(oscillator, monkeypatch):
    system, params, _, y0 = oscillator
    cm = CompiledSystem(system, params).modes[0]
    base = fast_dynamics(cm, 0.0, y0, set(), period=None, per_eval=1e-6, max_step=1.0).split(":")[0]
    monkeypatch.setattr(cm, "solve_algebraic", _no_slave_solution)
    assert fast_dynamics(cm, 0.0, y0, set(), period=None, per_eval=1e-6, max_step=1.0) == base
    monkeypatch.setattr(cm, "solve_algebraic", _defect)
    with pytest.raises(TypeError, match="a defect of the code"):
        fast_dynamics(cm, 0.0, y0, set(), period=None, per_eval=1e-6, max_step=1.0)
