"""Nothing lost (issue 22): every shipped network file gives the periodic orbits the enumerating builder
gave (exact integrator), now that its friction elements are components composed on demand.

The reference, ``data/network_orbits_before.json``, was recorded by ``data/network_orbits_before.py``
with the builder of commit 0247ea9 (every combination of element states a mode). Compared: the mode
sequence (the old ``slip+_stick`` is the new ``motion|slip+|stick``), the switch times, the state at
the section (the old variables; the new builder adds the slave variables ``f_NAME`` and ``vel_U``) and
the Floquet multipliers (the new ones without the zeros of the added slave variables).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import hybrid_models
from hybrid import Exact, SolverOptions, load_system, periodic_orbit, simulate

MODEL_DIR = Path(hybrid_models.__file__).parent
BEFORE = json.loads((Path(__file__).parent / "data" / "network_orbits_before.json").read_text())
#: Orbits agree to what the exact flows resolve: rounding amplified by cond(I - M) (measured below 3e-11).
BOUND = 1e-9
WORST: dict[str, float] = {}


@pytest.fixture(scope="module", autouse=True)
def _report():
    yield
    print("\nnetwork orbits against the enumerating builder's:")
    for k, v in WORST.items():
        print(f"  {k}: {v:.3g}")


def _record(key: str, value: float) -> float:
    WORST[key] = max(WORST.get(key, 0.0), float(value))
    return value


def _new_name(old: str) -> str:
    """``slip+_stick`` (one state per element, joined by _) as the composed system names it."""
    return "|".join(["motion", *old.split("_")])


def _state_at(system, orbit, t: float) -> dict[str, float]:
    """The orbit's state at time ``t`` (in ``[t0, t0 + T]``), by the exact flow from its section."""
    if t == orbit.t0:
        return dict(zip(system.variable_names, orbit.x0, strict=True))
    tr = simulate(
        system,
        orbit.params,
        (orbit.t0, orbit.t0 + orbit.period),
        orbit.x0,
        orbit.mode0,
        t_eval=[t],
        options=SolverOptions(method=Exact()),
    )
    return {n: float(tr[n][0]) for n in system.variable_names}


def _one_per_instant(switches: list, t0: float, T: float) -> list:
    """The reference's switches as phases of the forcing, those at one instant (a reversal through
    a stuck mode held for no time, recorded as two before issue 30) as one: the last mode entered."""
    out: list = []
    for s, m in switches:
        if out and abs(s - out[-1][0]) <= 1e-12 * T:
            out[-1] = (s, m)
        else:
            out.append((s, m))
    return sorted(((t0 + s) % T, m) for s, m in out)


@pytest.mark.slow
@pytest.mark.parametrize("case", sorted(BEFORE))
def test_shipped_network_orbit_equals_the_enumerating_builders(case):
    """The same orbit: the same switches at the same phases of the forcing, the same state at the
    old section (the section sits in the middle of the longest mode interval: on a symmetric orbit
    two intervals tie and the section may move by half a period), the same multipliers."""
    name, preset = case.split("/")
    ref = BEFORE[case]
    system = load_system(MODEL_DIR / f"{name}.toml")
    orbit = periodic_orbit(system, system.preset(preset), options=SolverOptions(method=Exact()))
    assert orbit.converged
    assert ref["converged"]
    T = ref["period"]
    assert abs(orbit.period - T) <= 1e-14 * T
    # the switches, by their phase of the forcing (mode entered, phase in [0, T))
    new = sorted(
        ((orbit.t0 + s) % T, m) for s, m in zip(orbit.switch_times, orbit.mode_sequence[1:], strict=True)
    )
    old = _one_per_instant(
        [(s, _new_name(m)) for s, m in zip(ref["switch_times"], ref["mode_sequence"][1:], strict=True)],
        ref["t0"],
        T,
    )
    assert [m for _, m in new] == [m for _, m in old]
    dt = max((abs(a - b) for (a, _), (b, _) in zip(new, old, strict=True)), default=0.0)
    assert _record("switch phases, largest difference [s]", dt) <= BOUND * T
    # the state at the old section (not the quadratures: they start at 0 at the section)
    t_old = ref["t0"] if ref["t0"] >= orbit.t0 else ref["t0"] + T
    y = _state_at(system, orbit, t_old)
    state = {n: v for n, v in ref["state"].items() if n not in system.quadratures}
    scale = max(abs(v) for v in state.values())
    dy = max(abs(y[n] - v) for n, v in state.items()) / scale
    assert _record("state at the old section, largest difference / largest state", dy) <= BOUND
    # the multipliers, without the structural zeros of the added slave variables
    old_mu = np.array([complex(*z) for z in ref["multipliers"]])
    kinds = np.array(orbit.multiplier_kinds)
    mu = np.asarray(orbit.multipliers)
    added = len(system.variables) - len(ref["state"])
    zeros = np.sort(np.abs(mu))[:added]
    assert (
        _record("multipliers of the added slave variables, largest modulus", np.max(zeros, initial=0.0))
        <= BOUND
    )
    kept = mu[np.argsort(np.abs(mu))][added:]
    dmu = np.max(np.abs(np.sort_complex(kept) - old_mu))
    assert _record("Floquet multipliers, largest difference", dmu) <= BOUND
    assert np.count_nonzero(kinds == "structural") >= added
