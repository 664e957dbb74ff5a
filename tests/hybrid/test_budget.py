"""Issue 13: every run has a budget (steps, wall clock, a command deadline); unresolvable time
ranges are refused; run-time failures come back as results with a reason, not tracebacks."""

import math

import numpy as np
import pytest

import hybrid
import hybrid.core.budget as budget_mod
import hybrid_models
from hybrid import (
    IDA,
    BudgetExceeded,
    HybridSystem,
    Mode,
    SolverOptions,
    Status,
    Transition,
    continue_orbits,
    frequency_response,
    periodic_orbit,
    simulate,
    time_limit,
)
from hybrid.core.budget import Budget
from hybrid.engine.variational import Sensitivity
from hybrid.model.compiled import CompiledSystem


def rest(system):
    return dict.fromkeys(system.variable_names, 0.0)


def coulomb_forced():
    system = hybrid_models.coulomb()
    return system, system.preset("forced")


class FakeClock:
    """Drives ``hybrid.core.budget``'s clock: time stands still until ``jump`` moves it."""

    def __init__(self):
        self.now = 1000.0

    def __call__(self):
        return self.now

    def jump(self, seconds):
        self.now += seconds


@pytest.fixture
def clock(monkeypatch):
    c = FakeClock()
    monkeypatch.setattr(budget_mod, "_clock", c)
    return c


# ----------------------------------------------------------------------------
# Options
# ----------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        (dict(max_steps=0), r"`max_steps` must be an integer >= 1, got 0"),
        (dict(max_steps=1.5), r"`max_steps` must be an integer >= 1"),
        (dict(max_steps=True), r"`max_steps` must be an integer >= 1"),
        (dict(max_wall_time=0.0), r"`max_wall_time` must be a finite number > 0"),
        (dict(max_wall_time=math.inf), r"`max_wall_time` must be a finite number > 0"),
    ],
)
def test_budget_options_are_validated(kwargs, match):
    with pytest.raises(ValueError, match=match):
        SolverOptions(**kwargs)


def test_default_budgets_are_finite():
    o = SolverOptions()
    assert 0 < o.max_steps < 1e9
    assert 0 < o.max_wall_time < 1e4


@pytest.mark.parametrize("seconds", [0, -1.0, math.nan, math.inf, True, "10"])
def test_time_limit_needs_a_positive_finite_number(seconds):
    with pytest.raises(ValueError, match=r"`time_limit` needs a finite number of seconds > 0"):
        with time_limit(seconds):
            pass


# ----------------------------------------------------------------------------
# Step and wall-clock limits of one simulation
# ----------------------------------------------------------------------------
def test_step_limit_stops_a_simulation_with_what_to_change():
    system, p = coulomb_forced()
    T = 2 * math.pi / p["Omega"]
    tr = simulate(system, p, (0.0, 50 * T), rest(system), options=SolverOptions(max_steps=300), throw=False)
    assert tr.status == Status.STEP_LIMIT
    assert not tr.success
    assert tr.reason == "steps"  # the budget used up (not projected)
    assert tr.message.startswith("step limit reached: ")
    assert "SolverOptions.max_steps = 300" in tr.message
    assert "--max-steps" in tr.message
    assert 300 <= tr.nfev < 300 + 1000  # one call into IDA past the limit at most
    assert 0 < tr.t_final < 50 * T
    assert np.all(np.isfinite(tr.y_final))


def test_ida_calls_that_stop_at_their_own_step_limit_are_bounded_by_max_steps(capsys):
    # IDA returns -1 after max_num_steps internal steps and the engine goes on from there:
    # without a total budget that loop is unbounded.
    system, p = coulomb_forced()
    T = 2 * math.pi / p["Omega"]
    opts = SolverOptions(method=IDA(max_num_steps=2), max_steps=500)
    tr = simulate(system, p, (0.0, 100 * T), rest(system), t_eval=[0.0, 100 * T], options=opts, throw=False)
    assert tr.status == Status.STEP_LIMIT
    assert "max_steps = 500" in tr.message
    # SUNDIALS prints "mxstep steps taken before reaching tout" at each such return: kept off stdout
    assert capsys.readouterr().out == ""


