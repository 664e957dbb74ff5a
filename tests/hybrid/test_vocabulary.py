"""One vocabulary (issue 21): one branch result, statuses with reason codes, options validated at
construction and passed one way, one signature per callback, short summaries.

Every reason code that :mod:`hybrid` produces is produced here (or in the test named beside it in
:data:`ELSEWHERE`) and checked against its table in :mod:`hybrid.core.status`. Rare failures
(a run or a monodromy that fails inside Newton's method, a line search without a decrease) are
produced by replacing the piece that fails, so that the code of each is tested, not the
circumstances.
"""

from __future__ import annotations

import csv
import io
import json
import math
from dataclasses import fields, replace

import numpy as np
import pytest

import hybrid
import hybrid.continuation.autonomous as autobranch
import hybrid.orbits.flowmap as flowmap
import hybrid.orbits.newton as newton
import hybrid.orbits.shooter as shooter
import hybrid.studies.sweep as sweep_mod
import hybrid_models
from hybrid import (
    IDA,
    Branch,
    BranchStatus,
    ContinuationOptions,
    Exact,
    HybridSystem,
    Mode,
    NewtonOptions,
    PointStatus,
    ResponseStatus,
    ShootingOptions,
    SolverOptions,
    SolveStatus,
    SpecialPoint,
    Status,
)
from hybrid.continuation.autonomous import AUTONOMOUS_CONTINUATION
from hybrid.continuation.frc import FrequencyResponse, Piece
from hybrid.core.errors import AlgebraicSolveError, IntegratorError
from hybrid.core.status import (
    BRANCH_REASONS,
    POINT_REASONS,
    RESPONSE_REASONS,
    SOLVE_REASONS,
    TRAJECTORY_REASONS,
)
from hybrid.engine.io import to_json
from hybrid.orbits.equilibria import EQUILIBRIUM_NEWTON, HOPF_SECANT

EXACT = SolverOptions(method=Exact())

#: Reason codes produced by tests elsewhere (code -> test).
ELSEWHERE = {
    ("solve", "budget"): "test_budget.py::test_periodic_orbit_reports_a_step_limit_as_not_converged",
    ("solve", "grazing"): "test_budget.py::test_grazing_switch_is_not_converged_with_the_reason",
    (
        "solve",
        "resonance",
    ): "test_budget.py::test_orbit_at_an_undamped_resonance_says_no_bounded_orbit_and_what_to_try",
    ("branch", "unbounded"): "test_continuation.py::test_unbounded_branch_stops_with_its_label",
    (
        "branch",
        "no-start",
    ): "test_continuation.py::test_a_start_that_fails_at_the_range_end_is_retried_inside_it",
    ("branch", "degenerate"): "test_continuation.py::test_an_unforced_system_has_no_branch_to_follow",
    ("branch", "budget"): "test_budget.py::test_continuation_stops_at_the_deadline_with_the_points_it_has",
    ("branch", "grazing"): "test_belt.py::test_stribeck_hopf_branch_meets_the_stick_slip_branch_at_a_grazing",
    ("response", "time-limit"): "test_budget.py::test_frequency_response_returns_what_it_has_at_the_deadline",
    (
        "response",
        "empty-branch",
    ): "test_continuation.py::test_a_start_that_fails_at_the_range_end_is_retried_inside_it",
    ("point", "unbounded"): "test_sweep.py::test_unbounded_failed_and_time_limit_points_recorded",
    ("point", "exception"): "test_sweep.py::test_unbounded_failed_and_time_limit_points_recorded",
    ("point", "time-limit"): "test_sweep.py::test_unbounded_failed_and_time_limit_points_recorded",
    ("trajectory", "steps"): "test_budget.py::test_step_limit_stops_a_simulation_with_what_to_change",
    (
        "trajectory",
        "projected",
    ): "test_budget.py::test_dynamics_far_faster_than_the_forcing_are_stopped_early_with_the_reason",
    ("trajectory", "time"): "test_budget.py::test_wall_clock_limit_of_one_run",
}


@pytest.fixture(scope="module")
def coulomb():
    system = hybrid_models.coulomb()
    return system, system.preset("forced")


@pytest.fixture(scope="module")
def coulomb_orbit(coulomb):
    system, p = coulomb
    o = hybrid.periodic_orbit(system, p, options=EXACT)
    assert o.converged, o.message
    return o


def _from(orbit, **changes):
    """Newton from ``orbit``'s own section (no transient, hence no cold-start fallback)."""
    x0 = orbit.x0 * changes.pop("scale", 1.0)
    settings = ShootingOptions(transient_periods=0, **changes)
    return hybrid.periodic_orbit(
        orbit.system, orbit.params, x0, orbit.mode0, t0=orbit.t0, options=EXACT, settings=settings
    )


