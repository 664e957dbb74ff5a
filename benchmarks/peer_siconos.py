"""This library against Siconos on the forced Burridge-Knopoff chain (issue 22), side by side.

The chain of ``models/bk_chain.toml`` (preset ``standard``: m = k = kc = 1, c = 0.1, F = 1,
Omega = 1, R_i = 0.3 (1 + 0.1 (-1)^i), free ends), from rest, over 50 s, at N = 6, 20 and 100
blocks:

* **this library**: ``simulate`` with the exact integrator (event-driven, exact flows between
  switches), timed end to end (the network file's content to the last sample, compilation
  included), checked against the independent event-driven reference ``benchmarks/reference_chain.py``
  (Taylor series of the flow per phase; numpy and scipy only, nothing of this library);
* **Siconos** (``benchmarks/siconos_chain.py``, run by the system Python where Debian's
  ``python3-siconos`` lives): Moreau-Jean time stepping (``EulerMoreauOSI``, theta = 1/2) with one
  relay law of size N for the contacts, its fastest relay solver on this problem (PGS; LEMKE, ENUM,
  PATH and the AVI solvers were tried: see ``docs/networks.md``), timed over its time loop only;
  its error is the largest difference of the final displacements from this library's.

Siconos' error follows h (first order: the relay's set-valued force is resolved once per step), so
the step that reaches an error of 1e-6 is found from the errors measured at several h (a fit
``error = C h^p``) and its time from the measured cost per step; ``--fine`` also runs it at N = 6
(about 8 minutes). The ratio compares that time with this library's at its own accuracy (1e-12 or
better against the reference: far below 1e-6).

Run: ``python benchmarks/peer_siconos.py`` (about 15 minutes on 2 cores, most of it Siconos at
N = 100; ``--n 6 20`` for the small ones). Skips cleanly (exit 0) where Siconos is not installed:
``apt-get install python3-siconos`` (Debian/Ubuntu; it installs for the system Python,
``/usr/bin/python3``, which this script calls; ``SICONOS_PYTHON`` names another interpreter).
Writes ``docs/networks/peer_siconos.json``.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import time
import tomllib
from pathlib import Path

import numpy as np

import hybrid_models
from hybrid import Exact, SolverOptions, simulate, system_from_dict

HERE = Path(__file__).resolve().parent
OUT = HERE.parent / "docs" / "networks" / "peer_siconos.json"
SICONOS_PYTHON = os.environ.get("SICONOS_PYTHON", "/usr/bin/python3")
T_END = 50.0
#: Siconos' steps per N: errors measured there give the order and the step for an error of 1e-6
#: (at N = 100 one step costs about 13 ms: h = 1e-3 alone takes about 11 minutes).
STEPS = {6: (1e-3, 3e-4, 1e-4), 20: (1e-3, 3e-4, 1e-4), 100: (1e-3,)}
TARGET = 1e-6


def load() -> float:
    return round(os.getloadavg()[0], 2)


def chain(n: int):
    """The chain of ``n`` blocks: models/bk_chain.toml with its cell repeated ``n`` times."""
    data = tomllib.loads((Path(hybrid_models.__file__).parent / "bk_chain.toml").read_text())
    data["cells"]["block"]["count"] = n
    return data


def siconos_available() -> str | None:
    """None where Siconos imports, else why not."""
    try:
        r = subprocess.run(
            [SICONOS_PYTHON, "-c", "import siconos.kernel, siconos.numerics"],
            capture_output=True,
            text=True,
            timeout=120,
        )
    except (OSError, subprocess.TimeoutExpired) as exc:
        return f"{SICONOS_PYTHON}: {exc}"
    return None if r.returncode == 0 else (r.stderr.strip().splitlines() or ["import failed"])[-1]


def run_json(cmd: list[str], timeout: float) -> dict:
    r = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout)
    if r.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)} failed: {r.stderr.strip()[-500:]}")
    return json.loads(r.stdout)


def ours(n: int) -> dict:
    """This library: the file's content to 50 s of the chain (exact integrator), end to end."""
    start = time.perf_counter()
    system = system_from_dict(chain(n))
    zero = dict.fromkeys(system.variable_names, 0.0)
    tr = simulate(
        system, system.preset("standard"), (0.0, T_END), zero, options=SolverOptions(method=Exact())
    )
    wall = time.perf_counter() - start
    x = np.array([tr.final(f"x_{i}") for i in range(1, n + 1)])
    breakaway, reversals, sticks = {}, 0, 0
    for ev in tr.events:
        before = system.local_modes_of(ev.source)[1:]
        after = system.local_modes_of(ev.target)[1:]
        for i, (a, b) in enumerate(zip(before, after, strict=True)):
            if a == b:
                continue
            if a.endswith(".stick") and i not in breakaway:
                breakaway[i] = ev.t
            if b.endswith(".stick"):
                sticks += 1
            if a.endswith(".stick") and ev.chained:
                reversals += 1  # a slip through zero velocity: stick entered and left at one instant
    return {
        "wall_s": wall,
        "load": load(),
        "x_end": x.tolist(),
        "switches": len(tr.events),
        "breakaways": [breakaway.get(i, math.nan) for i in range(n)],
        "reversals": reversals,
        "sticks": sticks,
    }