def test_wall_clock_limit_of_one_run(clock):
    system, p = coulomb_forced()
    T = 2 * math.pi / p["Omega"]
    orig = budget_mod.Budget.check
    calls = []

    def check(self, used, t, where=""):
        calls.append(t)
        if len(calls) == 20:
            clock.jump(10.0)
        return orig(self, used, t, where)

    budget_mod.Budget.check = check
    try:
        opts = SolverOptions(max_wall_time=5.0)
        tr = simulate(system, p, (0.0, 20 * T), rest(system), options=opts, throw=False)
    finally:
        budget_mod.Budget.check = orig
    assert tr.status == Status.TIME_LIMIT
    assert tr.reason == "time"
    assert tr.message.startswith("time limit reached: ")
    assert "max_wall_time = 5 s" in tr.message
    assert "--max-time" in tr.message
    assert len(calls) == 20


def test_command_deadline_stops_a_simulation(clock):
    system, p = coulomb_forced()
    T = 2 * math.pi / p["Omega"]
    with time_limit(60):
        clock.jump(61)
        tr = simulate(system, p, (0.0, 5 * T), rest(system), throw=False)
    assert tr.status == Status.TIME_LIMIT
    assert tr.reason == "time"
    assert "limit of 60 s (hybrid.time_limit; CLI --max-time)" in tr.message


def test_nested_time_limits_the_earliest_wins(clock):
    with time_limit(100):
        with time_limit(1000):
            assert budget_mod._DEADLINE.get()[0] == clock.now + 100
        with time_limit(10):
            assert budget_mod._DEADLINE.get()[0] == clock.now + 10
    assert budget_mod._DEADLINE.get() is None


def fast_oscillator(w: float):
    # x'' = -w^2 x + cos(t): a lightly damped oscillation w times faster than the forcing
    return HybridSystem(
        name="fast",
        variables=["x", "v"],
        parameters=["w"],
        modes=[Mode("m", derivatives={"x": "v", "v": "-w**2*x - 1e-3*w*v + cos(t)"})],
        transitions=[],
        period="2*pi",
        initial_mode="m",
    )


def test_dynamics_far_faster_than_the_forcing_are_stopped_early_with_the_reason():
    # The case of `--set m1=1e-9 --set m2=1e-9` (3 hours at 0 % before): at its rate so far the
    # run needs far more than its budget; it is stopped after 2 % of the budget, saying why.
    system = fast_oscillator(1e4)
    opts = SolverOptions(max_steps=1_000_000)
    tr = simulate(
        system, {"w": 1e4}, (0.0, 20 * 2 * math.pi), {"x": 1.0, "v": 0.0}, options=opts, throw=False
    )
    assert tr.status == Status.STEP_LIMIT
    assert tr.reason == "projected"  # the code the orbit's transient reads, not the message text
    assert tr.message.startswith("step limit: at its rate so far this run needs about ")
    assert tr.nfev < 50_000  # stopped early, not at the budget
    assert "mode `m` linearised here has an eigenvalue of modulus 1e+04 1/s" in tr.message
    assert "times the forcing frequency" in tr.message


def test_a_run_within_its_budget_is_not_stopped_by_the_projection():
    system = fast_oscillator(3.0)
    tr = simulate(system, {"w": 3.0}, (0.0, 20 * 2 * math.pi), {"x": 1.0, "v": 0.0})
    assert tr.status == Status.COMPLETED


