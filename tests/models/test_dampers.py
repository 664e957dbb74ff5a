"""The paper's dampers on the event-driven engine, against independent results (issue 2).

(a) never-slipping element: the closed-form linear steady state (App. A, Eqs. A.1-A.3);
(c) energy balance over long stick-slip runs: input work = dissipation + change of mechanical energy;
(e) every located event lies on its guard (|h| <= 1e-10);
consistency of the slave variable u after every switch; the paper's H and v_rel definitions.
"""

import numpy as np
import pytest
from scipy.linalg import eigh
from scipy.optimize import brentq

import hybrid_models
from hybrid import IDA, Exact, SolverOptions, simulate
from hybrid_models.linear import stick_amplitudes, stick_response

TIGHT = SolverOptions(method=IDA(rtol=1e-11, atol=1e-13))
NAMES = ("x1", "v1", "x2", "v2", "u")


def _state(y5):
    return {n: float(v) for n, v in zip(NAMES, y5, strict=True)}


@pytest.mark.parametrize("name", ["absorber", "isolator"])
@pytest.mark.parametrize("omega", [0.5, 0.854, 1.3])
def test_never_slipping_element_gives_the_linear_steady_state(name, omega):
    system = hybrid_models.BUILTIN[name]()
    p = system.preset("standard", R=1e6, Omega=omega)
    T = 2 * np.pi / omega
    t_eval = np.linspace(0.0, 5 * T, 201)
    exact = stick_response(name, p, t_eval)
    tr = simulate(system, p, (0.0, 5 * T), _state(exact[0]), "stick", t_eval=t_eval, options=TIGHT)
    assert tr.n_transitions == 0
    assert set(tr.mode) == {"stick"}
    got = tr.y[:, :5]
    scale = np.max(np.abs(exact), axis=0)
    scale = np.where(scale > 0, scale, np.max(scale))  # the isolator's u stays 0
    rel = np.max(np.abs(got - exact) / scale)
    assert rel <= 1e-7, rel


def _stick_slip_run(name, periods, options):
    system = hybrid_models.BUILTIN[name]()
    p = system.preset("standard")
    T = 2 * np.pi / p["Omega"]
    if name == "absorber":
        x0 = {"x1": 5.0, "v1": 0.0, "x2": 5.0, "v2": 0.0, "u": 5.0}
    else:
        x0 = {"x1": 4.0, "v1": 0.0, "x2": 4.0, "v2": 0.0, "u": 4.0 / 101.0}  # H = 0: a consistent stick state
    return (
        system,
        p,
        simulate(system, p, (0.0, periods * T), x0, "stick", samples_per_period=40, options=options),
    )


@pytest.fixture(scope="module", params=["absorber", "isolator"])
def long_run(request):
    return (
        request.param,
        *_stick_slip_run(request.param, 60, SolverOptions(method=IDA(rtol=1e-10, atol=1e-12))),
    )


def test_long_run_has_stick_and_slip(long_run):
    name, system, p, tr = long_run
    assert tr.success
    assert tr.n_transitions >= 40
    assert {"stick", "slip+", "slip-"} <= set(tr.mode)


def test_energy_balance_over_a_long_stick_slip_run(long_run):
    # W(t) = D(t) + E(t) - E(0) at every sample; relative to the energy that went through the system.
    name, system, p, tr = long_run
    W, D, E = tr["W"], tr["D"], tr["E"]
    scale = E[0] + D[-1]
    residual = np.max(np.abs(W - D - (E - E[0])))
    assert D[-1] > 0.1 * E[0]  # friction really dissipated a sizeable share
    assert residual / scale <= 1e-6, residual / scale


def test_dissipation_is_never_negative(long_run):
    name, system, p, tr = long_run
    assert np.all(np.diff(tr["D"]) >= -1e-12)


def paper_force_and_slip_rate(name, p, y):
    """The friction force H and the slip rate v_r of the element from the state (x1, v1, x2, v2, u),
    written here from the free-body diagrams (the paper's Eqs. 10-13, as in models/karnopp.py), not
    read from the model file: absorber H = c2 (u - x1) - c3 (x2 - u), v_r = c2 (v2 - v1)/(c2 + c3);
    isolator H = c1 (x1 - u) - c3 u, v_r = c1 v1/(c1 + c3)."""
    x1, v1, x2, v2, u = y[:5]
    c1, c2, c3 = p["c1"], p["c2"], p["c3"]
    if name == "absorber":
        return c2 * (u - x1) - c3 * (x2 - u), c2 * (v2 - v1) / (c2 + c3)
    return c1 * (x1 - u) - c3 * u, c1 * v1 / (c1 + c3)


