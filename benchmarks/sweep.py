"""Sweep speed-up: the same grid of frequency responses with 1 and 2 worker processes, and on a
Dask ``LocalCluster`` with 2 workers (issue 10, "Must show").

The grid is the absorber's (``standard`` preset) R x c3 with the exact integrator over the first
resonance's window (0.80-0.90 rad/s; ``--full-range`` for the default range of both resonances):
``--n-r`` values of R evenly over [0.3, 0.8] N times ``--n-c3`` values of c3 log-spaced over
[0.1, 10] N/m. Each configuration runs :func:`hybrid.sweep` into its own temporary folder; the
results of the three runs are checked equal (the same computation wherever it runs). Printed:
wall times, the speed-ups against 1 worker (from this one run, so that they compare like with
like), the cores each run actually got (the points' CPU time over the wall time), and the machine's
load (``uptime``) before and after, since other jobs may share the cores.

Run: ``python benchmarks/sweep.py`` (``--n-r 6 --n-c3 3`` by default; ``--no-dask`` without the
cluster; the Dask run needs the ``dask`` extra).
"""

from __future__ import annotations

import argparse
import subprocess
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor

import hybrid
from hybrid import resolve_model


def uptime() -> str:
    return subprocess.run(["uptime"], capture_output=True, text=True).stdout.strip()


def run(executor, axes, folder, p_range) -> tuple[float, hybrid.SweepResult]:
    system = resolve_model("absorber")
    params = system.presets["standard"]
    t0 = time.perf_counter()
    res = hybrid.sweep(
        system,
        params,
        axes,
        folder,
        p_range=p_range,
        options=hybrid.SolverOptions(method=hybrid.Exact()),
        executor=executor,
    )
    return time.perf_counter() - t0, res


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n-r", type=int, default=6, help="values of R (default 6)")
    ap.add_argument("--n-c3", type=int, default=3, help="values of c3 (default 3)")
    ap.add_argument("--full-range", action="store_true", help="the default range (both resonances)")
    ap.add_argument("--no-dask", action="store_true", help="skip the Dask LocalCluster run")
    args = ap.parse_args()
    step = 0.5 / (args.n_r - 1) if args.n_r > 1 else 1.0
    axes = [hybrid.linear_axis("R", 0.3, 0.8, step), hybrid.log_axis("c3", 0.1, 10.0, args.n_c3)]
    p_range = None if args.full_range else (0.80, 0.90)
    n = len(axes[0].values) * len(axes[1].values)
    window = "default range" if p_range is None else f"Omega in {p_range}"
    print(
        f"absorber, exact integrator, {window}: R ({len(axes[0].values)}) x c3 ({len(axes[1].values)}) = {n} points"
    )
    print(f"load before: {uptime()}")
    times, results = {}, {}
    with tempfile.TemporaryDirectory() as tmp:
        for workers in (1, 2):
            with ProcessPoolExecutor(max_workers=workers) as ex:
                times[f"{workers} worker(s)"], results[workers] = run(ex, axes, f"{tmp}/w{workers}", p_range)
            print(f"  {workers} worker process(es): {times[f'{workers} worker(s)']:.1f} s", flush=True)
        if not args.no_dask:
            from distributed import Client, LocalCluster

            with (
                LocalCluster(
                    n_workers=2,
                    threads_per_worker=1,
                    processes=True,
                    host="127.0.0.1",
                    dashboard_address=None,
                ) as cluster,
                Client(cluster) as client,
            ):
                times["dask 2 workers"], results["dask"] = run(client, axes, f"{tmp}/dask", p_range)
            print(
                f"  Dask LocalCluster, 2 workers: {times['dask 2 workers']:.1f} s (cluster start not counted)"
            )
    print(f"load after: {uptime()}")
    ref = results[1].points
    for key, res in results.items():
        same = all(res.points[k]["curve"] == r["curve"] for k, r in ref.items())
        print(f"  results of {key!r} equal to 1 worker's: {same}")
    t1 = times["1 worker(s)"]
    for (key, t), res in zip(times.items(), results.values(), strict=True):
        cpu = sum(r["cpu_seconds"] for r in res.points.values())
        print(
            f"speed-up {key}: {t1 / t:.2f}x   (CPU of the points {cpu:.1f} s / wall {t:.1f} s = {cpu / t:.2f} "
            "cores used: below the worker count when other jobs share the cores)"
        )
    best = min((r for r in ref.values() if r["status"] == "bounded"), key=lambda r: r["peak"], default=None)
    if best is not None:
        print(f"lowest bounded peak of x1: {best['peak']:.6g} m at {best['values']}")


if __name__ == "__main__":
    main()
