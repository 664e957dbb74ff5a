"""Files written with sign() as components (issue 22): one component per surface.

References: the builder as it was before (``filippov_expanded.py``, which expanded every
combination of a mode's surfaces into modes; kept only here), the same friction chain written as
one component per contact (``chains.py``, whose contacts own their friction force: an independent
formulation), closed forms of one-dimensional fields ``x' = b + c sign(x)``.
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import filippov_expanded as expanded
import numpy as np
import pytest
from chains import acceleration, chain_params, composed_chain

import hybrid
import hybrid.model.filippov as filippov
import hybrid.model.loader as loader
from hybrid import (
    IDA,
    Exact,
    Mode,
    ModelError,
    SolverOptions,
    Status,
    Transition,
    Variable,
    filippov_system,
    simulate,
)
from hybrid.model.compiled import CompiledSystem

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
EXACT = SolverOptions(method=Exact())
IDA = SolverOptions(method=IDA(rtol=1e-10, atol=1e-12))
_SIDE = {"plus": "+", "minus": "-", "slide": "0"}


def _both(path: Path):
    """A model file loaded by the component builder and by the expanded one (the reference)."""
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(loader, "filippov_system", expanded.filippov_system)
        reference = hybrid.load_system(path)
    return reference, hybrid.load_system(path)


@pytest.fixture(scope="module")
def coulomb_pair():
    return _both(ROOT / "models" / "coulomb_sign.toml")


@pytest.fixture(scope="module")
def belt_pair():
    return _both(ROOT / "models" / "belt_sign.toml")


def _expanded_name(mode: str) -> str:
    """The expanded builder's name of a composed mode: `m|plus|slide` -> `m_+0`."""
    own, *parts = mode.split("|")
    return f"{own}_" + "".join(_SIDE[p] for p in parts)


def _settled(tr, rename=lambda m: m) -> list[tuple[float, str]]:
    """``(t, mode)`` at the end of each instant's chain of switches (the mode the run goes on in)."""
    out: list[tuple[float, str]] = []
    for e in tr.events:
        if out and e.t == out[-1][0]:
            out[-1] = (e.t, e.target)
        else:
            out.append((e.t, e.target))
    return [(t, rename(m)) for t, m in out]


def _compare(ref, new, names, exact_bits: bool, tol: float, same_steps: bool = True) -> None:
    """The component run ``new`` against the expanded run ``ref``: same samples, modes, settled
    switches; states equal (``exact_bits``) or within ``tol``. With ``same_steps=False`` (IDA,
    whose step sizes follow the last bits of the residual: the two forms round differently) the
    same settled switches within ``tol`` and the same final state within ``tol``."""
    assert ref.status == new.status == Status.COMPLETED
    if not same_steps:
        sa, sb = _settled(ref), _settled(new, _expanded_name)
        assert [m for _, m in sa] == [m for _, m in sb]
        assert max(abs(a - b) for (a, _), (b, _) in zip(sa, sb, strict=True)) <= tol
        assert max(abs(ref.final(n) - new.final(n)) for n in names) <= tol
        return
    assert ref.t.shape == new.t.shape
    assert np.max(np.abs(ref.t - new.t)) <= (0.0 if exact_bits else tol)
    assert [str(m) for m in ref.mode] == [_expanded_name(str(m)) for m in new.mode]
    sa, sb = _settled(ref), _settled(new, _expanded_name)
    assert [m for _, m in sa] == [m for _, m in sb]
    dt = max(abs(a - b) for (a, _), (b, _) in zip(sa, sb, strict=True))
    dy = max(float(np.max(np.abs(ref[n] - new[n]))) for n in names)
    if exact_bits:
        assert dt == 0.0
        assert dy == 0.0
    else:
        assert dt <= tol
        assert dy <= tol


# ----------------------------------------------------------------------------
# The component form against the expanded form
# ----------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("options", "exact_bits"), [(EXACT, True), pytest.param(IDA, False, marks=pytest.mark.slow)]
)
@pytest.mark.parametrize(("W", "R"), [(0.8, 0.1), (0.6, 0.3)])  # crossings; stick phases
def test_coulomb_sign_equals_the_expanded_form(coulomb_pair, options, exact_bits, W, R):
    ref, new = coulomb_pair
    p = new.preset("forced", Omega=W, R=R)
    span = (0.0, (10 if options is EXACT else 3) * 2 * math.pi / W)
    a = simulate(ref, p, span, {"x": 0.0, "v": 0.0}, options=options)
    b = simulate(new, p, span, {"x": 0.0, "v": 0.0}, options=options)
    _compare(a, b, ("x", "v", "W", "D", "sign_1", "friction"), exact_bits, 1e-12)
    assert len(_settled(b)) >= (20 if options is EXACT else 6)


