"""The Iwan joint of 50 Jenkins elements (models/iwan.toml): energy dissipated per period against
Masing's closed form (issue 22, must-show).

The periodic orbit of the shipped model (preset ``standard``: a mass on a residual spring and 50
Jenkins elements, springs K/50, slip forces R_i from 0.002 to 0.02 N, forced by 0.9 sin(0.5 t)) is
computed with the exact integrator. In it the mass swings between -X and X; every element whose slip
displacement R_i/k_i is below X slides twice a period over 2 (X - R_i/k_i), so that the friction
dissipates sum_i 4 R_i (X - R_i/k_i) per period (Masing's rule). X is read at the turning points,
which are switches of the orbit (every sliding element stops there at once); the dissipation is the
model's quadrature D over the period (no damper: friction only).

Run: ``python benchmarks/iwan_masing.py [N]`` (N = 50 by default; a few minutes on 2 cores). Writes
``docs/networks/iwan_masing.json``.
"""

from __future__ import annotations

import json
import os
import sys
import time
import tomllib
from pathlib import Path

import numpy as np

import hybrid_models
from hybrid import Exact, SolverOptions, periodic_orbit, system_from_dict

OUT = Path(__file__).resolve().parents[1] / "docs" / "networks" / "iwan_masing.json"


def main(n: int = 50) -> dict:
    data = tomllib.loads((Path(hybrid_models.__file__).parent / "iwan.toml").read_text())
    data["cells"]["jenkins"]["count"] = n
    # the same joint for any N: slip displacements R_i N/K from 0.1 to 1 m, sum of R_i 0.55 N
    data["presets"]["standard"]["jenkins"]["R"] = {"linear": [0.1 / n, 1.0 / n]}
    load = os.getloadavg()[0]
    start = time.perf_counter()
    system = system_from_dict(data)
    built = time.perf_counter() - start
    p = system.preset("standard")
    print(f"Iwan joint of {n} Jenkins elements: {len(system.variables)} variables, built in {built:.2f} s")
    start = time.perf_counter()
    orbit = periodic_orbit(system, p, options=SolverOptions(method=Exact()))
    wall = time.perf_counter() - start
    print(orbit)
    if not orbit.converged:
        raise SystemExit(f"the periodic orbit did not converge: {orbit.message}")
    tr = orbit.trajectory
    ix = system.variable_names.index("x")
    turns = [e.x_minus[ix] for e in tr.events if ".stop" in e.guard]
    X = max(turns)
    asym = abs(max(turns) + min(turns)) / X
    R = np.array([p[f"R_{i}"] for i in range(1, n + 1)])
    k = p["K"] / n
    slide = R / k < X
    masing = float(np.sum(4.0 * R[slide] * (X - R[slide] / k)))
    D = float(tr["D"][-1] - tr["D"][0])
    W = float(tr["W"][-1] - tr["W"][0])
    result = {
        "elements": n,
        "sliding_elements": int(np.count_nonzero(slide)),
        "amplitude_X_m": X,
        "turning_point_asymmetry": asym,
        "dissipated_per_period_J": D,
        "masing_J": masing,
        "relative_difference": abs(D - masing) / masing,
        "work_per_period_J": W,
        "switches_per_period": len(orbit.switch_times),
        "multipliers_abs": [float(abs(z)) for z in orbit.multipliers[:4]],
        "build_s": built,
        "orbit_s": wall,
        "load_1min": load,
    }
    print(json.dumps(result, indent=1))
    OUT.parent.mkdir(parents=True, exist_ok=True)
    if n == 50:
        OUT.write_text(json.dumps(result, indent=1) + "\n")
        print(f"wrote {OUT}")
    return result


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 50)
