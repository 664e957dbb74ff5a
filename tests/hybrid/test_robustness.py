"""Regressions from the review of issue 2: bad numbers at run time, limits, model-file types, CLI lookup."""

import warnings

import numpy as np
import pytest

import hybrid_models
from hybrid import (
    IDA,
    Exact,
    HybridSystem,
    Mode,
    ModelError,
    SolverOptions,
    Status,
    Transition,
    method_named,
    simulate,
    system_from_dict,
)
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
    system = hybrid_models.absorber()
    p = system.preset("standard")
    with pytest.raises(
        ValueError,
        match=r"make 135918321\d{2} samples; at most 2000000 may be kept in memory: stream them to a sink",
    ):  # 1e9 s / (2 pi / 0.854 s) x 100 = 1.35918e10 samples
        simulate(system, p, (0.0, 1e9), dict.fromkeys(system.variable_names, 0.0), samples_per_period=100)


def test_max_transitions_is_exact_and_leaves_a_consistent_final_state():
    system = hybrid_models.coulomb()
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
            options=SolverOptions(method=IDA(rtol=1e-11, atol=1e-13)),
        )
    assert tr.status == Status.ZENO
    # Closed form: first impact at t1 = sqrt(2 h0/g) with speed v1 = sqrt(2 g h0); the k-th impact
    # (k = 1, 2, ...) hits with speed e^(k-1) v1 and the flight after it lasts 2 e^k v1/g, so
    # t_k = t1 + 2 (v1/g) e (1 - e^(k-1))/(1 - e), converging to t1 (1 + 2e/(1 - e)) = 3 t1.
    # Every impact the engine locates, while the flight before it rises at least 100 atol
    # (apex e^(2(k-1)) h0 >= 1e-11 m, k <= 19), against these (not the engine's own guard value: the
    # time and the state it switched at): time to 1e-12 s, speeds before and after to 1e-12 of the
    # speed, h to 1e-13 (h is quadratic in t, which IDA's interpolant of order >= 2 represents exactly:
    # measured 4.4e-16 s and 4e-15, i.e. rounding). Lower flights are inside the noise band of the
    # tolerances, where the Zeno diagnosis takes over.
    g, e, h0, atol = 9.81, 0.5, 1.0, 1e-13
    t1, v1 = np.sqrt(2 * h0 / g), np.sqrt(2 * g * h0)
    resolved = 0
    for k, ev in enumerate(tr.events, start=1):
        if e ** (2 * (k - 1)) * h0 < 100 * atol:
            break
        assert not ev.chained, k
        t_k = t1 + 2 * (v1 / g) * e * (1 - e ** (k - 1)) / (1 - e)
        speed = e ** (k - 1) * v1
        assert abs(ev.t - t_k) <= 1e-12, (k, ev.t - t_k)
        assert abs(ev.x_minus[1] + speed) <= 1e-12 * speed, k
        assert abs(ev.x_plus[1] - e * speed) <= 1e-12 * speed, k
        assert abs(ev.x_minus[0]) <= atol, k
        resolved += 1
    assert resolved == 19
    t_zeno = 3 * t1  # t1 (1 + 2e/(1 - e)) with e = 0.5
    assert abs(tr.t_final - t_zeno) <= 1e-5


def _with_output(expr: str) -> HybridSystem:
    return HybridSystem(
        name="toy",
        variables=["x"],
        parameters=["W"],
        modes=[Mode("a", derivatives={"x": "-W*x"})],
        transitions=[],
        definitions={"o": expr},
        outputs=["o"],
        initial_mode="a",
    )


@pytest.mark.parametrize(
    "expr",
    ["log(x)", "sqrt(x)*exp(-t) + abs(x - 0.5)*sign(x - 0.5) + atan(x)/cosh(x)", "x**1.5 + tan(x)*W", "W"],
)
def test_sampled_outputs_evaluated_at_once_equal_the_scalar_functions(expr):
    """Outputs of the samples are evaluated elementwise on arrays (numpy's functions); each value
    equals the generated scalar function's at that sample (math's functions) to rounding, and an
    output without a state symbol (a constant) fills every sample."""
    from hybrid.model.compiled import CompiledSystem

    system = _with_output(expr)
    for integrator in ("ida", "exact"):
        tr = simulate(
            system,
            {"W": 0.7},
            (0.0, 3.0),
            {"x": 2.0},
            t_eval=np.linspace(0.0, 3.0, 301),
            options=SolverOptions(method=method_named(integrator)),
        )
        assert tr.success, tr.message
        fn = CompiledSystem(system, {"W": 0.7}).modes[0].outputs["o"]
        ref = np.array([fn([t, x]) for t, x in zip(tr.t, tr["x"], strict=True)])
        np.testing.assert_allclose(tr["o"], ref, rtol=1e-14, atol=0.0)


def test_an_output_that_cannot_be_evaluated_at_a_sample_is_named_with_its_time():
    """Where an elementwise value is not finite the samples are evaluated one by one, so the
    failure names the output, the mode and the time, as before (log of a negative number)."""
    system = _with_output("log(x - 1)")  # x = 2 exp(-t) falls below 1 at t = log 2
    tr = simulate(system, {"W": 1.0}, (0.0, 1.0), {"x": 2.0}, t_eval=np.linspace(0.0, 1.0, 11), throw=False)
    assert tr.status == Status.EVALUATION_FAILED
    assert tr.message.startswith("evaluating output `o` of mode `a` at t=0.7")
    assert "ValueError" in tr.message


@pytest.mark.slow
def test_a_residual_stalled_by_an_ill_conditioned_map_says_so():
    """The forced Coulomb oscillator at half its natural frequency: stops of zero length, a
    multiplier 1 (I - M nearly singular). IDA's runs (rtol 1e-10) cannot bring the residual to
    1e-9 there; the failure says why and what to change, and the remedy it names works: the exact
    integrator converges at the same point and finds the multiplier 1 (an independent estimate)."""
    import re

    from hybrid import periodic_orbit

    system = hybrid_models.coulomb()
    p = system.preset("forced", Omega=0.5)
    o = periodic_orbit(system, p)
    assert not o.converged
    assert "I - M is nearly singular here" in o.message, o.message
    assert "--integrator exact" in o.message, o.message
    cond = float(re.search(r"cond ([0-9.e+]+):", o.message).group(1))
    assert cond * 1e-10 > 1e-9  # the amplified error exceeds the tolerance, as it says
    exact = periodic_orbit(system, p, options=SolverOptions(method=Exact()))
    assert exact.converged, exact.message
    # a multiplier 1 there (reported as a family of orbits, or with cond(I - M) above 1e6)
    assert np.min(np.abs(np.asarray(exact.multipliers) - 1.0)) < 1e-5
    assert exact.family or exact.condition > 1e6


def test_the_stall_note_is_not_given_where_the_map_is_well_conditioned():
    from hybrid.orbits.newton import _noisy

    J = np.diag([-0.5, -0.25])  # I - M of a map contracting by 1/2 and 3/4
    assert _noisy(J, 2e-9, 1e-9, 1e-10) == ""  # cond 2: the runs resolve the tolerance
    assert _noisy(np.diag([-1.0, -1e-7]), 1.0, 1e-9, 1e-10) == ""  # far from converged: not the reason
    assert "nearly singular" in _noisy(np.diag([-1.0, -1e-7]), 2e-9, 1e-9, 1e-10)
    assert _noisy(None, 2e-9, 1e-9, 1e-10) == ""
