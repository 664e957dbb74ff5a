"""Declarative systems: validation at construction, parameters, and the compiled form.

Every malformed model must fail at construction with a ModelError naming the item at fault; the
compiled residual Jacobian, consistent derivatives and Taylor series of the flow are checked
against finite differences and closed forms.
"""

import math

import numpy as np
import pytest
from problems import logistic, nonlinear_dae, riccati

import hybrid_models
from hybrid import Component, HybridSystem, Mode, ModelError, Parameter, Transition, Variable
from hybrid.model.compiled import CompiledSystem, lead_sign


def _toy(**over):
    """A valid 1-DOF stick-slip system; tests replace one piece at a time."""
    kw = dict(
        name="toy",
        variables=["x", "v", "W"],
        parameters=[
            Parameter("k", "N/m", "stiffness", "positive"),
            Parameter("R", "N", "friction", "nonnegative"),
        ],
        definitions={"H": "k*x"},
        equations={"W": "v**2"},
        quadratures=("W",),
        modes=[
            Mode("stick", derivatives={"x": "0", "v": "0"}),
            Mode("slip", derivatives={"x": "v", "v": "-H + R"}),
        ],
        transitions=[
            Transition("stick", "slip", "H - R", 1),
            Transition("slip", "stick", "v", 1, reset={"v": "0"}),
        ],
        initial_mode="stick",
        presets={"std": {"k": 1.0, "R": 0.1}},
    )
    kw.update(over)
    return HybridSystem(**kw)


def test_toy_system_is_valid():
    s = _toy()
    assert s.variable_names == ("x", "v", "W")
    assert s.parameter_names == ("k", "R")
    assert s.mode_names == ("stick", "slip")
    assert s.mode("slip").derivatives["v"] == "-H + R"
    assert s.preset("std") == {"k": 1.0, "R": 0.1}


STICK = Mode("stick", derivatives={"x": "0", "v": "0"})
SLIP = Mode("slip", derivatives={"x": "v", "v": "-H + R"})


