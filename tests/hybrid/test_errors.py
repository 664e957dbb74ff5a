"""One exception base (issue 21): every error hybrid raises on purpose is a HybridError of a typed
class, from hybrid.core.errors, raised where it is documented."""

import ast
import builtins
import errno
import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import hybrid
import hybrid_models
from hybrid import (
    IDA,
    AlgebraicSolveError,
    BudgetExceeded,
    ConvergenceError,
    Exact,
    ExpressionError,
    GrazingSwitchError,
    HybridError,
    HybridSystem,
    InputError,
    InputTypeError,
    IntegratorError,
    Mode,
    ModelError,
    NotAffineError,
    ParameterOutOfDomain,
    SampleCapReached,
    SimulationError,
    SolverOptions,
    Transition,
    WorkerError,
    autonomous_orbit,
    frequency_response,
    locate_hopf,
    periodic_orbit,
    simulate,
)
from hybrid.continuation import frc
from hybrid.core import errors
from hybrid.engine.record import Recorder
from hybrid.integrators.ida import ModeSolver
from hybrid.model.compiled import CompiledSystem
from hybrid.model.expr import parse
from hybrid.orbits.shooter import Shooter

ROOT = Path(__file__).resolve().parents[2] / "hybrid"
CLASSES = [getattr(errors, name) for name in errors.__all__]


def _builtin_bases(cls: type) -> set[str]:
    """The most specific built-in exceptions ``cls`` derives from (Exception itself not counted)."""
    found = [
        c
        for c in cls.__mro__
        if c.__module__ == "builtins" and issubclass(c, BaseException) and c not in (Exception, BaseException)
    ]
    return {c.__name__ for c in found if not any(d is not c and issubclass(d, c) for d in found)}


@pytest.mark.parametrize("cls", CLASSES, ids=lambda c: c.__name__)
def test_every_class_derives_from_hybrid_error_and_from_the_builtin_its_docstring_names(cls):
    assert issubclass(cls, HybridError)
    named = {
        n
        for n in re.findall(r":class:`(\w+)`", cls.__doc__)
        if isinstance(getattr(builtins, n, None), type) and issubclass(getattr(builtins, n), BaseException)
    }
    assert named == _builtin_bases(cls)


def test_the_built_ins_of_the_classes():
    # an independent table of what a caller's `except` clauses rely on
    expected = {
        "HybridError": set(),
        "InputError": {"ValueError"},
        "InputTypeError": {"TypeError"},
        "ModelError": {"ValueError"},
        "ExpressionError": {"ValueError"},
        "NotAffineError": {"ValueError"},
        "SimulationError": {"RuntimeError"},
        "AlgebraicSolveError": {"RuntimeError"},
        "IntegratorError": {"RuntimeError"},
        "BudgetExceeded": set(),
        "ConvergenceError": {"RuntimeError"},
        "GrazingSwitchError": {"ZeroDivisionError"},
        "ParameterOutOfDomain": {"ValueError", "RuntimeError"},
        "SampleCapReached": set(),
        "WorkerError": {"RuntimeError"},
        "OutputError": {"OSError"},
        "FolderInUse": {"ValueError"},
    }
    assert {c.__name__: _builtin_bases(c) for c in CLASSES} == expected


def test_every_class_is_exported_from_hybrid():
    for name in errors.__all__:
        assert getattr(hybrid, name) is getattr(errors, name)


def test_the_cli_usage_error_is_bad_input():
    from hybrid.cli.common import UsageError

    assert issubclass(UsageError, InputError)


def _modules():
    for path in sorted(ROOT.rglob("*.py")):
        yield path, ast.parse(path.read_text(), str(path)), path.read_text().splitlines()


def test_exception_classes_are_imported_from_core_errors_only():
    bad = []
    for path, tree, _ in _modules():
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom) and node.module is not None:
                names = {a.name for a in node.names} & set(errors.__all__)
                if names and not (
                    node.module.endswith("core.errors") or (node.level == 1 and node.module == "errors")
                ):
                    bad.append(
                        f"{path.relative_to(ROOT.parent)}:{node.lineno} {sorted(names)} from {node.module}"
                    )
    assert bad == []


