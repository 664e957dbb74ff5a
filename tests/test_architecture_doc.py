"""``docs/architecture.md`` says what the code is (issue 29, item 7): its table lists every module of
every subpackage and no other, its diagram names every built-in subcommand, and its size rule
holds (a module over the limit is listed there with its reason)."""

from __future__ import annotations

import argparse
import re
from pathlib import Path

from hybrid.cli.main import build_parser

ROOT = Path(__file__).resolve().parents[1]
DOC = (ROOT / "docs" / "architecture.md").read_text()


def _table() -> dict[str, set[str]]:
    """subpackage -> the modules the doc's table lists for it."""
    out = {}
    for line in DOC.splitlines():
        m = re.match(r"\| `(\w+)` \| (.+?) \|", line)
        if m:
            out[m.group(1)] = set(re.findall(r"`(\w+)`", m.group(2)))
    return out


def _modules(sub: str) -> set[str]:
    return {p.stem for p in (ROOT / "hybrid" / sub).glob("*.py") if p.stem not in ("__init__", "__main__")}


def test_the_table_lists_every_module_and_no_other():
    table = _table()
    subs = {p.name for p in (ROOT / "hybrid").iterdir() if (p / "__init__.py").exists()}
    assert set(table) == subs
    wrong = {s: (sorted(_modules(s) - table[s]), sorted(table[s] - _modules(s))) for s in subs}
    assert {s: w for s, w in wrong.items() if w != ([], [])} == {}


def test_the_diagram_names_every_built_in_subcommand():
    line = next(x for x in DOC.splitlines() if x.strip().startswith("cli") and "hybrid" in x)
    named = set(re.findall(r"\w+", line.split("hybrid", 1)[1]))
    action = next(a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction))
    installed = {"reproduce"}  # added by the installed models package (an entry point), not built in
    assert named == set(action.choices) - installed


def test_the_size_rule_holds():
    m = re.search(r"No module is over (\d+) lines(?: but ([^:]+))?[.:]", DOC)
    assert m, "the size rule is not stated"
    limit = int(m.group(1))
    excepted = set(re.findall(r"`([\w/]+\.py)`", m.group(2) or ""))
    over = {
        str(p.relative_to(ROOT / "hybrid"))
        for p in (ROOT / "hybrid").rglob("*.py")
        if len(p.read_text().splitlines()) > limit
    }
    assert over == excepted