@pytest.mark.parametrize(
    ("options", "exact_bits"), [(EXACT, True), pytest.param(IDA, False, marks=pytest.mark.slow)]
)
@pytest.mark.parametrize("preset", ["standard", "damped"])
def test_belt_sign_equals_the_expanded_form(belt_pair, options, exact_bits, preset):
    ref, new = belt_pair
    p = new.preset(preset)
    a = simulate(ref, p, (0.0, 100.0), {"x": 0.0, "v": 0.0}, options=options)
    b = simulate(new, p, (0.0, 100.0), {"x": 0.0, "v": 0.0}, options=options)
    _compare(a, b, ("x", "v", "sign_1", "H"), exact_bits, 1e-12)
    assert len(_settled(b)) >= 3


def _pair_kwargs() -> dict:
    return dict(
        name="pair",
        variables=["x1", "v1", "x2", "v2"],
        parameters=["m", "k1", "k2", "R1", "R2", "F", "Omega"],
        modes=[
            Mode(
                "m",
                derivatives={
                    "x1": "v1",
                    "v1": "(F*sin(Omega*t) - k1*x1 - R1*sign(v1))/m",
                    "x2": "v2",
                    "v2": "(F*sin(Omega*t) - k2*x2 - R2*sign(v2))/m",
                },
            )
        ],
        transitions=[],
        initial_mode="m",
        period="2*pi/Omega",
    )


# The exact flow takes long steps: a guard may dip and cross back within one (located since issue 12).
@pytest.mark.filterwarnings("ignore:guard .* before it could be armed:RuntimeWarning")
@pytest.mark.parametrize("options", [EXACT, pytest.param(IDA, marks=pytest.mark.slow)])
@pytest.mark.parametrize(
    ("k2", "R2", "v20", "both_slide"),
    [(7.3, 0.01, 0.3, False), (3.0, 0.05, 0.0, True)],  # crossing v2 = 0 while 1 slides; both slide
)
def test_two_surfaces_equal_the_expanded_form(options, k2, R2, v20, both_slide):
    """Two surfaces: one crossed while sliding on the other, and sliding on both at once (the
    expanded form's mode `m_00`). Its exits differ in form only: `m_00` left where sign_i reached
    +-1, the component's `slide` where a+- of its surface crosses 0, which is the same instant
    (sign_i = 1 exactly where a+ = 0): the exact runs agree to rounding (measured 7.1e-15 s in
    the switch times, 1.2e-14 in the sliding coefficients, 5.6e-17 in the states)."""
    ref, new = expanded.filippov_system(**_pair_kwargs()), filippov_system(**_pair_kwargs())
    p = {"m": 1.0, "k1": 1.0, "k2": k2, "R1": 0.3, "R2": R2, "F": 0.5, "Omega": 0.6}
    span = (0.0, 4 * 2 * math.pi / 0.6)
    x0 = {"x1": 0.0, "v1": 0.0, "x2": 0.0, "v2": v20}
    a = simulate(ref, p, span, x0, options=options)
    b = simulate(new, p, span, x0, options=options)
    if options is EXACT:
        _compare(a, b, ("x1", "v1", "x2", "v2", "sign_1", "sign_2"), False, 1e-13)
    else:  # measured: switch times 1.4e-11 apart, final states 2.2e-13 (rtol 1e-10)
        _compare(a, b, ("x1", "v1", "x2", "v2", "sign_1", "sign_2"), False, 1e-9, same_steps=False)
    assert (sum(str(m) == "m|slide|slide" for m in b.mode) > 0) == both_slide
    # one surface reached while sliding on the other (crossed or joined)
    meet = [e for e in b.events if e.guard.endswith(".reach") and "slide" in e.source.split("|")]
    assert len(meet) >= 3


