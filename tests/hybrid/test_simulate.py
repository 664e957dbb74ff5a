"""Event-driven simulation against closed forms, the pitfalls of notes/nonsmooth.md, and input checks.

Closed forms: harmonic and forced damped oscillators, a nonlinear index-1 DAE, the bouncing ball's
geometric series of impact times, the free Coulomb oscillator's decay by 2R/k per half cycle, a
variable that is differential in some modes and a slave variable in another.
"""

import math
import re

import numpy as np
import pytest
from problems import (
    TIGHT,
    bouncing_ball,
    chain_through_slave_mode,
    coulomb_free_exact,
    forced_oscillator,
    logistic,
    nonlinear_dae,
    oscillator,
    riccati,
    scaled_error,
    tracker,
)

import hybrid_models
from hybrid import (
    IDA,
    Exact,
    HybridSystem,
    Mode,
    SimulationError,
    SolverOptions,
    Status,
    Transition,
    initial_state,
    simulate,
)
from hybrid.model.compiled import CompiledSystem


# ----------------------------------------------------------------------------
# Helpers
# ----------------------------------------------------------------------------
def _guard_rate(cs, ev):
    """d/dt of the fired guard at the located state, along the source mode's flow."""
    cm = cs.modes[cs.mode_id(ev.source)]
    k = next(g.index for g in cm.guards if g.name == ev.guard)
    yp = cm.derivatives(ev.t, ev.x_minus)
    grad, gt = cm.guard_gradient(k, ev.t, ev.x_minus)
    return float(grad @ yp + gt), cm.guards[k].direction


def _check_located_events(system, params, events, residual=1e-10):
    """Every switch located by root finding lies on its guard and crosses it in its direction."""
    cs = CompiledSystem(system, params)
    located = [ev for ev in events if not ev.chained]
    for ev in located:
        assert abs(ev.guard_value) <= residual, ev
        rate, direction = _guard_rate(cs, ev)
        if direction:
            assert rate * direction > 0, (ev, rate)
    return located


# ----------------------------------------------------------------------------
# Smooth single-mode problems
# ----------------------------------------------------------------------------
def test_harmonic_oscillator_after_several_periods():
    system, params, x0, exact = oscillator(w=2.0)
    T = 2 * math.pi / params["w"]
    t_end = 7.3 * T
    t_eval = np.linspace(0.0, t_end, 30)
    tr = simulate(system, params, (0.0, t_end), x0, t_eval=t_eval, options=TIGHT)
    assert tr.status == Status.COMPLETED
    assert tr.success, tr.message
    assert np.array_equal(tr.t, t_eval)
    assert np.max(np.abs(tr.y - exact(t_eval))) <= 1e-8
    assert np.max(np.abs(tr.y_final - exact(t_end)[0])) <= 1e-8
    assert tr.t_final == t_end
    assert tr.mode_final == "free"
    # default sampling: every internal step lies on the exact solution too
    tr = simulate(system, params, (0.0, t_end), x0, options=TIGHT)
    assert tr.t[0] == 0.0
    assert tr.t[-1] == t_end
    assert np.all(np.diff(tr.t) > 0)
    assert np.max(np.abs(tr.y - exact(tr.t))) <= 1e-8


def test_index1_dae_with_closed_form_slave_variable():
    system, params, x0, exact = nonlinear_dae(x0=1.0)
    t_eval = np.linspace(0.0, 10.0, 101)
    tr = simulate(system, params, (0.0, 10.0), x0, t_eval=t_eval, options=TIGHT)
    assert tr.success
    assert tr["z"][0] == pytest.approx(1.0, rel=1e-14)  # z was omitted from x0 and solved
    assert np.max(np.abs(tr.y - exact(t_eval))) <= 1e-8
    # every sample satisfies the algebraic equation (not only to the integration tolerance)
    q = tr["x"] + np.sin(tr.t)
    assert np.max(np.abs(tr["z"] ** 3 + tr["z"] - q**3 - q)) <= 1e-13


@pytest.mark.parametrize(
    ("x0", "options"),
    [(1.5, TIGHT), (2.0, SolverOptions(method=IDA(rtol=1e-10, atol=1e-12)))],
    ids=["x0=1.5-TIGHT", "x0=2-rtol1e-10"],
)
def test_index1_dae_at_tight_tolerances_stays_accurate(x0, options):
    # Same DAE, other starts: measured (engines 0a53fb2, 1470c78) IDA stalls at steps of ~4e-6 near t = 5.5
    # with the engine's exact Jacobian; x0 = 1.5 ends with max_num_steps exhausted, x0 = 2 returns
    # success with an error of 2.3e-7 after ~85k residual calls (IDA's own difference-quotient
    # Jacobian: ~2k calls, error 3e-10).
    system, params, x0_, exact = nonlinear_dae(x0=x0)
    t_eval = np.linspace(0.0, 10.0, 101)
    tr = simulate(system, params, (0.0, 10.0), x0_, t_eval=t_eval, options=options, throw=False)
    assert tr.status == Status.COMPLETED, tr.message
    assert np.max(np.abs(tr.y - exact(t_eval))) <= 1e-8


@pytest.mark.parametrize("make", [riccati, logistic], ids=["riccati", "logistic"])
def test_nonlinear_scalar_odes(make):
    # f depends nonlinearly on the variable itself: the iteration matrix's diagonal is
    # cj - df/dx with a non-constant df/dx.
    system, params, x0, exact = make()
    t_eval = np.linspace(0.0, 5.0, 26)
    tr = simulate(system, params, (0.0, 5.0), x0, t_eval=t_eval, options=TIGHT, throw=False)
    assert tr.status == Status.COMPLETED, tr.message
    assert scaled_error(tr.y, exact(t_eval), rtol=1e-8, atol=1e-12) <= 1.0


