"""Filippov systems written with sign(): expansion, crossing, sliding, exit, reports (issue 12).

References, all independent of the expansion: the hand-written automata of the same models
(``models/coulomb.toml``, ``tests/hybrid/data/belt_automaton.toml``), Den Hartog's closed form of
the forced Coulomb oscillator's non-stop motion, the closed forms of a stick phase (Coulomb: the
mass stays at ``x0`` until ``F sin(W t) - k x0`` reaches ``+-R``; belt: ``x = x0 + v_b (t - t0)``
until ``k x + c v_b`` reaches ``F``), a relay oscillator integrated by ``scipy.integrate.solve_ivp``
with events, and central differences of the period map.
"""

from __future__ import annotations

import math
import warnings
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

import hybrid
from hybrid import (
    IDA,
    Exact,
    Mode,
    ModelError,
    SolverOptions,
    Status,
    filippov_system,
    periodic_orbit,
    simulate,
)
from hybrid.cli import main
from hybrid_models.coulomb_exact import den_hartog

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
EXACT = SolverOptions(method=Exact())
IDA = SolverOptions(method=IDA(rtol=1e-10, atol=1e-12))


@pytest.fixture(scope="module")
def coulomb():
    return hybrid.load_system(ROOT / "models" / "coulomb.toml")


@pytest.fixture(scope="module")
def coulomb_sign():
    return hybrid.load_system(ROOT / "models" / "coulomb_sign.toml")


@pytest.fixture(scope="module")
def belt_sign():
    return hybrid.load_system(ROOT / "models" / "belt_sign.toml")


@pytest.fixture(scope="module")
def belt_automaton():
    return hybrid.load_system(HERE / "data" / "belt_automaton.toml")


def _relay(**extra):
    return filippov_system(
        name="relay",
        variables=["x", "v"],
        parameters=["k", "R"],
        modes=[Mode("m", derivatives={"x": "v", "v": "-k*x - R*sign(v)"})],
        transitions=[],
        **extra,
    )


# ----------------------------------------------------------------------------
# Expansion and refusals
# ----------------------------------------------------------------------------
def test_components_derive_regions_sliding_mode_and_entry():
    # Issue 22: one component per surface (named as its coefficient), with local modes, instead
    # of the modes m_+, m_-, m_0, m_0r and the entry m expanded from them.
    s = _relay()
    assert s.mode_names == ("m",)
    assert s.initial_mode is None
    assert s.variable_names == ("x", "v", "sign_1")
    (c,) = s.components
    assert c.name == "sign_1"
    assert c.mode_names == ("entry+", "entry-", "plus", "minus", "slide", "repel")
    (surf,) = hybrid.model.filippov.surfaces(s)
    assert (surf.h, surf.coefficient, surf.slides, surf.mode, surf.component) == (
        "v",
        "sign_1",
        True,
        "m",
        "sign_1",
    )
    assert surf.modes == c.mode_names
    arcs = {(t.source, t.target, t.direction, t.name) for t in c.transitions}
    assert ("plus", "slide", -1, "reach") in arcs
    assert ("minus", "slide", 1, "reach") in arcs
    assert ("slide", "plus", 1, "exit+") in arcs
    assert ("slide", "minus", -1, "exit-") in arcs
    assert ("slide", "repel", 1, "repel") in arcs
    halts = {m.name: bool(m.halt) for m in c.modes}
    assert halts == {
        "entry+": False,
        "entry-": False,
        "plus": False,
        "minus": False,
        "slide": False,
        "repel": True,
    }
    # The sliding mode: sign_1 is the slave of 0 = dv/dt; the regions fix it at +-1.
    p = {"k": 2.0, "R": 0.5}
    cs = hybrid.model.compiled.CompiledSystem(s, p)
    slide = cs.modes[cs.mode_index["m|slide"]]
    y = slide.solve_algebraic(0.0, np.array([0.1, 0.0, 0.0]))
    assert y[2] == pytest.approx(-2.0 * 0.1 / 0.5, rel=1e-14)
    for local, value in (("plus", 1.0), ("minus", -1.0)):
        region = cs.modes[cs.mode_index[f"m|{local}"]]
        assert region.solve_algebraic(0.0, np.array([0.1, 0.3, 0.0]))[2] == value


def test_a_system_without_sign_is_unchanged(coulomb):
    assert hybrid.load_system(ROOT / "models" / "coulomb.toml").mode_names == coulomb.mode_names
    assert hybrid.model.filippov.surfaces(coulomb) == ()


