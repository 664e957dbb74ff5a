"""No broad ``except`` that swallows (issue 29, item 3): read from the source with :mod:`ast`.

A handler of a bare ``except:``, ``except Exception`` or ``except BaseException`` (alone, in a
tuple, or through a module-level tuple of exception classes such as ``STEP_FAILURES``, also one
imported from another module of the package) must re-raise: its last statement a bare ``raise``
or a ``raise ... from ...``, and no ``return``, ``break`` or ``continue`` in it that would leave
without raising. Otherwise it must be in :data:`ALLOWED` with its reason: such a catch turns a
programming error (a TypeError, an AttributeError, ...) into "no result" (one of them hid a
TypeError in a merge). The test is checked on synthetic sources first, so that it can fail.
"""

from __future__ import annotations

import ast
from collections import Counter
from pathlib import Path

import pytest
from private_names import module_name, resolve_import

REPO = Path(__file__).resolve().parents[1]
PACKAGES = ("hybrid", "models")
BROAD = frozenset({"Exception", "BaseException"})

#: The broad catches that swallow on purpose: (file, function, reason), one row per handler.
ALLOWED = (
    (
        "hybrid/studies/sweep.py",
        "run_point",
        "a sweep point's boundary: any failure of the user's point is recorded as its result "
        "(status failed, reason exception, type, message and line) and the sweep goes on",
    ),
    (
        "hybrid/core/workers.py",
        "run_calls",
        "an executor's failure to return a call (a dead worker, Dask's KilledWorker, a cancelled "
        "future: no common base) is handed to the caller's on_error (a sweep records it in "
        "SweepResult.lost with its type; a frequency response raises it as a WorkerError)",
    ),
    (
        "hybrid/core/workers.py",
        "run_calls",
        "withdrawing the futures not started, in a `finally` that may run while another exception "
        "propagates: a Dask client already closed raises ClosedClientError (an Exception only)",
    ),
    (
        "hybrid/cli/sweep.py",
        "_stop",
        "closing the Dask client on the way out, also while another exception propagates "
        "(the caller re-raises it): the sweep's outcome is decided, a failed close is moot",
    ),
    (
        "hybrid/cli/frc.py",
        "frc_overlays",
        "a user callback's boundary: a model package's overlay function (any code) that fails is "
        "reported on stderr with its type and message, and the figure drawn without it",
    ),
)


def _module_name(path: Path) -> str:
    return module_name(path, REPO)


_resolve = resolve_import


class _Module:
    """A parsed module: its tree, its module-level tuples (name -> elements) and its imports of
    names (name -> (module, name))."""

    def __init__(self, name: str, source: str, is_package: bool = False):
        self.name = name
        self.tree = ast.parse(source)
        self.tuples: dict[str, list[ast.expr]] = {}
        self.imports: dict[str, tuple[str, str]] = {}
        for node in self.tree.body:
            if isinstance(node, ast.Assign) and isinstance(node.value, ast.Tuple):
                for target in node.targets:
                    if isinstance(target, ast.Name):
                        self.tuples[target.id] = node.value.elts
            elif isinstance(node, ast.ImportFrom):
                src = _resolve(name, node, is_package)
                for alias in node.names:
                    self.imports[alias.asname or alias.name] = (src, alias.name)


def _names(expr: ast.expr | None, mod: _Module, modules: dict[str, _Module], seen=()) -> set[str]:
    """The class names an ``except`` clause's expression catches ("<bare>" for a bare one),
    module-level tuples expanded (also those imported from ``modules``)."""
    if expr is None:
        return {"<bare>"}
    if isinstance(expr, ast.Tuple):
        return set().union(*(_names(e, mod, modules, seen) for e in expr.elts)) if expr.elts else set()
    if isinstance(expr, ast.Starred):
        return _names(expr.value, mod, modules, seen)
    if isinstance(expr, ast.Attribute):
        return {expr.attr}
    if isinstance(expr, ast.Name):
        key = (mod.name, expr.id)
        if key in seen:
            return {expr.id}
        if expr.id in mod.tuples:
            return set().union(
                *(_names(e, mod, modules, (*seen, key)) for e in mod.tuples[expr.id]), {expr.id}
            )
        if expr.id in mod.imports:
            src, name = mod.imports[expr.id]
            if src in modules:
                return {expr.id} | _names(ast.Name(id=name), modules[src], modules, (*seen, key))
        return {expr.id}
    return set()


def _leaves_early(stmts: list[ast.stmt], in_loop: bool = False) -> bool:
    """Whether ``stmts`` hold a way out of the handler other than its last ``raise``: a
    ``return``, or a ``break``/``continue`` not inside a loop of their own (a nested function's or
    class's statements are not the handler's)."""
    for stmt in stmts:
        if isinstance(stmt, ast.Return):
            return True
        if isinstance(stmt, ast.Break | ast.Continue) and not in_loop:
            return True
        if isinstance(stmt, ast.FunctionDef | ast.AsyncFunctionDef | ast.ClassDef):
            continue
        loop = isinstance(stmt, ast.For | ast.AsyncFor | ast.While)
        blocks = [(getattr(stmt, "body", []), in_loop or loop)]
        blocks += [(getattr(stmt, f, []), in_loop) for f in ("orelse", "finalbody")]
        blocks += [(h.body, in_loop) for h in getattr(stmt, "handlers", [])]
        blocks += [(c.body, in_loop) for c in getattr(stmt, "cases", [])]
        if any(isinstance(b, list) and _leaves_early(b, inside) for b, inside in blocks):
            return True
    return False


