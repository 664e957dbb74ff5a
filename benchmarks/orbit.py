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

Second part (issue 7, "Must show"): time per periodic orbit with multipliers *from a continuation
neighbour*, median over a branch of the absorber's first stick-slip band (Omega from 0.8532 to
0.8556 rad/s in steps of 2e-4), each orbit started from the previous one's section state (the
section time scaled with the period, so the phase stays), for the engine with IDA (rtol 1e-10), the
engine with the exact integrator, and the paper's approach (Karnopp + FD shooting, started from
its own previous orbit); every ratio is the paper's time over the method's. Accuracy of each against
a tight reference (engine, IDA rtol 1e-12, tol 1e-11) at the same section (the engine may move its
section away from a switch; the paper's keeps its own, where the reference is run to): the largest state error
relative to the largest component and the largest multiplier error, over the branch. The engine is
timed with its default 512 samples per period (amplitudes) and with the fewest, 16.

Run: ``python benchmarks/orbit.py`` (about two minutes on 2 cores); ``--branch`` for the second
part only.
"""

from __future__ import annotations

import time

import numpy as np

import models
from hybrid import SolverOptions, periodic_orbit, simulate
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


#: Omega values of the branch; it ends before the orbit's slip phases vanish (0.85587: a family).
BRANCH = np.round(np.arange(0.8532, 0.85561, 2e-4), 6)


def state_at(system, p, orbit, t, options):
    """The reference orbit's state at time ``t`` (a tight run from its section)."""
    t = t % orbit.period
    if t < orbit.t0:
        t += orbit.period
    if t == orbit.t0:
        return orbit.x0
    tr = simulate(system, p, (orbit.t0, t), orbit.x0, orbit.mode0, options=options, samples_per_period=16)
    return tr.y_final


def branch() -> None:
    """Median time per orbit from a continuation neighbour, IDA and exact vs the paper's approach."""
    import os

    absorber = models.absorber()
    names = absorber.variable_names
    idx = [names.index(n) for n in STATE]
    base = absorber.preset("standard")
    tight = SolverOptions(rtol=1e-12, atol=1e-14)
    methods = {
        "engine, IDA rtol 1e-10": (SolverOptions(), 512),
        "engine, IDA rtol 1e-10, 16 samples": (SolverOptions(), 16),
        "engine, exact": (SolverOptions(integrator="exact"), 512),
        "engine, exact, 16 samples": (SolverOptions(integrator="exact"), 16),
    }
    p0 = {**base, "Omega": float(BRANCH[0])}
    start = periodic_orbit(absorber, p0, options=tight, tol=1e-11)
    # Section in the middle of the longest mode interval (from rest it may sit near a switch).
    sw = np.concatenate([start.switch_times, [start.switch_times[0] + start.period]])
    k = int(np.argmax(np.diff(sw)))
    tr = start.trajectory
    j = int(np.argmin(np.abs(tr.t - 0.5 * (sw[k] + sw[k + 1]) % start.period)))
    start = periodic_orbit(
        absorber,
        p0,
        tr.y[j],
        str(tr.mode[j]),
        t0=float(tr.t[j]),
        transient_periods=0,
        options=tight,
        tol=1e-11,
    )
    assert start.converged, start.message
    prev = {name: start for name in [*methods, "ref"]}
    kar_prev = shoot_karnopp(
        "absorber", {**base, "Omega": float(BRANCH[0])}, start.x0[idx], nu=1e-5, t0=start.t0
    )
    times: dict[str, list[float]] = {name: [] for name in [*methods, "paper"]}
    xerr: dict[str, float] = {name: 0.0 for name in [*methods, "paper"]}
    merr: dict[str, float] = {name: 0.0 for name in [*methods, "paper"]}
    failed: dict[str, int] = {name: 0 for name in [*methods, "paper"]}
    om_prev = float(BRANCH[0])
    for om in BRANCH[1:]:
        om = float(om)
        p = {**base, "Omega": om}
        ratio = om_prev / om  # the section's phase stays: t0 scales with the period

        def neighbour(o, opts, tol=1e-9, samples=512, p=p, ratio=ratio):
            return periodic_orbit(
                absorber,
                p,
                o.x0,
                o.mode0,
                t0=o.t0 * ratio,
                transient_periods=0,
                options=opts,
                tol=tol,
                samples_per_period=samples,
            )

        ref = neighbour(prev["ref"], tight, 1e-11)
        assert ref.converged, ref.message
        x_ref = ref.x0[idx]
        scale = np.max(np.abs(x_ref))
        mu_ref = [m for m, k in zip(ref.multipliers, ref.multiplier_kinds, strict=True) if k == "floquet"]
        for name, (opts, samples) in methods.items():
            t = time.perf_counter()
            o = neighbour(prev[name], opts, samples=samples)
            times[name].append(time.perf_counter() - t)
            if not o.converged or abs(o.t0 - ref.t0) > 1e-12 * ref.period:
                failed[name] += 1
                continue
            prev[name] = o
            xerr[name] = max(xerr[name], float(np.max(np.abs(o.x0[idx] - x_ref)) / scale))
            merr[name] = max(merr[name], mult_error(o.multipliers, mu_ref))
        t = time.perf_counter()
        kar = shoot_karnopp("absorber", p, kar_prev.y0, nu=1e-5, t0=kar_prev.t0 * ratio)
        times["paper"].append(time.perf_counter() - t)
        if kar.converged:
            kar_prev = kar
            x_kar = state_at(absorber, p, ref, kar.t0, tight)[idx]  # the reference at the paper's section
            xerr["paper"] = max(xerr["paper"], float(np.max(np.abs(kar.y0 - x_kar)) / scale))
            merr["paper"] = max(merr["paper"], mult_error(kar.multipliers, mu_ref))
        else:
            failed["paper"] += 1
        prev["ref"] = ref
        om_prev = om
    load = os.getloadavg()
    print(
        f"\nabsorber, first stick-slip band: {BRANCH.size - 1} orbits, Omega {BRANCH[1]:.4f}..{BRANCH[-1]:.4f} "
        f"rad/s, each from its neighbour; load average {load[0]:.2f} (2 cores)"
    )
    print(
        f"{'method':40s} {'median [ms]':>11s} {'paper/this':>10s} {'state err':>10s} {'mult err':>9s} {'failed':>6s}"
    )
    t_paper = float(np.median(times["paper"]))
    for name in [*methods, "paper"]:
        t = float(np.median(times[name]))
        label = "paper: Karnopp + FD shooting" if name == "paper" else name
        print(
            f"{label:40s} {1e3 * t:11.1f} {t_paper / t:10.1f} {xerr[name]:10.2e} {merr[name]:9.2e} {failed[name]:6d}"
        )


if __name__ == "__main__":
    import sys

    if "--branch" not in sys.argv:
        main()
    branch()
