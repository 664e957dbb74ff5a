"""The examples gallery (issue 24): every script in examples/ runs as a user would run it, from a
folder of their own, and writes what it says; every script is on the gallery page."""

import ast
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SCRIPTS = sorted((ROOT / "examples").glob("*.py"))


def test_every_example_is_in_the_gallery():
    page = (ROOT / "docs" / "examples" / "index.md").read_text()
    assert len(SCRIPTS) >= 5
    for s in SCRIPTS:
        assert f"../../examples/{s.name}" in page, s.name
        assert ast.get_docstring(ast.parse(s.read_text())), f"{s.name} has no docstring for the gallery"


@pytest.mark.slow
@pytest.mark.parametrize("script", SCRIPTS, ids=[s.stem for s in SCRIPTS])
def test_example_runs_from_a_folder_of_its_own(script, tmp_path):
    env = {**os.environ, "MPLBACKEND": "Agg"}
    run = subprocess.run(
        [sys.executable, str(script)], cwd=tmp_path, capture_output=True, text=True, timeout=300, env=env
    )
    assert run.returncode == 0, run.stderr[-3000:]
    assert run.stdout.strip(), "an example prints what it found"
    assert "Traceback" not in run.stderr
    for line in run.stdout.splitlines():
        if line.startswith("wrote "):
            assert (tmp_path / line.split(" ", 1)[1]).stat().st_size > 0, line
