"""Command line: outputs, JSON summary, and one-line errors with exit code 2 for bad input (issue 2)."""

import csv
import json
import math
import re
import shutil
import subprocess
import sys

import pytest

from hybrid.cli import main


def run(argv, capsys):
    code = main(argv)
    out = capsys.readouterr()
    return code, out.out, out.err


def test_simulate_writes_csv_figure_and_json(tmp_path, capsys):
    code, out, err = run(
        ["simulate", "coulomb", "--preset", "forced", "--periods", "3", "--out", str(tmp_path), "--json"],
        capsys,
    )
    assert code == 0, err
    summary = json.loads(out)
    assert summary["model"] == "coulomb"
    assert summary["parameters"]["F"] == 0.5
    assert summary["transitions"] == len(list(csv.reader((tmp_path / "events.csv").open()))) - 1
    assert abs(summary["energy_balance_residual"]) <= 1e-6 * (
        summary["input_work"] + summary["dissipated_energy"]
    )
    for name in ("trajectory.csv", "events.csv", "trajectory.png", "summary.json"):
        assert (tmp_path / name).stat().st_size > 0
    rows = list(csv.reader((tmp_path / "trajectory.csv").open()))
    assert rows[0][:3] == ["t [s]", "mode", "x [m]"]
    assert {r[1] for r in rows[1:]} <= {"stick", "slip+", "slip-"}


def test_coulomb_runs_forced_by_default_and_free_on_request(tmp_path, capsys):
    # the default preset of the built-in coulomb is `forced` (F > 0: the figure shows stick-slip);
    # `free` (F = 0, a free decay) stays available
    code, out, err = run(
        ["simulate", "coulomb", "--periods", "3", "--no-plot", "--out", str(tmp_path), "--json"], capsys
    )
    assert code == 0, err
    summary = json.loads(out)
    assert summary["preset"] == "forced"
    assert summary["parameters"]["F"] == 0.5
    assert summary["transitions"] > 0
    assert summary["input_work"] > 0
    code, out, err = run(
        ["simulate", "coulomb", "--preset", "free", "--t-end", "5", "--x0", "x=1", "--no-plot"]
        + ["--out", str(tmp_path), "--json"],
        capsys,
    )
    assert code == 0, err
    summary = json.loads(out)
    assert summary["preset"] == "free"
    assert summary["parameters"]["F"] == 0.0
    assert summary["input_work"] == 0.0


def test_set_and_omega_override_the_preset(tmp_path, capsys):
    code, out, err = run(
        [
            "simulate",
            "absorber",
            "--set",
            "R=0.7",
            "--omega",
            "1.2",
            "--periods",
            "2",
            "--out",
            str(tmp_path),
            "--json",
            "--no-plot",
        ],
        capsys,
    )
    assert code == 0, err
    summary = json.loads(out)
    assert summary["parameters"]["R"] == 0.7
    assert summary["parameters"]["Omega"] == 1.2
    assert summary["preset"] == "standard"
    assert math.isclose(summary["t_final"], 2 * 2 * math.pi / 1.2, rel_tol=1e-12)


BAD_PARAMS = [
    (["--set", "m1=0"], r"parameter `m1` .* must be > 0, got 0.0"),
    (["--set", "m2=-0.1"], r"parameter `m2` .* must be > 0"),
    (["--set", "c3=0"], r"parameter `c3` .* must be > 0"),
    (["--set", "R=-1"], r"parameter `R` .* must be >= 0, got -1.0"),
    (["--set", "F=-0.01"], r"parameter `F` .* must be >= 0"),
    (["--set", "c1=nan"], r"parameter `c1` .* must be finite"),
    (["--set", "c2=inf"], r"parameter `c2` .* must be finite"),
    (["--set", "mass=1"], r"no parameter `mass`; parameters: m1, m2, c1, c2, c3, R, F, Omega"),
    (["--set", "m1"], r"`--set` takes NAME=VALUE"),
    (["--set", "m1=heavy"], r"'heavy' is not a number"),
    (["--preset", "fig9"], r"no preset `fig9`; presets: standard, fig3a, fig3b"),
]


@pytest.mark.parametrize("extra,message", BAD_PARAMS)
def test_bad_parameters_give_one_line_errors(extra, message, tmp_path, capsys):
    code, out, err = run(["simulate", "absorber", "--periods", "1", "--out", str(tmp_path), *extra], capsys)
    assert code == 2
    assert out == ""
    lines = err.strip().splitlines()
    assert len(lines) == 1
    assert lines[0].startswith("hybrid: error: ")
    assert "Traceback" not in err
    assert re.search(message, lines[0]), lines[0]
    assert not (tmp_path / "trajectory.csv").exists()  # nothing integrated, nothing written


@pytest.mark.parametrize("omega", ["0", "-0.5", "nan", "inf"])
def test_non_positive_or_non_finite_omega_is_rejected(omega, capsys):
    with pytest.raises(SystemExit) as exc:
        main(["simulate", "absorber", f"--omega={omega}"])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert "--omega" in err
    assert "must be a finite number > 0" in err


