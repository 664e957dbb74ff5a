"""Expressions: the whitelist parser, the symbolic derivative, compiled closures and Taylor jets.

References: central finite differences (derivatives), textbook Maclaurin/binomial series and a
partial-fraction formula for atan (Taylor jets), direct ``math`` evaluation (closures).
"""

import cmath
import math

import numpy as np
import pytest

from hybrid import FUNCTIONS, ExpressionError
from hybrid.model.codegen import compile_scalar
from hybrid.model.expr import diff, free_symbols, parse, substitute
from hybrid.model.taylor import taylor_eval

KNOWN = {"x", "y", "t", "k"}
WHERE = "test expression"


# ----------------------------------------------------------------------------
# Parser: everything outside the whitelist is rejected, naming the item
# ----------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("x +", r"syntax error( at column \d+)? in 'x \+'"),
        ("(x", r"syntax error"),
        ("x y", r"syntax error"),
        ("x.__class__", r"forbidden construct `Attribute`"),
        ("x[0]", r"forbidden construct `Subscript`"),
        ("lambda: 1", r"forbidden construct `Lambda`"),
        ("[x for x in y]", r"forbidden construct `ListComp`"),
        ("sum(x for x in y)", r"call of `sum` is not allowed"),
        ("{x: y}", r"forbidden construct `Dict`"),
        ("x if y else k", r"forbidden construct `IfExp`"),
        ("x < y", r"forbidden construct `Compare`"),
        ("(y := 1)", r"forbidden construct `NamedExpr`"),
        ("'abc'", r"forbidden constant 'abc'.*only real numbers"),
        ("x + 'a'", r"forbidden constant 'a'"),
        ("True", r"forbidden constant True"),
        ("1j", r"forbidden constant 1j"),
        ("x ^ 2", r"forbidden operator `BitXor`.*\(use \*\* for powers\)"),
        ("x // 2", r"forbidden operator `FloorDiv`"),
        ("x % 2", r"forbidden operator `Mod`"),
        ("x @ y", r"forbidden operator `MatMult`"),
        ("not x", r"forbidden operator `Not`"),
        ("~x", r"forbidden operator `Invert`"),
        ('__import__("os")', r"call of `__import__` is not allowed"),
        ('open("/etc/passwd")', r"call of `open` is not allowed"),
        ("eval('1')", r"call of `eval` is not allowed"),  # allowed: checks the parser rejects eval
        ("x.real()", r"call of `Attribute\(.*is not allowed"),
        ("sin(x=1)", r"`sin` takes exactly one positional argument"),
        ("sin(x, y)", r"`sin` takes exactly one positional argument"),
        ("sin()", r"`sin` takes exactly one positional argument"),
        ("sin(*x)", r"forbidden construct `Starred`"),
        ("z + 1", r"unknown name `z`"),
        ("sin(q)", r"unknown name `q`"),
        ("__builtins__", r"unknown name `__builtins__`"),
        ("1e400", r"non-finite number"),
        ("", r"empty expression"),
        ("   ", r"empty expression"),
    ],
)
def test_parse_rejects_with_a_message_naming_the_item(text, match):
    with pytest.raises(ExpressionError, match=match) as info:
        parse(text, KNOWN, WHERE)
    assert str(info.value).startswith(WHERE + ":")  # says where the expression stands


def test_unknown_name_message_lists_the_known_names():
    with pytest.raises(ExpressionError, match=r"known names: k, t, x, y, pi"):
        parse("zz", KNOWN, WHERE)


def test_parse_rejects_non_strings_too_long_and_too_deep():
    with pytest.raises(ExpressionError, match=r"expected an expression string, got int 3"):
        parse(3, KNOWN, WHERE)
    with pytest.raises(ExpressionError, match=r"expression of 10003 characters; at most 10000 are allowed"):
        parse("x+" * 5001 + "x", KNOWN, WHERE)


# Issue 13: each limit is checked on the text before ast.parse (whose own limits give
# RecursionError / MemoryError tracebacks: a sum of 3000 terms, 3000 unary minuses, 3000 powers).
@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("+".join(["x"] * 3000), r"more than 1000 operators in one expression"),
        ("-" * 3000 + "x", r"more than 1000 operators"),
        ("x" + "**x" * 3000, r"more than 1000 operators"),
        ("(" * 150 + "x" + ")" * 150, r"parentheses nested deeper than 100 levels"),
        ("sin(" * 101 + "x" + ")" * 101, r"parentheses nested deeper than 100 levels"),
        ("1" * 401, r"number literal 1111.* has 401 characters; at most 40"),
        ("x + 0." + "0" * 60 + "1", r"number literal .* at most 40"),
    ],
)
def test_parse_limits_are_checked_before_the_parser(text, match):
    with pytest.raises(ExpressionError, match=match) as info:
        parse(text, KNOWN, WHERE)
    assert str(info.value).startswith(WHERE + ":")


