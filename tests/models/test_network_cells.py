"""Repeated structures in network files (issue 22, item 4): a cell declared once and repeated as a
chain or a ring, with per-copy parameters, expands to the same system as its elements written out by
hand; bad cells are refused naming the cell, the copy and the problem."""

from __future__ import annotations

import copy
import tomllib
from pathlib import Path

import pytest

import hybrid_models
from hybrid import ModelError, system_from_dict
from hybrid_models.network import describe, read_network

MODEL_DIR = Path(hybrid_models.__file__).parent

PARAMS = """
[parameters.m]
domain = "positive"
[parameters.k]
domain = "positive"
[parameters.kc]
domain = "positive"
[parameters.c]
domain = "nonnegative"
[parameters.F]
domain = "nonnegative"
[parameters.Omega]
domain = "positive"
"""

CHAIN_CELL = (
    """
[model]
format = "network"
name = "chain"

[cells.block]
count = 3

[cells.block.masses.x]
mass = "m"
velocity = "v"
[cells.block.springs.anchor]
between = ["ground", "x"]
stiffness = "k"
[cells.block.springs.coupling]
between = ["x", "next.x"]
stiffness = "kc"
[cells.block.dampers.damping]
between = ["ground", "x"]
coefficient = "c"
[cells.block.friction.contact]
between = ["ground", "x"]
sliding = "R"
[cells.block.forces.drive]
on = "x"
amplitude = "F"
frequency = "Omega"
[cells.block.parameters.R]
unit = "N"
description = "friction level"
domain = "positive"
"""
    + PARAMS
    + """
[presets.standard]
m = 1.0
k = 1.0
kc = 1.0
c = 0.1
F = 1.0
Omega = 1.0
[presets.standard.block]
R = { alternating = [0.27, 0.33] }
"""
)

# the same chain, every element written out (in the order the cell's copies are written out: copy by
# copy, and in each copy the cell's items in file order)
CHAIN_BY_HAND = (
    """
[model]
format = "network"
name = "chain"

[masses.x_1]
mass = "m"
velocity = "v_1"
[masses.x_2]
mass = "m"
velocity = "v_2"
[masses.x_3]
mass = "m"
velocity = "v_3"

[springs.anchor_1]
between = ["ground", "x_1"]
stiffness = "k"
[springs.coupling_1]
between = ["x_1", "x_2"]
stiffness = "kc"
[springs.anchor_2]
between = ["ground", "x_2"]
stiffness = "k"
[springs.coupling_2]
between = ["x_2", "x_3"]
stiffness = "kc"
[springs.anchor_3]
between = ["ground", "x_3"]
stiffness = "k"

[dampers.damping_1]
between = ["ground", "x_1"]
coefficient = "c"
[dampers.damping_2]
between = ["ground", "x_2"]
coefficient = "c"
[dampers.damping_3]
between = ["ground", "x_3"]
coefficient = "c"

[friction.contact_1]
between = ["ground", "x_1"]
sliding = "R_1"
[friction.contact_2]
between = ["ground", "x_2"]
sliding = "R_2"
[friction.contact_3]
between = ["ground", "x_3"]
sliding = "R_3"

[forces.drive_1]
on = "x_1"
amplitude = "F"
frequency = "Omega"
[forces.drive_2]
on = "x_2"
amplitude = "F"
frequency = "Omega"
[forces.drive_3]
on = "x_3"
amplitude = "F"
frequency = "Omega"
"""
    + PARAMS
    + """
[parameters.R_1]
unit = "N"
description = "friction level (cell block, copy 1)"
domain = "positive"
[parameters.R_2]
unit = "N"
description = "friction level (cell block, copy 2)"
domain = "positive"
[parameters.R_3]
unit = "N"
description = "friction level (cell block, copy 3)"
domain = "positive"

[presets.standard]
m = 1.0
k = 1.0
kc = 1.0
c = 0.1
F = 1.0
Omega = 1.0
R_1 = 0.27
R_2 = 0.33
R_3 = 0.27
"""
)


def test_a_chain_cell_expands_to_the_system_of_its_elements_written_by_hand():
    cells = system_from_dict(tomllib.loads(CHAIN_CELL))
    by_hand = system_from_dict(tomllib.loads(CHAIN_BY_HAND))
    assert cells == by_hand  # every field: variables, parameters, presets, equations, components, ...
    assert [c.name for c in cells.components] == ["contact_1", "contact_2", "contact_3"]
    assert cells.preset("standard")["R_2"] == 0.33
    # and the shipped chain at 3 blocks is this one (bk_chain.toml's cell is the same)
    shipped = tomllib.loads((MODEL_DIR / "bk_chain.toml").read_text())
    shipped["cells"]["block"]["count"] = 3
    assert system_from_dict(shipped).equations == cells.equations


