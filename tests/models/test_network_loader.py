"""Network files (issue 8): refusals with the file, the element and the problem named; the derived
structure; a fuzz of the network reader (only clean errors or valid models)."""

from __future__ import annotations

import copy
import re
import time
import tomllib
from collections import Counter
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import hybrid_models
from hybrid import ModelError, load_system, system_from_dict
from hybrid_models.network import build, describe, read_network

MODEL_DIR = Path(hybrid_models.__file__).parent
NETWORKS = [
    "absorber_network",
    "isolator_network",
    "coulomb_network",
    "sequential",
    "absorber_two_friction",
    "absorber_offset",
    "isolator_base",
    "friction_contact",
    "bk_chain",
    "iwan",
    "bladed_disk",
]
BASE = tomllib.loads((MODEL_DIR / "absorber_network.toml").read_text())


def _write(tmp_path: Path, data: dict, name: str = "mine.toml") -> Path:
    """A network dict as a TOML file (only the shapes the network files use)."""

    def value(v):
        if isinstance(v, str):
            return '"' + v.replace("\\", "\\\\").replace('"', '\\"') + '"'
        if isinstance(v, bool):
            return "true" if v else "false"
        if isinstance(v, list):
            return "[" + ", ".join(value(x) for x in v) + "]"
        return repr(v)

    lines = []
    for table, content in data.items():
        nested = {k: v for k, v in content.items() if isinstance(v, dict)}
        flat = {k: v for k, v in content.items() if not isinstance(v, dict)}
        if flat:
            lines.append(f"[{table}]")
            lines += [f"{k} = {value(v)}" for k, v in flat.items()]
        for k, v in nested.items():
            lines.append(f'[{table}."{k}"]')
            lines += [f"{kk} = {value(vv)}" for kk, vv in v.items()]
    path = tmp_path / name
    path.write_text("\n".join(lines) + "\n")
    return path


def _edit(**tables) -> dict:
    data = copy.deepcopy(BASE)
    for table, content in tables.items():
        if content is None:
            data.pop(table, None)
        else:
            data[table] = content
    return data


@pytest.mark.parametrize("name", NETWORKS)
def test_every_shipped_network_loads_and_describes_itself(name):
    system = load_system(MODEL_DIR / f"{name}.toml")
    data = tomllib.loads((MODEL_DIR / f"{name}.toml").read_text())
    friction = read_network(data).friction
    # one own mode, one component per friction element (3 local modes, 4 transitions each)
    assert system.mode_names == ("motion",)
    assert not system.transitions
    assert [c.name for c in system.components] == [e.name for e in friction]
    for c in system.components:
        assert c.mode_names == ("stick", "slip+", "slip-")
        assert [t.name for t in c.transitions] == ["breakaway+", "breakaway-", "stop+", "stop-"]
    assert system.default_mode == "|".join(["motion"] + ["stick"] * len(friction))
    text = describe(data)
    assert f"network `{system.name}`" in text
    assert system.energy == {"input": "W", "dissipated": "D", "mechanical": "E"}


def test_two_friction_elements_are_two_components_with_their_switches():
    data = tomllib.loads((MODEL_DIR / "absorber_two_friction.toml").read_text())
    system = build(data)
    H, G = system.components
    by_name = {(c.name, t.source, t.name): t for c in (H, G) for t in c.transitions}
    # the contact G of m1 to ground: its stop glues m1 to the ground (velocity reset to 0)
    stop = by_name[("G", "slip-", "stop-")]
    assert stop.target == "stick"
    assert stop.reset == {"v1": "0"}
    assert stop.direction == 1
    assert stop.guard == "w_G"
    brk = by_name[("H", "stick", "breakaway+")]
    assert brk.target == "slip+"
    assert brk.guard == "f_H - R"
    assert brk.direction == 1
    # stuck to the ground, G's force keeps m1's acceleration at 0: the momentum balance of m1 is its
    # equation; the sequential element's force is its node's balance, and the node moves with m2
    stick_G, stick_H = G.modes[0], H.modes[0]
    assert stick_G.algebraic == {"f_G": "c1*(-x1) + c2*(u - x1) - f_G + force"}
    assert system.equations["v1"] == "(c1*(-x1) + c2*(u - x1) - f_G + force)/m1"
    assert stick_H.algebraic == {"vel_u": "vel_u - v2", "f_H": "c2*(x1 - u) + c3*(x2 - u) + f_H"}
    assert stick_H.derivatives == {"u": "vel_u"}
    # sliding, the node is the slave of its balance, its velocity of the balance's derivative
    slip_H = H.modes[1]
    assert slip_H.algebraic == {
        "f_H": "f_H - R",
        "u": "c2*(x1 - u) + c3*(x2 - u) + f_H",
        "vel_u": "c2*(v1 - vel_u) + c3*(v2 - vel_u)",
    }
    assert system.mode("motion|slip+|stick").algebraic.keys() == {"f_H", "u", "vel_u", "f_G"}


