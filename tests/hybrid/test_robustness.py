"""Regressions from the review of issue 2: bad numbers at run time, limits, model-file types, CLI lookup."""

import warnings

import numpy as np
import pytest

import models
from hybrid import HybridSystem, Mode, ModelError, SolverOptions, Status, Transition, simulate
from hybrid._loader import system_from_dict
from hybrid.cli import main


def one_mode(rhs: str, guard: str = "x - 10", period: str | None = None, domain: str = "real"):
    return HybridSystem(
        name="toy",
        variables=["x"],
        parameters=["W"],
        modes=[Mode("a", derivatives={"x": rhs})],
        transitions=[Transition("a", "a", guard=guard, direction=1)],
        period=period,
        initial_mode="a",
    )


@pytest.mark.parametrize(
    "rhs,x0,kind",
    [
        ("log(x)", -1.0, "ValueError"),  # math domain error
        ("1/(x - 0.5)", 0.5, "ZeroDivisionError"),
        ("exp(100*x*x)", 3.0, "OverflowError"),
        ("-1 + 1e-9*x**0.5", 0.2, "ArithmeticError"),  # x goes negative: negative base, fractional power
    ],
)
def test_math_errors_in_model_expressions_are_failures_returned_as_data(rhs, x0, kind):
    system = one_mode(rhs)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        tr = simulate(system, {"W": 1.0}, (0.0, 1.0), {"x": x0}, throw=False)
    assert tr.status == Status.EVALUATION_FAILED
    assert tr.message.startswith("evaluating the equations of mode `a` near t=")
    assert kind in tr.message
    assert not tr.success


def test_a_period_that_cannot_be_evaluated_names_the_period():
    system = one_mode("-x", period="2*pi/W")
    with pytest.raises(ValueError, match=r"forcing period '2\*pi/W' cannot be evaluated"):
        simulate(system, {"W": 0.0}, (0.0, 1.0), {"x": 1.0})


def test_too_many_samples_is_refused_before_integrating():
    system = models.absorber()
    p = system.preset("standard")
    with pytest.raises(
        ValueError,
        match=r"make 135918321\d{2} samples; at most 2000000 may be kept in memory: stream them to a sink",
    ):  # 1e9 s / (2 pi / 0.854 s) x 100 = 1.35918e10 samples
        simulate(system, p, (0.0, 1e9), dict.fromkeys(system.variable_names, 0.0), samples_per_period=100)


def test_max_transitions_is_exact_and_leaves_a_consistent_final_state():
    system = models.coulomb()
    tr = simulate(
        system, system.preset("free"), (0.0, 60.0), {"x": 1.0, "v": 0.0}, max_transitions=3, throw=False
    )
    assert tr.status == Status.MAX_TRANSITIONS
    assert tr.n_transitions == 3
    assert tr.mode_final == tr.events[-1].target


def test_a_constant_guard_is_rejected():
    with pytest.raises(ModelError, match=r"guard of transition `a->a` \('x - x'\) depends on no variable"):
        one_mode("-x", guard="x - x")


@pytest.mark.parametrize(
    "patch,message",
    [
        ({"variables": ["x"]}, r"\[variables\] must be a table"),
        ({"plot": ["x"]}, r"\[plot\] must be a table"),
        ({"transitions": {"source": "a"}}, r"`transitions` must be an array of tables"),
        ({"model": {"name": {"a": 1}}}, r"\[model\] `name` must be a string"),
        ({"plot": {"displacements": "x"}}, r"\[plot\] `displacements` must be a list of names"),
    ],
)
def test_model_file_tables_of_the_wrong_type_are_named(patch, message):
    data = {
        "model": {"name": "toy", "initial_mode": "a"},
        "variables": {"x": {}},
        "modes": {"a": {"derivatives": {"x": "-x"}}},
    }
    data.update(patch)
    with pytest.raises(ModelError, match=message):
        system_from_dict(data)


def test_a_transition_direction_must_be_an_integer():
    with pytest.raises(ModelError, match=r"direction must be -1, 0 or 1, got -1.0"):
        Transition("a", "a", guard="x", direction=-1.0)


def test_a_bad_preset_value_names_the_preset():
    data = {
        "model": {"name": "toy"},
        "variables": {"x": {}},
        "parameters": {"k": {"domain": "positive"}},
        "presets": {"soft": {"k": -1.0}},
        "modes": {"a": {"derivatives": {"x": "-k*x"}}},
    }
    with pytest.raises(ModelError, match=r"preset `soft`: parameter `k` must be > 0, got -1.0"):
        system_from_dict(data)


def test_builtin_names_are_not_shadowed_by_files_and_directories_are_named(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "coulomb").write_text("not a model")
    assert main(["simulate", "coulomb", "--preset", "free", "--periods", "1", "--no-plot"]) == 0
    (tmp_path / "dir.toml").mkdir()
    assert main(["simulate", "dir.toml"]) == 2
    assert "is a directory" in capsys.readouterr().err


def test_cli_reports_a_run_time_math_error_in_one_line(tmp_path, capsys):
    path = tmp_path / "bad.toml"
    path.write_text(
        '[model]\nname = "bad"\ninitial_mode = "a"\n[variables.x]\n[modes.a]\nderivatives = { x = "log(x)" }\n'
        '[[transitions]]\nsource = "a"\ntarget = "a"\nguard = "x - 10"\ndirection = 1\n'
    )
    code = main(
        ["simulate", str(path), "--t-end", "5", "--x0", "x=-1", "--out", str(tmp_path / "o"), "--no-plot"]
    )
    err = capsys.readouterr().err
    assert code == 1
    assert "Traceback" not in err
    assert "simulation stopped early: evaluating the equations of mode `a` near t=0.0 failed" in err


def test_a_crossing_found_at_a_step_end_is_located():
    # Near the Zeno point the ball's guard is disarmed after each impact and later found crossed at a step
    # end; that crossing is bracketed and located on IDA's interpolant, not taken at the step end.
    ball = HybridSystem(
        name="ball",
        variables=["h", "v"],
        parameters=["g", "e"],
        modes=[Mode("fly", derivatives={"h": "v", "v": "-g"})],
        transitions=[Transition("fly", "fly", guard="h", direction=-1, name="impact", reset={"v": "-e*v"})],
    )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        tr = simulate(
            ball,
            {"g": 9.81, "e": 0.5},
            (0.0, 5.0),
            {"h": 1.0, "v": 0.0},
            "fly",
            throw=False,
            options=SolverOptions(rtol=1e-11, atol=1e-13),
        )
    assert tr.status == Status.ZENO
    located = [ev for ev in tr.events if not ev.chained]
    assert max(abs(ev.guard_value) for ev in located) <= 1e-10
    t_zeno = np.sqrt(2 / 9.81) * 3  # t1 (1 + 2e/(1 - e)) with e = 0.5
    assert abs(tr.t_final - t_zeno) <= 1e-5