# ----------------------------------------------------------------------------
# Orbits and continuation obey the budgets
# ----------------------------------------------------------------------------
def test_variational_run_obeys_the_step_budget():
    system, p = coulomb_forced()
    cs = CompiledSystem(system, p)
    T = cs.period
    tr = simulate(system, p, (0.0, T), rest(system), "stick")
    sens = Sensitivity(cs, SolverOptions(max_steps=40), T / 16)
    with pytest.raises(BudgetExceeded, match=r"step limit reached: .* in the variational equations of mode"):
        sens.fundamental(tr.t_start, tr.y[0], tr.mode_start, tr.t_final, list(tr.events), np.zeros(0))


def test_periodic_orbit_reports_a_step_limit_as_not_converged():
    system, p = coulomb_forced()
    o = periodic_orbit(
        system,
        p,
        options=SolverOptions(method=IDA(rtol=1e-10), max_steps=60),
        settings=hybrid.ShootingOptions(transient_periods=0),
    )
    assert not o.converged
    assert o.message.startswith("step limit reached: ")
    assert o.status == "failed"
    assert o.reason == "budget"


def test_periodic_orbit_honours_the_deadline(clock):
    system, p = coulomb_forced()
    with time_limit(30):
        clock.jump(31)
        o = periodic_orbit(system, p)
    assert not o.converged
    assert "time limit reached" in o.message
    assert "--max-time" in o.message


def test_continuation_stops_at_the_deadline_with_the_points_it_has(clock):
    system, p = coulomb_forced()
    seen = []

    def progress(f):
        seen.append(f)
        if len(seen) == 2:
            clock.jump(100)

    with time_limit(50):
        br = continue_orbits(
            system, p, "Omega", (0.8, 0.9), progress=progress, settings=hybrid.ContinuationOptions(ds=0.05)
        )
    assert br.status == "stopped"
    assert br.reason == "budget"
    assert "time limit reached" in br.message
    assert len(br.points) >= 3
    assert len(seen) == 2


def test_frequency_response_returns_what_it_has_at_the_deadline(clock):
    system, p = coulomb_forced()
    seen = []

    def progress(f):
        seen.append(f)
        if len(seen) == 3:
            clock.jump(100)

    with time_limit(50):
        fr = frequency_response(system, p, (0.8, 1.5), progress=progress)
    assert fr.status == "incomplete"
    assert fr.status is hybrid.ResponseStatus.INCOMPLETE
    assert fr.reason == "time-limit"
    assert sum(len(b.points) for b in fr.branches) >= 2
    assert fr.gaps
    assert fr.gaps[-1][1] == 1.5
    assert any("time limit reached" in m for m in fr.messages())


# ----------------------------------------------------------------------------
# Time ranges that cannot be resolved, IDA flags
# ----------------------------------------------------------------------------
@pytest.mark.parametrize("t0", [1e15, 1e17])
def test_time_ranges_below_the_float_resolution_are_refused(t0):
    # before: t0 = 1e15 reported COMPLETED after one step with the state unchanged; 1e17 gave
    # KeyError: -60 from scikit-sundae
    system = hybrid_models.absorber()
    p = system.preset("standard")
    T = 2 * math.pi / p["Omega"]
    with pytest.raises(ValueError, match=r"floating-point resolution of t near t = 1e\+1[57] s"):
        simulate(system, p, (t0, t0 + 1000 * T), {**rest(system), "x1": 1.0})


def test_a_period_too_short_to_integrate_is_refused():
    # before: `--omega 1e308` gave IDA status -22 after the start
    system = hybrid_models.absorber()
    with pytest.raises(ValueError, match=r"step bound .* is below 1e-100 s"):
        simulate(system, system.preset("standard", Omega=1e200), (0.0, 1e-190), rest(system))
    with pytest.raises(ValueError, match=r"is below 1e-100 s"):
        periodic_orbit(system, system.preset("standard", Omega=1e200))