def test_masses_glued_by_a_stop_share_their_momentum():
    data = {
        "model": {"name": "pair", "format": "network"},
        "parameters": {n: {"domain": "positive"} for n in ("m1", "m2", "k", "R")},
        "masses": {"a": {"mass": "m1"}, "b": {"mass": "m2"}},
        "springs": {"s": {"between": ["ground", "a"], "stiffness": "k"}},
        "friction": {"f": {"between": ["a", "b"], "sliding": "R"}},
    }
    system = build(data)
    (c,) = system.components
    stop = next(t for t in c.transitions if t.source == "slip+")
    assert stop.reset == {"v_a": "(m1*v_a + m2*v_b)/(m1 + m2)", "v_b": "(m1*v_a + m2*v_b)/(m1 + m2)"}
    # glued: the element's force keeps the two accelerations equal (f on a, -f on b)
    assert c.modes[0].algebraic == {"f_f": "(-f_f)/m2 - (k*(-a) + f_f)/m1"}
    assert system.equations["v_a"] == "(k*(-a) + f_f)/m1"
    assert system.equations["v_b"] == "(-f_f)/m2"
    assert system_from_dict(data) == system  # the loader takes what it built


# ----------------------------------------------------------------------------
# Refusals: the file, the element and the problem named
# ----------------------------------------------------------------------------
TWO_SPRINGS = {
    "k1": {"between": ["ground", "x1"], "stiffness": "c1"},
    "k2": {"between": ["x1", "u"], "stiffness": "c2"},
    "k3": {"between": ["u", "x2"], "stiffness": "c3"},
}

