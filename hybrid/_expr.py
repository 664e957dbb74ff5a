"""Expressions of a model: whitelist parser, symbolic derivative, compilation.

A model's equations, guards and definitions are strings such as
``"(F*sin(Omega*t) - c1*x1 - c2*(x1 - u))/m1"``. They are parsed with
:func:`ast.parse` and then walked node by node against a whitelist (numbers,
names, ``+ - * / **``, unary minus, and the functions of :data:`FUNCTIONS`);
anything else is rejected with a message naming the construct. The text is
never evaluated: it becomes a small immutable expression tree (:class:`Expr`)
from which the engine derives exact partial derivatives, compiles fast Python
closures (no code generation) and evaluates truncated Taylor series.
"""

from __future__ import annotations

import ast
import math
import operator
from collections.abc import Callable, Mapping

import numpy as np

__all__ = [
    "FUNCTIONS",
    "Expr",
    "ExpressionError",
    "parse",
    "diff",
    "substitute",
    "free_symbols",
    "compile_scalar",
    "taylor_eval",
]

MAX_EXPRESSION_LENGTH = 10_000
MAX_DEPTH = 200


class ExpressionError(ValueError):
    """An expression of a model is malformed, uses a forbidden construct or an unknown name."""


# ----------------------------------------------------------------------------
# Expression tree
# ----------------------------------------------------------------------------
class Expr:
    """Immutable node of an expression tree (hashable, compared structurally)."""

    __slots__ = ("op", "args", "_hash")

    def __init__(self, op: str, args: tuple):
        object.__setattr__(self, "op", op)
        object.__setattr__(self, "args", args)
        object.__setattr__(self, "_hash", hash((op, args)))

    def __setattr__(self, name, value):  # pragma: no cover - immutability guard
        raise AttributeError("Expr is immutable")

    def __hash__(self) -> int:
        return self._hash

    def __eq__(self, other) -> bool:
        return isinstance(other, Expr) and self.op == other.op and self.args == other.args

    def __repr__(self) -> str:
        return f"Expr({to_string(self)!r})"

    def __str__(self) -> str:
        return to_string(self)


def num(value: float) -> Expr:
    return Expr("num", (float(value),))


def sym(name: str) -> Expr:
    return Expr("sym", (name,))


ZERO = num(0.0)
ONE = num(1.0)


def _is_num(e: Expr, value: float | None = None) -> bool:
    return e.op == "num" and (value is None or e.args[0] == value)


# Smart constructors: fold constants and drop neutral elements so that derived
# Jacobians stay small and mostly constant.
def add(a: Expr, b: Expr) -> Expr:
    if _is_num(a) and _is_num(b) and math.isfinite(a.args[0] + b.args[0]):
        return num(a.args[0] + b.args[0])
    if _is_num(a, 0.0):
        return b
    if _is_num(b, 0.0):
        return a
    return Expr("add", (a, b))


def sub(a: Expr, b: Expr) -> Expr:
    if _is_num(a) and _is_num(b) and math.isfinite(a.args[0] - b.args[0]):
        return num(a.args[0] - b.args[0])
    if _is_num(b, 0.0):
        return a
    if _is_num(a, 0.0):
        return neg(b)
    if a == b:
        return ZERO
    return Expr("sub", (a, b))


def mul(a: Expr, b: Expr) -> Expr:
    if _is_num(a) and _is_num(b) and math.isfinite(a.args[0] * b.args[0]):
        return num(a.args[0] * b.args[0])
    if _is_num(a, 0.0) or _is_num(b, 0.0):
        return ZERO
    if _is_num(a, 1.0):
        return b
    if _is_num(b, 1.0):
        return a
    if _is_num(a, -1.0):
        return neg(b)
    if _is_num(b, -1.0):
        return neg(a)
    return Expr("mul", (a, b))


def div(a: Expr, b: Expr) -> Expr:
    if _is_num(b) and b.args[0] != 0.0:
        if _is_num(a) and math.isfinite(a.args[0] / b.args[0]):
            return num(a.args[0] / b.args[0])
        if b.args[0] == 1.0:
            return a
    if _is_num(a, 0.0):
        return ZERO
    return Expr("div", (a, b))


def neg(a: Expr) -> Expr:
    if _is_num(a):
        return num(-a.args[0])
    if a.op == "neg":
        return a.args[0]
    return Expr("neg", (a,))


def power(a: Expr, b: Expr) -> Expr:
    if _is_num(b, 0.0):
        return ONE
    if _is_num(b, 1.0):
        return a
    if _is_num(a) and _is_num(b):
        try:
            value = a.args[0] ** b.args[0]
        except (OverflowError, ZeroDivisionError):
            value = None
        # a negative base to a fractional power is complex in Python: never fold it
        if isinstance(value, float) and math.isfinite(value):
            return num(value)
    return Expr("pow", (a, b))


