"""Wall time per forcing period of the event-driven absorber against the paper's Karnopp model.

Both run in this process on the same case: the absorber at the paper's standard parameters
(Omega = 0.854 rad/s) in its stick-slip regime, started from x1 = x2 = u = 5 m at rest, for
50 forcing periods (about 200 stick/slip switches). Accuracy is the largest error of the final
state (x1, v1, x2, v2, u) relative to its largest component, against an event-driven run at
rtol = 1e-12. The baseline is the paper's numerical model (Karnopp friction, Eqs. 10-13) through
``scipy.integrate.solve_ivp`` (models/karnopp.py).

Run: ``python benchmarks/simulate.py`` (about a minute on 2 cores).
"""

from __future__ import annotations

import time

import numpy as np

import hybrid_models
from hybrid import IDA, SolverOptions, simulate
from hybrid_models.karnopp import simulate_karnopp

PERIODS = 50
REPEAT = 3


def best_time(fn):
    best, result = np.inf, None
    for _ in range(REPEAT):
        t0 = time.perf_counter()
        result = fn()
        best = min(best, time.perf_counter() - t0)
    return best, result


def main() -> None:
    system = hybrid_models.absorber()
    p = system.preset("standard")
    T = 2 * np.pi / p["Omega"]
    t_end = PERIODS * T
    y0 = np.array([5.0, 0.0, 5.0, 0.0, 5.0])
    x0 = dict(zip(("x1", "v1", "x2", "v2", "u"), y0, strict=True))

    ref = simulate(
        system,
        p,
        (0, t_end),
        x0,
        "stick",
        t_eval=[t_end],
        options=SolverOptions(method=IDA(rtol=1e-12, atol=1e-14)),
    )
    y_ref = ref.y_final[:5]

    def err(y):
        return float(np.max(np.abs(np.asarray(y)[:5] - y_ref)) / np.max(np.abs(y_ref)))

    rows = []
    for rtol in (1e-8, 1e-9, 1e-10):
        t_ev, tr = best_time(
            lambda rtol=rtol: simulate(
                system,
                p,
                (0, t_end),
                x0,
                "stick",
                t_eval=[t_end],
                options=SolverOptions(method=IDA(rtol=rtol, atol=rtol * 1e-2)),
            )
        )
        rows.append(
            (f"event-driven hybrid on IDA, rtol {rtol:g}", t_ev, err(tr.y_final), tr.nfev, tr.n_transitions)
        )
    for method, rtol, nu in (
        ("RK45", 1e-8, 1e-10),
        ("RK45", 1e-10, 1e-10),
        ("DOP853", 1e-10, 1e-10),
        ("RK45", 1e-8, 1e-6),
    ):
        t_k, k = best_time(
            lambda method=method, rtol=rtol, nu=nu: simulate_karnopp(
                "absorber", p, (0, t_end), y0, nu=nu, method=method, rtol=rtol, atol=rtol * 1e-2
            )
        )
        rows.append(
            (f"Karnopp (paper) solve_ivp {method}, rtol {rtol:g}, nu {nu:g}", t_k, err(k.y[-1]), k.nfev, None)
        )

    print(f"absorber, standard parameters, Omega = {p['Omega']} rad/s, {PERIODS} periods of stick-slip")
    print(f"reference: event-driven rtol 1e-12 ({ref.n_transitions} switches)\n")
    print(f"{'run':58s} {'ms/period':>10s} {'ratio':>7s} {'rel. error':>11s} {'nfev':>8s}")
    base = rows[0][1]
    for name, t, e, nfev, _ in rows:
        print(f"{name:58s} {1e3 * t / PERIODS:10.2f} {t / base:7.2f} {e:11.2e} {nfev:8d}")
    print("\nratio = wall time / wall time of the event-driven run (same process, best of 3)")


if __name__ == "__main__":
    main()
