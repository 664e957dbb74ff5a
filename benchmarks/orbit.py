"""Time per periodic orbit with Floquet multipliers: exact-monodromy shooting vs the paper's approach.

Case: the absorber at the paper's standard parameters, Omega = 0.854 rad/s (a stick-slip orbit
with multipliers about 0.995). Both methods start from the same guess, the state of a reference
orbit with every component 10 % off, with the section at the reference's section time, and both
return the orbit's state and its Floquet multipliers:

* engine: :func:`hybrid.periodic_orbit` (event-driven IDA, monodromy from the variational
  equations and saltation matrices, Newton), rtol 1e-10 (its default);
* paper: the Karnopp model (Eqs. 10-13, nu = 1e-5 m/s) through ``scipy.integrate.solve_ivp``
  (DOP853, rtol 1e-10), Newton shooting with a central finite-difference Jacobian
  (:func:`models.karnopp.shoot_karnopp`).

Accuracy is measured against a tight-tolerance orbit (engine, rtol 1e-12): the largest error of
the section state relative to its largest component, and the largest multiplier error.
The engine's default pipeline from rest (a 10-period transient, then Newton) is timed too.

Run: ``python benchmarks/orbit.py`` (about half a minute on 2 cores).
"""

from __future__ import annotations

import time

import numpy as np

import models
from hybrid import SolverOptions, periodic_orbit
from models.karnopp import shoot_karnopp

REPEAT = 3
STATE = ["x1", "v1", "x2", "v2", "u"]


def best_time(fn):
    best, result = np.inf, None
    for _ in range(REPEAT):
        t0 = time.perf_counter()
        result = fn()
        best = min(best, time.perf_counter() - t0)
    return best, result


def mult_error(mu, ref):
    """Largest distance from each reference multiplier to the nearest one of ``mu``."""
    return max(float(np.min(np.abs(np.asarray(mu) - r))) for r in ref)


def main() -> None:
    absorber = models.absorber()
    p = absorber.preset("standard", Omega=0.854)
    names = absorber.variable_names
    idx = [names.index(n) for n in STATE]
    ref = periodic_orbit(absorber, p, options=SolverOptions(rtol=1e-12, atol=1e-14), tol=1e-11)
    assert ref.converged, ref.message
    x_ref = ref.x0[idx]
    mu_ref = [m for m, k in zip(ref.multipliers, ref.multiplier_kinds, strict=True) if k == "floquet"]
    scale = np.max(np.abs(x_ref))
    guess = ref.x0.copy()
    guess[idx] *= 1.1

    t_eng, eng = best_time(
        lambda: periodic_orbit(absorber, p, guess, ref.mode0, t0=ref.t0, transient_periods=0)
    )
    t_rest, rest = best_time(lambda: periodic_orbit(absorber, p))
    t_kar, kar = best_time(lambda: shoot_karnopp("absorber", p, guess[idx], nu=1e-5, t0=ref.t0))

    rows = [
        (
            "engine (exact monodromy), 10 % guess",
            t_eng,
            eng.x0[idx],
            eng.multipliers,
            eng.iterations,
            eng.converged,
        ),
        (
            "engine from rest (transient + Newton)",
            t_rest,
            rest.x0[idx] if rest.t0 == ref.t0 else None,
            rest.multipliers,
            rest.iterations,
            rest.converged,
        ),
        (
            "paper: Karnopp + FD shooting, 10 % guess",
            t_kar,
            kar.y0,
            kar.multipliers,
            kar.iterations,
            kar.converged,
        ),
    ]
    print(
        "absorber, Omega = 0.854 rad/s; reference orbit at rtol 1e-12: |multipliers| "
        + ", ".join(f"{abs(m):.6f}" for m in mu_ref)
    )
    print(f"{'method':44s} {'time [s]':>9s} {'ratio':>6s} {'iter':>5s} {'state err':>10s} {'mult err':>9s}")
    for name, t, x, mu, it, ok in rows:
        xerr = f"{np.max(np.abs(x - x_ref)) / scale:10.2e}" if x is not None else f"{'(other t0)':>10s}"
        merr = mult_error(mu, mu_ref)
        flag = "" if ok else "  NOT CONVERGED"
        print(f"{name:44s} {t:9.3f} {t / t_eng:6.2f} {it:5d} {xerr} {merr:9.2e}{flag}")
    print(f"Karnopp shooting: {kar.n_solves} solve_ivp periods; ratio = time / engine time (same guess)")


if __name__ == "__main__":
    main()
