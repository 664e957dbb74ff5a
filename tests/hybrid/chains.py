"""Friction chains written by hand for the tests of components (issue 22): one Component per contact,
and the same chains enumerated into 3**N modes (the independent, long-established path).

Block ``i`` (mass ``m``, spring ``k`` to ground, springs ``kc`` to its neighbours, viscous ``c``,
forced ``F sin(Omega t)``) rubs on the ground with Coulomb friction ``R_i``; its friction force
``f_i`` is a slave variable: ``0 = f_i -+ R_i`` while it slips, and, while it sticks, ``0 =`` its
acceleration's numerator (the block does not accelerate).
"""

from __future__ import annotations

import itertools

from hybrid import Component, HybridSystem, Mode, Transition, Variable

STATES = ("stick", "slip+", "slip-")


def _neighbours(i: int, n: int, ring: bool) -> list[int]:
    if ring and n > 2:
        return [(i - 2) % n + 1, i % n + 1]
    return [j for j in (i - 1, i + 1) if 1 <= j <= n]


def acceleration(i: int, n: int, ring: bool = False) -> str:
    """``m`` times block ``i``'s acceleration, friction force included."""
    s = f"F*sin(Omega*t) - k*x{i} - c*v{i} + f{i}"
    for j in _neighbours(i, n, ring):
        s += f" - kc*(x{i} - x{j})"
    return s


def contact_modes(i: int, n: int, ring: bool = False) -> list[Mode]:
    return [
        Mode("stick", algebraic={f"f{i}": acceleration(i, n, ring)}),
        Mode("slip+", algebraic={f"f{i}": f"f{i} + R{i}"}),
        Mode("slip-", algebraic={f"f{i}": f"f{i} - R{i}"}),
    ]


def contact_transitions(i: int) -> list[Transition]:
    return [
        Transition("stick", "slip+", f"f{i} + R{i}", -1, name="breakaway+"),
        Transition("stick", "slip-", f"f{i} - R{i}", 1, name="breakaway-"),
        Transition("slip+", "stick", f"v{i}", -1, name="stop+", reset={f"v{i}": "0"}),
        Transition("slip-", "stick", f"v{i}", 1, name="stop-", reset={f"v{i}": "0"}),
    ]


def _base(n: int, ring: bool):
    variables = [Variable(f"{p}{i}") for i in range(1, n + 1) for p in ("x", "v", "f")]
    equations = {}
    for i in range(1, n + 1):
        equations[f"x{i}"] = f"v{i}"
        equations[f"v{i}"] = f"({acceleration(i, n, ring)})/m"
    parameters = ["m", "k", "kc", "c", "F", "Omega"] + [f"R{i}" for i in range(1, n + 1)]
    return variables, equations, parameters


def composed_chain(n: int, ring: bool = False, gauge=None) -> HybridSystem:
    """The chain with one component per contact (``gauge``: its ``[orbit] gauge``, if any)."""
    variables, equations, parameters = _base(n, ring)
    components = [
        Component(f"c{i}", contact_modes(i, n, ring), contact_transitions(i)) for i in range(1, n + 1)
    ]
    return HybridSystem(
        name=f"chain{n}",
        variables=variables,
        parameters=parameters,
        modes=[Mode("motion")],
        transitions=[],
        equations=equations,
        period="2*pi/Omega",
        initial_mode="motion",
        components=components,
        orbit={} if gauge is None else {"gauge": gauge},
    )


def enumerated_chain(n: int, ring: bool = False) -> HybridSystem:
    """The same chain with its 3**n modes written out (no components)."""
    variables, equations, parameters = _base(n, ring)
    modes, transitions = [], []

    def name(states) -> str:
        return "_".join(states)

    for states in itertools.product(STATES, repeat=n):
        algebraic = {}
        for i, s in enumerate(states, 1):
            algebraic.update(contact_modes(i, n, ring)[STATES.index(s)].algebraic)
        modes.append(Mode(name(states), algebraic=algebraic))
        for i, s in enumerate(states, 1):
            for tr in contact_transitions(i):
                if tr.source == s:
                    target = list(states)
                    target[i - 1] = tr.target
                    transitions.append(
                        Transition(
                            name(states),
                            name(target),
                            tr.guard,
                            tr.direction,
                            name=f"c{i}.{tr.name}",
                            reset=dict(tr.reset),
                        )
                    )
    return HybridSystem(
        name=f"chain{n}e",
        variables=variables,
        parameters=parameters,
        modes=modes,
        transitions=transitions,
        equations=equations,
        period="2*pi/Omega",
        initial_mode=name(["stick"] * n),
    )


def chain_params(n: int, R: float = 0.3, mistuning: float = 0.1, **over: float) -> dict[str, float]:
    """The benchmark chain's parameters: m = k = kc = 1, c = 0.1, F = 1, Omega = 1,
    ``R_i = R (1 + mistuning (-1)**i)``."""
    p = {"m": 1.0, "k": 1.0, "kc": 1.0, "c": 0.1, "F": 1.0, "Omega": 1.0}
    p.update({f"R{i}": R * (1 + mistuning * (-1) ** i) for i in range(1, n + 1)})
    p.update(over)
    return p
