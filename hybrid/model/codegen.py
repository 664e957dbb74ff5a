"""Compilation of expressions into straight-line Python functions.

The expression DAG (:class:`hybrid.model.expr.Expr`) of several roots becomes one generated
function with every shared sub-expression computed once per call. The generated code is built
from the tree node by node as a Python :mod:`ast` (never from the model's text) and can reach
only the names of a closed namespace (no builtins): the real-valued functions of
:data:`hybrid.model.expr.FUNCTIONS` and the parameters read at run time
(:func:`runtime_namespace`).
"""

from __future__ import annotations

import ast
import types
from collections.abc import Callable, Mapping

import numpy as np

from ..core.budget import check_deadline
from ..core.errors import ExpressionError, InputError
from .expr import (
    _FUNC_FLOAT,
    Expr,
    num,
    postorder,
    substitute,
)

__all__ = ["compile_many", "compile_scalar", "runtime_namespace", "set_runtime"]


def _real_pow(a: float, b: float) -> float:
    value = a**b
    if isinstance(value, complex):
        raise ArithmeticError(
            f"negative base {a!r} raised to the non-integer power {b!r} (not a real number)"
        )
    return value


def _real_pow_array(a, b):
    """``a ** b`` elementwise on arrays (NaN where it is not a real number: the caller checks)."""
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        return np.power(a, b)


#: The functions of :data:`FUNCTIONS` on arrays, elementwise (for ``compile_many(vector=True)``).
_FUNC_ARRAY: dict[str, Callable] = {
    "sin": np.sin,
    "cos": np.cos,
    "tan": np.tan,
    "exp": np.exp,
    "log": np.log,
    "sqrt": np.sqrt,
    "sinh": np.sinh,
    "cosh": np.cosh,
    "tanh": np.tanh,
    "atan": np.arctan,
    "abs": np.abs,
    "sign": np.sign,
}


_AST_BINOP = {"add": ast.Add, "sub": ast.Sub, "mul": ast.Mult, "div": ast.Div}


#: The only names generated code can reach (no builtins).
_NAMESPACE: dict[str, object] = {
    "__builtins__": {},
    "_real_pow": _real_pow,
    "_real_pow_array": _real_pow_array,
    **{f"_f_{n}": f for n, f in _FUNC_FLOAT.items()},
    **{f"_fa_{n}": f for n, f in _FUNC_ARRAY.items()},
}


def runtime_namespace(values: Mapping[str, float]) -> dict:
    """A namespace for :func:`compile_many` whose symbols ``values`` are read at run time.

    Functions compiled with it read each such symbol from the namespace at every call, so
    :func:`set_runtime` changes them in every function that shares the namespace at once.
    """
    ns = dict(_NAMESPACE)
    set_runtime(ns, values)
    return ns


def set_runtime(namespace: dict, values: Mapping[str, float]) -> None:
    """Set the run-time symbols of a :func:`runtime_namespace`."""
    for k, v in values.items():
        namespace[f"_p_{k}"] = float(v)


def _located(node: ast.AST) -> ast.AST:
    """``node`` with the source location every compiled node needs (line 1, column 0)."""
    node.lineno = node.end_lineno = 1
    node.col_offset = node.end_col_offset = 0
    return node