def test_forced_oscillator_is_not_aliased_over_1000_periods():
    # Pitfall (iii): from rest, IDA without a step bound steps one forcing period at a time and
    # returns x == 0. The model declares its period, so the default max_step is T/16.
    system, params, x0, exact = forced_oscillator()
    T = 2 * math.pi / params["Omega"]
    t_end = 1000.3 * T
    tr = simulate(system, params, (0.0, t_end), x0, samples_per_period=1)
    assert tr.success
    want = exact(t_end)[0]
    scale = exact.amplitude * np.array([1.0, params["Omega"]])  # amplitudes of x and v
    assert abs(tr.final("x")) > 0.1 * exact.amplitude  # not the aliased x == 0
    assert np.all(np.abs(tr.y_final - want) <= 1e-6 * scale)
    # the samples of the last periods follow the steady state too
    last = tr.t > t_end - 5 * T
    assert np.all(np.abs(tr.y[last] - exact(tr.t[last])) <= 1e-6 * scale)


# ----------------------------------------------------------------------------
# Bouncing ball: geometric series of impact times, Zeno
# ----------------------------------------------------------------------------
@pytest.mark.filterwarnings("ignore:guard `impact` of mode `fly` crossed zero:RuntimeWarning")
@pytest.mark.parametrize("e", [0.5, 0.8])
def test_bouncing_ball_impact_times_form_the_geometric_series(e):
    system, params, x0, exact = bouncing_ball(e=e)
    tr = simulate(system, params, (0.0, 10.0), x0, throw=False)
    assert tr.status == Status.ZENO
    assert not tr.success
    assert "Zeno" in tr.message
    located = [ev for ev in tr.events if not ev.chained]
    # Impacts whose rebound rises well above the guard's noise level (~1e-9 m): speed >= 1e-3 m/s,
    # apex >= 5e-8 m. (Below it the ball never leaves the noise band, the guard stays disarmed and the
    # engine switches, with a RuntimeWarning, at the end of the step where h < -noise: |h| ~ 1e-8 and
    # the time off by ~3e-5 s, for the last switch before the Zeno stop.)
    k = np.arange(1, len(located) + 1)
    resolved = e ** (k - 1) * params["g"] * exact.impact_time(1) >= 1e-3
    assert resolved.sum() >= 13
    assert np.all(resolved[: resolved.sum()])
    _check_located_events(system, params, [ev for ev, r in zip(located, resolved, strict=True) if r])
    ts = np.array([ev.t for ev in located])
    assert np.max(np.abs(ts[resolved] - exact.impact_time(k[resolved]))) <= 1e-9
    for ev in located:
        assert ev.source == ev.target == "fly"
        assert ev.guard == "impact"
        assert ev.x_minus[1] < 0  # falling
        assert ev.x_plus[1] == -e * ev.x_minus[1]  # reset applied exactly
        assert ev.x_plus[0] == ev.x_minus[0]
        assert abs(ev.guard_value) <= 1e-7
    # switches pile up at the Zeno time t_1 (1 + e)/(1 - e), never beyond it
    assert max(ev.t for ev in tr.events) <= exact.zeno_time + 1e-4
    assert tr.events[-1].t >= exact.zeno_time - 1e-3


@pytest.mark.parametrize("v0", [2.0, -2.0])
def test_guard_at_zero_at_the_start_is_decided_by_the_flow(v0):
    # h = 0 at t0: rising (v0 > 0) the impact guard leaves zero on its safe side and stays disarmed
    # until the ball comes down at 2 v0/g; falling (v0 < 0) the impact is taken at once (chained).
    system, params, _, _ = bouncing_ball(e=0.5)
    g, e = params["g"], params["e"]
    t_end = 0.6 if v0 > 0 else 0.4  # before the Zeno times 0.82 and 0.41
    tr = simulate(system, params, (0.0, t_end), {"h": 0.0, "v": v0}, options=TIGHT)
    if v0 > 0:
        assert tr.events[0].t == pytest.approx(2 * v0 / g, abs=1e-12)
        assert not tr.events[0].chained
    else:
        first, second = tr.events[:2]
        assert (first.t, first.chained) == (0.0, True)
        assert first.x_plus[1] == -e * v0
        assert second.t == pytest.approx(2 * e * abs(v0) / g, abs=1e-12)
        assert not second.chained


def test_ball_at_rest_on_the_ground_is_a_zeno_point():
    system, params, _, _ = bouncing_ball()
    tr = simulate(system, params, (0.0, 1.0), {"h": 0.0, "v": 0.0}, throw=False)
    assert tr.status == Status.ZENO
    assert "t=0.0" in tr.message


def test_two_way_guard_fires_at_every_crossing_but_not_where_it_starts():
    # direction 0: x crosses zero at t = (k + 1/2) pi / w from x = cos(w t); started at x = 0
    # (v0 = w), the crossings are at k pi / w, the one at t0 excluded.
    w = 3.0
    for x0, v0, first in ((1.0, 0.0, 0.5), (0.0, w, 1.0)):
        system = HybridSystem(
            name="cross",
            variables=["x", "v"],
            parameters=["w"],
            modes=[Mode("m", derivatives={"x": "v", "v": "-w**2*x"})],
            transitions=[Transition("m", "m", "x", 0, name="zero")],
        )
        tr = simulate(system, {"w": w}, (0.0, 4.0), {"x": x0, "v": v0}, "m", options=TIGHT)
        ts = np.array([ev.t for ev in tr.events])
        want = (first + np.arange(ts.size)) * math.pi / w
        assert ts.size == int(4.0 * w / math.pi - first) + 1
        assert np.max(np.abs(ts - want)) <= 1e-10
        assert not any(ev.chained for ev in tr.events)
        assert max(abs(ev.guard_value) for ev in tr.events) <= 1e-10


