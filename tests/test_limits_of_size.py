"""The limits of size a model meets are the documented ones, each refused with its own error (issue 32).

Every limit of docs/networks.md, "Limits of size", is exceeded here by a small synthetic model:
with the limit itself where a small model reaches it, else with the constant lowered by
``monkeypatch`` (the code path is the real one: the checks read the module's constant when they
run). The counts in the messages are counted here from the model's construction, not read back
from the system.
"""

from __future__ import annotations

import copy
import importlib
import tomllib
from pathlib import Path

import numpy as np
import pytest

import hybrid.model.expr as expr_mod
import hybrid.model.filippov as filippov_mod
import hybrid.model.system as system_mod
import hybrid_models
import hybrid_models.network_cells as cells_mod
import hybrid_models.network_read as read_mod
from hybrid import ExpressionError, ModelError, system_from_dict

DOCS = Path(__file__).resolve().parents[1] / "docs"
MODELS = Path(hybrid_models.__file__).parent

#: The modules whose ``MAX_*`` constants are limits of a model's size (not caches, not figures).
LIMIT_MODULES = {
    "hybrid.model.loader": set(),
    "hybrid.model.expr": set(),
    "hybrid.model.system": {"MAX_SHARED_SYSTEMS", "MAX_TEXT"},  # a cache; MAX_TEXT imported from elements
    "hybrid.model.filippov": {"MAX_COMPONENTS", "MAX_VARIABLES"},  # imported from hybrid.model.system
    "hybrid.model.elements": {"MAX_ANGLE"},  # the range of an angle's value, not of a size
    "hybrid_models.network_read": set(),
    "hybrid_models.network_cells": set(),
}


def _documented() -> dict[str, int]:
    text = (DOCS / "networks.md").read_text()
    section = text[text.index("## Limits of size") :]
    section = section[: section.index("\n## ", 1)]
    out = {}
    for row in section.splitlines():
        if row.startswith("| ") and "`" in row:
            _what, most, where = (c.strip() for c in row.strip("|").split("|"))
            out[where.strip("`")] = int(most.split()[0])
    return out


def test_every_limit_of_size_in_the_code_is_documented_with_its_value():
    # issue 32: the documented limits (10,000 components, 2,000,000 nodes) were unreachable
    # because stricter limits, documented nowhere, fired first; now every limit is in the table
    documented = _documented()
    in_code = {}
    for name, skip in LIMIT_MODULES.items():
        module = importlib.import_module(name)
        for const in dir(module):
            if const.startswith("MAX_") and const not in skip and isinstance(getattr(module, const), int):
                in_code[f"{name}.{const}"] = getattr(module, const)
    assert in_code == documented


def _blocks(n: int, *, forces: int = 1, springs: int = 0, name: str = "blocks") -> dict:
    """N masses, each on a friction contact to ground (N components of 3 local modes and 4
    transitions; variables x_i, v_i, f_i and W, D), ``forces`` forces on the first mass and
    ``springs`` springs from it to ground."""
    data: dict = {
        "model": {"format": "network", "name": name},
        "masses": {f"x{i}": {"mass": "m"} for i in range(n)},
        "friction": {f"h{i}": {"between": ["ground", f"x{i}"], "sliding": "R"} for i in range(n)},
        "springs": {f"s{i}": {"between": ["ground", "x0"], "stiffness": "k"} for i in range(max(springs, 1))},
        "forces": {f"p{i}": {"on": "x0", "amplitude": "F", "frequency": "Omega"} for i in range(forces)},
        "parameters": {
            p: {"unit": u, "domain": "positive"}
            for p, u in (("m", "kg"), ("k", "N/m"), ("R", "N"), ("F", "N"), ("Omega", "rad/s"))
        },
        "presets": {"standard": {"m": 1.0, "k": 1.0, "R": 0.1, "F": 0.5, "Omega": 0.8}},
    }
    return data


def test_the_synthetic_network_is_a_valid_model():
    system = system_from_dict(_blocks(3, forces=2, springs=2))
    assert len(system.components) == 3
    assert len(system.variables) == 3 * 3 + 2