def _failed(o, reason: str) -> None:
    assert o.status is SolveStatus.FAILED, o.message
    assert o.reason == reason, o.message
    assert not o.converged
    assert reason in SOLVE_REASONS


# ----------------------------------------------------------------------------
# Statuses: str enums that compare, print and serialise as today's strings
# ----------------------------------------------------------------------------
@pytest.mark.parametrize("enum", [SolveStatus, BranchStatus, ResponseStatus, PointStatus])
def test_statuses_compare_print_and_serialise_as_their_strings(enum):
    for member in enum:
        assert member == member.value
        assert f"{member}" == member.value
        assert str(member) == member.value
        assert json.dumps(member) == json.dumps(member.value)
        assert to_json({"s": member}) == to_json({"s": member.value})
        buf = io.StringIO()
        csv.writer(buf).writerow([member])
        assert buf.getvalue().strip() == member.value


def test_status_values_are_the_strings_of_the_files():
    assert [s.value for s in BranchStatus] == ["completed", "stopped"]
    assert [s.value for s in ResponseStatus] == ["complete", "incomplete"]
    assert [s.value for s in SolveStatus] == ["converged", "failed"]
    assert sweep_mod.STATUSES == ("bounded", "unbounded", "incomplete", "failed", "time limit")


def test_reason_tables_name_the_empty_code_and_the_codes_tested_elsewhere():
    tables = {
        "solve": SOLVE_REASONS,
        "branch": BRANCH_REASONS,
        "response": RESPONSE_REASONS,
        "point": POINT_REASONS,
        "trajectory": TRAJECTORY_REASONS,
    }
    for table in tables.values():
        assert "" in table
        assert all(code == code.strip().lower() and " " not in code for code in table)
    for kind, code in ELSEWHERE:
        assert code in tables[kind], (kind, code)


# ----------------------------------------------------------------------------
# Reason codes of a periodic orbit
# ----------------------------------------------------------------------------
def test_converged_orbit_has_no_reason(coulomb_orbit):
    assert coulomb_orbit.status is SolveStatus.CONVERGED
    assert coulomb_orbit.status == "converged"
    assert coulomb_orbit.reason == ""


def test_a_failed_transient_is_transient_failed(coulomb):
    system, p = coulomb
    o = hybrid.periodic_orbit(
        system, p, options=SolverOptions(max_steps=60), settings=ShootingOptions(transient_periods=2)
    )
    _failed(o, "transient-failed")
    assert o.message.startswith("transient failed: step limit reached")


def test_a_response_that_grows_is_unbounded(coulomb):
    system, p = coulomb
    # from rest one Newton step leaves the state thousands of times its start: no bounded orbit
    o = hybrid.periodic_orbit(
        system, p, t0=0.0, settings=ShootingOptions(newton=NewtonOptions(max_iter=1), transient_periods=0)
    )
    _failed(o, "unbounded")
    assert "grows without bound" in o.message


def test_iterations_used_up_is_not_converged(coulomb):
    system, p = coulomb
    settings = ShootingOptions(newton=NewtonOptions(max_iter=1), transient_periods=0)
    o = hybrid.periodic_orbit(system, p, {"x": 1.0, "v": 0.0}, t0=0.0, settings=settings)
    _failed(o, "not-converged")
    assert o.message.startswith("Newton's method did not converge")


def test_a_guess_whose_slave_variables_cannot_be_solved_is_an_inconsistent_guess(coulomb_orbit, monkeypatch):
    def project(self, t, y):
        raise AlgebraicSolveError("no root (test)")

    monkeypatch.setattr(newton.NewtonMap, "project", project)
    o = _from(coulomb_orbit)
    _failed(o, "inconsistent-guess")
    assert o.message == "guess is not consistent: no root (test)"


def test_a_run_that_fails_inside_newton_is_run_failed(coulomb_orbit, monkeypatch):
    run = shooter.Shooter.run_now

    def failing(self, *args):
        return replace(run(self, *args), status=Status.ZENO, message="Zeno point (test)")

    monkeypatch.setattr(shooter.Shooter, "run_now", failing)
    o = _from(coulomb_orbit)
    _failed(o, "run-failed")
    assert o.message == "run failed at iteration 0: Zeno point (test)"


def test_failed_variational_equations_are_monodromy_failed(coulomb_orbit, monkeypatch):
    def monodromy(self, tr):
        raise IntegratorError("variational equations failed (test)")

    monkeypatch.setattr(shooter.Shooter, "monodromy", monodromy)
    o = _from(coulomb_orbit)
    _failed(o, "monodromy-failed")
    assert o.message == "monodromy failed: variational equations failed (test)"


