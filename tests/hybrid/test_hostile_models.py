"""Hostile and careless model files (issue 13): clean errors in bounded time and memory.

Each case was a hang, a traceback or a silent misbehaviour before; each must now end in a valid
model or a ModelError naming the file, the item and the limit.
"""

import os
import time
import tracemalloc

import numpy as np
import pytest

from hybrid import ModelError, load_system, simulate, system_from_dict
from hybrid.model.expr import MAX_OPERATORS, count_nodes
from hybrid.model.loader import MAX_FILE_BYTES
from hybrid.model.system import MAX_DEFINITIONS

COULOMB_LIKE = """\
[model]
name = "osc"
initial_mode = "free"
{extra_model}

[variables.x]
unit = "m"
[variables.v]
unit = "m/s"

[parameters.k]
domain = "positive"

[presets.standard]
k = 1.0

[definitions]
{definitions}

[modes.free]
derivatives = {{ x = "v", v = "{accel}" }}
{tail}
"""


def _model(tmp_path, *, extra_model="", definitions="", accel="-k*x", tail="", name="osc.toml", prefix=""):
    text = prefix + COULOMB_LIKE.format(
        extra_model=extra_model, definitions=definitions, accel=accel, tail=tail
    )
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


def test_squaring_definitions_expand_as_a_dag_in_linear_time(tmp_path):
    # a_k = a_{k-1}*a_{k-1}, 40 levels: 2**40 leaves as a tree (the 20 levels ran > 60 s,
    # 495 MB and rising); as a DAG 40 nodes. The value is x**(2**40), checked at x = 1 and x < 1.
    defs = 'a0 = "x"\n' + "".join(f'a{k} = "a{k - 1}*a{k - 1}"\n' for k in range(1, 41))
    t0 = time.perf_counter()
    system = load_system(
        _model(tmp_path, definitions=defs, accel="-k*x + a40 - a40", extra_model='outputs = ["a40"]')
    )
    tr = simulate(system, {"k": 1.0}, (0.0, 1.0), {"x": 1.0, "v": 0.0}, t_eval=[0.0])
    assert time.perf_counter() - t0 < 5.0
    assert tr["a40"][0] == 1.0
    data = system.parsed.modes["free"]["defs"]["a40"]
    assert count_nodes([data]) == 41  # 40 products and the symbol x
    tr2 = simulate(system, {"k": 1.0}, (0.0, 1.0), {"x": 1.0 - 2.0**-45, "v": 0.0}, t_eval=[0.0])
    assert tr2["a40"][0] == pytest.approx((1.0 - 2.0**-45) ** (2.0**40), rel=1e-9)


def test_long_chain_of_definitions_loads_and_runs(tmp_path):
    # c_k = c_{k-1} + 1 for 3000 levels: deeper than Python's recursion limit, walked iteratively
    n = 3000
    defs = 'c0 = "x"\n' + "".join(f'c{k} = "c{k - 1} + 1"\n' for k in range(1, n))
    system = load_system(_model(tmp_path, definitions=defs, accel=f"-k*(c{n - 1} - {n - 1})"))
    tr = simulate(system, {"k": 1.0}, (0.0, np.pi / 2), {"x": 1.0, "v": 0.0}, t_eval=[np.pi / 2])
    assert tr.y[-1, 0] == pytest.approx(0.0, abs=1e-6)  # cos(pi/2): the chain is x itself
    assert tr.y[-1, 1] == pytest.approx(-1.0, rel=1e-6)


def test_many_unused_definitions_load_in_linear_time(tmp_path):
    # loading was about quadratic in the number of definitions (300 000 took > 120 s)
    def timed(n):
        defs = "".join(f'd{k} = "x*{k} + v"\n' for k in range(n))
        path = _model(tmp_path, definitions=defs, name=f"m{n}.toml")
        t0 = time.perf_counter()
        load_system(path)
        return time.perf_counter() - t0

    small, large = timed(1000), timed(8000)
    assert large < 8 * 3 * small + 0.5  # linear with a generous factor, not quadratic (64x)


def test_too_many_definitions_is_refused_naming_the_limit(tmp_path):
    defs = "".join(f'd{k} = "x"\n' for k in range(MAX_DEFINITIONS + 1))
    with pytest.raises(
        ModelError, match=rf"osc.toml: model `osc`: {MAX_DEFINITIONS + 1} definitions; at most"
    ):
        load_system(_model(tmp_path, definitions=defs))