@pytest.mark.parametrize(
    ("over", "match"),
    [
        # names
        (dict(variables=[]), r"model `toy`: no variables"),
        (dict(modes=[]), r"no modes"),
        (dict(variables=["x", "v", "W", "x"]), r"name `x` is both a variable and a variable"),
        (dict(parameters=["k", "R", "x"]), r"name `x` is both a variable and a parameter"),
        (dict(definitions={"k": "x"}), r"name `k` is both a parameter and a definition"),
        (dict(variables=["x", "v", "W", "t"]), r"invalid variable name `t`"),
        (dict(parameters=["k", "R", "pi"]), r"invalid parameter name `pi`"),
        (dict(parameters=["k", "R", "2a"]), r"invalid parameter name `2a`"),
        (dict(definitions={"H": "k*x", "a-b": "x"}), r"invalid definition name `a-b`"),
        (dict(parameters=[Parameter("k", domain="negative"), "R"]), r"parameter `k` has domain 'negative'"),
        (dict(modes=[STICK, SLIP, Mode("slip", derivatives={"x": "v", "v": "0"})]), r"duplicate mode names"),
        (dict(modes=[STICK, Mode("sl ip", derivatives={"x": "v", "v": "0"})]), r"invalid mode name 'sl ip'"),
        (dict(modes=[STICK, "slip"]), r"modes must be Mode objects"),
        (dict(initial_mode="fly"), r"initial mode `fly` does not exist; modes: stick, slip"),
        # equations
        (
            dict(modes=[Mode("stick", derivatives={"x": "0", "v": "0", "w": "1"}), SLIP]),
            r"mode `stick` gives an equation for unknown variable `w`",
        ),
        (
            dict(modes=[STICK, Mode("slip", derivatives={"x": "v"})]),
            r"mode `slip` has no equation for variable\(s\) v",
        ),
        (dict(equations={"W": "v**2", "y": "1"}), r"shared equation given for unknown variable `y`"),
        (
            dict(modes=[STICK, Mode("slip", derivatives={"x": "v", "v": "0"}, algebraic={"v": "v - x"})]),
            r"mode `slip`: `v` has both a derivative and an algebraic equation",
        ),
        (
            dict(modes=[STICK, Mode("slip", derivatives={"x": "v"}, algebraic={"v": "x - 1"})]),
            r"algebraic equation of `v` does not involve any slave variable of the mode",
        ),
        (
            dict(modes=[STICK, Mode("slip", derivatives={"x": "v", "v": "-H + R + q"})]),
            r"mode `slip`: derivative of `v`: unknown name `q`",
        ),
        (
            dict(modes=[STICK, Mode("slip", derivatives={"x": "v", "v": "-H +* R"})]),
            r"mode `slip`: derivative of `v`: syntax error",
        ),
        (
            dict(modes=[STICK, Mode("slip", derivatives={"x": "v", "v": "x.__class__"})]),
            r"mode `slip`: derivative of `v`: forbidden construct `Attribute`",
        ),
        (
            dict(modes=[STICK, Mode("slip", derivatives={"x": "v", "v": "__import__('os')"})]),
            r"derivative of `v`: call of `__import__` is not allowed",
        ),
        # definitions
        (
            dict(modes=[STICK, Mode("slip", derivatives={"x": "v", "v": "-x"}, definitions={"x": "1"})]),
            r"mode `slip`: invalid definition name `x`",
        ),
        (dict(definitions={"H": "k*x*undefined"}), r"definition `H`: unknown name `undefined`"),
        # transitions
        (
            dict(transitions=[Transition("stick", "fly", "H - R", 1)]),
            r"transition `stick->fly` has target mode `fly` that does not exist; modes: stick, slip",
        ),
        (
            dict(transitions=[Transition("hover", "slip", "H - R", 1)]),
            r"transition `hover->slip` has source mode `hover` that does not exist",
        ),
        (
            dict(transitions=[Transition("stick", "slip", "H - Q", 1)]),
            r"guard of transition `stick->slip`: unknown name `Q`",
        ),
        (
            dict(
                transitions=[
                    Transition("stick", "slip", "H - R", 1, name="go"),
                    Transition("stick", "slip", "H + R", -1, name="go"),
                ]
            ),
            r"duplicate transition name `go` from mode `stick`",
        ),
        (
            dict(transitions=[Transition("slip", "stick", "v", 1, reset={"y": "0"})]),
            r"transition `slip->stick` resets unknown variable `y`",
        ),
        (
            dict(transitions=[Transition("slip", "stick", "v", 1, reset={"v": "v^2"})]),
            r"reset of `v` in transition `slip->stick`: forbidden operator `BitXor`.*use \*\* for powers",
        ),
        (dict(transitions=["stick->slip"]), r"transitions must be Transition objects"),
        # quadratures
        (
            dict(transitions=[Transition("stick", "slip", "H - R + W", 1)]),
            r"guard of transition `stick->slip` depends on a quadrature",
        ),
        (
            dict(definitions={"H": "k*x + W"}),
            r"equation of `v` depends on a quadrature \(W\)",
        ),
        (dict(quadratures=("Z",)), r"quadrature `Z` is not a variable"),
        (
            dict(
                modes=[STICK, Mode("slip", derivatives={"x": "v", "v": "-H + R"}, algebraic={"W": "W - x"})]
            ),
            r"mode `slip`: quadrature `W` cannot be algebraic",
        ),
        # outputs, period, presets
        (dict(outputs=("Q",)), r"output `Q` is not a definition in mode `stick`"),
        (dict(period="2*pi/w"), r"period: unknown name `w`"),
        (dict(period="2*pi/x"), r"period: unknown name `x`"),  # the period may use parameters only
        (
            dict(presets={"std": {"k": 1.0, "R": 0.1, "Q": 2.0}}),
            r"preset `std` sets unknown parameter `Q`; parameters: k, R",
        ),
    ],
)
def test_malformed_system_is_rejected_naming_the_item(over, match):
    with pytest.raises(ModelError, match=match) as info:
        _toy(**over)
    assert str(info.value).startswith("model `toy`: ")