def test_no_decrease_along_newtons_direction(coulomb_orbit, monkeypatch):
    monkeypatch.setattr(newton, "_sequence_candidate", lambda *a: None)
    monkeypatch.setattr(newton, "_line_search", lambda *a, **k: (None, None))
    o = _from(coulomb_orbit, scale=1.001)  # near the orbit: a residual below 0.1
    _failed(o, "no-decrease")
    assert "no decrease of the residual" in o.message


def test_no_run_along_newtons_direction_far_from_the_orbit_is_run_failed(coulomb_orbit, monkeypatch):
    monkeypatch.setattr(newton, "_sequence_candidate", lambda *a: None)
    monkeypatch.setattr(newton, "_line_search", lambda *a, **k: (None, None))
    o = _from(coulomb_orbit, scale=3.0)  # far from it: a residual above 0.1
    _failed(o, "run-failed")
    assert o.message.startswith("every run along the Newton step failed")


def test_steps_accepted_uphill_are_not_trusted(coulomb_orbit, monkeypatch):
    search = newton._line_search
    calls = []

    def first_uphill(*args, **kwargs):
        found, best = search(*args, **kwargs)
        calls.append(found)
        if len(calls) == 1 and found is not None:
            return None, found  # as if no step decreased the residual: the best one, uphill
        return found, best

    monkeypatch.setattr(newton, "_sequence_candidate", lambda *a: None)
    monkeypatch.setattr(newton, "_line_search", first_uphill)
    o = _from(coulomb_orbit, scale=3.0)
    _failed(o, "uphill")
    assert o.residual <= 1e-9  # the residual met the tolerance: the orbit is there, not trusted
    assert "accepted without a decrease of the residual" in o.message


def test_an_orbit_ending_in_another_mode_is_a_mode_mismatch(coulomb_orbit, monkeypatch):
    run = shooter.Shooter.run_now

    def elsewhere(self, *args):
        return replace(run(self, *args), mode_final="elsewhere")

    monkeypatch.setattr(shooter.Shooter, "run_now", elsewhere)
    o = _from(coulomb_orbit)
    _failed(o, "mode-mismatch")
    assert o.message.startswith("the mode at t0 + T differs from the section's mode")


def test_a_transient_that_never_crosses_the_section_is_no_section_crossing():
    belt = hybrid_models.belt_stribeck()
    p = belt.preset("standard", v_b=1.4)  # steady sliding is stable above v_b* = 1.15
    x_star = (p["Fk"] + (p["Fs"] - p["Fk"]) * math.exp(-p["v_b"] / p["vs"])) / p["k"]
    o = hybrid.autonomous_orbit(
        belt, p, {"x": x_star, "w": -p["v_b"]}, "slip-", settings=ShootingOptions(transient_periods=2)
    )
    _failed(o, "no-section-crossing")
    assert "never crossed the section `breakaway-`" in o.message


# ----------------------------------------------------------------------------
# Reason codes of an equilibrium
# ----------------------------------------------------------------------------
def _one_mode(derivatives: dict) -> HybridSystem:
    return HybridSystem(
        name="eq",
        variables=list(derivatives),
        parameters=["c"],
        modes=[Mode("m", derivatives=derivatives)],
        transitions=[],
        initial_mode="m",
    )


@pytest.mark.parametrize(
    ("derivatives", "x0", "reason", "message"),
    [
        # a free offset: every x is a steady state
        ({"x": "v", "v": "-c*v"}, None, "singular", "the Jacobian is singular there"),
        # no real root: Newton wanders
        ({"x": "v", "v": "x*x + 1 - c*v"}, {"x": 0.3, "v": 0.0}, "not-converged", "did not converge"),
        # f' underflows to a subnormal number: the first step overflows
        ({"x": "exp(-x*x) + c"}, {"x": 27.0}, "diverged", "Newton's iterates diverged"),
        # exp overflows in the model's equations
        (
            {"x": "v", "v": "-x - c*v + exp(x)"},
            {"x": -800.0, "v": 0.0},
            "solve-failed",
            "Newton's method failed",
        ),
    ],
)
def test_equilibrium_reasons(derivatives, x0, reason, message):
    e = hybrid.equilibrium(_one_mode(derivatives), {"c": 1.0}, "m", x0)
    assert e.status is SolveStatus.FAILED
    assert not e.converged
    assert e.reason == reason
    assert reason in SOLVE_REASONS
    assert message in e.message
    assert e.stability == "unknown" or reason == "singular"


def test_a_converged_equilibrium_has_no_reason():
    e = hybrid.equilibrium(_one_mode({"x": "v", "v": "-x - c*v"}), {"c": 1.0}, "m", {"x": 0.3, "v": 0.0})
    assert e.status == "converged"
    assert e.converged
    assert e.reason == ""
    assert e.stability == "stable"


