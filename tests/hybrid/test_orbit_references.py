"""Self-tests of the reference periodic orbits in ``orbit_problems.py``.

Each reference is checked against a second, independent computation (solve_ivp of the
equations written out here, finite differences, an exact identity such as Liouville's
``det M = exp(-c T/m)`` or an energy balance), and the model strings of each system are checked
against the reference trajectories by a small ``ast``-whitelist evaluator written here, so
that a mismatch between a model and its reference cannot hide. No hybrid-engine solver is used.
"""

from __future__ import annotations

import ast
import math
import operator

import numpy as np
import orbit_problems as op
import pytest
from scipy.integrate import solve_ivp

# ----------------------------------------------------------------------------
# Helpers: evaluate the model strings independently of the engine
# ----------------------------------------------------------------------------
_BINOPS = {ast.Add: operator.add, ast.Sub: operator.sub, ast.Mult: operator.mul, ast.Div: operator.truediv}
_FUNCS = {"sin": math.sin, "cos": math.cos, "exp": math.exp, "sqrt": math.sqrt, "abs": abs}


def _evaluate(text: str, lookup) -> float:
    """Value of an expression string: numbers, names, + - * / **, unary -, a few functions."""

    def ev(node):
        if isinstance(node, ast.Expression):
            return ev(node.body)
        if isinstance(node, ast.Constant) and isinstance(node.value, int | float):
            return float(node.value)
        if isinstance(node, ast.Name):
            return math.pi if node.id == "pi" else lookup(node.id)
        if isinstance(node, ast.BinOp) and type(node.op) in _BINOPS:
            return _BINOPS[type(node.op)](ev(node.left), ev(node.right))
        if isinstance(node, ast.BinOp) and isinstance(node.op, ast.Pow):
            return ev(node.left) ** ev(node.right)
        if isinstance(node, ast.UnaryOp) and isinstance(node.op, ast.USub):
            return -ev(node.operand)
        if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and len(node.args) == 1:
            return _FUNCS[node.func.id](ev(node.args[0]))
        raise ValueError(f"unsupported expression {ast.dump(node)!r} in {text!r}")

    return ev(ast.parse(text, mode="eval"))


def _environment(system, mode: str, params, t: float, y):
    """A name lookup: variables, parameters, t, and definitions (the mode's own first)."""
    m = system.mode(mode)
    defs = {**system.definitions, **m.definitions}
    values = dict(zip(system.variable_names, (float(v) for v in y), strict=True))
    values.update(params)
    values["t"] = t

    def lookup(name):
        if name in values:
            return values[name]
        if name in defs:
            values[name] = _evaluate(defs[name], lookup)
            return values[name]
        raise KeyError(f"unknown name `{name}`")

    return lookup


def _model_rates(system, mode, params, t, y):
    """``({variable: derivative}, {slave: residual})`` of the model strings at ``(t, y)``."""
    m = system.mode(mode)
    lookup = _environment(system, mode, params, t, y)
    derivs = {**system.equations, **m.derivatives}
    for n in m.algebraic:
        derivs.pop(n, None)
    return (
        {n: _evaluate(e, lookup) for n, e in derivs.items()},
        {n: _evaluate(e, lookup) for n, e in m.algebraic.items()},
    )


