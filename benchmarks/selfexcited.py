"""The measurements of issue 11 (self-excited stick-slip): writes ``docs/selfexcited/`` and prints them.

1. ``belt`` (Coulomb stiction, no damping): the stick-slip cycle's period and amplitude over belt
   speeds against the closed form of docs/selfexcited.md, exact integrator and IDA;
2. ``belt_stribeck``: the Hopf point against its closed form, the branch of unstable cycles from
   it and the branch of stick-slip cycles, both to the grazing where they meet; a long run from
   near the (unstable) steady sliding settling onto the computed cycle;
3. ``belt_damper``: the amplitude of the main mass against the belt speed with and without the
   sequential friction-spring damper.

Usage: ``python benchmarks/selfexcited.py [--out docs/selfexcited]`` (about a minute on 2 cores).
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import os
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

import hybrid
import hybrid_models
from hybrid import IDA, SolverOptions, method_named, simulate
from hybrid.continuation.autonomous import AUTONOMOUS_CONTINUATION, hopf_branch, orbit_branch
from hybrid.points.autonomous import autonomous_orbit
from hybrid.points.equilibria import locate_hopf

#: Tolerances of the Stribeck and damper branches: at rtol 1e-10 the trivial multiplier of the
#: smooth cycles is off by up to 7e-8 (the variational runs' error), at 1e-12 by about 1e-9.
BRANCH_OPTIONS = SolverOptions(method=IDA(rtol=1e-12, atol=1e-14))
#: Continuation settings of the branches: orbits periodic to 1e-11.
SETTINGS = replace(
    AUTONOMOUS_CONTINUATION, ds=0.04, ds_max=0.12, newton=hybrid.NewtonOptions(tol=1e-11, max_iter=8)
)


def trivial_error(o) -> float:
    return float(abs(o.multipliers[o.multiplier_kinds.index("trivial")] - 1.0))


def closed_form(p, v_b):
    d, om = (p["Fs"] - p["Fk"]) / p["k"], math.sqrt(p["k"] / p["m"])
    return 2 * d / v_b + (math.pi + 2 * math.atan(v_b / (om * d))) / om, math.hypot(d, v_b / om)


def figure(shape=(1, 2), size=(11, 4.2)):
    fig = Figure(figsize=size, layout="constrained")
    FigureCanvasAgg(fig)
    return fig, fig.subplots(*shape)


def coulomb(out: Path) -> dict:
    belt = hybrid_models.belt()
    p = belt.preset("standard")
    rows = []
    for v_b in np.geomspace(0.05, 3.0, 25):
        T, A = closed_form(p, v_b)
        row = {"v_b": v_b, "period_closed": T, "amplitude_closed": A}
        for integ in ("exact", "ida"):
            o = autonomous_orbit(
                belt,
                {**p, "v_b": float(v_b)},
                options=SolverOptions(
                    method=(IDA(rtol=1e-10, atol=1e-12) if integ == "ida" else method_named(integ))
                ),
                settings=hybrid.ShootingOptions(newton=hybrid.NewtonOptions(tol=1e-12)),
            )
            row[f"period_{integ}"] = o.period
            row[f"amplitude_{integ}"] = o.half_peak_to_peak["x"]
            row[f"period_err_{integ}"] = abs(o.period / T - 1)
            row[f"amplitude_err_{integ}"] = abs(o.half_peak_to_peak["x"] / A - 1)
            row[f"trivial_err_{integ}"] = trivial_error(o)
        rows.append(row)
    with open(out / "coulomb.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    fig, (a, b) = figure()
    vb = np.array([r["v_b"] for r in rows])
    fine = np.geomspace(0.05, 3.0, 400)
    cf = np.array([closed_form(p, v) for v in fine])
    a.plot(fine, cf[:, 0], "k-", lw=1, label="period, closed form")
    a.plot(vb, [r["period_ida"] for r in rows], "o", mfc="none", color="C0", label="period, computed (IDA)")
    a.plot(fine, cf[:, 1] * 10, "k--", lw=1, label="10 x amplitude of x, closed form")
    a.plot(
        vb,
        [10 * r["amplitude_ida"] for r in rows],
        "s",
        mfc="none",
        color="C1",
        label="10 x amplitude, computed",
    )
    a.set_xscale("log")
    a.set_xlabel("belt speed v_b [m/s]")
    a.set_ylabel("T [s], 10 x amplitude [m]")
    a.legend(fontsize=8)
    a.set_title("belt, Coulomb stiction, c = 0: the stick-slip cycle")
    for integ, mk in (("exact", "o"), ("ida", "s")):
        b.semilogy(
            vb, [max(r[f"period_err_{integ}"], 1e-17) for r in rows], mk + "-", label=f"period, {integ}"
        )
        b.semilogy(
            vb,
            [max(r[f"amplitude_err_{integ}"], 1e-17) for r in rows],
            mk + "--",
            label=f"amplitude, {integ}",
        )
        b.semilogy(
            vb,
            [max(r[f"trivial_err_{integ}"], 1e-17) for r in rows],
            mk + ":",
            label=f"|trivial mu - 1|, {integ}",
        )
    b.set_xscale("log")
    b.set_xlabel("belt speed v_b [m/s]")
    b.set_ylabel("relative error")
    b.legend(fontsize=7, ncol=2)
    b.set_title("error against the closed form (rtol 1e-10)")
    b.grid(alpha=0.3)
    fig.savefig(out / "coulomb.png", dpi=110)
    return {k: max(r[k] for r in rows) for k in rows[0] if "err" in k}


def stribeck(out: Path) -> tuple[dict, list]:
    belt = hybrid_models.belt_stribeck()
    p = belt.preset("standard")
    v_star = p["vs"] * math.log((p["Fs"] - p["Fk"]) / (p["vs"] * (p["c"] + p["cf"])))
    hp = locate_hopf(belt, p, "slip-", "v_b", (0.6, 2.5), {"x": 0.5, "w": -0.6})
    v_h, eq = hp.parameter, hp.equilibrium
    settings = SETTINGS
    smooth = hopf_branch(eq, "v_b", (0.2, 3.0), settings=settings, options=BRANCH_OPTIONS)
    cycle = autonomous_orbit(belt, p, options=BRANCH_OPTIONS)
    up = orbit_branch(cycle, "v_b", (0.2, 3.0), settings=settings, options=BRANCH_OPTIONS)
    down = orbit_branch(cycle, "v_b", (0.2, 3.0), direction=-1, settings=settings, options=BRANCH_OPTIONS)
    # a long run from near the unstable steady sliding at v_b = 0.8
    x_star = (p["Fk"] + (p["Fs"] - p["Fk"]) * math.exp(-p["v_b"] / p["vs"])) / p["k"]
    tr = simulate(
        belt,
        p,
        (0.0, 400.0),
        {"x": x_star + 1e-3, "w": -p["v_b"]},
        mode0="slip-",
        options=SolverOptions(method=IDA(rtol=1e-10, atol=1e-12)),
        t_eval=np.linspace(0, 400, 40001),
    )
    hits = [e for e in tr.events if e.guard == "breakaway-"]
    fig, (a, b) = figure()
    a.plot(tr.t, tr["x"], lw=0.6)
    a.set_xlabel("t [s]")
    a.set_ylabel("x [m]")
    a.set_title(f"long run from steady sliding + 1e-3 (v_b = {p['v_b']})")
    k = tr.t > hits[-3].t
    b.plot(
        tr["x"][tr.t < hits[0].t],
        tr["w"][tr.t < hits[0].t],
        lw=0.4,
        color="C0",
        label="run, before the first stick",
    )
    b.plot(tr["x"][k], tr["w"][k], lw=3, color="C1", alpha=0.5, label="run, last two cycles")
    ot = cycle.trajectory
    b.plot(ot["x"], ot["w"], "k--", lw=1, label="computed cycle")
    b.set_xlabel("x [m]")
    b.set_ylabel("w = v - v_b [m/s]")
    b.legend(fontsize=8)
    fig.savefig(out / "settling.png", dpi=110)
    res = {
        "hopf_closed_form": v_star,
        "hopf_located": v_h,
        "hopf_relative_error": abs(v_h / v_star - 1),
        "hopf_frequency": abs(float(eq.eigenvalues[0].imag)),
        "smooth_branch": {
            "reason": smooth.reason,
            "end": float(smooth.values[-1]),
            "points": len(smooth.points),
            "stability": sorted({o.stability for o in smooth.points}),
            "first": {"v_b": float(smooth.values[0]), "period": smooth.points[0].period},
            "max_trivial_error": max(trivial_error(o) for o in smooth.points),
        },
        "stick_slip_up": {
            "reason": up.reason,
            "end": float(up.values[-1]),
            "points": len(up.points),
            "max_trivial_error": max(trivial_error(o) for o in up.points),
        },
        "stick_slip_down": {
            "reason": down.reason,
            "end": float(down.values[-1]),
            "points": len(down.points),
            "max_trivial_error": max(trivial_error(o) for o in down.points),
        },
        "grazing_gap": abs(float(smooth.values[-1]) - float(up.values[-1])),
        "cycle_at_preset": {
            "period": cycle.period,
            "multipliers": [[z.real, z.imag] for z in cycle.multipliers],
            "kinds": list(cycle.multiplier_kinds),
            "amplitude_x": cycle.half_peak_to_peak["x"],
        },
        "settling": {
            "first_stick_s": next(e.t for e in tr.events if e.target == "stick"),
            "cycles": len(hits),
            "last_period": hits[-1].t - hits[-2].t,
            "period_relative_error": abs((hits[-1].t - hits[-2].t) / cycle.period - 1),
            "state_error": float(np.max(np.abs(hits[-1].x_plus - cycle.x0))),
        },
    }
    table = [("without damper, stick-slip", o) for o in down.points[::-1] + up.points]
    table += [("without damper, unstable cycles from the Hopf point", o) for o in smooth.points]
    return res, table


def damper(out: Path, undamped: list) -> dict:
    sys_ = hybrid_models.belt_damper()
    p = sys_.preset("standard")
    settings = SETTINGS
    cycle = autonomous_orbit(
        sys_, p, options=BRANCH_OPTIONS, settings=hybrid.ShootingOptions(transient_periods=30)
    )
    up = orbit_branch(cycle, "v_b", (0.2, 3.0), settings=settings, options=BRANCH_OPTIONS)
    down = orbit_branch(cycle, "v_b", (0.2, 3.0), direction=-1, settings=settings, options=BRANCH_OPTIONS)
    table = undamped + [("with damper, stick-slip", o) for o in down.points[::-1] + up.points]
    with open(out / "damper.csv", "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["curve", "v_b", "amplitude_main_mass", "period", "stability", "max_abs_floquet"])
        for label, o in table:
            coord = "x" if "x" in o.half_peak_to_peak else "x1"
            fl = np.abs(o.floquet_multipliers)
            w.writerow(
                [
                    label,
                    o.params["v_b"],
                    o.half_peak_to_peak[coord],
                    o.period,
                    o.stability,
                    float(fl.max()) if fl.size else 0.0,
                ]
            )
    fig, (a, b) = figure()
    styles = {
        "without damper, stick-slip": ("C0", "-"),
        "without damper, unstable cycles from the Hopf point": ("C0", "--"),
        "with damper, stick-slip": ("C3", "-"),
    }
    for label, (color, ls) in styles.items():
        pts = [
            (
                o.params["v_b"],
                o.half_peak_to_peak["x" if "x" in o.half_peak_to_peak else "x1"],
                o.period,
                o.stability,
            )
            for lab, o in table
            if lab == label
        ]
        pts.sort()
        v = np.array([q[0] for q in pts])
        amp = np.array([q[1] for q in pts])
        T = np.array([q[2] for q in pts])
        a.plot(v, amp, ls=ls, color=color, label=label)
        b.plot(v, T, ls=ls, color=color, label=label)
        uns = np.array([q[3] == "unstable" for q in pts])
        if uns.any() and ls == "-":
            a.plot(v[uns], amp[uns], "x", color=color, label=label.split(",")[0] + ": unstable points")
    bs = hybrid_models.belt_stribeck().preset("standard")
    v_star = bs["vs"] * math.log((bs["Fs"] - bs["Fk"]) / (bs["vs"] * (bs["c"] + bs["cf"])))
    a.axvline(
        v_star,
        color="grey",
        lw=0.8,
        ls=":",
        label=f"steady sliding loses stability (no damper), v_b = {v_star:.4f}",
    )
    a.set_xlabel("belt speed v_b [m/s]")
    a.set_ylabel("amplitude of the main mass (half peak-to-peak) [m]")
    a.legend(fontsize=7)
    a.set_title("stick-slip cycles with and without the friction-spring damper")
    b.set_xlabel("belt speed v_b [m/s]")
    b.set_ylabel("period T [s]")
    for ax in (a, b):
        ax.grid(alpha=0.3)
    fig.savefig(out / "damper.png", dpi=110)
    return {
        "up": {"reason": up.reason, "end": float(up.values[-1])},
        "down": {
            "reason": down.reason,
            "end": float(down.values[-1]),
            "unstable_below": [float(o.params["v_b"]) for o in down.points if o.stability == "unstable"],
        },
        "max_trivial_error": max(trivial_error(o) for o in up.points + down.points),
        "amplitude_at_preset": cycle.half_peak_to_peak["x1"],
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="docs/selfexcited")
    out = Path(ap.parse_args().out)
    out.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    res = {"load_before": os.getloadavg()[0], "coulomb": coulomb(out)}
    res["stribeck"], table = stribeck(out)
    res["damper"] = damper(out, table)
    res["wall_time_s"] = time.perf_counter() - t0
    res["load_after"] = os.getloadavg()[0]
    (out / "results.json").write_text(json.dumps(res, indent=2, default=float) + "\n")
    print(json.dumps(res, indent=2, default=float))


if __name__ == "__main__":
    main()