# ----------------------------------------------------------------------------
# One branch result
# ----------------------------------------------------------------------------
@pytest.fixture(scope="module")
def three_branches(coulomb):
    system, p = coulomb
    forced = hybrid.continue_orbits(system, p, "Omega", (0.8, 0.82), options=EXACT)
    belt = hybrid_models.belt()
    cycle = hybrid.autonomous_orbit(belt, belt.preset("standard"))
    autonomous = hybrid.orbit_branch(
        cycle, "v_b", (0.2, 0.6), settings=replace(AUTONOMOUS_CONTINUATION, max_points=3)
    )
    stribeck = hybrid_models.belt_stribeck()
    equilibria = hybrid.equilibrium_branch(
        stribeck, stribeck.preset("standard"), "slip-", "v_b", np.linspace(1.0, 1.3, 4), {"x": 0.5, "w": -1.0}
    )
    return forced, autonomous, equilibria


def test_all_three_branch_kinds_are_one_class_with_the_same_attributes(three_branches):
    forced, autonomous, equilibria = three_branches
    assert [b.kind for b in three_branches] == ["forced-orbits", "autonomous-orbits", "equilibria"]
    names = {f.name for f in fields(Branch)}
    for b in three_branches:
        assert type(b) is Branch
        assert {f.name for f in fields(b)} == names
        assert isinstance(b.values, np.ndarray)
        assert b.values.tolist() == [pt.params[b.parameter] for pt in b.points]
        assert all(isinstance(sp, SpecialPoint) for sp in b.special)
        assert isinstance(b.status, BranchStatus)
        assert b.status == "completed"
        assert b.reason == ""
        assert len(b.stability) == len(b.points)
        assert b.half_peak_to_peak("x").shape == (len(b.points),)
        assert len(b.to_rows()) == len(b.points)
    assert forced.values[0] == 0.8
    assert forced.values[-1] >= 0.82
    assert autonomous.values.tolist()[0] == 0.5
    assert len(autonomous.points) == 3
    assert "reached max_points = 3" in autonomous.message
    # an equilibrium's amplitude is |x|, its half peak-to-peak 0
    np.testing.assert_array_equal(equilibria.half_peak_to_peak("x"), 0.0)
    assert equilibria.amplitude("x").tolist() == [abs(e.state("x")) for e in equilibria.points]


def test_an_equilibrium_branch_holds_its_hopf_point_as_a_special_point(three_branches):
    *_, eb = three_branches
    p = hybrid_models.belt_stribeck().preset("standard")
    v_star = p["vs"] * math.log((p["Fs"] - p["Fk"]) / (p["vs"] * (p["c"] + p["cf"])))
    (sp,) = eb.special
    assert sp.kind == "hopf"
    assert sp.status == "located"
    assert abs(sp.parameter - v_star) <= 1e-10 * v_star
    assert sp.interval[0] <= sp.parameter <= sp.interval[1]
    eq = eb.points[sp.index]  # the located equilibrium is a point of the branch, between the grid values
    assert eq.params["v_b"] == sp.parameter
    assert eb.values[sp.index - 1] < sp.parameter < eb.values[sp.index + 1]
    assert abs(abs(eq.eigenvalues[0].imag) - math.sqrt(p["k"] / p["m"])) <= 1e-10
    assert len(eb.points) == 5  # four grid values and the Hopf point


def test_branch_kind_is_checked():
    system = hybrid_models.coulomb()
    with pytest.raises(
        ValueError,
        match=r"Branch: `kind` must be one of forced-orbits, autonomous-orbits, equilibria, got 'orbits'",
    ):
        Branch("orbits", system, {}, "Omega")


def test_a_forced_branch_that_stalls_says_stalled(coulomb, monkeypatch):
    system, p = coulomb
    first = []
    run = shooter.Shooter.run

    def run_until_first(self, *args, **kwargs):
        if first:
            raise IntegratorError("IDA failed (test)")
        return run(self, *args, **kwargs)

    monkeypatch.setattr(shooter.Shooter, "run", run_until_first)
    br = hybrid.continue_orbits(
        system,
        p,
        "Omega",
        (0.8, 0.9),
        options=EXACT,
        settings=ContinuationOptions(max_failures=2),
        on_point=lambda k, o: first.append(o),
    )
    assert br.status == BranchStatus.STOPPED, br.message
    assert br.reason == "stalled", br.message
    assert len(br.points) == 1
    assert br.message.startswith("stalled at Omega=0.8: 3 failed steps in a row")


@pytest.fixture()
def belt_cycle():
    belt = hybrid_models.belt()
    return hybrid.autonomous_orbit(belt, belt.preset("standard"))


