"""`hybrid reproduce` (issue 9, part 4): bad input, and the files of one fast figure."""

import csv
import json
import os
import subprocess
from pathlib import Path

import pytest

from hybrid.cli import main
from hybrid_models.figures import FIGURES
from hybrid_models.jobs import run_job
from hybrid_models.report import read_notes, regenerate


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


# --- issue 24: a run writes under out/, the committed report is regenerated only on request, and the
# notes written by hand live apart from the generated numbers.

REPO = Path(__file__).resolve().parents[2]
NOTES_PATH = REPO / "docs" / "reproduction_notes.md"


def _git(*argv, cwd):
    return subprocess.run(["git", *argv], cwd=cwd, capture_output=True, text=True, check=True).stdout


@pytest.mark.slow
def test_a_run_from_a_fresh_clone_leaves_git_status_clean(tmp_path, monkeypatch, capsys):
    if not (REPO / ".git").exists():
        pytest.skip("not a git checkout")  # e.g. an unpacked sdist: there is no status to keep clean
    clone = tmp_path / "clone"
    subprocess.run(["git", "clone", "-q", str(REPO), str(clone)], check=True)
    assert _git("status", "--porcelain", cwd=clone) == ""
    committed = (clone / "docs" / "reproduction.md").read_text()
    monkeypatch.chdir(clone)
    code = main(["reproduce", "--figure", "3a", "--workers", "1", "--no-progress"])
    std = capsys.readouterr()
    assert code == 0, std.err
    assert _git("status", "--porcelain", "--ignored=no", cwd=clone) == ""
    assert (clone / "out" / "reproduction" / "fig3a.png").stat().st_size > 0
    assert "fig3a.png" in (clone / "out" / "reproduction.md").read_text()
    assert (clone / "docs" / "reproduction.md").read_text() == committed


def test_the_committed_report_is_its_json_and_the_notes(tmp_path):
    """docs/reproduction.md is exactly what the generator makes of the committed JSON files and the
    notes written by hand: no text lives only in the generated file, where a run would lose it."""
    report = tmp_path / "reproduction.md"
    regenerate(REPO / "docs" / "reproduction", report, NOTES_PATH)
    made = report.read_text()
    for path in ("reproduction_notes.md", "reproduction"):
        made = made.replace(os.path.relpath(REPO / "docs" / path, tmp_path), path)
    assert made == (REPO / "docs" / "reproduction.md").read_text()
    notes = read_notes(NOTES_PATH)
    assert len([k for k in notes if k.startswith("fig ")]) == 17
    for key in ("intro", "design-values", "fig 7"):
        assert notes[key].split("\n")[0] in made


def test_docs_merges_the_notes_and_never_writes_them(tmp_path, monkeypatch, capsys):
    (tmp_path / "docs").mkdir()
    notes = tmp_path / "docs" / "reproduction_notes.md"
    notes.write_text("# notes\n\n## intro\n\nAn intro by hand.\n\n## fig 3a\n\nFour crossings, seen.\n")
    before = notes.stat().st_mtime_ns, notes.read_text()
    monkeypatch.chdir(tmp_path)
    code = main(["reproduce", "--docs", "--figure", "3a", "--workers", "1", "--no-progress"])
    assert code == 0, capsys.readouterr().err
    text = (tmp_path / "docs" / "reproduction.md").read_text()
    assert "An intro by hand." in text
    assert "**Seen on the PNG:** Four crossings, seen." in text
    assert (notes.stat().st_mtime_ns, notes.read_text()) == before
    assert (tmp_path / "docs" / "reproduction" / "fig3a.json").is_file()
    # a second figure later: the report lists both, the first from its JSON
    code = main(["reproduce", "--docs", "--figure", "3b", "--workers", "1", "--no-progress"])
    assert code == 0
    text = (tmp_path / "docs" / "reproduction.md").read_text()
    assert "## Fig. 3a" in text
    assert "## Fig. 3b" in text
    assert "figures 3b; the others are from earlier runs" in text


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--docs"], "run from the checkout's root, where docs/reproduction_notes.md is"),
        (["--docs", "--out", "x"], "give no `--out` or `--report` with it"),
        (["--notes", "missing.md"], "`--notes missing.md`: no such file"),
    ],
)
def test_docs_and_notes_refused_where_they_cannot_work(argv, message, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    code = main(["reproduce", "--figure", "3a", *argv])
    err = capsys.readouterr().err
    assert code == 2
    assert message in err
    assert not (tmp_path / "docs").exists()
