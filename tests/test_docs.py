"""The documentation (issue 24): Sphinx builds it from docs/ with warnings as errors, every theory
page is in it, and the API reference covers hybrid's public names."""

import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

import hybrid

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"


def test_the_api_reference_documents_every_public_name():
    text = "\n".join(p.read_text() for p in (DOCS / "api").glob("*.md"))
    documented = set(re.findall(r"^\.\. auto(?:class|function|data):: (?:hybrid\.)?(\w+)", text, re.M))
    assert set(hybrid.__all__) <= documented, sorted(set(hybrid.__all__) - documented)


def test_every_page_is_in_a_toctree_and_the_theory_is_linked():
    index = (DOCS / "index.md").read_text()
    for page in ("theory", "averaging", "orbits", "filippov", "selfexcited", "tutorial", "guide", "results"):
        assert re.search(rf"^{page}$", index, re.M), page


@pytest.mark.slow
def test_the_docs_build_with_warnings_as_errors(tmp_path):
    pytest.importorskip("sphinx", reason="the `docs` extra (CI installs it: .ci/run)")
    pytest.importorskip("myst_parser", reason="the `docs` extra")
    pytest.importorskip("numpydoc", reason="the `docs` extra")
    out = tmp_path / "html"
    run = subprocess.run(
        [sys.executable, "-m", "sphinx", "-W", "--keep-going", "-q", "-b", "html", str(DOCS), str(out)],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert run.returncode == 0, run.stderr[-5000:]
    assert run.stderr.strip() == ""
    for page in ("index", "tutorial", "guide", "results", "theory", "api/continuation", "examples/index"):
        assert (out / f"{page}.html").stat().st_size > 0, page
    # the API pages hold the docstrings, not just the headings
    assert "Floquet multipliers" in (out / "api" / "orbits.html").read_text()
    shutil.rmtree(out)