def test_file_size_is_checked_before_reading(tmp_path):
    # a 2 GB sparse file took 20 s and 4.2 GB of memory before "not valid TOML"
    path = tmp_path / "huge.toml"
    with path.open("wb") as fh:
        fh.truncate(2 << 30)
    tracemalloc.start()
    t0 = time.perf_counter()
    with pytest.raises(
        ModelError, match=rf"huge.toml' has {2 << 30} bytes; at most {MAX_FILE_BYTES} are allowed"
    ):
        load_system(path)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert time.perf_counter() - t0 < 1.0
    assert peak < 10 << 20


def test_device_behind_a_symlink_is_not_a_regular_file(tmp_path):
    link = tmp_path / "zero.toml"
    os.symlink("/dev/zero", link)
    with pytest.raises(ModelError, match=r"zero.toml' is not a regular file"):
        load_system(link)


def test_utf8_byte_order_mark_is_accepted(tmp_path):
    system = load_system(_model(tmp_path, prefix="\ufeff"))
    assert system.name == "osc"


def test_reference_model_is_valid(tmp_path):
    assert load_system(_model(tmp_path)).name == "osc"


@pytest.mark.parametrize(
    ("edit", "match"),
    [
        (
            ('name = "osc"', 'name = "../../../../elsewhere/escaped"'),
            r"model name '\.\./\.\./.*' is not allowed",
        ),
        (('name = "osc"', 'name = "/tmp/abs"'), r"model name '/tmp/abs' is not allowed"),
        (('name = "osc"', 'name = "a.b"'), r"model name 'a.b' is not allowed"),
        (('name = "osc"', 'name = ""'), r"model name '' is not allowed"),
        (('name = "osc"', 'name = "x\\ny"'), r"model name 'x\\ny' is not allowed"),
        (("[variables.x]", '[variables."x\\n"]'), r"invalid variable name 'x\\n'"),
        (('unit = "m"\n', 'unit = "m\\u0007"\n'), r"unit of variable `x` 'm\\x07' must be printable text"),
        (("[presets.standard]", '[presets."../p"]'), r"preset name '\.\./p' is not allowed"),
        (
            ("[modes.free]", "[orbit]\nstick_modes = 5\n[modes.free]"),
            r"\[orbit\] `stick_modes` is no longer read: every orbit reports the fraction of the period in each mode",
        ),
        (
            ("[modes.free]", '[plot]\nforse = "x"\n[modes.free]'),
            r"\[plot\] has unknown key\(s\) forse; allowed: displacements",
        ),
        (("[modes.free]", "[plot]\nforce = 3\n[modes.free]"), r"plot `force` must be a name, got 3"),
        (("[modes.free]", "[energy]\ninput = 3\n[modes.free]"), r"energy `input` must be a name, got 3"),
        (
            ('v = "-k*x"', 'v = "-k*x + ' + "+".join(["x"] * (MAX_OPERATORS + 5)) + '"'),
            r"derivative of `v`: more than 1000 operators",
        ),
        (
            ('v = "-k*x"', 'v = "-k*x + ' + "1" * 401 + '"'),
            r"derivative of `v`: number literal 1111.* 401 characters",
        ),
        (('v = "-k*x"', 'v = "' + "-" * 3000 + 'x"'), r"more than 1000 operators"),
    ],
)
def test_hostile_items_are_refused_naming_file_item_and_limit(tmp_path, edit, match):
    path = _model(tmp_path)
    text = path.read_text()
    assert edit[0] in text
    path.write_text(text.replace(edit[0], edit[1], 1))
    with pytest.raises(ModelError, match=match) as info:
        load_system(path)
    msg = str(info.value)
    assert msg.startswith("osc.toml: ") or msg.startswith("model file")
    assert "\n" not in msg
    assert len(msg) < 600


def test_names_and_limits_apply_to_systems_built_in_python_too():
    base = {
        "model": {"name": "ok", "initial_mode": "m"},
        "variables": {"x": {}},
        "parameters": {},
        "modes": {"m": {"derivatives": {"x": "-x"}}},
    }
    assert system_from_dict(base).name == "ok"
    with pytest.raises(ModelError, match=r"model name 'a/b' is not allowed"):
        system_from_dict({**base, "model": {"name": "a/b"}})
    with pytest.raises(ModelError, match=r"definitions form a cycle: a -> b -> a"):
        system_from_dict({**base, "definitions": {"a": "b", "b": "a"}})
