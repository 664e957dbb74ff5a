"""Results keep the options they were computed with, print them, and repeat from them (issue 29
item 6: "results cannot be repeated from themselves")."""

from __future__ import annotations

import json

import numpy as np
import pytest
from problems import forced_oscillator

import hybrid
import hybrid_models
from hybrid import IDA, ContinuationOptions, Exact, NewtonOptions, ShootingOptions, SolverOptions
from hybrid.cli import main
from hybrid.core import options as options_module
from hybrid.core.plain import CLASS_KEY, options_text, plain_data

RANGE = (0.6, 0.7)
#: Non-default options of every kind (a nested one included).
OPTIONS = SolverOptions(method=Exact(), max_chain=9)
SETTINGS = ContinuationOptions(ds=0.03, max_angle=0.08, newton=NewtonOptions(tol=1e-10, max_iter=8))


def rebuilt(data):
    """The options object of :func:`plain_data`'s data, built by its class name (independent of
    the code under test: a plain walk of the data)."""
    if isinstance(data, dict) and CLASS_KEY in data:
        cls = getattr(options_module, data[CLASS_KEY], None) or getattr(hybrid, data[CLASS_KEY])
        return cls(**{k: rebuilt(v) for k, v in data.items() if k != CLASS_KEY})
    return data


@pytest.fixture(scope="module")
def coulomb():
    system = hybrid_models.coulomb()
    return system, system.presets["forced"]


@pytest.fixture(scope="module")
def branch(coulomb):
    system, params = coulomb
    return hybrid.continue_orbits(system, params, None, RANGE, options=OPTIONS, settings=SETTINGS)


def test_a_branch_carries_and_prints_the_options_it_was_computed_with(branch):
    assert branch.points
    assert branch.options == OPTIONS and branch.settings == SETTINGS
    text = repr(branch)
    assert "options=SolverOptions(method=Exact(), max_chain=9)" in text
    assert (
        "settings=ContinuationOptions(ds=0.03, newton=NewtonOptions(tol=1e-10, max_iter=8), max_angle=0.08)"
        in text
    )


def test_a_branch_run_again_from_its_stored_options_is_the_same_branch(coulomb, branch):
    system, params = coulomb
    again = hybrid.continue_orbits(
        system, branch.params, branch.parameter, RANGE, options=branch.options, settings=branch.settings
    )
    np.testing.assert_array_equal(again.values, branch.values)
    assert [o.amplitude for o in again.points] == [o.amplitude for o in branch.points]
    assert (again.status, again.reason) == (branch.status, branch.reason)
    # the options make a difference here: without them (the defaults, exact flow) the points differ
    default = hybrid.continue_orbits(system, params, None, RANGE, options=SolverOptions(method=Exact()))
    assert default.settings == ContinuationOptions()
    assert len(default.values) != len(branch.values) or not np.array_equal(default.values, branch.values)


def test_the_defaults_used_in_place_of_none_are_recorded(coulomb):
    system, params = coulomb
    orbit = hybrid.periodic_orbit(system, params, options=OPTIONS)
    assert orbit.options == OPTIONS and orbit.settings == ShootingOptions()
    assert "options=SolverOptions(method=Exact(), max_chain=9), settings=ShootingOptions())" in repr(orbit)
    tr = hybrid.simulate(system, params, (0.0, 1.0), np.zeros(4))
    assert tr.options == SolverOptions()
    assert repr(tr).endswith("options=SolverOptions())")
    assert hybrid.simulate(system, params, (0.0, 1.0), np.zeros(4), options=OPTIONS).options == OPTIONS


def test_plain_data_of_nested_options_is_json_and_builds_them_again():
    for obj in (
        OPTIONS,
        SETTINGS,
        ShootingOptions(newton=NewtonOptions(tol=1e-7)),
        SolverOptions(method=IDA(atol={"x": 1e-9})),
    ):
        data = json.loads(json.dumps(plain_data(obj)))
        assert rebuilt(data) == obj
    assert plain_data(SETTINGS)["newton"] == {CLASS_KEY: "NewtonOptions", "tol": 1e-10, "max_iter": 8}
    assert "_atol_map" not in plain_data(OPTIONS)  # (not a constructor argument)
    assert options_text(SolverOptions()) == "SolverOptions()"
    assert plain_data(None) is None


@pytest.mark.slow
def test_a_frequency_response_and_a_sweep_carry_their_options(tmp_path):
    system, params, _, _ = forced_oscillator()
    fr = hybrid.frequency_response(system, params, (0.5, 1.5), options=OPTIONS, settings=SETTINGS)
    assert fr.options == OPTIONS and fr.settings == SETTINGS
    assert all(b.options == OPTIONS and b.settings == SETTINGS for b in fr.branches)
    assert "options=SolverOptions(method=Exact(), max_chain=9)" in repr(fr)
    res = hybrid.sweep(
        system,
        params,
        [hybrid.linear_axis("c", 0.1, 0.1, 1.0)],
        tmp_path,
        p_range=(0.5, 1.5),
        options=OPTIONS,
    )
    assert res.options == OPTIONS and res.settings == hybrid.studies.sweep.SWEEP_CONTINUATION
    assert "options=SolverOptions(method=Exact(), max_chain=9)" in repr(res)


@pytest.mark.slow
def test_frc_json_and_orbit_json_hold_the_options(tmp_path, capsys):
    code = main(
        ["frc", "coulomb", "--omega-range", *map(str, RANGE), "--integrator", "ida", "--rtol", "1e-9"]
        + ["--no-plot", "--no-progress", "--workers", "1", "--out", str(tmp_path / "f")]
    )
    assert code == 0, capsys.readouterr().err
    data = json.loads((tmp_path / "f" / "frc.json").read_text())
    # the CLI's tolerances (--rtol given; --atol's default 1e-12) and its budgets' defaults
    assert rebuilt(data["options"]) == SolverOptions(method=IDA(rtol=1e-9, atol=1e-12))
    capsys.readouterr()
    # issue 29: a tolerance the exact method does not use is refused, not ignored
    code = main(
        [
            "frc",
            "coulomb",
            "--omega-range",
            *map(str, RANGE),
            "--integrator",
            "exact",
            "--rtol",
            "1e-9",
            "--no-plot",
            "--out",
            str(tmp_path / "g"),
        ]
    )
    assert code == 2
    assert "--rtol does not apply to --integrator exact" in capsys.readouterr().err
    assert rebuilt(data["settings"]) == ContinuationOptions()
    capsys.readouterr()
    code = main(
        ["orbit", "coulomb", "--integrator", "exact", "--json", "--no-plot", "--out", str(tmp_path / "o")]
    )
    assert code == 0
    data = json.loads(capsys.readouterr().out)
    assert rebuilt(data["options"]) == SolverOptions(method=Exact())
    assert rebuilt(data["settings"]) == ShootingOptions()  # (the CLI's defaults: 10 periods, 512 samples)
