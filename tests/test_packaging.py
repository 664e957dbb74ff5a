"""The shipped models install as `hybrid_models` (issue 8, item 6), not as a top-level `models` that
would clash with a user's own package of that name."""

import importlib.util
import re
import subprocess
import sys
import tomllib
from importlib.metadata import entry_points
from pathlib import Path

import hybrid_models

ROOT = Path(__file__).resolve().parents[1]
PYPROJECT = tomllib.loads((ROOT / "pyproject.toml").read_text())


def test_the_models_folder_installs_as_hybrid_models():
    tool = PYPROJECT["tool"]["setuptools"]
    assert "models" not in tool["packages"]
    assert "hybrid_models" in tool["packages"]
    assert tool["package-dir"] == {"hybrid_models": "models"}
    assert tool["package-data"] == {"hybrid_models": ["*.toml"]}
    # the installed package carries every model file of the folder
    shipped = {p.name for p in (ROOT / "models").glob("*.toml")}
    assert shipped
    assert {p.name for p in Path(hybrid_models.__file__).parent.glob("*.toml")} == shipped
    assert hybrid_models.coulomb().name == "coulomb"


def test_entry_points_name_hybrid_models_and_load():
    declared = PYPROJECT["project"]["entry-points"]
    for group, entries in declared.items():
        for name, target in entries.items():
            assert target.split(".")[0].split(":")[0] in ("hybrid", "hybrid_models"), (group, name, target)
        installed = {ep.name: ep for ep in entry_points(group=group)}
        for name, target in entries.items():
            assert installed[name].value == target, (group, name)
            module, _, attr = target.partition(":")
            named = importlib.import_module(module)
            assert installed[name].load() is (getattr(named, attr) if attr else named), (group, name)


def test_no_file_imports_a_top_level_models():
    pattern = re.compile(
        r"^\s*(>>> )?(import models\b|from models\b|import .*, models\b)|[\"'](import|from) models\b", re.M
    )
    offenders = []
    for path in [*ROOT.glob("*.md"), *ROOT.glob("*.toml")] + [
        p for d in ("hybrid", "models", "tests", "benchmarks", "docs") for p in (ROOT / d).rglob("*")
    ]:
        if path.suffix in (".py", ".md", ".toml") and pattern.search(path.read_text()):
            offenders.append(str(path.relative_to(ROOT)))
    assert offenders == []


def test_import_models_outside_the_checkout_is_not_ours(tmp_path):
    # from a folder of the user's (not the checkout, whose `models/` folder is on the path there),
    # `models` is not a package this project installed
    code = "import importlib.util as u; s = u.find_spec('models'); print('none' if s is None else s.origin)"
    out = subprocess.run(
        [sys.executable, "-c", code], cwd=tmp_path, capture_output=True, text=True, check=True
    ).stdout.strip()
    assert out == "none" or not Path(out).resolve().is_relative_to(ROOT), out
    assert importlib.util.find_spec("hybrid_models") is not None
