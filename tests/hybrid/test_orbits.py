"""Periodic orbits, monodromy and continuation of the engine against independent references.

The references (``orbit_problems.py``) are computed without the engine: closed forms, exact
piecewise solutions and solve_ivp. The saltation monodromy is also checked against central
differences of the period map evaluated by :func:`hybrid.simulate`.
"""

from __future__ import annotations

import math

import numpy as np
import orbit_problems as op
import pytest

import hybrid
from hybrid import IDA, SolverOptions, continue_orbits, periodic_orbit, simulate
from hybrid.engine.eventloop import Run
from hybrid.engine.variational import Sensitivity

#: Tolerances of the finite-difference period maps (tighter than the orbit's own runs).
FD_OPTIONS = SolverOptions(method=IDA(rtol=1e-12, atol=1e-14))


# ----------------------------------------------------------------------------
# Helpers
# ----------------------------------------------------------------------------
def state_indices(orbit) -> list[int]:
    """Positions of ``orbit.state_names`` in ``system.variable_names``."""
    names = orbit.system.variable_names
    return [names.index(n) for n in orbit.state_names]


def differential_columns(orbit) -> list[int]:
    """Columns of the monodromy that are free at the section (not slave variables of ``mode0``)."""
    slaves = orbit.system.mode(orbit.mode0).algebraic
    return [j for j, n in enumerate(orbit.state_names) if n not in slaves]


def period_map(orbit, y: np.ndarray, options: SolverOptions = FD_OPTIONS) -> tuple[np.ndarray, str]:
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
        options=options,
    )
    return tr.y_final[idx], tr.mode_final


def fd_monodromy(orbit, rel_step: float) -> tuple[np.ndarray, list[int]]:
    """Central differences of the period map, steps ``h`` and ``h/2``, Richardson-extrapolated.

    The step of every column is ``rel_step * max |y|`` (the orbit's size). Returns the matrix
    (columns of slave variables left 0) and the differentiated columns.
    """
    idx = state_indices(orbit)
    y0 = orbit.x0[idx]
    cols = differential_columns(orbit)
    h = rel_step * float(np.max(np.abs(y0)))
    J = np.zeros((len(idx), len(idx)))

    def central(j: int, step: float) -> np.ndarray:
        e = np.zeros(len(idx))
        e[j] = step
        (fp, mp), (fm, mm) = period_map(orbit, y0 + e), period_map(orbit, y0 - e)
        assert mp == mm == orbit.mode0, "a finite-difference run left the orbit's mode sequence"
        return (fp - fm) / (2.0 * step)

    for j in cols:
        J[:, j] = (4.0 * central(j, 0.5 * h) - central(j, h)) / 3.0
    return J, cols


def fd_error(orbit, rel_step: float) -> float:
    """Max-norm error of the monodromy relative to its max-norm (differentiated columns)."""
    J, cols = fd_monodromy(orbit, rel_step)
    M = orbit.monodromy
    return float(np.max(np.abs(J[:, cols] - M[:, cols])) / np.max(np.abs(M)))


def rel(a, b) -> float:
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    return float(np.max(np.abs(a - b)) / np.max(np.abs(b)))


# ----------------------------------------------------------------------------
# Fixtures
# ----------------------------------------------------------------------------
@pytest.fixture(scope="module")
def friction():
    return op.friction_oscillator()


@pytest.fixture(scope="module")
def friction_orbit(friction):
    system, params, _ = friction
    return periodic_orbit(system, params)


@pytest.fixture(scope="module")
def impact():
    return op.impact_oscillator()


@pytest.fixture(scope="module")
def impact_orbit(impact):
    system, params, _ = impact
    return periodic_orbit(system, params)


@pytest.fixture(scope="module")
def duffing():
    return op.duffing()


@pytest.fixture(scope="module")
def duffing_branch(duffing):
    system, params, _ = duffing
    return continue_orbits(
        system,
        params,
        "Omega",
        (1.0, 1.4),
        options=SolverOptions(method=IDA(rtol=1e-9, atol=1e-11)),
        settings=hybrid.ContinuationOptions(ds=0.1, ds_max=0.5, samples_per_period=32, transient_periods=5),
    )