def compile_many(
    exprs,
    slots: Mapping[str, int],
    name: str = "f",
    *,
    scalar: bool = False,
    namespace: dict | None = None,
    vector: bool = False,
) -> Callable:
    """Compile expressions into one function ``f(v) -> tuple of float``.

    The function is generated from the expression DAG, never from the
    model's text: one local assignment per distinct operation node (shared
    sub-expressions are computed once), symbols read as ``v[slot]``, numbers
    as constants, functions from a fixed namespace without builtins. It is
    built as a Python syntax tree and compiled; no string is evaluated.

    Parameters
    ----------
    exprs : sequence of Expr
        The expressions (their symbols must all have a slot).
    slots : mapping of str to int
        Position of each symbol in the sequence ``v`` passed to ``f``.
    name : str
        Name of the generated function (shown in tracebacks).
    scalar : bool
        Return the value of the single expression instead of a tuple.
    namespace : dict, optional
        A :func:`runtime_namespace`: symbols without a slot that it holds are read from it at
        every call (shared by all functions compiled with it).
    vector : bool
        Elementwise on arrays: ``v`` holds one array per slot and the functions are numpy's.
        Where a scalar function would raise (a logarithm of a negative number, a division by
        zero) the result holds a non-finite value instead, without a warning: the caller checks.
        An expression without slot symbols returns a float.

    Returns
    -------
    callable
        ``f(v)`` returning a tuple with one float per expression (a float
        with ``scalar=True``).
    """
    exprs = list(exprs)
    glob = dict(_NAMESPACE) if namespace is None else namespace
    for e in exprs:
        # (not `e.free - slots.keys()`: that walks every slot, O(N^2) over a large model's rows)
        missing = {s for s in e.free if s not in slots and f"_p_{s}" not in glob}
        if missing:
            raise ExpressionError(f"symbol `{sorted(missing)[0]}` has no value at run time")
    refs: dict[Expr, ast.expr] = {}
    body: list[ast.stmt] = []
    at = _located

    def ref(node: Expr) -> ast.expr:
        return refs[node]

    for k, node in enumerate(postorder(exprs)):
        if k and not k & 4095:  # a large model's set-up honours the deadline in force (--max-time)
            check_deadline(f"compiling the model's function `{name}`")
        op, args = node.op, node.args
        if op == "num":
            refs[node] = at(ast.Constant(args[0]))
            continue
        if op == "sym":
            if args[0] in slots:
                refs[node] = at(
                    ast.Subscript(at(ast.Name("v", ast.Load())), at(ast.Constant(slots[args[0]])), ast.Load())
                )
            else:
                refs[node] = at(ast.Name(f"_p_{args[0]}", ast.Load()))
            continue
        if op == "neg":
            value = ast.UnaryOp(ast.USub(), ref(args[0]))
        elif op == "call":
            fn = f"_fa_{args[0]}" if vector else f"_f_{args[0]}"
            value = ast.Call(at(ast.Name(fn, ast.Load())), [ref(args[1])], [])
        elif op == "pow":
            a, b = args
            if b.op == "num" and b.args[0] == 2.0:
                value = ast.BinOp(ref(a), ast.Pow(), at(ast.Constant(2)))
            else:
                pw = "_real_pow_array" if vector else "_real_pow"
                value = ast.Call(at(ast.Name(pw, ast.Load())), [ref(a), ref(b)], [])
        else:
            value = ast.BinOp(ref(args[0]), _AST_BINOP[op](), ref(args[1]))
        local = f"_{len(body)}"
        body.append(at(ast.Assign([at(ast.Name(local, ast.Store()))], at(value))))
        refs[node] = at(ast.Name(local, ast.Load()))
    if scalar:
        if len(exprs) != 1:
            raise InputError("scalar=True needs exactly one expression")
        body.append(at(ast.Return(ref(exprs[0]))))
    else:
        body.append(at(ast.Return(at(ast.Tuple([ref(e) for e in exprs], ast.Load())))))
    fdef = ast.FunctionDef(
        name=name,
        args=ast.arguments(
            posonlyargs=[], args=[at(ast.arg("v"))], kwonlyargs=[], kw_defaults=[], defaults=[]
        ),
        body=body,
        decorator_list=[],
        returns=None,
    )
    # every node carries its location already (_located): ast.fix_missing_locations, a recursive
    # walk, took 40 % of compiling 1000 contacts (issue 32)
    module = ast.Module([at(fdef)], type_ignores=[])
    code = compile(module, f"<hybrid {name}>", "exec")
    fcode = next(c for c in code.co_consts if isinstance(c, types.CodeType))
    return types.FunctionType(fcode, glob, name)


def compile_scalar(
    e: Expr, slots: Mapping[str, int], constants: Mapping[str, float], namespace: dict | None = None
) -> Callable:
    """Compile an expression into a function ``f(v) -> float``.

    Parameters
    ----------
    e : Expr
        Expression.
    slots : mapping of str to int
        Position of each runtime symbol in the list ``v`` passed to ``f``.
    constants : mapping of str to float
        Values of the symbols fixed at compile time (parameters); they are
        folded into the tree before compilation.

    Returns
    -------
    callable
        ``f(v)`` with ``v`` a list (or tuple) of floats.
    """
    e = substitute(e, {k: num(v) for k, v in constants.items()})
    if e.op == "num":
        c = e.args[0]
        return lambda v: c
    if e.op == "sym" and e.args[0] not in slots and namespace is not None and f"_p_{e.args[0]}" in namespace:
        return compile_many([e], slots, scalar=True, namespace=namespace)
    if e.op == "sym":
        if e.args[0] not in slots:
            raise ExpressionError(f"symbol `{e.args[0]}` has no value at run time")
        i = slots[e.args[0]]
        return lambda v: v[i]
    return compile_many([e], slots, scalar=True, namespace=namespace)