def test_an_autonomous_branch_that_stalls_says_stalled_or_no_start(belt_cycle, monkeypatch):
    returned = flowmap.FlowMap.returned
    calls = []

    def fail_after(limit):
        def returned_until(self, *args, **kwargs):
            calls.append(1)
            if len(calls) > limit:
                raise RuntimeError("run failed (test)")
            return returned(self, *args, **kwargs)

        return returned_until

    monkeypatch.setattr(flowmap.FlowMap, "returned", fail_after(0))
    br = hybrid.orbit_branch(belt_cycle, "v_b", (0.2, 0.6))
    assert br.status == "stopped", br.message
    assert br.reason == "no-start", br.message
    assert not br.points, br.message
    calls.clear()
    monkeypatch.setattr(flowmap.FlowMap, "returned", fail_after(2))
    br = hybrid.orbit_branch(belt_cycle, "v_b", (0.2, 0.6))
    assert br.status == "stopped", br.message
    assert br.reason == "stalled", br.message
    assert len(br.points) == 2
    assert br.message.startswith(f"stalled at v_b={br.values[-1]:.8g}")


def test_an_autonomous_orbit_whose_period_jumps_ends_the_branch(belt_cycle, monkeypatch):
    # the stick-slip cycle's period grows as the belt slows: any growth is a jump at PERIOD_JUMP = 1
    monkeypatch.setattr(autobranch, "PERIOD_JUMP", 1.0)
    br = hybrid.orbit_branch(belt_cycle, "v_b", (0.2, 0.6), direction=-1)
    assert br.status == "stopped", br.message
    assert br.reason == "period-jump", br.message
    assert len(br.points) == 1
    assert "period is over 1 times" in br.message


# ----------------------------------------------------------------------------
# Reason codes of a frequency response and of a sweep's point
# ----------------------------------------------------------------------------
def _response(system, branches, gaps, timed_out=False) -> FrequencyResponse:
    fr = FrequencyResponse(system, {}, "Omega", (0.5, 0.6), np.zeros(0))
    fr.pieces = [Piece(0.5, 0.6, None, branches, gaps, timed_out)]
    fr.conclude()
    return fr


def test_response_reasons_from_its_pieces(coulomb):
    system, _ = coulomb
    full = Branch("forced-orbits", system, {}, "Omega", points=["an orbit"])
    empty = Branch("forced-orbits", system, {}, "Omega")
    cases = [
        (([full], []), ResponseStatus.COMPLETE, ""),
        (([full], [(0.55, 0.6)]), ResponseStatus.INCOMPLETE, "gaps"),
        (([empty, full], []), ResponseStatus.INCOMPLETE, "empty-branch"),
        (([full], [(0.55, 0.6)], True), ResponseStatus.INCOMPLETE, "time-limit"),
    ]
    for args, status, reason in cases:
        fr = _response(system, *args)
        assert (fr.status, fr.reason) == (status, reason)
        assert reason in RESPONSE_REASONS


@pytest.mark.parametrize(
    ("branches", "gaps", "reason"), [((), [(0.5, 0.6)], "gaps"), ("empty", [], "empty-branch")]
)
def test_an_incomplete_point_of_a_sweep_carries_the_response_reason(
    coulomb, tmp_path, monkeypatch, branches, gaps, reason
):
    system, p = coulomb
    made = [Branch("forced-orbits", system, {}, "Omega")] if branches == "empty" else []

    def response(system, params, p_range, **kwargs):
        return _response(system, made, gaps)

    monkeypatch.setattr(sweep_mod, "frequency_response", response)
    axis = hybrid.linear_axis("F", 0.5, 0.5, 0.1)
    res = hybrid.sweep(system, p, [axis], tmp_path, p_range=(0.5, 0.6), coordinate="x")
    r = res.points[(0,)]
    assert r["status"] == PointStatus.INCOMPLETE
    assert r["reason"] == reason
    assert reason in POINT_REASONS


# ----------------------------------------------------------------------------
# Options: validated at construction, messages naming the field and the value, passed one way
# ----------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("make", "error", "match"),
    [
        (
            lambda: NewtonOptions(tol=0.0),
            ValueError,
            r"NewtonOptions: `tol` must be a finite number > 0, got 0\.0",
        ),
        (
            lambda: NewtonOptions(tol=math.nan),
            ValueError,
            r"NewtonOptions: `tol` must be a finite number > 0, got nan",
        ),
        (
            lambda: NewtonOptions(max_iter=0),
            ValueError,
            r"NewtonOptions: `max_iter` must be an integer >= 1, got 0",
        ),
        (
            lambda: NewtonOptions(max_iter=2.5),
            ValueError,
            r"NewtonOptions: `max_iter` must be an integer >= 1, got 2\.5",
        ),
        (
            lambda: ShootingOptions(transient_periods=-1),
            ValueError,
            r"ShootingOptions: `transient_periods` must be an integer >= 0, got -1",
        ),
        (
            lambda: ShootingOptions(samples_per_period=8),
            ValueError,
            r"ShootingOptions: `samples_per_period` must be an integer >= 16 .*, got 8",
        ),
        (
            lambda: ShootingOptions(newton=1e-9),
            TypeError,
            r"ShootingOptions: `newton` must be a NewtonOptions, got float",
        ),
        (
            lambda: ContinuationOptions(newton={"tol": 1e-9}),
            TypeError,
            r"ContinuationOptions: `newton` must be a NewtonOptions, got dict",
        ),
        (
            lambda: ContinuationOptions(samples_per_period=15),
            ValueError,
            r"ContinuationOptions: `samples_per_period` must be an integer >= 16 .*, got 15",
        ),
        (
            lambda: ContinuationOptions(max_failures=0),
            ValueError,
            r"ContinuationOptions: `max_failures` must be an integer >= 1, got 0",
        ),
    ],
)
def test_options_are_validated_at_construction(make, error, match):
    with pytest.raises(error, match=match):
        make()