def test_hybrid_system_refuses_sign_of_the_state():
    # Issue 12: sign(v) in a derivative used to be stepped across silently.
    with pytest.raises(ModelError, match=r"derivative of `v` contains sign\(v\).*filippov_system"):
        hybrid.HybridSystem(
            name="relay",
            variables=["x", "v"],
            parameters=["R"],
            modes=[Mode("m", derivatives={"x": "v", "v": "-x - R*sign(v)"})],
            transitions=[],
        )
    # sign() of parameters only is a constant: allowed.
    hybrid.HybridSystem(
        name="c",
        variables=["x"],
        parameters=["R"],
        modes=[Mode("m", derivatives={"x": "sign(R)"})],
        transitions=[],
    )


@pytest.mark.parametrize(
    ("derivs", "algebraic", "match"),
    [
        ({"x": "v", "v": "-x - sign(v)**2"}, {}, r"not affine in sign\(v\)"),
        ({"x": "v", "v": "-x - sign(v + sign(x))"}, {}, r"contains sign\(\) itself"),
        ({"x": "v", "v": "-x - sign(z)"}, {"z": "z - x"}, r"depends on `z`, a slave variable"),
        (
            {"x": "v", "v": "-x - z - sign(v)"},
            {"z": "z - sign(v)"},
            r"algebraic equation of `z` contains sign",
        ),
    ],
)
def test_inexpandable_sign_is_refused(derivs, algebraic, match):
    variables = ["x", "v"] + list(algebraic)
    with pytest.raises(ModelError, match=match):
        filippov_system(
            name="bad",
            variables=variables,
            parameters=[],
            modes=[Mode("m", derivs, algebraic)],
            transitions=[],
        )


def test_mode_names_of_the_model_do_not_clash_with_the_derived_ones():
    # Issue 22: a mode named `m_+` beside a Filippov mode `m` used to be refused (it was the name
    # of a derived region); the regions are now local modes of the component `sign_1`, so the
    # model builds, with the indicator in_m telling the component which mode the system is in.
    s = filippov_system(
        name="ok",
        variables=["x"],
        parameters=[],
        modes=[Mode("m", {"x": "-sign(x)"}), Mode("m_+", {"x": "0"})],
        transitions=[],
    )
    assert s.mode_names == ("m", "m_+")
    assert s.variable_names == ("x", "sign_1", "in_m")
    assert s.components[0].mode_names[-1] == "off"


# ----------------------------------------------------------------------------
# Coulomb oscillator: sign(v) against the automaton, Den Hartog and the stick closed form
# ----------------------------------------------------------------------------
def _switches(tr, sign_model: bool):
    """(time, kind) of the switches that move the state: stick entries and stick exits (a
    crossing of v = 0 without a stop is one stop and one exit at the same instant in both)."""
    out = []
    for e in tr.events:
        if e.t == tr.events[0].t == 0.0 and e.chained:
            continue  # the start's dispatch
        if sign_model:
            kind = "stop" if e.guard == "sign_1.reach" else "go"
        else:
            kind = "stop" if e.guard.startswith("stop") else "go"
        out.append((e.t, kind))
    return out


@pytest.mark.parametrize(("options", "tol"), [(EXACT, 1e-12), (IDA, 1e-8)])
@pytest.mark.parametrize(("W", "R"), [(0.8, 0.1), (0.6, 0.3)])  # crossings; stick phases
def test_coulomb_switches_match_the_automaton(coulomb, coulomb_sign, options, tol, W, R):
    p = coulomb.preset("forced", Omega=W, R=R)
    span = (0.0, 10 * 2 * math.pi / W)
    ta = simulate(coulomb, p, span, {"x": 0.0, "v": 0.0}, options=options)
    tb = simulate(coulomb_sign, p, span, {"x": 0.0, "v": 0.0}, options=options)
    assert ta.status == tb.status == Status.COMPLETED
    sa, sb = _switches(ta, False), _switches(tb, True)
    assert len(sa) == len(sb) >= 20
    assert [k for _, k in sa] == [k for _, k in sb]
    assert max(abs(a - b) for (a, _), (b, _) in zip(sa, sb, strict=True)) <= tol
    for name in ("x", "v", "W", "D"):
        assert tb.final(name) == pytest.approx(ta.final(name), rel=tol, abs=tol)
    # The friction force while stuck (sliding) is the automaton's stick force: -R sign_1 = H.
    stuck = tb.mode == "motion|slide"
    H = p["k"] * tb["x"][stuck] - p["F"] * np.sin(W * tb.t[stuck])
    assert np.allclose(tb["friction"][stuck], H, rtol=0, atol=1e-9)
    assert stuck.sum() > (20 if R == 0.3 else 0)