def test_sliding_on_two_surfaces_at_once_equals_the_expanded_form():
    """x' = 0.5 - sign(x), y' = -sign(y): sliding on y = 0, then on both from t = 2."""
    kwargs = dict(
        name="two",
        variables=["x", "y"],
        parameters=[],
        modes=[Mode("m", derivatives={"x": "0.5 - sign(x)", "y": "-sign(y)"})],
        transitions=[],
        initial_mode="m",
    )
    ref, new = expanded.filippov_system(**kwargs), filippov_system(**kwargs)
    for options in (EXACT, IDA):
        a = simulate(ref, {}, (0.0, 5.0), {"x": 1.0, "y": 0.5}, options=options)
        b = simulate(new, {}, (0.0, 5.0), {"x": 1.0, "y": 0.5}, options=options)
        _compare(a, b, ("x", "y", "sign_1", "sign_2"), options is EXACT, 1e-12)
        assert b.mode_final == "m|slide|slide"


def _two_mode_kwargs() -> dict:
    """Two modes written with sign(), whose first surfaces share the component sign_1: A slides on
    x = 0, B on x = 1 (with sign_1 = 1/2); a clock y switches A -> B at y = 2 and B -> A at y = 5
    (y := 0)."""
    return dict(
        name="two_modes",
        variables=["x", "y"],
        parameters=[],
        modes=[
            Mode("A", derivatives={"x": "-sign(x)", "y": "1"}),
            Mode("B", derivatives={"x": "0.5 - sign(x - 1)", "y": "1"}),
        ],
        transitions=[
            Transition("A", "B", "y - 2", 1, "go"),
            Transition("B", "A", "y - 5", 1, "back", {"y": "0"}),
        ],
        initial_mode="A",
    )


def test_two_filippov_modes_share_a_component():
    new = filippov_system(**_two_mode_kwargs())
    (c,) = new.components
    assert c.mode_names == (
        *(f"A_{k}" for k in filippov.LOCAL_MODES),
        *(f"B_{k}" for k in filippov.LOCAL_MODES),
        "off",  # passed through between the modes
    )
    assert new.variable_names == ("x", "y", "sign_1", "in_A", "in_B")
    assert [(s.mode, s.h, s.component) for s in filippov.surfaces(new)] == [
        ("A", "x", "sign_1"),
        ("B", "(x - 1.0)", "sign_1"),
    ]
    ref = expanded.filippov_system(**_two_mode_kwargs())
    grid = np.linspace(0.0, 9.0, 91)
    for options, tol in ((EXACT, 1e-12), (IDA, 1e-9)):
        a = simulate(ref, {}, (0.0, 9.0), {"x": 0.5, "y": 0.0}, t_eval=grid, options=options)
        b = simulate(new, {}, (0.0, 9.0), {"x": 0.5, "y": 0.0}, t_eval=grid, options=options)
        assert a.status == b.status == Status.COMPLETED
        assert np.array_equal(a.t, b.t)
        for n in ("x", "y", "sign_1"):
            assert np.max(np.abs(a[n] - b[n])) <= tol
        # x: to 0 at 0.5 (slides), B at 2: to 1 at 2 + 2/3 (slides, sign_1 = 1/2), A at 5: to 0 at
        # 6, B at 7: to 1 at 7 + 2/3.
        reach = [e.t for e in b.events if e.guard == "sign_1.reach"]
        assert np.allclose(reach, [0.5, 2 + 2 / 3, 6.0, 7 + 2 / 3], rtol=0, atol=1e-9)
        assert b.final("x") == pytest.approx(1.0, abs=1e-12)
        assert b.final("sign_1") == pytest.approx(0.5, abs=1e-12)
        assert b.mode_final == "B|B_slide"


# ----------------------------------------------------------------------------
# The entry: the initial local mode decided from the state
# ----------------------------------------------------------------------------
# x' = b + c sign(x): a+ = b + c, a- = b - c.
ENTRY_CASES = [
    # (b, c, what happens on x = 0, local mode after the entry at x0 = 0, x(t) from x0 = 0)
    (0.5, -1.0, "sliding", "slide", lambda t: 0.0 * t),
    (2.0, 1.0, "crossing up", "plus", lambda t: 3.0 * t),
    (-2.0, 1.0, "crossing down", "minus", lambda t: -3.0 * t),
    (1.0, -1.0, "tangent on the + side", "slide", lambda t: 0.0 * t),
]


def _line_kwargs() -> dict:
    return dict(
        name="line",
        variables=["x"],
        parameters=["b", "c"],
        modes=[Mode("m", derivatives={"x": "b + c*sign(x)"})],
        transitions=[],
        initial_mode="m",
    )