def test_long_flat_sums_and_chains_within_the_limits_parse_without_recursion():
    # 1000 terms / 999 unary minuses: an AST 1000 levels deep, walked iteratively
    e = parse("+".join(["x"] * 1000), KNOWN, WHERE)
    assert compile_scalar(e, {"x": 0}, {})([0.5]) == 500.0
    assert compile_scalar(parse("-" * 999 + "x", KNOWN, WHERE), {"x": 0}, {})([2.0]) == -2.0
    assert diff(e, "x") == parse("1000", set(), WHERE)


def test_number_literals_up_to_the_limit_are_exact_floats():
    assert parse("1" + "0" * 39, set(), WHERE) == parse("1e39", set(), WHERE)
    with pytest.raises(ExpressionError, match=r"non-finite number"):
        parse("1e999", KNOWN, WHERE)


def test_parse_folds_constants_and_knows_pi():
    assert parse("2*pi", set(), WHERE) == parse(repr(2 * math.pi), set(), WHERE)
    e = parse("0*x + 1*y - (k - k) + x**1 + y**0", KNOWN, WHERE)
    assert free_symbols(e) == {"x", "y"}
    assert compile_scalar(e, {"x": 0, "y": 1}, {})([3.0, 5.0]) == pytest.approx(9.0, rel=1e-15)


def test_constant_folding_never_leaks_a_type_error():
    # Python evaluates (-8)**(1/3) to a complex number; the parser must either keep the real-number
    # contract with an ExpressionError or leave the power unfolded, not raise TypeError from float().
    for text in ("(-8)**(1/3)", "x + (-1)**0.5"):
        try:
            parse(text, KNOWN, WHERE)
        except ExpressionError:
            pass


def test_string_form_parses_back_to_the_same_tree():
    for text in [
        "-(x - 2.5)**3/(1 + y**2) + sin(t)*exp(-k*t)",
        "abs(x) - sign(y)*sqrt(1e-3 + x**2)",
        "-x**-2 + atan(y/x) - tanh(-t)",
    ]:
        e = parse(text, KNOWN, WHERE)
        assert parse(str(e), KNOWN, WHERE) == e
        assert hash(parse(str(e), KNOWN, WHERE)) == hash(e)


def test_substitute_and_free_symbols():
    e = parse("x*y + sin(t)", KNOWN, WHERE)
    assert free_symbols(e) == {"x", "y", "t"}
    s = substitute(e, {"y": parse("2*k", KNOWN, WHERE), "t": parse("0", set(), WHERE)})
    assert free_symbols(s) == {"x", "k"}
    assert compile_scalar(s, {"x": 0, "k": 1}, {})([1.5, 4.0]) == pytest.approx(12.0, rel=1e-15)


# ----------------------------------------------------------------------------
# Symbolic derivative against central finite differences
# ----------------------------------------------------------------------------
DIFF_CASES = [
    "sin(x)*cos(y) + tan(x*y)",
    "exp(-x**2)*log(1 + y**2)",
    "sqrt(1 + x**2 + y**4)/(2 + cosh(x))",
    "sinh(x*y) - tanh(x - y)**3",
    "atan(x/y) + abs(x - 2*y)*sign(x + y)",
    "x**y",
    "(x + 1)**2.5 - y**-1.5",
    "1/(x - y) - x/(y**2 + 1)",
    "log(x)*exp(y)*sin(t)",
    "-(-x) + +y - pi*x*t",
    "abs(sin(x))**3 + sign(y)*y**2",
    "tan(atan(x) + y) - sqrt(x)*log(y)",
    "exp(sin(x*y*t))/cos(x)",
    "k*x**3 - 2**x + y**(x*t)",
]
POINTS = [
    {"x": 0.7, "y": 1.3, "t": 0.4, "k": -1.1},
    {"x": 1.9, "y": 0.6, "t": -0.8, "k": 2.5},
]
SLOTS = {"x": 0, "y": 1, "t": 2, "k": 3}


def _fd(f, v, i, h):
    """Fourth-order central difference of f along coordinate i."""

    def at(d):
        w = list(v)
        w[i] += d
        return f(w)

    return (-at(2 * h) + 8 * at(h) - 8 * at(-h) + at(-2 * h)) / (12 * h)


def test_diff_cases_use_every_whitelisted_function():
    used = set()
    for text in DIFF_CASES:
        used |= {fn for fn in FUNCTIONS if fn + "(" in text}
    assert used == set(FUNCTIONS)