@pytest.mark.parametrize("options", [EXACT, IDA])
def test_coulomb_stick_exits_at_tangency_match_the_closed_form(coulomb_sign, options):
    """Each stick (sliding) phase ends where F sin(W t) - k x0 reaches +-R (a tangency of f+-)."""
    p = coulomb_sign.preset("forced", Omega=0.6, R=0.3)
    k, R, F, W = p["k"], p["R"], p["F"], p["Omega"]
    tr = simulate(coulomb_sign, p, (0.0, 6 * 2 * math.pi / W), {"x": 0.0, "v": 0.0}, options=options)
    assert tr.status == Status.COMPLETED
    ev = tr.events
    exits = [(i, e) for i, e in enumerate(ev) if e.source == "motion|slide" and not e.chained]
    assert len(exits) >= 10
    for i, e in exits:
        entry = ev[i - 1]
        assert entry.target == "motion|slide"
        x0 = entry.x_plus[0]

        def drive(t, x0=x0):
            return F * math.sin(W * t) - k * x0

        # first t after entry where |drive| = R
        ts = np.linspace(entry.t, e.t + 1.0, 4001)
        g = np.abs([drive(t) for t in ts]) - R
        j = int(np.argmax(g[1:] > 0)) + 1
        t_ref = brentq(lambda t: abs(drive(t)) - R, ts[j - 1], ts[j], xtol=1e-15, rtol=1e-15)
        assert abs(e.t - t_ref) <= 1e-9
        assert e.target == ("motion|plus" if drive(t_ref) > 0 else "motion|minus")
        assert abs(e.x_minus[0] - x0) <= 1e-12
        assert abs(e.x_minus[1]) <= 1e-12


# (Omega, R/F, non-stop): Den Hartog's closed form holds for the non-stop orbits.
OMEGAS_RATIOS = [
    (0.8, 0.2, True),
    (1.5, 0.2, True),
    (2.0, 0.4, True),
    (0.6, 0.6, False),
    (1.2, 0.1, True),
    (3.0, 0.5, True),
]


# The exact flow takes long steps: a guard may dip and cross back within one (located since issue 12).
@pytest.mark.filterwarnings("ignore:guard .* before it could be armed:RuntimeWarning")
@pytest.mark.parametrize(("W", "ratio", "nonstop"), OMEGAS_RATIOS)
def test_coulomb_orbits_match_the_automaton_and_den_hartog(coulomb, coulomb_sign, W, ratio, nonstop):
    p = coulomb.preset("forced", Omega=W, R=ratio * 0.5)
    oa = periodic_orbit(coulomb, p, options=EXACT)
    ob = periodic_orbit(coulomb_sign, p, options=EXACT)
    assert oa.converged, (oa.message, ob.message)
    assert ob.converged, (oa.message, ob.message)
    assert ob.amplitude["x"] == pytest.approx(oa.amplitude["x"], rel=1e-9)
    assert ob.amplitude["v"] == pytest.approx(oa.amplitude["v"], rel=1e-9)
    # Multipliers: the automaton's two, plus the structural zero of the slave sign_1.
    mu = np.sort_complex(ob.multipliers[np.array(ob.multiplier_kinds) != "structural"])
    assert np.allclose(mu, np.sort_complex(oa.multipliers), rtol=0, atol=1e-9)
    assert ob.multiplier_kinds.count("structural") == 1
    assert ob.stability == oa.stability
    m, k, R, F = p["m"], p["k"], p["R"], p["F"]
    X = ob.amplitude["x"]
    assert (ob.mode_fractions.get("motion|slide", 0.0) == 0.0) == nonstop
    if nonstop:
        r = W / math.sqrt(k / m)
        assert k * X * r * r > R  # Den Hartog's condition of non-stop motion
        assert X == pytest.approx(den_hartog(m, k, R, F, W), rel=1e-8 + 1e-9 / abs(1 - r))


def test_coulomb_orbit_on_ida_matches_the_exact_one(coulomb, coulomb_sign):
    p = coulomb.preset("forced", Omega=1.5, R=0.1)
    ob = periodic_orbit(coulomb_sign, p, options=IDA)
    oe = periodic_orbit(coulomb_sign, p, options=EXACT)
    assert ob.converged, ob.message
    assert oe.converged, oe.message
    assert ob.amplitude["x"] == pytest.approx(den_hartog(1.0, 1.0, 0.1, 0.5, 1.5), rel=1e-8)
    assert np.allclose(np.sort_complex(ob.multipliers), np.sort_complex(oe.multipliers), atol=1e-7)