# ----------------------------------------------------------------------------
# 1. Linear forced systems: closed forms
# ----------------------------------------------------------------------------
@pytest.mark.parametrize("problem", [op.forced_linear_2dof, op.forced_linear_2dof_slave])
def test_linear_orbit_and_multipliers_match_the_closed_form(problem):
    system, params, ref = problem()
    # From rest at the reference's section (t0 = 0): one Newton step on a linear map.
    orbit = periodic_orbit(
        system, params, None, ref.mode0, t0=0.0, settings=hybrid.ShootingOptions(transient_periods=0)
    )
    assert orbit.converged
    assert orbit.t0 == 0.0
    assert orbit.mode0 == ref.mode0
    assert orbit.iterations >= 1
    assert rel(orbit.x0, ref.x0) <= 1e-8
    n = len(ref.state_names)
    assert orbit.state_names[:n] == ref.state_names
    kinds = np.array(orbit.multiplier_kinds)
    assert list(kinds[:n]) == ["floquet"] * n
    assert op.multiplier_distance(orbit.multipliers[:n], ref.multipliers) <= 1e-7
    assert op.multiplier_distance(orbit.floquet_multipliers, ref.multipliers) <= 1e-7
    assert rel(orbit.monodromy[:n, :n], ref.monodromy) <= 1e-7
    assert orbit.stability == ref.stability == "stable"
    assert not orbit.family
    if problem is op.forced_linear_2dof_slave:
        # u is a slave variable: its multiplier is a structural zero.
        assert orbit.state_names == (*ref.state_names, "u")
        assert list(kinds[n:]) == ["structural"]
        assert orbit.multipliers[n] == 0
    else:
        assert orbit.state_names == ref.state_names


# ----------------------------------------------------------------------------
# 2. Saltation monodromy vs finite differences of the period map
# ----------------------------------------------------------------------------
def test_friction_monodromy_matches_finite_differences(friction_orbit):
    orbit = friction_orbit
    assert orbit.converged, orbit.message
    assert orbit.stability == "stable"
    assert {"stick", "slip+", "slip-"} <= set(orbit.mode_sequence)
    assert fd_error(orbit, 1e-3) <= 1e-6


def test_impact_monodromy_matches_finite_differences(impact, impact_orbit):
    _, params, ref = impact
    orbit = impact_orbit
    assert orbit.converged, orbit.message
    assert orbit.transitions_per_period == 1
    assert fd_error(orbit, 1e-3) <= 1e-6
    # The impact's saltation: det M = r^2 exp(-c T/m) exactly.
    det = float(np.linalg.det(orbit.monodromy))
    assert abs(det - ref.details["det_monodromy"]) <= 1e-8 * abs(ref.details["det_monodromy"])
    assert op.multiplier_distance(orbit.multipliers, ref.multipliers) <= 1e-7


# ----------------------------------------------------------------------------
# 3. Orbits vs long simulations and the reference section
# ----------------------------------------------------------------------------
def test_friction_orbit_attracts_a_perturbed_simulation(friction, friction_orbit):
    system, params, _ = friction
    orbit = friction_orbit
    T, t0 = orbit.period, orbit.t0
    idx = state_indices(orbit)
    x = orbit.x0.copy()
    x[idx] += np.array([0.05, -0.03])
    tr = simulate(
        system,
        params,
        (t0, t0 + 60 * T),
        x,
        orbit.mode0,
        t_eval=[t0, t0 + 60 * T],
        options=hybrid.ORBIT_OPTIONS,
    )
    assert tr.mode_final == orbit.mode0
    assert np.max(np.abs(tr.y_final[idx] - orbit.x0[idx])) <= 1e-8


def test_friction_orbit_at_the_reference_section(friction):
    system, params, ref = friction
    # Section t0 = 0 in mid-slip, from a perturbed guess, no transient.
    guess = ref.x0 + np.array([2e-3, -1e-3, 0.0, 0.0, 0.0])
    orbit = periodic_orbit(
        system, params, guess, ref.mode0, t0=0.0, settings=hybrid.ShootingOptions(transient_periods=0)
    )
    assert orbit.converged
    assert orbit.t0 == 0.0
    assert orbit.iterations >= 1
    assert np.max(np.abs(orbit.x0[:2] - ref.x0[:2])) <= 1e-8
    assert np.max(np.abs(orbit.monodromy - ref.monodromy)) <= 1e-7
    assert op.multiplier_distance(orbit.multipliers, ref.multipliers) <= 1e-7
    assert orbit.stability == ref.stability == "stable"
    assert orbit.mode_sequence == ref.mode_sequence