REFUSALS = [
    (
        "undetermined node",
        {"springs": {"k1": TWO_SPRINGS["k1"], "k4": {"between": ["x1", "x2"], "stiffness": "c2"}}},
        r"mine\.toml: \[nodes\.u\]: no spring or damper is attached, so its position is undetermined while its "
        r"friction element\(s\) H slip",
    ),
    (
        "unconnected mass",
        {"masses": {**BASE["masses"], "x3": {"mass": "m2"}}},
        r"mine\.toml: \[masses\.x3\] has no connection",
    ),
    (
        "zero friction level",
        {"friction": {"H": {"between": ["u", "x2"], "sliding": 0.0}}},
        r"mine\.toml: \[friction\.H\] `sliding` is 0\.0: a friction level must be > 0",
    ),
    (
        "negative friction level",
        {"friction": {"H": {"between": ["u", "x2"], "sliding": "-R"}}},
        r"mine\.toml: \[friction\.H\] `sliding` = '-R': a friction level must be a number > 0 or a parameter",
    ),
    (
        "friction level of a nonnegative parameter",
        {"friction": {"H": {"between": ["u", "x2"], "sliding": "F"}}},
        r"\[friction\.H\] `sliding`: parameter `F` has domain 'nonnegative'",
    ),
    (
        "static level below sliding level",
        {"friction": {"H": {"between": ["u", "x2"], "sliding": "R", "static": 0.1}}},
        r"\[friction\.H\]: static level 0\.1 = 0\.1 lies below the sliding level R = 0\.5 in preset `standard`",
    ),
    (
        "unknown end",
        {"springs": {**TWO_SPRINGS, "k9": {"between": ["x1", "x7"], "stiffness": "c1"}}},
        r"\[springs\.k9\] `between`: unknown end `x7`; masses: x1, x2; nodes: u; or ground",
    ),
    (
        "unknown name in a stiffness",
        {"springs": {**TWO_SPRINGS, "k9": {"between": ["x1", "x2"], "stiffness": "c1*zeta"}}},
        r"\[springs\.k9\] `stiffness`: unknown name `zeta`",
    ),
    (
        "forbidden construct in a mass",
        {"masses": {**BASE["masses"], "x1": {"mass": "__import__('os')", "velocity": "v1"}}},
        r"\[masses\.x1\] `mass`: call of `__import__` is not allowed",
    ),
    (
        "unknown key",
        {"friction": {"H": {"between": ["u", "x2"], "sliding": "R", "kinetic": "R"}}},
        r"\[friction\.H\]: unknown key\(s\) kinetic; allowed: between, description, sliding, static",
    ),
    (
        "force on a node",
        {"forces": {"force": {"on": "u", "amplitude": "F", "frequency": "Omega"}}},
        r"\[forces\.force\] `on` = 'u': a force acts on a mass",
    ),
    (
        "damper between two nodes",
        {
            "nodes": {"u": {}, "p": {}},
            "springs": {**TWO_SPRINGS, "kp": {"between": ["x1", "p"], "stiffness": "c1"}},
            "dampers": {"d": {"between": ["u", "p"], "coefficient": "c1"}},
        },
        r"\[dampers\.d\] joins two massless nodes \(`u`, `p`\): not supported",
    ),
    (
        "nodes floating on springs",
        {
            "nodes": {"u": {}, "p": {}, "q": {}},
            "springs": {**TWO_SPRINGS, "kpq": {"between": ["p", "q"], "stiffness": "c1"}},
            "friction": {
                "H": {"between": ["u", "x2"], "sliding": "R"},
                "G": {"between": ["p", "x1"], "sliding": "R"},
                "J": {"between": ["q", "ground"], "sliding": "R"},
            },
        },
        r"mine\.toml: \[nodes\.p\]: the massless nodes p, q are joined by springs only to each other, so their "
        r"positions are undetermined while their friction elements slip",
    ),
    (
        "zero mass",
        {"masses": {**BASE["masses"], "x2": {"mass": 0, "velocity": "v2"}}},
        r"mine\.toml: \[masses\.x2\] `mass` is 0\.0: a mass must be > 0",
    ),
    (
        "mass of a real parameter",
        {"masses": {**BASE["masses"], "x2": {"mass": "m2*2", "velocity": "v2"}}},
        r"\[masses\.x2\] `mass` = 'm2\*2': a mass must be a number > 0 or a parameter whose domain is positive",
    ),
    (
        "force on a list",
        {"forces": {"force": {"on": ["x1"], "amplitude": "F", "frequency": "Omega"}}},
        r"\[forces\.force\] `on` = \['x1'\]: a force acts on a mass",
    ),
    (
        "name taken twice",
        {"nodes": {"u": {}, "k1": {}}},
        r"\[springs\.k1\]: the name `k1` is already \[nodes\.k1\]",
    ),
    (
        "generated name taken",
        {"forces": {"E": {"on": "x1", "amplitude": "F", "frequency": "Omega"}}},
        r"the name\(s\) E are generated by the builder",
    ),
    (
        "two elements in parallel",
        {
            "friction": {
                "H": {"between": ["u", "x2"], "sliding": "R"},
                "H2": {"between": ["x2", "u"], "sliding": "R"},
            }
        },
        r"\[friction\.H2\]: friction elements H2, H form a loop: while they all stick",
    ),
]


@pytest.mark.parametrize(("what", "tables", "message"), REFUSALS, ids=[r[0] for r in REFUSALS])
def test_a_network_it_cannot_handle_is_refused_with_the_element_named(tmp_path, what, tables, message):
    with pytest.raises(ModelError, match=message):
        load_system(_write(tmp_path, _edit(**tables)))


def test_a_loop_of_massless_nodes_joined_only_by_friction_is_refused(tmp_path):
    data = _edit(
        nodes={"u": {}, "p": {}, "q": {}},
        springs={
            **TWO_SPRINGS,
            "kp": {"between": ["x1", "p"], "stiffness": "c2"},
            "kq": {"between": ["x2", "q"], "stiffness": "c2"},
        },
        friction={
            "H": {"between": ["u", "p"], "sliding": "R"},
            "G": {"between": ["p", "q"], "sliding": "R"},
            "J": {"between": ["q", "u"], "sliding": "R"},
        },
    )
    with pytest.raises(
        ModelError,
        match=r"mine\.toml: \[friction\.J\]: friction elements J, H, G form a loop of massless nodes "
        r"joined only by friction: while they all stick the forces they carry are undetermined",
    ):
        load_system(_write(tmp_path, data))


