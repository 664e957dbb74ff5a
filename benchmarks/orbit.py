"""Time per periodic orbit with Floquet multipliers from a continuation neighbour: engine vs the paper.

Case: the absorber at the paper's standard parameters along its first stick-slip band
(Omega = 0.8555 down to 0.8539 rad/s in steps of 1e-4, 17 stable stick-slip orbits with
multipliers up to 0.998; below, towards the band's steep left edge, the paper's shooting no longer
converges from a neighbour 1e-4 away). Each orbit is started from the previous one's section state (a
continuation neighbour) and returns the orbit's state and its Floquet multipliers:

* engine, IDA path: :func:`hybrid.periodic_orbit` with ``transient_periods=0`` from the previous
  orbit (event-driven IDA, monodromy from the variational equations and saltation matrices,
  Newton with Broyden updates between exact monodromies), at rtol 1e-10 (its default) and
  tighter;
* paper: the Karnopp model (Eqs. 10-13, nu = 1e-5 m/s) through ``scipy.integrate.solve_ivp``
  (DOP853, rtol 1e-10), Newton shooting with a central finite-difference Jacobian
  (:func:`hybrid_models.karnopp.shoot_karnopp`), from the previous Karnopp orbit.

Accuracy is measured in the same run against reference orbits of the exact integrator (matrix
exponentials of the affine modes, tol 1e-12: accurate to rounding amplified by cond(I - M)) at the
same section time: the largest error of the section state relative to its largest
component over the branch, and the largest multiplier error. The ratio is the paper's median time
over the median time of the fastest engine setting at equal or better state accuracy.
Times are CPU times of this process (the machine may be loaded; ``uptime`` is printed).

Second part (issue 7, "Must show"): time per periodic orbit with multipliers *from a continuation
neighbour*, median over a branch of the absorber's first stick-slip band (Omega from 0.8532 to
0.8556 rad/s in steps of 2e-4), each orbit started from the previous one's section state (the
section time scaled with the period, so the phase stays), for the engine with IDA (rtol 1e-10), the
engine with the exact integrator, and the paper's approach (Karnopp + FD shooting, started from
its own previous orbit); every ratio is the paper's time over the method's, and the last lines name
the fastest setting of each integrator at equal or better accuracy (state and multipliers) than
the paper's approach, IDA at rtol 1e-10, 1e-11, 3e-12 and 1e-12. Accuracy of each against
a reference of the exact integrator (tol 1e-12; until 2026-11 the reference was IDA at rtol 1e-12,
whose own error, about 9e-9 on the state, was then charged to every method) at the same section
(the engine may move its section away from a switch; the paper's keeps its own, where the
reference is run to): the largest state error relative to the largest component and the largest
multiplier error, over the branch. The engine is
timed with its default 512 samples per period (amplitudes) and with the fewest, 16.

Run: ``python benchmarks/orbit.py`` (a few minutes on 2 cores); ``--branch`` for the second part only.
"""

from __future__ import annotations

import os
import time

import numpy as np

import hybrid
import hybrid_models
from hybrid import IDA, Exact, SolverOptions, periodic_orbit, simulate
from hybrid_models.karnopp import shoot_karnopp

STATE = ["x1", "v1", "x2", "v2", "u"]
OMEGAS = np.round(np.arange(0.8555, 0.85389, -1e-4), 6)
ENGINE_RTOLS = (1e-10, 1e-11, 3e-12)
EXACT = SolverOptions(method=Exact())


def mult_error(mu, ref):
    """Largest distance from each reference multiplier to the nearest one of ``mu``."""
    return max(float(np.min(np.abs(np.asarray(mu) - r))) for r in ref)


def floquet(o):
    return [m for m, k in zip(o.multipliers, o.multiplier_kinds, strict=True) if k == "floquet"]