@pytest.mark.filterwarnings("ignore:guard `impact` of mode `fly` crossed zero:RuntimeWarning")
def test_bouncing_ball_zeno_is_detected_at_tight_tolerances():
    # With TIGHT tolerances the noise band of the guard is ~1e-12 m: past the Zeno time the ball
    # must still be stopped as Zeno, not chatter through the band (measured on 1470c78: a switch
    # every ~1.2e-6 s, each taken at a step end with a speed set by the band, never 20 within the
    # default Zeno window of 1.5e-6 s; the run returns COMPLETED after 75k switches for t1 = 0.5).
    system, params, x0, exact = bouncing_ball(e=0.5)
    tr = simulate(system, params, (0.0, 1.5), x0, options=TIGHT, throw=False, max_transitions=300)
    assert tr.status == Status.ZENO, (tr.status, tr.n_transitions, tr.events[-1].t, exact.zeno_time)
    assert tr.events[-1].t <= exact.zeno_time + 1e-4


@pytest.mark.filterwarnings("ignore:guard `impact` of mode `fly` crossed zero:RuntimeWarning")
def test_bouncing_ball_zeno_raises_when_throw():
    system, params, x0, _ = bouncing_ball()
    with pytest.raises(SimulationError, match=r"Zeno"):
        simulate(system, params, (0.0, 10.0), x0)


def test_bouncing_ball_samples_between_impacts():
    system, params, x0, exact = bouncing_ball(e=0.5)
    t_end = 1.3  # before the Zeno time 1.3546
    t_eval = np.linspace(0.0, t_end, 200)
    tr = simulate(system, params, (0.0, t_end), x0, t_eval=t_eval, options=TIGHT)
    assert tr.success, tr.message
    assert tr.n_transitions == 5
    assert np.max(np.abs(tr.y - exact(t_eval))) <= 1e-9


@pytest.mark.filterwarnings("ignore:guard `impact` of mode `fly` crossed zero:RuntimeWarning")
def test_time_reached_is_not_before_the_last_switch_when_a_run_stops_early():
    # After a Zeno stop or MAX_TRANSITIONS the trajectory must report where it stopped:
    # t_final ("time reached") cannot precede a switch that was logged.
    system, params, x0, exact = bouncing_ball(e=0.5)
    tr = simulate(system, params, (0.0, 10.0), x0, throw=False)
    assert tr.status == Status.ZENO
    assert tr.t_final >= tr.events[-1].t
    tr = simulate(system, params, (0.0, 10.0), x0, throw=False, max_transitions=3)
    assert tr.status == Status.MAX_TRANSITIONS
    assert "raise `max_transitions`" in tr.message
    assert tr.t_final >= tr.events[-1].t


@pytest.mark.filterwarnings("ignore:guard `impact` of mode `fly` crossed zero:RuntimeWarning")
def test_max_transitions_zero_stops_at_the_first_switch():
    system, params, x0, exact = bouncing_ball()
    with pytest.raises(SimulationError, match=r"stopped after 0 transitions"):
        simulate(system, params, (0.0, 10.0), x0, max_transitions=0)


def test_taylor_series_of_a_negative_base_power_in_a_mode():
    # The ball with a negligible extra force c (h - L)**-2 (L above the ball, so the base is negative):
    # at every impact the engine expands the new mode's flow in Taylor series, which must handle it.
    system = HybridSystem(
        name="ball2",
        variables=["h", "v"],
        parameters=["g", "e", "c", "L"],
        modes=[Mode("fly", derivatives={"h": "v", "v": "-g + c*(h - L)**-2"})],
        transitions=[Transition("fly", "fly", guard="h", direction=-1, name="impact", reset={"v": "-e*v"})],
    )
    _, params, x0, exact = bouncing_ball(e=0.5)
    tr = simulate(system, {**params, "c": 1e-14, "L": 5.0}, (0.0, 1.3), x0, "fly", options=TIGHT)
    ts = np.array([ev.t for ev in tr.events])
    assert ts.size == 5
    assert np.max(np.abs(ts - exact.impact_time(np.arange(1, 6)))) <= 1e-9