def test_no_built_in_exception_is_raised_on_purpose():
    """A ``raise`` of a built-in exception class is allowed only where its built-in is the contract:
    a broken invariant (``AssertionError``, or a line excluded from coverage as unreachable), a
    protocol method (``__getitem__``: KeyError/IndexError, ``__setattr__``: AttributeError), and
    the arithmetic of evaluating a model's expressions (``ArithmeticError`` and its subclasses in
    :mod:`hybrid.model.codegen` and :mod:`hybrid.model.taylor`, as Python's own operators raise)."""
    protocol = {"__getitem__": {"KeyError", "IndexError"}, "__setattr__": {"AttributeError"}}
    arithmetic = {"model/codegen.py", "model/taylor.py"}
    bad = []
    for path, tree, lines in _modules():
        rel = str(path.relative_to(ROOT))
        parents = {}
        for node in ast.walk(tree):
            for child in ast.iter_child_nodes(node):
                parents[child] = node
        for node in ast.walk(tree):
            if not (isinstance(node, ast.Raise) and node.exc is not None):
                continue
            exc = node.exc.func if isinstance(node.exc, ast.Call) else node.exc
            cls = getattr(builtins, exc.id, None) if isinstance(exc, ast.Name) else None
            if not (isinstance(cls, type) and issubclass(cls, BaseException)):
                continue
            fn = node
            while fn in parents and not isinstance(fn, ast.FunctionDef):
                fn = parents[fn]
            if (
                cls is AssertionError
                or "pragma: no cover" in lines[node.lineno - 1]
                or (isinstance(fn, ast.FunctionDef) and exc.id in protocol.get(fn.name, ()))
                or (issubclass(cls, ArithmeticError) and rel in arithmetic)
            ):
                continue
            bad.append(f"{rel}:{node.lineno} {exc.id}")
    assert bad == []


# ----------------------------------------------------------------------------
# Each class where it is documented
# ----------------------------------------------------------------------------
def _oscillator(x_equation: str = "v") -> HybridSystem:
    return HybridSystem(
        name="osc",
        variables=["x", "v"],
        parameters=["w"],
        modes=[Mode("free", derivatives={"x": x_equation, "v": "-w**2*x"})],
        transitions=[],
        initial_mode="free",
    )


def _relay(guard: str = "sign(v)", reset: dict | None = None) -> HybridSystem:
    """A forced oscillator switching modes as v changes sign (extra variable c, constant)."""
    rhs = {"x": "v", "v": "-x - 0.1*v + cos(W*t)", "c": "0"}
    return HybridSystem(
        name="relay",
        variables=["x", "v", "c"],
        parameters=["W"],
        modes=[Mode("up", derivatives=rhs), Mode("down", derivatives=rhs)],
        transitions=[
            Transition("up", "down", guard=guard, direction=-1, name="fall", reset=reset or {}),
            Transition("down", "up", guard=guard, direction=1, name="rise"),
        ],
        period="2*pi/W",
        initial_mode="up",
    )


def test_input_error_for_a_bad_argument():
    with pytest.raises(InputError, match=r"`t_span` must be finite with t1 > t0, got \(1.0, 1.0\)"):
        simulate(_oscillator(), {"w": 2.0}, (1.0, 1.0), {"x": 1.0, "v": 0.0})
    with pytest.raises(InputError, match=r"IDA: `rtol` must lie in \[1e-14, 1e-2\], got 1.0"):
        SolverOptions(method=IDA(rtol=1.0))


def test_input_type_error_for_an_argument_of_the_wrong_type():
    with pytest.raises(InputTypeError, match="`options` must be a SolverOptions, got dict"):
        simulate(_oscillator(), {"w": 2.0}, (0.0, 1.0), {"x": 1.0, "v": 0.0}, options={"rtol": 1e-6})


def test_model_error_for_an_inconsistent_model_and_for_one_that_lacks_a_period():
    with pytest.raises(ModelError, match="mode `free` has no equation for variable"):
        HybridSystem(
            name="bad",
            variables=["x", "v"],
            parameters=[],
            modes=[Mode("free", derivatives={"x": "v"})],
            transitions=[],
        )
    with pytest.raises(
        ModelError, match="model `osc` declares no forcing `period`: this continuation of forced"
    ):
        hybrid.forcing_parameter(_oscillator())


def test_expression_error_for_a_malformed_expression():
    with pytest.raises(ExpressionError, match=r"equation: syntax error at column 4 in 'x \+\* 2'"):
        parse("x +* 2", {"x"}, "equation")
    # in a model's definition it is a ModelError naming where (an ExpressionError is one)
    with pytest.raises(
        ModelError, match=r"model `osc`: mode `free`: derivative of `x`: syntax error at column 4"
    ):
        _oscillator("x +* 2")