def main() -> None:
    absorber = hybrid_models.absorber()
    names = absorber.variable_names
    idx = [names.index(n) for n in STATE]
    params = [absorber.preset("standard", Omega=float(w)) for w in OMEGAS]
    first = periodic_orbit(absorber, params[0])
    assert first.converged, first.message

    # Engine chains (the first orbit of each chain from `first`, not timed as a neighbour).
    chains = {}
    for rtol in ENGINE_RTOLS:
        opts = SolverOptions(method=IDA(rtol=rtol, atol=rtol * 1e-2))
        prev, times, orbits = first, [], []
        for p in params:
            c = time.process_time()
            o = periodic_orbit(
                absorber,
                p,
                prev.x0,
                prev.mode0,
                t0=prev.t0,
                options=opts,
                settings=hybrid.ShootingOptions(transient_periods=0),
            )
            times.append(time.process_time() - c)
            assert o.converged, (p["Omega"], o.message)
            orbits.append(o)
            prev = o
        chains[rtol] = (times[1:], orbits)

    # The paper's approach, chained the same way, at the section times of the engine's chain.
    sections = [o.t0 for o in chains[ENGINE_RTOLS[-1]][1]]
    prev_y, kar_times, kar = first.x0[idx], [], []
    for p, ts in zip(params, sections, strict=True):
        c = time.process_time()
        k = shoot_karnopp("absorber", p, prev_y, nu=1e-5, t0=ts)
        kar_times.append(time.process_time() - c)
        assert k.converged, (p["Omega"], k.message)
        kar.append(k)
        prev_y = k.y0
    kar_times = kar_times[1:]

    # References: orbits of the exact integrator at the same section times.
    refs = []
    for p, o in zip(params, chains[ENGINE_RTOLS[-1]][1], strict=True):
        r = periodic_orbit(
            absorber,
            p,
            o.x0,
            o.mode0,
            t0=o.t0,
            options=EXACT,
            settings=hybrid.ShootingOptions(newton=hybrid.NewtonOptions(tol=1e-12), transient_periods=0),
        )
        assert r.converged, r.message
        refs.append(r)

    def errors(states, mults, t0s):
        """Largest state and multiplier errors over the points whose section is the reference's."""
        xe = me = 0.0
        for x, mu, ts, r in zip(states, mults, t0s, refs, strict=True):
            if ts != r.t0:
                continue
            xr = r.x0[idx]
            xe = max(xe, float(np.max(np.abs(x - xr)) / np.max(np.abs(xr))))
            me = max(me, mult_error(mu, floquet(r)))
        return xe, me

    rows = []
    for rtol, (times, orbits) in chains.items():
        xe, me = errors([o.x0[idx] for o in orbits], [floquet(o) for o in orbits], [o.t0 for o in orbits])
        its = int(np.median([o.iterations for o in orbits]))
        rows.append((f"engine IDA, rtol {rtol:.0e}", float(np.median(times)), its, xe, me))
    kxe, kme = errors([k.y0 for k in kar], [k.multipliers for k in kar], sections)
    t_kar = float(np.median(kar_times))
    rows.append(
        ("paper: Karnopp + FD shooting", t_kar, int(np.median([k.iterations for k in kar])), kxe, kme)
    )

    print(f"load average: {' '.join(f'{v:.2f}' for v in os.getloadavg())} (2-core machine)")
    print(
        f"absorber, first stick-slip band, Omega {OMEGAS[0]} -> {OMEGAS[-1]} rad/s, {len(OMEGAS)} orbits, "
        "each from the previous one's section state; median CPU time per orbit with multipliers"
    )
    print(
        f"{'method':32s} {'time [ms]':>10s} {'iter':>5s} {'state err':>10s} {'mult err':>9s} {'paper/this':>11s}"
    )
    for name, t, it, xe, me in rows:
        print(f"{name:32s} {1e3 * t:10.1f} {it:5d} {xe:10.2e} {me:9.2e} {t_kar / t:11.1f}")
    fair = [r for r in rows[:-1] if r[3] <= kxe]
    if fair:
        best = min(fair, key=lambda r: r[1])
        print(
            f"at equal or better state accuracy: {best[0]} is {t_kar / best[1]:.1f}x ahead of the paper's approach"
        )
    else:
        print("no engine setting reached the paper's state accuracy; tighten ENGINE_RTOLS")


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

    absorber = hybrid_models.absorber()
    names = absorber.variable_names
    idx = [names.index(n) for n in STATE]
    base = absorber.preset("standard")
    tight = SolverOptions(method=IDA(rtol=1e-12, atol=1e-14))
    methods = {
        "engine, IDA rtol 1e-10": (SolverOptions(method=IDA(rtol=1e-10, atol=1e-12)), 512),
        "engine, IDA rtol 1e-10, 16 samples": (SolverOptions(method=IDA(rtol=1e-10, atol=1e-12)), 16),
        "engine, IDA rtol 1e-11": (SolverOptions(method=IDA(rtol=1e-11, atol=1e-13)), 512),
        "engine, IDA rtol 3e-12": (SolverOptions(method=IDA(rtol=3e-12, atol=3e-14)), 512),
        "engine, IDA rtol 3e-12, 16 samples": (SolverOptions(method=IDA(rtol=3e-12, atol=3e-14)), 16),
        "engine, IDA rtol 1e-12": (SolverOptions(method=IDA(rtol=1e-12, atol=1e-14)), 512),
        "engine, exact": (SolverOptions(method=Exact()), 512),
        "engine, exact, 16 samples": (SolverOptions(method=Exact()), 16),
    }
    p0 = {**base, "Omega": float(BRANCH[0])}
    start = periodic_orbit(
        absorber, p0, options=tight, settings=hybrid.ShootingOptions(newton=hybrid.NewtonOptions(tol=1e-11))
    )
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
        options=tight,
        settings=hybrid.ShootingOptions(newton=hybrid.NewtonOptions(tol=1e-11), transient_periods=0),
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
                options=opts,
                settings=hybrid.ShootingOptions(
                    newton=hybrid.NewtonOptions(tol=tol), transient_periods=0, samples_per_period=samples
                ),
            )

        ref = neighbour(prev["ref"], EXACT, 1e-12)
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
            x_kar = state_at(absorber, p, ref, kar.t0, EXACT)[idx]  # the reference at the paper's section
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
    # The must-show's ratio: the fastest setting of each integrator whose state and multipliers are
    # at least as accurate as the paper's approach, measured above, with every orbit converged.
    for kind in ("IDA", "exact"):
        fair = [
            n
            for n in methods
            if kind in n and not failed[n] and xerr[n] <= xerr["paper"] and merr[n] <= merr["paper"]
        ]
        if fair:
            best = min(fair, key=lambda n: float(np.median(times[n])))
            t = float(np.median(times[best]))
            print(
                f"{kind} at equal or better accuracy than the paper's approach: `{best}`, "
                f"{1e3 * t:.1f} ms, {t_paper / t:.1f}x ahead"
            )
        else:
            print(f"{kind}: no setting reached the paper's accuracy")


if __name__ == "__main__":
    import sys

    if "--branch" not in sys.argv:
        main()
    branch()