RING_CELL = """
[model]
format = "network"
name = "ring"

[cells.blade]
count = 3
layout = "ring"
[cells.blade.masses.x]
mass = "m"
[cells.blade.springs.root]
between = ["ground", "x"]
stiffness = "k"
[cells.blade.nodes.p]
[cells.blade.springs.contact]
between = ["x", "p"]
stiffness = "kd*(1 + 0.1*i/N)"
[cells.blade.friction.damper]
between = ["p", "next.x"]
sliding = "R"
[cells.blade.forces.drive]
on = "x"
amplitude = "F"
frequency = "Omega"
phase = "-2*pi*(i - 1)/N"

[parameters.m]
domain = "positive"
[parameters.k]
domain = "positive"
[parameters.kd]
domain = "positive"
[parameters.R]
domain = "positive"
[parameters.F]
[parameters.Omega]
domain = "positive"
"""

RING_BY_HAND = """
[model]
format = "network"
name = "ring"

[masses.x_1]
mass = "m"
[masses.x_2]
mass = "m"
[masses.x_3]
mass = "m"
[nodes.p_1]
[nodes.p_2]
[nodes.p_3]

[springs.root_1]
between = ["ground", "x_1"]
stiffness = "k"
[springs.contact_1]
between = ["x_1", "p_1"]
stiffness = "kd*(1 + 0.1*(1)/(3))"
[springs.root_2]
between = ["ground", "x_2"]
stiffness = "k"
[springs.contact_2]
between = ["x_2", "p_2"]
stiffness = "kd*(1 + 0.1*(2)/(3))"
[springs.root_3]
between = ["ground", "x_3"]
stiffness = "k"
[springs.contact_3]
between = ["x_3", "p_3"]
stiffness = "kd*(1 + 0.1*(3)/(3))"

[friction.damper_1]
between = ["p_1", "x_2"]
sliding = "R"
[friction.damper_2]
between = ["p_2", "x_3"]
sliding = "R"
[friction.damper_3]
between = ["p_3", "x_1"]
sliding = "R"

[forces.drive_1]
on = "x_1"
amplitude = "F"
frequency = "Omega"
phase = "-2*pi*((1) - 1)/(3)"
[forces.drive_2]
on = "x_2"
amplitude = "F"
frequency = "Omega"
phase = "-2*pi*((2) - 1)/(3)"
[forces.drive_3]
on = "x_3"
amplitude = "F"
frequency = "Omega"
phase = "-2*pi*((3) - 1)/(3)"

[parameters.m]
domain = "positive"
[parameters.k]
domain = "positive"
[parameters.kd]
domain = "positive"
[parameters.R]
domain = "positive"
[parameters.F]
[parameters.Omega]
domain = "positive"
"""


def test_a_ring_cell_closes_and_substitutes_the_copy_index_and_count():
    """The last blade's damper rubs on the first; `i` and `N` in the cell's expressions are the copy's
    index and the count; items of a copy are nodes as well as masses."""
    assert system_from_dict(tomllib.loads(RING_CELL)) == system_from_dict(tomllib.loads(RING_BY_HAND))
    net = read_network(tomllib.loads(RING_CELL))
    assert [(e.a, e.b) for e in net.friction] == [("p_1", "x_2"), ("p_2", "x_3"), ("p_3", "x_1")]
    assert net.cells == (("blade", 3, "ring"),)
    assert "cell   blade      3 copies as a ring" in describe(tomllib.loads(RING_CELL))


def test_a_chain_with_fixed_ends_attaches_the_elements_past_its_ends_to_the_ground():
    data = tomllib.loads(CHAIN_CELL)
    data["cells"]["block"]["ends"] = "fixed"
    data["cells"]["block"]["springs"]["back"] = {"between": ["prev.x", "x"], "stiffness": "kc"}
    net = read_network(data)
    springs = {e.name: (e.a, e.b) for e in net.elements if e.kind == "spring"}
    assert springs["coupling_3"] == ("x_3", "ground")
    assert springs["back_1"] == ("ground", "x_1")
    assert springs["back_2"] == ("x_1", "x_2")
    # free ends (the default) leave those elements out
    free = read_network(tomllib.loads(CHAIN_CELL))
    assert "coupling_3" not in {e.name for e in free.elements}


