"""All first partial derivatives of an expression at once, by one reverse sweep over its DAG.

:func:`hybrid.model.expr.diff` differentiates in one symbol, visiting the nodes that depend on it;
for a row that depends on many symbols (the momentum balance of a mass held by N contacts, an
energy summed over N springs) one ``diff`` per symbol walks, for each symbol, the path from its
leaf to the root: N^2 in a chain of additions. :func:`gradient` propagates the adjoint of each node
from the root down once (issue 32: the set-up of 1000 contacts).
"""

from __future__ import annotations

from .expr import (
    ONE,
    Expr,
    _dfunc,
    _is_num,
    add,
    call,
    div,
    mul,
    neg,
    num,
    postorder_depending,
    power,
    sub,
)

__all__ = ["gradient"]


def gradient(e: Expr, names) -> dict[str, Expr]:
    """Exact partial derivatives of ``e`` with respect to each symbol of ``names`` it depends on,
    by one reverse sweep over the DAG (``diff`` once per symbol walks, for each symbol, the path
    from its leaf to the root: a sum of N terms, differentiated in its N variables, costs N^2 in a
    chain of additions; here N). The derivatives equal :func:`diff`'s as expressions of the same
    value, not always the same nodes (issue 32: the set-up of 1000 contacts).

    Parameters
    ----------
    e : Expr
    names : container of str
        The symbols wanted (others are constants here); a set or a dict's keys (membership is
        asked, the container is not walked).

    Returns
    -------
    dict of str to Expr
        One entry per symbol of ``names`` in ``e``'s free symbols whose derivative is not the
        constant zero.
    """
    wanted = frozenset(s for s in e.free if s in names)  # `names` may be large: its size is not walked
    if not wanted:
        return {}
    adj: dict[Expr, Expr] = {e: ONE}

    def acc(c: Expr, v: Expr) -> None:
        if not (c.free & wanted) or _is_num(v, 0.0):
            return
        old = adj.get(c)
        adj[c] = v if old is None else add(old, v)

    out: dict[str, Expr] = {}
    for node in reversed(postorder_depending(e, wanted)):
        a = adj.get(node)
        if a is None:
            continue
        op = node.op
        if op == "sym":
            if not _is_num(a, 0.0):
                out[node.args[0]] = a
        elif op == "neg":
            acc(node.args[0], neg(a))
        elif op == "add":
            acc(node.args[0], a)
            acc(node.args[1], a)
        elif op == "sub":
            acc(node.args[0], a)
            acc(node.args[1], neg(a))
        elif op == "mul":
            x, y = node.args
            acc(x, mul(a, y))
            acc(y, mul(a, x))
        elif op == "div":
            x, y = node.args
            acc(x, div(a, y))
            acc(y, neg(div(mul(a, x), power(y, num(2.0)))))
        elif op == "pow":
            x, y = node.args
            acc(x, mul(a, mul(y, power(x, sub(y, ONE)))))
            if y.free & wanted:
                acc(y, mul(a, mul(node, call("log", x))))
        elif op == "call":
            fname, x = node.args
            acc(x, mul(a, _dfunc(fname, x)))
        else:  # pragma: no cover
            raise AssertionError(op)
    return out
