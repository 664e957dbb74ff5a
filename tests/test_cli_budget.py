"""Issue 13 from the command line: bounded runs with one clear line; exit code 2 for input refused
before any run, 1 for a computation that failed or ran out of its budget."""

import json

import pytest

from hybrid.cli import main


def run(argv, capsys, tmp_path):
    code = main([*argv, "--out", str(tmp_path), "--no-plot"])
    out = capsys.readouterr()
    return code, out.out, out.err


def reason(err: str) -> str:
    """The one line of the failure (``hybrid: ...``), checked to be alone and without a traceback."""
    assert "Traceback" not in err
    lines = [ln for ln in err.splitlines() if ln.startswith("hybrid:")]
    assert len(lines) == 1, err
    return lines[0]


@pytest.mark.parametrize(
    ("argv", "start"),
    [
        (["simulate", "absorber", "--omega", "1e308"], "hybrid: error: the step bound 3.93e-309 s"),
        (["orbit", "absorber", "--omega", "1e308"], "hybrid: error: the step bound 3.93e-309 s"),
        (["frc", "absorber", "--omega-range", "1", "1e300"], "hybrid: error: the step bound"),
        (
            ["simulate", "absorber", "--x0", "x1=1e308"],
            "hybrid: error: the initial state cannot be evaluated",
        ),
        (["orbit", "absorber", "--x0", "x1=1e308"], "hybrid: error: the initial state cannot be evaluated"),
        (
            ["orbit", "absorber", "--samples-per-period", "4"],
            "hybrid: error: ShootingOptions: `samples_per_period` must be",
        ),
    ],
)
def test_input_that_cannot_be_run_is_refused_with_exit_code_2(argv, start, capsys, tmp_path):
    code, _, err = run(argv, capsys, tmp_path)
    assert code == 2
    assert reason(err).startswith(start)


@pytest.mark.parametrize("command", ["simulate", "orbit", "frc"])
@pytest.mark.parametrize("flag", ["--max-time", "--max-steps"])
def test_budget_flags_must_be_positive(command, flag, capsys, tmp_path):
    with pytest.raises(SystemExit) as info:
        main([command, "coulomb", flag, "0"])
    assert info.value.code == 2
    assert f"argument {flag}: must be" in capsys.readouterr().err


def test_simulate_out_of_steps_exits_1_and_writes_its_files(capsys, tmp_path):
    code, _, err = run(
        ["simulate", "coulomb", "--preset", "forced", "--max-steps", "300", "--json"], capsys, tmp_path
    )
    assert code == 1
    assert reason(err).startswith("hybrid: simulation stopped early: step limit reached: ")
    assert "--max-steps" in err
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["status"] == "STEP_LIMIT"
    assert summary["message"].startswith("step limit reached")


def test_tiny_masses_stop_quickly_saying_why(capsys, tmp_path):
    # before: about 3 hours with the progress bar at 0 %
    argv = ["simulate", "absorber", "--set", "m1=1e-9", "--set", "m2=1e-9", "--max-steps", "1000000"]
    code, _, err = run(argv, capsys, tmp_path)
    assert code == 1
    line = reason(err)
    assert line.startswith("hybrid: simulation stopped early: step limit: at its rate so far this run needs")
    assert "times the forcing frequency (dynamics far faster than the forcing" in line


@pytest.mark.slow
@pytest.mark.parametrize(
    "argv",
    [
        ["orbit", "absorber", "--transient", "1000000", "--max-steps", "1000000"],  # before: > 120 s
        ["orbit", "absorber", "--set", "m2=1e-9", "--max-steps", "200000"],  # before: hung
    ],
)
def test_orbit_runs_out_of_steps_with_exit_code_1(argv, capsys, tmp_path):
    code, _, err = run(argv, capsys, tmp_path)
    assert code == 1
    line = reason(err)
    assert line.startswith("hybrid: no periodic orbit: transient failed: step limit")
    assert "--transient" in line


def test_orbit_runs_out_of_time_with_exit_code_1(capsys, tmp_path):
    code, _, err = run(["orbit", "absorber", "--max-time", "0.001"], capsys, tmp_path)
    assert code == 1
    assert "time limit reached: the computation's limit of 0.001 s" in reason(err)


def test_frc_out_of_time_still_writes_its_files(capsys, tmp_path):
    # before: `--omega-range 0.001 1000` ran for more than 120 s with nothing written
    argv = ["frc", "coulomb", "--preset", "forced", "--omega-range", "0.001", "1000", "--max-time", "1"]
    code, _, err = run(argv, capsys, tmp_path)
    assert code == 1
    assert "Traceback" not in err
    assert "hybrid: time limit reached (hybrid.time_limit; CLI --max-time)" in err
    for name in ("frc.csv", "frc_special.csv", "frc_overlays.csv", "frc.json"):
        assert (tmp_path / name).exists()
    assert json.loads((tmp_path / "frc.json").read_text())["complete"] is False
