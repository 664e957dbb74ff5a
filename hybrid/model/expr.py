"""Expressions of a model: the expression tree, whitelist parser and symbolic derivative.

A model's equations, guards and definitions are strings such as
``"(F*sin(Omega*t) - c1*x1 - c2*(x1 - u))/m1"``. They are parsed with
:func:`ast.parse` and then walked node by node against a whitelist (numbers,
names, ``+ - * / **``, unary minus, and the functions of :data:`FUNCTIONS`);
anything else is rejected with a message naming the construct. The text is
never evaluated: it becomes a small immutable expression tree (:class:`Expr`)
from which the engine derives exact partial derivatives (:func:`diff`), compiles
straight-line Python functions (:mod:`hybrid.model.codegen`) and evaluates truncated Taylor
series (:mod:`hybrid.model.taylor`).
"""

from __future__ import annotations

import ast
import math
import re
import weakref
from collections.abc import Callable, Mapping

from ..core.errors import ExpressionError

__all__ = [
    "FUNCTIONS",
    "Expr",
    "parse",
    "diff",
    "substitute",
    "free_symbols",
    "to_data",
    "from_data",
]

MAX_EXPRESSION_LENGTH = 10_000


# ----------------------------------------------------------------------------
# Expression tree: a DAG of interned nodes
# ----------------------------------------------------------------------------
class Expr:
    """Immutable node of an expression DAG.

    Nodes are interned (hash-consed): building a node equal to an existing
    one returns the existing object, so structurally equal sub-expressions are
    one shared node, equality is identity and every walk over an expression
    visits each distinct sub-expression once. Definitions that refer to each
    other therefore expand in time and memory linear in the model's size,
    never exponential (``a2 = a1*a1, a3 = a2*a2, ...`` is a chain of nodes).
    The set of free symbols and the depth of each node are stored with it.
    """

    __slots__ = ("op", "args", "_hash", "free", "depth", "__weakref__")
    _table: weakref.WeakValueDictionary = weakref.WeakValueDictionary()

    def __new__(cls, op: str, args: tuple):
        key = (op, args, math.copysign(1.0, args[0])) if op == "num" else (op, args)
        hit = cls._table.get(key)
        if hit is not None:
            return hit
        self = object.__new__(cls)
        set_ = object.__setattr__
        set_(self, "op", op)
        set_(self, "args", args)
        set_(self, "_hash", hash(key))
        kids = _children_of(op, args)
        if op == "sym":
            free = frozenset(args)
        elif not kids:
            free = frozenset()
        elif len(kids) == 1:
            free = kids[0].free
        else:
            free = kids[0].free | kids[1].free
        set_(self, "free", free)
        set_(self, "depth", 1 + max((k.depth for k in kids), default=0))
        cls._table[key] = self
        return self

    def __setattr__(self, name, value):  # pragma: no cover - immutability guard
        raise AttributeError("Expr is immutable")

    def __reduce__(self):
        return (Expr, (self.op, self.args))

    def __hash__(self) -> int:
        return self._hash

    def __eq__(self, other) -> bool:
        return self is other

    def __repr__(self) -> str:
        return f"Expr({to_string(self)!r})"

    def __str__(self) -> str:
        return to_string(self)


def _children_of(op: str, args: tuple) -> tuple:
    if op in ("num", "sym"):
        return ()
    if op == "call":
        return (args[1],)
    return args


def children(e: Expr) -> tuple:
    """The sub-expressions of a node (operands; the argument of a call)."""
    return _children_of(e.op, e.args)


def postorder(roots) -> list[Expr]:
    """Every distinct node reachable from ``roots``, each once, children before parents.

    Iterative (no recursion limit on the depth of an expression).
    """
    seen: set[Expr] = set()
    out: list[Expr] = []
    stack: list[tuple[Expr, bool]] = [(r, False) for r in reversed(list(roots))]
    while stack:
        node, expanded = stack.pop()
        if expanded:
            out.append(node)
            continue
        if node in seen:
            continue
        seen.add(node)
        stack.append((node, True))
        for c in reversed(children(node)):
            if c not in seen:
                stack.append((c, False))
    return out


