"""Backbones of the shipped examples by EPMC (issue 31): the figures and numbers of docs/backbones.md.

* the Jenkins oscillator (models/jenkins_oscillator.toml, m = k = kt = 1, Fs = 0.1): the backbone
  from 0.05 to 5 (50 Fs/kt) on the exact integrator, beside the single-harmonic (describing-function)
  estimate, which is approximate;
* the Iwan joint of 50 elements (models/iwan.toml, its forcing removed): the backbone from 0.05 to
  2 m beside the Masing-based single-mode estimate (the describing functions of its elements), and
  the energy dissipated per period at each point against Masing's rule.

Run: ``python benchmarks/backbones.py`` (several minutes on 2 cores). Writes
``docs/backbones/jenkins.png``, ``docs/backbones/iwan.png`` and ``docs/backbones/backbones.json``.
"""

from __future__ import annotations

import json
import math
import os
import time
from pathlib import Path

import numpy as np

import hybrid
import hybrid_models
from hybrid import Exact, SolverOptions
from hybrid.plot.backbone import plot_backbone

OUT = Path(__file__).resolve().parents[1] / "docs" / "backbones"
MODELS = Path(hybrid_models.__file__).parent
EXACT = SolverOptions(method=Exact())


def describing(a: float, kt: float, Fs: float) -> tuple[float, float]:
    """First-harmonic stiffness [N/m] and energy per cycle [J] of a Jenkins element at amplitude a."""
    if a <= Fs / kt:
        return kt, 0.0
    beta = math.acos(1 - 2 * Fs / (kt * a))
    return kt / math.pi * (beta - 0.5 * math.sin(2 * beta)), 4 * Fs * (a - Fs / kt)


def single_mode(a: np.ndarray, m: float, k0: float, kt: np.ndarray, Fs: np.ndarray):
    """The single-harmonic estimate ``(omega, D)`` of a mass on a spring k0 and Jenkins elements."""
    w, D = [], []
    for x in a:
        parts = [describing(x, k, f) for k, f in zip(kt, Fs, strict=True)]
        keq = k0 + sum(p[0] for p in parts)
        E = sum(p[1] for p in parts)
        om = math.sqrt(keq / m)
        xi = E / (math.pi * m * om * x * x)
        w.append(om)
        D.append(xi / (2 * om))
    return np.array(w), np.array(D)


def jenkins() -> dict:
    system = hybrid_models.epmc_system(MODELS / "jenkins_oscillator.toml")
    p = system.preset("standard")
    t0 = time.perf_counter()
    bb = hybrid.backbone(system, p, coordinate="x", amplitude_range=(0.05, 5.0), options=EXACT)
    wall = time.perf_counter() - t0
    a = np.geomspace(0.1001, 5.0, 200)
    w1, D1 = single_mode(a, p["m"], p["k"], np.array([p["kt"]]), np.array([p["Fs"]]))
    plot_backbone(
        bb, OUT / "jenkins.png", {"single harmonic (describing function): approximate": (a, w1, D1)}
    )
    errs = []
    for q in bb.points:
        if q.amplitude > 0.1001:
            wq, Dq = single_mode(
                np.array([q.amplitude]), p["m"], p["k"], np.array([p["kt"]]), np.array([p["Fs"]])
            )
            errs.append((q.amplitude, float(wq[0] / q.omega - 1), float(Dq[0] / q.damping_ratio - 1)))
    return {
        "points": len(bb.points),
        "wall_s": wall,
        "events": [e.as_dict() for e in bb.events],
        "single_harmonic_errors": errs,
    }


def iwan() -> dict:
    system = hybrid_models.epmc_system(MODELS / "iwan.toml")
    p = system.preset("standard")
    n = 50
    R = np.array([p[f"R_{i}"] for i in range(1, n + 1)])
    t0 = time.perf_counter()
    bb = hybrid.backbone(system, p, coordinate="x", amplitude_range=(0.05, 2.0), options=EXACT)
    wall = time.perf_counter() - t0
    a = np.geomspace(0.05, 2.0, 200)
    w1, D1 = single_mode(a, p["m"], p["k0"], np.full(n, p["K"] / n), R)
    plot_backbone(
        bb, OUT / "iwan.png", {"Masing-based single-mode estimate (one harmonic): approximate": (a, w1, D1)}
    )
    rows = []
    for q in bb.points:
        mas = float(np.sum(4 * R * np.clip(q.amplitude - R * n / p["K"], 0, None)))
        rows.append(
            {
                "amplitude": q.amplitude,
                "omega": q.omega,
                "damping_ratio": q.damping_ratio,
                "dissipated": q.dissipated,
                "masing": mas,
                "relative_deviation": (q.dissipated / mas - 1) if mas > 0 else q.dissipated,
            }
        )
    worst = max(abs(r["relative_deviation"]) for r in rows if r["masing"] > 0)
    assert worst < 1e-9, worst
    return {
        "points": len(bb.points),
        "wall_s": wall,
        "events": [e.as_dict() for e in bb.events],
        "rows": rows,
        "worst_masing_deviation": worst,
    }


def error_figure(errs) -> None:
    """``docs/backbones/jenkins_single_harmonic.png``: the single-harmonic estimate's relative errors."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    e = np.array(errs)
    fig = Figure(figsize=(7.0, 3.6), layout="constrained")
    FigureCanvasAgg(fig)
    ax = fig.subplots()
    ax.loglog(e[:, 0], np.abs(e[:, 1]), "-o", ms=3, label="omega: |single harmonic / exact - 1|")
    ax.loglog(e[:, 0], np.abs(e[:, 2]), "-s", ms=3, label="D: |single harmonic / exact - 1|")
    ax.set_xlabel("amplitude max x [m]")
    ax.set_ylabel("relative error of the approximation")
    ax.set_title("Jenkins oscillator: the single-harmonic (describing-function) EPMC estimate", fontsize=10)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.savefig(OUT / "jenkins_single_harmonic.png", dpi=110)


def main() -> dict:
    OUT.mkdir(parents=True, exist_ok=True)
    out = {"load": os.getloadavg()[0], "jenkins": jenkins()}
    error_figure(out["jenkins"]["single_harmonic_errors"])
    out["iwan"] = iwan()
    (OUT / "backbones.json").write_text(json.dumps(out, indent=2) + "\n")
    return out


if __name__ == "__main__":
    res = main()
    print(
        json.dumps(
            {
                k: (v if k == "load" else {kk: vv for kk, vv in v.items() if kk not in ("rows",)})
                for k, v in res.items()
            },
            indent=2,
        )
    )