@pytest.mark.parametrize(
    "over",
    [
        dict(transitions=[Transition("stick", "slip", "H - Q", 1)]),
        dict(modes=[STICK, Mode("slip", derivatives={"x": "v", "v": "x.__class__"})]),
        dict(period="2*pi/w"),
    ],
    ids=["guard", "derivative", "period"],
)
def test_expression_errors_name_the_model_once(over):
    with pytest.raises(ModelError) as info:
        _toy(**over)
    assert str(info.value).count("model `toy`") == 1, str(info.value)


@pytest.mark.parametrize(
    ("over", "match"),
    [
        (dict(definitions={"H": "k*x + G", "G": "2*H"}), r"definitions form a cycle: H -> G -> H"),
        (dict(definitions={"H": "H + 1"}), r"definitions form a cycle: H -> H"),
        (
            dict(
                modes=[
                    STICK,
                    Mode("slip", derivatives={"x": "v", "v": "-A"}, definitions={"A": "B", "B": "A"}),
                ]
            ),
            r"mode `slip` definitions form a cycle: A -> B -> A",
        ),
    ],
)
def test_definition_cycles_are_rejected_naming_the_cycle(over, match):
    # (the cycle message is the one construction error without the "model `toy`: " prefix)
    with pytest.raises(ModelError, match=match):
        _toy(**over)


@pytest.mark.parametrize("direction", [2, -2, 0.5, True, "up"])
def test_transition_direction_must_be_minus_one_zero_or_one(direction):
    with pytest.raises(ModelError, match=r"transition `a->b`: direction must be -1, 0 or 1, got"):
        Transition("a", "b", "x", direction)


def test_mode_and_transition_maps_must_be_mappings():
    with pytest.raises(ModelError, match=r"mode `m` derivatives must be a mapping"):
        Mode("m", derivatives="x")
    with pytest.raises(ModelError, match=r"transition `a->b` reset must be a mapping"):
        Transition("a", "b", "x", 0, reset=["v"])


def test_system_is_immutable_and_maps_are_read_only():
    s = _toy()
    with pytest.raises(AttributeError):
        s.name = "other"
    with pytest.raises(TypeError):
        s.mode("slip").derivatives["v"] = "0"
    with pytest.raises(TypeError):
        s.presets["std"]["k"] = 2.0


def test_mode_lookup_and_slave_variables():
    s = _toy()
    with pytest.raises(ValueError, match=r"model `toy` has no mode `fly`; modes: stick, slip"):
        s.mode("fly")
    absorber = hybrid_models.absorber()
    assert absorber.algebraic_variables("stick") == ()
    assert absorber.algebraic_variables("slip+") == ("u",)
    assert absorber.algebraic_variables("slip-") == ("u",)


# ----------------------------------------------------------------------------
# Parameters
# ----------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("domain", "value", "match"),
    [
        ("real", float("nan"), r"must be finite, got nan"),
        ("real", float("inf"), r"must be finite, got inf"),
        ("positive", -float("inf"), r"must be finite"),
        ("positive", 0.0, r"must be > 0, got 0.0"),
        ("positive", -1.0, r"must be > 0"),
        ("nonnegative", -1e-300, r"must be >= 0"),
        ("real", "abc", r"must be a real number, got 'abc'"),
        ("real", None, r"must be a real number, got None"),
        ("real", [1.0], r"must be a real number"),
        ("real", True, r"must be a real number, got True"),
    ],
)
def test_parameter_check_rejects_bad_values_naming_the_parameter(domain, value, match):
    p = Parameter("c2", "N/m", "spring stiffness", domain)
    with pytest.raises(ValueError, match=r"parameter `c2` \(spring stiffness\) " + match):
        p.check(value)


