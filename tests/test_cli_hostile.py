"""Command line against hostile and careless input (issue 13): no file outside the output folder,
output folders checked before any computation, one-line errors with exit code 2.
"""

import json
from pathlib import Path

import pytest

import hybrid_models
from hybrid.cli import main


def run(argv, capsys):
    code = main(argv)
    out = capsys.readouterr()
    return code, out.out, out.err


def _coulomb_file(tmp_path: Path, name: str) -> Path:
    text = (Path(hybrid_models.__file__).parent / "coulomb.toml").read_text()
    assert 'name = "coulomb"' in text
    path = tmp_path / "evil.toml"
    path.write_text(text.replace('name = "coulomb"', f"name = {name}", 1))
    return path


@pytest.mark.parametrize("name", ['"../../../../escaped"', '"/tmp/hybrid-abs-escape"', '"a/../../b"', '".."'])
def test_model_name_cannot_direct_output_outside_out(name, tmp_path, monkeypatch, capsys):
    work = tmp_path / "work"
    work.mkdir()
    monkeypatch.chdir(work)
    path = _coulomb_file(tmp_path, name)
    before = set(tmp_path.rglob("*"))
    code, out, err = run(["simulate", str(path), "--t-end", "1"], capsys)
    assert code == 2
    assert err.startswith("hybrid: error: evil.toml: model name ")
    assert err.count("\n") == 1
    assert set(tmp_path.rglob("*")) == before  # nothing written anywhere
    assert not Path("/tmp/hybrid-abs-escape").exists()


def test_default_output_folder_is_out_slash_model_name(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    code, _, err = run(["simulate", "coulomb", "--preset", "forced", "--periods", "1", "--no-plot"], capsys)
    assert code == 0, err
    assert sorted(p.name for p in (tmp_path / "out" / "coulomb").iterdir()) == [
        "events.csv",
        "summary.json",
        "trajectory.csv",
    ]


def test_two_files_with_one_model_name_write_to_two_folders(tmp_path, monkeypatch, capsys):
    # Two user files that both declare `[model] name = "coulomb"`: each run's results go to a folder
    # named after its file, and neither overwrites the other (nor the built-in's out/coulomb).
    monkeypatch.chdir(tmp_path)
    text = (Path(hybrid_models.__file__).parent / "coulomb.toml").read_text()
    (tmp_path / "a").mkdir()
    first, second = tmp_path / "a" / "soft.toml", tmp_path / "stiff.toml"
    first.write_text(text)
    second.write_text(text.replace("k = 1.0\nR = 0.1\nF = 0.5", "k = 4.0\nR = 0.1\nF = 0.5"))
    assert second.read_text() != text
    for path in (first, second):
        code, _, err = run(
            ["simulate", str(path), "--preset", "forced", "--periods", "1", "--no-plot"], capsys
        )
        assert code == 0, err
    out = tmp_path / "out"
    assert sorted(p.name for p in out.iterdir()) == ["soft", "stiff"]
    soft = json.loads((out / "soft" / "summary.json").read_text())
    stiff = json.loads((out / "stiff" / "summary.json").read_text())
    assert soft["model"] == stiff["model"] == "coulomb"
    assert soft["parameters"]["k"] == 1.0
    assert stiff["parameters"]["k"] == 4.0


@pytest.mark.parametrize("stem", ["..", "."])
def test_a_file_stem_that_is_no_folder_inside_out_is_refused(stem, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    text = (Path(hybrid_models.__file__).parent / "coulomb.toml").read_text()
    path = tmp_path / f"{stem}.toml"
    path.write_text(text)
    code, stdout, err = run(["simulate", str(path), "--t-end", "1"], capsys)
    assert code == 2, err
    assert stdout == ""
    assert "does not name a folder inside out/" in err and err.count("\n") == 1, err
    assert not (tmp_path / "out").exists() or not any((tmp_path / "out").iterdir())


@pytest.mark.parametrize(
    "command", [["simulate", "coulomb", "--t-end", "1"], ["orbit", "absorber"], ["frc", "absorber"]]
)
def test_bad_out_is_refused_before_any_computation(command, tmp_path, capsys):
    a_file = tmp_path / "file.txt"
    a_file.write_text("keep me")
    for out, message in (
        (str(a_file), "exists and is not a folder"),
        ("/dev/null", "exists and is not a folder"),
        ("", "`--out` needs a folder path"),
        ("  ", "`--out` needs a folder path"),
        (str(a_file / "sub"), "Not a directory (ENOTDIR): a part of the path is a file"),
    ):
        code, stdout, err = run([*command, "--out", out], capsys)
        assert code == 2, (out, err)
        # one line, and nothing computed first (no announcement of a run, nothing on stdout)
        assert err.startswith("hybrid: error: ") and message in err and err.count("\n") == 1, err
        assert stdout == ""
    assert a_file.read_text() == "keep me"