def test_every_located_event_lies_on_the_papers_switching_surface(long_run):
    """Each switch happens where the paper's switching conditions hold, evaluated from the state the
    engine switched at (not the engine's own guard value): breakaway to slip+- where H = +-R, the end
    of a slip where v_r = 0. This checks that the model file's guards and slip directions are the
    paper's conditions (a wrong sign or coefficient in models/*.toml fails here); measured: 0 to
    rounding (the engine leaves x_minus on its guard), so 1e-10 of R and of the velocity scale is the
    engine's root tolerance. *When* the switches happen is checked independently of IDA by the next
    test (the exact integrator)."""
    name, system, p, tr = long_run
    located = [ev for ev in tr.events if not ev.chained]
    assert len(located) == tr.n_transitions  # this element never needs a chained switch
    R = p["R"]
    vscale = max(np.max(np.abs(tr["v1"])), np.max(np.abs(tr["v2"])))
    kinds = set()
    for ev in located:
        H, vr = paper_force_and_slip_rate(name, p, ev.x_minus)
        if ev.source == "stick":
            s = 1.0 if ev.target == "slip+" else -1.0
            assert abs(H - s * R) <= 1e-10 * R, (ev.t, ev.target, H)
        else:
            assert ev.target == "stick"
            assert abs(vr) <= 1e-10 * vscale, (ev.t, vr)
            assert abs(abs(H) - R) <= 1e-10 * R  # the force is still saturated where the slip ends
        kinds.add((ev.source, ev.target))
    assert kinds == {("stick", "slip+"), ("stick", "slip-"), ("slip+", "stick"), ("slip-", "stick")}


def test_switch_times_of_a_long_run_agree_with_the_exact_integrator(long_run):
    """The same 60 periods on the exact integrator (matrix exponentials of the affine modes and guard
    roots of the exact solution; SolverOptions(method=Exact())) instead of IDA: the same sequence
    of switches at the same times. The difference is the global error of the IDA run (rtol 1e-10)
    after up to 440 s: measured 5.7e-6 s (absorber, at a breakaway near t = 400 s where H reaches R at
    a small rate) and 4.8e-7 s (isolator); the final states 4.6e-8 and 8.5e-8 of the state's scale.
    It is IDA's: re-run without samples at rtol 1e-10, 1e-11, 1e-12 the largest switch-time
    difference falls 5.3e-6, 7.0e-7, 1.3e-7 s (absorber) and 4.8e-7, 5.6e-8, 8.8e-9 s (isolator).
    Hence 1e-5 s (2.3e-8 of the run's length) and 2e-7 of the scale."""
    name, system, p, tr = long_run
    T = 2 * np.pi / p["Omega"]
    x0 = {n: float(v) for n, v in zip(system.variable_names, tr.y[0], strict=True)}
    ex = simulate(
        system,
        p,
        (0.0, 60 * T),
        x0,
        "stick",
        t_eval=[0.0, 60 * T],
        options=SolverOptions(method=Exact()),
    )
    assert ex.success
    assert [(e.source, e.target) for e in ex.events] == [(e.source, e.target) for e in tr.events]
    dt = np.abs(np.array([e.t for e in ex.events]) - np.array([e.t for e in tr.events]))
    assert dt.max() <= 1e-5, dt.max()
    scale = np.max(np.abs(tr.y[:, :5]))
    assert np.max(np.abs(ex.y_final[:5] - tr.y_final[:5])) <= 2e-7 * scale


def test_slave_variable_satisfies_the_node_balance_after_every_switch(long_run):
    name, system, p, tr = long_run
    c1, c2, c3, R = p["c1"], p["c2"], p["c3"], p["R"]
    for ev in tr.events:
        x1, v1, x2, v2, u = ev.x_plus[:5]
        # u is continuous across every switch of this element
        assert abs(ev.x_plus[4] - ev.x_minus[4]) <= 1e-9 * (1 + abs(u))
        if ev.target.startswith("slip"):
            s = 1.0 if ev.target == "slip+" else -1.0
            if name == "absorber":
                res = (c2 + c3) * u - c2 * x1 - c3 * x2 - R * s
            else:
                res = (c1 + c3) * u - c1 * x1 + R * s
            assert abs(res) <= 1e-12 * (1 + abs(c2 * x1) + abs(c3 * x2) + R)