@pytest.mark.parametrize(
    ("domain", "value", "want"),
    [
        ("real", -2, -2.0),
        ("positive", 1e-300, 1e-300),
        ("nonnegative", 0, 0.0),
        ("real", np.float32(0.5), 0.5),
        ("real", "2.5", 2.5),
    ],
)
def test_parameter_check_accepts_and_converts(domain, value, want):
    got = Parameter("a", domain=domain).check(value)
    assert type(got) is float
    assert got == want


def test_parameter_values_complete_checked_and_named():
    s = _toy()
    assert s.parameter_values({"k": 2, "R": 0}) == {"k": 2.0, "R": 0.0}
    assert s.parameter_values({"R": 0.3}, preset="std") == {"k": 1.0, "R": 0.3}
    assert s.preset("std", k=4.0) == {"k": 4.0, "R": 0.1}
    with pytest.raises(ValueError, match=r"model `toy` has no parameter `Q`; parameters: k, R"):
        s.parameter_values({"k": 1.0, "R": 0.1, "Q": 1.0})
    with pytest.raises(ValueError, match=r"model `toy`: missing value for parameter\(s\) R"):
        s.parameter_values({"k": 1.0})
    with pytest.raises(ValueError, match=r"model `toy`: missing value for parameter\(s\) k, R"):
        s.parameter_values()
    with pytest.raises(ValueError, match=r"model `toy` has no preset `big`; presets: std"):
        s.parameter_values(preset="big")
    with pytest.raises(ValueError, match=r"parameter `k` \(stiffness\) must be > 0, got -1.0"):
        s.preset("std", k=-1.0)
    with pytest.raises(ValueError, match=r"parameter `R` \(friction\) must be finite"):
        s.parameter_values({"k": 1.0, "R": math.nan})


def test_period_value():
    s = _toy(period="2*pi/k")
    assert s.period_value({"k": 4.0, "R": 0.0}) == pytest.approx(math.pi / 2, rel=1e-15)
    assert _toy().period_value({"k": 4.0, "R": 0.0}) is None
    bad = _toy(period="k - 2")
    with pytest.raises(
        ValueError, match=r"forcing period 'k - 2' evaluates to -1.0; it must be finite and > 0"
    ):
        bad.period_value({"k": 1.0, "R": 0.0})


# ----------------------------------------------------------------------------
# Compiled form: residual Jacobian, consistent derivatives, Taylor series of the flow
# ----------------------------------------------------------------------------
def _fd_iteration_matrix(cm, t, y, yp, cj, h=1e-6):
    """dF/dy + cj dF/dy' by central differences of the residual."""
    n = cm.n
    out = np.zeros((n, n))
    r1, r2 = np.zeros(n), np.zeros(n)
    for j in range(n):
        e = np.zeros(n)
        e[j] = h * max(1.0, abs(y[j]))
        cm.residual(t, y + e, yp, r1)
        cm.residual(t, y - e, yp, r2)
        out[:, j] = (r1 - r2) / (2 * e[j])
        e[j] = h
        cm.residual(t, y, yp + e, r1)
        cm.residual(t, y, yp - e, r2)
        out[:, j] += cj * (r1 - r2) / (2 * h)
    return out


def _jacobian_cases():
    cases = []
    for name, preset in (("absorber", "fig3a"), ("isolator", "fig4a"), ("coulomb", "forced")):
        s = hybrid_models.BUILTIN[name]()
        cases.append(pytest.param(s, s.preset(preset), id=name))
    for make in (riccati, logistic, nonlinear_dae):
        s, p, _, _ = make()
        cases.append(pytest.param(s, p, id=s.name))
    return cases


