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
    # the structures' matrices beside the model files (issue 32), and the script that writes them
    assert tool["package-data"] == {"hybrid_models": ["*.toml", "data/*.npz", "data/*.py"]}
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


# --- issue 24, item 2: install advice that works, checked against pyproject.toml

INSTALL = re.compile(r"pip install (?:-[-\w]+ )*(['\"]?)([^'\"\s`]+)\1")


def _install_advice():
    """``(file, position, target)`` of every ``pip install TARGET`` the project tells a user."""
    files = [ROOT / "README.md", *(ROOT / "docs").rglob("*.md"), *(ROOT / "docs").rglob("*.rst")]
    files += [p for d in ("hybrid", "models", "examples", "benchmarks") for p in (ROOT / d).rglob("*.py")]
    files += [ROOT / ".ci" / "run"]
    out = []
    for f in files:
        text = f.read_text()
        out += [(f.relative_to(ROOT), m.start(), m.group(2), text) for m in INSTALL.finditer(text)]
    return out


def test_every_install_command_names_this_project_or_a_declared_requirement():
    project = PYPROJECT["project"]
    extras = project["optional-dependencies"]
    requirements = set(project["dependencies"]) | {r for reqs in extras.values() for r in reqs}
    advice = _install_advice()
    assert len(advice) >= 5
    for where, pos, target, text in advice:
        name, _, rest = target.partition("[")
        wanted = set(rest.rstrip("]").split(",")) - {""}
        if name == ".":  # from a checkout
            assert wanted <= set(extras), (where, target)
        elif name == project["name"]:  # from the index: only where the text says it is not there yet
            assert wanted <= set(extras), (where, target)
            assert "not published" in text[max(0, pos - 300) : pos], (where, target)
        else:
            assert target in requirements, (where, target, "not a requirement declared in pyproject.toml")


def test_the_licence_is_the_one_pyproject_names():
    assert PYPROJECT["project"]["license"] == {"text": "BSD-3-Clause"}
    text = (ROOT / "LICENSE").read_text()
    assert text.startswith("BSD 3-Clause License")
    assert "Neither the name of the copyright holder" in text