def test_an_ida_flag_unknown_to_scikit_sundae_is_a_failure_status(monkeypatch):
    import hybrid.integrators.ida as dae

    def unknown(ida, t, method, tstop):
        return None, (-60, "IDA returned flag -60, unknown to scikit-sundae: tout too close to t0"), ""

    monkeypatch.setattr(dae, "_call", unknown)
    system, p = coulomb_forced()
    tr = simulate(system, p, (0.0, 1.0), rest(system), throw=False)
    assert tr.status == Status.SOLVER_FAILED
    assert "IDA failed in mode `stick` at t=0.0" in tr.message
    assert "flag -60" in tr.message


def test_call_turns_a_keyerror_of_scikit_sundae_into_a_flag():
    from hybrid.integrators.ida import _call

    class Raises:
        def step(self, t, method, tstop=None):
            print("[IDASolve, Error: -60] tout too close to t0 to start integration.")
            raise KeyError(-60)

    r, bad, words = _call(Raises(), 1.0, "normal", None)
    assert r is None
    assert words == "tout too close to t0 to start integration."
    assert bad[0] == -60
    assert "unknown to scikit-sundae: tout too close to t0" in bad[1]


# ----------------------------------------------------------------------------
# Silently wrong results and tracebacks at run time
# ----------------------------------------------------------------------------
def elastic_ball():
    return HybridSystem(
        name="ball",
        variables=["h", "v"],
        parameters=["g"],
        modes=[Mode("fly", derivatives={"h": "v", "v": "-g"})],
        transitions=[Transition("fly", "fly", guard="h", direction=-1, name="impact", reset={"v": "-v"})],
    )


def test_zeno_window_of_a_model_without_period_does_not_grow_with_the_span():
    # before: the window was 1e-6 of the span: a ball bouncing every 0.9 s over 1e8 s was stopped
    # as "Zeno burst: 20 transitions within 17 s"
    tr = simulate(
        elastic_ball(), {"g": 9.81}, (0.0, 1e8), {"h": 1.0, "v": 0.0}, "fly", max_transitions=40, throw=False
    )
    assert tr.status == Status.MAX_TRANSITIONS, tr.message
    assert tr.events[1].t - tr.events[0].t == pytest.approx(2 * math.sqrt(2 / 9.81), rel=1e-6)


@pytest.mark.parametrize("n", [0, 1, 15, 2.5, True])
def test_periodic_orbit_refuses_too_few_samples(n):
    # before: samples_per_period=0 returned amplitude 2.218 instead of 3.3166
    system, p = coulomb_forced()
    with pytest.raises(ValueError, match=r"`samples_per_period` must be an integer >= 16"):
        periodic_orbit(system, p, settings=hybrid.ShootingOptions(samples_per_period=n))
    with pytest.raises(ValueError, match=r"`samples_per_period` must be an integer >= 16"):
        continue_orbits(
            system, p, "Omega", (0.5, 0.6), settings=hybrid.ContinuationOptions(samples_per_period=n)
        )


def test_condition_of_a_fully_stuck_orbit_is_infinite_not_nan():
    # M = I (every state stays put): I - M = 0; before, cond came out 0/0 = NaN
    system = hybrid_models.coulomb()
    o = periodic_orbit(system, system.preset("free"))
    assert o.converged, o.message
    assert np.all(o.monodromy == np.eye(2))
    assert math.isinf(o.condition)
    assert "I - M vanishes" in o.message


def test_an_exception_of_the_progress_callback_propagates_unchanged():
    # before: reported as EVALUATION_FAILED, "evaluating the equations of mode ... failed"
    system, p = coulomb_forced()
    boom = ValueError("the caller's own bug")

    def progress(f):
        if f > 0.1:
            raise boom

    with pytest.raises(ValueError) as info:
        simulate(system, p, (0.0, 30.0), rest(system), progress=progress, throw=False)
    assert info.value is boom


def sign_relay():
    rhs = {"x": "v", "v": "-x - 0.1*v + cos(W*t)"}
    return HybridSystem(
        name="relay",
        variables=["x", "v"],
        parameters=["W"],
        modes=[Mode("up", derivatives=rhs), Mode("down", derivatives=rhs)],
        transitions=[
            Transition("up", "down", guard="sign(v)", direction=-1, name="fall"),
            Transition("down", "up", guard="sign(v)", direction=1, name="rise"),
        ],
        period="2*pi/W",
        initial_mode="up",
    )