def count_nodes(roots) -> int:
    """Number of distinct nodes of the DAG under ``roots``."""
    return len(postorder(roots))


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

#: Limits of one expression, checked on the text before :func:`ast.parse` sees it.
MAX_OPERATORS = 1000  # operators, calls and commas (a sum of N terms has N - 1)
MAX_NESTING = 100  # depth of parentheses (calls included)
MAX_NUMBER_LENGTH = 40  # characters of a number literal

_TOKEN = re.compile(r"\d[\w.]*(?:[eE][+-]\d*)?|\.\d[\w.]*(?:[eE][+-]\d*)?|[A-Za-z_]\w*|\*\*|\S")


def _prescan(text: str, where: str) -> None:
    """Check the size limits of an expression on its text, in one linear pass."""
    ops = depth = deepest = 0
    for m in _TOKEN.finditer(text):
        tok = m.group()
        c = tok[0]
        if c.isdigit() or (c == "." and len(tok) > 1):
            if len(tok) > MAX_NUMBER_LENGTH:
                raise ExpressionError(
                    f"{where}: number literal {tok[:20]}... has {len(tok)} characters; "
                    f"at most {MAX_NUMBER_LENGTH} are allowed (use an exponent, e.g. 1e30)"
                )
        elif c == "(" or c == "[" or c == "{":
            depth += 1
            deepest = max(deepest, depth)
            if deepest > MAX_NESTING:
                raise ExpressionError(
                    f"{where}: parentheses nested deeper than {MAX_NESTING} levels; split the "
                    "expression into named definitions"
                )
        elif c == ")" or c == "]" or c == "}":
            depth -= 1
        elif not (c.isalpha() or c == "_"):
            ops += 1
            if ops > MAX_OPERATORS:
                raise ExpressionError(
                    f"{where}: more than {MAX_OPERATORS} operators in one expression; split it "
                    "into named definitions"
                )