def test_not_affine_error_from_the_exact_integrator():
    with pytest.raises(NotAffineError, match="model `osc`: .*not affine"):
        simulate(
            _oscillator("v + x**2"),
            {"w": 2.0},
            (0.0, 1.0),
            {"x": 1.0, "v": 0.0},
            options=SolverOptions(method=Exact()),
        )


def test_simulation_error_when_asked_for():
    with pytest.raises(SimulationError, match="stopped after 0 transitions"):
        simulate(
            _relay("v"),
            {"W": 1.3},
            (0.0, 10.0),
            {"x": 0.0, "v": 0.5, "c": 0.0},
            max_transitions=0,
            throw=True,
        )


def test_algebraic_solve_error_for_slave_variables_without_a_solution():
    system = HybridSystem(
        name="dae",
        variables=["x", "z"],
        parameters=[],
        modes=[Mode("m", derivatives={"x": "-z"}, algebraic={"z": "z**2 + 1 + 0*x"})],
        transitions=[],
    )
    cm = CompiledSystem(system, {}).modes[0]
    with pytest.raises(AlgebraicSolveError, match="mode `m`"):
        cm.solve_algebraic(0.0, np.array([1.0, 0.0]))


def test_integrator_error_when_ida_fails_outside_the_event_loop():
    cm = CompiledSystem(_oscillator(), {"w": 2.0}).modes[0]
    solver = ModeSolver(cm, rtol=1e-8, atol=np.full(2, 1e-10), max_step=0.1, max_num_steps=500)
    y0 = np.array([1.0, 0.0])
    solver.start(0.0, y0, cm.derivatives(0.0, y0))
    solver.step(1.0, 10.0, one_step=False)
    with pytest.raises(
        IntegratorError, match=r"IDA could not interpolate at t=-5.0: One of the function inputs is invalid"
    ):
        solver.interpolate(-5.0)


def test_budget_exceeded_from_a_run_of_the_period_map():
    sh = Shooter(_relay("v"), {"W": 1.3}, SolverOptions(max_steps=20))
    with pytest.raises(BudgetExceeded, match=r"max_steps") as info:
        sh.run(np.array([0.0, 0.5, 0.0]), "up", 0.0)
    assert info.value.kind == "steps"


def test_convergence_error_where_the_bracket_has_no_equilibrium():
    # x' = p - x^2 has no equilibrium for p < 0
    system = HybridSystem(
        name="fold",
        variables=["x"],
        parameters=["p"],
        modes=[Mode("m", derivatives={"x": "p - x**2"})],
        transitions=[],
    )
    with pytest.raises(
        ConvergenceError, match=r"no equilibrium at p = -1.0: Newton's method did not converge"
    ):
        locate_hopf(system, {"p": 1.0}, "m", "p", (-1.0, 1.0), {"x": 1.0})


def test_grazing_switch_error_from_a_monodromy_across_a_step_guard():
    sh = Shooter(_relay(), {"W": 1.3}, SolverOptions())
    tr = sh.run(np.array([0.0, 0.5, 0.0]), "up", 0.0)
    assert tr.events  # (the run switches)
    with pytest.raises(
        GrazingSwitchError, match=r"grazing switch: the guard of `fall` .* saltation matrix is undefined"
    ):
        sh.monodromy(tr)


def test_parameter_out_of_domain_when_an_iteration_leaves_the_domain():
    system = HybridSystem(
        name="osc",
        variables=["x", "v"],
        parameters=[hybrid.Parameter("W", domain="positive")],
        modes=[Mode("free", derivatives={"x": "v", "v": "-x - 0.1*v + cos(W*t)"})],
        transitions=[],
        period="2*pi/W",
        initial_mode="free",
    )
    sh = Shooter(system, {"W": 1.3}, SolverOptions())
    with pytest.raises(ParameterOutOfDomain, match=r"parameter `W` must be > 0, got -0.5"):
        sh.set_params({"W": -0.5})
    with pytest.raises(InputError, match=r"parameter `W` must be > 0, got -0.5"):  # the caller's input
        Shooter(system, {"W": -0.5}, SolverOptions())


def test_sample_cap_reached_when_a_run_records_too_many_samples():
    rec = Recorder(
        1, lambda m: np.full(np.shape(m), "m", dtype=object), lambda t, y, m: {}, max_kept=2, max_total=2
    )
    rec.add(0.0, np.zeros(1), 0)
    rec.add(1.0, np.zeros(1), 0)
    with pytest.raises(
        SampleCapReached, match=r"stopped at t=2.0 after 2 samples, the most a run may have kept in memory"
    ):
        rec.add(2.0, np.zeros(1), 0)