def call(name: str, arg: Expr) -> Expr:
    if _is_num(arg):
        try:
            value = _FUNC_FLOAT[name](arg.args[0])
        except (ValueError, OverflowError, ZeroDivisionError):
            value = None
        if value is not None and math.isfinite(value):
            return num(value)
    return Expr("call", (name, arg))


# ----------------------------------------------------------------------------
# Functions: scalar implementation, derivative, Taylor-jet implementation
# ----------------------------------------------------------------------------
def _sign(x: float) -> float:
    return 1.0 if x > 0 else (-1.0 if x < 0 else 0.0)


_FUNC_FLOAT: dict[str, Callable[[float], float]] = {
    "sin": math.sin,
    "cos": math.cos,
    "tan": math.tan,
    "exp": math.exp,
    "log": math.log,
    "sqrt": math.sqrt,
    "sinh": math.sinh,
    "cosh": math.cosh,
    "tanh": math.tanh,
    "atan": math.atan,
    "abs": abs,
    "sign": _sign,
}

#: Functions an expression may call (one argument each).
FUNCTIONS: tuple[str, ...] = tuple(_FUNC_FLOAT)

#: Named constants an expression may use.
CONSTANTS: dict[str, float] = {"pi": math.pi}


def _dfunc(name: str, a: Expr) -> Expr:
    """d/da of ``name(a)`` as an expression."""
    if name == "sin":
        return call("cos", a)
    if name == "cos":
        return neg(call("sin", a))
    if name == "tan":
        return add(ONE, power(call("tan", a), num(2.0)))
    if name == "exp":
        return call("exp", a)
    if name == "log":
        return div(ONE, a)
    if name == "sqrt":
        return div(num(0.5), call("sqrt", a))
    if name == "sinh":
        return call("cosh", a)
    if name == "cosh":
        return call("sinh", a)
    if name == "tanh":
        return sub(ONE, power(call("tanh", a), num(2.0)))
    if name == "atan":
        return div(ONE, add(ONE, power(a, num(2.0))))
    if name == "abs":
        return call("sign", a)
    if name == "sign":
        return ZERO
    raise KeyError(name)  # pragma: no cover - parser admits only FUNCTIONS


# ----------------------------------------------------------------------------
# Parsing
# ----------------------------------------------------------------------------
_BINOPS = {ast.Add: add, ast.Sub: sub, ast.Mult: mul, ast.Div: div, ast.Pow: power}


def parse(text: str, known: Mapping[str, object] | set[str] | frozenset[str], where: str) -> Expr:
    """Parse ``text`` into an expression tree, admitting only whitelisted constructs.

    Parameters
    ----------
    text : str
        The expression, in Python syntax restricted to numbers, names,
        ``+ - * / **``, unary ``-``/``+``, parentheses and the functions
        :data:`FUNCTIONS`.
    known : collection of str
        Names the expression may use (variables, parameters, definitions,
        ``t``); :data:`CONSTANTS` are always allowed.
    where : str
        Where the expression stands (e.g. ``"derivative of `v1` in mode
        `stick`"``), used in error messages.

    Returns
    -------
    Expr

    Raises
    ------
    ExpressionError
        On a syntax error, a forbidden construct or an unknown name.
    """
    if not isinstance(text, str):
        raise ExpressionError(f"{where}: expected an expression string, got {type(text).__name__} {text!r}")
    if len(text) > MAX_EXPRESSION_LENGTH:
        raise ExpressionError(f"{where}: expression longer than {MAX_EXPRESSION_LENGTH} characters")
    if not text.strip():
        raise ExpressionError(f"{where}: empty expression")
    try:
        tree = ast.parse(text.strip(), mode="eval")
    except SyntaxError as exc:
        col = f" at column {exc.offset}" if exc.offset else ""
        raise ExpressionError(f"{where}: syntax error{col} in {text!r}") from None

    def walk(node: ast.AST, depth: int) -> Expr:
        if depth > MAX_DEPTH:
            raise ExpressionError(
                f"{where}: expression nested deeper than {MAX_DEPTH} levels (a long sum counts one level per term)"
            )
        if isinstance(node, ast.Constant):
            value = node.value
            if isinstance(value, bool) or not isinstance(value, int | float):
                raise ExpressionError(
                    f"{where}: forbidden constant {value!r} in {text!r}; only real numbers are allowed"
                )
            if not math.isfinite(float(value)):
                raise ExpressionError(f"{where}: non-finite number in {text!r}")
            return num(float(value))
        if isinstance(node, ast.Name):
            if node.id in CONSTANTS:
                return num(CONSTANTS[node.id])
            if node.id not in known:
                allowed = ", ".join(sorted(known))
                raise ExpressionError(
                    f"{where}: unknown name `{node.id}` in {text!r}; known names: {allowed}, pi"
                )
            return sym(node.id)
        if isinstance(node, ast.BinOp):
            op = _BINOPS.get(type(node.op))
            if op is None:
                hint = " (use ** for powers)" if isinstance(node.op, ast.BitXor) else ""
                raise ExpressionError(
                    f"{where}: forbidden operator `{type(node.op).__name__}` in {text!r}{hint}; "
                    "allowed: + - * / **"
                )
            return op(walk(node.left, depth + 1), walk(node.right, depth + 1))
        if isinstance(node, ast.UnaryOp):
            if isinstance(node.op, ast.USub):
                return neg(walk(node.operand, depth + 1))
            if isinstance(node.op, ast.UAdd):
                return walk(node.operand, depth + 1)
            raise ExpressionError(f"{where}: forbidden operator `{type(node.op).__name__}` in {text!r}")
        if isinstance(node, ast.Call):
            if not isinstance(node.func, ast.Name) or node.func.id not in _FUNC_FLOAT:
                name = node.func.id if isinstance(node.func, ast.Name) else ast.dump(node.func)
                raise ExpressionError(
                    f"{where}: call of `{name}` is not allowed in {text!r}; "
                    f"allowed functions: {', '.join(FUNCTIONS)}"
                )
            if node.keywords or len(node.args) != 1:
                raise ExpressionError(
                    f"{where}: `{node.func.id}` takes exactly one positional argument in {text!r}"
                )
            return call(node.func.id, walk(node.args[0], depth + 1))
        raise ExpressionError(
            f"{where}: forbidden construct `{type(node).__name__}` in {text!r}; only numbers, "
            f"names, + - * / **, parentheses and the functions {', '.join(FUNCTIONS)} are allowed"
        )

    return walk(tree.body, 0)


