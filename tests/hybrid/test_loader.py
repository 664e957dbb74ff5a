"""Model files (TOML): a small model loads and simulates; malformed files fail naming the file and item."""

import math
import tomllib
from importlib import resources

import numpy as np
import pytest
from problems import TIGHT, bouncing_ball

import hybrid_models
from hybrid import ModelError, load_system, simulate, system_from_dict

BALL = """\
# bouncing ball
[model]
name = "ball"
title = "Bouncing ball"
initial_mode = "fly"

[variables.h]
unit = "m"
description = "height"
[variables.v]
unit = "m/s"

[parameters.g]
unit = "m/s^2"
domain = "positive"
[parameters.e]
description = "restitution"
domain = "nonnegative"

[presets.earth]
g = 9.81
e = 0.5

[modes.fly]
derivatives = { h = "v", v = "-g" }

[[transitions]]
name = "impact"
source = "fly"
target = "fly"
guard = "h"
direction = -1
reset = { v = "-e*v" }
"""


def _write(tmp_path, text, name="ball.toml"):
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


def test_small_model_file_loads_and_simulates(tmp_path):
    system = load_system(_write(tmp_path, BALL))
    assert system.name == "ball"
    assert system.title == "Bouncing ball"
    assert system.variable_names == ("h", "v")
    assert system.variables[0].unit == "m"
    assert system.variables[0].description == "height"
    assert [p.domain for p in system.parameters] == ["positive", "nonnegative"]
    assert system.transitions[0].reset["v"] == "-e*v"
    assert system.transitions[0].direction == -1
    params = system.preset("earth")
    _, _, x0, exact = bouncing_ball(e=0.5, g=9.81)
    tr = simulate(system, params, (0.0, 1.3), x0, options=TIGHT)  # mode0 from the file
    assert tr.success, tr.message
    assert tr.n_transitions == 5
    ts = np.array([ev.t for ev in tr.events])
    assert np.max(np.abs(ts - exact.impact_time(np.arange(1, 6)))) <= 1e-9


def test_builtin_model_files_round_trip_through_system_from_dict():
    for name in hybrid_models.BUILTIN:
        with resources.as_file(resources.files("models") / f"{name}.toml") as path:
            from_file = load_system(path)
            data = tomllib.loads(path.read_text(encoding="utf-8"))
        assert system_from_dict(data) == from_file
        assert from_file == hybrid_models.BUILTIN[name]()
        if name.endswith("_sign"):  # written with sign(): the entry of the file's mode (issue 12)
            assert from_file.initial_mode == "motion"
        elif from_file.components:  # network files of many contacts (issue 22): one component each
            assert from_file.initial_mode == "motion"
            assert from_file.default_mode == "|".join(["motion"] + ["stick"] * len(from_file.components))
            assert from_file.period == "2*pi/Omega"
        elif name.startswith("belt"):  # the autonomous models of issue 11: no forcing period
            assert from_file.initial_mode in ("stick", "stick_stick")
            assert from_file.period is None
        else:
            assert from_file.initial_mode == "stick"
            assert from_file.period == "2*pi/Omega"