# ----------------------------------------------------------------------------
# Coulomb oscillator: the successor mode is decided by the vector field (pitfall ii)
# ----------------------------------------------------------------------------
def test_free_coulomb_oscillator_decays_by_2R_over_k_and_sticks():
    system = hybrid_models.coulomb()
    params = system.preset("free")  # m = k = 1, R = 0.1, F = 0
    x0 = 1.05
    turning, exact = coulomb_free_exact(params, x0)
    assert len(turning) == 6  # 1.05, -0.85, 0.65, -0.45, 0.25, -0.05 (stuck: |x| <= R/k)
    t_end = 20.0
    tr = simulate(system, params, (0.0, t_end), {"x": x0, "v": 0.0}, "stick", options=TIGHT)
    assert tr.success, tr.message
    assert tr.mode_final == "stick"
    located = _check_located_events(system, params, tr.events)
    # released in stick where k x > R: slip- is taken at once (chained at t0)
    first = tr.events[0]
    assert (first.t, first.source, first.target, first.chained) == (0.0, "stick", "slip-", True)
    # every velocity zero is located (slip -> stick) ...
    assert [ev.source for ev in located] == ["slip-", "slip+", "slip-", "slip+", "slip-"]
    assert all(ev.target == "stick" for ev in located)
    for n, ev in enumerate(located, start=1):
        tn, xn = turning[n]
        assert ev.t == pytest.approx(tn, abs=1e-9)
        assert ev.x_plus[0] == pytest.approx(xn, abs=1e-9)
        assert ev.x_plus[1] == 0.0
    # ... and where |k x| > R the stick mode is left at the same instant, for the opposite slip
    chained = [ev for ev in tr.events[1:] if ev.chained]
    assert len(chained) == 4
    for ev, prev in zip(chained, located[:4], strict=True):
        assert ev.t == prev.t
        assert ev.source == "stick"
        assert ev.target == ("slip+" if prev.source == "slip-" else "slip-")
        assert np.array_equal(ev.x_minus, prev.x_plus)
    # where |k x| <= R it stays in stick for good
    assert tr.n_transitions == 1 + 5 + 4
    assert tr.final("x") == pytest.approx(turning[-1][1], abs=1e-9)
    assert tr.final("v") == 0.0
    # the whole trajectory, with the work and dissipation quadratures
    t_eval = np.linspace(0.0, t_end, 400)
    tr = simulate(system, params, (0.0, t_end), {"x": x0, "v": 0.0}, "stick", t_eval=t_eval, options=TIGHT)
    assert np.max(np.abs(tr.y - exact(t_eval))) <= 1e-8
    # mode intervals: slip phases of exactly pi, then stick
    iv = tr.mode_intervals()
    assert [m for _, _, m in iv] == ["slip-", "slip+", "slip-", "slip+", "slip-", "stick"]
    assert np.allclose([b - a for a, b, _ in iv[:-1]], math.pi, rtol=0, atol=1e-9)
    assert iv[-1][1] == t_end


@pytest.mark.parametrize(("x0", "n_events"), [(0.1, 0), (-0.1, 0), (0.0999, 0), (0.12, 2)])
def test_coulomb_at_the_friction_limit(x0, n_events):
    # |k x0| <= R: static friction holds for ever (the guard k x -+ R starts at zero and stays there
    # for x0 = +-R/k). Slightly beyond: one slip of half a period to 2R/k - x0, then stick.
    system = hybrid_models.coulomb()
    params = system.preset("free")
    tr = simulate(system, params, (0.0, 10.0), {"x": x0, "v": 0.0}, "stick", options=TIGHT)
    assert tr.success, tr.message
    assert tr.n_transitions == n_events
    assert tr.mode_final == "stick"
    if n_events == 0:
        assert set(tr.mode) == {"stick"}
        assert np.all(tr["x"] == x0)
        assert np.all(tr["v"] == 0.0)
    else:
        assert tr.events[0].chained
        assert tr.events[0].t == 0.0
        assert tr.events[0].target == "slip-"
        assert tr.events[1].t == pytest.approx(math.pi, abs=1e-9)
        assert tr.final("x") == pytest.approx(0.2 - x0, abs=1e-9)


@pytest.mark.parametrize(("t0", "direction"), [(0.0, "slip+"), (math.pi / 0.8, "slip-")])
def test_vector_field_selects_the_slip_direction_when_both_guards_are_zero(t0, direction):
    # R = 0 at x = 0 and sin(Omega t0) = 0: both breakaway guards k x - F sin(Omega t) -+ R are 0.
    # Only the force's derivative tells the direction (sin rises after t0 = 0, falls after pi/Omega).
    # With R = 0 the motion is the linear forced oscillator x'' + x = F sin(Omega t) from rest.
    system = hybrid_models.coulomb()
    params = system.preset("forced", R=0.0)  # m = k = 1, F = 0.5, Omega = 0.8
    F, W = params["F"], params["Omega"]
    t_end = t0 + 20.0
    t_eval = np.linspace(t0, t_end, 101)
    tr = simulate(system, params, (t0, t_end), {"x": 0.0, "v": 0.0}, "stick", t_eval=t_eval, options=TIGHT)
    first = tr.events[0]
    assert (first.t, first.source, first.target, first.chained) == (t0, "stick", direction, True)

    def xp(s):
        return F / (1 - W**2) * np.sin(W * s)

    def vp(s):
        return F * W / (1 - W**2) * np.cos(W * s)

    A, B = -xp(t0), -vp(t0)
    x = xp(t_eval) + A * np.cos(t_eval - t0) + B * np.sin(t_eval - t0)
    v = vp(t_eval) - A * np.sin(t_eval - t0) + B * np.cos(t_eval - t0)
    assert np.max(np.abs(tr["x"] - x)) <= 1e-8
    assert np.max(np.abs(tr["v"] - v)) <= 1e-8
    # at every later velocity zero the mass passes through stick at the same instant
    for ev in tr.events[1:]:
        if ev.target == "stick":
            assert not ev.chained
        else:
            assert ev.chained
            assert ev.source == "stick"


