"""Cold starts: :func:`hybrid.periodic_orbit` from rest over a grid of R and Omega, for both dampers.

Issue 7, item 4 ("Cold starts that find the orbit"): from rest (all states 0 in the initial mode,
the default transient of 10 forcing periods), does :func:`hybrid.periodic_orbit` return a
converged orbit that is not unstable, at every Omega of the default frequency range
(:func:`hybrid.continuation.frc.default_range`) with R over the paper's ranges (absorber 0.3-0.8 N, isolator
0.9-2.0 N), close to the peaks included? And by which route (``PeriodicOrbit.route``: Newton
from the transient, or the fallback, see :mod:`hybrid.continuation.coldstart`)?

Grid per damper: ``--n-r`` values of R evenly over its range (default 5) times 21 values of Omega:
both ends of the default range, the midpoint between the two natural frequencies ``w1``, ``w2``
of the stuck system, and ``w (1 + d)`` for each ``w`` and ``d`` in ``OFFSETS`` (denser near the
peaks, where the stick-slip bands lie and the multipliers reach 0.999 and more).

An orbit counts as *found* when it converged and is stable or neutral (a pure-stick orbit
outside the stick-slip bands is a neutral family member). Printed per damper: how many were
found, by which route, the failures with their reasons, the largest Floquet multiplier modulus
met, and wall times (median, largest; the machine's load is printed, other jobs may run).

Second part (``--edges``): the hardest places, where the multipliers reach 0.999 and more (the
steep edges of the stick-slip bands). For R at the ends and the middle of each range and each
natural frequency ``w``, a continuation over ``w (1 -+ 6e-3)`` gives the branch; at up to
``--edge-points`` of its stable orbits with the largest multiplier moduli (0.999 and more) a cold
start is made at the same Omega and compared with the branch's orbit (an independent route): the
largest difference of the state, carried to the branch orbit's section by a tight run (rtol
1e-12), relative to the largest component. Counted as found: converged, stable, and within
``max(1e-6, 10 cond(I - M) rtol)`` of the branch's orbit (the accuracy both carry).

Run: ``python benchmarks/cold_starts.py`` (``--dampers isolator``, ``--n-r 3``, ``--max-time S``
per cold start; ``--csv FILE`` writes one row per cold start; ``--edges`` adds the second part,
``--edges-only`` runs it alone).
"""

from __future__ import annotations

import argparse
import csv
import os
import statistics
import time

import numpy as np

import hybrid
from hybrid import resolve_model
from hybrid.continuation.frc import default_range
from hybrid.model.linear import natural_frequencies

R_RANGES = {"absorber": (0.3, 0.8), "isolator": (0.9, 2.0)}
#: Relative offsets from each natural frequency of the stuck system.
OFFSETS = (-3e-3, -2e-3, -1e-3, -5e-4, -1e-4, -3e-5, 3e-5, 1e-4, 1e-3)


def omega_grid(system, params) -> np.ndarray:
    lo, hi = default_range(system, params)
    w = natural_frequencies(system, params)
    pts = [lo, hi, 0.5 * (w[0] + w[-1])]
    pts += [float(wk) * (1.0 + d) for wk in w for d in OFFSETS]
    return np.round(np.sort(pts), 6)


def cold_start(system, params, max_time: float) -> dict:
    t = time.perf_counter()
    with hybrid.time_limit(max_time):
        o = hybrid.periodic_orbit(system, params)
    wall = time.perf_counter() - t
    fl = np.abs(o.floquet_multipliers)
    found = o.converged and o.stability in ("stable", "neutral")
    return {
        "R": params["R"],
        "Omega": params["Omega"],
        "found": found,
        "converged": o.converged,
        "stability": o.stability,
        "route": getattr(o, "route", "newton"),
        "max_multiplier": float(np.max(fl)) if fl.size and np.all(np.isfinite(fl)) else float("nan"),
        "switches": o.transitions_per_period,
        "wall_s": wall,
        "message": o.message,
        "orbit": o,
    }


TIGHT = hybrid.SolverOptions(method=hybrid.IDA(rtol=1e-12, atol=1e-14))


def state_at(orbit, t: float) -> np.ndarray:
    """The orbit's state at time ``t`` (modulo the period), by a tight run from its section."""
    dt = (t - orbit.t0) % orbit.period
    if dt < 1e-12 * orbit.period:
        return orbit.x0.copy()
    tr = hybrid.simulate(
        orbit.system, orbit.params, (orbit.t0, orbit.t0 + dt), orbit.x0, orbit.mode0, options=TIGHT
    )
    return tr.y_final.copy()


def difference(orbit, ref) -> float:
    keep = [i for i, n in enumerate(ref.system.variable_names) if n not in ref.system.quadratures]
    x = state_at(orbit, ref.t0)[keep]
    return float(np.max(np.abs(x - ref.x0[keep])) / np.max(np.abs(ref.x0[keep])))


