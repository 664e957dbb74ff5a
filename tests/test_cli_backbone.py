"""`hybrid backbone` (issue 31): EPMC backbones from the command line, files and errors."""

import csv
import json
import sys
from pathlib import Path

import pytest

from hybrid.cli import main

ROOT = Path(__file__).resolve().parents[1]
JENKINS = str(ROOT / "models" / "jenkins_oscillator.toml")
sys.path.insert(0, str(ROOT / "tests" / "models"))
from jenkins_reference import jenkins_epmc  # noqa: E402  (the independent EPMC of the test suite)


def run(argv, capsys):
    code = main(argv)
    out = capsys.readouterr()
    return code, out.out, out.err


@pytest.mark.slow
def test_backbone_writes_json_csv_and_figure(tmp_path, capsys):
    argv = ["backbone", JENKINS, "--coordinate", "x", "--amplitudes", "0.2", "1.0"]
    code, out, err = run(argv + ["--integrator", "exact", "--out", str(tmp_path), "--json"], capsys)
    assert code == 0, err
    data = json.loads(out)
    assert json.loads((tmp_path / "backbone.json").read_text())["points"] == data["points"]
    assert [p["amplitude"] for p in data["points"]] == pytest.approx([0.2, 1.0], rel=1e-12)
    for p in data["points"]:
        w, xi, _ = jenkins_epmc(p["amplitude"])
        assert p["omega"] == pytest.approx(w, rel=1e-9)
        assert p["xi"] == pytest.approx(xi, rel=1e-9)
        assert p["damping_ratio"] == pytest.approx(xi / (2 * w), rel=1e-9)
        assert p["dissipated"] == pytest.approx(4 * 0.1 * (p["amplitude"] - 0.1), rel=1e-9)
    rows = list(csv.DictReader((tmp_path / "backbone.csv").open()))
    assert [float(r["omega"]) for r in rows] == pytest.approx([p["omega"] for p in data["points"]], rel=1e-15)
    assert (tmp_path / "backbone.png").stat().st_size > 10_000
    assert data["references"]["linear: all contacts sliding"] == pytest.approx(1.0, rel=1e-12)
    first = next(e for e in data["events"] if e["kind"] == "first-switch")
    assert first["interval"][0] <= 0.1 <= first["interval"][1]


@pytest.mark.parametrize(
    "argv, message",
    [
        (["--coordinate", "nope", "--amplitudes", "1"], "not a variable"),
        (["--coordinate", "x", "--amplitude-range", "2", "1"], "LO < HI"),
        (["--coordinate", "x", "--amplitudes", "1", "--mode", "0"], "--mode"),
    ],
)
def test_backbone_bad_input(tmp_path, capsys, argv, message):
    code, _, err = run(["backbone", JENKINS, *argv, "--out", str(tmp_path)], capsys)
    assert code == 2 and message in err and "Traceback" not in err


def test_backbone_negative_amplitude_is_a_usage_error(tmp_path, capsys):
    with pytest.raises(SystemExit) as exc:
        main(["backbone", JENKINS, "--coordinate", "x", "--amplitudes", "-1", "--out", str(tmp_path)])
    assert exc.value.code == 2
    assert "argument --amplitudes" in capsys.readouterr().err


def test_backbone_of_a_forced_built_in_model_says_what_to_give(tmp_path, capsys):
    code, _, err = run(
        ["backbone", "iwan", "--coordinate", "x", "--amplitudes", "1", "--out", str(tmp_path)], capsys
    )
    assert code == 2
    assert "models/iwan.toml" in err and "Traceback" not in err