# ----------------------------------------------------------------------------
# Tree utilities
# ----------------------------------------------------------------------------
def to_string(e: Expr) -> str:
    """Render an expression (fully parenthesised where needed)."""
    op = e.op
    if op == "num":
        return repr(e.args[0])
    if op == "sym":
        return e.args[0]
    if op == "neg":
        return f"-({to_string(e.args[0])})"
    if op == "call":
        return f"{e.args[0]}({to_string(e.args[1])})"
    sym_ = {"add": "+", "sub": "-", "mul": "*", "div": "/", "pow": "**"}[op]
    return f"({to_string(e.args[0])} {sym_} {to_string(e.args[1])})"


def free_symbols(e: Expr) -> set[str]:
    """Names of the symbols an expression depends on."""
    out: set[str] = set()
    stack = [e]
    while stack:
        node = stack.pop()
        if node.op == "sym":
            out.add(node.args[0])
        elif node.op == "call":
            stack.append(node.args[1])
        elif node.op != "num":
            stack.extend(node.args)
    return out


def substitute(e: Expr, values: Mapping[str, Expr]) -> Expr:
    """Replace symbols by expressions (constants folded on the way)."""
    cache: dict[Expr, Expr] = {}

    def rec(node: Expr) -> Expr:
        hit = cache.get(node)
        if hit is not None:
            return hit
        op = node.op
        if op == "num":
            out = node
        elif op == "sym":
            out = values.get(node.args[0], node)
        elif op == "neg":
            out = neg(rec(node.args[0]))
        elif op == "call":
            out = call(node.args[0], rec(node.args[1]))
        else:
            out = _REBUILD[op](rec(node.args[0]), rec(node.args[1]))
        cache[node] = out
        return out

    return rec(e)


_REBUILD = {"add": add, "sub": sub, "mul": mul, "div": div, "pow": power}


def diff(e: Expr, name: str) -> Expr:
    """Exact partial derivative of an expression with respect to symbol ``name``."""
    cache: dict[Expr, Expr] = {}

    def rec(node: Expr) -> Expr:
        hit = cache.get(node)
        if hit is not None:
            return hit
        op = node.op
        if op == "num":
            out = ZERO
        elif op == "sym":
            out = ONE if node.args[0] == name else ZERO
        elif op == "neg":
            out = neg(rec(node.args[0]))
        elif op == "add":
            out = add(rec(node.args[0]), rec(node.args[1]))
        elif op == "sub":
            out = sub(rec(node.args[0]), rec(node.args[1]))
        elif op == "mul":
            a, b = node.args
            out = add(mul(rec(a), b), mul(a, rec(b)))
        elif op == "div":
            a, b = node.args
            da, db = rec(a), rec(b)
            out = sub(div(da, b), div(mul(a, db), power(b, num(2.0))))
        elif op == "pow":
            a, b = node.args
            da, db = rec(a), rec(b)
            if _is_num(db, 0.0):
                out = mul(mul(b, power(a, sub(b, ONE))), da)
            else:
                out = mul(node, add(mul(db, call("log", a)), div(mul(b, da), a)))
        elif op == "call":
            fname, a = node.args
            out = mul(_dfunc(fname, a), rec(a))
        else:  # pragma: no cover
            raise AssertionError(op)
        cache[node] = out
        return out

    return rec(e)