def edges(name: str, n_points: int, max_time: float) -> None:
    system = resolve_model(name)
    base = system.preset("standard")
    lo, hi = R_RANGES[name]
    out = []
    t_cont = 0.0
    for R in (lo, 0.5 * (lo + hi), hi):
        params = {**base, "R": float(R)}
        for w in natural_frequencies(system, params):
            t = time.perf_counter()
            br = hybrid.continue_orbits(
                system,
                params,
                "Omega",
                (w * (1 - 6e-3), w * (1 + 6e-3)),
                settings=hybrid.ContinuationOptions(locate=False),
            )
            t_cont += time.perf_counter() - t
            mu = [
                float(np.max(np.abs(o.floquet_multipliers))) if o.stability == "stable" else 0.0
                for o in br.points
            ]
            order = [k for k in np.argsort(mu)[::-1] if mu[k] >= 0.999][:n_points]
            if not order:
                print(f"{name} R={R:.4g} w={w:.6f}: no stable orbit with |mu| >= 0.999 on the branch ({br})")
            for k in order:
                ref = br.points[k]
                om = ref.params["Omega"]
                row = cold_start(system, {**params, "Omega": om}, max_time)
                o = row.pop("orbit")
                diff = difference(o, ref) if o.converged else float("nan")
                bound = max(1e-6, 10 * max(o.condition, ref.condition) * hybrid.ORBIT_OPTIONS.method.rtol)
                row["found"] = row["found"] and o.stability == "stable" and diff <= bound
                out.append(row)
                print(
                    f"{name} R={R:.4g} Omega={om:.9f} (branch |mu| {mu[k]:.7f}): "
                    f"{'found' if row['found'] else 'NOT FOUND'} ({row['stability']}, |mu| "
                    f"{row['max_multiplier']:.7f}) by {row['route']!r} in {row['wall_s']:.2f} s; "
                    f"state vs the branch's orbit {diff:.2g} (bound {bound:.2g})",
                    flush=True,
                )
                if not row["found"]:
                    print(f"    {row['message']}", flush=True)
    found = [r for r in out if r["found"]]
    print(f"\n== {name}, band edges: {len(found)} of {len(out)} cold starts found the branch's orbit")
    kinds: dict[str, list] = {}
    for r in found:
        kinds.setdefault(route_kind(r["route"]), []).append(r["wall_s"])
    for k, w in sorted(kinds.items()):
        print(f"   by {k}: {len(w)} (wall median {statistics.median(w):.2f} s, max {max(w):.2f} s)")
    if out:
        print(f"   largest multiplier modulus of these orbits: {max(r['max_multiplier'] for r in out):.7f}")
    print(f"   continuations (references): {t_cont:.1f} s\n")


def route_kind(route: str) -> str:
    return route.split(" from ")[0] if route else "none"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dampers", nargs="+", default=["absorber", "isolator"])
    ap.add_argument("--n-r", type=int, default=5)
    ap.add_argument("--max-time", type=float, default=300.0)
    ap.add_argument("--csv", default=None)
    ap.add_argument("--edges", action="store_true")
    ap.add_argument("--edges-only", action="store_true")
    ap.add_argument("--edge-points", type=int, default=3)
    args = ap.parse_args()
    print(f"load average: {os.getloadavg()}, cpus: {os.cpu_count()}")
    rows = []
    for name in [] if args.edges_only else args.dampers:
        system = resolve_model(name)
        base = system.preset("standard")
        out = []
        for R in np.linspace(*R_RANGES[name], args.n_r):
            params = {**base, "R": float(R)}
            for om in omega_grid(system, params):
                row = cold_start(system, {**params, "Omega": float(om)}, args.max_time)
                row.pop("orbit")
                row["model"] = name
                out.append(row)
                flag = "found" if row["found"] else "NOT FOUND"
                print(
                    f"{name} R={row['R']:.4g} Omega={row['Omega']:.6f}: {flag} ({row['stability']}, "
                    f"max|mu| {row['max_multiplier']:.6f}, {row['switches']} switches) by {row['route']!r} "
                    f"in {row['wall_s']:.2f} s",
                    flush=True,
                )
                if not row["found"]:
                    print(f"    {row['message']}", flush=True)
        rows += out
        n = len(out)
        found = [r for r in out if r["found"]]
        walls = [r["wall_s"] for r in out]
        print(f"\n== {name}: {len(found)} of {n} cold starts found the orbit")
        kinds: dict[str, list] = {}
        for r in found:
            kinds.setdefault(route_kind(r["route"]), []).append(r["wall_s"])
        for k, w in sorted(kinds.items()):
            print(f"   by {k}: {len(w)} (wall median {statistics.median(w):.2f} s, max {max(w):.2f} s)")
        for r in out:
            if not r["found"]:
                print(f"   NOT FOUND R={r['R']:.4g} Omega={r['Omega']:.6f}: {r['message']}")
        mu = [r["max_multiplier"] for r in found if r["stability"] == "stable"]
        if mu:
            print(f"   largest Floquet multiplier modulus among the stable orbits found: {max(mu):.7f}")
        print(f"   wall per cold start: median {statistics.median(walls):.2f} s, max {max(walls):.2f} s\n")
    if args.edges or args.edges_only:
        for name in args.dampers:
            edges(name, args.edge_points, args.max_time)
    print(f"load average: {os.getloadavg()}")
    if args.csv and rows:
        with open(args.csv, "w", newline="") as fh:
            w = csv.DictWriter(fh, fieldnames=list(rows[0]))
            w.writeheader()
            w.writerows(rows)


if __name__ == "__main__":
    main()