@pytest.mark.parametrize(("system", "params"), _jacobian_cases())
def test_iteration_matrix_matches_finite_differences(system, params):
    cs = CompiledSystem(system, params)
    rng = np.random.default_rng(7)
    for cm in cs.modes:
        for _ in range(3):
            t = rng.uniform(0, 5)
            y = rng.uniform(0.2, 1.5, cm.n)
            yp = rng.uniform(-1, 1, cm.n)
            cj = rng.uniform(10, 1000)
            got = np.zeros((cm.n, cm.n))
            cm.jacobian(t, y, cj, got)
            want = _fd_iteration_matrix(cm, t, y, yp, cj)
            assert np.allclose(got, want, rtol=1e-7, atol=1e-7 * cj), (cm.name, got, want)


def test_solve_algebraic_and_consistent_derivatives_of_the_dae():
    system, params, _, _ = nonlinear_dae()
    cm = CompiledSystem(system, params).modes[0]
    t, x = 0.9, -0.4
    y = cm.solve_algebraic(t, np.array([x, 25.0]))  # far-off guess for z
    assert y[0] == x
    assert y[1] == pytest.approx(x + math.sin(t), rel=1e-14)
    yp = cm.derivatives(t, y)
    # x' = -z; z = x + sin t => z' = x' + cos t
    assert yp[0] == pytest.approx(-y[1], rel=1e-15)
    assert yp[1] == pytest.approx(-y[1] + math.cos(t), rel=1e-13)


def test_solve_algebraic_of_the_absorber_slip_modes():
    s = hybrid_models.absorber()
    p = s.preset("fig3a")
    cs = CompiledSystem(s, p)
    y = np.array([0.3, -0.2, 0.8, 0.1, 123.0, 0.0, 0.0])
    for mode, sgn in (("slip+", 1.0), ("slip-", -1.0)):
        got = cs.modes[cs.mode_id(mode)].solve_algebraic(0.0, y)
        u = (p["c2"] * y[0] + p["c3"] * y[2] + sgn * p["R"]) / (p["c2"] + p["c3"])
        assert got[4] == pytest.approx(u, rel=1e-15)
        assert np.array_equal(np.delete(got, 4), np.delete(y, 4))
    with pytest.raises(
        ValueError, match=r"model `absorber` has no mode `glide`; modes: stick, slip\+, slip-"
    ):
        cs.mode_id("glide")


def test_taylor_series_of_the_flow_of_the_dae_matches_the_closed_form():
    x0 = 2.0
    system, params, _, _ = nonlinear_dae(x0)
    system = HybridSystem(
        name="dae_guard",
        variables=system.variables,
        parameters=[],
        modes=system.modes,
        transitions=[Transition("only", "only", "z - 0.3", 0, name="level")],
    )
    cm = CompiledSystem(system, params).modes[0]
    t0, K = 0.7, 8
    C = x0 - 0.5

    def coeff(k):  # k-th Taylor coefficient of x and z at t0
        dx = (
            C * (-1) ** k * math.exp(-t0)
            + (math.cos(t0 + k * math.pi / 2) - math.sin(t0 + k * math.pi / 2)) / 2
        )
        dz = dx + math.sin(t0 + k * math.pi / 2)
        return dx / math.factorial(k), dz / math.factorial(k)

    want = np.array([coeff(k) for k in range(K + 1)]).T
    y = cm.solve_algebraic(t0, np.array([want[0, 0], 0.0]))
    X = cm.taylor(t0, y, K)
    assert X.shape == (2, K + 1)
    assert np.allclose(X, want, rtol=0, atol=1e-14)
    G = cm.guard_series(0, t0, y, K)
    assert np.allclose(G, want[1] - np.r_[0.3, np.zeros(K)], rtol=0, atol=1e-14)