def _period_map_fd(system, orbit, delta=1e-6):
    """Central differences of the stroboscopic map in (x, v) from the orbit's section."""
    tr = orbit.trajectory
    t0, y0, mode0 = tr.t[0], np.array(tr.y[0]), tr.mode[0]
    T = orbit.period
    names = system.variable_names
    ix = [names.index("x"), names.index("v")]
    M = np.zeros((2, 2))
    for j, i in enumerate(ix):
        out = []
        for s in (1.0, -1.0):
            y = y0.copy()
            y[i] += s * delta
            r = simulate(system, orbit.params, (t0, t0 + T), y, mode0=mode0, options=EXACT)
            assert r.status == Status.COMPLETED
            out.append(np.array([r.final(n) for n in ("x", "v")]))
        M[:, j] = (out[0] - out[1]) / (2 * delta)
    return M


@pytest.mark.parametrize(
    ("W", "R", "sliding"), [(0.6, 0.3, True), (1.5, 0.1, False)]
)  # stick phases; crossings only
def test_monodromy_matches_central_differences_of_the_period_map(coulomb_sign, W, R, sliding):
    p = coulomb_sign.preset("forced", Omega=W, R=R)
    for options in (EXACT, IDA):
        orbit = periodic_orbit(coulomb_sign, p, options=options)
        assert orbit.converged
        assert (orbit.mode_fractions.get("motion|slide", 0.0) > 0) == sliding
        M = orbit.monodromy[:2, :2]
        fd = _period_map_fd(coulomb_sign, orbit)
        assert np.max(np.abs(M - fd)) <= 1e-6 * max(1.0, np.max(np.abs(fd)))
        if sliding:  # entering the sliding mode drops a dimension: det M = 0
            assert abs(np.linalg.det(M)) <= 1e-12


# ----------------------------------------------------------------------------
# Belt: sign(v - v_b) against the automaton and the closed form of stick on the belt
# ----------------------------------------------------------------------------
@pytest.mark.parametrize(("options", "tol"), [(EXACT, 1e-12), (IDA, 1e-8)])
@pytest.mark.parametrize("preset", ["standard", "damped"])
def test_belt_switches_and_stick_phases(belt_sign, belt_automaton, options, tol, preset):
    p = belt_sign.preset(preset)
    k, c, F, vb = p["k"], p["c"], p["F"], p["v_b"]
    span = (0.0, 100.0)
    ta = simulate(belt_automaton, p, span, {"x": 0.0, "v": 0.0}, mode0="slip-", options=options)
    tb = simulate(belt_sign, p, span, {"x": 0.0, "v": 0.0}, options=options)
    assert ta.status == tb.status == Status.COMPLETED
    eb = [e for e in tb.events if e.t > 0.0]
    assert len(eb) == len(ta.events) >= 2
    for a, b in zip(ta.events, eb, strict=True):
        assert abs(a.t - b.t) <= tol * max(1.0, a.t)  # IDA's error grows with time
        assert np.allclose(a.x_plus[:2], b.x_plus[:2], rtol=0, atol=tol * max(1.0, a.t))
        assert (a.target, b.target) in {
            ("stick", "motion|slide"),
            ("slip-", "motion|minus"),
            ("slip+", "motion|plus"),
        }
    # Stick phases: x = x0 + v_b (t - t0) until k x + c v_b = F (the sliding coefficient reaches -1).
    n_stick = 0
    for i, e in enumerate(eb):
        if e.target != "motion|slide":
            continue
        n_stick += 1
        x0, t0 = e.x_plus[0], e.t
        t_exit = t0 + ((F - c * vb) / k - x0) / vb
        if i + 1 < len(eb):
            assert eb[i + 1].source == "motion|slide"
            assert eb[i + 1].target == "motion|minus"
            assert abs(eb[i + 1].t - t_exit) <= tol * max(1.0, t_exit)
        inside = (tb.mode == "motion|slide") & (tb.t > t0) & (tb.t < min(t_exit, span[1]))
        assert np.allclose(tb["x"][inside], x0 + vb * (tb.t[inside] - t0), rtol=0, atol=tol)
        assert np.allclose(tb["v"][inside], vb, rtol=0, atol=tol)
        assert np.all(np.abs(tb["sign_1"][inside]) <= 1.0 + 1e-12)
    assert n_stick == (1 if preset == "damped" else sum(1 for e in ta.events if e.target == "stick"))