def test_top_level_items_refer_to_copies_and_copies_to_top_level_points():
    """An Iwan-like hub: a top-level mass held by the copies of a cell, and a top-level force on a
    copy's mass named CELL[k].X."""
    data = tomllib.loads((MODEL_DIR / "iwan.toml").read_text())
    data["cells"]["jenkins"]["count"] = 4
    data["masses"]["tip"] = {"mass": "m"}
    data["springs"]["to_tip"] = {"between": ["jenkins[4].u", "tip"], "stiffness": "k0"}
    net = read_network(data)
    assert [(e.a, e.b) for e in net.elements if e.name.startswith("spring_")] == [
        ("x", f"u_{i}") for i in range(1, 5)
    ]
    assert [(e.a, e.b) for e in net.elements if e.name == "to_tip"] == [("u_4", "tip")]
    system = system_from_dict(data)
    assert system.preset("standard")["R_4"] == pytest.approx(0.02)  # linear from 0.002 to 0.02


def _chain(**edits) -> dict:
    data = tomllib.loads(CHAIN_CELL)
    for path, value in edits.items():
        target = data
        keys = path.split("__")
        for k in keys[:-1]:
            target = target[k]
        if value is None:
            del target[keys[-1]]
        else:
            target[keys[-1]] = value
    return data


