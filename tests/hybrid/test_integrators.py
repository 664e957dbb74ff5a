"""The integrators by name (issue 21): the registry, and what each integrator answers, against
closed forms of an undamped oscillator (its flow, Taylor series and fundamental matrix)."""

import ast
import math
from pathlib import Path

import numpy as np
import pytest

from hybrid import HybridSystem, InputError, Mode, NotAffineError, SolverOptions, Transition
from hybrid.core.options import INTEGRATORS
from hybrid.integrators.base import Integrator
from hybrid.integrators.exact import ExactIntegrator, ExactModeSolver
from hybrid.integrators.ida import IDAIntegrator, ModeSolver
from hybrid.integrators.registry import NAMES, integrator
from hybrid.model.compiled import CompiledSystem
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


def test_the_option_names_are_the_registry_names():
    # core/options.py keeps its own tuple (core may not import the integrators): the two must agree
    assert INTEGRATORS == NAMES


def test_each_name_gives_its_one_integrator():
    assert isinstance(integrator("ida"), IDAIntegrator)
    assert isinstance(integrator("exact"), ExactIntegrator)
    for name in NAMES:
        assert isinstance(integrator(name), Integrator)
        assert integrator(name).name == name
        assert integrator(name) is integrator(name)


@pytest.mark.parametrize("name", ["rk4", "EXACT", None])
def test_an_unknown_integrator_is_refused(name):
    with pytest.raises(InputError, match=f"no integrator `{name}`; integrators: ida, exact"):
        integrator(name)


def test_only_the_exact_integrator_is_exact_and_its_noise_is_rounding():
    opts = SolverOptions(rtol=3e-9)
    assert integrator("ida").noise_rtol(opts) == 3e-9
    assert integrator("exact").noise_rtol(opts) == 1e-15
    assert not integrator("ida").exact
    assert integrator("exact").exact


def test_the_exact_integrator_refuses_a_model_that_is_not_affine_and_ida_takes_it():
    system = _oscillator("v + 0.1*x**2")
    cs = CompiledSystem(system, {"w": W})
    with pytest.raises(NotAffineError, match="model `osc`: .*not affine"):
        integrator("exact").check(cs)
    with pytest.raises(NotAffineError, match="model `osc`: .*not affine"):
        integrator("exact").check_model(system, {"w": W})
    assert integrator("ida").check(cs) is None
    assert integrator("ida").check_model(system, {"w": W}) is None


@pytest.mark.parametrize("name", NAMES)
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
    opts = SolverOptions(rtol=1e-11, atol=1e-13)
    solver = integrator(name).mode_solver(cs, 0, opts, atol=np.full(2, 1e-13), max_step=0.05)
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
    ida = integrator("ida")
    a = ida.mode_solver(cs, 0, opts, atol=np.full(2, 1e-10), max_step=0.1)
    assert ida.mode_solver(cs, 0, opts, atol=np.full(2, 1e-10), max_step=0.1) is a
    assert ida.mode_solver(cs, 0, opts, atol=np.full(2, 1e-10), max_step=0.1, first_step=1e-7) is not a
    assert ida.mode_solver(cs, 0, opts, atol=np.full(2, 1e-10), max_step=0.2) is not a


@pytest.mark.parametrize(("name", "tol"), [("ida", 1e-8), ("exact", 1e-13)])
def test_the_variational_solver_gives_the_fundamental_matrix(name, tol):
    # dy(t)/dy(0) = [[cos w t, sin(w t)/w], [-w sin w t, cos w t]]
    cs = CompiledSystem(_oscillator(), {"w": W})
    opts = SolverOptions(rtol=1e-11, atol=1e-13)
    s = np.array([0, 1])
    solvers = integrator(name).variational(cs, s, opts, 0.05)
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
def test_a_shooter_asks_its_integrator(name):
    system = HybridSystem(
        name="forced",
        variables=["x", "v"],
        parameters=["w", "F", "W"],
        modes=[Mode("free", derivatives={"x": "v", "v": "-w**2*x - 0.1*v + F*sin(W*t)"})],
        transitions=[],
        period="2*pi/W",
        initial_mode="free",
    )
    sh = Shooter(system, {"w": 1.0, "F": 1.0, "W": 1.5}, SolverOptions(rtol=1e-9, integrator=name))
    assert sh.integrator is integrator(name)
    assert sh.noise_rtol == integrator(name).noise_rtol(sh.options)


def test_no_module_compares_an_integrator_name():
    """Behaviour that depends on the integrator is asked of its object, never decided by testing
    ``SolverOptions.integrator`` against a name (``== "exact"``)."""
    root = Path(__file__).resolve().parents[2] / "hybrid"
    found = []
    for path in sorted(root.rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            if isinstance(node, ast.Compare):
                operands = [node.left, *node.comparators]
                if any(isinstance(o, ast.Constant) and o.value in NAMES for o in operands):
                    found.append(f"{path.relative_to(root.parent)}:{node.lineno}")
    assert found == []