# ----------------------------------------------------------------------------
# Compilation to closures over a flat list of values
# ----------------------------------------------------------------------------
def _real_pow(a: float, b: float) -> float:
    value = a**b
    if isinstance(value, complex):
        raise ArithmeticError(
            f"negative base {a!r} raised to the non-integer power {b!r} (not a real number)"
        )
    return value


_PYOP = {
    "add": operator.add,
    "sub": operator.sub,
    "mul": operator.mul,
    "div": operator.truediv,
    "pow": _real_pow,
}


def compile_scalar(e: Expr, slots: Mapping[str, int], constants: Mapping[str, float]) -> Callable:
    """Compile an expression into a closure ``f(v) -> float``.

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
    return _compile(e, slots)


def _compile(e: Expr, slots: Mapping[str, int]) -> Callable:
    op = e.op
    if op == "num":
        c = e.args[0]
        return lambda v: c
    if op == "sym":
        name = e.args[0]
        if name not in slots:
            raise ExpressionError(f"symbol `{name}` has no value at run time")
        return operator.itemgetter(slots[name])
    if op == "neg":
        f = _compile(e.args[0], slots)
        return lambda v: -f(v)
    if op == "call":
        fn = _FUNC_FLOAT[e.args[0]]
        f = _compile(e.args[1], slots)
        return lambda v: fn(f(v))
    a, b = e.args
    pyop = _PYOP[op]
    # Specialisations for a constant or a plain symbol on either side.
    if a.op == "num":
        ca = a.args[0]
        fb = _compile(b, slots)
        return lambda v: pyop(ca, fb(v))
    if b.op == "num":
        cb = b.args[0]
        fa = _compile(a, slots)
        if op == "pow" and cb == 2.0:
            return lambda v: fa(v) ** 2
        return lambda v: pyop(fa(v), cb)
    if a.op == "sym" and b.op == "sym":
        for name in (a.args[0], b.args[0]):
            if name not in slots:
                raise ExpressionError(f"symbol `{name}` has no value at run time")
        ia, ib = slots[a.args[0]], slots[b.args[0]]
        return lambda v: pyop(v[ia], v[ib])
    fa = _compile(a, slots)
    fb = _compile(b, slots)
    return lambda v: pyop(fa(v), fb(v))


# ----------------------------------------------------------------------------
# Truncated Taylor series ("jets")
# ----------------------------------------------------------------------------
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
    order = next(len(v) for v in env.values() if isinstance(v, np.ndarray))

    def const(c: float) -> np.ndarray:
        out = np.zeros(order)
        out[0] = c
        return out

    cache: dict[Expr, np.ndarray] = {}

    def rec(node: Expr) -> np.ndarray:
        hit = cache.get(node)
        if hit is not None:
            return hit
        op = node.op
        if op == "num":
            out = const(node.args[0])
        elif op == "sym":
            value = env[node.args[0]]
            out = value if isinstance(value, np.ndarray) else const(value)
        elif op == "neg":
            out = -rec(node.args[0])
        elif op == "add":
            out = rec(node.args[0]) + rec(node.args[1])
        elif op == "sub":
            out = rec(node.args[0]) - rec(node.args[1])
        elif op == "mul":
            out = _jmul(rec(node.args[0]), rec(node.args[1]))
        elif op == "div":
            out = _jdiv(rec(node.args[0]), rec(node.args[1]))
        elif op == "pow":
            a, b = node.args
            ja = rec(a)
            if b.op == "num" and float(b.args[0]).is_integer() and abs(b.args[0]) <= 1024:
                out = _jpow_int(ja, int(b.args[0]))
            elif b.op == "num" and b.args[0] == 0.5:
                out = _jsqrt(ja)
            else:
                out = _jexp(_jmul(rec(b), _jlog(ja)))
        elif op == "call":
            out = _jcall(node.args[0], rec(node.args[1]))
        else:  # pragma: no cover
            raise AssertionError(op)
        cache[node] = out
        return out

    return rec(e)