def test_worker_error_when_a_worker_ends_without_a_result(monkeypatch):
    def die(self, *args, **kwargs):
        os._exit(3)  # (in the forked worker)

    monkeypatch.setattr(frc._PieceJob, "piece", die)
    system = hybrid_models.absorber()
    with pytest.raises(WorkerError, match=r"the worker of piece \d ended without a result \(exit code 3\)"):
        frequency_response(
            system,
            system.preset("standard"),
            (0.85, 1.175),
            options=SolverOptions(method=Exact()),
            workers=2,
        )


def test_output_error_when_a_result_cannot_be_written(tmp_path):
    from hybrid.core.files import write_atomic

    (tmp_path / "r.json").mkdir()  # a folder where the file goes
    with pytest.raises(
        hybrid.OutputError, match=r"cannot write '.*r.json': Is a directory \(EISDIR\)"
    ) as info:
        write_atomic(tmp_path / "r.json", "{}")
    assert info.value.errno == errno.EISDIR
    assert sorted(p.name for p in tmp_path.iterdir()) == ["r.json"]  # no temporary file left


def test_folder_in_use_when_another_process_holds_the_folder(tmp_path):
    holder = subprocess.Popen([sys.executable, "-c", HOLD, str(tmp_path)], stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout.readline().strip() == "locked"
        with pytest.raises(
            hybrid.FolderInUse, match=rf"is in use by another hybrid run \(pid {holder.pid}, "
        ):
            hybrid.core.files.FolderLock(tmp_path).acquire()
    finally:
        holder.kill()
        holder.wait()


#: A process holding the lock of the folder argv[1] until killed.
HOLD = (
    "import sys, time\nfrom hybrid.core.files import FolderLock\n"
    "FolderLock(sys.argv[1], 'holder').acquire()\nprint('locked', flush=True)\ntime.sleep(60)\n"
)


# ----------------------------------------------------------------------------
# A division by zero in the model's equations is not a grazing
# ----------------------------------------------------------------------------
def test_a_division_by_zero_in_the_monodromy_is_reported_as_an_evaluation_failure():
    # the reset v -> v + sqrt(c) runs (c = 0), its derivative 1/(2 sqrt(c)) divides by zero
    o = periodic_orbit(
        _relay("v", reset={"v": "v + sqrt(c)"}), {"W": 1.3}, {"x": 0.0, "v": 0.5, "c": 0.0}, "up"
    )
    assert not o.converged
    assert o.message == "evaluating the model's equations failed: ZeroDivisionError: float division by zero"


def test_a_grazing_switch_is_still_reported_as_one():
    o = periodic_orbit(_relay(), {"W": 1.3}, {"x": 0.0, "v": 0.5, "c": 0.0}, "up")
    assert not o.converged
    assert o.message.startswith("grazing switch: the guard of ")
    assert "saltation matrix is undefined" in o.message


def _cycle(guard: str = "y", reset: dict | None = None) -> HybridSystem:
    """The Stuart-Landau limit cycle (the unit circle) with a section switch on y (c constant)."""
    rhs = {"x": "a*x - w*y - x*(x**2 + y**2)", "y": "w*x + a*y - y*(x**2 + y**2)", "c": "0"}
    return HybridSystem(
        name="cycle",
        variables=["x", "y", "c"],
        parameters=["a", "w"],
        modes=[Mode("one", derivatives=rhs), Mode("two", derivatives=rhs)],
        transitions=[
            Transition("one", "two", guard, direction=1, name="up", reset=reset or {}),
            Transition("two", "one", guard, direction=-1, name="down"),
        ],
        initial_mode="one",
        orbit={"period_guess": "2*pi/w", "section": "up"},
    )


def test_an_autonomous_orbit_tells_an_evaluation_failure_from_a_grazing():
    p, x0 = {"a": 1.0, "w": 2.5}, {"x": 0.3, "y": 0.0, "c": 0.0}
    o = autonomous_orbit(_cycle(reset={"y": "y + sqrt(c)"}), p, x0, period=2.0)
    assert not o.converged
    assert o.message == "evaluating the model's equations failed: ZeroDivisionError: float division by zero"
    o = autonomous_orbit(_cycle("sign(y)"), p, x0, period=2.0)
    assert not o.converged
    assert o.message.startswith("grazing switch: ")
    assert o.message.endswith("at a grazing, try a nearby parameter value")
