"""The three shipped networks of many contacts (issue 22) against independent results.

* ``bk_chain``: the forced Burridge-Knopoff chain of 3 blocks, composed (one component per contact),
  against the same chain enumerated by hand into its 27 modes (the old way: every combination of
  contact states a mode of its own), to the last bit with the exact integrator; the chain of 6
  blocks against an independent event-driven reference (``data/bk_chain_reference_N6.json``).
* ``iwan``: the energy an Iwan joint of 5 Jenkins elements dissipates per period of its periodic
  orbit against Masing's closed form, ``sum_i 4 R_i (X - R_i/k_i)`` over the elements that slide
  (``benchmarks/iwan_masing.py`` does the 50 elements of the shipped file).
* ``bladed_disk``: a tuned ring under a travelling wave of engine order EO has a periodic orbit
  with the ring's cyclic symmetry, blade ``i + 1`` at ``t + EO T/N`` being blade ``i`` at ``t``
  (the ring closed, the phases right).

Tolerances are stated at each assertion; measured figures are printed (run with ``-s``).
"""

from __future__ import annotations

import itertools
import json
import tomllib
from pathlib import Path

import numpy as np
import pytest

import hybrid_models
from hybrid import (
    Exact,
    HybridSystem,
    Mode,
    SolverOptions,
    Transition,
    Variable,
    periodic_orbit,
    simulate,
    system_from_dict,
)

MODEL_DIR = Path(hybrid_models.__file__).parent
DATA = Path(__file__).parent / "data"
EXACT = SolverOptions(method=Exact())
FIGURES: dict[str, float] = {}


@pytest.fixture(scope="module", autouse=True)
def _report():
    yield
    print("\nfriction network figures:")
    for k, v in FIGURES.items():
        print(f"  {k}: {v:.3g}")


def _record(key: str, value: float) -> float:
    FIGURES[key] = max(FIGURES.get(key, 0.0), float(value))
    return value


def _file(name: str, count: int | None = None, **preset_changes) -> dict:
    """A shipped network file's content, with its cell repeated ``count`` times."""
    data = tomllib.loads((MODEL_DIR / f"{name}.toml").read_text())
    if count is not None:
        (cell,) = data["cells"].values()
        cell["count"] = count
    for preset, table in preset_changes.items():
        data["presets"] = {preset: table}
    return data


# ----------------------------------------------------------------------------
# Burridge-Knopoff chain
# ----------------------------------------------------------------------------
STATES = ("stick", "slip+", "slip-")


def _chain3_enumerated() -> HybridSystem:
    """The 3-block chain of bk_chain.toml written by hand as 27 modes: one per combination of the
    contacts' states, each with the algebraic equations of the three friction forces, and the 4
    transitions of each contact out of each combination (108 in all). The expressions are those the
    builder writes (so that both integrate the same arithmetic): force f_i on the ground, -f_i on
    block i; stuck, the block's net force is 0; sliding, f_i = +-R_i; a stop resets v_i to 0."""
    net = {
        1: "k*(-x_1) + kc*(x_2 - x_1) + c*(-v_1) - f_contact_1 + drive_1",
        2: "kc*(x_1 - x_2) + k*(-x_2) + kc*(x_3 - x_2) + c*(-v_2) - f_contact_2 + drive_2",
        3: "kc*(x_2 - x_3) + k*(-x_3) + c*(-v_3) - f_contact_3 + drive_3",
    }
    local = {
        "stick": lambda i: net[i],
        "slip+": lambda i: f"f_contact_{i} - R_{i}",
        "slip-": lambda i: f"f_contact_{i} + R_{i}",
    }
    equations = {}
    for i in (1, 2, 3):
        equations[f"x_{i}"] = f"v_{i}"
        equations[f"v_{i}"] = f"({net[i]})/m"
    equations["W"] = "drive_1*v_1 + drive_2*v_2 + drive_3*v_3"
    equations["D"] = (
        "f_contact_1*w_contact_1 + f_contact_2*w_contact_2 + f_contact_3*w_contact_3 + c*(v_1)**2 "
        "+ c*(v_2)**2 + c*(v_3)**2"
    )
    modes, transitions = [], []
    for states in itertools.product(STATES, repeat=3):
        name = "_".join(states)
        modes.append(Mode(name, algebraic={f"f_contact_{i}": local[s](i) for i, s in enumerate(states, 1)}))
        for i, s in enumerate(states, 1):
            out = (
                [
                    ("slip+", f"f_contact_{i} - R_{i}", 1, "breakaway+"),
                    ("slip-", f"f_contact_{i} + R_{i}", -1, "breakaway-"),
                ]
                if s == "stick"
                else [("stick", f"w_contact_{i}", -1 if s == "slip+" else 1, f"stop{s[-1]}")]
            )
            for target, guard, direction, tname in out:
                to = "_".join(states[: i - 1] + (target,) + states[i:])
                reset = {f"v_{i}": "0"} if target == "stick" else {}
                transitions.append(
                    Transition(name, to, guard, direction, name=f"contact_{i}.{tname}", reset=reset)
                )
    data = _file("bk_chain", 3)
    composed = system_from_dict(data)
    return HybridSystem(
        name="chain3_enumerated",
        variables=[Variable(n) for n in composed.variable_names],
        parameters=composed.parameters,
        modes=modes,
        transitions=transitions,
        equations=equations,
        definitions={
            **{f"drive_{i}": "F*sin(Omega*t)" for i in (1, 2, 3)},
            **{f"w_contact_{i}": f"v_{i}" for i in (1, 2, 3)},
        },
        quadratures=("W", "D"),
        period="2*pi/Omega",
        initial_mode="stick_stick_stick",
        presets=composed.presets,
    )