def test_impact_orbit_at_the_reference_section(impact):
    system, params, ref = impact
    guess = ref.x0 + np.array([1e-3, 1e-3, 0.0, 0.0])
    orbit = periodic_orbit(
        system, params, guess, ref.mode0, t0=0.0, settings=hybrid.ShootingOptions(transient_periods=0)
    )
    assert orbit.converged
    assert orbit.iterations >= 1
    assert np.max(np.abs(orbit.x0[:2] - ref.x0[:2])) <= 1e-8
    assert np.max(np.abs(orbit.monodromy - ref.monodromy)) <= 1e-7
    (t_impact,) = orbit.switch_times
    assert abs(t_impact - ref.details["t_impact"]) <= 1e-8
    # W - D is the impact loss (a jump, outside the quadratures).
    assert abs(orbit.energy["residual"] - ref.details["impact_loss"]) <= 1e-8


# ----------------------------------------------------------------------------
# 4. Energy balance
# ----------------------------------------------------------------------------
def test_friction_energy_balance(friction, friction_orbit):
    _, _, ref = friction
    e = friction_orbit.energy
    assert abs(e["relative_residual"]) <= 1e-8
    assert abs(e["input"] - ref.increments["W"]) <= 1e-8 * ref.increments["W"]
    assert abs(e["dissipated"] - ref.increments["D"]) <= 1e-8 * ref.increments["D"]


# ----------------------------------------------------------------------------
# 5. Continuation through folds and over the stick boundary
# ----------------------------------------------------------------------------
@pytest.mark.slow
def test_duffing_continuation_locates_both_folds(duffing, duffing_branch):
    _, _, ref = duffing
    br = duffing_branch
    assert br.status == "completed", br.message
    assert br.values[0] == 1.0
    assert br.values[-1] >= 1.4
    folds = [s for s in br.special if s.kind == "fold"]
    assert len(folds) == 2
    # Upper fold first (the resonant branch turns back), then the lower one.
    # The reference band is right to ~1e-12. This branch runs IDA at rtol 1e-9, which moves the zero
    # of the fold's test function by ~1e-8 (measured 1.4e-8 and 4.4e-10): 1e-7. The 1e-8 at the
    # default tolerances is tests/hybrid/test_continuation.py::test_duffing_folds_located_to_1e8.
    assert abs(folds[0].parameter - ref.band[1]) <= 1e-7
    assert abs(folds[1].parameter - ref.band[0]) <= 1e-7
    # The orbit the branch reports at each fold against the reference's fold orbit (the extended system
    # {P(y0, W) = y0, det(I - M) = 0} solved with DOP853 at rtol 1e-13, no engine; x0 to ~2e-12). Along
    # the branch the state is smooth in the arclength s and W - W_fold ~ -a s^2, so an error dW of the
    # located frequency moves the state by at most ~sqrt(dW/a) (1e-5 for dW = 1e-10), and the orbit at
    # a *given* W is right to the IDA tolerance (rtol 1e-9) times cond(I - M) (~1e3 off the fold): hence
    # 1e-6 of |x0| for the section state and the amplitude (measured 3.1e-7 and 1.2e-7). One multiplier
    # is 1 at a fold and the other exp(-c T/m) (Liouville, T = 2 pi/W_fold): both to 1e-6 (measured
    # 2.2e-7 and 1.5e-7). The old checks here (1e-3, and the reported point's Omega compared with the special
    # point's own parameter, equal by construction) could not fail on a wrong fold orbit.
    m, c = duffing[1]["m"], duffing[1]["c"]
    for s, fold in zip(folds, (ref.folds[1], ref.folds[0]), strict=True):
        o = br.points[s.index]
        assert o.t0 == 0.0 == fold.t0
        x_ref = np.asarray(fold.x0[:2])
        assert np.max(np.abs(o.x0[:2] - x_ref)) <= 1e-6 * np.max(np.abs(x_ref)), s.parameter
        assert abs(o.amplitude["x"] - fold.amplitude["x"]) <= 1e-6 * fold.amplitude["x"]
        assert abs(s.amplitude["x"] - fold.amplitude["x"]) <= 1e-6 * fold.amplitude["x"]
        mu = np.sort(np.abs(o.multipliers))[::-1]
        damped = math.exp(-c * 2 * math.pi / fold.params["Omega"] / m)
        assert abs(np.sort(np.abs(fold.multipliers))[0] - damped) <= 1e-9  # the reference's own check
        assert abs(mu[0] - 1.0) <= 1e-6, mu
        assert abs(mu[1] - damped) <= 1e-6, mu