def test_guard_with_two_crossings_within_one_natural_step_is_detected():
    # Pitfall (iv): in stick the state is constant, so IDA's error control allows any step, while
    # the breakaway guard k x - F sin(Omega t) + R is negative only for |Omega t - pi/2| < acos(R/F)
    # (0.31 rad for F = 1.05 R). The default max_step T/16 (0.39 rad) bounds the step below that.
    system = hybrid_models.coulomb()
    params = system.preset("forced", F=0.105, R=0.1)
    W, F, R = params["Omega"], params["F"], params["R"]
    T = 2 * math.pi / W
    t_first = math.asin(R / F) / W
    tr = simulate(system, params, (0.0, 2 * T), {"x": 0.0, "v": 0.0}, "stick")
    ev = tr.events[0]
    assert (ev.source, ev.target, ev.guard) == ("stick", "slip+", "breakaway+")
    assert ev.t == pytest.approx(t_first, abs=1e-9)
    _check_located_events(system, params, tr.events)
    # the premise: the window is wider than the default step bound, and nothing else bounds the step
    assert 2 * math.acos(R / F) / W > T / 16
    cs = CompiledSystem(system, params)
    assert np.all(cs.modes[cs.mode_id("stick")].rhs(0.3, np.array([0.0, 0.0, 0.0, 0.0]))[:2] == 0.0)


# ----------------------------------------------------------------------------
# The dampers: guards at zero at a restart do not re-fire (pitfall i); consistent re-initialisation
# ----------------------------------------------------------------------------
DAMPERS = [
    ("absorber", "fig3a", {"x1": 0.0, "v1": 0.0, "x2": 0.0, "v2": 0.0, "u": 0.0}),
    ("absorber", "standard", {"x1": 5.0, "v1": 0.0, "x2": 5.0, "v2": 0.0, "u": 5.0}),
    ("isolator", "fig4a", {"x1": 0.0, "v1": 0.0, "x2": 0.0, "v2": 0.0, "u": 0.0}),
]


def _slave_residual(name, p, x, target):
    """The slip modes' algebraic equation on a state (s = +1 for slip+, -1 for slip-)."""
    s = 1.0 if target == "slip+" else -1.0
    x1, _, x2, _, u = x[:5]
    if name == "absorber":
        return (p["c2"] + p["c3"]) * u - p["c2"] * x1 - p["c3"] * x2 - p["R"] * s
    return (p["c1"] + p["c3"]) * u - p["c1"] * x1 + p["R"] * s


def _H(name, p, x):
    x1, _, x2, _, u = x[:5]
    if name == "absorber":
        return p["c2"] * (u - x1) - p["c3"] * (x2 - u)
    return p["c1"] * (x1 - u) - p["c3"] * u


@pytest.fixture(scope="module", params=DAMPERS, ids=[f"{n}-{p}" for n, p, _ in DAMPERS])
def damper_run(request):
    name, preset, x0 = request.param
    system = hybrid_models.BUILTIN[name]()
    p = system.preset(preset)
    T = 2 * math.pi / p["Omega"]
    tr = simulate(system, p, (0.0, 20 * T), x0, "stick", samples_per_period=8)
    return name, system, p, tr


def test_damper_guards_at_zero_after_stick_entry_do_not_refire(damper_run):
    name, system, p, tr = damper_run
    assert tr.success, tr.message
    assert tr.n_transitions >= 20
    kinds = {ev.guard for ev in tr.events}
    assert kinds == {"breakaway+", "breakaway-", "stop+", "stop-"}
    _check_located_events(system, p, tr.events)
    events = tr.events
    for a, b in zip(events, events[1:], strict=False):
        if b.t == a.t:  # no two switches share a time unless chained
            assert b.chained, (a, b)
        assert b.t >= a.t
        if a.target == "stick":
            # the breakaway guard H -+ R of the slip just ended starts at zero: it is disarmed and
            # the next switch is a genuine breakaway later on (rounding flicker fires ~5e-8 later)
            assert abs(_H(name, p, a.x_plus) - (p["R"] if a.source == "slip+" else -p["R"])) <= 1e-9
            assert b.source == "stick"
            assert b.guard.startswith("breakaway")
            assert not b.chained, (a, b)
            assert b.t - a.t > 1e-3, (a, b)


def test_damper_slave_variable_is_consistent_after_every_switch_into_slip(damper_run):
    name, system, p, tr = damper_run
    into_slip = [ev for ev in tr.events if ev.target.startswith("slip")]
    assert len(into_slip) >= 10
    for ev in into_slip:
        assert abs(_slave_residual(name, p, ev.x_plus, ev.target)) <= 1e-12, ev
    # and at every sample in a slip mode
    for mode in ("slip+", "slip-"):
        sel = tr.mode == mode
        res = [_slave_residual(name, p, y, mode) for y in tr.y[sel]]
        assert np.max(np.abs(res)) <= 1e-12
    # u is continuous where it is a differential variable: at slip -> stick it keeps its value
    for ev in tr.events:
        if ev.target == "stick":
            assert ev.x_plus[4] == ev.x_minus[4]


def test_variable_differential_in_one_mode_and_slave_in_another():
    system, params, x0, exact = tracker()
    t_end = 4.0
    tr = simulate(system, params, (0.0, t_end), x0, options=TIGHT)
    assert tr.success
    assert [(ev.source, ev.target) for ev in tr.events] == [("hold1", "track"), ("track", "hold2")]
    on, off = tr.events
    assert on.t == pytest.approx(params["t_on"], abs=1e-12)
    assert off.t == pytest.approx(params["t_off"], abs=1e-12)
    assert on.x_minus[2] == pytest.approx(2.0 * math.exp(-params["a"] * params["t_on"]), rel=1e-9)
    assert on.x_plus[2] == on.x_plus[0]  # re-solved in `track`: u = x
    assert on.x_plus[0] == pytest.approx(math.cos(on.t), abs=1e-9)
    assert off.x_plus[2] == off.x_minus[2]  # continuous into `hold2`
    want = exact(tr.t)
    hold1 = tr.mode == "hold1"  # the sample just before the switch at t_on is still in hold1
    want[hold1, 2] = 2.0 * np.exp(-params["a"] * tr.t[hold1])
    assert np.max(np.abs(tr.y - want)) <= 1e-8
    assert tr.final("u") == pytest.approx(math.cos(2.5) * math.exp(-params["a"] * 1.5), abs=1e-9)
    track = tr.mode == "track"
    assert track.sum() > 5
    assert np.max(np.abs(tr["u"][track] - tr["x"][track])) <= 1e-14


