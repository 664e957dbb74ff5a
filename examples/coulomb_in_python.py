"""A model built in Python: a Coulomb oscillator as a hybrid automaton, against its closed form.

A mass ``m`` on a spring ``k`` with Coulomb friction ``R``, released from rest at ``x0``: it
slides back and forth, losing ``2 R / k`` of amplitude every half cycle of ``pi sqrt(m/k)``.
Two modes (sliding left, sliding right) and the turning points between them as transitions;
``simulate`` locates each. The script checks the turning points against the closed form
``x_n = (-1)^n (x0 - 2 n R / k)`` over the first three half cycles (the mass would stick at
the fourth turning point here, ``|x| <= R / k``: a stuck mode and its transitions are left
out to keep the example short; ``models/coulomb.toml`` has them).
"""

import numpy as np

from hybrid import IDA, HybridSystem, Mode, SolverOptions, Transition, simulate

coulomb = HybridSystem(
    name="coulomb_free",
    variables=["x", "v"],
    parameters=["m", "k", "R"],
    equations={"x": "v"},
    modes=[
        Mode("left", derivatives={"v": "(-k*x + R)/m"}),  # v < 0: friction pushes right
        Mode("right", derivatives={"v": "(-k*x - R)/m"}),  # v > 0
    ],
    transitions=[
        # a turning point: the velocity crosses zero; the mass slides on if the spring beats friction
        Transition("left", "right", guard="v", direction=1, name="turn+"),
        Transition("right", "left", guard="v", direction=-1, name="turn-"),
    ],
)
params = {"m": 1.0, "k": 1.0, "R": 0.1}  # kg, N/m, N
x0 = 1.0  # m
tr = simulate(
    coulomb,
    params,
    (0.0, 3.5 * np.pi),
    {"x": x0, "v": 0.0},
    "left",
    options=SolverOptions(method=IDA(rtol=1e-10, atol=1e-12)),
)
print(tr)
turns = [ev for ev in tr.events if ev.guard in ("turn+", "turn-")]
dk = 2 * params["R"] / params["k"]
worst = 0.0
for n, ev in enumerate(turns, start=1):
    expected = (-1) ** n * (x0 - n * dk)
    x = ev.x_plus[0]  # the state just after the switch, in variable order (x, v)
    worst = max(worst, abs(x - expected))
    print(f"turn {n} at t = {ev.t:.6f} s: x = {x:+.10f} m (closed form {expected:+.10f})")
print(f"largest difference from the closed form: {worst:.2e} m")
assert worst < 1e-8, worst
assert np.isclose(turns[0].t, np.pi, rtol=1e-8)  # half a period sqrt(m/k) * pi