@pytest.mark.parametrize("options", [EXACT, IDA])
@pytest.mark.parametrize(("b", "c", "what", "local", "x_of_t"), ENTRY_CASES)
def test_entry_on_the_surface_follows_filippov(options, b, c, what, local, x_of_t):
    s, ref = filippov_system(**_line_kwargs()), expanded.filippov_system(**_line_kwargs())
    tr = simulate(s, {"b": b, "c": c}, (0.0, 1.0), {"x": 0.0}, options=options)
    assert tr.status == Status.COMPLETED, what
    assert tr.mode[0] == f"m|{local}", what
    assert tr.final("x") == pytest.approx(x_of_t(1.0), abs=1e-12)
    r = simulate(ref, {"b": b, "c": c}, (0.0, 1.0), {"x": 0.0}, mode0="m", options=options)
    assert _expanded_name(str(tr.mode[0])) == r.mode[0]
    assert tr.final("x") == r.final("x")


@pytest.mark.parametrize("options", [EXACT, IDA])
def test_entry_off_the_surface_and_repulsion(options):
    s = filippov_system(**_line_kwargs())
    for b, c in ((0.5, -1.0), (2.0, 1.0), (-2.0, 1.0), (0.5, 1.0)):
        for x0 in (1.0, -1.0):
            tr = simulate(s, {"b": b, "c": c}, (0.0, 0.25), {"x": x0}, options=options)
            assert tr.status == Status.COMPLETED
            side = "plus" if x0 > 0 else "minus"
            assert tr.mode[0] == f"m|{side}"
            assert tr.final("x") == pytest.approx(x0 + 0.25 * (b + c * x0), abs=1e-12)
    # both fields pointing away (a+ = 1.5 > 0 > a- = -0.5): not unique, reported at the start
    tr = simulate(s, {"b": 0.5, "c": 1.0}, (0.0, 1.0), {"x": 0.0}, options=options, throw=False)
    assert tr.status == Status.HALTED
    assert tr.t_final == 0.0
    assert "repulsive sliding on the surface x = 0 of mode `m`" in tr.message
    assert [e.target for e in tr.events] == ["m|entry-", "m|slide", "m|repel"]


def test_a_model_starting_in_an_ordinary_mode_starts_its_components_off():
    kwargs = _two_mode_kwargs()
    kwargs["modes"] = [*kwargs["modes"], Mode("C", derivatives={"x": "0", "y": "1"})]
    kwargs["transitions"] = [*kwargs["transitions"], Transition("C", "A", "y - 1", 1, "start")]
    kwargs["initial_mode"] = "C"
    s = filippov_system(**kwargs)
    assert s.default_mode == "C|off"
    tr = simulate(s, {}, (0.0, 1.9), {"x": 2.0, "y": 0.0}, options=EXACT)
    assert tr.status == Status.COMPLETED
    assert [e.target for e in tr.events] == ["A|off", "A|A_entry+", "A|A_entry-", "A|A_plus"]
    assert [e.t for e in tr.events] == pytest.approx([1.0] * 4, abs=1e-12)
    assert tr.final("x") == pytest.approx(1.1, abs=1e-12)  # x' = -1 from t = 1


# ----------------------------------------------------------------------------
# A chain of blocks written with sign() against the same chain with contact components
# ----------------------------------------------------------------------------
def sign_chain(n: int) -> hybrid.HybridSystem:
    """The chain of ``chains.py`` written with ``sign()``: block i's friction force is
    ``-R_i sign(v_i)`` in its momentum balance (no variable of its own)."""
    variables = [Variable(f"{p}{i}") for i in range(1, n + 1) for p in ("x", "v")]
    equations = {}
    for i in range(1, n + 1):
        equations[f"x{i}"] = f"v{i}"
        equations[f"v{i}"] = "(" + acceleration(i, n).replace(f"+ f{i}", f"- R{i}*sign(v{i})") + ")/m"
    return filippov_system(
        name=f"sign_chain{n}",
        variables=variables,
        parameters=["m", "k", "kc", "c", "F", "Omega"] + [f"R{i}" for i in range(1, n + 1)],
        modes=[Mode("motion")],
        transitions=[],
        equations=equations,
        period="2*pi/Omega",
        initial_mode="motion",
    )