def parse(text: str, known: Mapping[str, object] | set[str] | frozenset[str], where: str) -> Expr:
    """Parse ``text`` into an expression tree, admitting only whitelisted constructs.

    Parameters
    ----------
    text : str or Expr
        The expression (an :class:`Expr` already built from parsed trees is
        returned as it is, once its names are checked), in Python syntax restricted to numbers, names,
        ``+ - * / **``, unary ``-``/``+``, parentheses and the functions
        :data:`FUNCTIONS`; at most :data:`MAX_EXPRESSION_LENGTH` characters,
        :data:`MAX_OPERATORS` operators, :data:`MAX_NESTING` levels of
        parentheses and number literals of :data:`MAX_NUMBER_LENGTH` characters.
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
        On a syntax error, a forbidden construct, an unknown name or a limit
        exceeded (checked before :func:`ast.parse` runs).
    """
    if isinstance(text, Expr):  # built by a front end from parsed trees (e.g. hybrid.model.filippov)
        unknown = sorted(n for n in text.free if n not in known and n not in CONSTANTS)
        if unknown:
            raise ExpressionError(f"{where}: unknown name `{unknown[0]}` in {to_string(text, 80)!r}")
        return text
    if not isinstance(text, str):
        raise ExpressionError(f"{where}: expected an expression string, got {type(text).__name__} {text!r}")
    if len(text) > MAX_EXPRESSION_LENGTH:
        raise ExpressionError(
            f"{where}: expression of {len(text)} characters; at most {MAX_EXPRESSION_LENGTH} are allowed"
        )
    if not text.strip():
        raise ExpressionError(f"{where}: empty expression")
    shown = text if len(text) <= 80 else text[:77] + "..."
    _prescan(text, where)
    try:
        tree = ast.parse(text.strip(), mode="eval")
    except SyntaxError as exc:
        col = f" at column {exc.offset}" if exc.offset else ""
        raise ExpressionError(f"{where}: syntax error{col} in {shown!r}") from None
    except (RecursionError, MemoryError):  # pragma: no cover - the prescan keeps below the parser's limits
        raise ExpressionError(f"{where}: expression too deeply nested for the parser") from None

    def leaf(node: ast.AST) -> Expr:
        if isinstance(node, ast.Constant):
            value = node.value
            if isinstance(value, bool) or not isinstance(value, int | float):
                raise ExpressionError(
                    f"{where}: forbidden constant {value!r} in {shown!r}; only real numbers are allowed"
                )
            try:
                value = float(value)
            except OverflowError:
                raise ExpressionError(f"{where}: number too large for a float in {shown!r}") from None
            if not math.isfinite(value):
                raise ExpressionError(f"{where}: non-finite number in {shown!r}")
            return num(value)
        if isinstance(node, ast.Name):
            if node.id in CONSTANTS:
                return num(CONSTANTS[node.id])
            if node.id not in known:
                names = sorted(known)
                allowed = ", ".join(names[:40]) + (f", ... ({len(names)} names)" if len(names) > 40 else "")
                raise ExpressionError(
                    f"{where}: unknown name `{node.id}` in {shown!r}; known names: {allowed}, pi"
                )
            return sym(node.id)
        raise AssertionError(node)  # pragma: no cover

    def operands(node: ast.AST) -> list[ast.AST]:
        """The sub-nodes to build first, after checking the node is allowed."""
        if isinstance(node, ast.Constant | ast.Name):
            return []
        if isinstance(node, ast.BinOp):
            if type(node.op) not in _BINOPS:
                hint = " (use ** for powers)" if isinstance(node.op, ast.BitXor) else ""
                raise ExpressionError(
                    f"{where}: forbidden operator `{type(node.op).__name__}` in {shown!r}{hint}; "
                    "allowed: + - * / **"
                )
            return [node.left, node.right]
        if isinstance(node, ast.UnaryOp):
            if not isinstance(node.op, ast.USub | ast.UAdd):
                raise ExpressionError(f"{where}: forbidden operator `{type(node.op).__name__}` in {shown!r}")
            return [node.operand]
        if isinstance(node, ast.Call):
            if not isinstance(node.func, ast.Name) or node.func.id not in _FUNC_FLOAT:
                name = node.func.id if isinstance(node.func, ast.Name) else ast.dump(node.func)[:60]
                raise ExpressionError(
                    f"{where}: call of `{name}` is not allowed in {shown!r}; "
                    f"allowed functions: {', '.join(FUNCTIONS)}"
                )
            if node.keywords or len(node.args) != 1:
                raise ExpressionError(
                    f"{where}: `{node.func.id}` takes exactly one positional argument in {shown!r}"
                )
            return [node.args[0]]
        raise ExpressionError(
            f"{where}: forbidden construct `{type(node).__name__}` in {shown!r}; only numbers, "
            f"names, + - * / **, parentheses and the functions {', '.join(FUNCTIONS)} are allowed"
        )

    # Iterative post-order walk (an expression may be a long flat sum: no recursion).
    built: dict[int, Expr] = {}
    stack: list[tuple[ast.AST, bool]] = [(tree.body, False)]
    while stack:
        node, ready = stack.pop()
        if not ready:
            subs = operands(node)
            if not subs:
                built[id(node)] = leaf(node)
                continue
            stack.append((node, True))
            stack.extend((s, False) for s in reversed(subs))
            continue
        if isinstance(node, ast.BinOp):
            out = _BINOPS[type(node.op)](built.pop(id(node.left)), built.pop(id(node.right)))
        elif isinstance(node, ast.UnaryOp):
            inner = built.pop(id(node.operand))
            out = neg(inner) if isinstance(node.op, ast.USub) else inner
        else:  # ast.Call
            out = call(node.func.id, built.pop(id(node.args[0])))
        built[id(node)] = out
    return built[id(tree.body)]


# ----------------------------------------------------------------------------
# Tree utilities (iterative, each distinct node visited once)
# ----------------------------------------------------------------------------
#: Operations of :class:`Expr` nodes and the number of sub-expressions each takes (``from_data``).
_ARITY = {"add": 2, "sub": 2, "mul": 2, "div": 2, "pow": 2, "neg": 1}


