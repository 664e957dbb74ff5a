"""Cost of a network file of N contacts: building its system, and 50 s of the forced chain.

The Burridge-Knopoff chain of models/bk_chain.toml (one cell repeated N times; the chain of the
Siconos benchmark, preset ``standard``):

* building: the file's content to the HybridSystem (the cells written out, the network validated,
  one component per contact derived, the system validated), N = 10, 100, 1000, 3000: best of a few;
* running: ``simulate`` over 50 s from rest with the exact integrator, N = 6, 20, 100, its first
  call (which compiles the composed system) and the switches; with the final displacements against
  the independent event-driven reference of issue 22 (``benchmarks/reference_chain.py``, its exact
  Taylor backend), computed here the first time and kept in ``docs/networks/reference_chain.json``
  (shipped: a fresh clone needs nothing else).

Run: ``python benchmarks/network_scale.py`` (several minutes on 2 cores; the machine's load is
printed with every timing). Writes ``docs/networks/network_scale.json``.
"""

from __future__ import annotations

import importlib.util
import json
import os
import time
import tomllib
from pathlib import Path

import numpy as np

import hybrid_models
from hybrid import Exact, SolverOptions, simulate, system_from_dict

OUT = Path(__file__).resolve().parents[1] / "docs" / "networks" / "network_scale.json"
#: The final displacements of the independent reference, by N (computed once, then read).
REFERENCE = OUT.parent / "reference_chain.json"
BUILD_N = (10, 100, 1000, 3000)
RUN_N = (6, 20, 100)


def chain(n: int) -> dict:
    data = tomllib.loads((Path(hybrid_models.__file__).parent / "bk_chain.toml").read_text())
    data["cells"]["block"]["count"] = n
    return data


def reference_x_end(n: int) -> list[float]:
    """``x_i(50 s)`` of the chain of N blocks from rest by ``benchmarks/reference_chain.py`` (Taylor
    backend), from :data:`REFERENCE`, computed and added there if missing."""
    known = json.loads(REFERENCE.read_text()) if REFERENCE.exists() else {}
    if str(n) not in known:
        spec = importlib.util.spec_from_file_location(
            "reference_chain", Path(__file__).with_name("reference_chain.py")
        )
        ref = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(ref)
        start = time.perf_counter()
        r = ref.run_taylor(ref.Chain(ref.default_params(n)), 50.0)
        known[str(n)] = {
            "x_end": [float(q) for q in r["x"]],
            "t_end": r["t"],
            "wall_s": time.perf_counter() - start,
        }
        REFERENCE.parent.mkdir(parents=True, exist_ok=True)
        REFERENCE.write_text(json.dumps(known, indent=1) + "\n")
    return known[str(n)]["x_end"]


def load() -> float:
    return round(os.getloadavg()[0], 2)


def main() -> dict:
    builds = []
    for n in BUILD_N:
        best = np.inf
        for _ in range(3 if n <= 1000 else 1):
            data = chain(n)
            start = time.perf_counter()
            system = system_from_dict(data)
            best = min(best, time.perf_counter() - start)
        row = {
            "contacts": n,
            "variables": len(system.variables),
            "build_s": best,
            "build_per_contact_ms": 1e3 * best / n,
            "load": load(),
        }
        builds.append(row)
        print(
            f"build N = {n:5d}: {best:8.3f} s ({row['build_per_contact_ms']:.2f} ms per contact), load {row['load']}"
        )
    runs = []
    for n in RUN_N:
        start = time.perf_counter()
        system = system_from_dict(chain(n))
        built = time.perf_counter() - start
        zero = dict.fromkeys(system.variable_names, 0.0)
        start = time.perf_counter()
        tr = simulate(
            system, system.preset("standard"), (0.0, 50.0), zero, options=SolverOptions(method=Exact())
        )
        wall = time.perf_counter() - start
        row = {
            "blocks": n,
            "build_s": built,
            "simulate_50s_s": wall,
            "switches": len(tr.events),
            "status": str(tr.status),
            "load": load(),
        }
        x_end = reference_x_end(n)
        row["x_end_error_vs_reference_m"] = max(
            abs(tr.final(f"x_{i}") - x_end[i - 1]) for i in range(1, n + 1)
        )
        runs.append(row)
        print(
            f"chain N = {n:3d}: build {built:.3f} s, simulate 50 s {wall:7.2f} s, {row['switches']} switches, "
            f"x(50) error {row.get('x_end_error_vs_reference_m', float('nan')):.2g} m, load {row['load']}"
        )
    result = {"build": builds, "simulate": runs}
    OUT.parent.mkdir(parents=True, exist_ok=True)
    OUT.write_text(json.dumps(result, indent=1) + "\n")
    print(f"wrote {OUT}")
    return result


if __name__ == "__main__":
    main()
