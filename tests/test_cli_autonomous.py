"""Command line for autonomous models (issue 11): `hybrid orbit` with an unknown period, `hybrid cont`."""

import csv
import json
import math

import pytest

from hybrid.cli import main


def run(argv, capsys):
    code = main(argv)
    out = capsys.readouterr()
    return code, out.out, out.err


def test_orbit_of_an_autonomous_model(tmp_path, capsys):
    code, out, _ = run(["orbit", "belt", "--set", "v_b=0.3", "--out", str(tmp_path), "--json"], capsys)
    assert code == 0
    data = json.loads(out)
    d, vb = 0.5, 0.3  # the standard preset: m = k = 1, Fs = 1, Fk = 0.5
    T = 2 * d / vb + math.pi + 2 * math.atan(vb / d)
    assert abs(data["period"] / T - 1) <= 1e-7
    assert "trivial" in data["multiplier_kinds"]
    assert data["converged"]
    assert (tmp_path / "orbit.png").stat().st_size > 0
    code, out, _ = run(["orbit", "belt", "--set", "v_b=0.3", "--out", str(tmp_path), "--no-plot"], capsys)
    assert "the period is an unknown" in out


@pytest.mark.slow
def test_cont_finds_the_hopf_point_and_its_branch(tmp_path, capsys):
    code, out, err = run(
        ["cont", "belt_stribeck", "--param", "v_b", "--range", "1.0", "1.3", "--out", str(tmp_path)], capsys
    )
    assert code == 0, err
    v_star = 0.5 * math.log(0.5 / (0.5 * 0.1))  # vs ln((Fs - Fk)/(vs (c + cf))), the standard preset
    summary = json.loads((tmp_path / "cont.json").read_text())
    (hopf,) = [c for e in summary["equilibria"] for c in e["special"]]
    assert hopf["kind"] == "hopf"
    assert abs(hopf["value"] - v_star) <= 1e-10
    assert hopf["status"] == "located"
    assert hopf["interval"][0] <= hopf["value"] <= hopf["interval"][1]
    assert abs(hopf["frequency"] - 1.0) <= 1e-10  # sqrt(k/m)
    (branch,) = summary["orbit_branches"]
    assert branch["start"] == "hopf"
    assert branch["status"] == "completed"
    assert branch["reason"] == ""
    assert branch["message"].startswith("left the range at v_b=")
    assert f"hopf at v_b = {hopf['value']:.12g}" in out
    rows = list(csv.DictReader(open(tmp_path / "cont.csv")))
    orbits = [r for r in rows if r["kind"] == "hopf"]
    assert orbits
    assert all(r["stability"] == "unstable" for r in orbits)
    assert all(1.0 <= float(r["parameter"]) for r in orbits)
    assert (tmp_path / "cont.png").stat().st_size > 0


def test_cont_refuses_bad_input(tmp_path, capsys):
    code, _, err = run(
        ["cont", "belt", "--param", "nope", "--range", "0", "1", "--out", str(tmp_path)], capsys
    )
    assert code == 2, err
    assert "no parameter `nope`" in err
    code, _, err = run(
        ["cont", "belt", "--param", "v_b", "--range", "1", "1", "--out", str(tmp_path)], capsys
    )
    assert code == 2, err
    assert "--range" in err
    code, _, err = run(
        ["cont", "belt", "--param", "v_b", "--range", "-1", "1", "--out", str(tmp_path)], capsys
    )
    assert code == 2, err
    assert "v_b" in err
    code, _, err = run(
        ["cont", "coulomb", "--param", "F", "--range", "0", "1", "--out", str(tmp_path)], capsys
    )
    assert code == 2, err
    assert "periodically forced" in err


def test_frc_of_an_autonomous_model_points_to_cont(tmp_path, capsys):
    code, out, err = run(["frc", "belt", "--out", str(tmp_path)], capsys)
    assert code == 2, err
    assert out == ""
    assert "declares no forcing `period`" in err
    assert "hybrid cont belt --param NAME --range A B" in err
    assert "Traceback" not in err


def test_simulate_an_autonomous_model_on_n_samples_matches_every_step(tmp_path, capsys):
    # issue 34: `--samples N` puts N evenly spaced samples on a model without a period (IDA goes
    # from one to the next inside SUNDIALS); the run is the same run: the same switches, the same
    # final state to the tolerances
    argv = ["simulate", "belt_stribeck", "--t-end", "60", "--no-plot"]
    code, _, err = run([*argv, "--samples", "121", "--out", str(tmp_path / "n")], capsys)
    assert code == 0, err
    code, _, err = run([*argv, "--out", str(tmp_path / "all")], capsys)
    assert code == 0, err

    def rows(name):
        with (tmp_path / name / "trajectory.csv").open() as f:
            return list(csv.DictReader(f))

    def switches(name):
        with (tmp_path / name / "events.csv").open() as f:
            return [float(r["t [s]"]) for r in csv.DictReader(f)]

    sampled, every = rows("n"), rows("all")
    grid = [float(r["t [s]"]) for r in sampled if float(r["t [s]"]) not in switches("n")]
    assert grid == pytest.approx([0.5 * k for k in range(121)], abs=1e-12)
    assert len(every) > 2 * len(sampled)  # every internal step is a sample without --samples
    assert switches("n") == pytest.approx(switches("all"), abs=1e-9)
    for v in ("x [m]", "w [m/s]"):
        assert float(sampled[-1][v]) == pytest.approx(float(every[-1][v]), abs=1e-7)


def test_samples_is_refused_for_a_model_with_a_period(tmp_path, capsys):
    code, _, err = run(["simulate", "absorber", "--samples", "10", "--out", str(tmp_path / "o")], capsys)
    assert code == 2
    assert "--samples is for models without a forcing period; model `absorber` has one" in err