@pytest.mark.parametrize(
    ("module", "const", "value", "model", "message"),
    [
        # network files
        (
            read_mod,
            "MAX_FRICTION",
            3,
            _blocks(4),
            r"\[friction\]: 4 friction elements; at most 3 are allowed",
        ),
        (read_mod, "MAX_POINTS", 3, _blocks(4), r"4 masses and nodes; at most 3 are allowed"),
        (
            read_mod,
            "MAX_ELEMENTS",
            5,
            _blocks(4, springs=2),
            r"6 springs, dampers and friction elements; at most 5 are allowed",
        ),
        (read_mod, "MAX_FORCES", 2, _blocks(1, forces=3), r"\[forces\]: 3 forces; at most 2 are allowed"),
        # the engine's, met by the system a network file derives
        (system_mod, "MAX_COMPONENTS", 3, _blocks(4), r"model `blocks`: 4 components; at most 3 are allowed"),
        (
            system_mod,
            "MAX_VARIABLES",
            13,
            _blocks(4),
            r"model `blocks`: 14 variables; at most 13 are allowed",
        ),
        (system_mod, "MAX_PARAMETERS", 4, _blocks(1), r"model `blocks`: 5 parameters; at most 4 are allowed"),
        (
            system_mod,
            "MAX_LOCAL_MODES",
            11,
            _blocks(4),
            r"model `blocks`: 12 local modes in its components; at most 11 are allowed",
        ),
        (
            system_mod,
            "MAX_LOCAL_TRANSITIONS",
            15,
            _blocks(4),
            r"model `blocks`: 16 transitions in its components; at most 15 are allowed",
        ),
        (
            system_mod,
            "MAX_NODES",
            10,
            _blocks(2),
            r"model `blocks`: its expressions, definitions expanded, have \d+ distinct operations; "
            r"at most 10 are allowed",
        ),
    ],
)
def test_each_limit_of_a_network_refuses_with_its_own_error(
    monkeypatch, module, const, value, model, message
):
    # issue 32: each limit gives its clear error, naming the count and the limit
    monkeypatch.setattr(module, const, value)
    with pytest.raises(ModelError, match=message):
        system_from_dict(copy.deepcopy(model))


def _absorber() -> dict:
    return tomllib.loads((MODELS / "absorber.toml").read_text())


def test_the_limits_on_modes_and_transitions_of_a_modes_file(monkeypatch):
    data = _absorber()
    modes, transitions = len(data["modes"]), len(data["transitions"])
    assert (modes, transitions) == (3, 4)  # stick, slip+, slip-; stick to either slip and back
    monkeypatch.setattr(system_mod, "MAX_MODES", modes - 1)
    with pytest.raises(
        ModelError, match=rf"model `absorber`: {modes} modes; at most {modes - 1} are allowed"
    ):
        system_from_dict(_absorber())
    monkeypatch.setattr(system_mod, "MAX_MODES", modes)
    monkeypatch.setattr(system_mod, "MAX_TRANSITIONS", transitions - 1)
    with pytest.raises(
        ModelError,
        match=rf"model `absorber`: {transitions} transitions; at most {transitions - 1} are allowed",
    ):
        system_from_dict(_absorber())


def test_the_limits_of_one_expression_at_their_real_values():
    # MAX_OPERATORS, MAX_EXPRESSION_LENGTH have tests of their own (tests/hybrid/test_hostile_models.py,
    # tests/hybrid/test_expr.py); here nesting and number literals, at the real limits
    deep = "(" * (expr_mod.MAX_NESTING + 1) + "x" + ")" * (expr_mod.MAX_NESTING + 1)
    with pytest.raises(
        ExpressionError, match=rf"parentheses nested deeper than {expr_mod.MAX_NESTING} levels"
    ):
        expr_mod.parse(deep, {"x"}, "here")
    expr_mod.parse(
        "(" * expr_mod.MAX_NESTING + "x" + ")" * expr_mod.MAX_NESTING, {"x"}, "here"
    )  # at the limit
    long = "1" * (expr_mod.MAX_NUMBER_LENGTH + 1)
    with pytest.raises(ExpressionError, match=rf"at most {expr_mod.MAX_NUMBER_LENGTH} are allowed"):
        expr_mod.parse(long, set(), "here")
    expr_mod.parse("1" * expr_mod.MAX_NUMBER_LENGTH, set(), "here")