# ----------------------------------------------------------------------------
# Crossing only; repulsive sliding; intersections
# ----------------------------------------------------------------------------
def test_crossing_only_relay_matches_solve_ivp():
    """x'' + 2 z x' + x = -R sign(x): a force that jumps across x = 0, which the flow always
    crosses (dx/dt does not depend on sign(x)): no sliding mode, direct crossings."""
    s = filippov_system(
        name="relay",
        variables=["x", "v"],
        parameters=["z", "R"],
        modes=[Mode("m", derivatives={"x": "v", "v": "-2*z*v - x - R*sign(x)"})],
        transitions=[],
    )
    (surf,) = hybrid.model.filippov.surfaces(s)
    assert not surf.slides
    assert s.components[0].mode_names == ("entry+", "plus", "minus")  # no sliding mode
    p = {"z": 0.02, "R": 0.1}
    tr = simulate(s, p, (0.0, 30.0), {"x": 1.0, "v": 0.0}, mode0="m|entry+", options=EXACT)
    assert tr.status == Status.COMPLETED
    crossings = [e.t for e in tr.events if e.t > 0]

    def rhs(t, y, sgn):
        return [y[1], -2 * p["z"] * y[1] - y[0] - p["R"] * sgn]

    ref, t, y, sgn = [], 0.0, [1.0, 0.0], 1.0
    while True:
        ev = lambda t, y, sgn: y[0]  # noqa: E731
        ev.terminal = True
        ev.direction = -sgn
        sol = solve_ivp(rhs, (t, 30.0), y, args=(sgn,), events=ev, rtol=1e-12, atol=1e-14, method="DOP853")
        if sol.status != 1:
            break
        t, y, sgn = sol.t_events[0][0], [0.0, sol.y_events[0][0][1]], -sgn
        ref.append(t)
    assert len(crossings) == len(ref) >= 10
    assert np.max(np.abs(np.array(crossings) - ref)) <= 1e-9
    assert all(e.target in ("m|plus", "m|minus") for e in tr.events)


def test_repulsive_sliding_is_reported_not_integrated():
    """A state on a surface where both fields point away is reported (a halt naming the surface),
    whether the orientation of the fields depends on the state (y' = x sign(y)) or not
    (x' = sign(x)); a crossing with that orientation passes."""
    two = filippov_system(
        name="twofold",
        variables=["x", "y"],
        parameters=[],
        modes=[Mode("m", derivatives={"x": "1", "y": "x*sign(y)"})],
        transitions=[],
    )
    one = filippov_system(
        name="push",
        variables=["x"],
        parameters=["b"],
        modes=[Mode("m", derivatives={"x": "b + sign(x)"})],
        transitions=[],
    )
    tr = simulate(two, {}, (0.0, 5.0), {"x": 0.5, "y": 0.0}, mode0="m|entry+", options=IDA, throw=False)
    assert tr.status == Status.HALTED
    assert tr.t_final == 0.0
    assert "repulsive sliding on the surface y = 0 of mode `m`" in tr.message
    # Sliding into a two-fold (y' = x sign(y) from x < 0): the sliding equation is singular
    # there; the run stops at it instead of going on.
    tr = simulate(two, {}, (0.0, 5.0), {"x": -1.0, "y": 0.3}, mode0="m|entry+", options=IDA, throw=False)
    assert tr.status == Status.ALGEBRAIC_FAILED
    assert "singular" in tr.message
    assert tr.t_final == pytest.approx(1.0, abs=1e-6)
    for options in (IDA, EXACT):  # x' = b + sign(x) is affine: both integrators
        tr = simulate(one, {"b": 0.5}, (0.0, 1.0), {"x": 0.0}, mode0="m|entry+", options=options, throw=False)
        assert tr.status == Status.HALTED
        assert "repulsive sliding on the surface x = 0" in tr.message
        # x' = b + sign(x) with b = -2: the flow crosses x = 0 downwards (orientation repulsive).
        tr = simulate(one, {"b": -2.0}, (0.0, 1.0), {"x": 0.5}, mode0="m|entry+", options=options)
        assert tr.final("x") == pytest.approx(-3.0 * 0.5, abs=1e-9)  # x = 0 at t = 0.5, then x' = -3
        assert [e.target for e in tr.events if e.t > 0] == ["m|slide", "m|repel", "m|minus"]