def reference(n: int) -> dict:
    return run_json(
        [sys.executable, str(HERE / "reference_chain.py"), "--N", str(n), "--no-switch-list"], 3600
    )


def siconos(n: int, h: float, solver: str) -> dict:
    cmd = [
        SICONOS_PYTHON,
        str(HERE / "siconos_chain.py"),
        "--N",
        str(n),
        "--h",
        repr(h),
        "--t-end",
        repr(T_END),
    ]
    out = run_json([*cmd, "--solver", solver], 24 * 3600)
    out["load"] = load()
    return out


def fit(hs: list[float], errs: list[float], fallback: float | None) -> tuple[float, float]:
    """``(C, p)`` of ``error = C h^p`` (least squares in logs; with one point, ``p`` from
    ``fallback``)."""
    if len(hs) >= 2:
        p, logc = np.polyfit(np.log(hs), np.log(errs), 1)
        return float(np.exp(logc)), float(p)
    p = 1.0 if fallback is None else fallback
    return float(errs[0] / hs[0] ** p), p


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, nargs="+", default=[6, 20, 100], help="numbers of blocks")
    ap.add_argument("--solver", default="PGS", help="Siconos relay solver (PGS: the fastest here)")
    ap.add_argument("--fine", action="store_true", help="also run Siconos at the step for 1e-6 at N = 6")
    ap.add_argument("--out", type=Path, default=OUT)
    args = ap.parse_args(argv)
    why = siconos_available()
    if why is not None:
        print(
            f"Siconos is not available ({why}): skipped. Install it with `apt-get install python3-siconos` "
            f"(it installs for the system Python, {SICONOS_PYTHON}; SICONOS_PYTHON names another)."
        )
        return 0
    rows, order = [], None
    for n in args.n:
        mine = ours(n)
        ref = reference(n)
        x = np.array(mine["x_end"])
        err_ours = float(np.max(np.abs(x - np.array(ref["x_end"]))))
        print(
            f"N = {n}: this library {mine['wall_s']:.3f} s (load {mine['load']}), error {err_ours:.2e} vs reference"
        )
        runs = []
        for h in STEPS.get(n, (1e-3,)):
            s = siconos(n, h, args.solver)
            err = float(np.max(np.abs(np.array(s["x_end"]) - x)))
            t_sw = [sw[0] for sw in s.get("switches", []) if sw[2] == "slip"]
            first = {}
            for t, i, kind in s.get("switches", []):
                if kind == "slip" and i - 1 not in first:
                    first[i - 1] = t
            dt = max((abs(first[i] - mine["breakaways"][i]) for i in first), default=math.nan)
            runs.append(
                {
                    "h": h,
                    "wall_s": s["wall_s"],
                    "per_step_ms": 1e3 * s["wall_s"] / s["steps"],
                    "error": err,
                    "breakaway_time_error": dt,
                    "slips": len(t_sw),
                    "switches": s.get("n_switches"),
                    "switches_filtered": s.get("n_switches_filtered"),
                    "reversals": s.get("n_reversals"),
                    "load": s["load"],
                }
            )
            print(
                f"  Siconos h = {h:g}: {s['wall_s']:.2f} s ({runs[-1]['per_step_ms']:.3f} ms/step, load {s['load']}), "
                f"error {err:.2e}, breakaway instants off by {dt:.1e} s"
            )
        C, p = fit([r["h"] for r in runs], [r["error"] for r in runs], order)
        if len(runs) >= 2:
            order = p
        h_target = (TARGET / C) ** (1.0 / p)
        per_step = float(np.median([r["per_step_ms"] for r in runs])) / 1e3
        t_target = per_step * T_END / h_target
        fine = None
        if args.fine and n == 6:
            s = siconos(n, h_target, args.solver)
            fine = {
                "h": h_target,
                "wall_s": s["wall_s"],
                "error": float(np.max(np.abs(np.array(s["x_end"]) - x))),
                "load": s["load"],
            }
            t_target = s["wall_s"]
            print(f"  Siconos h = {h_target:.3g} (measured): {s['wall_s']:.1f} s, error {fine['error']:.2e}")
        at_1e3 = next((r for r in runs if r["h"] == 1e-3), None)
        row = {
            "blocks": n,
            "ours": mine,
            "ours_error_vs_reference": err_ours,
            "reference_wall_s": ref.get("wall_s"),
            "siconos": runs,
            "order_fit": {"C": C, "p": p, "from": "these runs" if len(runs) >= 2 else "the smaller chains"},
            "siconos_h_for_1e-6": h_target,
            "siconos_time_for_1e-6_s": t_target,
            "siconos_time_for_1e-6": "measured" if fine else "from the fit and the cost per step",
            "siconos_fine": fine,
            "ratio_at_1e-6": t_target / mine["wall_s"],
            "ratio_at_h_1e-3": at_1e3["wall_s"] / mine["wall_s"] if at_1e3 else None,
        }
        rows.append(row)
        print(
            f"  error 1e-6: Siconos h = {h_target:.2e}, {t_target:.3g} s ({row['siconos_time_for_1e-6']}): "
            f"{row['ratio_at_1e-6']:.3g} x this library's time"
        )
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps({"t_end": T_END, "solver": args.solver, "rows": rows}, indent=1) + "\n")
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