def test_defaults_are_those_of_before():
    # periodic_orbit's tol, max_iter, transient_periods, samples_per_period keywords
    assert ShootingOptions() == ShootingOptions(NewtonOptions(1e-9, 30), 10, 512)
    # ContinuationOptions' tol and max_iter
    assert ContinuationOptions().newton == NewtonOptions(1e-9, 8)
    # PalcSettings() and orbit_branch's samples_per_period
    a = AUTONOMOUS_CONTINUATION
    assert (a.ds, a.ds_min, a.ds_max, a.max_points, a.newton, a.samples_per_period) == (
        0.02,
        1e-6,
        0.2,
        200,
        NewtonOptions(1e-9, 8),
        256,
    )
    # equilibrium's and locate_hopf's keywords
    assert EQUILIBRIUM_NEWTON == NewtonOptions(1e-12, 50)
    assert HOPF_SECANT == NewtonOptions(1e-13, 60)


def test_an_autonomous_orbit_needs_a_transient():
    belt = hybrid_models.belt()
    with pytest.raises(
        ValueError, match=r"ShootingOptions: `transient_periods` must be >= 1 for an autonomous orbit"
    ):
        hybrid.autonomous_orbit(belt, belt.preset("standard"), settings=ShootingOptions(transient_periods=0))


@pytest.mark.parametrize(
    ("call", "match"),
    [
        (
            lambda s, p: hybrid.frequency_response(s, p, (0.7, 0.9), integrator="exact"),
            r"frequency_response\(\) got unexpected keyword argument\(s\) 'integrator': options go in "
            r"objects, not keywords: call frequency_response\(\.\.\., options=SolverOptions\(method=Exact\(\)\)\)$",
        ),
        (
            lambda s, p: hybrid.periodic_orbit(s, p, tol=1e-11),
            r"call periodic_orbit\(\.\.\., settings=ShootingOptions\(newton=NewtonOptions\(tol=1e-11\)\)\)",
        ),
        (
            lambda s, p: hybrid.periodic_orbit(s, p, transient_periods=0),
            r"settings=ShootingOptions\(transient_periods=0\)",
        ),
        (
            lambda s, p: hybrid.continue_orbits(s, p, "Omega", (0.7, 0.9), ds=0.1, rtol=1e-9),
            r"'ds', 'rtol': options go in objects, not keywords: call continue_orbits\(\.\.\., "
            r"options=SolverOptions\(method=IDA\(rtol=1e-09\)\), settings=ContinuationOptions\(ds=0\.1\)\)",
        ),
        (
            lambda s, p: hybrid.continue_orbits(s, p, "Omega", (0.7, 0.9), max_iter=4),
            r"settings=ContinuationOptions\(newton=NewtonOptions\(max_iter=4\)\)",
        ),
        (
            lambda s, p: hybrid.continue_orbits(s, p, "Omega", (0.7, 0.9), step=0.1),
            r"`step` is not an argument of continue_orbits\(\)",
        ),
    ],
)
def test_a_loose_option_says_where_it_goes(coulomb, call, match):
    system, p = coulomb
    with pytest.raises(TypeError, match=match):
        call(system, p)


def test_the_message_of_a_loose_option_is_the_call_that_works(coulomb):
    """Issue 24: the fix, merged with the options already passed, runs as it is printed."""
    system, p = coulomb
    with pytest.raises(TypeError) as info:
        hybrid.periodic_orbit(
            system, p, options=SolverOptions(method=IDA(rtol=1e-9)), integrator="exact", max_iter=7
        )
    msg = str(info.value)
    fix = msg.split("call periodic_orbit(..., ", 1)[1][:-1]
    assert fix == (
        "options=SolverOptions(method=Exact()), settings=ShootingOptions(newton=NewtonOptions(max_iter=7))"
    )
    namespace = {
        "SolverOptions": SolverOptions,
        "Exact": Exact,
        "IDA": IDA,
        "ShootingOptions": ShootingOptions,
        "NewtonOptions": NewtonOptions,
    }
    kwargs = _build_call(f"dict({fix})", namespace)
    assert kwargs["options"] == SolverOptions(method=Exact())
    assert kwargs["settings"].newton.max_iter == 7