def test_unknown_model(capsys):
    code, out, err = run(["simulate", "damper9000"], capsys)
    assert code == 2
    assert (
        "unknown model `damper9000`; built-in models: absorber, belt, belt_damper, belt_sign, belt_stribeck, bk_chain, bladed_disk, coulomb, coulomb_sign, friction_oscillator, isolator, iwan"
        in err
    )


MODEL = """
[model]
name = "toy"
period = "2*pi/Omega"
initial_mode = "a"
[variables.x]
[variables.v]
[parameters.k]
domain = "positive"
[parameters.Omega]
domain = "positive"
[presets.standard]
k = 1.0
Omega = 1.0
[modes.a]
derivatives = {{ x = "v", v = "{rhs}" }}
[[transitions]]
source = "a"
target = "{target}"
guard = "{guard}"
direction = 1
"""

BAD_MODELS = [
    ({"rhs": "-k*x + q", "target": "a", "guard": "x"}, r"unknown name `q`"),
    ({"rhs": "-k*x +* 2", "target": "a", "guard": "x"}, r"syntax error"),
    ({"rhs": "-k*x.real", "target": "a", "guard": "x"}, r"forbidden construct `Attribute`"),
    ({"rhs": "__import__('os')", "target": "a", "guard": "x"}, r"call of `__import__` is not allowed"),
    ({"rhs": "-k*x^2", "target": "a", "guard": "x"}, r"use \*\* for powers"),
    ({"rhs": "-k*x", "target": "b", "guard": "x"}, r"target mode `b` that does not exist"),
    ({"rhs": "-k*x", "target": "a", "guard": "y - 1"}, r"guard of transition .* unknown name `y`"),
]


@pytest.mark.parametrize("fields,message", BAD_MODELS)
def test_bad_model_files_give_one_line_errors(fields, message, tmp_path, capsys):
    path = tmp_path / "toy.toml"
    path.write_text(MODEL.format(**fields))
    code, out, err = run(["simulate", str(path), "--periods", "1", "--out", str(tmp_path / "o")], capsys)
    assert code == 2, err
    lines = err.strip().splitlines()
    assert len(lines) == 1
    assert "Traceback" not in err
    assert lines[0].startswith("hybrid: error: toy.toml: model `toy`"), lines[0]
    assert re.search(message, lines[0]), lines[0]


def test_unknown_variable_in_a_mode(tmp_path, capsys):
    path = tmp_path / "toy.toml"
    path.write_text(
        MODEL.format(rhs="-k*x", target="a", guard="x").replace('v = "-k*x"', 'v = "-k*x", z = "1"')
    )
    code, out, err = run(["simulate", str(path), "--periods", "1"], capsys)
    assert code == 2
    assert "mode `a` gives an equation for unknown variable `z`; variables: x, v" in err


def test_model_file_runs(tmp_path, capsys):
    path = tmp_path / "toy.toml"
    path.write_text(MODEL.format(rhs="-k*x", target="a", guard="x - 2"))
    code, out, err = run(
        ["simulate", str(path), "--periods", "2", "--x0", "x=1", "--out", str(tmp_path), "--json"], capsys
    )
    assert code == 0, err
    summary = json.loads(out)
    # x = cos t never reaches 2: no transition; the final state is the exact one to the tolerance.
    assert summary["transitions"] == 0
    assert math.isclose(summary["final_state"]["x"], 1.0, abs_tol=1e-6)


@pytest.mark.slow
def test_console_script_json_on_paper_defaults(tmp_path):
    # The acceptance command, run as a user would (the console script when installed).
    exe = [shutil.which("hybrid")] if shutil.which("hybrid") else [sys.executable, "-m", "hybrid.cli"]
    proc = subprocess.run(
        [*exe, "simulate", "absorber", "--omega", "0.854", "--periods", "200", "--json"],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert proc.returncode == 0, proc.stderr
    summary = json.loads(proc.stdout)
    assert summary["success"]
    assert summary["transitions"] > 100
    assert summary["final_mode"] in ("stick", "slip+", "slip-")
    assert summary["input_work"] > summary["dissipated_energy"] > 0
    # default rtol 1e-8 over 200 periods: measured 1.6e-5 relative (global error of the quadratures)
    assert abs(summary["energy_balance_residual"]) <= 1e-4 * summary["input_work"]


def test_module_entry_point(tmp_path):
    proc = subprocess.run(
        [sys.executable, "-m", "hybrid.cli", "models"],
        capture_output=True,
        text=True,
        cwd=tmp_path,
        timeout=120,
    )
    assert proc.returncode == 0
    assert "absorber" in proc.stdout
    assert "isolator" in proc.stdout
    assert "coulomb" in proc.stdout
    # one column of titles, however long the names (belt_stribeck, coulomb_sign)
    lines = proc.stdout.splitlines()
    starts = {len(ln) - len(ln.split(None, 1)[1]) for ln in lines}
    assert len(lines) >= 8, proc.stdout
    assert len(starts) == 1, proc.stdout
