"""``models/`` (the package ``hybrid_models``) uses only the public API of ``hybrid`` (issue 29).

Read from the source with :mod:`ast` (nothing is imported). The test fails on

* an import of a private name from ``hybrid`` (``from hybrid.x import _y``), or of a module whose
  path has a private component (``hybrid.x._y``);
* any import of the command line's internals, :mod:`hybrid.cli` (what a subcommand of an installed
  package shares with the built-in ones is :mod:`hybrid.core.commands`);
* ``name._x`` on a name bound by an import from ``hybrid`` (``hybrid._x``, ``loader._y``, also
  down a chain: ``hybrid.model.loader._y``; and ``hybrid.cli`` reached that way);
* ``obj._x`` on any other object where ``_x`` is a private name defined by a module of ``hybrid``
  and by none of ``models/`` (a heuristic on names, as in tests/test_layers.py: the object's type is
  not known; e.g. a compiled mode's private function reached on a mode made by ``hybrid``).
"""

from __future__ import annotations

import ast
from pathlib import Path

from private_names import defined_private_names, is_private, private_attribute_uses

REPO = Path(__file__).resolve().parents[1]


def _hybrid_module(name: str | None) -> bool:
    return name is not None and (name == "hybrid" or name.startswith("hybrid."))


def _refused_module(module: str) -> str | None:
    """Why an import of ``module`` (a module of ``hybrid``) is refused, or None."""
    parts = module.split(".")
    if len(parts) > 1 and parts[1] == "cli":
        return "imports the command line's internals"
    private = [p for p in parts if is_private(p)]
    if private:
        return f"imports the private module {private[0]}"
    return None


def private_uses(sources: dict[str, str], hybrid_private: set[str]) -> list[str]:
    """What the module docstring refuses, in ``sources`` (module -> source of ``models/``), with
    ``hybrid_private`` the private names the modules of ``hybrid`` define."""
    trees = {m: ast.parse(src, m) for m, src in sources.items()}
    own = set().union(*map(defined_private_names, trees.values()))
    bad = []
    for m, tree in trees.items():
        bound: set[str] = set()  # names bound to a module or an object of hybrid
        for node in ast.walk(tree):
            if isinstance(node, ast.Import):
                for a in node.names:
                    if _hybrid_module(a.name):
                        why = _refused_module(a.name)
                        if why:
                            bad.append(f"{m}:{node.lineno} {why}: import {a.name}")
                        bound.add(a.asname or a.name.split(".")[0])
            elif isinstance(node, ast.ImportFrom) and node.level == 0 and _hybrid_module(node.module):
                why = _refused_module(node.module)
                if why:
                    bad.append(f"{m}:{node.lineno} {why}: from {node.module}")
                for a in node.names:
                    if is_private(a.name):
                        bad.append(f"{m}:{node.lineno} imports the private name {a.name} from {node.module}")
                    elif (r := _refused_module(f"{node.module}.{a.name}")) and not why:
                        bad.append(f"{m}:{node.lineno} {r}: from {node.module} import {a.name}")
                    bound.add(a.asname or a.name)
        for node in ast.walk(tree):
            # hybrid.cli.x down a chain of attributes from a bound name
            if isinstance(node, ast.Attribute) and node.attr == "cli":
                root = node.value
                if isinstance(root, ast.Name) and root.id == "hybrid" and "hybrid" in bound:
                    bad.append(f"{m}:{node.lineno} reaches the command line's internals: hybrid.cli")
        for line, obj, name in private_attribute_uses(tree):
            root = obj
            while isinstance(root, ast.Attribute):
                root = root.value
            if isinstance(root, ast.Name) and root.id in bound:
                bad.append(f"{m}:{line} reaches {ast.unparse(obj)}.{name}, private to hybrid")
            elif name in hybrid_private and name not in own:
                bad.append(f"{m}:{line} reaches {ast.unparse(obj)}.{name}, a private name of hybrid")
    return sorted(bad)


def _hybrid_private() -> set[str]:
    trees = (ast.parse(p.read_text(), str(p)) for p in sorted((REPO / "hybrid").rglob("*.py")))
    return set().union(*map(defined_private_names, trees))


def test_the_check_flags_private_and_cli_uses():
    # issue 29: models/ used private loader helpers and hybrid.cli.common
    sources = {
        "hybrid_models.a": (
            "import hybrid\n"
            "import hybrid.cli.common\n"  # 2: the command line
            "from hybrid.cli.common import info\n"  # 3: the command line
            "from hybrid import cli\n"  # 4: the command line
            "from hybrid.model.loader import _key, shown_key\n"  # 5: a private name
            "from hybrid.model._hidden import f\n"  # 6: a private module
            "from hybrid.model import loader\n"
            "from .b import _local\n"  # models' own: allowed
            "def g(mode, tr, fig):\n"
            "    loader._short(1)\n"  # 10: on a name bound to hybrid
            "    hybrid.model.loader._key(1)\n"  # 11: down a chain
            "    hybrid.cli.main\n"  # 12: the command line down a chain
            "    mode._res_fn\n"  # 13: a private name of hybrid on another object
            "    mode._mine\n"  # defined in models/ too: allowed
            "    tr._replace(t=0)\n"  # the namedtuple API
            "    fig._suptitle\n"  # nobody's in hybrid (matplotlib's): not this test's business
            "    return _local, shown_key, f, info\n"
        ),
        "hybrid_models.b": "_local = 1\nclass B:\n    def _mine(self):\n        return self._x\n",
    }
    bad = private_uses(sources, {"_res_fn", "_key", "_short", "_mine"})
    assert bad == sorted(
        [
            "hybrid_models.a:2 imports the command line's internals: import hybrid.cli.common",
            "hybrid_models.a:3 imports the command line's internals: from hybrid.cli.common",
            "hybrid_models.a:4 imports the command line's internals: from hybrid import cli",
            "hybrid_models.a:5 imports the private name _key from hybrid.model.loader",
            "hybrid_models.a:6 imports the private module _hidden: from hybrid.model._hidden",
            "hybrid_models.a:10 reaches loader._short, private to hybrid",
            "hybrid_models.a:11 reaches hybrid.model.loader._key, private to hybrid",
            "hybrid_models.a:12 reaches the command line's internals: hybrid.cli",
            "hybrid_models.a:13 reaches mode._res_fn, a private name of hybrid",
        ]
    )


def test_hybrid_defines_the_private_names_the_check_looks_for():
    # the heuristic needs hybrid's private names: a few that exist today (a reach is unseen without them)
    assert {"_check_keys", "_gzz_inv", "_Summary"} <= _hybrid_private()


def test_models_use_only_the_public_api_of_hybrid():
    sources = {f"hybrid_models.{p.stem}": p.read_text() for p in sorted((REPO / "models").glob("*.py"))}
    assert {"hybrid_models.reproduce", "hybrid_models.network_read"} <= sources.keys()  # the folder found
    assert private_uses(sources, _hybrid_private()) == []