def test_duffing_branch_stability_agrees_with_the_reference(duffing, duffing_branch):
    system, params, ref = duffing
    br = duffing_branch
    i_up, i_lo = (s.index for s in br.special if s.kind == "fold")
    for i, o in enumerate(br.points):
        if i in (i_up, i_lo):
            continue  # at a fold (a multiplier 1): either verdict
        expected = "unstable" if i_up < i < i_lo else "stable"
        assert o.stability == expected, (i, o.params["Omega"])
    # The three orbits at Omega = 1.18, one from each part of the branch, vs the reference.
    W = ref.orbits[0].params["Omega"]
    parts = [range(0, i_up), range(i_up + 1, i_lo), range(i_lo + 1, len(br.points))]
    found = []
    for part, expected in zip(parts, ("stable", "unstable", "stable"), strict=True):
        k = min(part, key=lambda i: abs(br.points[i].params["Omega"] - W))
        start = br.points[k]
        o = periodic_orbit(
            system,
            {**params, "Omega": W},
            start.x0,
            start.mode0,
            t0=start.t0,
            settings=hybrid.ShootingOptions(transient_periods=0),
        )
        assert o.converged, o.message
        assert o.stability == expected
        found.append(o)
    found.sort(key=lambda o: o.amplitude["x"])
    for o, r in zip(found, ref.orbits, strict=True):
        assert o.stability == r.stability
        assert abs(o.amplitude["x"] - r.amplitude["x"]) <= 1e-6 * r.amplitude["x"]
        assert op.multiplier_distance(o.multipliers, r.multipliers) <= 1e-7


@pytest.mark.slow
def test_friction_continuation_finds_the_stick_boundary(friction):
    system, params, _ = friction
    boundary = op.friction_stick_boundary(params)
    assert abs(boundary - 0.58970847211665) <= 1e-10
    br = continue_orbits(
        system,
        params,
        "Omega",
        (0.56, 0.62),
        settings=hybrid.ContinuationOptions(ds=0.02, ds_max=0.05, samples_per_period=64),
    )
    assert br.status == "completed", br.message
    lost = [s for s in br.special if s.kind == "mode-lost"]
    assert len(lost) == 1, f"special points: {br.special}"
    assert abs(lost[0].parameter - boundary) <= 1e-6
    assert br.points[0].mode_fractions.get("stick", 0.0) > 0.0
    assert br.points[-1].mode_fractions.get("stick", 0.0) == 0.0


# ----------------------------------------------------------------------------
# 7. Bad input: ValueError before any integration
# ----------------------------------------------------------------------------
@pytest.fixture
def no_integration(monkeypatch):
    """Fail the test if a run starts."""

    def forbidden(*args, **kwargs):
        raise AssertionError("an integration started before the input was checked")

    monkeypatch.setattr(Run, "execute", forbidden)  # every run goes through the event loop
    monkeypatch.setattr(Sensitivity, "fundamental", forbidden)


def test_periodic_orbit_needs_a_period(no_integration):
    ball = hybrid.HybridSystem(
        name="ball",
        variables=["h", "v"],
        parameters=["g", "e"],
        modes=[hybrid.Mode("fly", derivatives={"h": "v", "v": "-g"})],
        transitions=[
            hybrid.Transition("fly", "fly", guard="h", direction=-1, name="impact", reset={"v": "-e*v"})
        ],
    )
    with pytest.raises(ValueError, match="period"):
        periodic_orbit(ball, {"g": 9.81, "e": 0.5}, {"h": 1.0, "v": 0.0}, "fly")
    with pytest.raises(ValueError, match="period"):
        continue_orbits(ball, {"g": 9.81, "e": 0.5}, "g", (9.0, 10.0), x0={"h": 1.0, "v": 0.0}, mode0="fly")


@pytest.mark.parametrize("tol", [0.0, -1e-9, math.nan])
def test_tolerance_must_be_positive(duffing, no_integration, tol):
    system, params, _ = duffing
    with pytest.raises(ValueError, match="tol"):
        periodic_orbit(system, params, settings=hybrid.ShootingOptions(newton=hybrid.NewtonOptions(tol=tol)))
    with pytest.raises(ValueError, match="tol"):
        continue_orbits(
            system,
            params,
            "Omega",
            (1.0, 1.1),
            settings=hybrid.ContinuationOptions(newton=hybrid.NewtonOptions(tol=tol, max_iter=8)),
        )


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"parameter": "omega", "p_range": (1.0, 1.1)}, "no parameter `omega`"),
        ({"parameter": "Omega", "p_range": (1.1, 1.1)}, "two different"),
        ({"parameter": "Omega", "p_range": (1.0, math.inf)}, "two different"),
        ({"parameter": "Omega", "p_range": None}, "p_range"),
    ],
)
def test_continuation_rejects_bad_arguments(duffing, no_integration, kwargs, match):
    system, params, _ = duffing
    with pytest.raises(ValueError, match=match):
        continue_orbits(system, params, **kwargs)