def test_autonomous_functions_say_where_a_loose_option_goes(belt_cycle):
    belt = belt_cycle.system
    with pytest.raises(TypeError, match=r"settings=ContinuationOptions\(samples_per_period=64\)"):
        hybrid.orbit_branch(belt_cycle, "v_b", (0.2, 0.6), samples_per_period=64)
    with pytest.raises(TypeError, match=r"settings=ShootingOptions\(newton=NewtonOptions\(tol=1e-12\)\)"):
        hybrid.autonomous_orbit(belt, belt.preset("standard"), tol=1e-12)
    with pytest.raises(TypeError, match=r"`bounds` is not an argument of hopf_branch\(\)"):
        hybrid.hopf_branch(None, "v_b", (0.2, 0.6), bounds=(0.2, 0.6))


@pytest.mark.parametrize(
    ("call", "match"),
    [
        (
            lambda: hybrid.periodic_orbit(hybrid_models.coulomb(), {}, settings=ContinuationOptions()),
            r"`settings` must be a ShootingOptions, got ContinuationOptions",
        ),
        (
            lambda: hybrid.continue_orbits(
                hybrid_models.coulomb(), {}, "Omega", (0.7, 0.9), settings=ShootingOptions()
            ),
            r"`settings` must be a ContinuationOptions, got ShootingOptions",
        ),
        (
            lambda: hybrid.equilibrium(_one_mode({"x": "-x"}), {"c": 1.0}, "m", settings=ShootingOptions()),
            r"`settings` must be a NewtonOptions, got ShootingOptions",
        ),
        (
            lambda: hybrid.locate_hopf(_one_mode({"x": "-x"}), {"c": 1.0}, "m", "c", (0, 1), settings=1e-13),
            r"`settings` must be a NewtonOptions, got float",
        ),
    ],
)
def test_settings_of_the_wrong_kind_are_refused(call, match):
    with pytest.raises(TypeError, match=match):
        call()


def test_orbit_branch_refuses_settings_of_the_wrong_kind(belt_cycle):
    with pytest.raises(TypeError, match=r"`settings` must be a ContinuationOptions, got NewtonOptions"):
        hybrid.orbit_branch(belt_cycle, "v_b", (0.2, 0.6), settings=NewtonOptions())


# ----------------------------------------------------------------------------
# Callbacks: one signature per name
# ----------------------------------------------------------------------------
def test_continue_orbits_calls_on_point_with_index_and_orbit_and_progress_with_a_fraction(coulomb):
    system, p = coulomb
    seen, fractions = [], []
    br = hybrid.continue_orbits(
        system,
        p,
        "Omega",
        (0.8, 0.82),
        options=EXACT,
        on_point=lambda k, o: seen.append((k, o)),
        progress=fractions.append,
    )
    assert [k for k, _ in seen] == [0] * len(br.points)
    assert all(o is q for (_, o), q in zip(seen, br.points, strict=True))
    assert fractions == sorted(fractions)
    assert 0.0 < fractions[-1] <= 1.0


def test_sweep_calls_progress_with_a_fraction_and_on_point_with_index_and_result(coulomb, tmp_path):
    system, p = coulomb
    axis = hybrid.linear_axis("F", 0.4, 0.5, 0.1)
    fractions, seen = [], []
    kw = {"p_range": (0.8, 0.82), "options": EXACT, "progress": fractions.append}
    res = hybrid.sweep(system, p, [axis], tmp_path, on_point=lambda i, r: seen.append((i, r)), **kw)
    assert fractions == [0.0, 0.5, 1.0]
    assert [i for i, _ in seen] == [0, 1]  # one axis: an int (issue 33); res.points keys stay tuples
    assert res.computed == [(0,), (1,)]
    assert all(r == res.points[(i,)] for i, r in seen)
    fractions.clear()
    hybrid.sweep(system, p, [axis], tmp_path, resume=True, **kw)  # both found finished
    assert fractions == [1.0]


# ----------------------------------------------------------------------------
# Short summaries
# ----------------------------------------------------------------------------
def _short(text: str) -> str:
    assert text.count("\n") <= 2, text
    assert len(text) <= 400, text
    return text