def test_sliding_on_two_and_three_surfaces_at_once():
    """x' = 0.5 - sign(x), y' = -sign(y) from (1, 0.5): sliding on y = 0 from t = 0.5, then x
    reaches 0 at t = 2 where both fields point towards x = 0: sliding on both (sign_1 = 0.5,
    sign_2 = 0): two components in `slide`. Issue 22: a third surface used to halt the run at the
    intersection (sliding on two was derived for two surfaces only); with components it is a
    third component sliding, here with an exit: x' = s/4 - sign(x) (s' = 1, s = t) slides on x = 0
    from t = 4 - 2 sqrt(2) until sign_1 = t/4 reaches 1 at t = 4, then x = (t - 4)^2 / 8."""
    two = filippov_system(
        name="two",
        variables=["x", "y"],
        parameters=[],
        modes=[Mode("m", derivatives={"x": "0.5 - sign(x)", "y": "-sign(y)"})],
        transitions=[],
    )
    assert len(hybrid.model.filippov.surfaces(two)) == 2
    assert [c.name for c in two.components] == ["sign_1", "sign_2"]
    for options in (IDA, EXACT):
        tr = simulate(two, {}, (0.0, 5.0), {"x": 1.0, "y": 0.5}, mode0="m|entry+|entry+", options=options)
        assert [(e.target, e.guard, round(e.t, 9)) for e in tr.events if not e.chained] == [
            ("m|plus|slide", "sign_2.reach", 0.5),
            ("m|slide|slide", "sign_1.reach", 2.0),
        ]
        assert tr.mode_final == "m|slide|slide"
        assert [tr.final(n) for n in ("x", "y", "sign_1", "sign_2")] == pytest.approx(
            [0, 0, 0.5, 0], abs=1e-9
        )
    three = filippov_system(
        name="three",
        variables=["x", "y", "z", "s"],
        parameters=[],
        modes=[Mode("m", derivatives={"x": "s/4 - sign(x)", "y": "-sign(y)", "z": "-sign(z)", "s": "1"})],
        transitions=[],
        initial_mode="m",
    )
    t_x = 4.0 - 2.0 * math.sqrt(2.0)
    for options in (IDA, EXACT):
        tr = simulate(three, {}, (0.0, 5.0), {"x": 1.0, "y": 0.5, "z": 3.0, "s": 0.0}, options=options)
        assert tr.status == Status.COMPLETED
        moves = [(e.target, e.guard) for e in tr.events if not e.chained]
        assert moves == [
            ("m|plus|slide|plus", "sign_2.reach"),
            ("m|slide|slide|plus", "sign_1.reach"),
            ("m|slide|slide|slide", "sign_3.reach"),
            ("m|plus|slide|slide", "sign_1.exit+"),
        ]
        times = [e.t for e in tr.events if not e.chained]
        assert np.allclose(times, [0.5, t_x, 3.0, 4.0], rtol=0, atol=1e-9)
        assert [tr.final(n) for n in ("x", "y", "z", "sign_1", "sign_2", "sign_3")] == pytest.approx(
            [1.0 / 8.0, 0, 0, 1, 0, 0], abs=1e-9
        )
        sliding = (tr.t > 3.0) & (tr.t < 4.0)
        assert np.allclose(tr["sign_1"][sliding], tr.t[sliding] / 4.0, rtol=0, atol=1e-9)


def test_exact_path_locates_a_guard_crossed_twice_within_a_step(coulomb):
    """Found with issue 12: a guard that starts at zero (disarmed), dips to its safe side and
    crosses back within one long step of the exact flow was logged at the step's end, 0.0046 m/s
    past zero (the automaton's reset v = 0 hid it). Now located: both integrators agree. Issue 30:
    the exact flow finds that crossing itself (its polynomial on the step), with no warning."""
    p = coulomb.preset("forced", Omega=0.6, R=0.01, k=7.3)
    span = (0.0, 4 * 2 * math.pi / 0.6)
    with warnings.catch_warnings(record=True) as got:
        warnings.simplefilter("always")
        ex = simulate(coulomb, p, span, {"x": 0.0, "v": 0.0}, options=EXACT)
    assert not [w for w in got if "before it could be armed" in str(w.message)]
    ida = simulate(coulomb, p, span, {"x": 0.0, "v": 0.0}, options=IDA)
    assert max(abs(e.guard_value) for e in ex.events if not e.chained) <= 1e-12
    assert len(ex.events) == len(ida.events)
    assert max(abs(a.t - b.t) for a, b in zip(ex.events, ida.events, strict=True)) <= 1e-7
    assert ex.final("x") == pytest.approx(ida.final("x"), abs=1e-8)


