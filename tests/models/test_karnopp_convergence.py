"""The paper's Karnopp model converges to the event-driven result as its band nu -> 0 (issue 2, (d)).

Two independent formulations: the Karnopp ODE of models/karnopp.py through scipy's solve_ivp (no events,
u integrated in both phases) and the hybrid automaton of models/*.toml on IDA (u a slave variable while
slipping). Measured (10 periods, 40 switches): error ~ nu^2 down to the solve_ivp floor, e.g. absorber
5.5e-6, 5.7e-8, 1.8e-9 and isolator 7.0e-5, 7.1e-7, 7.2e-9 for nu = 1e-3, 1e-4, 1e-5 m/s.
"""

import numpy as np
import pytest

import hybrid_models
from hybrid import IDA, SolverOptions, simulate
from hybrid_models.karnopp import simulate_karnopp

CASES = {
    "absorber": [5.0, 0.0, 5.0, 0.0, 5.0],
    "isolator": [4.0, 0.0, 4.0, 0.0, 4.0 / 101.0],
}


@pytest.mark.slow
@pytest.mark.parametrize("name", list(CASES))
def test_karnopp_converges_to_the_event_driven_solution(name):
    system = hybrid_models.BUILTIN[name]()
    p = system.preset("standard")
    y0 = CASES[name]
    t_end = 10 * 2 * np.pi / p["Omega"]
    ref = simulate(
        system,
        p,
        (0.0, t_end),
        dict(zip(("x1", "v1", "x2", "v2", "u"), y0, strict=True)),
        "stick",
        t_eval=[t_end],
        options=SolverOptions(method=IDA(rtol=1e-12, atol=1e-14)),
    )
    assert ref.n_transitions > 30
    y_ref = ref.y_final[:5]
    errors = []
    for nu in (1e-3, 1e-4, 1e-5):
        k = simulate_karnopp(name, p, (0.0, t_end), np.array(y0), nu=nu, rtol=1e-11, atol=1e-13)
        errors.append(np.max(np.abs(k.y[-1] - y_ref)) / np.max(np.abs(y_ref)))
    print(name, "relative error for nu = 1e-3, 1e-4, 1e-5:", errors)
    assert errors[1] < errors[0] / 30  # ~ nu^2
    assert errors[2] < errors[1] / 5
    assert errors[2] < 2e-8
    # The work and dissipation of both models agree too.
    k = simulate_karnopp(name, p, (0.0, t_end), np.array(y0), nu=1e-5, rtol=1e-11, atol=1e-13)
    assert abs(k.D[-1] - ref.final("D")) <= 1e-6 * ref.final("D")  # measured 1.5e-7 (isolator)
    assert abs(k.W[-1] - ref.final("W")) <= 1e-6 * (abs(ref.final("W")) + ref.final("D"))
