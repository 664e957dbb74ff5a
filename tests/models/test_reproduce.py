"""`hybrid reproduce` (issue 9, part 4): bad input, and the files of one fast figure."""

import csv
import json

import pytest

from hybrid.cli import main
from hybrid_models.figures import FIGURES
from hybrid_models.jobs import run_job


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--figure", "99"], "unknown figure '99'"),
        (["--figure", "5", "--workers", "0"], "`--workers` must be an integer >= 1, got '0'"),
        (["--figure", "5", "--workers", "two"], "`--workers` must be an integer >= 1, got 'two'"),
    ],
)
def test_bad_input_is_one_line_with_exit_2(argv, message, tmp_path, capsys):
    code = main(["reproduce", "--out", str(tmp_path / "o"), *argv])
    out = capsys.readouterr()
    assert code == 2
    assert out.out == ""
    assert out.err.count("\n") == 1
    assert message in out.err
    assert "Traceback" not in out.err
    assert not list((tmp_path / "o").glob("*.png"))


def test_unwritable_out_is_refused(tmp_path, capsys):
    blocker = tmp_path / "file"
    blocker.write_text("x")
    code = main(["reproduce", "--figure", "5", "--out", str(blocker / "sub")])
    out = capsys.readouterr()
    assert code == 2
    assert out.out == ""
    assert out.err.count("\n") == 1
    assert "Not a directory (ENOTDIR): a part of the path is a file" in out.err


def _cell(text):
    if text in ("True", "False"):
        return text == "True"
    try:
        return float(text)
    except ValueError:
        return text


@pytest.mark.slow
def test_figure_5_writes_png_csv_json_from_the_same_data(tmp_path, capsys):
    out = tmp_path / "repro"
    code = main(["reproduce", "--figure", "5", "--out", str(out), "--workers", "1", "--no-progress"])
    std = capsys.readouterr()
    assert code == 0, std.err
    assert std.out.startswith("Fig. 5: Confirmed: 2 stick and 2 slip phases")
    for ext in ("png", "csv", "json"):
        assert (out / f"fig5.{ext}").stat().st_size > 0
    assert (tmp_path / "repro.md").read_text().count("fig5.png") == 1
    info = json.loads((out / "fig5.json").read_text())
    assert info["integrator"] == "exact"
    assert info["ida_check"]["max_relative_difference"] < 1e-6
    # the CSV holds exactly the rows of the figure function, computed again here
    spec = FIGURES["5"]
    jobs = spec.jobs("exact")
    results = {j: run_job(j) for j in jobs}
    results.update({j: run_job(j) for j in spec.checks(results, "exact")})
    fig = spec.build(results, "exact")
    with (out / "fig5.csv").open() as fh:
        rows = [{k: _cell(v) for k, v in r.items()} for r in csv.DictReader(fh)]
    assert rows == fig.rows
    assert info["numbers"]["stick_phases"] == fig.numbers["stick_phases"] == 2
