#!/usr/bin/env python3
"""Cost of a model written with sign() against its number of surfaces (issue 22).

The forced friction chain of ``tests/hybrid/chains.py`` written with ``sign()``: block ``i``'s
momentum balance has ``- R_i*sign(v_i)`` (``R_i`` written as numbers, so that 1000 blocks stay
within the model's 1000 parameters), one surface per block. Measured:

* ``build`` (N = 10, 100, 1000): :func:`hybrid.filippov_system` (the equations parsed, the
  surfaces found, their rates derived, one component each, the system checked): must grow
  linearly in N; best of ``REPEAT``;
* ``compile`` (same N): the system compiled once for all its modes (``CompiledSystem``, the
  engine's);
* ``entry`` (N = 10, 30, 100, 300): the start from rest, every surface's entry deciding its
  local mode (all end in ``slide``: two chained switches each, each deciding by the Taylor series
  of ``h`` since ``h = 0``), a run over 1e-9 s with the exact integrator (compiled beforehand);
* ``run`` (N = 10, 100): ``SPAN`` s of simulated time from rest, exact integrator, and the
  number of switches.

Wall clock, with ``uptime`` (the machine is shared). Writes ``benchmarks/filippov_scale.json``.

Run: ``python benchmarks/filippov_scale.py`` (about 4 minutes on 2 cores; ``--quick``: N <= 100).
"""

from __future__ import annotations

import argparse
import json
import os
import time
from pathlib import Path

import hybrid
from hybrid import Exact, Mode, SolverOptions, Variable, filippov_system, simulate
from hybrid.model.compiled import CompiledSystem

HERE = Path(__file__).resolve().parent
SIZES = (10, 100, 1000)
ENTRY_SIZES = (10, 30, 100, 300)
RUN_SIZES = (10, 100)
REPEAT = 3
SPAN = 5.0
EXACT = SolverOptions(method=Exact())


def sign_chain(n: int) -> hybrid.HybridSystem:
    """The chain of ``n`` blocks written with sign() (see the module docstring)."""
    variables = [Variable(f"{p}{i}") for i in range(1, n + 1) for p in ("x", "v")]
    equations = {}
    for i in range(1, n + 1):
        force = f"F*sin(Omega*t) - k*x{i} - c*v{i} - {0.3 * (1 + 0.1 * (-1) ** i)!r}*sign(v{i})"
        for j in (i - 1, i + 1):
            if 1 <= j <= n:
                force += f" - kc*(x{i} - x{j})"
        equations[f"x{i}"] = f"v{i}"
        equations[f"v{i}"] = f"({force})/m"
    return filippov_system(
        name=f"sign_chain{n}",
        variables=variables,
        parameters=["m", "k", "kc", "c", "F", "Omega"],
        modes=[Mode("motion")],
        transitions=[],
        equations=equations,
        period="2*pi/Omega",
        initial_mode="motion",
    )


PARAMS = {"m": 1.0, "k": 1.0, "kc": 1.0, "c": 0.1, "F": 1.0, "Omega": 1.0}


def measure_build(n: int) -> dict:
    build = []
    for _ in range(REPEAT):
        t0 = time.perf_counter()
        system = sign_chain(n)
        build.append(time.perf_counter() - t0)
    t0 = time.perf_counter()
    CompiledSystem(system, PARAMS)
    compile_s = time.perf_counter() - t0
    return {
        "N": n,
        "build_s": min(build),
        "build_ms_per_surface": 1e3 * min(build) / n,
        "compile_s": compile_s,
    }


def measure_entry(n: int) -> dict:
    system = sign_chain(n)
    rest = {f"{q}{i}": 0.0 for i in range(1, n + 1) for q in ("x", "v")}
    simulate(system, PARAMS, (0.0, 1e-12), rest, options=EXACT)  # compiled into the model's pool
    t0 = time.perf_counter()
    start = simulate(system, PARAMS, (0.0, 1e-9), rest, options=EXACT)
    entry_s = time.perf_counter() - t0
    assert start.mode_final == "motion|" + "|".join(["slide"] * n), start.mode_final
    return {"N": n, "entry_s": entry_s, "entry_switches": len(start.events)}


def measure_run(n: int) -> dict:
    system = sign_chain(n)
    rest = {f"{q}{i}": 0.0 for i in range(1, n + 1) for q in ("x", "v")}
    t0 = time.perf_counter()
    run = simulate(system, PARAMS, (0.0, SPAN), rest, options=EXACT)
    run_s = time.perf_counter() - t0
    assert run.status == hybrid.Status.COMPLETED, run.message
    return {"N": n, "run_s": run_s, "run_switches": sum(e.t > 0 for e in run.events)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="N <= 100 only")
    args = ap.parse_args()

    def upto(sizes):
        return [n for n in sizes if n <= 100] if args.quick else list(sizes)

    load = [os.popen("uptime").read().strip()]
    print(f"uptime: {load[0]}")
    out: dict = {"build": [], "entry": [], "run": []}
    for n in upto(SIZES):
        r = measure_build(n)
        out["build"].append(r)
        print(
            f"N = {n:5d}: build {r['build_s']:.3f} s ({r['build_ms_per_surface']:.2f} ms per surface), "
            f"compile {r['compile_s']:.2f} s",
            flush=True,
        )
    for n in upto(ENTRY_SIZES):
        r = measure_entry(n)
        out["entry"].append(r)
        print(
            f"N = {n:5d}: entry from rest {r['entry_s']:.2f} s ({r['entry_switches']} switches)", flush=True
        )
    for n in upto(RUN_SIZES):
        r = measure_run(n)
        out["run"].append(r)
        print(
            f"N = {n:5d}: {SPAN:g} s from rest {r['run_s']:.2f} s ({r['run_switches']} switches)", flush=True
        )
    load.append(os.popen("uptime").read().strip())
    print(f"uptime: {load[1]}")
    path = HERE / "filippov_scale.json"
    path.write_text(json.dumps({"uptime": load, "span_s": SPAN, **out}, indent=2) + "\n")
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