def _sample_times(ref, n: int = 9, margin: float = 1e-3):
    """Times in (0, T) at least ``margin * T`` away from every switch."""
    T = ref.period
    sw = [s[0] for s in ref.switches]
    out = []
    for t in np.linspace(0.05 * T, 0.95 * T, 4 * n):
        if all(abs(t - s) > margin * T for s in sw):
            out.append(float(t))
    return out[:: max(1, len(out) // n)]


# ----------------------------------------------------------------------------
# Fixtures (each reference is built once per module)
# ----------------------------------------------------------------------------
@pytest.fixture(scope="module")
def linear():
    return op.forced_linear_2dof()


@pytest.fixture(scope="module")
def linear_slave():
    return op.forced_linear_2dof_slave()


@pytest.fixture(scope="module")
def duffing():
    return op.duffing()


@pytest.fixture(scope="module")
def friction():
    return op.friction_oscillator()


@pytest.fixture(scope="module")
def impact():
    return op.impact_oscillator()


def _all_orbits(linear, linear_slave, duffing, friction, impact):
    system_d, params_d, dref = duffing
    out = [linear, linear_slave, friction, impact]
    out += [(system_d, o.params, o) for o in dref.orbits + dref.folds]
    return out


@pytest.fixture(scope="module")
def every_orbit(linear, linear_slave, duffing, friction, impact):
    return _all_orbits(linear, linear_slave, duffing, friction, impact)


# ----------------------------------------------------------------------------
# Generic checks on every reference orbit
# ----------------------------------------------------------------------------
def test_every_reference_is_consistent(every_orbit):
    for system, params, ref in every_orbit:
        assert ref.variable_names == system.variable_names
        assert ref.x0.shape == (len(system.variable_names),)
        assert set(ref.state_names) <= set(system.variable_names)
        assert not set(ref.state_names) & set(system.quadratures)
        assert ref.monodromy.shape == (len(ref.state_names),) * 2
        # multipliers are the eigenvalues of the monodromy, by decreasing modulus
        assert op.multiplier_distance(ref.multipliers, np.linalg.eigvals(ref.monodromy)) < 1e-12
        assert np.all(np.diff(np.abs(ref.multipliers)) <= 1e-12)
        if ref.stability != "neutral":
            assert ref.stability == op.classify_multipliers(ref.multipliers)
        assert math.isclose(ref.period, 2 * math.pi / params["Omega"], rel_tol=1e-15)
        assert ref.mode_sequence[0] == ref.mode0 == ref.mode_at(0.0)
        assert all(ref.x0_dict[q] == 0.0 for q in system.quadratures)
        assert set(ref.increments) == set(system.quadratures)
        assert np.allclose(ref.state(), [ref.x0_dict[n] for n in ref.state_names])
        if "det_monodromy" in ref.details:
            assert (
                abs(np.linalg.det(ref.monodromy) - ref.details["det_monodromy"])
                < 10 * ref.accuracy["monodromy"]
            )


def test_trajectory_closes_and_carries_the_increments(every_orbit):
    for system, _, ref in every_orbit:
        tol = ref.accuracy.get("trajectory", ref.accuracy["x0"])
        ends = ref.trajectory([0.0, ref.period])
        assert np.max(np.abs(ends[0] - ref.x0)) < tol, system.name
        index = {n: i for i, n in enumerate(ref.variable_names)}
        for n in ref.state_names:
            assert abs(ends[1, index[n]] - ref.x0[index[n]]) < tol, (system.name, n)
        for q, dq in ref.increments.items():
            assert abs(ends[1, index[q]] - dq) < tol, (system.name, q)


def test_model_strings_agree_with_reference_trajectories(every_orbit):
    """d/dt of the reference trajectory equals the model's derivative strings, in every mode;
    slave residuals vanish. Central differences with h = 1e-5 s (error ~1e-10 on closed forms,
    ~1e-6 on the Duffing dense output)."""
    h = 1e-5
    for system, params, ref in every_orbit:
        tol = 1e-6 if system.name == "duffing" else 1e-8
        seen = set()
        for t in _sample_times(ref):
            mode = ref.mode_at(t)
            seen.add(mode)
            y_m, y, y_p = ref.trajectory([t - h, t, t + h])
            derivs, residuals = _model_rates(system, mode, params, t, y)
            for n, rate in derivs.items():
                i = ref.variable_names.index(n)
                fd = (y_p[i] - y_m[i]) / (2 * h)
                assert abs(rate - fd) < tol * (1 + abs(rate)), (system.name, mode, n, t, rate, fd)
            for n, r in residuals.items():
                assert abs(r) < 1e-12, (system.name, n, r)
        assert seen == set(ref.mode_sequence), (system.name, seen)


def test_guards_vanish_at_the_reference_switches(friction, impact):
    for system, params, ref in (friction, impact):
        assert ref.switches
        for t, source, target in ref.switches:
            y = ref.trajectory([t])[0]
            lookup = _environment(system, source, params, t, y)
            guards = [tr for tr in system.transitions if tr.source == source and tr.target == target]
            assert len(guards) == 1
            assert abs(_evaluate(guards[0].guard, lookup)) < 1e-12, (system.name, source, target)


# ----------------------------------------------------------------------------
# 1. Linear oscillators
# ----------------------------------------------------------------------------
def _linear_rhs(p):
    def rhs(t, y):
        x1, v1, x2, v2 = y[:4]
        f = p["F"] * math.sin(p["Omega"] * t)
        a1 = (f - p["k1"] * x1 - p["c1"] * v1 - p["k2"] * (x1 - x2) - p["c2"] * (v1 - v2)) / p["m1"]
        a2 = (-p["k2"] * (x2 - x1) - p["c2"] * (v2 - v1)) / p["m2"]
        return [v1, a1, v2, a2, f * v1, p["c1"] * v1**2 + p["c2"] * (v1 - v2) ** 2]

    return rhs


def test_linear_orbit_and_energy_by_solve_ivp(linear):
    _, p, ref = linear
    sol = solve_ivp(_linear_rhs(p), (0, ref.period), ref.x0, method="DOP853", rtol=1e-13, atol=1e-15)
    assert np.max(np.abs(sol.y[:4, -1] - ref.x0[:4])) < 1e-11
    assert abs(sol.y[4, -1] - ref.increments["W"]) < 1e-12
    assert abs(sol.y[5, -1] - ref.increments["D"]) < 1e-12
    assert abs(ref.increments["W"] - ref.increments["D"]) < 1e-15  # energy balance of a periodic orbit


def test_linear_monodromy_by_variational_equations(linear):
    _, p, ref = linear
    rhs = _linear_rhs(dict(p, F=0.0))
    cols = [
        solve_ivp(rhs, (0, ref.period), np.r_[e, 0, 0], method="DOP853", rtol=1e-13, atol=1e-15).y[:4, -1]
        for e in np.eye(4)
    ]
    assert np.max(np.abs(np.column_stack(cols) - ref.monodromy)) < 1e-11
    # modulus of the multipliers: the damping rates of the two modes
    rates = sorted(math.log(abs(mu)) / ref.period for mu in ref.multipliers)
    assert np.allclose(rates, sorted(ref.details["eigenvalue_real_parts"]), atol=1e-13)
    assert ref.stability == "stable"
    assert all(abs(mu.imag) > 0.1 for mu in ref.multipliers)  # two oscillatory modes


def test_linear_slave_variant_shares_the_differential_solution(linear, linear_slave):
    system, p, ref = linear_slave
    assert system.algebraic_variables("linear") == ("u",)
    assert ref.state_names == ("x1", "v1", "x2", "v2")
    _, _, ref0 = linear  # k2 k3/(k2 + k3) = 0.6 = k2 of the plain chain
    assert np.max(np.abs(ref.state() - ref0.state())) < 1e-15
    assert np.max(np.abs(ref.monodromy - ref0.monodromy)) < 1e-13
    assert ref.increments["W"] == pytest.approx(ref0.increments["W"], rel=1e-14)
    u = ref.x0_dict["u"]
    assert abs((p["k2"] + p["k3"]) * u - p["k2"] * ref.x0_dict["x1"] - p["k3"] * ref.x0_dict["x2"]) < 1e-15
    assert ref.amplitude["u"] == pytest.approx(
        np.max(np.abs(ref.trajectory(np.linspace(0, ref.period, 4001))[:, 4])), rel=1e-6
    )


# ----------------------------------------------------------------------------
# 2. Duffing oscillator
# ----------------------------------------------------------------------------
#: Fold frequencies [rad/s] of the default Duffing set (regression anchors).
DUFFING_FOLDS = (1.112711260452889, 1.256394847149698)


def test_duffing_fold_values(duffing):
    _, p, ref = duffing
    assert np.allclose(ref.band, DUFFING_FOLDS, rtol=0, atol=1e-11)
    assert [f.params["Omega"] for f in ref.folds] == list(ref.band)
    # harmonic balance is a good first guess but not exact
    hb = [w for w, _ in ref.harmonic_balance_folds]
    assert np.allclose(hb, ref.band, atol=3e-3)
    assert not np.allclose(hb, ref.band, atol=1e-5)
    assert ref.band[1] - ref.band[0] == pytest.approx(0.1437, abs=1e-4)


def test_duffing_folds_by_parabola_vertex(duffing):
    """Independent of det(I - M) = 0: the extremum of Omega along the branch."""
    _, _, ref = duffing
    for fold in ref.folds:
        assert abs(op.duffing_fold_by_parabola(fold, h=1e-3) - fold.params["Omega"]) < 1e-10


def test_duffing_fold_orbits(duffing):
    _, p, ref = duffing
    for fold in ref.folds:
        T = fold.period
        mu = fold.multipliers
        assert abs(mu[0] - 1) < 1e-9
        assert abs(mu[0].imag) == 0
        assert abs(mu[1] - math.exp(-p["c"] * T / p["m"])) < 1e-9
        assert fold.stability == "neutral"
        # closes on itself at a coarser tolerance too
        yT, M, _, _ = op.duffing_period_map(fold.params, fold.state(), rtol=1e-11)
        assert np.max(np.abs(yT - fold.state())) < 1e-10
        assert np.max(np.abs(M - fold.monodromy)) < 1e-9


def test_duffing_monodromy_by_finite_differences(duffing):
    _, _, ref = duffing
    orbit = ref.orbits[1]

    def pmap(y):
        return op.duffing_period_map(orbit.params, y)[0]

    fd = op._richardson_jacobian(pmap, orbit.state(), 1e-3)
    assert np.max(np.abs(fd - orbit.monodromy)) < 1e-8


def test_duffing_three_orbits_inside_the_band(duffing):
    _, p, ref = duffing
    assert ref.band[0] < p["Omega"] < ref.band[1]
    low, mid, high = ref.orbits
    assert [o.stability for o in ref.orbits] == ["stable", "unstable", "stable"]
    assert low.amplitude["x"] < mid.amplitude["x"] < high.amplitude["x"]
    detM = math.exp(-p["c"] * low.period / p["m"])
    for o in ref.orbits:
        assert abs(np.prod(o.multipliers) - detM) < 1e-11  # Liouville
        assert abs(o.increments["W"] - o.increments["D"]) < 1e-11  # energy balance
        yT, _, _, _ = op.duffing_period_map(o.params, o.state(), rtol=1e-12)
        assert np.max(np.abs(yT - o.state())) < 1e-11
        lo, hi = o.extrema["x"]
        assert hi == pytest.approx(-lo, abs=1e-10)  # symmetric orbits: x(t + T/2) = -x(t)
    # stable orbits: a complex pair on the circle of radius sqrt(det M); the saddle: real mu > 1
    for o in (low, high):
        assert np.allclose(np.abs(o.multipliers), math.sqrt(detM), atol=1e-11)
    assert mid.multipliers[0].real > 1.3
    assert mid.multipliers.imag.max() == 0
    # harmonic balance amplitudes are within 2 %
    hb = [a for a, _ in op.duffing_harmonic_balance(p)]
    assert np.allclose(hb, [o.amplitude["x"] for o in ref.orbits], rtol=2e-2)


def test_duffing_single_orbit_outside_the_band(duffing):
    _, p, ref = duffing
    for W in (ref.band[0] - 0.01, ref.band[1] + 0.01):
        orbits = op.duffing_orbits(dict(p, Omega=W))
        assert len(orbits) == 1
        assert orbits[0].stability == "stable"


def test_duffing_amplitude_from_dense_samples(duffing):
    _, _, ref = duffing
    o = ref.orbits[2]
    x = o.trajectory(np.linspace(0, o.period, 20001))[:, 0]
    assert np.max(np.abs(x)) <= o.amplitude["x"] + 1e-10
    assert np.max(np.abs(x)) > o.amplitude["x"] - 1e-6


# ----------------------------------------------------------------------------
# 3. Friction oscillator
# ----------------------------------------------------------------------------
def test_friction_orbit_from_a_long_solve_ivp_run(friction):
    """A second implementation (solve_ivp event loop) from rest in stick converges to x0."""
    _, p, ref = friction
    x, v, mode, log = op.friction_simulate_ivp(p, 30 * ref.period, 0.0, 0.0, "stick")
    assert mode == ref.mode0
    assert abs(x - ref.x0[0]) < 1e-9
    assert abs(v - ref.x0[1]) < 1e-9
    assert len(log) == 1 + 4 * 30  # first breakaway, then four switches per period


def test_friction_switches_match_solve_ivp(friction):
    _, p, ref = friction
    x, v, mode, log = op.friction_simulate_ivp(p, ref.period, ref.x0[0], ref.x0[1], ref.mode0)
    assert [s[1:] for s in log] == [s[1:] for s in ref.switches]
    assert np.allclose([s[0] for s in log], [s[0] for s in ref.switches], rtol=0, atol=1e-9)
    assert abs(x - ref.x0[0]) < 1e-10
    assert abs(v - ref.x0[1]) < 1e-10
    assert ref.mode_sequence == ("slip+", "stick", "slip-", "stick", "slip+")


def test_friction_orbit_is_symmetric_with_two_sticks(friction):
    _, p, ref = friction
    T = ref.period
    half = ref.trajectory([T / 2])[0]
    assert np.max(np.abs(half[:2] + ref.x0[:2])) < 1e-12
    (t1, *_), (t2, *_), (t3, *_), (t4, *_) = ref.switches
    assert t3 - t1 == pytest.approx(T / 2, abs=1e-12)
    assert t4 - t2 == pytest.approx(T / 2, abs=1e-12)
    assert ref.details["stick_fraction"] == pytest.approx(2 * (t2 - t1) / T, rel=1e-12)
    assert 0.1 < ref.details["stick_fraction"] < 0.2
    assert all(0.3 < r < 0.7 for r in ref.details["H_turn_over_R"])  # far from reversal
    assert ref.details["x_stick"][0] == pytest.approx(-ref.details["x_stick"][1], abs=1e-13)


def test_friction_energy_balance(friction):
    _, p, ref = friction
    inc = ref.increments
    assert abs(inc["W"] - inc["D"]) < 1e-12  # periodic: input work = dissipation
    # friction dissipation: R times the distance slid, 4 amplitudes per period
    assert abs(inc["Df"] - 4 * p["R"] * ref.amplitude["x"]) < 1e-13
    assert inc["D"] - inc["Df"] == pytest.approx(ref.details["Dv"], abs=1e-14)
    assert ref.details["Dv"] > 0.2 * inc["D"]  # the damper matters


def test_friction_monodromy(friction):
    _, p, ref = friction
    mu = ref.multipliers
    assert abs(mu[1]) < 1e-9  # entering stick: a zero multiplier
    assert 0.07 < abs(mu[0]) < 0.09
    assert mu[0].imag == 0
    assert abs(np.linalg.det(ref.monodromy)) < 1e-9
    assert ref.stability == "stable"

    def pmap(y):
        return np.array(op.friction_period_map(p, y[0], y[1], ref.mode0)[:2])

    other = op._richardson_jacobian(pmap, ref.state(), 3e-4)
    assert np.max(np.abs(other - ref.monodromy)) < 1e-9


def test_friction_stick_boundary(friction):
    _, p, _ = friction
    W = op.friction_stick_boundary(p)
    assert W == pytest.approx(0.5897084721166495, abs=1e-11)
    below = op.friction_oscillator(Omega=W - 1e-3)[2]
    above = op.friction_oscillator(Omega=W + 1e-3)[2]
    assert 0 < below.details["stick_fraction"] < 0.01
    assert below.mode_sequence == ("slip+", "stick", "slip-", "stick", "slip+")
    assert above.details["stick_fraction"] == 0
    assert above.mode_sequence == ("slip+", "slip-", "slip+")
    assert all(r > 1 for r in above.details["H_turn_over_R"])


# ----------------------------------------------------------------------------
# 4. Impact oscillator
# ----------------------------------------------------------------------------
def _impact_ivp(p, x0, v0, t_end):
    """Event loop around solve_ivp, independent of the closed form."""

    def rhs(t, y):
        return [y[1], (p["F"] * math.sin(p["Omega"] * t) - p["k"] * y[0] - p["c"] * y[1]) / p["m"]]

    def wall(t, y):
        return y[0] - p["g"]

    wall.terminal, wall.direction = True, 1
    t, y, impacts = 0.0, [x0, v0], []
    while True:
        sol = solve_ivp(rhs, (t, t_end), y, method="DOP853", events=wall, rtol=1e-13, atol=1e-15)
        if sol.status == 0:
            return sol.y[:, -1], impacts
        t = float(sol.t_events[0][0])
        xe, ve = sol.y_events[0][0]
        impacts.append((t, ve))
        y = [p["g"], -p["r"] * ve]


def test_impact_orbit_by_solve_ivp(impact):
    _, p, ref = impact
    y, impacts = _impact_ivp(p, ref.x0[0], ref.x0[1], ref.period)
    assert np.max(np.abs(y - ref.x0[:2])) < 1e-10
    assert len(impacts) == 1
    assert impacts[0][0] == pytest.approx(ref.details["t_impact"], abs=1e-10)
    assert impacts[0][1] == pytest.approx(ref.details["v_impact"], abs=1e-10)


def test_impact_saltation_determinant_and_energy(impact):
    _, p, ref = impact
    assert abs(np.linalg.det(ref.monodromy) - p["r"] ** 2 * math.exp(-p["c"] * ref.period / p["m"])) < 1e-9
    assert ref.stability == "stable"
    assert np.allclose(np.abs(ref.multipliers), math.sqrt(ref.details["det_monodromy"]), atol=1e-9)
    inc = ref.increments
    assert abs(inc["W"] - inc["D"] - ref.details["impact_loss"]) < 1e-13
    assert ref.extrema["x"][1] == p["g"]


def test_impact_grazing_frequency(impact):
    _, p, _ = impact
    (Wg,) = op.impact_grazing_frequencies(p)
    X = p["F"] / abs(p["k"] - p["m"] * Wg**2 + 1j * p["c"] * Wg)
    assert X == pytest.approx(p["g"], rel=1e-14)
    # just above grazing the steady state misses the wall, just below it impacts
    assert op.impact_period_map(dict(p, Omega=Wg + 0.05), *_linear_state(dict(p, Omega=Wg + 0.05)))[2] == 0
    assert _linear_state(dict(p, Omega=Wg - 0.05), amplitude=True) > p["g"]


def _linear_state(p, amplitude=False):
    X = p["F"] / (p["k"] - p["m"] * p["Omega"] ** 2 + 1j * p["c"] * p["Omega"])
    return abs(X) if amplitude else (X.imag, p["Omega"] * X.real)


# ----------------------------------------------------------------------------
# Helpers and argument checks
# ----------------------------------------------------------------------------
def test_classify_and_distance():
    assert op.classify_multipliers([0.5, 0.2j]) == "stable"
    assert op.classify_multipliers([1.0, 0.2]) == "neutral"
    assert op.classify_multipliers([-1.1, 0.2]) == "unstable"
    assert op.multiplier_distance([1, 2j], [2j, 1 + 1e-3]) == pytest.approx(1e-3)
    with pytest.raises(ValueError, match="`mu` has 2 multipliers, `mu_ref` has 1"):
        op.multiplier_distance([1, 2], [1])


@pytest.mark.parametrize(
    ("call", "match"),
    [
        (lambda: op.forced_linear_2dof(m1=0.0), "`m1` must be a finite number > 0"),
        (lambda: op.forced_linear_2dof_slave(k3=-1.0), "`k3` must be a finite number > 0"),
        (lambda: op.duffing(k3=-0.1), "`c` and `k3` must be > 0"),
        (lambda: op.friction_oscillator(c=3.0), "underdamped"),
        (lambda: op.impact_oscillator(r=1.5), r"`r` must be in \(0, 1\]"),
        (
            lambda: op.impact_grazing_frequencies({"m": 1, "c": 0.1, "k": 1, "g": 0.0, "F": 1}),
            "`g` must be > 0",
        ),
    ],
)
def test_bad_arguments(call, match):
    with pytest.raises(ValueError, match=match):
        call()
