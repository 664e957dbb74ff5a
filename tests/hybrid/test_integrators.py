"""The integration methods (issues 21, 29): the registry of names, what each method answers against
closed forms of an undamped oscillator (its flow, Taylor series and fundamental matrix), and that
no layer above the integrators asks a method's name or reaches into it."""

import ast
import math
from pathlib import Path

import numpy as np
import pytest

from hybrid import (
    IDA,
    Exact,
    HybridSystem,
    InputError,
    Method,
    Mode,
    NotAffineError,
    SolverOptions,
    Transition,
    method_named,
)
from hybrid.integrators.auto import Auto
from hybrid.integrators.exact import ExactModeSolver
from hybrid.integrators.ida import ModeSolver
from hybrid.integrators.registry import METHODS, NAMES
from hybrid.model.compiled import CompiledSystem
from hybrid.orbits.newton import NewtonPolicy
from hybrid.orbits.shooter import Shooter

W = 2.0  # rad/s
X0, V0 = 0.3, -0.7  # m, m/s


def _oscillator(x_equation: str = "v") -> HybridSystem:
    """x'' = -w^2 x with a guard on x: x(t) = x0 cos(w t) + v0/w sin(w t)."""
    return HybridSystem(
        name="osc",
        variables=["x", "v"],
        parameters=["w"],
        modes=[Mode("free", derivatives={"x": x_equation, "v": "-w**2*x"})],
        transitions=[Transition("free", "free", guard="x", direction=-1, name="cross")],
        initial_mode="free",
    )


def _exact_state(t: float) -> np.ndarray:
    return np.array(
        [X0 * math.cos(W * t) + V0 / W * math.sin(W * t), -X0 * W * math.sin(W * t) + V0 * math.cos(W * t)]
    )


def integrator(name: str) -> Method:
    """The method of ``name`` with its default settings."""
    return method_named(name)


def test_each_name_gives_its_method_class():
    assert METHODS == {"ida": IDA, "exact": Exact, "auto": Auto}  # (auto: issue 34)
    assert NAMES == ("ida", "exact", "auto")
    for name in NAMES:
        assert isinstance(method_named(name), Method)
        assert method_named(name).name == name
        assert method_named(name) == method_named(name)
    assert method_named("ida", rtol=1e-9) == IDA(rtol=1e-9)


@pytest.mark.parametrize("name", ["IDA", "lsoda", "", None])
def test_an_unknown_integrator_is_refused(name):
    with pytest.raises(InputError, match=f"no integration method `{name}`; methods: ida, exact, auto"):
        method_named(name)


def test_only_the_exact_method_is_exact_and_its_noise_is_rounding():
    assert IDA(rtol=3e-9).noise_rtol == 3e-9
    assert Exact().noise_rtol == 1e-15
    assert not IDA().flows_exact
    assert Exact().flows_exact


def test_tighter_and_looser_copies_scale_every_tolerance():
    ida = IDA(rtol=1e-8, atol={"x": 1e-10}, atol_default=1e-9)
    tight = ida.tightened(100.0)
    assert (tight.rtol, tight.atol["x"], tight.atol_default) == pytest.approx(
        (1e-10, 1e-12, 1e-11), rel=1e-15
    )
    loose = ida.loosened_to(1e-6)
    assert (loose.rtol, loose.atol["x"], loose.atol_default) == pytest.approx((1e-6, 1e-8, 1e-7), rel=1e-15)
    assert ida.loosened_to(1e-7) is None  # not 100 times looser: nothing to save
    assert Exact().tightened(100.0) is None and Exact().loosened_to(1e-6) is None


def test_newton_policy_follows_the_capabilities_not_the_name():
    assert NewtonPolicy.for_method(IDA()) == NewtonPolicy(
        broyden=True, coarse_stage=True, switch_time_newton=False, cheap_jacobian=False
    )
    assert NewtonPolicy.for_method(Exact()) == NewtonPolicy(
        broyden=False, coarse_stage=False, switch_time_newton=True, cheap_jacobian=True
    )


