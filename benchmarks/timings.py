"""Wall times of ``hybrid frc`` as a user runs it, with one and two worker processes, and the load.

Each case is the command ``hybrid frc MODEL --integrator I --workers N --no-progress --out TMP``
run in a fresh process, its wall time measured from outside (start-up,
computation, files and figure included), with the machine's load average (``os.getloadavg()``)
before and after: the project's machine has 2 cores shared with other jobs, and two workers give
no speed-up when the cores are already busy. Prints a Markdown table and writes it as JSON.

Run: ``python benchmarks/timings.py [--models absorber isolator] [--repeat 1] [--out out/benchmarks]``
(about 1.5 min at load 1-4 on 2 cores, 6 min at load 5-11).
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path


def run(model: str, integrator: str, workers: int, plot: bool) -> dict:
    with tempfile.TemporaryDirectory() as out:
        argv = ["hybrid", "frc", model, "--integrator", integrator, "--workers", str(workers)]
        argv += ["--no-progress", "--out", out] + ([] if plot else ["--no-plot"])
        load0 = os.getloadavg()[0]
        t0 = time.perf_counter()
        proc = subprocess.run(argv, capture_output=True, text=True)
        wall = time.perf_counter() - t0
        load1 = os.getloadavg()[0]
        orbits = next(
            (line.split()[0] for line in proc.stderr.splitlines() if "periodic orbits in" in line), "?"
        )
    return {
        "model": model,
        "integrator": integrator,
        "workers": workers,
        "plot": plot,
        "wall_s": wall,
        "orbits": orbits,
        "exit_code": proc.returncode,
        "load_before": load0,
        "load_after": load1,
    }


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--models", nargs="+", default=["absorber", "isolator"])
    ap.add_argument("--repeat", type=int, default=1)
    ap.add_argument("--out", default="out/benchmarks")
    args = ap.parse_args()
    rows = []
    for model in args.models:
        for integrator in ("ida", "exact"):
            for workers in (1, 2):
                for _ in range(args.repeat):
                    rows.append(run(model, integrator, workers, plot=True))
                    r = rows[-1]
                    print(
                        f"{model} {integrator} workers={workers}: {r['wall_s']:.1f} s, {r['orbits']} orbits, "
                        f"load {r['load_before']:.2f} -> {r['load_after']:.2f}",
                        file=sys.stderr,
                    )
    meta = {
        "cpu_count": os.cpu_count(),
        "machine": platform.machine(),
        "python": platform.python_version(),
        "date_utc": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()),
    }
    print("| model | integrator | workers | wall [s] | orbits | load before -> after |")
    print("|---|---|---|---|---|---|")
    for r in rows:
        print(
            f"| {r['model']} | {r['integrator']} | {r['workers']} | {r['wall_s']:.1f} | {r['orbits']} | "
            f"{r['load_before']:.2f} -> {r['load_after']:.2f} |"
        )
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    (out / "timings.json").write_text(json.dumps({"meta": meta, "runs": rows}, indent=2) + "\n")
    print(f"\n{meta['cpu_count']} CPUs, {meta['machine']}, Python {meta['python']}, {meta['date_utc']}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