def to_data(e: Expr) -> list:
    """An expression as plain data (JSON-ready), its DAG kept: a list of nodes, each after its
    sub-expressions, the last the expression itself.

    A node is ``["num", value]`` (a non-finite value as the text ``"inf"``, ``"-inf"``, ``"nan"``),
    ``["sym", name]``, ``["call", function, i]`` or ``[op, i, ...]`` with ``i`` the index of a
    sub-expression in the list. A shared sub-expression is written once, so the data is as large
    as the DAG (never the exponential text of :func:`to_string`), and equal expressions give
    equal data. :func:`from_data` builds the same node (the same object: nodes are interned).

    Examples
    --------
    >>> to_data(parse("x*x + 1", {"x"}, "e"))
    [['sym', 'x'], ['mul', 0, 0], ['num', 1.0], ['add', 1, 2]]
    """
    index: dict[Expr, int] = {}
    nodes: list[list] = []
    stack: list[Expr] = [e]
    while stack:  # iterative post-order: the depth of a model's expression is not Python's stack's
        node = stack[-1]
        if node in index:
            stack.pop()
            continue
        todo = [k for k in children(node) if k not in index]
        if todo:
            stack.extend(reversed(todo))
            continue
        stack.pop()
        op, args = node.op, node.args
        if op == "num":
            v = float(args[0])
            item = ["num", v if math.isfinite(v) else repr(v)]
        elif op == "sym":
            item = ["sym", args[0]]
        elif op == "call":
            item = ["call", args[0], index[args[1]]]
        else:
            item = [op, *(index[a] for a in args)]
        index[node] = len(nodes)
        nodes.append(item)
    return nodes


def from_data(nodes: list) -> Expr:
    """The expression of :func:`to_data` (the same interned node).

    Raises
    ------
    ExpressionError
        ``nodes`` is not what :func:`to_data` writes (an unknown operation or function, an index
        that does not point before the node, a value that is not a number).
    """
    built: list[Expr] = []
    try:
        for k, item in enumerate(nodes):
            op, rest = item[0], list(item[1:])
            if op == "num" and len(rest) == 1:
                v = rest[0]
                if isinstance(v, bool) or not isinstance(v, int | float | str):
                    raise ExpressionError(f"node {k}: {v!r} is not a number")
                built.append(Expr("num", (float(v),)))
            elif op == "sym" and len(rest) == 1 and isinstance(rest[0], str):
                built.append(Expr("sym", (rest[0],)))
            elif op == "call" and len(rest) == 2 and rest[0] in FUNCTIONS:
                built.append(Expr("call", (rest[0], built[_before(rest[1], k)])))
            elif op in _ARITY and len(rest) == _ARITY[op]:
                built.append(Expr(op, tuple(built[_before(i, k)] for i in rest)))
            else:
                raise ExpressionError(f"node {k}: {str(item)[:80]} is not an expression node")
        if not built:
            raise ExpressionError("no node")
    except (TypeError, IndexError, ValueError) as exc:
        if isinstance(exc, ExpressionError):
            raise
        raise ExpressionError(f"not the data of an expression: {exc}") from None
    return built[-1]


def _before(i, k: int) -> int:
    if isinstance(i, bool) or not isinstance(i, int) or not 0 <= i < k:
        raise ExpressionError(f"node {k}: {i!r} is not the index of an earlier node")
    return i


_OPSYM = {"add": "+", "sub": "-", "mul": "*", "div": "/", "pow": "**"}


def to_string(e: Expr, limit: int = 2000) -> str:
    """Render an expression (fully parenthesised), cut after about ``limit`` characters.

    A shared sub-expression is written out at each use, so the text of a DAG
    can be far longer than the DAG: the cut keeps messages short.
    """
    parts: list[str] = []
    size = 0
    stack: list[object] = [e]
    while stack:
        item = stack.pop()
        if isinstance(item, str):
            parts.append(item)
            size += len(item)
        else:
            op, args = item.op, item.args
            if op == "num":
                stack.append(repr(args[0]))
            elif op == "sym":
                stack.append(args[0])
            elif op == "neg":
                stack.extend([")", args[0], "-("])
            elif op == "call":
                stack.extend([")", args[1], f"{args[0]}("])
            else:
                stack.extend([")", args[1], f" {_OPSYM[op]} ", args[0], "("])
        if size > limit:
            return "".join(parts) + " ..."
    return "".join(parts)


