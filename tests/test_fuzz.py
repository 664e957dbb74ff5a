"""Fuzz tests (issue 13): the model-file loader and the command line against generated input.

Every input must end in a valid model, a result, or a clean error (ModelError/ValueError from the
library; exit code 0, 1 or 2 with no traceback from the CLI), each within a time limit. The runs
are derandomised (the same inputs in every CI run) and sized to take well under a minute together;
``INPUTS`` counts the inputs tried, for the record.
"""

from __future__ import annotations

import contextlib
import copy
import io
import time
import tomllib
from collections import Counter
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import hybrid_models
from hybrid import FUNCTIONS, IDA, ModelError, SolverOptions, load_system, simulate, system_from_dict
from hybrid.cli import main

MODEL_DIR = Path(hybrid_models.__file__).parent
BASES = {name: tomllib.loads((MODEL_DIR / f"{name}.toml").read_text()) for name in ("coulomb", "absorber")}
INPUTS: Counter = Counter()


@pytest.fixture(scope="module", autouse=True)
def _report_counts():
    yield
    print(f"\nfuzz inputs: {dict(sorted(INPUTS.items()))}, total {sum(INPUTS.values())}")


FUZZ = settings(
    derandomize=True,
    deadline=None,  # the per-input limit is asserted below, on wall time
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large, HealthCheck.filter_too_much],
    database=None,
)
PER_INPUT_SECONDS = 10.0

# ----------------------------------------------------------------------------
# Expressions: a grammar that mixes valid pieces with hostile ones
# ----------------------------------------------------------------------------
NAMES = ["x", "v", "x1", "x2", "u", "m", "k", "R", "F", "Omega", "t", "pi", "H", "nope", "__import__", "os"]
NUMBERS = st.one_of(
    st.sampled_from(
        ["0", "1", "2.5", "1e308", "1e-320", "0.0", "-1", "1e400", "9" * 50, "1_000", "0x1F", "1j"]
    ),
    st.floats(allow_nan=False, allow_infinity=False, width=32).map(repr),
)
BAD = st.sampled_from(
    ["x.__class__", "lambda: 1", "x if x else v", "[x]", "{x: 1}", "x ^ 2", "x // 2", "'s'", "open('f')", "(", ")",
     "x,", "not x", "x < v", "*x", "\\n", "\x00", "\u00e9", "-" * 1500 + "x", "(" * 120 + "x" + ")" * 120,
     "eval('1')", "exec('1')"]  # allowed: hostile input the parser must refuse
)  # fmt: skip


def _expressions() -> st.SearchStrategy[str]:
    leaf = st.one_of(st.sampled_from(NAMES), NUMBERS)
    return st.recursive(
        leaf,
        lambda inner: st.one_of(
            st.tuples(inner, st.sampled_from(["+", "-", "*", "/", "**", " ", ""]), inner).map("".join),
            st.tuples(st.sampled_from(list(FUNCTIONS) + ["exp", "open", "sum"]), inner).map(
                lambda p: f"{p[0]}({p[1]})"
            ),
            inner.map(lambda e: f"-({e})"),
            BAD,
        ),
        max_leaves=12,
    )


EXPR = _expressions()
VALUES = st.one_of(
    EXPR,
    st.integers(min_value=-(10**30), max_value=10**30),
    st.floats(allow_nan=True, allow_infinity=True),
    st.booleans(),
    st.lists(st.sampled_from(["stick", "x", "nope", "slip+", ""]), max_size=3),
    st.dictionaries(st.sampled_from(["x", "v", "u", "nope", "x\n"]), EXPR, max_size=3),
    st.text(max_size=20),
    st.none(),
)


def _paths(data: dict) -> list[tuple]:
    """Every path of keys (and list indices) in a nested model dict."""
    out = []
    stack = [((), data)]
    while stack:
        path, node = stack.pop()
        out.append(path)
        if isinstance(node, dict):
            stack.extend((path + (k,), v) for k, v in node.items())
        elif isinstance(node, list):
            stack.extend((path + (i,), v) for i, v in enumerate(node))
    return out


@st.composite
def mutated_models(draw) -> dict:
    """A shipped model with 1-4 random edits: a value replaced, a key deleted or added."""
    data = copy.deepcopy(BASES[draw(st.sampled_from(sorted(BASES)))])
    for _ in range(draw(st.integers(1, 4))):
        paths = [p for p in _paths(data) if p]
        path = draw(st.sampled_from(paths))
        parent = data
        for key in path[:-1]:
            parent = parent[key]
        action = draw(st.sampled_from(["replace", "replace", "replace", "delete", "add"]))
        if action == "delete":
            del parent[path[-1]]
        elif action == "add" and isinstance(parent, dict):
            parent[draw(st.sampled_from(["name", "x", "extra", "guard", "v", "nope", "1bad", "a b"]))] = draw(
                VALUES
            )
        else:
            parent[path[-1]] = draw(VALUES)
    return data


def _check_clean(exc: BaseException) -> None:
    msg = str(exc)
    assert isinstance(exc, ValueError), f"{type(exc).__name__}: {msg}"
    assert msg and "\n" not in msg and len(msg) < 2000, msg


def _try_run(system) -> str:
    """A short run of a model that loaded: a result (any status) or a clean ValueError."""
    try:
        preset = "standard" if "standard" in system.presets else next(iter(system.presets), None)
        params = system.parameter_values(preset=preset)
        period = system.period_value(params)
        t_end = 0.5 * period if period else 0.5
        tr = simulate(
            system,
            params,
            (0.0, t_end),
            np.zeros(len(system.variable_names)),
            throw=False,
            options=SolverOptions(method=IDA(max_num_steps=5000)),
            max_transitions=200,
        )
    except ValueError as exc:
        _check_clean(exc)
        return "run refused"
    assert tr.message
    return "ran" if tr.success else "run failed"


