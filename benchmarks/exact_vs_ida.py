"""Exact integrator against IDA along the whole first-resonance branch of each damper.

For each damper (paper's standard parameters) the branch over the first piece of its default
frequency range (0.8 x the lowest stick natural frequency up to midway between the two) is
continued with the exact integrator; at every orbit of it, the IDA path (rtol 1e-10, the default
orbit tolerance, or ``--rtol``) solves the orbit again from the exact orbit's section state (``transient_periods=0``).
Printed: the number of orbits compared, the largest relative difference of the amplitudes (every
variable and output, relative to the largest amplitude of the state), of the switch times (relative
to the period) and of the Floquet multipliers, and where each occurs.

IDA's error on an orbit is about cond(I - M) x rtol (cond up to 1e7 at the left edge of a band):
the differences are printed beside that bound. Orbits where one integrator resolves a phase the
other does not (the few at a mode change) are listed apart.

Run: ``python benchmarks/exact_vs_ida.py [--rtol 1e-12]`` (a minute or two on 2 cores).
"""

from __future__ import annotations

import os
import time

import numpy as np

import hybrid
import hybrid_models as models
from hybrid import IDA, Exact, SolverOptions, continue_orbits, periodic_orbit
from hybrid.continuation.frc import _cuts, default_range
from hybrid.model.linear import natural_frequencies


def compare(system, rtol: float) -> None:
    p = system.preset("standard")
    lo, hi = default_range(system, p)
    a, b, _ = _cuts(lo, hi, natural_frequencies(system, p))[0]
    t = time.process_time()
    br = continue_orbits(system, p, "Omega", (a, b), options=SolverOptions(method=Exact()))
    t_exact = time.process_time() - t
    worst = {"amplitude": (0.0, None), "switch": (0.0, None), "multiplier": (0.0, None)}
    worst_ratio = (0.0, None)  # amplitude difference over the IDA orbit's own bound cond(I - M) rtol
    over = []  # orbits whose amplitudes differ by more than 1e-7
    n = 0
    t = time.process_time()
    for o in br.points:
        W = o.params["Omega"]
        q = periodic_orbit(
            system,
            o.params,
            o.x0,
            o.mode0,
            t0=o.t0,
            options=SolverOptions(method=IDA(rtol=rtol, atol=rtol / 100)),
            settings=hybrid.ShootingOptions(transient_periods=0),
        )
        if not q.converged:
            print(f"  IDA did not converge at Omega = {W:.10g}: {q.message[:120]}")
            continue
        scale = max(o.amplitude[s] for s in o.state_names if s in o.amplitude)
        da = max(abs(q.amplitude[k] - v) for k, v in o.amplitude.items()) / scale
        if (
            q.mode_sequence != o.mode_sequence
        ):  # at a mode change: one run resolves a phase the other does not
            print(
                f"  mode sequences differ at Omega = {W:.10g} (a phase at the noise level): "
                f"{' '.join(o.mode_sequence)} vs {' '.join(q.mode_sequence)}; amplitudes differ by {da:.2e}"
            )
            continue
        n += 1
        if da > worst["amplitude"][0]:
            worst["amplitude"] = (da, W)
        bound = q.condition * rtol + 1e-12
        if da / bound > worst_ratio[0]:
            worst_ratio = (da / bound, W)
        if da > 1e-7:
            over.append((W, da, q.condition, len(o.switch_times)))
        if o.switch_times.size:
            ds = float(np.max(np.abs(q.switch_times - o.switch_times))) / o.period
            if ds > worst["switch"][0]:
                worst["switch"] = (ds, W)
        fe, fq = o.floquet_multipliers, q.floquet_multipliers
        if fe.size == fq.size and fe.size:
            dm = max(float(np.min(np.abs(fq - z))) for z in fe)
            if dm > worst["multiplier"][0]:
                worst["multiplier"] = (dm, W)
    t_ida = time.process_time() - t
    print(
        f"{system.name}: {len(br.points)} orbits on Omega {a:.6g}-{b:.6g} ({br.status}), {n} compared; "
        f"exact branch {t_exact:.1f} s CPU, IDA re-solves {t_ida:.1f} s CPU"
    )
    print(
        f"  amplitude differences over 1e-7: {len(over)} orbits (Omega, difference, cond(I - M), switches):"
    )
    for W, da, cond, ns in over:
        print(f"    {W:.10g} {da:.2e} {cond:.2e} {ns}")
    print(
        f"  largest amplitude difference / (cond(I - M) x rtol): {worst_ratio[0]:.2f} at Omega = {worst_ratio[1]}"
    )
    for k, (v, W) in worst.items():
        where = f" at Omega = {W:.10g}" if W is not None else ""
        print(f"  largest {k} difference: {v:.2e}{where}")


def main() -> None:
    import argparse

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rtol", type=float, default=1e-10, help="IDA's rtol (atol = rtol / 100); default 1e-10")
    args = ap.parse_args()
    print(
        f"load average: {' '.join(f'{v:.2f}' for v in os.getloadavg())} (2-core machine); IDA rtol {args.rtol:g}"
    )
    for system in (models.absorber(), models.isolator()):
        compare(system, args.rtol)


if __name__ == "__main__":
    main()
