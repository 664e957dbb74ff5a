"""Systems composed of components, their modes composed on demand (issue 22).

References: the same systems with every combination of local modes written out as modes (the
engine's established path), an independent event-driven solver of the friction chain
(``benchmarks/reference_chain.py``; its results in ``data/chain_reference.json``), the symmetry of
a ring of identical blocks (each moves as one block alone), the energy balance, and finite
differences of the period map.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from chains import chain_params, composed_chain, enumerated_chain

import hybrid
import hybrid.integrators.assembly as assembly
from hybrid import (
    IDA,
    Component,
    Exact,
    HybridSystem,
    Mode,
    SolverOptions,
    Transition,
    Variable,
    method_named,
    simulate,
)
from hybrid.model.compiled import CompiledSystem

EXACT = SolverOptions(method=Exact())
TIGHT = SolverOptions(method=IDA(rtol=1e-11, atol=1e-13))
DATA = Path(__file__).parent / "data"


def _run(system, p, options, t_end=50.0):
    n = len(system.variable_names)
    tr = simulate(system, p, (0.0, t_end), np.zeros(n), options=options, throw=False)
    assert tr.success, tr.message
    return tr


# ---------------------------------------------------------------------------------------------
# the composed system equals the enumerated one
@pytest.mark.parametrize("n", [2, 3])
def test_a_composed_chain_equals_the_enumerated_one_exactly(n):
    p = chain_params(n)
    a = _run(composed_chain(n), p, EXACT)
    b = _run(enumerated_chain(n), p, EXACT)
    assert len(a.events) == len(b.events)
    assert [e.guard for e in a.events] == [e.guard for e in b.events]
    np.testing.assert_allclose([e.t for e in a.events], [e.t for e in b.events], rtol=0, atol=1e-14)
    np.testing.assert_allclose(a.y_final, b.y_final, rtol=0, atol=1e-13)


@pytest.mark.slow
def test_a_composed_chain_equals_the_enumerated_one_with_ida():
    n = 3
    p = chain_params(n)
    a = _run(composed_chain(n), p, TIGHT)
    b = _run(enumerated_chain(n), p, TIGHT)
    assert [e.guard for e in a.events] == [e.guard for e in b.events]
    np.testing.assert_allclose(a.y_final, b.y_final, rtol=0, atol=1e-9)


def test_mode_names_list_the_parts():
    system = composed_chain(3)
    assert system.composed
    assert system.default_mode == "motion|stick|stick|stick"
    assert system.mode_key("motion|slip+|stick|slip-") == (0, 1, 0, 2)
    assert system.mode_label((0, 2, 2, 0)) == "motion|slip-|slip-|stick"
    mode = system.mode("motion|slip+|stick|stick")
    assert set(mode.algebraic) == {"f1", "f2", "f3"}
    with pytest.raises(hybrid.InputError, match=r"has 2 parts; .* each of its 3 components, joined by `\|`"):
        system.mode_key("motion|stick")
    with pytest.raises(
        hybrid.InputError, match=r"component `c2` has no mode `slide`; its modes: stick, slip\+, slip-"
    ):
        system.mode_key("motion|stick|slide|stick")


# ---------------------------------------------------------------------------------------------
# against independent references
@pytest.mark.parametrize("n", [1, 2, 6, 20])
def test_the_chain_matches_an_independent_event_driven_solver(n):
    """benchmarks/reference_chain.py (numpy/scipy, written apart from the library; energy balance
    to 1e-15, against solve_ivp at rtol 1e-12 to 3.4e-10): displacements and velocities at t = 50."""
    ref = json.loads((DATA / "chain_reference.json").read_text())["chains"][str(n)]
    tr = _run(composed_chain(n), chain_params(n), EXACT)
    x, v = tr.y_final[0::3], tr.y_final[1::3]
    np.testing.assert_allclose(x, ref["x_end"], rtol=0, atol=1e-10)
    np.testing.assert_allclose(v, ref["v_end"], rtol=0, atol=1e-10)
    breakaways = [e for e in tr.events if ".breakaway" in e.guard]
    assert len(breakaways) == ref["n_switches"] + ref["n_reversals"]  # a reversal passes through stick


def test_a_ring_of_identical_blocks_moves_as_one_block():
    """By symmetry every block of a ring of equal blocks moves as a single block (its springs to the
    neighbours stay unstretched): all contacts switch at the same instants, each a chain of 8
    simultaneous switches decided at once."""
    n = 8
    ring = composed_chain(n, ring=True)
    p = chain_params(n, mistuning=0.0)
    tr = _run(ring, p, EXACT, t_end=30.0)
    single = _run(composed_chain(1), chain_params(1, mistuning=0.0, R1=0.3), EXACT, t_end=30.0)
    for i in range(n):
        np.testing.assert_allclose(tr.y_final[3 * i : 3 * i + 3], single.y_final, rtol=0, atol=1e-12)
    instants = sorted({e.t for e in tr.events})
    assert len(tr.events) == n * len(single.events)
    np.testing.assert_allclose(instants, sorted({e.t for e in single.events}), rtol=0, atol=1e-12)


# ---------------------------------------------------------------------------------------------
# simultaneous switches: sticking one contact releases another
def _stack() -> tuple[HybridSystem, HybridSystem]:
    """Mass m1 rubs on mass m2 (contact e1), m2 on the ground (e2); m1 forced. When e1 sticks, e2
    must hold both masses and may break away at that instant."""
    acc1, acc2 = "F*sin(Omega*t) - k1*x1 + f1", "-k2*x2 - f1 + f2"
    mean = "(m1*v1 + m2*v2)/(m1 + m2)"
    e1 = (
        [
            Mode("stick", algebraic={"f1": f"({acc2})/m2 - ({acc1})/m1"}),
            Mode("slip+", algebraic={"f1": "f1 - R1"}),
            Mode("slip-", algebraic={"f1": "f1 + R1"}),
        ],
        [
            Transition("stick", "slip+", "f1 - R1", 1, name="breakaway+"),
            Transition("stick", "slip-", "f1 + R1", -1, name="breakaway-"),
            Transition("slip+", "stick", "v2 - v1", -1, name="stop+", reset={"v1": mean, "v2": mean}),
            Transition("slip-", "stick", "v2 - v1", 1, name="stop-", reset={"v1": mean, "v2": mean}),
        ],
    )
    e2 = (
        [
            Mode("stick", algebraic={"f2": acc2}),
            Mode("slip+", algebraic={"f2": "f2 - R2"}),
            Mode("slip-", algebraic={"f2": "f2 + R2"}),
        ],
        [
            Transition("stick", "slip+", "f2 - R2", 1, name="breakaway+"),
            Transition("stick", "slip-", "f2 + R2", -1, name="breakaway-"),
            Transition("slip+", "stick", "-v2", -1, name="stop+", reset={"v2": "0"}),
            Transition("slip-", "stick", "-v2", 1, name="stop-", reset={"v2": "0"}),
        ],
    )
    common = dict(
        variables=[Variable(v) for v in ("x1", "v1", "x2", "v2", "f1", "f2")],
        parameters=["m1", "m2", "k1", "k2", "F", "Omega", "R1", "R2"],
        equations={"x1": "v1", "v1": f"({acc1})/m1", "x2": "v2", "v2": f"({acc2})/m2"},
        period="2*pi/Omega",
    )
    composed = HybridSystem(
        name="stack", modes=[Mode("motion")], transitions=[], initial_mode="motion",
        components=[Component("e1", *e1), Component("e2", *e2)], **common,
    )  # fmt: skip
    states = ("stick", "slip+", "slip-")
    modes, transitions = [], []
    for a in states:
        for b in states:
            alg = {**e1[0][states.index(a)].algebraic, **e2[0][states.index(b)].algebraic}
            modes.append(Mode(f"{a}_{b}", algebraic=alg))
            for tr in e1[1]:
                if tr.source == a:
                    transitions.append(
                        Transition(
                            f"{a}_{b}",
                            f"{tr.target}_{b}",
                            tr.guard,
                            tr.direction,
                            name=f"e1.{tr.name}",
                            reset=dict(tr.reset),
                        )
                    )
            for tr in e2[1]:
                if tr.source == b:
                    transitions.append(
                        Transition(
                            f"{a}_{b}",
                            f"{a}_{tr.target}",
                            tr.guard,
                            tr.direction,
                            name=f"e2.{tr.name}",
                            reset=dict(tr.reset),
                        )
                    )
    enumerated = HybridSystem(
        name="stack_e", modes=modes, transitions=transitions, initial_mode="stick_stick", **common
    )
    return composed, enumerated


STACK = {"m1": 0.5, "m2": 1.0, "k1": 1.0, "k2": 1.0, "F": 1.0, "Omega": 0.8, "R1": 0.5, "R2": 0.4}


def test_sticking_one_contact_releases_another_at_the_same_instant():
    composed, enumerated = _stack()
    a = _run(composed, STACK, EXACT, t_end=60.0)
    b = _run(enumerated, STACK, EXACT, t_end=60.0)
    pairs = [
        (e, f)
        for e, f in zip(a.events, a.events[1:], strict=False)
        if e.guard.startswith("e1.stop") and f.guard.startswith("e2.breakaway") and f.t == e.t
    ]
    assert len(pairs) >= 10
    for _, f in pairs:
        assert f.chained
        assert abs(f.x_plus[5]) <= STACK["R2"] * (1 + 1e-12)  # e2 slides at its level
    assert [e.guard for e in a.events] == [e.guard for e in b.events]
    np.testing.assert_allclose(a.y_final, b.y_final, rtol=0, atol=1e-13)


def test_no_consistent_successor_names_the_switches():
    """Two components that send each other round: a stops naming the switches of the loop."""
    a = Component(
        "A",
        [Mode("a0", algebraic={"s": "s"}), Mode("a1", algebraic={"s": "s - 1"})],
        [Transition("a0", "a1", "r - 0.5", 1, name="up"), Transition("a1", "a0", "0.5 - r", 1, name="down")],
    )
    b = Component(
        "B",
        [Mode("b0", algebraic={"r": "r"}), Mode("b1", algebraic={"r": "r - 1"})],
        [Transition("b0", "b1", "0.5 - s", 1, name="up"), Transition("b1", "b0", "s - 0.5", 1, name="down")],
    )
    system = HybridSystem(
        name="pingpong", variables=["x", "s", "r"], parameters=[], modes=[Mode("m", derivatives={"x": "1"})],
        transitions=[], initial_mode="m", components=[a, b],
    )  # fmt: skip
    tr = simulate(system, {}, (0.0, 1.0), [0.0, 0.0, 0.0], throw=False)
    assert tr.status == hybrid.Status.NO_ADMISSIBLE_MODE
    assert "B.up -> A.up -> B.down -> A.down" in tr.message, tr.message


# ---------------------------------------------------------------------------------------------
# the large-system path of the exact integrator
def test_the_sparse_taylor_path_equals_the_dense_eigen_path(monkeypatch):
    n = 6
    p = chain_params(n)
    dense = _run(composed_chain(n), p, EXACT)
    monkeypatch.setattr(assembly, "DENSE_LIMIT", 0)
    monkeypatch.setattr(assembly, "dense_is_cheaper", lambda am: False)  # the sparse path, whatever it costs
    system = composed_chain(n)
    sparse = _run(system, p, EXACT)
    cs = CompiledSystem(system, p)
    from hybrid.integrators.flows import exact_flows

    assert isinstance(exact_flows(cs)[cs.mode_id(system.default_mode)], assembly.SparseAffineMode)
    assert [e.guard for e in sparse.events] == [e.guard for e in dense.events]
    np.testing.assert_allclose([e.t for e in sparse.events], [e.t for e in dense.events], rtol=0, atol=1e-12)
    np.testing.assert_allclose(sparse.y_final, dense.y_final, rtol=0, atol=1e-11)


@pytest.mark.slow
def test_energy_balance_of_a_large_chain():
    """Work of the forces = energy dissipated by the dampers and the contacts + change of the
    mechanical energy, summed from the samples of a run of 64 blocks (sparse path)."""
    n = 64
    system = composed_chain(n)
    p = chain_params(n)
    tr = simulate(system, p, (0.0, 12.0), np.zeros(3 * n), options=EXACT, t_eval=np.linspace(0, 12, 24001))
    t, y = tr.t, tr.y
    x, v, f = y[:, 0::3], y[:, 1::3], y[:, 2::3]
    power_in = p["F"] * np.sin(p["Omega"] * t)[:, None] * v
    dissipated = p["c"] * v**2 - f * v
    energy = (
        0.5 * (v**2).sum(1) + 0.5 * p["k"] * (x**2).sum(1) + 0.5 * p["kc"] * (np.diff(x, axis=1) ** 2).sum(1)
    )
    lhs = np.trapezoid(power_in.sum(1) - dissipated.sum(1), t)
    assert abs(lhs - (energy[-1] - energy[0])) <= 2e-6 * max(1.0, abs(energy[-1]))


# ---------------------------------------------------------------------------------------------
# periodic orbits of composed systems
@pytest.mark.parametrize("integrator", ["exact", "ida"])
def test_a_composed_orbit_equals_the_enumerated_one(integrator):
    # R3 apart from R1: the end blocks do not reverse together. (Where they do, only the composed
    # system knows the two switches are independent, two components': a system without
    # components takes a chained switch as caused by the one before it, see
    # test_the_monodromy_of_a_composed_orbit_against_finite_differences.)
    n = 3
    p = chain_params(n, R3=0.25)
    options = SolverOptions(
        method=(IDA(rtol=1e-11, atol=1e-13) if integrator == "ida" else method_named(integrator))
    )
    a = hybrid.periodic_orbit(composed_chain(n), p, options=options)
    b = hybrid.periodic_orbit(enumerated_chain(n), p, options=options)
    assert a.converged, a.message
    assert b.converged, b.message
    assert a.t0 == b.t0
    np.testing.assert_allclose(a.x0, b.x0, rtol=0, atol=1e-12)
    np.testing.assert_allclose(
        np.sort(np.abs(a.multipliers)), np.sort(np.abs(b.multipliers)), rtol=0, atol=1e-10
    )


def test_the_monodromy_of_a_composed_orbit_against_finite_differences():
    n = 3
    system = composed_chain(n)
    p = chain_params(n)
    o = hybrid.periodic_orbit(system, p, options=EXACT)
    assert o.converged, o.message
    d = [system.variable_names.index(v) for v in o.state_names if not v.startswith("f")]
    T, t0 = o.period, o.t0

    def period_map(y: np.ndarray) -> np.ndarray:
        tr = simulate(system, p, (t0, t0 + T), y, o.mode0, options=EXACT)
        return tr.y_final[d]

    h = 1e-6
    fd = np.empty((len(d), len(d)))
    for j, col in enumerate(d):
        yp, ym = o.x0.copy(), o.x0.copy()
        yp[col] += h
        ym[col] -= h
        fd[:, j] = (period_map(yp) - period_map(ym)) / (2 * h)
    rows = [o.state_names.index(system.variable_names[i]) for i in d]
    M = o.monodromy[np.ix_(rows, rows)]
    np.testing.assert_allclose(M, fd, rtol=0, atol=1e-7)
    assert math.isclose(o.period, 2 * math.pi, rel_tol=1e-15)


def test_a_family_of_two_stuck_blocks_is_held_by_their_own_gauges():
    """Blocks 2 and 5 of a 6-block chain hold (R = 5) all period: their offsets are free, a family
    of two dimensions (two neutral multipliers 1). Of the gauges x1..x6 the two that move along the
    family are picked, x2 and x5; with them at 0 block 1 (and 6) is a 1-block chain of stiffness
    k + kc, whose orbit, computed on its own, it must equal."""
    n = 6
    p = chain_params(n, R2=5.0, R5=5.0)
    o = hybrid.periodic_orbit(composed_chain(n, gauge=[f"x{i}" for i in range(1, n + 1)]), p, options=EXACT)
    assert o.converged and o.family
    assert o.multiplier_kinds.count("neutral") == 2
    assert "the member with gauges `x2`, `x5` = 0 is returned" in o.message
    # stuck all period at 0 (to rounding)
    assert np.max(np.abs(o.trajectory["x2"])) < 1e-14 and np.max(np.abs(o.trajectory["x5"])) < 1e-14
    for block, other in ((1, 1), (6, 6)):
        q = chain_params(1, k=2.0, R1=p[f"R{other}"])
        one = hybrid.periodic_orbit(composed_chain(1), q, options=EXACT)
        assert one.converged and not one.family
        # both from their sections to one instant
        a = hybrid.simulate(composed_chain(n), p, (o.t0, 4 * math.pi), o.x0, mode0=o.mode0, options=EXACT)
        b = hybrid.simulate(
            composed_chain(1), q, (one.t0, 4 * math.pi), one.x0, mode0=one.mode0, options=EXACT
        )
        assert abs(a.final(f"x{block}") - b.final("x1")) < 1e-12
        assert abs(o.amplitude[f"x{block}"] - one.amplitude["x1"]) < 1e-12


def test_a_single_gauge_that_leaves_a_direction_free_says_so():
    n = 6
    p = chain_params(n, R2=5.0, R5=5.0)
    o = hybrid.periodic_orbit(composed_chain(n, gauge="x1"), p, options=EXACT)
    assert o.converged and o.multiplier_kinds.count("neutral") == 2
    assert "1 of its directions held by no gauge" in o.message


@pytest.mark.parametrize(
    ("gauge", "words"),
    [([], "non-empty list"), (["x1", 3], "non-empty list"), (["x1", "t"], "not on t"), (["zz"], "zz")],
)
def test_a_bad_gauge_list_is_refused_naming_it(gauge, words):
    with pytest.raises(hybrid.ModelError, match=words):
        composed_chain(2, gauge=gauge)