def test_hybrid_show_lists_surfaces_and_derived_modes(capsys):
    assert main(["show", str(ROOT / "models" / "coulomb_sign.toml")]) == 0
    out = capsys.readouterr().out
    assert "discontinuity surfaces" in out
    assert "entry+, entry-, plus, minus, slide, repel" in out


def test_transitions_of_the_model_between_a_filippov_mode_and_an_ordinary_one():
    """A Filippov mode beside an ordinary one: the model's own transitions leave the Filippov
    mode whatever the side of its surface, and enter it through its component's entry (the side
    decided from the state). x' = -sign(x) reaches x = 0 at t = x0 and stays there (sliding); y
    is a clock, reset to 0 on release. Issue 22: the transitions are the model's own (they used
    to be copied to each derived mode, `slide_+`, `slide_-`, `slide_0`); outside `slide` the
    component is `off`, told by the indicator in_slide."""
    s = filippov_system(
        name="mixed",
        variables=["x", "y"],
        parameters=[],
        modes=[
            Mode("slide", derivatives={"x": "-sign(x)", "y": "1"}),
            Mode("rest", derivatives={"x": "0", "y": "1"}),
        ],
        transitions=[
            hybrid.Transition("slide", "rest", "y - 2", 1, "hold"),
            hybrid.Transition("rest", "slide", "y - 3", 1, "release", {"x": "1 - 2*x", "y": "0"}),
        ],
        initial_mode="slide",
    )
    assert [(t.source, t.target, t.name) for t in s.transitions] == [
        ("slide", "rest", "hold"),
        ("rest", "slide", "release"),
    ]
    assert s.variable_names == ("x", "y", "sign_1", "in_slide")
    assert s.default_mode == "slide|entry+"
    assert s.components[0].mode_names[-1] == "off"
    for options in (IDA, EXACT):
        tr = simulate(s, {}, (0.0, 5.5), {"x": 0.5, "y": 0.0}, options=options)
        assert tr.status == Status.COMPLETED
        moves = [(e.source, e.target, e.guard) for e in tr.events if not e.chained]
        assert moves == [
            ("slide|plus", "slide|slide", "sign_1.reach"),
            ("slide|slide", "rest|slide", "hold"),
            ("rest|off", "slide|off", "release"),
            ("slide|plus", "slide|slide", "sign_1.reach"),
            ("slide|slide", "rest|slide", "hold"),
        ]
        times = [e.t for e in tr.events if not e.chained]
        assert np.allclose(times, [0.5, 2.0, 3.0, 4.0, 5.0], rtol=0, atol=1e-9)
        # at each switch of the system's mode, the component follows at once
        k = next(j for j, e in enumerate(tr.events) if e.guard == "release")
        assert [(e.target, e.guard, e.chained) for e in tr.events[k - 1 : k + 4]] == [
            ("rest|off", "sign_1.leave", True),
            ("slide|off", "release", False),
            ("slide|entry+", "sign_1.enter slide", True),
            ("slide|entry-", "sign_1.side+", True),
            ("slide|plus", "sign_1.side+", True),
        ]
        rest = tr.mode == "rest|off"
        assert rest.sum() > 10
        assert np.all(tr["sign_1"][rest] == 0.0)  # not a Filippov mode: the slot is 0
        assert np.all(tr["in_slide"][rest] == 0.0)
        assert np.all(tr["in_slide"][~rest] == 1.0)
        assert tr.final("x") == pytest.approx(0.0, abs=1e-12)


def _meetings(tr) -> list[str]:
    """What follows each arrival on one surface while the other slides: "cross" (the sliding
    field carries the state across it: its exit is taken at once) or "slide" (on both). Issue 22:
    this used to be read off the derived halt modes `m_0+_meet2` and their guards."""
    out = []
    for j, e in enumerate(tr.events):
        if e.chained or not e.guard.endswith(".reach"):
            continue
        c = int(e.guard.split(".")[0][len("sign_") :])  # the component that reached its surface
        other = e.source.split("|")[3 - c]
        if other != "slide":
            continue
        nxt = tr.events[j + 1] if j + 1 < len(tr.events) else None
        crossed = nxt is not None and nxt.chained and nxt.guard.startswith(f"sign_{c}.exit")
        out.append("cross" if crossed else "slide")
    return out


