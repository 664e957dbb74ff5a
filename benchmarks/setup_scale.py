"""Set-up of a network of N friction contacts against N (issue 32, "1000 contacts").

The Iwan joint of ``models/iwan.toml`` (a mass on N Jenkins elements, each a spring ``K/N`` and a
slider to ground, one cell repeated N times: N components) with ``count`` = N and the slip forces
spread over ``[0.1, 1] K/N`` so that the elements start to slide at the same displacements
(0.1 ... 1 m) for every N. For each N, in a fresh process (so that its peak memory is its own):

* ``read``: the file's content to the :class:`hybrid.HybridSystem` (cells written out, network
  validated and derived, system validated);
* ``setup``: that plus the first call of ``simulate`` with the exact integrator over 1e-9 s,
  which compiles the composed system (residual, Jacobian, guards) and makes the affine analysis of
  every part: everything a computation needs before its first step;
* ``simulate``: then the motion from rest with the exact integrator up to its first
  :data:`SWITCHES` switches (the elements of lowest slip force break away one after another), wall
  time (it compiles the system again: ``simulate`` keeps no compiled system between calls; the
  affine analysis is kept with the system);
* peak resident memory of the process (``resource.getrusage``), and the machine's load.

The growth exponent is the slope of ``log(setup)`` against ``log(N)`` between successive sizes.

Run: ``python benchmarks/setup_scale.py [N ...]`` (default 256 512 1000 2000; minutes on 2 cores).
Writes ``docs/networks/setup_scale.json`` and prints a Markdown table (for docs/networks.md).
"""

from __future__ import annotations

import json
import math
import os
import resource
import subprocess
import sys
import time
import tomllib
from pathlib import Path

OUT = Path(__file__).resolve().parents[1] / "docs" / "networks" / "setup_scale.json"
SIZES = (256, 512, 1000, 2000)
#: Switches simulated from rest after the set-up (the elements of lowest slip force break away one
#: after another): the cost of a mode change in a model of N contacts
SWITCHES = 20


def iwan(n: int) -> dict:
    """The content of ``models/iwan.toml`` with N elements, slip forces ``linear [0.1, 1]/N``."""
    import hybrid_models

    data = tomllib.loads((Path(hybrid_models.__file__).parent / "iwan.toml").read_text())
    data["cells"]["jenkins"]["count"] = n
    data["presets"]["standard"]["jenkins"]["R"] = {"linear": [0.1 / n, 1.0 / n]}
    return data


def measure(n: int) -> dict:
    """One row of the table, measured in this process (call it in a fresh one)."""
    from hybrid import Exact, SolverOptions, simulate, system_from_dict

    opts = SolverOptions(method=Exact())
    w0, c0 = time.perf_counter(), time.process_time()
    system = system_from_dict(iwan(n))
    w1 = time.perf_counter()
    params = system.preset("standard")
    zero = dict.fromkeys(system.variable_names, 0.0)
    simulate(system, params, (0.0, 1e-9), zero, options=opts)
    w2, c2 = time.perf_counter(), time.process_time()
    rss_setup = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    tr = simulate(
        system, params, (0.0, 4 * math.pi), zero, options=opts, max_transitions=SWITCHES, throw=False
    )
    w3 = time.perf_counter()
    return {
        "contacts": n,
        "variables": len(system.variable_names),
        "read_s": w1 - w0,
        "setup_s": w2 - w0,
        "setup_cpu_s": c2 - c0,
        "compile_s": w2 - w1,
        "peak_MB_setup": rss_setup,
        "simulate_s": w3 - w2,
        "switches": len(tr.events),
        "status": str(tr.status),
        "peak_MB": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
        "load": round(os.getloadavg()[0], 2),
    }


def table(rows: list[dict]) -> str:
    """The rows as a Markdown table, with the growth exponent of the set-up between sizes."""
    lines = [
        "| contacts | variables | read [s] | set-up [s] (CPU) | peak memory [MB] | first switches [s] (count) "
        "| exponent | load |",
        "| ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |",
    ]
    prev = None
    for r in rows:
        slope = (
            f"{math.log(r['setup_cpu_s'] / prev['setup_cpu_s']) / math.log(r['contacts'] / prev['contacts']):.2f}"
            if prev
            else ""
        )
        lines.append(
            f"| {r['contacts']} | {r['variables']} | {r['read_s']:.1f} | {r['setup_s']:.1f} ({r['setup_cpu_s']:.1f}) "
            f"| {r['peak_MB']:.0f} | {r['simulate_s']:.1f} ({r['switches']}) | {slope} | {r['load']} |"
        )
        prev = r
    return "\n".join(lines)


def main(sizes=SIZES) -> list[dict]:
    rows = []
    for n in sizes:
        out = subprocess.run(
            [sys.executable, __file__, "--one", str(n)], capture_output=True, text=True, check=True
        ).stdout
        row = json.loads(out.strip().splitlines()[-1])
        print(
            f"N = {n}: set-up {row['setup_s']:.1f} s ({row['setup_cpu_s']:.1f} s CPU), peak {row['peak_MB']:.0f} MB, "
            f"{row['switches']} switches {row['simulate_s']:.1f} s, load {row['load']}",
            flush=True,
        )
        rows.append(row)
    print(table(rows))
    print("exponent: slope of log(set-up CPU time) against log(N) from the previous row")
    OUT.parent.mkdir(parents=True, exist_ok=True)
    OUT.write_text(json.dumps(rows, indent=1) + "\n")
    print(f"wrote {OUT}")
    return rows


if __name__ == "__main__":
    if len(sys.argv) == 3 and sys.argv[1] == "--one":
        print(json.dumps(measure(int(sys.argv[2]))))
    else:
        main(tuple(int(a) for a in sys.argv[1:]) or SIZES)