@pytest.mark.parametrize(
    ("edit", "match"),
    [
        # malformed TOML
        (lambda s: s.replace("[modes.fly]", "[modes.fly"), r"is not valid TOML"),
        (lambda s: s.replace('guard = "h"', "guard = h"), r"is not valid TOML"),
        # unknown keys
        (
            lambda s: s + "\n[solver]\nrtol = 1e-6\n",
            r"ball.toml: model file: unknown key\(s\) solver; allowed: ",
        ),
        (
            lambda s: s.replace('title = "Bouncing ball"', 'titel = "x"'),
            r"ball.toml: \[model\]: unknown key\(s\) titel",
        ),
        (
            lambda s: s.replace('unit = "m"\n', 'units = "m"\n', 1),
            r"ball.toml: \[variables.h\]: unknown key\(s\) units; allowed: description, unit",
        ),
        (
            lambda s: s.replace('domain = "positive"', 'range = "positive"'),
            r"ball.toml: \[parameters.g\]: unknown key\(s\) range",
        ),
        (
            lambda s: s.replace("derivatives = {", "derivative = {"),
            r"ball.toml: \[modes.fly\]: unknown key\(s\) derivative; allowed: algebraic, definitions, derivatives",
        ),
        (
            lambda s: s.replace("direction = -1", "dir = -1"),
            r"ball.toml: transition #1: unknown key\(s\) dir",
        ),
        # inconsistent model
        (
            lambda s: s.replace('target = "fly"', 'target = "land"'),
            r"ball.toml: model `ball`: transition `impact` has target mode `land` that does not exist; modes: fly",
        ),
        (
            lambda s: s.replace('source = "fly"', 'source = "air"'),
            r"ball.toml: model `ball`: transition `impact` has source mode `air`",
        ),
        (
            lambda s: s.replace('guard = "h"', 'guard = "h - H0"'),
            r"ball.toml: .*guard of transition `impact`: unknown name `H0`",
        ),
        (
            lambda s: s.replace('v = "-g" }', 'v = "-g^2" }'),
            r"ball.toml: .*mode `fly`: derivative of `v`: forbidden operator `BitXor`.*use \*\* for powers",
        ),
        (
            lambda s: s.replace('v = "-g" }', 'v = "open(g)" }'),
            r"ball.toml: .*derivative of `v`: call of `open` is not allowed",
        ),
        (
            lambda s: s.replace('v = "-g" }', "v = -9.81 }"),
            r"ball.toml: .*derivative of `v`: expected an expression string, got float -9.81",
        ),
        (
            lambda s: s.replace('h = "v", ', ""),
            r"ball.toml: model `ball`: mode `fly` has no equation for variable\(s\) h",
        ),
        (
            lambda s: s.replace("direction = -1", "direction = 2"),
            r"ball.toml: transition `impact`: direction must be -1, 0 or 1, got 2",
        ),
        (
            lambda s: s.replace("e = 0.5", "e = 0.5\nk = 1.0"),
            r"ball.toml: model `ball`: preset `earth` sets unknown parameter `k`",
        ),
        (
            lambda s: s.replace('initial_mode = "fly"', 'initial_mode = "roll"'),
            r"ball.toml: model `ball`: initial mode `roll` does not exist",
        ),
        (lambda s: s.replace('name = "ball"\n', "", 1), r"ball.toml: \[model\] needs a `name`"),
        (lambda s: s.replace('guard = "h"\n', ""), r"ball.toml: transition #1 lacks guard"),
        (
            lambda s: s.replace("[presets.earth]\ng = 9.81\ne = 0.5\n", "[presets]\nearth = 1\n"),
            r"ball.toml: \[presets.earth\] must be a table of parameter values",
        ),
        (
            lambda s: s.replace('[variables.v]\nunit = "m/s"\n', '[variables]\nv = "m/s"\n'),
            r"is not valid TOML|\[variables.v\] must be a table",
        ),
    ],
)
def test_malformed_model_file_names_the_file_and_the_item(tmp_path, edit, match):
    text = edit(BALL)
    assert text != BALL
    with pytest.raises(ModelError, match=match) as info:
        load_system(_write(tmp_path, text))
    assert "ball.toml" in str(info.value)


def test_missing_or_undecodable_file(tmp_path):
    with pytest.raises(ModelError, match=r"model file '.*nothere.toml' does not exist"):
        load_system(tmp_path / "nothere.toml")
    path = tmp_path / "latin1.toml"
    path.write_bytes('[model]\nname = "caf\xe9"\n'.encode("latin-1"))
    with pytest.raises(ModelError, match=r"model file '.*latin1.toml' is not UTF-8 text"):
        load_system(path)
    with pytest.raises(ModelError, match=r"model file '.*ball.toml' is not valid TOML: "):
        load_system(_write(tmp_path, "[model\n"))


def test_model_file_with_slave_variable_and_definitions(tmp_path):
    # The DAE of problems.nonlinear_dae written as a file: definitions, algebraic equations.
    text = """
[model]
name = "dae"
initial_mode = "only"
[variables.x]
[variables.z]
[modes.only]
derivatives = { x = "-z" }
algebraic = { z = "z**3 + z - q**3 - q" }
definitions = { q = "x + sin(t)" }
"""
    system = load_system(_write(tmp_path, text, "dae.toml"))
    assert system.algebraic_variables("only") == ("z",)
    tr = simulate(system, {}, (0.0, 3.0), {"x": 1.0}, t_eval=[3.0], options=TIGHT)
    x = 0.5 * math.exp(-3.0) + (math.cos(3.0) - math.sin(3.0)) / 2
    assert tr.final("x") == pytest.approx(x, abs=1e-9)
    assert tr.final("z") == pytest.approx(x + math.sin(3.0), abs=1e-9)
