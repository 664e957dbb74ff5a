"""The built-in Coulomb oscillator against its exact piecewise free response (issue 2, (b)).

Free vibration (F = 0) from rest at x0: half cycles of a cosine about the shifted equilibrium
+-R/k, the turning-point amplitude dropping by 2R/k each half cycle, then stick forever at the
first turning point with |x| <= R/k. Reference: models/coulomb_exact.py (closed form).
"""

import numpy as np
import pytest

import hybrid_models
from hybrid import IDA, SolverOptions, simulate
from hybrid_models.coulomb_exact import free_response, stop_position, stop_time

TIGHT = SolverOptions(method=IDA(rtol=1e-12, atol=1e-14))


@pytest.mark.parametrize("x0", [1.0, -0.73, 2.55])
def test_free_coulomb_oscillator_matches_the_exact_piecewise_solution(x0):
    system = hybrid_models.coulomb()
    p = system.preset("free")  # m = 1 kg, k = 1 N/m, R = 0.1 N, F = 0
    m, k, R = p["m"], p["k"], p["R"]
    t_stop = stop_time(m, k, R, x0)
    t_end = t_stop + 5.0
    t_eval = np.linspace(0.0, t_end, 801)
    tr = simulate(system, p, (0.0, t_end), {"x": x0, "v": 0.0}, "stick", t_eval=t_eval, options=TIGHT)
    x_ex, v_ex = free_response(m, k, R, x0, t_eval)
    assert np.max(np.abs(tr["x"] - x_ex)) <= 1e-8 * abs(x0)
    assert np.max(np.abs(tr["v"] - v_ex)) <= 1e-8 * abs(x0) * np.sqrt(k / m)
    # switch times: a stop (v = 0) every half period pi*sqrt(m/k), the last one for good
    stops = [ev.t for ev in tr.events if ev.guard.startswith("stop")]
    half = np.pi * np.sqrt(m / k)
    assert np.allclose(stops, half * np.arange(1, len(stops) + 1), rtol=0, atol=1e-8)
    assert abs(stops[-1] - t_stop) <= 1e-8
    assert tr.mode_final == "stick"
    assert abs(tr.final("x") - stop_position(m, k, R, x0)) <= 1e-8 * abs(x0)
    # every intermediate stop chains at once into the opposite slip (|k x| > R there)
    for ev in tr.events:
        if ev.source == "stick":
            assert ev.chained
    # energy: all the initial spring energy minus the final one went into friction
    assert abs(tr.final("D") - 0.5 * k * (x0**2 - stop_position(m, k, R, x0) ** 2)) <= 1e-9


def test_inside_the_static_band_the_oscillator_never_moves():
    system = hybrid_models.coulomb()
    p = system.preset("free")
    tr = simulate(system, p, (0.0, 10.0), {"x": 0.09, "v": 0.0}, "stick")
    assert tr.n_transitions == 0
    assert np.all(tr["x"] == 0.09)