def test_chained_switch_records_have_consistent_post_switch_states():
    # TransitionRecord.x_plus: "reset applied, slave variables re-solved in the new mode"; in a
    # chain A -> B -> C the record A -> B must hold B's consistent state, the state B -> C leaves from.
    system, params, x0, exact = chain_through_slave_mode()
    tr = simulate(system, params, (0.0, 2.0), x0)
    ab, bc = tr.events
    assert (ab.source, ab.target, ab.chained) == ("A", "B", False)
    assert (bc.source, bc.target, bc.chained) == ("B", "C", True)
    assert ab.t == pytest.approx(1.0, abs=1e-12)
    assert bc.t == ab.t
    assert bc.x_minus[1] == 2.0
    assert np.array_equal(ab.x_plus, bc.x_minus), (ab.x_plus, bc.x_minus)
    assert np.allclose(tr.y_final, exact(2.0)[0], rtol=0, atol=1e-12)


def test_mode_loop_at_one_instant_is_no_admissible_mode():
    system = HybridSystem(
        name="loop",
        variables=["x"],
        parameters=[],
        modes=[Mode("A", derivatives={"x": "1"}), Mode("B", derivatives={"x": "1"})],
        transitions=[Transition("A", "B", "x - 1", 1), Transition("B", "A", "x - 0.5", 1)],
    )
    tr = simulate(system, {}, (0.0, 1.0), {"x": 2.0}, "A", throw=False)
    assert tr.status == Status.NO_ADMISSIBLE_MODE
    assert "no admissible mode at t=0.0" in tr.message
    assert "A -> B -> A" in tr.message
    with pytest.raises(SimulationError, match=r"no admissible mode"):
        simulate(system, {}, (0.0, 1.0), {"x": 2.0}, "A")


def test_unsolvable_algebraic_equation_is_reported():
    system = HybridSystem(
        name="noroot",
        variables=["x", "z"],
        parameters=[],
        modes=[Mode("m", derivatives={"x": "1"}, algebraic={"z": "z**2 + 1"})],
        transitions=[],
    )
    tr = simulate(system, {}, (0.0, 1.0), {"x": 0.0}, "m", throw=False)
    assert tr.status == Status.ALGEBRAIC_FAILED
    assert "mode `m`" in tr.message


# ----------------------------------------------------------------------------
# Sampling and the Trajectory API
# ----------------------------------------------------------------------------
def test_samples_per_period_and_event_samples():
    system = hybrid_models.coulomb()
    params = system.preset("forced")
    T = 2 * math.pi / params["Omega"]
    t_end = 3.25 * T
    tr = simulate(system, params, (0.0, t_end), {"x": 0.0, "v": 0.0}, "stick", samples_per_period=8)
    want = np.arange(27) * T / 8  # the last one is t_end = 26 T/8
    assert np.allclose(tr.t, want, rtol=0, atol=1e-12)
    tr2 = simulate(
        system, params, (0.0, t_end), {"x": 0.0, "v": 0.0}, "stick", samples_per_period=8, include_events=True
    )
    located = [ev for ev in tr2.events if not ev.chained]
    assert any(ev.chained for ev in tr2.events)
    assert tr2.t.size == want.size + 2 * len(located)  # before and after each instant of switching
    for ev in located:
        at = np.flatnonzero(tr2.t == ev.t)
        last = [e for e in tr2.events if e.t == ev.t][-1]
        assert at.size == 2
        assert np.array_equal(tr2.y[at[0]], ev.x_minus)
        assert np.array_equal(tr2.y[at[1]], last.x_plus)
        assert (tr2.mode[at[0]], tr2.mode[at[1]]) == (ev.source, last.target)
    # the samples on the grid are the same with or without event samples
    grid = np.isin(tr2.t, tr.t) & ~np.isin(tr2.t, [ev.t for ev in tr2.events])
    assert np.allclose(tr2.y[grid], tr.y, rtol=0, atol=1e-12)


def test_trajectory_accessors_and_progress():
    system, params, x0, exact = oscillator()
    seen = []
    tr = simulate(system, params, (0.0, 3.0), x0, progress=seen.append)
    assert seen[-1] == 1.0
    assert all(0.0 <= f <= 1.0 for f in seen)
    assert seen == sorted(seen)
    assert np.array_equal(tr["x"], tr.y[:, 0])
    assert np.array_equal(tr["v"], tr.y[:, 1])
    with pytest.raises(KeyError, match=r"no variable or output `q`; have: x, v"):
        tr["q"]
    assert tr.final("x") == tr.y_final[0]
    assert tr.params == params
    assert tr.system is system
    assert tr.n_transitions == 0
    assert tr.mode_intervals() == [(0.0, 3.0, "free")]
    assert "COMPLETED" in repr(tr)
    # outputs of the built-in models are recorded with the samples
    c = hybrid_models.coulomb()
    p = c.preset("free")
    tr = simulate(c, p, (0.0, 4.0), {"x": 1.05, "v": 0.0}, "stick", options=TIGHT)
    assert np.allclose(tr["E"], 0.5 * tr["v"] ** 2 + 0.5 * tr["x"] ** 2, rtol=1e-14, atol=0)
    assert np.allclose(tr["E"] + tr["D"], 0.5 * 1.05**2, rtol=0, atol=1e-9)  # energy balance