def _chains_agree(n: int, span: tuple[float, float], options, tol: float) -> int:
    """Both chains from rest; returns the number of switches checked."""
    p = chain_params(n)
    x0 = {f"{q}{i}": 0.0 for i in range(1, n + 1) for q in ("x", "v")}
    grid = np.linspace(*span, 201)
    a = simulate(composed_chain(n), p, span, x0, t_eval=grid, options=options)
    b = simulate(sign_chain(n), p, span, x0, t_eval=grid, options=options)
    assert a.status == b.status == Status.COMPLETED
    assert b.mode[0] == "motion|" + "|".join(["slide"] * n)  # from rest: every block stuck
    for i in range(1, n + 1):
        for q in ("x", "v"):
            assert np.max(np.abs(a[f"{q}{i}"] - b[f"{q}{i}"])) <= tol
            assert abs(a.final(f"{q}{i}") - b.final(f"{q}{i}")) <= tol
        # the friction force: f_i of the contact, -R_i sign_i of the surface
        assert np.max(np.abs(a[f"f{i}"] + p[f"R{i}"] * b[f"sign_{i}"])) <= tol * 10
    # The switches that move each block (a stop or a breakaway; a reversal is a stop and a
    # breakaway at one instant in both), at the same instants. (Several blocks may switch at one
    # instant, in an order that differs: compared block by block.)
    kind = {"stop": "stop", "reach": "stop", "breakaway": "go", "exit": "go"}

    def switches(tr) -> dict[str, list]:
        out: dict[str, list] = {}
        for e in tr.events:
            if e.t > 0:
                part, name = e.guard.split(".")
                out.setdefault(re.sub(r"\D", "", part), []).append((e.t, kind[name.rstrip("+-")]))
        return out

    sa, sb = switches(a), switches(b)
    assert sa.keys() == sb.keys()
    for i in sa:
        assert [k for _, k in sa[i]] == [k for _, k in sb[i]]
        assert max(abs(x[0] - y[0]) for x, y in zip(sa[i], sb[i], strict=True)) <= tol
    sa = [s for block in sa.values() for s in block]
    return len(sa)


def test_a_six_block_chain_written_with_sign_equals_the_contact_components():
    """Six surfaces in one mode (the expanded form refused more than 4)."""
    assert _chains_agree(6, (0.0, 4 * math.pi), EXACT, 1e-12) >= 20


@pytest.mark.slow
def test_a_twenty_block_chain_written_with_sign_equals_the_contact_components():
    """Measured: 620 switches over 50 s; states equal to 1.1e-16 on the samples, the final states
    and switch times identical (exact integrator, the same rtol)."""
    assert _chains_agree(20, (0.0, 50.0), EXACT, 1e-12) >= 500


# ----------------------------------------------------------------------------
# Limits by size
# ----------------------------------------------------------------------------
def _many(n: int, extra_variables: int = 0):
    variables = [f"x{i}" for i in range(n)] + [f"z{i}" for i in range(extra_variables)]
    derivs = {f"x{i}": f"-sign(x{i})" for i in range(n)} | {f"z{i}": "0" for i in range(extra_variables)}
    return dict(name="many", variables=variables, parameters=[], modes=[Mode("m", derivs)], transitions=[])


def test_more_surfaces_than_the_limit_are_refused(monkeypatch):
    assert filippov.MAX_SURFACES == hybrid.model.system.MAX_COMPONENTS
    s = filippov_system(**_many(5))  # the expanded form refused more than 4
    assert len(s.components) == 5
    monkeypatch.setattr(filippov, "MAX_SURFACES", 4)
    with pytest.raises(
        ModelError, match=r"model `many` has 5 discontinuity surfaces sign\(h\) \(`m`: 5\); at most 4"
    ):
        filippov_system(**_many(5))


def test_too_many_variables_with_the_coefficients_are_refused(monkeypatch):
    monkeypatch.setattr(filippov, "MAX_VARIABLES", 12)
    filippov_system(**_many(6))  # 6 + 6 = 12
    with pytest.raises(
        ModelError,
        match=r"many`: 7 variables and 6 surfaces sign\(h\) in one mode make 13 variables \(each surface adds "
        r"its coefficient sign_i\); at most 12",
    ):
        filippov_system(**_many(6, extra_variables=1))


