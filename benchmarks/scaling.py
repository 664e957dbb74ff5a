"""Cost against size: the forced Burridge-Knopoff chain of N blocks, N = 1, 2, 4, ..., 256 (issue 22).

For each N and each integrator (``exact``, ``ida``), from the network file's content
(``models/bk_chain.toml`` with its cell repeated N times, preset ``standard``):

* **set-up**: the content to a system (the cells written out, one component per contact), its
  compilation (one generated function for all modes) and the first step (the first mode's equations
  assembled): ``system_from_dict`` and a run over 1e-9 s;
* **run**: 50 s of simulated time from rest, after the set-up (the compiled system reused, every
  other mode assembled when first entered).

Both are timed as wall time and as the process's CPU time (the machine is shared: the growth is
fitted on CPU time, and drawn).

Nothing here enumerates modes: N = 256 has 3**256 of them. Prints a table with the machine's load,
fits the growth exponents (least squares in logs over N >= 16) and writes
``docs/networks/scaling.json`` and ``docs/networks/scaling.png`` (log-log).

Run: ``python benchmarks/scaling.py`` (about 20 minutes on 2 cores; ``--max-n 64`` for a quick look,
``--integrators exact``; IDA up to ``--max-n-ida``, 128 by default).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
import tomllib
from pathlib import Path

import numpy as np

import hybrid_models
from hybrid import SolverOptions, method_named, simulate, system_from_dict

OUT = Path(__file__).resolve().parents[1] / "docs" / "networks"
T_END = 50.0


def chain(n: int) -> dict:
    data = tomllib.loads((Path(hybrid_models.__file__).parent / "bk_chain.toml").read_text())
    data["cells"]["block"]["count"] = n
    return data


def load() -> float:
    return round(os.getloadavg()[0], 2)


def measure(n: int, integrator: str) -> dict:
    options = SolverOptions(method=method_named(integrator))
    start, cpu = time.perf_counter(), time.process_time()
    system = system_from_dict(chain(n))
    params = system.preset("standard")
    zero = dict.fromkeys(system.variable_names, 0.0)
    simulate(system, params, (0.0, 1e-9), zero, options=options)
    setup, setup_cpu = time.perf_counter() - start, time.process_time() - cpu
    start, cpu = time.perf_counter(), time.process_time()
    tr = simulate(system, params, (0.0, T_END), zero, options=options)
    run, run_cpu = time.perf_counter() - start, time.process_time() - cpu
    return {
        "blocks": n,
        "variables": len(system.variable_names),
        "integrator": integrator,
        "setup_s": setup,
        "run_s": run,
        "setup_cpu_s": setup_cpu,
        "run_cpu_s": run_cpu,
        "switches": len(tr.events),
        "status": tr.status.name,
        "load": load(),
    }


def exponent(rows: list[dict], key: str, n_min: int = 16) -> float:
    pts = [(r["blocks"], r[key]) for r in rows if r["blocks"] >= n_min and r[key] > 0]
    if len(pts) < 2:
        return float("nan")
    n, t = np.array(pts, dtype=float).T
    return float(np.polyfit(np.log(n), np.log(t), 1)[0])


def plot(rows: list[dict], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7.0, 4.6), layout="constrained")
    styles = {"exact": "C0", "ida": "C1"}
    for integ in sorted({r["integrator"] for r in rows}):
        sel = [r for r in rows if r["integrator"] == integ]
        n = [r["blocks"] for r in sel]
        ax.loglog(
            n, [r["setup_cpu_s"] for r in sel], "s--", color=styles.get(integ, "C2"), label=f"{integ}: set-up"
        )
        ax.loglog(
            n, [r["run_cpu_s"] for r in sel], "o-", color=styles.get(integ, "C2"), label=f"{integ}: 50 s run"
        )
    n = np.array(sorted({r["blocks"] for r in rows}), dtype=float)
    for p, ls in ((1.0, ":"), (2.0, "-.")):
        ref = 0.05 * (n / n[0]) ** p
        ax.loglog(n, ref, ls, color="0.6", lw=1)
        ax.annotate(f"N^{p:g}", (n[-1], ref[-1]), color="0.4", fontsize=8, ha="right", va="bottom")
    ax.set_xlabel("blocks N (contacts; 3N variables)")
    ax.set_ylabel("CPU time of the process [s]")
    ax.set_title(f"Forced Burridge-Knopoff chain, {T_END:g} s simulated from rest: cost against size")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.savefig(path, dpi=120)
    plt.close(fig)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--max-n", type=int, default=256)
    ap.add_argument(
        "--max-n-ida",
        type=int,
        default=128,
        help="largest N run with IDA (its guards' Taylor series at every switch cost O(N) each: "
        "N = 256 takes about half an hour)",
    )
    ap.add_argument("--integrators", nargs="+", default=["exact", "ida"])
    ap.add_argument("--out", type=Path, default=OUT)
    ap.add_argument("--replot", action="store_true", help="redraw the figure from the JSON written before")
    args = ap.parse_args(argv)
    if args.replot:
        plot(json.loads((args.out / "scaling.json").read_text())["rows"], args.out / "scaling.png")
        print(f"wrote {args.out / 'scaling.png'}")
        return 0
    sizes = [2**k for k in range(0, 20) if 2**k <= args.max_n]
    rows = []
    print(
        f"{'N':>5} {'integrator':>10} {'set-up [s]':>11} {'run [s]':>9} {'set-up CPU':>11} {'run CPU':>9} "
        f"{'switches':>9} {'load':>5}"
    )
    for integ in args.integrators:
        for n in sizes:
            if integ == "ida" and n > args.max_n_ida:
                continue
            r = measure(n, integ)
            rows.append(r)
            print(
                f"{n:5d} {integ:>10} {r['setup_s']:11.3f} {r['run_s']:9.3f} {r['setup_cpu_s']:11.3f} "
                f"{r['run_cpu_s']:9.3f} {r['switches']:9d} {r['load']:5.2f}",
                flush=True,
            )
    fits = {
        integ: {
            "setup_exponent": exponent([r for r in rows if r["integrator"] == integ], "setup_cpu_s"),
            "run_exponent": exponent([r for r in rows if r["integrator"] == integ], "run_cpu_s"),
        }
        for integ in args.integrators
    }
    for integ, f in fits.items():
        print(
            f"{integ}: set-up grows as N^{f['setup_exponent']:.2f}, run as N^{f['run_exponent']:.2f} (N >= 16)"
        )
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "scaling.json").write_text(
        json.dumps({"t_end": T_END, "rows": rows, "fits": fits}, indent=1) + "\n"
    )
    plot(rows, args.out / "scaling.png")
    print(f"wrote {args.out / 'scaling.json'} and {args.out / 'scaling.png'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