def test_friction_force_is_bounded_and_saturates_while_slipping(long_run):
    name, system, p, tr = long_run
    H, mode = tr["H"], tr.mode
    R = p["R"]
    assert np.max(np.abs(H)) <= R * (1 + 1e-9)
    for m, s in (("slip+", 1.0), ("slip-", -1.0)):
        sel = mode == m
        assert np.allclose(H[sel], s * R, rtol=0, atol=1e-9 * R)
        # slip+ means the element slides forwards
        assert np.all(s * tr["v_rel"][sel] >= -1e-9)
    # While stuck, the element does not move: its extension w (absorber x2 - u, c3 being the stuck
    # spring; isolator u) stays constant over each stick phase, from the integrated state (v_rel is
    # defined 0 in the stick mode, so testing it would hold by construction). While slipping w moves
    # in the direction of the slip: w' = v_r (absorber: (c2 + c3) u' = c2 v1 + c3 v2 gives
    # (x2 - u)' = c2 (v2 - v1)/(c2 + c3); isolator: (c1 + c3) u' = c1 v1).
    w = tr["x2"] - tr["u"] if name == "absorber" else tr["u"]
    wscale = np.max(np.abs(w))
    runs = np.flatnonzero(mode[1:] != mode[:-1]) + 1
    n_stick = 0
    for a, b in zip(np.r_[0, runs], np.r_[runs, len(mode)], strict=True):
        seg = w[a:b]
        if mode[a] == "stick":
            # u' = v2 (absorber) or u' = 0 integrated by IDA: measured spread 4e-14 and 0 of the scale
            assert np.ptp(seg) <= 1e-10 * wscale, (tr.t[a], np.ptp(seg))
            n_stick += b - a >= 2
        else:
            s = 1.0 if mode[a] == "slip+" else -1.0
            assert np.all(s * np.diff(seg) >= -1e-10 * wscale), tr.t[a]
    assert n_stick >= 20


def test_slip_phase_ends_in_stick_and_stick_ends_in_slip(long_run):
    # With equal static and kinetic friction, slip of this element always ends in stick (docs/theory.md).
    name, system, p, tr = long_run
    for ev in tr.events:
        assert (ev.source == "stick") != (ev.target == "stick")
    times = np.array([ev.t for ev in tr.events])
    assert np.all(np.diff(times) > 0)  # the guard just crossed never re-fires at the entry point


def stuck_absorber_from_rest(p, t):
    """Closed-form motion of the stuck absorber released from rest at t = 0 (x = v = 0, u = x2).

    Stuck, u = x2 and the two masses form the undamped chain M x'' + K x = (F sin(W t), 0) with
    M = diag(m1, m2), K = [[c1 + c2, -c2], [-c2, c2]] (hybrid_models.karnopp's free-body diagrams with u = x2).
    Its solution is the forced part of App. A (A1, A2 sin(W t), stick_amplitudes, which vanishes at
    t = 0) plus free modes phi_k b_k sin(w_k t) (K phi = w^2 M phi) with sum_k phi_k b_k w_k =
    -(A1, A2) W so that the velocities start at 0. Returns x1, x2 and the friction force
    H = c2 (u - x1) - c3 (x2 - u) = c2 (x2 - x1) and its derivative."""
    m1, m2, c1, c2, W = (p[k] for k in ("m1", "m2", "c1", "c2", "Omega"))
    A = np.array([float(a) for a in stick_amplitudes(p)])
    K = np.array([[c1 + c2, -c2], [-c2, c2]])
    w2, phi = eigh(K, np.diag([m1, m2]))
    w = np.sqrt(w2)
    b = np.linalg.solve(phi * w, -A * W)
    t = np.asarray(t, dtype=float)
    x = A[:, None] * np.sin(W * t) + (phi * b) @ np.sin(np.outer(w, t))
    v = A[:, None] * W * np.cos(W * t) + (phi * b * w) @ np.cos(np.outer(w, t))
    return x[0], x[1], c2 * (x[1] - x[0]), c2 * (v[1] - v[0])