def test_the_exact_integrator_refuses_a_model_that_is_not_affine_and_ida_takes_it():
    system = _oscillator("v + 0.1*x**2")
    cs = CompiledSystem(system, {"w": W})
    with pytest.raises(NotAffineError, match="model `osc`: .*not affine"):
        integrator("exact").check(cs)
    with pytest.raises(NotAffineError, match="model `osc`: .*not affine"):
        integrator("exact").check_model(system, {"w": W})
    assert integrator("ida").check(cs) is None
    assert integrator("ida").check_model(system, {"w": W}) is None


@pytest.mark.parametrize("name", ["ida", "exact"])  # (auto is one of them once resolved)
def test_the_guard_series_is_the_taylor_series_of_the_flow(name):
    # x(t) = x0 cos(w t) + v0/w sin(w t): coefficients x0, v0, -w^2 x0/2, -w^2 v0/6, w^4 x0/24
    cs = CompiledSystem(_oscillator(), {"w": W})
    series = integrator(name).guard_series(cs, 0, 0.0, np.array([X0, V0]), 4)(0)
    expected = [X0, V0, -(W**2) * X0 / 2, -(W**2) * V0 / 6, W**4 * X0 / 24]
    np.testing.assert_allclose(series, expected, rtol=1e-14, atol=0)


@pytest.mark.parametrize(
    ("name", "kind", "tol"), [("ida", ModeSolver, 1e-9), ("exact", ExactModeSolver, 1e-14)]
)
def test_a_mode_solver_follows_the_flow_to_the_guard(name, kind, tol):
    cs = CompiledSystem(_oscillator(), {"w": W})
    method = IDA(rtol=1e-11, atol=1e-13) if name == "ida" else Exact()
    solver = method.mode_solver(cs, 0, SolverOptions(method=method), max_step=0.05)
    assert isinstance(solver, kind)
    y0 = np.array([X0, V0])
    solver.start(0.0, y0, cs.modes[0].derivatives(0.0, y0))
    r = solver.step(10.0, 10.0, one_step=False)
    # x falls through 0 first at w t = atan2(x0, -v0/w) (x = A cos(w t + phi) with x0 > 0, v0 < 0)
    t_cross = math.atan2(X0, -V0 / W) / W
    assert r.fired == (0,)
    assert r.t == pytest.approx(t_cross, rel=tol)
    np.testing.assert_allclose(r.y, _exact_state(r.t), rtol=0, atol=tol)


def test_ida_mode_solvers_are_kept_with_the_compiled_system_per_settings():
    cs = CompiledSystem(_oscillator(), {"w": W})
    opts = SolverOptions()
    ida = opts.method
    a = ida.mode_solver(cs, 0, opts, max_step=0.1)
    assert IDA().mode_solver(cs, 0, opts, max_step=0.1) is a  # equal settings share the solver
    assert ida.mode_solver(cs, 0, opts, max_step=0.1, first_step=1e-7) is not a
    assert ida.mode_solver(cs, 0, opts, max_step=0.2) is not a
    assert IDA(rtol=1e-9).mode_solver(cs, 0, opts, max_step=0.1) is not a


@pytest.mark.parametrize(("name", "tol"), [("ida", 1e-8), ("exact", 1e-13)])
def test_the_variational_solver_gives_the_fundamental_matrix(name, tol):
    # dy(t)/dy(0) = [[cos w t, sin(w t)/w], [-w sin w t, cos w t]]
    cs = CompiledSystem(_oscillator(), {"w": W})
    method = IDA(rtol=1e-11, atol=1e-13) if name == "ida" else Exact()
    opts = SolverOptions(method=method)
    s = np.array([0, 1])
    solvers = method.variational(cs, s, opts, 0.05)
    t1 = 1.3
    _, Y = solvers.solver(0, np.zeros(0)).propagate(0.0, np.array([X0, V0]), np.eye(2), t1)
    c, sn = math.cos(W * t1), math.sin(W * t1)
    np.testing.assert_allclose(Y, [[c, sn / W], [-W * sn, c]], rtol=0, atol=tol)
    assert (solvers.nfev > 0) == (name == "ida")  # only IDA's residual evaluations are counted