def reraises(handler: ast.ExceptHandler) -> bool:
    """Whether the handler ends in a bare ``raise`` or a ``raise ... from ...`` with no way out
    before it."""
    last = handler.body[-1]
    if not (isinstance(last, ast.Raise) and (last.exc is None or last.cause is not None)):
        return False
    return not _leaves_early(handler.body[:-1])


def _enclosing(tree: ast.AST) -> dict[int, str]:
    """``id(handler) -> name of the innermost function holding it`` ("<module>" at top level)."""
    out: dict[int, str] = {}

    def visit(node: ast.AST, func: str) -> None:
        for child in ast.iter_child_nodes(node):
            name = child.name if isinstance(child, ast.FunctionDef | ast.AsyncFunctionDef) else func
            if isinstance(child, ast.ExceptHandler):
                out[id(child)] = func
            visit(child, name)

    visit(tree, "<module>")
    return out


def broad_swallowers(modules: dict[str, _Module], files: dict[str, str]) -> list[tuple[str, str, int, str]]:
    """``(file, function, line, caught)`` of every broad handler that does not re-raise."""
    found = []
    for name, mod in modules.items():
        where = _enclosing(mod.tree)
        for node in ast.walk(mod.tree):
            if not isinstance(node, ast.ExceptHandler):
                continue
            caught = _names(node.type, mod, modules)
            broad = caught & (BROAD | {"<bare>"})
            if broad and not reraises(node):
                found.append((files[name], where[id(node)], node.lineno, ", ".join(sorted(broad))))
    return found


def _package_modules() -> tuple[dict[str, _Module], dict[str, str]]:
    modules, files = {}, {}
    for pkg in PACKAGES:
        for path in sorted((REPO / pkg).rglob("*.py")):
            name = _module_name(path)
            modules[name] = _Module(name, path.read_text(), path.name == "__init__.py")
            files[name] = path.relative_to(REPO).as_posix()
    return modules, files


def _unallowed(found) -> tuple[list, list]:
    """The handlers beyond the allow-list's rows for their (file, function), and the rows that
    match no handler (stale)."""
    budget = Counter((f, fn) for f, fn, _ in ALLOWED)
    have = Counter((f, fn) for f, fn, _, _ in found)
    extra = [x for x in found if have[(x[0], x[1])] > budget[(x[0], x[1])]]
    stale = sorted(k for k in budget if have[k] < budget[k])
    return extra, stale


# ----------------------------------------------------------------------------------------------
# The checker on synthetic sources: it flags what it should and only that.
SYNTHETIC = """
import numpy as np
from .other import IMPORTED
_FAILS = (ArithmeticError, Exception)

def swallow_bare():
    try:
        f()
    except:
        return None

def swallow_exception():
    try:
        f()
    except Exception:
        pass

def swallow_in_tuple():
    try:
        f()
    except (ValueError, BaseException) as exc:
        log(exc)

def swallow_through_constant():
    try:
        f()
    except (KeyError, *_FAILS):
        return 0

def swallow_through_import():
    try:
        f()
    except IMPORTED:
        return 0

def raise_new_without_cause():
    try:
        f()
    except Exception as exc:
        raise RuntimeError(str(exc))

def reraise_conditionally():
    try:
        f()
    except Exception:
        if cond():
            return None
        raise

def reraise_bare():
    try:
        f()
    except BaseException:
        cleanup()
        raise

def reraise_from():
    try:
        f()
    except Exception as exc:
        raise RuntimeError("wrapped") from exc

def reraise_after_a_loop():
    try:
        f()
    except Exception:
        for x in xs:
            if x:
                break
        raise

def narrow():
    try:
        f()
    except (ValueError, np.linalg.LinAlgError):
        return None
"""


def _synthetic() -> tuple[dict[str, _Module], dict[str, str]]:
    modules = {
        "pkg.mod": _Module("pkg.mod", SYNTHETIC),
        "pkg.other": _Module("pkg.other", "IMPORTED = (OSError, Exception)\n"),
    }
    return modules, {"pkg.mod": "pkg/mod.py", "pkg.other": "pkg/other.py"}


def test_the_checker_flags_swallowing_broad_excepts_and_only_those():
    found = broad_swallowers(*_synthetic())
    assert sorted(fn for _, fn, _, _ in found) == [
        "raise_new_without_cause",
        "reraise_conditionally",
        "swallow_bare",
        "swallow_exception",
        "swallow_in_tuple",
        "swallow_through_constant",
        "swallow_through_import",
    ]
    assert {fn: caught for _, fn, _, caught in found}["swallow_through_import"] == "Exception"


def test_the_allow_list_arithmetic_flags_a_second_handler_in_an_allowed_function():
    found = [("hybrid/studies/sweep.py", "run_point", 1, "Exception")] * 2
    extra, stale = _unallowed(found)
    assert len(extra) == 2  # one row for run_point: two handlers there are one too many
    assert ("hybrid/cli/frc.py", "frc_overlays") in stale


# ----------------------------------------------------------------------------------------------
def test_no_broad_except_swallows_outside_the_allow_list():
    found = broad_swallowers(*_package_modules())
    extra, stale = _unallowed(found)
    assert not extra, (
        "broad excepts that swallow the exception (catch what can really occur there, re-raise, or "
        "add the site to ALLOWED with its reason):\n"
        + "\n".join(f"  {f}:{line} in {fn}(): except {caught}" for f, fn, line, caught in extra)
    )
    assert not stale, f"rows of ALLOWED that match no broad except any more (remove them): {stale}"


@pytest.mark.parametrize("row", ALLOWED, ids=lambda r: f"{r[0]}:{r[1]}")
def test_each_allowed_row_gives_a_one_line_reason(row):
    file, function, reason = row
    assert (REPO / file).is_file()
    assert function.isidentifier() and "\n" not in reason and len(reason) > 20
