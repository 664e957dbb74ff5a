"""``gradient`` (one reverse sweep) against ``diff`` (one forward pass per symbol) (issue 32)."""

from __future__ import annotations

import numpy as np
import pytest

from hybrid.model.codegen import compile_many
from hybrid.model.expr import ZERO, diff, parse
from hybrid.model.gradient import gradient

SYMS = ["x", "y", "z", "p"]
CASES = [
    "x + y - z",
    "3*x*y - x/y + (x - z)**2",
    "sin(x*y) + cos(z)*exp(-x) - log(y)",
    "(x*y + z)**2.5 + (x*y + z)*sqrt(y)",  # a shared sub-expression
    "x**y + y**x",  # the exponent depends on the state
    "abs(x - y)*tanh(z) + atan(x/z)",
    "p*(x - y) + p*p",  # p is not wanted below
    "-(-(x)) + 0*y",
    "((((x + y) + z) + x) + y)*((x + 1)/(z + 2))",
]


@pytest.mark.parametrize("text", CASES)
def test_gradient_equals_diff_at_random_points(text):
    e = parse(text, set(SYMS), "test")
    wanted = ["x", "y", "z"]
    grad = gradient(e, wanted)
    assert set(grad) <= set(wanted) & e.free
    rows = [grad.get(s, ZERO) for s in wanted] + [diff(e, s) for s in wanted]
    f = compile_many(rows, {s: i for i, s in enumerate(SYMS)})
    rng = np.random.default_rng(32)
    for _ in range(20):
        v = rng.uniform(0.3, 2.0, size=len(SYMS))
        out = np.array(f(list(v)))
        rev, fwd = out[:3], out[3:]
        np.testing.assert_allclose(rev, fwd, rtol=1e-12, atol=1e-14)


def test_gradient_of_a_long_sum_visits_each_node_once():
    # a chain of 399 additions: every partial is the coefficient, with one sweep
    text = " + ".join(f"{k + 1}*u{k}" for k in range(400))
    names = {f"u{k}" for k in range(400)}
    e = parse(text, names, "test")
    grad = gradient(e, names)
    assert {s: g.args[0] for s, g in grad.items()} == {f"u{k}": float(k + 1) for k in range(400)}
