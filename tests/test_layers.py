"""The import graph of ``hybrid/`` (issue 21): subpackages in layers, dependencies one way only.

Read from the source with :mod:`ast` (nothing is imported): every ``import`` of a module of
``hybrid`` is an edge. The test fails on

* a cycle among modules (imports under ``if TYPE_CHECKING:``, for annotations only, are no
  dependency at run time and are left out of this check; they still point one way);
* an import of a subpackage to the right of the importer in :data:`LAYERS` (a lower layer
  importing a higher one);
* a private name (``_x``) imported from another subpackage;
* an import of a ``hybrid`` module inside a function (the usual way to dodge a cycle), except
  the figures of :mod:`hybrid.plot` imported by a subcommand of :mod:`hybrid.cli` when it draws
  one (:data:`LAZY`: matplotlib costs a third of a second of every command's start-up);
* a private attribute of another subpackage reached on an object, ``obj._x`` (issue 29). Without
  types this is a heuristic on names: each subpackage's private names are collected (``def _x``,
  ``class _X``, ``self._x = ...``, ``_X = ...`` at module or class level:
  :func:`private_names.defined_private_names`), and ``obj._x`` in a module is flagged when ``_x``
  is defined by another subpackage and not by the module's own. ``self._x`` and ``cls._x``,
  dunders and the namedtuple API (``_replace``, ``_asdict``, ``_fields``, ...) are allowed; so is a
  private name that no module of ``hybrid`` defines (another library's, e.g. ``os._exit``). A name
  that both subpackages define passes unseen: the check finds a reach across subpackages, it cannot
  prove there is none.
"""

from __future__ import annotations

import ast
from pathlib import Path

from private_names import defined_private_names, module_name, private_attribute_uses, resolve_import

ROOT = Path(__file__).resolve().parents[1] / "hybrid"

#: Subpackages from the bottom layer up; each may import only those before it (and itself).
LAYERS = ("core", "model", "integrators", "engine", "orbits", "continuation", "studies", "plot", "cli")


#: Imports inside functions allowed, as (importer prefix, imported prefix): loaded when needed.
LAZY = (("hybrid.cli.", "hybrid.plot."),)


def _module_name(path: Path) -> str:
    return module_name(path, ROOT.parent)


_resolve = resolve_import


#: module -> the lines of its imports for annotations only (under ``if TYPE_CHECKING:``).
TYPING: dict[str, set[int]] = {}


def _graph() -> dict[str, list[tuple[str, tuple[str, ...], bool, int]]]:
    """module -> [(imported module, names, inside a function, line)]."""
    graph: dict[str, list] = {}
    modules = {_module_name(p): p for p in ROOT.rglob("*.py")}
    for name, path in modules.items():
        tree = ast.parse(path.read_text(), str(path))
        edges = []
        func_lines: set[int] = set()
        typing_lines: set[int] = set()
        for node in ast.walk(tree):
            if isinstance(node, ast.If) and ast.unparse(node.test) in (
                "TYPE_CHECKING",
                "typing.TYPE_CHECKING",
            ):
                for inner in ast.walk(node):
                    if isinstance(inner, ast.Import | ast.ImportFrom):
                        typing_lines.add(inner.lineno)
        TYPING[name] = typing_lines
        for node in ast.walk(tree):
            if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
                for inner in ast.walk(node):
                    if isinstance(inner, ast.Import | ast.ImportFrom):
                        func_lines.add(inner.lineno)
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom):
                target = _resolve(name, node, path.name == "__init__.py")
                if not target.startswith("hybrid"):
                    continue
                names = tuple(a.name for a in node.names)
                # "from . import x" / "from .pkg import mod": the imported names may be modules
                subs = [f"{target}.{n}" for n in names if f"{target}.{n}" in modules]
                for t in subs or [target]:
                    edges.append((t, names, node.lineno in func_lines, node.lineno))
            elif isinstance(node, ast.Import):
                for a in node.names:
                    if a.name.startswith("hybrid"):
                        edges.append((a.name, (), node.lineno in func_lines, node.lineno))
        graph[name] = edges
    return graph


def _layer(module: str) -> int | None:
    parts = module.split(".")
    if len(parts) < 2 or parts[1] not in LAYERS:
        return None  # the package root: it re-exports the public API of every layer
    return LAYERS.index(parts[1])


def test_every_subpackage_is_in_a_layer():
    found = {p.name for p in ROOT.iterdir() if p.is_dir() and (p / "__init__.py").exists()}
    assert found == set(LAYERS)


def test_no_module_left_at_the_top_level():
    top = sorted(p.name for p in ROOT.glob("*.py"))
    assert top == ["__init__.py"]