def test_per_variable_atol_and_initial_state():
    system, params, x0, exact = oscillator()
    opts = SolverOptions(method=IDA(rtol=1e-11, atol={"x": 1e-13}, atol_default=1e-13))
    tr = simulate(system, params, (0.0, 3.0), x0, t_eval=[3.0], options=opts)
    assert np.max(np.abs(tr.y_final - exact(3.0)[0])) <= 1e-9
    with pytest.raises(ValueError, match=r"`atol` names unknown variable\(s\) \['q'\]"):
        simulate(system, params, (0.0, 3.0), x0, options=SolverOptions(method=IDA(atol={"q": 1e-9})))
    assert np.array_equal(initial_state(system, [1.0, 2.0]), [1.0, 2.0])
    dae, _, _, _ = nonlinear_dae()
    assert np.array_equal(initial_state(dae, {"x": 3.0}, "only"), [3.0, 0.0])


# ----------------------------------------------------------------------------
# Input validation
# ----------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        (dict(rtol=0), r"`rtol` must be a finite number > 0, got 0"),
        (dict(rtol=-1e-8), r"`rtol` must be a finite number > 0"),
        (dict(rtol=1e-1), r"`rtol` must lie in \[1e-14, 1e-2\], got 0.1"),
        (dict(rtol=1e-15), r"`rtol` must lie in"),
        (dict(rtol=float("nan")), r"`rtol` must be a finite number > 0"),
        (dict(atol=-1e-10), r"`atol` must be a finite number > 0, got -1e-10"),
        (dict(atol=0.0), r"`atol` must be a finite number > 0"),
        (dict(atol={"x": -1.0}), r"`atol\['x'\]` must be a finite number > 0"),
        (dict(atol_default=0), r"`atol_default` must be a finite number > 0"),
        (dict(guard_noise=-1), r"`guard_noise` must be a finite number > 0"),
        (dict(max_num_steps=0), r"`max_num_steps` must be an integer >= 1, got 0"),
        (dict(max_num_steps=10.5), r"`max_num_steps` must be an integer >= 1"),
    ],
)
def test_ida_settings_are_validated(kwargs, match):
    with pytest.raises(ValueError, match=r"IDA: " + match):
        IDA(**kwargs)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        (dict(max_step=0.0), r"`max_step` must be a finite number > 0, got 0.0"),
        (dict(max_step=-1.0), r"`max_step` must be a finite number > 0"),
        (dict(max_step=float("inf")), r"`max_step` must be a finite number > 0"),
        (dict(zeno_window=0), r"`zeno_window` must be a finite number > 0"),
        (dict(zeno_count=True), r"`zeno_count` must be an integer >= 1, got True"),
        (dict(max_chain=0), r"`max_chain` must be an integer >= 1"),
        (dict(taylor_order=1), r"`taylor_order` must be >= 2"),
        (dict(method="exact"), r"`method` must be an integration method such as hybrid.IDA"),
    ],
)
def test_solver_options_are_validated(kwargs, match):
    with pytest.raises((ValueError, TypeError), match=r"SolverOptions: " + match):
        SolverOptions(**kwargs)


def test_solver_options_reject_unknown_keywords():
    with pytest.raises(TypeError, match=r"max_step_count"):
        SolverOptions(max_step_count=1)


# issue 29: the old spelling (tolerances and the integrator's name on SolverOptions) is refused
# with the new one in the message
@pytest.mark.parametrize(
    ("kwargs", "new"),
    [
        (dict(rtol=1e-9), "SolverOptions(method=IDA(rtol=1e-09))"),
        (dict(rtol=1e-9, atol=1e-11), "SolverOptions(method=IDA(rtol=1e-09, atol=1e-11))"),
        (dict(integrator="exact"), "SolverOptions(method=Exact())"),
        (dict(integrator="exact", rtol=1e-10, atol=1e-12), "SolverOptions(method=Exact())"),
        (dict(integrator="ida", max_num_steps=10), "SolverOptions(method=IDA(max_num_steps=10))"),
    ],
)
def test_the_old_spelling_of_solver_options_prints_the_new_one(kwargs, new):
    with pytest.raises(TypeError, match=re.escape(new)):
        SolverOptions(**kwargs)


def test_the_exact_method_refuses_tolerances_it_does_not_use():
    with pytest.raises(TypeError, match=r"Exact: `rtol` does not apply: the exact flow has no tolerances"):
        Exact(rtol=1e-9)
    with pytest.raises(TypeError, match=r"IDA: no setting 'max_steps'"):
        IDA(max_steps=10)


def test_a_method_owns_its_settings_and_prints_them():
    opts = SolverOptions(method=IDA(rtol=1e-9, atol={"x": 1e-12}))
    assert opts.method.settings() == {
        "name": "ida",
        "rtol": 1e-9,
        "atol": {"x": 1e-12},
        "atol_default": 1e-10,
        "max_num_steps": 50_000,
        "guard_noise": 10.0,
    }
    assert "IDA(rtol=1e-09" in repr(opts)
    assert SolverOptions(method=Exact()).method.settings() == {"name": "exact", "guard_noise": 10.0}
    assert hash(SolverOptions(method=IDA(rtol=1e-9))) == hash(SolverOptions(method=IDA(rtol=1e-9)))