def test_grazing_switch_is_not_converged_with_the_reason():
    # before: ZeroDivisionError from the saltation matrix out of periodic_orbit
    o = periodic_orbit(sign_relay(), {"W": 1.3}, {"x": 0.0, "v": 0.5}, "up")
    assert not o.converged
    assert o.reason == "grazing"
    assert o.message.startswith("grazing switch: ")
    assert "saltation matrix is undefined" in o.message
    br = continue_orbits(sign_relay(), {"W": 1.3}, "W", (1.3, 1.4), x0={"x": 0.0, "v": 0.5}, mode0="up")
    assert br.status == "stopped"
    assert "grazing switch" in br.message
    assert br.reason == "no-start"  # its first orbit is that failed one


def test_an_initial_state_out_of_range_is_refused_before_the_run():
    # before: `--x0 x1=1e308` raised OverflowError from the outputs after the run
    system = hybrid_models.absorber()
    p = system.preset("standard")
    x0 = {**rest(system), "x1": 1e308}
    with pytest.raises(ValueError, match=r"initial state cannot be evaluated: output `E` .*x1 = 1e\+308"):
        simulate(system, p, (0.0, 1.0), x0)
    with pytest.raises(ValueError, match=r"initial state cannot be evaluated"):
        periodic_orbit(system, p, x0)


# ----------------------------------------------------------------------------
# Messages that help
# ----------------------------------------------------------------------------
def test_a_strong_forcing_from_rest_is_integrated_with_a_small_first_step():
    # before: F = 100 failed at t = 0 with "Error tests failed too many times" (IDA's own first
    # step far too large); now the segment is restarted once with a small first step
    system = hybrid_models.absorber()
    o = periodic_orbit(
        system, system.preset("standard", F=100.0), settings=hybrid.ShootingOptions(transient_periods=2)
    )
    assert o.converged, o.message


@pytest.mark.slow
def test_orbit_at_an_undamped_resonance_says_no_bounded_orbit_and_what_to_try():
    # R = 0 at the resonance of the slipping (linear, undamped) system: no bounded orbit
    system = hybrid_models.absorber()
    o = periodic_orbit(
        system,
        system.preset("standard", R=0.0, Omega=0.8525006),
        settings=hybrid.ShootingOptions(newton=hybrid.NewtonOptions(max_iter=8)),
    )
    assert not o.converged
    assert o.reason == "resonance"
    assert o.message.startswith("no bounded periodic orbit near the guess: a Floquet multiplier is 1")
    assert "--transient" in o.message
    assert "--x0" in o.message
    # the cold-start fallback tried both sides: each branch grows without bound towards Omega
    assert o.route == "none"
    tried = o.message.split("fallback (continuation in the forcing parameter): ")[1]
    assert tried.count("the response grows without bound") == 2


def test_switches_decided_within_the_noise_of_the_guards_are_named():
    # c3 = 1e9: the breakaway guards' noise (~3 N) exceeds the band 2R = 1 N between them
    system = hybrid_models.absorber()
    p = system.preset("standard", c3=1e9)
    tr = simulate(system, p, (0.0, 10.0), rest(system), throw=False)
    assert tr.status == Status.NO_ADMISSIBLE_MODE
    assert "decided within the guards' noise levels" in tr.message
    assert "`breakaway-` of mode `stick`" in tr.message
    assert "tighten rtol/atol" in tr.message


def test_budget_check_projection_needs_a_minimum_of_evaluations():
    b = Budget(SolverOptions(max_steps=200), 0.0, 100.0)
    b.check(150, 1e-6)  # far too slow by rate, but the start of a run is slow: no projection
    with pytest.raises(BudgetExceeded, match=r"step limit reached: 200"):
        b.check(200, 1e-6)