def test_orbit_repr(coulomb_orbit, coulomb):
    text = _short(repr(coulomb_orbit))
    assert text.startswith("PeriodicOrbit(coulomb, T=7.85398 s, ")
    assert "converged" in text
    assert coulomb_orbit.stability in text
    system, p = coulomb
    failed = hybrid.periodic_orbit(
        system, p, t0=0.0, settings=ShootingOptions(newton=NewtonOptions(max_iter=1), transient_periods=0)
    )
    assert _short(repr(failed)) == (
        f"PeriodicOrbit(coulomb, T=7.85398 s, failed (unbounded) after 1 iterations, residual {failed.residual:.2g}, "
        # the options it was computed with (issue 29 item 6): ORBIT_OPTIONS in place of None
        "options=SolverOptions(method=IDA(rtol=1e-10, atol=1e-12)), "
        "settings=ShootingOptions(newton=NewtonOptions(max_iter=1), transient_periods=0))"
    )


def test_branch_repr(three_branches):
    forced, autonomous, equilibria = three_branches
    text = _short(repr(forced))
    assert text.startswith(
        f"Branch(forced-orbits of coulomb in Omega: {len(forced.points)} points from 0.8 to "
    )
    assert text.endswith(
        "; completed; options=SolverOptions(method=Exact()), settings=ContinuationOptions())"
    )
    assert _short(repr(autonomous)) == (
        "Branch(autonomous-orbits of belt in v_b: 3 points from 0.5 to 0.56, special: []; completed; "
        "options=SolverOptions(method=IDA(rtol=1e-10, atol=1e-12)), "  # (ORBIT_OPTIONS in place of None)
        "settings=ContinuationOptions(ds_min=1e-06, ds_max=0.2, max_points=3, samples_per_period=256))"
    )
    sp = equilibria.special[0]
    assert _short(repr(equilibria)) == (
        f"Branch(equilibria of belt_stribeck in v_b: 5 points from 1 to 1.3, special: [hopf@{sp.parameter:.6g}]; completed)"
    )
    empty = Branch("forced-orbits", forced.system, {}, "Omega")
    empty.stop("no-start", "no periodic orbit")
    assert repr(empty) == "Branch(forced-orbits of coulomb in Omega: no point; stopped (no-start))"


def test_special_point_and_hopf_point_reprs(three_branches):
    *_, eb = three_branches
    sp = eb.special[0]
    assert _short(repr(sp)).startswith(f"SpecialPoint(hopf at {sp.parameter:.10g} (located, +-")
    stribeck = hybrid_models.belt_stribeck()
    hp = hybrid.locate_hopf(
        stribeck, stribeck.preset("standard"), "slip-", "v_b", (1.0, 1.3), {"x": 0.5, "w": -1.0}
    )
    assert _short(repr(hp)).startswith(f"HopfPoint(hopf at {hp.parameter:.12g} (located, ")
    assert "frequency 1 rad/s" in repr(hp)


def test_equilibrium_repr():
    e = hybrid.equilibrium(_one_mode({"x": "v", "v": "-x - c*v"}), {"c": 1.0}, "m", {"x": 0.3, "v": 0.0})
    assert (
        _short(repr(e))
        == f"Equilibrium(eq, mode m, stable, leading eigenvalue -0.5+0.866025j 1/s, residual {e.residual:.2g})"
    )
    bad = hybrid.equilibrium(_one_mode({"x": "v", "v": "-c*v"}), {"c": 1.0}, "m")
    assert repr(bad) == "Equilibrium(eq, mode m, failed (singular))"


def test_frequency_response_repr_is_short(coulomb):
    system, p = coulomb
    fr = hybrid.frequency_response(system, p, (0.8, 0.82), options=EXACT)
    n = sum(len(b.points) for b in fr.branches)
    assert _short(repr(fr)) == (
        f"FrequencyResponse(coulomb in Omega from 0.8 to 0.82: 1 branch, {n} orbits, 0 special points, 0 gaps; "
        "complete; options=SolverOptions(method=Exact()), settings=ContinuationOptions())"
    )
    assert len(repr(fr)) < 250  # before: the whole model, 3 kB


def test_sweep_result_repr(coulomb, tmp_path):
    system, p = coulomb
    axis = hybrid.linear_axis("F", 0.5, 0.5, 0.1)
    res = hybrid.sweep(system, p, [axis], tmp_path, p_range=(0.8, 0.82), options=EXACT)
    assert _short(repr(res)) == (
        f"SweepResult(coulomb over F (1) in {str(tmp_path)!r}: 1 bounded; "
        "options=SolverOptions(method=Exact()), settings=ContinuationOptions(locate=False))"
    )


def _build_call(text: str, classes: dict):
    """The value of ``text``, calls of ``classes`` (and ``dict``) with literal or nested-call
    keyword arguments only: the message's fix rebuilt without evaluating text."""
    import ast

    def value(node):
        if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and not node.args:
            kw = {k.arg: value(k.value) for k in node.keywords}
            return dict(**kw) if node.func.id == "dict" else classes[node.func.id](**kw)
        return ast.literal_eval(node)

    return value(ast.parse(text, mode="eval").body)