def _blocks(count: int, masses_per_cell: int = 1) -> dict:
    """A chain of `count` cells of blocks on friction contacts (a repeated cell)."""
    cell = {"count": count}
    cell["masses"] = {f"y{k}": {"mass": "m1"} for k in range(masses_per_cell)}
    cell["friction"] = {
        f"f{k}": {"between": ["ground", f"y{k}"], "sliding": "R"} for k in range(masses_per_cell)
    }
    return _edit(masses=None, nodes=None, springs=None, friction=None, forces=None, cells={"block": cell})


@pytest.mark.parametrize(
    ("count", "per_cell", "message"),
    [
        (3001, 1, r"\[friction\]: 3001 friction elements; at most 3000 are allowed \(each is a component"),
        (3001, 2, r"6002 masses and nodes; at most 6000 are allowed"),
        (5001, 1, r"\[cells\.block\] `count` = 5001: the number of copies must be an integer from 1 to 5000"),
    ],
)
def test_networks_beyond_the_limits_of_size_are_refused_naming_the_limit(count, per_cell, message):
    with pytest.raises(ModelError, match=message):
        system_from_dict(_blocks(count, per_cell))


def test_a_network_of_a_thousand_contacts_is_composed_not_enumerated():
    system = system_from_dict(_blocks(1000))
    assert len(system.components) == 1000
    assert system.mode_names == ("motion",)
    assert len(system.variables) == 3002  # y0_i, v_y0_i, f_f0_i; W, D


def test_an_unknown_model_format_is_refused(tmp_path):
    data = _edit(model={"name": "x", "format": "bond-graph"})
    with pytest.raises(
        ModelError,
        match=r"mine\.toml: \[model\] `format` = 'bond-graph' is not a known model format; formats: modes, network",
    ):
        load_system(_write(tmp_path, data))


# ----------------------------------------------------------------------------
# Fuzz: random edits of network files end in a valid model or a clean ModelError
# ----------------------------------------------------------------------------
FUZZ = settings(
    derandomize=True,
    deadline=None,
    max_examples=400,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
    database=None,
)
FUZZ_BASES = {n: tomllib.loads((MODEL_DIR / f"{n}.toml").read_text()) for n in NETWORKS}
OUTCOMES: Counter = Counter()


@pytest.fixture(scope="module", autouse=True)
def _report_outcomes():
    yield
    print(f"\nnetwork fuzz: {dict(OUTCOMES)}, total {sum(OUTCOMES.values())}")


JUNK = st.one_of(
    st.sampled_from(
        [
            "ground",
            "x1",
            "x2",
            "u",
            "x",
            "v",
            "R",
            "-R",
            "0",
            "c1*",
            "__import__('os')",
            "1e999",
            "t",
            "",
            " ",
            "H",
            "E",
            "W",
            "stick",
            "slip+",
            "pi",
            "Rs",
            "sin(t)",
            "m1/0",
            ["ground", "ground"],
            ["x1", "u"],
            ["u", "x2"],
            ["ground", "u"],
            ["x1"],
            [],
            [1, 2],
            0,
            -1,
            1.5,
            float("nan"),
            float("inf"),
            True,
            {},
            {"between": ["x1", "u"]},
        ]
    ),
    st.text(max_size=12),
    st.floats(),
    st.integers(-5, 5),
)
#: Values of a type no field takes (unhashable ones included): half of the field replacements.
STRUCTURED = st.one_of(
    st.lists(st.sampled_from(["ground", "x1", "u", "x", 1]), max_size=3),
    st.dictionaries(
        st.sampled_from(["mass", "on", "between", "x"]), st.sampled_from(["x1", "1", "R"]), max_size=2
    ),
)
POINTS = ["ground", "x1", "x2", "u", "x", "nope"]