def test_bk_chain_of_three_blocks_composed_equals_its_27_modes_enumerated_by_hand():
    composed = system_from_dict(_file("bk_chain", 3))
    enumerated = _chain3_enumerated()
    assert len(enumerated.modes) == 27
    assert len(enumerated.transitions) == 108
    assert len(composed.components) == 3
    assert composed.mode_names == ("motion",)
    p = composed.preset("standard")
    assert [p[f"R_{i}"] for i in (1, 2, 3)] == [0.27, 0.33, 0.27]
    zero = dict.fromkeys(composed.variable_names, 0.0)
    t_eval = np.linspace(0.0, 50.0, 501)
    a = simulate(composed, p, (0.0, 50.0), zero, t_eval=t_eval, options=EXACT)
    b = simulate(enumerated, p, (0.0, 50.0), zero, t_eval=t_eval, options=EXACT)
    assert a.success and b.success
    assert len(a.events) == len(b.events) >= 45  # 3 break-aways, 14-15 reversals per block
    assert [(e.source, e.target) for e in a.events] == [
        ("motion|" + e.source.replace("_", "|"), "motion|" + e.target.replace("_", "|")) for e in b.events
    ]
    assert [e.guard for e in a.events] == [e.guard for e in b.events]
    # to the last bit: the switch instants, the states at the switches and at every sample
    assert [e.t for e in a.events] == [e.t for e in b.events]
    assert all(np.array_equal(e.x_plus, f.x_plus) for e, f in zip(a.events, b.events, strict=True))
    assert np.array_equal(a.y, b.y)


def test_bk_chain_of_six_blocks_against_an_independent_event_driven_reference():
    """50 s of the chain of the Siconos benchmark against a reference written without this library
    (an exact linear flow between events by Taylor series, its own event logic). With the exact
    integrator at rtol 1e-12 (its tolerances set the noise band within which two guards count as
    crossing together: at the default 1e-8 the break-aways of blocks 2 and 4, 8.2e-9 s apart, are
    taken at one instant)."""
    ref = json.loads((DATA / "bk_chain_reference_N6.json").read_text())
    system = system_from_dict(_file("bk_chain", 6))
    tr = simulate(
        system,
        system.preset("standard"),
        (0.0, 50.0),
        dict.fromkeys(system.variable_names, 0.0),
        options=SolverOptions(method=Exact()),
    )
    assert tr.success

    def block(ev) -> int:
        return int(ev.guard.split(".")[0].rsplit("_", 1)[1])

    breakaways = sorted(
        (e.t, block(e)) for e in tr.events if "breakaway" in e.guard and "stick" in e.source and e.t < 1.0
    )
    stops = sorted((e.t, block(e)) for e in tr.events if ".stop" in e.guard)
    ref_breakaways = sorted((t, b) for t, b, _ in ref["switches"])
    ref_reversals = sorted((t, b) for t, b in ref["reversals"])
    assert [b for _, b in breakaways] == [b for _, b in ref_breakaways]
    assert [b for _, b in stops] == [b for _, b in ref_reversals]  # 90: every stop is a reversal
    dt = max(
        abs(a - b) for (a, _), (b, _) in zip(breakaways + stops, ref_breakaways + ref_reversals, strict=True)
    )
    assert _record("6-block chain vs reference: switch times [s]", dt) <= 1e-11  # measured 4.3e-13
    # every reversal is a stop followed at once by a break-away the other way (no stick phase)
    assert len(tr.events) == 6 + 2 * 90
    dx = max(abs(tr.final(f"x_{i}") - ref["x_end"][i - 1]) for i in range(1, 7))
    dv = max(abs(tr.final(f"v_{i}") - ref["v_end"][i - 1]) for i in range(1, 7))
    assert _record("6-block chain vs reference: x(50 s) [m] (|x| ~ 5.5 m)", dx) <= 1e-11  # measured 9e-13
    assert _record("6-block chain vs reference: v(50 s) [m/s]", dv) <= 1e-11  # measured 2.7e-12


