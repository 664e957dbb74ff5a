"""Truncated Taylor series ("jets") of expressions along a flow.

An expression is evaluated on series ``a_0 + a_1 s + ... + a_K s^K`` of its variables
(arithmetic, powers and the functions of :data:`hybrid.model.expr.FUNCTIONS` by their recurrences),
giving its own series to the same order: the engine reads from it with which sign a guard leaves
zero at a switch (:func:`hybrid.model.compiled.lead_sign`).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Mapping

import numpy as np

from .expr import Expr, postorder

__all__ = ["taylor_eval", "taylor_eval_many"]


def _jmul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.convolve(a, b)[: a.size]


def _jdiv(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    if b[0] == 0.0:
        raise ZeroDivisionError("division by a series with zero constant term")
    c = np.zeros_like(a)
    for k in range(a.size):
        c[k] = (a[k] - np.dot(b[1 : k + 1], c[k - 1 :: -1][:k])) / b[0]
    return c


def _jintegrate_rate(a: np.ndarray, rate: np.ndarray, c0: float) -> np.ndarray:
    """Series c with c(0) = c0 and c' = rate * a' (k c_k = sum_j j a_j rate_{k-j})."""
    c = np.zeros_like(a)
    c[0] = c0
    for k in range(1, a.size):
        j = np.arange(1, k + 1)
        c[k] = np.dot(j * a[1 : k + 1], rate[k - j]) / k
    return c


def _jexp(a: np.ndarray) -> np.ndarray:
    e = np.zeros_like(a)
    e[0] = math.exp(a[0])
    for k in range(1, a.size):
        j = np.arange(1, k + 1)
        e[k] = np.dot(j * a[1 : k + 1], e[k - j]) / k
    return e


def _jsincos(a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    s = np.zeros_like(a)
    c = np.zeros_like(a)
    s[0], c[0] = math.sin(a[0]), math.cos(a[0])
    for k in range(1, a.size):
        j = np.arange(1, k + 1)
        ja = j * a[1 : k + 1]
        s[k] = np.dot(ja, c[k - j]) / k
        c[k] = -np.dot(ja, s[k - j]) / k
    return s, c


def _jlog(a: np.ndarray) -> np.ndarray:
    return _jintegrate_rate(a, _jdiv(_unit(a), a), math.log(a[0]))


def _unit(a: np.ndarray) -> np.ndarray:
    u = np.zeros_like(a)
    u[0] = 1.0
    return u


def _jsqrt(a: np.ndarray) -> np.ndarray:
    r = np.zeros_like(a)
    r[0] = math.sqrt(a[0])
    if r[0] == 0.0:
        raise ZeroDivisionError("sqrt of a series with zero constant term")
    for k in range(1, a.size):
        r[k] = (a[k] - np.dot(r[1:k], r[k - 1 : 0 : -1])) / (2.0 * r[0])
    return r


def _jpow_int(a: np.ndarray, n: int) -> np.ndarray:
    """Series of a**n for an integer n (binary powering; any sign of a[0])."""
    out = _unit(a)
    base = a
    k = abs(n)
    while k:
        if k & 1:
            out = _jmul(out, base)
        base = _jmul(base, base)
        k >>= 1
    return _jdiv(_unit(a), out) if n < 0 else out


def _first_nonzero_sign(a: np.ndarray) -> float:
    for value in a:
        if value != 0.0:
            return 1.0 if value > 0 else -1.0
    return 0.0


def _jcall(name: str, a: np.ndarray) -> np.ndarray:
    if name == "sin":
        return _jsincos(a)[0]
    if name == "cos":
        return _jsincos(a)[1]
    if name == "tan":
        s, c = _jsincos(a)
        return _jdiv(s, c)
    if name == "exp":
        return _jexp(a)
    if name == "log":
        return _jlog(a)
    if name == "sqrt":
        return _jsqrt(a)
    if name in ("sinh", "cosh", "tanh"):
        ep, em = _jexp(a), _jexp(-a)
        if name == "sinh":
            return 0.5 * (ep - em)
        if name == "cosh":
            return 0.5 * (ep + em)
        return _jdiv(ep - em, ep + em)
    if name == "atan":
        return _jintegrate_rate(a, _jdiv(_unit(a), _unit(a) + _jmul(a, a)), math.atan(a[0]))
    if name == "abs":
        return _first_nonzero_sign(a) * a
    if name == "sign":
        out = np.zeros_like(a)
        out[0] = _first_nonzero_sign(a)
        return out
    raise KeyError(name)  # pragma: no cover


@functools.lru_cache(maxsize=1024)
def _postorder_of(roots: tuple[Expr, ...]) -> tuple[Expr, ...]:
    """:func:`postorder` of ``roots``, kept: Taylor series evaluate the same few expressions at
    every switch of a run."""
    return tuple(postorder(roots))


def taylor_eval(e: Expr, env: Mapping[str, np.ndarray | float]) -> np.ndarray:
    """Evaluate an expression on truncated Taylor series.

    Parameters
    ----------
    e : Expr
        Expression.
    env : mapping of str to array or float
        Taylor coefficients (shape ``(K+1,)``) of every symbol; a float is a
        constant.

    Returns
    -------
    ndarray, shape (K+1,)
        Taylor coefficients of the expression.
    """
    return taylor_eval_many((e,), env)[0]


def taylor_eval_many(roots: tuple[Expr, ...], env: Mapping[str, np.ndarray | float]) -> list[np.ndarray]:
    """:func:`taylor_eval` of several expressions at once, each shared sub-expression once."""
    order = next(len(v) for v in env.values() if isinstance(v, np.ndarray))

    def const(c: float) -> np.ndarray:
        out = np.zeros(order)
        out[0] = c
        return out

    val: dict[Expr, np.ndarray] = {}
    for node in _postorder_of(tuple(roots)):
        op = node.op
        if op == "num":
            out = const(node.args[0])
        elif op == "sym":
            value = env[node.args[0]]
            out = value if isinstance(value, np.ndarray) else const(value)
        elif op == "neg":
            out = -val[node.args[0]]
        elif op == "add":
            out = val[node.args[0]] + val[node.args[1]]
        elif op == "sub":
            out = val[node.args[0]] - val[node.args[1]]
        elif op == "mul":
            out = _jmul(val[node.args[0]], val[node.args[1]])
        elif op == "div":
            out = _jdiv(val[node.args[0]], val[node.args[1]])
        elif op == "pow":
            a, b = node.args
            ja = val[a]
            if b.op == "num" and float(b.args[0]).is_integer() and abs(b.args[0]) <= 1024:
                out = _jpow_int(ja, int(b.args[0]))
            elif b.op == "num" and b.args[0] == 0.5:
                out = _jsqrt(ja)
            else:
                out = _jexp(_jmul(val[b], _jlog(ja)))
        elif op == "call":
            out = _jcall(node.args[0], val[node.args[1]])
        else:  # pragma: no cover
            raise AssertionError(op)
        val[node] = out
    return [val[e] for e in roots]