def sign_arguments(e: Expr) -> list[Expr]:
    """The distinct arguments ``h`` of the calls ``sign(h)`` in an expression, in walk order."""
    return [n.args[1] for n in postorder([e]) if n.op == "call" and n.args[0] == "sign"]


def free_symbols(e: Expr) -> set[str]:
    """Names of the symbols an expression depends on."""
    return set(e.free)


def _rebuild(node: Expr, new_kids: list[Expr]) -> Expr:
    op = node.op
    if op == "neg":
        return neg(new_kids[0])
    if op == "call":
        return call(node.args[0], new_kids[0])
    return _REBUILD[op](new_kids[0], new_kids[1])


def substitute(e: Expr, values: Mapping[str, Expr]) -> Expr:
    """Replace symbols by expressions (constants folded on the way)."""
    if not (e.free & values.keys()):
        return e
    out: dict[Expr, Expr] = {}
    for node in postorder([e]):
        if not (node.free & values.keys()):
            out[node] = node
        elif node.op == "sym":
            out[node] = values[node.args[0]]
        else:
            out[node] = _rebuild(node, [out[c] for c in children(node)])
    return out[e]


_REBUILD = {"add": add, "sub": sub, "mul": mul, "div": div, "pow": power}


def replace_nodes(e: Expr, mapping: Mapping[Expr, Expr]) -> Expr:
    """Replace whole sub-expressions (nodes of the DAG) by others (constants folded on the way)."""
    out: dict[Expr, Expr] = {}
    for node in postorder([e]):
        hit = mapping.get(node)
        if hit is not None:
            out[node] = hit
        elif node.op in ("num", "sym"):
            out[node] = node
        else:
            out[node] = _rebuild(node, [out[c] for c in children(node)])
    return out[e]


def diff(e: Expr, name: str) -> Expr:
    """Exact partial derivative of an expression with respect to symbol ``name``."""
    if name not in e.free:
        return ZERO
    # Only the nodes that depend on `name` are visited (the others' derivative is 0): the cost is
    # the size of that part, not of the whole DAG (a sum of N terms is differentiated in each of
    # its N variables in O(N) in all, not O(N^2)).
    d: dict[Expr, Expr] = {}
    for node in postorder_depending(e, {name}):
        op = node.op
        if op == "sym":
            out = ONE
        elif op == "neg":
            out = neg(d.get(node.args[0], ZERO))
        elif op == "add":
            out = add(d.get(node.args[0], ZERO), d.get(node.args[1], ZERO))
        elif op == "sub":
            out = sub(d.get(node.args[0], ZERO), d.get(node.args[1], ZERO))
        elif op == "mul":
            a, b = node.args
            out = add(mul(d.get(a, ZERO), b), mul(a, d.get(b, ZERO)))
        elif op == "div":
            a, b = node.args
            out = sub(div(d.get(a, ZERO), b), div(mul(a, d.get(b, ZERO)), power(b, num(2.0))))
        elif op == "pow":
            a, b = node.args
            da, db = d.get(a, ZERO), d.get(b, ZERO)
            if _is_num(db, 0.0):
                out = mul(mul(b, power(a, sub(b, ONE))), da)
            else:
                out = mul(node, add(mul(db, call("log", a)), div(mul(b, da), a)))
        elif op == "call":
            fname, a = node.args
            out = mul(_dfunc(fname, a), d.get(a, ZERO))
        else:  # pragma: no cover
            raise AssertionError(op)
        d[node] = out
    return d[e]


def postorder_depending(root: Expr, wanted) -> list[Expr]:
    """The distinct nodes under ``root`` whose value depends on a symbol of ``wanted`` (a set of
    names), children first."""
    seen: set[Expr] = set()
    out: list[Expr] = []
    stack: list[tuple[Expr, bool]] = [(root, False)]
    while stack:
        node, expanded = stack.pop()
        if expanded:
            out.append(node)
            continue
        if node in seen:
            continue
        seen.add(node)
        stack.append((node, True))
        for c in reversed(children(node)):
            if c not in seen and c.free & wanted:
                stack.append((c, False))
    return out