# ----------------------------------------------------------------------------
# Iwan joint: Masing's rule
# ----------------------------------------------------------------------------
def masing_dissipation(R: np.ndarray, k: float, X: float) -> float:
    """Energy a set of Jenkins elements (springs ``k`` in series with sliders ``R``) dissipates in a
    cycle of amplitude ``X`` between ``-X`` and ``X``: ``sum 4 R_i (X - R_i/k)`` over ``R_i/k < X``."""
    slide = R / k < X
    return float(np.sum(4.0 * R[slide] * (X - R[slide] / k)))


def test_iwan_joint_dissipation_per_period_is_masings_closed_form():
    """Five Jenkins elements (slipping at x = 0.1, 0.325, ..., 1 m), the mass swinging over +-1.21 m:
    every element slides twice a period and the friction dissipation D over one period of the exact
    periodic orbit equals Masing's sum to 1e-9 (there is no damper: D is friction only)."""
    N = 5
    data = _file("iwan", N)
    data["presets"]["standard"]["jenkins"]["R"] = {"linear": [0.1 / N, 1.0 / N]}
    system = system_from_dict(data)
    p = system.preset("standard")
    orbit = periodic_orbit(system, p, options=EXACT)
    assert orbit.converged
    assert orbit.stability == "stable"
    tr = orbit.trajectory
    # the turning points are the instants where every sliding element stops at once (v = 0)
    ix = system.variable_names.index("x")
    turns = [e.x_minus[ix] for e in tr.events if e.guard.endswith(".stop+") or e.guard.endswith(".stop-")]
    X_top, X_bottom = max(turns), min(turns)
    assert abs(X_top + X_bottom) <= 1e-12 * X_top  # a symmetric orbit
    X = X_top
    assert abs(X - 0.5 * (np.max(tr["x"]) - np.min(tr["x"]))) <= 1e-12 * X
    R = np.array([p[f"R_{i}"] for i in range(1, N + 1)])
    k = p["K"] / N
    assert np.all(R / k < X)  # every element slides
    expected = masing_dissipation(R, k, X)
    D = tr["D"][-1] - tr["D"][0]
    FIGURES["Iwan N=5: amplitude X [m]"] = X
    FIGURES["Iwan N=5: dissipated per period [J]"] = D
    assert _record("Iwan N=5: dissipation vs Masing, relative", abs(D - expected) / expected) <= 1e-9
    # and the work of the force over the period is what is dissipated (a periodic orbit)
    assert abs(tr["W"][-1] - tr["W"][0] - D) <= 1e-9 * D


# ----------------------------------------------------------------------------
# Bladed disk: the ring's cyclic symmetry under a travelling wave
# ----------------------------------------------------------------------------
def test_bladed_disk_orbit_under_a_travelling_wave_has_the_rings_cyclic_symmetry():
    """Six tuned blades, engine order 1: blade i+1 lags blade i by T EO/N in the periodic orbit, for
    the displacements, velocities and damper forces (blade 6 -> blade 1 across the ring's closure)."""
    N, EO = 6, 1.0
    data = _file("bladed_disk", N)
    del data["presets"]["mistuned"]  # its list has 24 values
    system = system_from_dict(data)
    p = system.preset("tuned", EO=EO, F=0.03, Omega=1.2)
    orbit = periodic_orbit(system, p, options=EXACT)
    assert orbit.converged
    assert len(orbit.switch_times) == 4 * N  # every damper sticks and slips both ways
    tau = orbit.period * EO / N
    later = simulate(
        system,
        orbit.params,
        (orbit.t0, orbit.t0 + orbit.period),
        orbit.x0,
        orbit.mode0,
        t_eval=[orbit.t0 + tau],
        options=EXACT,
    )
    now = dict(zip(system.variable_names, orbit.x0, strict=True))
    scale = max(abs(now[f"x_{i}"]) for i in range(1, N + 1))
    worst = 0.0
    for i in range(1, N + 1):
        j = i % N + 1
        for name in ("x", "v", "f_damper"):
            worst = max(worst, abs(later[f"{name}_{j}"][0] - now[f"{name}_{i}"]))
    assert _record("bladed disk: cyclic symmetry, largest difference / amplitude", worst / scale) <= 1e-10