@pytest.mark.parametrize(
    ("args", "kwargs", "error", "match"),
    [
        (((1.0, 1.0), None), {}, ValueError, r"`t_span` must be finite with t1 > t0, got \(1.0, 1.0\)"),
        (((2.0, 1.0), None), {}, ValueError, r"t1 > t0"),
        (((0.0, math.inf), None), {}, ValueError, r"`t_span` must be finite"),
        (((0.0,), None), {}, ValueError, r"`t_span` must be two numbers"),
        (((0.0, "a"), None), {}, ValueError, r"`t_span` must be two numbers"),
        (((0.0, 1.0), {"x": math.nan, "v": 0.0}), {}, ValueError, r"initial state is not finite for x"),
        (((0.0, 1.0), [0.0, math.inf]), {}, ValueError, r"initial state is not finite for v"),
        (
            ((0.0, 1.0), {"x": 1.0, "v": 0.0, "q": 1.0}),
            {},
            ValueError,
            r"initial state names unknown variable\(s\) q",
        ),
        (((0.0, 1.0), {"x": 1.0}), {}, ValueError, r"initial state lacks variable\(s\) v"),
        (
            ((0.0, 1.0), [1.0, 2.0, 3.0]),
            {},
            ValueError,
            r"initial state has 3 values; model `oscillator` has 2",
        ),
        (((0.0, 1.0), None, "glide"), {}, ValueError, r"model `oscillator` has no mode `glide`; modes: free"),
        (
            ((0.0, 1.0), None),
            dict(t_eval=[0.5, 1.5]),
            ValueError,
            r"`t_eval` must be increasing and lie within t_span",
        ),
        (
            ((0.0, 1.0), None),
            dict(t_eval=[-0.5, 0.5]),
            ValueError,
            r"`t_eval` must be increasing and lie within",
        ),
        (((0.0, 1.0), None), dict(t_eval=[0.6, 0.5]), ValueError, r"`t_eval` must be increasing"),
        (
            ((0.0, 1.0), None),
            dict(t_eval=[]),
            ValueError,
            r"`t_eval` must be a non-empty array of finite times",
        ),
        (
            ((0.0, 1.0), None),
            dict(samples_per_period=4),
            ValueError,
            r"`samples_per_period` needs a model with a forcing period",
        ),
        (
            ((0.0, 1.0), None),
            dict(t_eval=[0.5], samples_per_period=4),
            ValueError,
            r"give `t_eval` or `samples_per_period`, not both",
        ),
        (
            ((0.0, 1.0), None),
            dict(max_transitions=-1),
            ValueError,
            r"`max_transitions` must be an integer >= 0",
        ),
        (((0.0, 1.0), None), dict(options={"rtol": 1e-6}), TypeError, r"`options` must be a SolverOptions"),
    ],
)
def test_simulate_rejects_bad_input_before_integrating(args, kwargs, error, match):
    system, params, x0, _ = oscillator()
    span, state, *mode = args
    with pytest.raises(error, match=match):
        simulate(system, params, span, x0 if state is None else state, *mode, **kwargs)


def test_simulate_rejects_bad_system_params_and_mode():
    system, params, x0, _ = oscillator()
    with pytest.raises(TypeError, match=r"`system` must be a HybridSystem"):
        simulate("oscillator", params, (0.0, 1.0), x0)
    with pytest.raises(TypeError, match=r"`params` must be a mapping"):
        simulate(system, [2.0], (0.0, 1.0), x0)
    with pytest.raises(ValueError, match=r"model `oscillator` has no parameter `q`"):
        simulate(system, {"w": 1.0, "q": 1.0}, (0.0, 1.0), x0)
    with pytest.raises(ValueError, match=r"missing value for parameter\(s\) w"):
        simulate(system, {}, (0.0, 1.0), x0)
    with pytest.raises(ValueError, match=r"parameter `w` must be > 0"):
        simulate(system, {"w": 0.0}, (0.0, 1.0), x0)
    no_initial = HybridSystem(
        name="plain",
        variables=["x"],
        parameters=[],
        modes=[Mode("m", derivatives={"x": "1"})],
        transitions=[],
    )
    with pytest.raises(
        ValueError, match=r"`mode0` is required: model `plain` declares no initial mode; modes: m"
    ):
        simulate(no_initial, {}, (0.0, 1.0), {"x": 0.0})


@pytest.mark.parametrize("x0", [0.1, 0.3, 0.5, 0.7])
def test_a_switch_on_a_requested_sample_time_is_sampled_after_it(x0):
    """Found with issue 22: a switch at a time of ``t_eval`` (or within rounding before it) left
    that sample to the next mode's IDA run, which refused a time that close to its start (IDA flag
    -60, "tout too close to t0"): x' = -1 stops at x = 0 at t = x0 in 0, 0.1, ..., 1."""
    s = HybridSystem(
        name="drop",
        variables=["x"],
        parameters=[],
        modes=[Mode("fall", derivatives={"x": "-1"}), Mode("rest", derivatives={"x": "0"})],
        transitions=[Transition("fall", "rest", "x", -1, "stop", {"x": "0"})],
        initial_mode="fall",
    )
    grid = np.linspace(0.0, 1.0, 11)
    for options in (
        SolverOptions(method=IDA(rtol=1e-10, atol=1e-12)),
        SolverOptions(method=Exact()),
    ):
        tr = simulate(s, {}, (0.0, 1.0), {"x": x0}, t_eval=grid, options=options)
        assert tr.status == Status.COMPLETED
        assert np.array_equal(tr.t, grid)
        assert tr.events[0].t == pytest.approx(x0, abs=1e-15)
        assert np.allclose(tr["x"], np.maximum(x0 - grid, 0.0), rtol=0, atol=1e-12)