def test_the_limit_of_copies_of_a_cell_at_its_real_value():
    data = {
        "model": {"format": "network", "name": "c"},
        "cells": {"block": {"count": cells_mod.MAX_COPIES + 1}},
    }
    with pytest.raises(
        ModelError, match=rf"`count` = {cells_mod.MAX_COPIES + 1}: .* from 1 to {cells_mod.MAX_COPIES}"
    ):
        system_from_dict(data)


def test_the_limit_on_the_terms_of_sign_surfaces(monkeypatch):
    # a file written with sign(): one surface x, whose rate v has one term per differential variable
    data = tomllib.loads((MODELS / "coulomb_sign.toml").read_text())
    system_from_dict(copy.deepcopy(data))
    monkeypatch.setattr(filippov_mod, "MAX_SURFACE_TERMS", 0)
    with pytest.raises(ModelError, match=r"at most 0 "):
        system_from_dict(data)


# ----------------------------------------------------------------------------------------------
# Set-up honours the deadline in force (--max-time): reading the components, the affine analysis
@pytest.mark.slow
def test_reading_a_large_network_stops_at_the_deadline_saying_how_far_it_got():
    # issue 32: a cell of 3000 contacts set up for 587 s past --max-time; the reading of the
    # components (the engine's parse of every local mode) now checks the deadline every 256
    from hybrid import BudgetExceeded, time_limit

    data = _blocks(600)
    with pytest.raises(
        BudgetExceeded,
        match=r"time limit reached: .* ran out while reading the model's components \(\d+ of 600 read\)",
    ):
        with time_limit(1e-3):
            system_from_dict(data)
    assert len(system_from_dict(data).components) == 600  # nothing is left behind


@pytest.mark.slow
def test_the_affine_analysis_of_a_large_network_stops_at_the_deadline():
    from hybrid import BudgetExceeded, time_limit
    from hybrid.integrators.assembly import composed_analysis

    system = system_from_dict(_blocks(100))  # 1 own mode and 3 local modes of 100 parts: 301 forms
    with pytest.raises(
        BudgetExceeded, match=r"ran out while analysing the modes' affine forms \(\d+ of 301 parts done\)"
    ):
        with time_limit(1e-3):
            composed_analysis(system)
    analysis = composed_analysis(system)  # the interrupted analysis is not kept: made anew
    assert len(analysis.analysis.forms) == 301


@pytest.mark.slow
def test_a_mass_on_1200_springs_moves_as_on_one_spring_of_1200_times_the_stiffness():
    # issue 32: within MAX_ELEMENTS, a mass on 3000 springs was refused by a limit the user never
    # met: the builder's parts of the long sum of spring forces had 1333 operators (at most 1000)
    from hybrid import Exact, SolverOptions, simulate

    many = _blocks(1, springs=1200)
    one = _blocks(1)
    many_sys, one_sys = system_from_dict(many), system_from_dict(one)
    opts = SolverOptions(method=Exact())
    runs = []
    for system, k in ((many_sys, 1.0), (one_sys, 1200.0)):
        p = system.preset("standard", k=k, R=5.0)
        x0 = dict.fromkeys(system.variable_names, 0.0)
        x0["x0"] = 0.01  # a spring force of 12 N: the contact slides, then sticks
        tr = simulate(system, p, (0.0, 0.5), x0, options=opts)
        runs.append((tr.final("x0"), tr.final("v_x0"), [e.t for e in tr.events]))
    (xa, va, ea), (xb, vb, eb) = runs
    assert len(ea) == len(eb) >= 1
    np.testing.assert_allclose(ea, eb, rtol=0, atol=1e-12)
    assert abs(xa - xb) <= 1e-12 and abs(va - vb) <= 1e-10
