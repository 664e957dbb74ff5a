"""Private names (``_x``) in source code, read with :mod:`ast` (nothing imported): which a module
defines and which it reaches on other objects (issue 29). Shared by tests/test_layers.py (across the
subpackages of ``hybrid/``) and tests/test_models_public_api.py (from ``models/`` into ``hybrid``).
"""

from __future__ import annotations

import ast
from pathlib import Path

#: The public API of :func:`collections.namedtuple` (underscored so as not to clash with fields).
NAMEDTUPLE_API = frozenset({"_replace", "_asdict", "_fields", "_make", "_field_defaults"})

#: Objects whose private attributes a class may reach: its own instance and class.
OWN = frozenset({"self", "cls"})

#: Built-ins that reach an attribute named by a string.
_BY_NAME = frozenset({"getattr", "setattr", "hasattr", "delattr"})


def is_private(name: str) -> bool:
    """``_x`` and ``__x`` (name-mangled), not a dunder ``__x__``."""
    return name.startswith("_") and not (name.startswith("__") and name.endswith("__"))


def defined_private_names(tree: ast.Module) -> set[str]:
    """The private names a module defines that other code could reach as an attribute: functions,
    classes and methods (``def _x``, ``class _X``, at any depth), attributes assigned
    (``self._x = ...``, ``obj._x = ...``, ``setattr(obj, "_x", ...)``) and names assigned at module
    or class level (``_X = ...``: ``module._X``, ``Class._X``)."""
    out: set[str] = set()

    def top_level(body: list[ast.stmt]) -> None:
        for st in body:
            if isinstance(st, ast.Assign):
                targets = st.targets
            elif isinstance(st, ast.AnnAssign | ast.AugAssign):
                targets = [st.target]
            else:
                continue
            for t in targets:
                out.update(n.id for n in ast.walk(t) if isinstance(n, ast.Name) and is_private(n.id))

    top_level(tree.body)
    for node in ast.walk(tree):
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef | ast.ClassDef) and is_private(node.name):
            out.add(node.name)
        if isinstance(node, ast.ClassDef):
            top_level(node.body)
        elif isinstance(node, ast.Attribute) and isinstance(node.ctx, ast.Store) and is_private(node.attr):
            out.add(node.attr)
        elif _by_name(node) is not None and node.func.id == "setattr":
            out.add(_by_name(node)[1])
    return out


def _by_name(node: ast.AST) -> tuple[ast.expr, str] | None:
    """``(obj, name)`` of ``getattr(obj, "_x", ...)`` and its kin with a private constant name."""
    if (
        isinstance(node, ast.Call)
        and isinstance(node.func, ast.Name)
        and node.func.id in _BY_NAME
        and len(node.args) >= 2
        and isinstance(node.args[1], ast.Constant)
        and isinstance(node.args[1].value, str)
        and is_private(node.args[1].value)
    ):
        return node.args[0], node.args[1].value
    return None


def private_attribute_uses(tree: ast.Module) -> list[tuple[int, ast.expr, str]]:
    """Every ``obj._x`` (and ``getattr(obj, "_x")``) of a module as ``(line, obj, "_x")``, except on
    ``self`` and ``cls`` and except the namedtuple API (:data:`NAMEDTUPLE_API`); by line."""
    out = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Attribute) and is_private(node.attr):
            obj, name = node.value, node.attr
        elif (hit := _by_name(node)) is not None:
            obj, name = hit
        else:
            continue
        if name in NAMEDTUPLE_API or (isinstance(obj, ast.Name) and obj.id in OWN):
            continue
        out.append((node.lineno, obj, name))
    return sorted(out, key=lambda use: use[0])


def module_name(path: Path, repo: Path) -> str:
    """The dotted module name of the file ``path`` under the repository root ``repo``."""
    parts = list(path.relative_to(repo).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def resolve_import(module: str, node: ast.ImportFrom, is_package: bool) -> str:
    """The absolute module an ``ImportFrom`` in ``module`` names (relative imports resolved)."""
    if node.level == 0:
        return node.module or ""
    base = module.split(".")
    if not is_package:
        base = base[:-1]
    base = base[: len(base) - (node.level - 1)]
    return ".".join(base + ([node.module] if node.module else []))