@pytest.mark.parametrize("text", DIFF_CASES)
@pytest.mark.parametrize("point", POINTS, ids=["p0", "p1"])
def test_diff_matches_central_finite_differences(text, point):
    e = parse(text, KNOWN, WHERE)
    f = compile_scalar(e, SLOTS, {})
    v = [point[n] for n in SLOTS]
    for name, i in SLOTS.items():
        d = diff(e, name)
        got = compile_scalar(d, SLOTS, {})(v)
        h = 1e-3 * max(1.0, abs(v[i]))
        want = _fd(f, v, i, h)
        scale = max(abs(want), 1e-3 * max(1.0, abs(f(v))))
        assert abs(got - want) <= 1e-7 * scale, (text, name, got, want)
        if name not in free_symbols(e):
            assert d.op == "num"
            assert d.args[0] == 0.0


def test_diff_of_constants_and_absent_symbols_is_exactly_zero():
    e = parse("sin(x)*y", KNOWN, WHERE)
    assert diff(e, "t") == parse("0", set(), WHERE)
    assert diff(parse("3*pi", set(), WHERE), "x") == parse("0", set(), WHERE)
    # d/dx x**2 = 2*x exactly, with no log(x) term (x may be negative)
    d = diff(parse("x**2", KNOWN, WHERE), "x")
    assert "log" not in str(d)
    assert compile_scalar(d, SLOTS, {})([-3.0, 0, 0, 0]) == -6.0


# ----------------------------------------------------------------------------
# Taylor jets against known series
# ----------------------------------------------------------------------------
K = 11  # coefficients 0..10


def _jet(value, slope=1.0):
    a = np.zeros(K)
    a[0], a[1] = value, slope
    return a


def _binom(alpha, k):
    out = 1.0
    for j in range(k):
        out *= (alpha - j) / (j + 1)
    return out


def _atan_series(a):
    """atan(a + s): atan(a) + sum_k c_k s^(k+1)/(k+1), c_k from 1/(1+z^2) = Im(1/(z - i))."""
    out = [math.atan(a)]
    for k in range(K - 1):
        # 1/(1 + z^2) = (1/(2i)) (1/(z - i) - 1/(z + i)); expand each pole around z = a
        ck = ((-1) ** k) * ((a - 1j) ** (-(k + 1)) - (a + 1j) ** (-(k + 1))) / (2j)
        out.append(ck.real / (k + 1))
    return np.array(out)