@pytest.mark.slow
@settings(FUZZ, max_examples=400)
@given(mutated_models())
def test_fuzz_structured_model_edits_end_in_a_model_or_a_clean_error(data):
    t0 = time.perf_counter()
    try:
        system = system_from_dict(data)
    except ModelError as exc:
        _check_clean(exc)
        outcome = "refused"
    else:
        outcome = _try_run(system)
    INPUTS["structured:" + outcome] += 1
    assert time.perf_counter() - t0 < PER_INPUT_SECONDS


@st.composite
def mutated_texts(draw) -> bytes:
    """A shipped model file's bytes with random splices (bytes, lines or expressions)."""
    text = (MODEL_DIR / f"{draw(st.sampled_from(sorted(BASES)))}.toml").read_bytes()
    for _ in range(draw(st.integers(1, 3))):
        i = draw(st.integers(0, len(text)))
        j = min(len(text), i + draw(st.integers(0, 40)))
        piece = draw(
            st.one_of(
                st.binary(max_size=20),
                EXPR.map(lambda e: f'"{e}"'.encode("utf-8", "surrogatepass")),
                st.sampled_from(
                    [b"\n[model]\n", b'\nname = "../x"\n', b"\xef\xbb\xbf", b"[[transitions]]\n", b"=" * 3]
                ),
            )
        )
        text = text[:i] + piece + text[j:]
    return text


@pytest.mark.slow
@settings(FUZZ, max_examples=300)
@given(mutated_texts())
def test_fuzz_model_file_bytes_end_in_a_model_or_a_clean_error(tmp_path_factory, text):
    path = tmp_path_factory.mktemp("fuzz") / "model.toml"
    path.write_bytes(text)
    t0 = time.perf_counter()
    try:
        load_system(path)
        INPUTS["file:loaded"] += 1
    except ModelError as exc:
        _check_clean(exc)
        INPUTS["file:refused"] += 1
    assert time.perf_counter() - t0 < PER_INPUT_SECONDS


# ----------------------------------------------------------------------------
# Command-line arguments
# ----------------------------------------------------------------------------
PLAUSIBLE = st.sampled_from(["0.5", "0.854", "1", "1.17", "2", "10", "100", "1e-3", "1e-9", "1e-12"])
NUMBER_TEXT = st.one_of(
    PLAUSIBLE,
    PLAUSIBLE,
    st.sampled_from(
        ["0", "-1", "1e308", "1e-308", "nan", "inf", "-inf", "1e17", "abc", "", "0.854", "3", "1e9"]
    ),
    st.floats(allow_nan=False, allow_infinity=False, min_value=-1e6, max_value=1e6).map(repr),
)
OPTIONS = st.one_of(
    st.tuples(st.just("--omega"), NUMBER_TEXT),
    st.tuples(st.just("--rtol"), NUMBER_TEXT),
    st.tuples(st.just("--atol"), NUMBER_TEXT),
    st.tuples(st.just("--set"), st.tuples(st.sampled_from(["m1", "m2", "R", "F", "c3", "c1", "k", "nope", "", "R="]), NUMBER_TEXT).map("=".join)),
    st.tuples(st.just("--x0"), st.tuples(st.sampled_from(["x1", "v1", "u", "nope"]), NUMBER_TEXT).map("=".join)),
    st.tuples(st.just("--preset"), st.sampled_from(["standard", "fig3a", "nope", "../x", ""])),
    st.tuples(st.just("--mode0"), st.sampled_from(["stick", "slip+", "nope"])),
    st.tuples(st.just("--samples-per-period"), NUMBER_TEXT),
    st.tuples(st.just("--transient"), NUMBER_TEXT),
    st.tuples(st.just("--bogus"), NUMBER_TEXT),
)  # fmt: skip


@st.composite
def cli_arguments(draw, out: str) -> list[str]:
    command = draw(st.sampled_from(["simulate", "orbit"]))
    model = draw(
        st.sampled_from(["absorber", "coulomb", "isolator"] * 3 + ["nope", "/dev/zero", "../x.toml"])
    )
    argv = [command, model]
    for opt in draw(st.lists(OPTIONS, max_size=3)):
        if command == "simulate" and opt[0] in ("--transient",):
            continue
        argv += list(opt)
    # keep each input cheap: short runs, few periods, a small budget
    argv += ["--out", out, "--no-plot", "--max-time", "5", "--max-steps", "200000"]
    argv += ["--periods", "0.5"] if command == "simulate" else ["--transient", "0"]
    return argv


@pytest.mark.slow
@settings(FUZZ, max_examples=150)
@given(data=st.data())
def test_fuzz_cli_arguments_end_in_exit_code_0_1_2_without_traceback(tmp_path_factory, data):
    out = str(tmp_path_factory.mktemp("cli"))
    argv = data.draw(cli_arguments(out))
    t0 = time.perf_counter()
    stderr = io.StringIO()
    with contextlib.redirect_stderr(stderr), contextlib.redirect_stdout(io.StringIO()):
        try:
            code = main(argv)
        except SystemExit as exc:  # argparse: bad option values
            code = exc.code
    err = stderr.getvalue()
    assert code in (0, 1, 2), (argv, code, err)
    assert "Traceback" not in err, (argv, err)
    if code == 2:
        assert err.strip().splitlines()[-1].startswith(("hybrid: error:", "usage:")) or "error:" in err, err
    INPUTS[f"cli:exit {code}"] += 1
    assert time.perf_counter() - t0 < 3 * PER_INPUT_SECONDS, argv