def test_only_the_exact_integrator_has_exact_flows():
    cs = CompiledSystem(_oscillator(), {"w": W})
    assert integrator("ida").exact_flows(cs) is None
    flows = integrator("exact").exact_flows(cs)
    assert len(flows) == 1
    # the flow's generator on z = (x, v, 1): x' = v, v' = -w^2 x
    np.testing.assert_array_equal(flows[0].M[:2, :2], [[0.0, 1.0], [-(W**2), 0.0]])


@pytest.mark.parametrize("name", NAMES)
def test_a_shooter_asks_its_method(name):
    system = HybridSystem(
        name="forced",
        variables=["x", "v"],
        parameters=["w", "F", "W"],
        modes=[Mode("free", derivatives={"x": "v", "v": "-w**2*x - 0.1*v + F*sin(W*t)"})],
        transitions=[],
        period="2*pi/W",
        initial_mode="free",
    )
    sh = Shooter(
        system,
        {"w": 1.0, "F": 1.0, "W": 1.5},
        SolverOptions(method=(IDA(rtol=1e-9) if name == "ida" else method_named(name))),
    )
    assert sh.method is sh.options.method
    assert sh.noise_rtol == sh.method.noise_rtol == (1e-9 if name == "ida" else 1e-15)


def test_no_module_compares_an_integrator_name():
    """Behaviour that depends on the integrator is asked of its object, never decided by testing
    ``SolverOptions.integrator`` against a name (``== "exact"``)."""
    root = Path(__file__).resolve().parents[2] / "hybrid"
    found = []
    for path in sorted(root.rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            if isinstance(node, ast.Compare):
                operands = [node.left, *node.comparators]
                # ("auto" is also a word of other options, e.g. the autonomous orbit's phase="auto")
                if any(isinstance(o, ast.Constant) and o.value in ("ida", "exact") for o in operands):
                    found.append(f"{path.relative_to(root.parent)}:{node.lineno}")
    assert found == []


def _allowed(owner: ast.expr) -> bool:
    """The Newton policy of ``orbits/`` (chosen from the capabilities) and the command line's
    ``args.integrator`` (the name the user typed) may use these words."""
    if isinstance(owner, ast.Name) and owner.id in ("policy", "args"):
        return True
    return isinstance(owner, ast.Call) and "NewtonPolicy" in ast.unparse(owner.func)


def test_no_layer_above_the_integrators_asks_a_method_its_kind():
    """Issue 29: above ``hybrid/integrators`` a method is asked for capabilities (``flows_exact``,
    ``noise_rtol``, ``tightened``, ...), never for its name or the flags of the old integrator
    objects (``.exact``, ``.integrator``, ``.broyden``, ``.coarse_stage``, ``.switch_time_newton``)."""
    root = Path(__file__).resolve().parents[2] / "hybrid"
    banned = {"exact", "integrator", "broyden", "coarse_stage", "switch_time_newton"}
    found = []
    for sub in ("engine", "orbits", "continuation", "studies", "plot", "cli"):
        for path in sorted((root / sub).rglob("*.py")):
            for node in ast.walk(ast.parse(path.read_text(), str(path))):
                if isinstance(node, ast.Attribute) and node.attr in banned and not _allowed(node.value):
                    found.append(f"{path.relative_to(root.parent)}:{node.lineno} .{node.attr}")
                if isinstance(node, ast.Attribute) and node.attr == "name":
                    inner = node.value
                    if isinstance(inner, ast.Attribute) and inner.attr in ("method", "integ"):
                        found.append(f"{path.relative_to(root.parent)}:{node.lineno} .method.name")
    assert found == []
    # the check can fail: a synthetic module that asks the old flag is flagged
    bad = ast.parse("if sh.integrator.exact:\n    pass\n")
    assert any(
        isinstance(n, ast.Attribute) and n.attr in banned and not _allowed(n.value) for n in ast.walk(bad)
    )