def test_taylor_series_of_the_oscillator_flow():
    s = HybridSystem(
        name="osc",
        variables=["x", "v"],
        parameters=["w"],
        modes=[Mode("m", derivatives={"x": "v", "v": "-w**2*x"})],
        transitions=[Transition("m", "m", "x*v", 0)],
    )
    w, t0, K = 1.7, 0.3, 9
    cm = CompiledSystem(s, {"w": w}).modes[0]
    y = np.array([math.cos(w * t0), -w * math.sin(w * t0)])
    X = cm.taylor(t0, y, K)
    for k in range(K + 1):
        assert X[0, k] == pytest.approx(
            w**k * math.cos(w * t0 + k * math.pi / 2) / math.factorial(k), abs=1e-14
        )
    # guard x v = -(w/2) sin(2 w t): coefficients of -(w/2) sin(2 w (t0 + s))
    G = cm.guard_series(0, t0, y, K)
    for k in range(K + 1):
        want = -(w / 2) * (2 * w) ** k * math.sin(2 * w * t0 + k * math.pi / 2) / math.factorial(k)
        assert G[k] == pytest.approx(want, abs=1e-13)


@pytest.mark.parametrize(
    ("series", "noise", "want"),
    [
        ([0.0, 1e-3, -1.0], 1e-9, 1.0),  # linear term reaches the noise first
        ([0.0, 1e-12, -1.0], 1e-9, -1.0),  # quadratic term wins: leaves zero downwards
        ([0.0, 0.0, 0.0, 2.0], 1e-9, 1.0),
        ([0.0, -0.0, 0.0], 1e-9, 0.0),
    ],
)
def test_lead_sign(series, noise, want):
    assert lead_sign(np.array(series), noise) == want


def test_builtin_vector_fields_match_hand_derived_equations():
    # pydy-style: the declarative Coulomb model against its textbook equations.
    s = hybrid_models.coulomb()
    p = s.preset("forced")
    cs = CompiledSystem(s, p)
    rng = np.random.default_rng(3)
    for _ in range(5):
        t, x, v = rng.uniform(-2, 2, 3)
        y = np.array([x, v, 0.0, 0.0])
        force = p["F"] * math.sin(p["Omega"] * t)
        for mode, friction in (("slip+", -p["R"]), ("slip-", p["R"])):
            f = cs.modes[cs.mode_id(mode)].rhs(t, y)
            acc = (force - p["k"] * x + friction) / p["m"]
            assert f[:2] == pytest.approx([v, acc], rel=1e-14, abs=1e-15)
            assert f[2] == pytest.approx(force * v, rel=1e-14, abs=1e-15)  # W' = input power
            assert f[3] == pytest.approx(-friction * v, rel=1e-14, abs=1e-15)  # D' = friction power
        assert np.all(cs.modes[cs.mode_id("stick")].rhs(t, y)[:2] == 0.0)


def test_variable_descriptions_are_kept():
    s = _toy(variables=[Variable("x", "m", "position"), "v", "W"])
    assert s.variables[0] == Variable("x", "m", "position")
    assert s.variables[1] == Variable("v")


def test_a_composed_mode_with_many_halting_parts_is_described():
    """Found with issue 22: HybridSystem.mode() of a mode whose many components' local modes
    halt joined their messages past the limit of Mode.halt and raised (simulate's check of
    mode0 did so); the joined text is now cut, saying how many parts halt."""
    n = 30
    comps = [
        Component(
            f"c{i}",
            (
                Mode("h", algebraic={f"s{i}": f"s{i}"}, halt="x" * 100),
                Mode("ok", algebraic={f"s{i}": f"s{i} - 1"}),
            ),
        )
        for i in range(n)
    ]
    s = HybridSystem(
        name="halts",
        variables=["x"] + [f"s{i}" for i in range(n)],
        parameters=[],
        modes=[Mode("own", derivatives={"x": "1"})],
        transitions=[],
        components=comps,
        initial_mode="own",
    )
    halt = s.mode(s.default_mode).halt
    assert len(halt) == 2000
    assert halt.startswith("x" * 100 + "; " + "x" * 100)
    assert halt.endswith(" ... (30 parts halt)")
    assert s.mode("own|" + "|".join(["ok"] * n)).halt == ""