# The exact flow takes long steps: a guard may dip and cross back within one (located since issue 12).
@pytest.mark.filterwarnings("ignore:guard .* before it could be armed:RuntimeWarning")
def test_two_surfaces_crossing_one_while_sliding_on_the_other(coulomb):
    """Two uncoupled Coulomb oscillators in one mode (surfaces v1 = 0 and v2 = 0): each must move
    as the automaton of its own: both stuck at the start (sliding on both surfaces), one
    reversing while the other sticks (the state reaches the second surface while sliding on the
    first and crosses it), each breaking away."""
    s = filippov_system(
        name="pair",
        variables=["x1", "v1", "x2", "v2"],
        parameters=["m", "k1", "k2", "R1", "R2", "F", "Omega"],
        modes=[
            Mode(
                "m",
                derivatives={
                    "x1": "v1",
                    "v1": "(F*sin(Omega*t) - k1*x1 - R1*sign(v1))/m",
                    "x2": "v2",
                    "v2": "(F*sin(Omega*t) - k2*x2 - R2*sign(v2))/m",
                },
            )
        ],
        transitions=[],
        initial_mode="m",
        period="2*pi/Omega",
    )
    assert [x.h for x in hybrid.model.filippov.surfaces(s)] == ["v1", "v2"]
    span = (0.0, 4 * 2 * math.pi / 0.6)
    grid = np.linspace(*span, 400)
    # (k2, R2, v2 at t = 0, which guard follows a meeting of the surfaces): crossings of v2 = 0
    # while oscillator 1 sticks; both stuck at once (from rest, and later).
    for k2, R2, v20, after_meet in ((7.3, 0.01, 0.3, "cross"), (3.0, 0.05, 0.0, "slide")):
        p = {"m": 1.0, "k1": 1.0, "k2": k2, "R1": 0.3, "R2": R2, "F": 0.5, "Omega": 0.6}
        for options, tol in ((EXACT, 1e-10), (IDA, 1e-7)):
            x0 = {"x1": 0.0, "v1": 0.0, "x2": 0.0, "v2": v20}
            tr = simulate(s, p, span, x0, t_eval=grid, options=options)
            assert tr.status == Status.COMPLETED
            assert _meetings(tr).count(after_meet) >= 3
            for x, v, k, R, v0 in (("x1", "v1", "k1", "R1", 0.0), ("x2", "v2", "k2", "R2", v20)):
                pk = coulomb.preset("forced", Omega=0.6, R=p[R], k=p[k])
                mode0 = "slip+" if v0 > 0 else "stick"
                ref = simulate(
                    coulomb, pk, span, {"x": 0.0, "v": v0}, mode0=mode0, t_eval=grid, options=options
                )
                i = np.searchsorted(tr.t, grid, side="right") - 1
                j = np.searchsorted(ref.t, grid, side="right") - 1
                assert np.array_equal(tr.t[i], grid)
                assert np.array_equal(ref.t[j], grid)
                assert np.max(np.abs(tr[x][i] - ref["x"][j])) <= tol
                assert np.max(np.abs(tr[v][i] - ref["v"][j])) <= tol


def test_halt_mode_passes_on_or_ends_the_run():
    """Mode.halt (generic): a halt mode whose guard is beyond its level at entry passes on at
    once; otherwise the run ends with Status.HALTED and the mode's message."""
    s = hybrid.HybridSystem(
        name="halting",
        variables=["x"],
        parameters=["a"],
        modes=[
            Mode("go", derivatives={"x": "1"}),
            Mode("check", derivatives={"x": "0"}, halt="x went past 1 with a <= 0"),
            Mode("after", derivatives={"x": "-1"}),
        ],
        transitions=[
            hybrid.Transition("go", "check", "x - 1", 1, "past"),
            hybrid.Transition("check", "after", "a*x", 1, "allowed"),
        ],
        initial_mode="go",
    )
    tr = simulate(s, {"a": 1.0}, (0.0, 2.0), {"x": 0.0}, options=IDA)
    assert tr.status == Status.COMPLETED
    assert tr.final("x") == pytest.approx(0.0, abs=1e-9)
    assert [e.target for e in tr.events] == ["check", "after"]
    tr = simulate(s, {"a": -1.0}, (0.0, 2.0), {"x": 0.0}, options=IDA, throw=False)
    assert tr.status == Status.HALTED
    assert tr.t_final == pytest.approx(1.0, abs=1e-9)
    assert "halted at t=" in tr.message
    assert "x went past 1 with a <= 0" in tr.message
    with pytest.raises(ModelError, match="`halt` must be printable text"):
        Mode("bad", halt="line\nbreak")