def test_surfaces_in_too_many_variables_are_refused(monkeypatch):
    kwargs = _many(3)
    kwargs["modes"] = [Mode("m", {"x0": "-sign(x0 + x1 + x2)", "x1": "-sign(x1)", "x2": "-sign(x2)"})]
    monkeypatch.setattr(filippov, "MAX_SURFACE_TERMS", 5)
    filippov_system(**kwargs)  # 3 + 1 + 1 terms
    monkeypatch.setattr(filippov, "MAX_SURFACE_TERMS", 4)
    with pytest.raises(
        ModelError,
        match=r"model `many`: mode `m`: the rates dh/dt of its 3 surfaces sign\(h\) have 5 terms \(one per "
        r"differential variable a surface depends on\); at most 4 are allowed",
    ):
        filippov_system(**kwargs)


def test_components_given_with_sign_are_refused():
    kwargs = _many(1)
    kwargs["components"] = [hybrid.Component("c", (Mode("a", algebraic={"x0": "x0"}),))]
    with pytest.raises(ModelError, match="gets its components from its surfaces"):
        filippov_system(**kwargs)


def test_a_transition_from_a_filippov_mode_to_itself_re_enters_it():
    """A block braked by Coulomb friction (x'' = -mu sign(x')) bounces on a wall at x = 0 (v := -e v,
    a transition of its mode to itself): after the impact the state is on the other side of the
    surface v = 0, which the component must learn through its entry (without it, `minus` would
    take the state for one reaching v = 0 and stop it). From x = 1, v = -2, mu = 1/2, e = 1/2: the
    wall at t1 = 4 - 2 sqrt(3) with v = -sqrt(3), then v = sqrt(3)/2 braked to rest at
    t1 + sqrt(3), x = 3/4, stuck."""
    kwargs = dict(
        name="bounce",
        variables=["x", "v"],
        parameters=["mu", "e"],
        modes=[Mode("m", derivatives={"x": "v", "v": "-mu*sign(v)"})],
        transitions=[Transition("m", "m", "x", -1, "impact", {"v": "-e*v"})],
        initial_mode="m",
    )
    s = filippov_system(**kwargs)
    assert s.mode_names == ("m", "m_")  # its twin: the impact goes from one to the other
    assert [(t.source, t.target) for t in s.transitions] == [("m", "m_"), ("m_", "m")]
    ref = expanded.filippov_system(**kwargs)
    p = {"mu": 0.5, "e": 0.5}
    t1 = 4.0 - 2.0 * math.sqrt(3.0)
    grid = np.linspace(0.0, 4.0, 41)
    for options in (EXACT, IDA):
        tr = simulate(s, p, (0.0, 4.0), {"x": 1.0, "v": -2.0}, t_eval=grid, options=options)
        assert tr.status == Status.COMPLETED
        moves = [(e.guard, e.target) for e in tr.events if not e.chained]
        assert moves == [("impact", "m_|m_minus"), ("sign_1.reach", "m_|m__slide")]
        assert [e.t for e in tr.events if not e.chained] == pytest.approx([t1, t1 + math.sqrt(3.0)], abs=1e-9)
        assert tr.final("x") == pytest.approx(0.75, abs=1e-9)
        assert tr.final("v") == 0.0
        r = simulate(ref, p, (0.0, 4.0), {"x": 1.0, "v": -2.0}, t_eval=grid, mode0="m", options=options)
        assert np.max(np.abs(tr["x"] - r["x"])) <= 1e-9
        assert np.max(np.abs(tr["v"] - r["v"])) <= 1e-9


def test_a_sliding_coefficient_follows_a_parameter_read_at_run_time(coulomb_pair):
    """The slave block of a composed mode is factorised once per mode where it does not depend on
    the state (`slide`: d(dv/dt)/d sign_1 = -R/m); a parameter read at run time (continuation,
    the exact integrator) changes it: the factorisation is made again after set_runtime."""
    _, s = coulomb_pair
    p = s.preset("forced", R=0.2)
    cs = CompiledSystem(s, p, runtime=("R", "m"))
    slide = cs.modes[cs.mode_id("motion|slide")]
    y = np.array([0.1, 0.0, 0.0, 0.0, 0.0])  # x, v, W, D, sign_1 at t = 0: F sin(0) - k x = -0.1
    assert slide.solve_algebraic(0.0, y)[4] == pytest.approx(-0.1 / 0.2, rel=1e-14)
    cs.set_runtime({"R": 0.4})
    assert cs.modes[cs.mode_id("motion|slide")].solve_algebraic(0.0, y)[4] == pytest.approx(
        -0.1 / 0.4, rel=1e-14
    )