def _series_cases():
    f = math.factorial
    r = range(K)
    z = 1 + 1j
    return [
        ("sin(2*t + 1)", {}, [math.sin(1 + k * math.pi / 2) * 2**k / f(k) for k in r]),
        ("exp(t)*cos(t)", {}, [(z**k).real / f(k) for k in r]),
        ("1/(1 + t**2)", {}, [(-1) ** (k // 2) if k % 2 == 0 else 0.0 for k in r]),
        ("sqrt(1 + t)", {}, [_binom(0.5, k) for k in r]),
        ("(1 + t)**0.5", {}, [_binom(0.5, k) for k in r]),
        ("atan(t)", {}, [0.0 if k % 2 == 0 else (-1) ** (k // 2) / k for k in r]),
        ("atan(t + 0.5)", {}, list(_atan_series(0.5))),
        ("atan(x)", {"x": _jet(-1.7)}, list(_atan_series(-1.7))),
        ("tanh(t)", {}, [0, 1, 0, -1 / 3, 0, 2 / 15, 0, -17 / 315, 0, 62 / 2835, 0]),
        ("tan(t)", {}, [0, 1, 0, 1 / 3, 0, 2 / 15, 0, 17 / 315, 0, 62 / 2835, 0]),
        ("x**2.5", {"x": _jet(1.3)}, [1.3**2.5 * _binom(2.5, k) / 1.3**k for k in r]),
        ("x**3", {"x": _jet(-2.0)}, [-8.0, 12.0, -6.0, 1.0] + [0.0] * (K - 4)),
        ("x**-2", {"x": _jet(2.0)}, [(k + 1) * (-1) ** k / 2.0 ** (k + 2) for k in r]),
        ("x**-2", {"x": _jet(-2.0)}, [(k + 1) / 2.0 ** (k + 2) for k in r]),
        ("x**17", {"x": _jet(-1.5)}, [math.comb(17, k) * (-1.5) ** (17 - k) for k in r]),
        ("log(1 + t)", {}, [0.0] + [(-1) ** (k + 1) / k for k in range(1, K)]),
        ("log(x)", {"x": _jet(2.0, -1.0)}, [math.log(2.0)] + [-1.0 / (k * 2.0**k) for k in range(1, K)]),
        ("sinh(t) + cosh(2*t)", {}, [((k % 2) + (1 - k % 2) * 2**k) / f(k) for k in r]),
        ("exp(-t)*sin(t)", {}, [(cmath.exp(0) * (-1 + 1j) ** k).imag / f(k) for k in r]),
        ("abs(t - 2)", {}, [2.0, -1.0] + [0.0] * (K - 2)),
        ("sign(t - 2)*t", {}, [0.0, -1.0] + [0.0] * (K - 2)),
        ("k*t/(1 - t)", {"k": 3.0}, [0.0] + [3.0] * (K - 1)),
    ]


@pytest.mark.parametrize(
    ("text", "env", "want"),
    [
        pytest.param(*case, id=f"{i}:{case[0]}@{case[1]['x'][0] if 'x' in case[1] else 0}")
        for i, case in enumerate(_series_cases())
    ],
)
def test_taylor_eval_matches_known_series(text, env, want):
    e = parse(text, KNOWN, WHERE)
    full = {"t": _jet(0.0), **env}
    got = taylor_eval(e, full)
    want = np.asarray(want, dtype=float)
    assert got.shape == (K,)
    assert np.all(np.abs(got - want) <= 1e-12 * np.maximum(1.0, np.abs(want))), (got, want)


def test_taylor_eval_zero_order_term_is_the_compiled_value():
    # Every function at a generic point: coefficient 0 equals the compiled closure's value.
    for text in DIFF_CASES:
        e = parse(text, KNOWN, WHERE)
        p = POINTS[0]
        env = {n: _jet(p[n], 0.3 * (i + 1)) for i, n in enumerate(SLOTS)}
        value = compile_scalar(e, SLOTS, {})([p[n] for n in SLOTS])
        assert taylor_eval(e, env)[0] == pytest.approx(value, rel=1e-13, abs=1e-15)


def test_taylor_first_coefficient_is_the_directional_derivative():
    # d/ds f(p + s*w) at s = 0 = grad f . w, with grad from diff (two independent code paths).
    w = {"x": 0.3, "y": -0.7, "t": 1.1, "k": 0.2}
    for text in DIFF_CASES:
        e = parse(text, KNOWN, WHERE)
        p = POINTS[1]
        env = {n: _jet(p[n], w[n]) for n in SLOTS}
        v = [p[n] for n in SLOTS]
        want = sum(compile_scalar(diff(e, n), SLOTS, {})(v) * w[n] for n in SLOTS)
        assert taylor_eval(e, env)[1] == pytest.approx(want, rel=1e-11, abs=1e-13), text


# ----------------------------------------------------------------------------
# Compiled closures against direct evaluation
# ----------------------------------------------------------------------------
def test_compile_scalar_matches_direct_math_evaluation():
    params = {"F": 0.45, "Omega": 0.854, "c1": 1.0, "c2": 0.1, "m1": 1.3}
    text = "(F*sin(Omega*t) - c1*x1 - c2*(x1 - u))/m1 + x1**2 - u**3 + exp(-abs(u))*atan(x1/u)"
    e = parse(text, {"t", "x1", "u", *params}, WHERE)
    slots = {"t": 0, "x1": 1, "u": 2}
    f = compile_scalar(e, slots, params)
    rng = np.random.default_rng(1)
    for t, x1, u in rng.uniform(-2, 2, size=(50, 3)):
        want = (
            (params["F"] * math.sin(params["Omega"] * t) - params["c1"] * x1 - params["c2"] * (x1 - u))
            / params["m1"]
            + x1**2
            - u**3
            + math.exp(-abs(u)) * math.atan(x1 / u)
        )
        assert f([t, x1, u]) == pytest.approx(want, rel=1e-14, abs=1e-14)


@pytest.mark.parametrize("fn", FUNCTIONS)
def test_compile_scalar_of_each_function(fn):
    e = parse(f"{fn}(x*y)", KNOWN, WHERE)
    f = compile_scalar(e, {"x": 0, "y": 1}, {})
    direct = {"abs": abs, "sign": lambda v: math.copysign(1.0, v) if v else 0.0}.get(fn) or getattr(math, fn)
    for x, y in [(0.3, 1.7), (1.1, 0.4), (-0.2, -2.0)]:
        if fn in ("log", "sqrt") and x * y <= 0:
            continue
        assert f([x, y]) == direct(x * y)


def test_compile_scalar_needs_a_slot_for_every_symbol():
    e = parse("x + y", KNOWN, WHERE)
    with pytest.raises(ExpressionError, match=r"symbol `y` has no value at run time"):
        compile_scalar(e, {"x": 0}, {})
