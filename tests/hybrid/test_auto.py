"""The method chosen by the model, ``Auto()`` (issue 34, item 3): the exact integrator where every
mode and guard is affine and the forcing harmonic, IDA otherwise, with the reason; resolved by the
entry points before any run, so that a run with ``Auto()`` is the run of the method it chose."""

from __future__ import annotations

import numpy as np
import pytest

import hybrid_models
from hybrid import IDA, Exact, SolverOptions, simulate
from hybrid.cli import main
from hybrid.core.errors import InputError, InputTypeError
from hybrid.integrators.auto import EXACT_REASON, Auto, resolve
from hybrid.model.compiled import CompiledSystem


@pytest.fixture(scope="module")
def absorber():
    return hybrid_models.absorber()


@pytest.fixture(scope="module")
def belt():
    return hybrid_models.belt_stribeck()


def test_auto_takes_the_exact_integrator_for_an_affine_model_with_harmonic_forcing(absorber):
    choice = Auto().choose(absorber, absorber.preset("standard"))
    assert choice.method == Exact()
    assert choice.reason == EXACT_REASON
    assert choice.describe().startswith("exact (every mode and guard is affine")


def test_auto_takes_ida_with_its_own_tolerances_where_a_mode_is_not_affine_and_says_which(belt):
    choice = Auto(rtol=1e-9, atol=1e-12).choose(belt, belt.preset("standard"))
    assert choice.method == IDA(rtol=1e-9, atol=1e-12)
    # the Stribeck law exp(w/vs) of mode slip- is what the exact integrator cannot take
    assert "mode `slip-`" in choice.reason and "not affine in `w`" in choice.reason


def test_a_run_with_auto_is_the_run_of_the_method_it_chose(absorber, belt):
    pa = absorber.preset("standard")
    x0 = {"x1": 5.0, "v1": 0.0, "x2": 5.0, "v2": 0.0, "u": 5.0}
    T = 2 * np.pi / pa["Omega"]
    span, t_eval = (0.0, 5 * T), np.linspace(0.0, 5 * T, 11)
    a = simulate(absorber, pa, span, x0, "stick", t_eval=t_eval, options=SolverOptions(method=Auto()))
    e = simulate(absorber, pa, span, x0, "stick", t_eval=t_eval, options=SolverOptions(method=Exact()))
    assert len(a.events) == len(e.events) > 0
    np.testing.assert_array_equal(a.y, e.y)
    pb = belt.preset("standard")
    b = simulate(belt, pb, (0.0, 30.0), {"x": 0.0, "w": 0.0}, options=SolverOptions(method=Auto(rtol=1e-9)))
    i = simulate(belt, pb, (0.0, 30.0), {"x": 0.0, "w": 0.0}, options=SolverOptions(method=IDA(rtol=1e-9)))
    np.testing.assert_array_equal(b.y_final, i.y_final)
    assert [ev.t for ev in b.events] == [ev.t for ev in i.events]


def test_resolve_replaces_only_auto(absorber):
    p = absorber.preset("standard")
    opts = SolverOptions(method=IDA(rtol=1e-9), max_steps=12345)
    assert resolve(opts, absorber, p) == (opts, None)
    resolved, choice = resolve(SolverOptions(method=Auto(), max_steps=12345), absorber, p)
    assert resolved == SolverOptions(method=Exact(), max_steps=12345)
    assert choice.method == Exact()


def test_auto_checks_its_settings_as_ida_does_and_refuses_to_run_unresolved(absorber):
    with pytest.raises(InputError, match=r"IDA: `rtol` must lie in \[1e-14, 1e-2\]"):
        Auto(rtol=1.0)
    with pytest.raises(InputTypeError, match="IDA: no setting 'tol'"):
        Auto(tol=1e-9)
    assert Auto(rtol=1e-9) == Auto(rtol=1e-9) != Auto(rtol=1e-10)
    assert Auto(rtol=1e-9).settings()["name"] == "auto"
    cs = CompiledSystem(absorber, absorber.preset("standard"))
    with pytest.raises(InputError, match=r"Auto\(\) is resolved per model before a run"):
        Auto().mode_solver(cs, 0, SolverOptions(), max_step=0.1)


def test_the_command_line_says_what_auto_chose(tmp_path, capsys):
    code = main(
        [
            "simulate",
            "absorber",
            "--periods",
            "2",
            "--integrator",
            "auto",
            "--no-plot",
            "--out",
            str(tmp_path / "a"),
        ]
    )
    err = capsys.readouterr().err
    assert code == 0
    assert "integrator auto: exact (every mode and guard is affine" in err
    code = main(
        [
            "simulate",
            "belt_stribeck",
            "--t-end",
            "5",
            "--integrator",
            "auto",
            "--no-plot",
            "--out",
            str(tmp_path / "b"),
        ]
    )
    err = capsys.readouterr().err
    assert code == 0
    assert (
        "integrator auto: ida (the exact integrator cannot take it: model `belt_stribeck`: mode `slip-`"
        in err
    )
