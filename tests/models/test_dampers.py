"""The paper's dampers on the event-driven engine, against independent results (issue 2).

(a) never-slipping element: the closed-form linear steady state (App. A, Eqs. A.1-A.3);
(c) energy balance over long stick-slip runs: input work = dissipation + change of mechanical energy;
(e) every located event lies on its guard (|h| <= 1e-10);
consistency of the slave variable u after every switch; the paper's H and v_rel definitions.
"""

import numpy as np
import pytest

import models
from hybrid import SolverOptions, simulate
from models.linear import stick_response

TIGHT = SolverOptions(rtol=1e-11, atol=1e-13)
NAMES = ("x1", "v1", "x2", "v2", "u")


def _state(y5):
    return {n: float(v) for n, v in zip(NAMES, y5, strict=True)}


@pytest.mark.parametrize("name", ["absorber", "isolator"])
@pytest.mark.parametrize("omega", [0.5, 0.854, 1.3])
def test_never_slipping_element_gives_the_linear_steady_state(name, omega):
    system = models.BUILTIN[name]()
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
    system = models.BUILTIN[name]()
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
    return (request.param, *_stick_slip_run(request.param, 60, SolverOptions(rtol=1e-10, atol=1e-12)))


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


def test_every_located_event_lies_on_its_guard(long_run):
    name, system, p, tr = long_run
    located = [ev for ev in tr.events if not ev.chained]
    assert len(located) == tr.n_transitions  # this element never needs a chained switch
    assert max(abs(ev.guard_value) for ev in located) <= 1e-10


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
    assert np.all(tr["v_rel"][mode == "stick"] == 0.0)


def test_slip_phase_ends_in_stick_and_stick_ends_in_slip(long_run):
    # With equal static and kinetic friction, slip of this element always ends in stick (docs/theory.md).
    name, system, p, tr = long_run
    for ev in tr.events:
        assert (ev.source == "stick") != (ev.target == "stick")
    times = np.array([ev.t for ev in tr.events])
    assert np.all(np.diff(times) > 0)  # the guard just crossed never re-fires at the entry point


def test_from_rest_the_absorber_first_slips_only_after_the_response_has_grown():
    system = models.absorber()
    p = system.preset("standard")
    T = 2 * np.pi / p["Omega"]
    tr = simulate(system, p, (0.0, 110 * T), dict.fromkeys(NAMES, 0.0), "stick", samples_per_period=20)
    assert tr.success
    first = tr.events[0]
    assert first.source == "stick" and first.target.startswith("slip")
    # Before the first slip the motion is the linear stick system's: |H| < R.
    before = tr.t < first.t
    assert np.max(np.abs(tr["H"][before])) < p["R"]
    assert 90 * T < first.t < 110 * T  # notes/nonsmooth.md: about 100 forcing periods


def test_presets_are_the_papers_parameter_sets():
    # Section 3 and the captions of Figs. 3-7, 9, 11, 13 (the one place these numbers are written in tests).
    standard = dict(m1=1.0, m2=0.1, c1=1.0, c2=0.1, c3=10.0, R=0.5, F=0.01, Omega=0.854)
    assert models.absorber().preset("standard") == standard
    assert models.absorber().preset("fig3a") == dict(standard, R=0.60, F=0.45)
    assert models.absorber().preset("fig3b") == dict(standard, R=0.45, F=0.60)
    assert models.isolator().preset("standard") == dict(standard, c3=100.0, R=1.5)
    assert models.isolator().preset("fig4a") == dict(standard, c3=0.25, R=0.60, F=0.45)
    assert models.isolator().preset("fig4b") == dict(standard, c3=0.25, R=0.45, F=0.60)
