"""Sphinx configuration of hybrid's documentation (``python -m sphinx -W -b html docs out/docs``)."""

from __future__ import annotations

import os
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))  # the checkout's `hybrid` when it is not installed
os.environ.setdefault("MPLBACKEND", "Agg")

from hybrid import __version__  # noqa: E402

project = "hybrid"
author = "the authors of hybrid"
copyright = "2026, " + author
release = version = __version__

extensions = [
    "myst_parser",  # the pages are Markdown (MyST)
    "sphinx.ext.autodoc",
    "numpydoc",  # the docstrings are numpydoc
    "sphinx.ext.mathjax",
    "sphinx.ext.viewcode",
]
source_suffix = {".md": "markdown", ".rst": "restructuredtext"}
root_doc = "index"
exclude_patterns = [
    "_build",
    "selfexcited/**",
    "sweeps/**",
    "reproduction/*.json",
    "bifurcation/*.json",
    "networks/*.json",
]
myst_enable_extensions = ["dollarmath", "amsmath", "colon_fence", "deflist"]
myst_heading_anchors = 3
myst_heading_slug_func = "github"  # the anchors GitHub gives (the reproduction report links to them)

autodoc_member_order = "bysource"
autodoc_typehints = "none"  # numpydoc's Parameters sections give the types
numpydoc_show_class_members = False
numpydoc_class_members_toctree = False
numpydoc_xref_param_type = False


html_theme = "alabaster"
html_title = f"hybrid {version}"
html_static_path: list[str] = []