def test_no_import_cycle():
    graph = _graph()
    state: dict[str, int] = {}
    cycles: list[list[str]] = []

    def visit(m: str, path: list[str]) -> None:
        state[m] = 1
        path.append(m)
        for t, _, _, line in graph.get(m, []):
            if t not in graph or t == "hybrid" or line in TYPING.get(m, ()):
                continue
            if state.get(t) == 1:
                cycles.append(path[path.index(t) :] + [t])
            elif t not in state:
                visit(t, path)
        path.pop()
        state[m] = 2

    for m in sorted(graph):
        if m not in state:
            visit(m, [])
    assert cycles == []


def test_layers_point_one_way():
    bad = []
    for m, edges in _graph().items():
        lm = _layer(m)
        for t, _, _, line in edges:
            lt = _layer(t)
            if t == "hybrid" and m != "hybrid":
                bad.append(f"{m}:{line} imports the package root")
            elif lm is not None and lt is not None and lt > lm:
                bad.append(f"{m}:{line} -> {t} (layer {LAYERS[lm]} imports {LAYERS[lt]})")
    assert bad == []


def test_no_private_name_across_subpackages():
    bad = []
    for m, edges in _graph().items():
        for t, names, _, line in edges:
            if _layer(t) is None or _layer(m) == _layer(t):
                continue
            private = [n for n in names if n.startswith("_") and not n.startswith("__")]
            if private or t.rsplit(".", 1)[-1].startswith("_"):
                bad.append(f"{m}:{line} imports {', '.join(private) or t} from {t}")
    assert bad == []


def test_no_import_of_hybrid_inside_a_function():
    bad = [
        f"{m}:{line} -> {t}"
        for m, edges in _graph().items()
        for t, _, inner, line in edges
        if inner and not any(m.startswith(a) and t.startswith(b) for a, b in LAZY)
    ]
    assert bad == []


def _by_subpackage() -> dict[str, dict[str, str]]:
    """subpackage (the root: "hybrid") -> {module: source} of ``hybrid/``."""
    out: dict[str, dict[str, str]] = {}
    for path in sorted(ROOT.rglob("*.py")):
        module = _module_name(path)
        parts = module.split(".")
        out.setdefault(parts[1] if len(parts) > 1 else "hybrid", {})[module] = path.read_text()
    return out


def private_attributes_across(sources: dict[str, dict[str, str]]) -> list[str]:
    """``obj._x`` in a module of one subpackage where ``_x`` is private to another (see the module's
    docstring for the heuristic); ``sources``: subpackage -> {module: source}."""
    trees = {sub: {m: ast.parse(src, m) for m, src in mods.items()} for sub, mods in sources.items()}
    defined = {sub: set().union(*map(defined_private_names, mods.values())) for sub, mods in trees.items()}
    bad = []
    for sub, mods in trees.items():
        for m, tree in mods.items():
            for line, obj, name in private_attribute_uses(tree):
                owners = sorted(s for s, names in defined.items() if s != sub and name in names)
                if owners and name not in defined[sub]:
                    bad.append(
                        f"{m}:{line} reaches {ast.unparse(obj)}.{name}, private to {', '.join(owners)}"
                    )
    return bad


def test_the_private_attribute_check_flags_a_reach_across_subpackages():
    # issue 29: an integrator calling a compiled mode's generated function by its private name
    sources = {
        "model": {
            "hybrid.model.m": (
                "_TABLE = {}\n"
                "class Mode:\n"
                "    _kind = 'plain'\n"
                "    def __init__(self):\n"
                "        self._res_fn = len\n"
                "    def _helper(self):\n"
                "        return self._res_fn\n"
            )
        },
        "integrators": {
            "hybrid.integrators.i": (
                "from ..model import m\n"
                "def step(mode, tr):\n"
                "    mode._res_fn(())\n"  # flagged: defined by model only
                "    mode._helper()\n"  # flagged
                "    getattr(mode, '_kind')\n"  # flagged: a class-level name, reached by getattr
                "    m._TABLE.clear()\n"  # flagged: a module-level name
                "    tr._replace(t=0.0)\n"  # the namedtuple API
                "    mode.__class__\n"  # a dunder
                "    mode._own()\n"  # defined here too
                "    import os; os._exit\n"  # defined by no module of hybrid
                "class Solver:\n"
                "    def __init__(self):\n"
                "        self._state = None\n"
                "    def _own(self):\n"
                "        return self._helper\n"  # self: allowed
            )
        },
    }
    bad = private_attributes_across(sources)
    assert bad == [
        "hybrid.integrators.i:3 reaches mode._res_fn, private to model",
        "hybrid.integrators.i:4 reaches mode._helper, private to model",
        "hybrid.integrators.i:5 reaches mode._kind, private to model",
        "hybrid.integrators.i:6 reaches m._TABLE, private to model",
    ]
    # the same reach from the subpackage that defines the name is not flagged
    assert (
        private_attributes_across(
            {"model": {**sources["model"], "hybrid.model.n": "def f(mode):\n    return mode._helper\n"}}
        )
        == []
    )


def test_no_private_attribute_across_subpackages():
    assert private_attributes_across(_by_subpackage()) == []