REFUSALS = [
    ("no count", {"cells__block__count": None}, r"^\[cells\.block\] lacks `count`"),
    (
        "count 0",
        {"cells__block__count": 0},
        r"`count` = 0: the number of copies must be an integer from 1 to 5000",
    ),
    ("count too large", {"cells__block__count": 5001}, r"`count` = 5001: .* from 1 to 5000"),
    (
        "count as text",
        {"cells__block__count": "3"},
        r"`count` = '3': the number of copies must be an integer",
    ),
    ("count as a bool", {"cells__block__count": True}, r"`count` = True"),
    (
        "bad layout",
        {"cells__block__layout": "tree"},
        r"`layout` = 'tree': a cell repeats as a \"chain\" or a \"ring\"",
    ),
    (
        "ends of a ring",
        {"cells__block__layout": "ring", "cells__block__ends": "fixed"},
        r"a ring has no ends",
    ),
    ("unknown key", {"cells__block__repeat": 3}, r"^\[cells\.block\]: unknown key\(s\) repeat; allowed:"),
    (
        "empty cell",
        {"cells__block": {"count": 2}},
        r"^\[cells\.block\] has no masses, nodes, elements or forces",
    ),
    (
        "neighbour's unknown item",
        {"cells__block__springs__coupling__between": ["x", "next.y"]},
        r"^\[cells\.block\.springs\.coupling\] `between`: 'next\.y': the cell has no mass or node `y` \(its points: x\)",
    ),
    (
        "a cell that does not exist",
        {"forces": {"push": {"on": "blok[1].x", "offset": 1.0}}},
        r"^\[forces\.push\] `on`: 'blok\[1\]\.x' names cell `blok`, which does not exist; cells: block",
    ),
    (
        "a copy that does not exist",
        {"forces": {"push": {"on": "block[4].x", "offset": 1.0}}},
        r"'block\[4\]\.x': cell `block` has copies 1 to 3",
    ),
    (
        "an item a cell does not have",
        {"forces": {"push": {"on": "block[1].u", "offset": 1.0}}},
        r"'block\[1\]\.u': cell `block` has no mass or node `u`; its points: x",
    ),
    (
        "a malformed reference",
        {"forces": {"push": {"on": "block[1]", "offset": 1.0}}},
        r"'block\[1\]' is not a reference to a cell's item; write CELL\[k\]\.NAME",
    ),
    (
        "a list of the wrong length",
        {"presets__standard__block__R": [0.27, 0.33]},
        r"^\[presets\.standard\.block\] `R`: 2 values for the 3 copies of the cell; give 3 \(or one number\)",
    ),
    (
        "a list with text",
        {"presets__standard__block__R": [0.27, "x", 0.3]},
        r"`R`: value 2 is 'x', not a finite number",
    ),
    (
        "an unknown distribution",
        {"presets__standard__block__R": {"normal": [0.3, 0.01]}},
        r"`R`: a distribution is one of \{ linear = \[a, b\] \}.* or \{ alternating = \[a, b, \.\.\.\] \}",
    ),
    (
        "a linear distribution of three numbers",
        {"presets__standard__block__R": {"linear": [0.1, 0.2, 0.3]}},
        r"`linear` takes two numbers \[a, b\], got 3",
    ),
    (
        "preset values of a cell that does not exist",
        {"presets__standard__blocks": {"R": 0.3}},
        r"^\[presets\.standard\.blocks\]: a table in a preset gives the per-copy parameters of a cell, and "
        r"there is no cell `blocks`; cells: block",
    ),
    (
        "preset value of a parameter the cell does not have",
        {"presets__standard__block__S": 0.3},
        r"^\[presets\.standard\.block\]: `S` is not a parameter of cell `block`; its parameters: R",
    ),
    (
        "a per-copy value given twice",
        {"presets__standard__R_2": 0.3},
        r"^\[presets\.standard\]: `R_2` is given twice \(\[presets\.standard\.block\] sets it too\)",
    ),
    (
        "a bad level in one copy",
        {"presets__standard__block__R": [0.27, -0.33, 0.27]},
        r"preset `standard`: parameter `R_2` \(friction level \(cell block, copy 2\)\) must be > 0, got -0\.33",
    ),
    (
        "a bad coefficient in the cell",
        {"cells__block__friction__contact__sliding": -1.0},
        r"^\[cells\.block\.friction\.contact\] \(copy 1 of 3, `contact_1`\) `sliding` is -1\.0: a friction level must be > 0",
    ),
    (
        "an unknown name in the cell",
        {"cells__block__springs__anchor__stiffness": "k*zeta"},
        r"^\[cells\.block\.springs\.anchor\] \(copy 1 of 3, `anchor_1`\) `stiffness`: unknown name `zeta`",
    ),
    (
        "a copy's name already taken",
        {"masses": {"x_2": {"mass": "m"}}},
        r"^\[cells\.block\.masses\.x\]: copy 2 is named `x_2`, which the file already uses in \[masses\]",
    ),
    (
        "a local name hiding a top-level one",
        {"masses": {"x": {"mass": "m"}}, "springs": {"s": {"between": ["ground", "x"], "stiffness": "k"}}},
        r"^\[cells\.block\.masses\.x\]: `x` is also the name of a top-level item or parameter",
    ),
    (
        "a parameter named N",
        {"parameters__N": {"domain": "positive"}},
        r"^\[parameters\.N\]: in the expressions of a cell `i` is the copy's index and `N` the number of copies",
    ),
    (
        "a force on a neighbour",
        {"cells__block__forces__drive__on": "next.x"},
        r"`on` = 'next\.x': a cell's force acts on a mass of its own copy",
    ),
    (
        "a reserved local name",
        {"cells__block__nodes": {"next": {}}},
        r"^\[cells\.block\.nodes\.next\]: the name `next` is reserved in a cell",
    ),
    (
        "a ring of friction elements",
        {
            "cells__block__layout": "ring",
            "cells__block__friction__link": {"between": ["x", "next.x"], "sliding": "R"},
            "cells__block__friction__contact": None,
        },
        r"^\[cells\.block\.friction\.link\] \(copy 3 of 3, `link_3`\): friction elements link_3, link_1, link_2 form a loop",
    ),
]


@pytest.mark.parametrize(("what", "edits", "message"), REFUSALS, ids=[r[0] for r in REFUSALS])
def test_a_bad_cell_is_refused_naming_the_cell_the_copy_and_the_problem(what, edits, message):
    with pytest.raises(ModelError, match=message):
        system_from_dict(_chain(**copy.deepcopy(edits)))


@pytest.mark.slow
def test_a_cell_of_a_thousand_copies_builds_in_linear_time():
    """Building (reading, writing out the cell, deriving the system) grows linearly with the copies:
    a 1000-block chain costs at most 25 times a 100-block one (10 if linear; timing noise allowed)."""
    import time

    def build(n: int) -> float:
        data = tomllib.loads((MODEL_DIR / "bk_chain.toml").read_text())
        data["cells"]["block"]["count"] = n
        start = time.perf_counter()
        system = system_from_dict(data)
        assert len(system.components) == n
        return time.perf_counter() - start

    build(100)  # warm up
    small = min(build(100) for _ in range(2))
    large = build(1000)
    assert large <= 25 * small, (small, large)