@st.composite
def edited_networks(draw) -> dict:
    data = copy.deepcopy(FUZZ_BASES[draw(st.sampled_from(NETWORKS))])
    for _ in range(draw(st.integers(1, 4))):
        action = draw(st.sampled_from(["replace", "replace_field", "delete", "add_element", "drop_table"]))
        tables = [k for k, v in data.items() if isinstance(v, dict)]
        if not tables:
            break
        table = draw(st.sampled_from(sorted(tables)))
        if action == "drop_table":
            del data[table]
        elif action == "replace_field":  # a field of an element, mass, node or force
            parts = [k for k in ("masses", "springs", "friction", "forces") if isinstance(data.get(k), dict)]
            if not parts:
                continue
            table = draw(st.sampled_from(parts))
            fields = [
                (name, key) for name, spec in data[table].items() if isinstance(spec, dict) for key in spec
            ]
            if fields:
                name, key = draw(st.sampled_from(sorted(fields)))
                data[table][name][key] = draw(st.one_of(JUNK, STRUCTURED))
        elif action == "add_element":
            kind = draw(st.sampled_from(["springs", "dampers", "friction", "masses", "nodes", "forces"]))
            key = draw(st.sampled_from(["n1", "n2", "H", "k1", "x1", "u", "ground", "E"]))
            spec = {
                "springs": {
                    "between": [draw(st.sampled_from(POINTS)), draw(st.sampled_from(POINTS))],
                    "stiffness": "1",
                },
                "dampers": {
                    "between": [draw(st.sampled_from(POINTS)), draw(st.sampled_from(POINTS))],
                    "coefficient": "1",
                },
                "friction": {
                    "between": [draw(st.sampled_from(POINTS)), draw(st.sampled_from(POINTS))],
                    "sliding": "0.5",
                },
                "masses": {"mass": "1"},
                "nodes": {},
                "forces": {"on": draw(st.sampled_from(POINTS)), "offset": "1"},
            }[kind]
            data.setdefault(kind, {})[key] = spec
        else:
            content = data[table]
            keys = sorted(content, key=str)
            if not keys:
                continue
            key = draw(st.sampled_from(keys))
            target, k = content, key
            if isinstance(content[key], dict) and content[key] and draw(st.booleans()):
                target, k = content[key], draw(st.sampled_from(sorted(content[key], key=str)))
            if action == "delete":
                del target[k]
            else:
                target[k] = draw(JUNK)
    return data


@pytest.mark.slow
@FUZZ
@given(edited_networks())
def test_fuzz_network_reader_gives_a_model_or_a_clean_error(data):
    start = time.perf_counter()
    try:
        system = system_from_dict(data)
    except ModelError as exc:
        assert str(exc)
        assert "Traceback" not in str(exc)
        OUTCOMES["clean error"] += 1
    else:
        assert system == build(data)  # the model the network describes
        OUTCOMES["valid model"] += 1
    assert time.perf_counter() - start < 5.0


TEXTS = {n: (MODEL_DIR / f"{n}.toml").read_text() for n in NETWORKS}
SNIPPETS = st.sampled_from(
    [
        '"',
        "'",
        "[",
        "]",
        "[[friction]]",
        "=",
        "\n",
        "\x00",
        "\u00e9",
        'between = ["u", "u"]',
        'sliding = "-R"',
        "static = 1e999",
        "[masses.ground]",
        "[nodes.u]\n",
        "format = 1",
        "{",
        "}",
        'stiffness = "c1**c1**c1"',
        "mass = 0",
        "[base]\namplitude = 1\nfrequency = 0",
        " ",
    ]
)


@st.composite
def spliced_texts(draw) -> str:
    text = TEXTS[draw(st.sampled_from(NETWORKS))]
    for _ in range(draw(st.integers(1, 3))):
        i = draw(st.integers(0, len(text)))
        j = draw(st.integers(i, min(len(text), i + 40)))
        piece = draw(st.one_of(SNIPPETS, st.text(max_size=8), st.just("")))
        text = text[:i] + piece + text[j:]
    return text


@pytest.mark.slow
@settings(FUZZ, max_examples=200)
@given(spliced_texts())
def test_fuzz_network_files_as_text_give_a_model_or_a_clean_error(text):
    import tempfile

    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "spliced.toml"
        path.write_text(text, encoding="utf-8", errors="surrogatepass")
        start = time.perf_counter()
        try:
            system = load_system(path)
        except ModelError as exc:
            assert str(exc).startswith(("spliced.toml: ", "model file ")), str(exc)
            OUTCOMES["clean error (file)"] += 1
        else:
            assert system == build(tomllib.loads(text))  # what the file describes
            OUTCOMES["valid model (file)"] += 1
        assert time.perf_counter() - start < 5.0


FIELD_JUNK = [
    [],
    ["x1"],
    ["x1", "u", "x2"],
    {},
    {"a": 1},
    0,
    -1.5,
    float("nan"),
    True,
    "",
    "ground",
    "nope",
    "1e999",
]