def first_breakaway_from_rest(p, t_max):
    """First t with |H(t)| = R on the closed form: the extrema of H (roots of H', bracketed on a grid
    of 400 points per forcing period, so no half-oscillation of H, at least 0.63 T long, is missed),
    the first whose |H| exceeds R, and the root of |H| - R between it and the previous extremum."""
    R = p["R"]
    T = 2 * np.pi / p["Omega"]
    t = np.linspace(0.0, t_max, int(400 * t_max / T))
    dH = stuck_absorber_from_rest(p, t)[3]
    H = lambda s: float(stuck_absorber_from_rest(p, [s])[2][0])  # noqa: E731
    dHs = lambda s: float(stuck_absorber_from_rest(p, [s])[3][0])  # noqa: E731
    prev = 0.0
    for i in np.flatnonzero(np.sign(dH[1:]) != np.sign(dH[:-1])):
        te = brentq(dHs, t[i], t[i + 1], xtol=1e-14)
        if abs(H(te)) > R:
            return brentq(lambda s: abs(H(s)) - R, prev, te, xtol=1e-13), te
        prev = te
    raise AssertionError("no breakaway before t_max")


def test_from_rest_the_absorber_first_slips_where_the_stuck_closed_form_reaches_R():
    """Released from rest, the stuck absorber is a linear two-mass chain beating between the forcing
    and its stick eigenfrequency (0.8559 rad/s at W = 0.854): |H| grows until it first reaches R after
    102 periods (t = 750.23 s). The engine's motion before the first slip is the closed form
    (stuck_absorber_from_rest; 2e-8 of its scale, measured 5e-9 at rtol 1e-11 over 750 s), and the first
    slip happens where the closed form first reaches |H| = R (first_breakaway_from_rest). There the peak
    of |H| exceeds R by 2.9e-3 relative (the previous peak is below R) and H crosses R at |H'| =
    3.2e-2 N/s, so a state error of 3.5e-8 m (c2 x 3.5e-8 N in H) moves the time by ~1e-7 s: 1e-6 s
    (measured 3.0e-7 s). The old check (90 T < t < 110 T) was a number read off the engine's output."""
    system = hybrid_models.absorber()
    p = system.preset("standard")
    T = 2 * np.pi / p["Omega"]
    t_slip, t_peak = first_breakaway_from_rest(p, 130 * T)
    tr = simulate(
        system,
        p,
        (0.0, t_slip + 2 * T),
        dict.fromkeys(NAMES, 0.0),
        "stick",
        samples_per_period=20,
        options=TIGHT,
    )
    assert tr.success
    first = tr.events[0]
    assert first.source == "stick"
    assert first.target == ("slip+" if first.x_minus[4] - first.x_minus[0] > 0 else "slip-")
    assert abs(first.t - t_slip) <= 1e-6, (first.t, t_slip)
    before = tr.t < first.t
    x1, x2, H, _ = stuck_absorber_from_rest(p, tr.t[before])
    scale = max(np.max(np.abs(x1)), np.max(np.abs(x2)))
    assert np.max(np.abs(tr["x1"][before] - x1)) <= 2e-8 * scale
    assert np.max(np.abs(tr["x2"][before] - x2)) <= 2e-8 * scale
    assert np.max(np.abs(tr["u"][before] - x2)) <= 2e-8 * scale  # stuck: u = x2 from rest


def test_presets_are_the_papers_parameter_sets():
    # Section 3 and the captions of Figs. 3-7, 9, 11, 13 (the one place these numbers are written in tests).
    standard = dict(m1=1.0, m2=0.1, c1=1.0, c2=0.1, c3=10.0, R=0.5, F=0.01, Omega=0.854)
    assert hybrid_models.absorber().preset("standard") == standard
    assert hybrid_models.absorber().preset("fig3a") == dict(standard, R=0.60, F=0.45)
    assert hybrid_models.absorber().preset("fig3b") == dict(standard, R=0.45, F=0.60)
    assert hybrid_models.isolator().preset("standard") == dict(standard, c3=100.0, R=1.5)
    assert hybrid_models.isolator().preset("fig4a") == dict(standard, c3=0.25, R=0.60, F=0.45)
    assert hybrid_models.isolator().preset("fig4b") == dict(standard, c3=0.25, R=0.45, F=0.60)