@pytest.mark.slow
@pytest.mark.parametrize("name", NETWORKS)
def test_every_field_of_every_shipped_network_takes_junk_cleanly(name):
    """Systematic: each field of each mass, element, force and [model]/[base] entry replaced by each junk value."""
    base = FUZZ_BASES[name]
    tried = 0
    for table, content in base.items():
        if not isinstance(content, dict):
            continue
        entries = [(k, v) for k, v in content.items() if isinstance(v, dict)] or [(None, content)]
        if table in ("parameters", "presets"):  # the engine checks these; one entry each suffices
            entries = entries[:1]
        for key, spec in entries:
            for field in spec:
                for junk in FIELD_JUNK:
                    data = copy.deepcopy(base)
                    target = data[table] if key is None else data[table][key]
                    target[field] = copy.deepcopy(junk)
                    try:
                        system_from_dict(data)
                    except ModelError as exc:
                        assert str(exc)
                    tried += 1
    OUTCOMES["field replacements"] += tried
    assert tried >= 100


def test_elements_have_a_namespace_of_their_own(tmp_path):
    """Issue 24: `[springs.c1] stiffness = "c1"` is accepted (element names are not parameters); the
    model is the same as with other element names, except for a friction element's outputs."""
    data = copy.deepcopy(BASE)
    renamed = copy.deepcopy(BASE)
    for table in ("springs", "friction"):
        renamed[table] = {
            (spec.get("stiffness") or spec.get("sliding")): spec for spec in data[table].values()
        }
    assert set(renamed["springs"]) <= set(renamed["parameters"])  # each spring named as its stiffness
    a = load_system(_write(tmp_path, data, "a.toml"))
    b = load_system(_write(tmp_path, renamed, "b.toml"))
    assert a.mode_names == b.mode_names
    fa, fb = next(iter(data["friction"])), next(iter(renamed["friction"]))

    def ren(text) -> str:  # a's names of the friction element's force and relative velocity as b's
        return re.sub(rf"\b([fw])_{fa}\b", rf"\1_{fb}", str(text))

    assert [ren(v) for v in a.variable_names] == list(b.variable_names)
    for m in a.modes:
        mb = b.modes[a.mode_names.index(m.name)]
        assert {ren(k): ren(v) for k, v in m.derivatives.items()} == {
            k: str(v) for k, v in mb.derivatives.items()
        }
    assert [c.name for c in b.components] == [fb]  # the friction element's component, named as it
    assert f"f_{fb}" in b.variable_names and f"w_{fb}" in b.outputs
    assert f"f_{fa}" in a.variable_names and f"w_{fa}" in a.outputs
    # still one name per element, and masses, nodes and forces stay apart from parameters
    twice = copy.deepcopy(renamed)
    twice["dampers"] = {next(iter(renamed["springs"])): {"between": ["ground", "x1"], "coefficient": "c1"}}
    with pytest.raises(ModelError, match=r"\[dampers\.c1\]: the name `c1` is already \[springs\.c1\]"):
        load_system(_write(tmp_path, twice, "c.toml"))
    force = copy.deepcopy(BASE)
    force["forces"] = {"F": next(iter(BASE["forces"].values()))}
    with pytest.raises(
        ModelError, match=r"\[forces\.F\]: the name `F` is already a parameter \(masses, nodes and forces"
    ):
        load_system(_write(tmp_path, force, "d.toml"))


def test_a_node_is_drawn_between_the_points_it_joins(tmp_path):
    """Issue 24: `hybrid show --out` placed a node hanging between two masses beyond the second one
    (breadth-first from the ground, both masses being the ground's neighbours)."""
    import tomllib as _toml

    from hybrid_models.network import draw
    from hybrid_models.network_draw import _layout

    data = copy.deepcopy(BASE)
    data["springs"] = {
        "a": {"between": ["ground", "x1"], "stiffness": "c1"},
        "b": {"between": ["x1", "u"], "stiffness": "c2"},
        "c": {"between": ["x2", "ground"], "stiffness": "c3"},
    }
    data["friction"] = {"H": {"between": ["u", "x2"], "sliding": "R"}}
    net = read_network(_toml.loads(_write(tmp_path, data).read_text()))
    col = _layout(net)
    assert col["ground"] < col["x1"] < col["u"] < col["x2"]
    draw(data, tmp_path / "net.png")
    assert (tmp_path / "net.png").stat().st_size > 0
