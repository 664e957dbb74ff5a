"""The measurements of issue 23 (bifurcation analysis): writes ``docs/bifurcation/`` and prints them.

Sections (``python benchmarks/bifurcation.py [SECTION ...]``, all by default):

* ``table``: the special points of issue 23's item 1 against their closed forms (Den Hartog's
  non-stop boundary, the belt's grazing, the Duffing folds bracketed and located, the absorber's
  band edges, Shaw's branch point, the Stribeck Hopf point), exact integrator and IDA: closed
  form, reported point, interval, whether it holds the closed form;
* ``shaw``: Shaw's oscillator (m = k = F = 1, c = 0, Rk = 0.3, Rs = 0.5): the branch point of the
  symmetric orbit against the half map's closed form, the asymmetric branches switched onto, their
  multipliers against long simulations;
* ``doubling``: the friction oscillator with Rs = 0.9, Rk = 0.2 (c = 0): the period doubling of
  its asymmetric orbits, the switch onto the doubled branch, its multipliers, one doubled orbit
  checked by a run;
* ``edges``: the absorber's four band edges continued in R over [0.3, 0.8] against the closed form;
* ``rmin``: the smallest R with a bounded response of each damper and resonance, beside the
  averaging model's;
* ``check``: the band loci of ``planes`` against the closed form (``band_edges``);
* ``planes``: the stick-slip bands of each damper in (R, Omega) and (c3, Omega), the boundary of
  bounded response in (R, c3), the belt's Hopf and grazing curves in (v_b, c); each curve timed.

Each section writes ``<section>.json`` (and CSV and PNG where it draws) under ``--out``.
About an hour on 2 cores (``planes`` most of it); the load is recorded with every timing.
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import os
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

import hybrid
import hybrid_models
from hybrid import (
    IDA,
    ContinuationOptions,
    Exact,
    SolverOptions,
    continue_locus,
    continue_orbits,
    switch_branch,
)
from hybrid.continuation.autonomous import AUTONOMOUS_CONTINUATION
from hybrid_models.classics import (
    belt_grazing_speed,
    den_hartog_boundary,
    shaw_branch_point,
    shaw_symmetric_orbit,
)
from hybrid_models.linear import band_edges
from hybrid_models.studies import bounded_response_limit, study_params

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests" / "hybrid"))
import orbit_problems as op  # noqa: E402  (the Duffing references of the test suite)

EXACT = SolverOptions(method=Exact())
IDA = SolverOptions(method=IDA(rtol=1e-10, atol=1e-12))
OPTIONS = {"exact": EXACT, "ida": IDA}


def load() -> str:
    a, b, c = os.getloadavg()
    return f"load {a:.2f} {b:.2f} {c:.2f}"


def figure(shape=(1, 1), size=(7, 5)):
    fig = Figure(figsize=size, layout="constrained")
    FigureCanvasAgg(fig)
    return fig, fig.subplots(*shape)


def row(name, integrator, ref, sp, extra=""):
    lo, hi = sp.interval
    return {
        "point": name,
        "integrator": integrator,
        "closed_form": ref,
        "reported": sp.parameter,
        "status": str(sp.status),
        "accuracy": sp.accuracy,
        "interval_lo": lo,
        "interval_hi": hi,
        "error": sp.parameter - ref,
        "holds": bool(lo <= ref <= hi),
        "note": extra,
    }


def write(out: Path, name: str, data) -> None:
    (out / f"{name}.json").write_text(json.dumps(data, indent=1, default=str) + "\n")


def write_csv(path: Path, rows: list[dict]) -> None:
    with open(path, "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)


# ----------------------------------------------------------------------------
def table(out: Path) -> dict:
    rows = []
    fo = hybrid_models.friction_oscillator()
    # Den Hartog (m = k = F = 1, c = 0.1, R = 0.3): non-stop above the boundary
    p = fo.preset("denhartog")
    W = den_hartog_boundary(1.0, 1.0, 0.1, 0.3, 1.0, (0.45, 0.55))
    for integ, opts in OPTIONS.items():
        br = continue_orbits(fo, p, "Omega", (0.4, 0.8), options=opts)
        (sp,) = [s for s in br.special if s.kind == "mode-lost"]
        rows.append(row("Den Hartog non-stop boundary (Omega)", integ, W, sp))
    # the belt with damping (c = 0.05): the stick-slip cycle ends at a grazing
    belt = hybrid_models.belt()
    pb = belt.preset("damped")
    V = belt_grazing_speed(1.0, 1.0, 0.05, 1.0, 0.5, (0.8, 0.86))
    st = replace(AUTONOMOUS_CONTINUATION, ds=0.058, ds_max=0.145)
    for integ, opts in OPTIONS.items():
        o = hybrid.autonomous_orbit(belt, pb, options=opts)
        br = hybrid.orbit_branch(o, "v_b", (0.3, 3.0), options=opts, settings=st)
        (sp,) = [s for s in br.special if s.kind == "grazing"]
        rows.append(row("belt grazing, c = 0.05 (v_b)", integ, V, sp))
    # Duffing's folds (the test suite's reference: harmonic-balance seeded, Newton on the period map)
    system, params, ref = op.duffing()
    for locate, name in ((False, "not located (locate=False)"), (True, "located")):
        br = continue_orbits(
            system,
            params,
            "Omega",
            (1.0, 1.4),
            settings=ContinuationOptions(ds=0.1, samples_per_period=32, locate=locate),
        )
        folds = [s for s in br.special if s.kind == "fold"]
        for sp, fold, which in zip(folds, (ref.folds[1], ref.folds[0]), ("upper", "lower"), strict=True):
            rows.append(
                row(f"Duffing {which} fold, {name} (Omega)", "ida", fold.params["Omega"], sp, "rtol 1e-8")
            )
    # the absorber's band edges (standard preset)
    ab = hybrid_models.absorber()
    pa = ab.preset("standard")
    for window, lab in (((0.852, 0.858), 1), ((1.166, 1.175), 2)):
        refs = band_edges("absorber", pa, window[0] - 0.05, window[1] + 0.02)
        for integ, opts in OPTIONS.items():
            br = continue_orbits(ab, pa, "Omega", window, options=opts)
            edges = sorted(
                (s for s in br.special if s.kind in ("mode-gained", "mode-lost")), key=lambda s: s.parameter
            )
            for sp, r, side in zip(edges, refs, ("onset", "end"), strict=True):
                rows.append(row(f"absorber band {lab} {side} of slip (Omega)", integ, r, sp))
    # Shaw's branch point
    ps = fo.preset("shaw")
    Wb = shaw_branch_point((0.46, 0.465))
    for integ, opts in OPTIONS.items():
        br = continue_orbits(fo, ps, "Omega", (0.3, 0.5), options=opts)
        (sp,) = [s for s in br.special if s.kind == "branch-point"]
        rows.append(row("Shaw branch point (Omega)", integ, Wb, sp))
    # the Stribeck belt's Hopf point
    bs = hybrid_models.belt_stribeck()
    q = bs.preset("standard")
    vstar = q["vs"] * math.log((q["Fs"] - q["Fk"]) / (q["vs"] * (q["c"] + q["cf"])))
    eb = hybrid.equilibrium_branch(bs, q, "slip-", "v_b", np.linspace(0.5, 2.5, 41))
    (sp,) = [s for s in eb.special if s.kind == "hopf"]
    rows.append(row("belt_stribeck Hopf (v_b)", "-", vstar, sp))
    write_csv(out / "table.csv", rows)
    print(
        f"{'point':44s} {'integ':5s} {'closed form':>19s} {'reported':>19s} {'status':>10s} {'interval':>44s} holds"
    )
    for r in rows:
        print(
            f"{r['point']:44s} {r['integrator']:5s} {r['closed_form']:19.15g} {r['reported']:19.15g} "
            f"{r['status']:>10s} [{r['interval_lo']:.15g}, {r['interval_hi']:.15g}] {r['holds']}"
        )
    return {"rows": rows, "all_hold": all(r["holds"] for r in rows)}


# ----------------------------------------------------------------------------
def _multiplier_by_run(system, orbit, periods: int = 40, eps: float = 1e-7, skip: int = 5) -> float:
    """The dominant Floquet multiplier of an orbit of the friction oscillator from two long runs
    (``periods`` forcing periods) from the section state moved by ``+-eps`` in ``x``: the
    difference of the runs' stroboscopic states ``d_n`` (a central difference of the ``n``-th
    iterate of the map) grows as ``mu^n`` once it is along the dominant direction, so
    ``|mu| = (|d_N| / |d_skip|)^(1 / (N - skip))``; its sign from ``d_{n+1} . d_n``."""
    T = orbit.period
    times = orbit.t0 + T * np.arange(periods + 1)
    runs = []
    for sgn in (1.0, -1.0):
        x0 = dict(zip(system.variable_names, orbit.x0, strict=True))
        x0["x"] += sgn * eps
        tr = hybrid.simulate(
            system, orbit.params, (times[0], times[-1]), x0, mode0=orbit.mode0, t_eval=times, options=EXACT
        )
        runs.append(np.column_stack([np.asarray(tr["x"]), np.asarray(tr["v"])]))
    d = (runs[0] - runs[1]) / (2 * eps)
    n = np.linalg.norm(d, axis=1)
    last = periods
    while last > skip + 1 and not (1e-300 < n[last] and n[last] * 2 * eps > 1e-11):
        last -= 1  # the difference must stay above the runs' rounding
    mag = (n[last] / n[skip]) ** (1.0 / (last - skip))
    sign = np.sign(np.sum(d[skip + 1 : last + 1] * d[skip:last], axis=1).mean())
    return float(sign * mag)


def shaw(out: Path) -> dict:
    fo = hybrid_models.friction_oscillator()
    p = fo.preset("shaw")
    W = shaw_branch_point((0.46, 0.465))
    res = {"closed_form_branch_point": W}
    for integ, opts in OPTIONS.items():
        t0 = time.perf_counter()
        br = continue_orbits(fo, p, "Omega", (0.3, 0.5), options=opts)
        (k,) = [i for i, s in enumerate(br.special) if s.kind == "branch-point"]
        sp = br.special[k]
        res[integ] = {
            "branch_point": row("Shaw branch point", integ, W, sp),
            "wall_time_s": time.perf_counter() - t0,
        }
    # the symmetric orbit's multiplier against the half map (mu = h'^2) at three frequencies
    br = continue_orbits(fo, p, "Omega", (0.3, 0.5), options=EXACT)
    sym = []
    for o in br.points:
        w = o.params["Omega"]
        if 0.40 <= w <= 0.463:
            xs, d = shaw_symmetric_orbit(w)
            mu = float(np.max(np.abs(o.floquet_multipliers)))
            sym.append({"Omega": w, "mu": mu, "half_map_squared": d * d, "error": mu - d * d})
    res["symmetric_multipliers"] = sym
    # switch onto the asymmetric branches; their multipliers against runs
    t0 = time.perf_counter()
    k = [i for i, s in enumerate(br.special) if s.kind == "branch-point"][0]
    halves = switch_branch(br, k, (0.3, 0.5), options=EXACT)
    res["switch_wall_time_s"] = time.perf_counter() - t0
    res["load"] = load()
    asym = []
    fig, ax = figure((1, 2), (11, 4.2))
    ax[0].plot(br.values, br.amplitude("x"), "k-", lw=1, label="symmetric")
    for h, half in enumerate(halves):
        pts = [o for o in half.points if o.params["Omega"] <= 0.479]
        ax[0].plot(
            [o.params["Omega"] for o in pts],
            [o.amplitude["x"] for o in pts],
            "-",
            lw=1.2,
            label=f"asymmetric {'+-'[h]}",
        )
        ax[1].plot(
            [o.params["Omega"] for o in pts],
            [max(np.abs(o.floquet_multipliers)) for o in pts],
            "-",
            label=f"asymmetric {'+-'[h]}",
        )
        for o in pts[:: max(1, len(pts) // 6)][:6]:
            mu = float(o.floquet_multipliers.real[np.argmax(np.abs(o.floquet_multipliers))])
            run = _multiplier_by_run(fo, o)
            asym.append(
                {
                    "half": "+-"[h],
                    "Omega": o.params["Omega"],
                    "x_stuck": float(o.x0[0]),
                    "mu": mu,
                    "mu_by_run": run,
                    "difference": run - mu,
                }
            )
    ax[1].plot(br.values, [max(np.abs(o.floquet_multipliers)) for o in br.points], "k-", lw=1)
    ax[0].axvline(W, color="C3", ls=":", lw=1)
    ax[1].axvline(W, color="C3", ls=":", lw=1)
    ax[1].axhline(1.0, color="0.5", lw=0.8)
    ax[0].set(
        xlabel="Omega [rad/s]",
        ylabel="max |x| [m]",
        xlim=(0.40, 0.48),
        title="Shaw's oscillator: the pitchfork",
    )
    ax[1].set(xlabel="Omega [rad/s]", ylabel="largest |multiplier|", xlim=(0.40, 0.48), ylim=(0.5, 1.2))
    ax[0].legend(fontsize=8)
    fig.savefig(out / "shaw.png", dpi=120)
    res["asymmetric"] = asym
    res["max_multiplier_difference"] = max(abs(a["difference"]) for a in asym)
    write_csv(out / "shaw_asymmetric.csv", asym)
    print(
        json.dumps(
            {k: v for k, v in res.items() if k not in ("symmetric_multipliers", "asymmetric")},
            indent=1,
            default=str,
        )
    )
    print("symmetric orbit: max |mu - h'^2| =", max(abs(s["error"]) for s in sym))
    print("asymmetric orbits: max |mu(run) - mu| =", res["max_multiplier_difference"])
    return res


# ----------------------------------------------------------------------------
def doubling(out: Path) -> dict:
    fo = hybrid_models.friction_oscillator()
    p = {**fo.preset("shaw"), "Rs": 0.9, "Rk": 0.2}
    t0 = time.perf_counter()
    br = continue_orbits(fo, p, "Omega", (0.15, 0.9), options=EXACT)
    k = [i for i, s in enumerate(br.special) if s.kind == "branch-point"][0]
    asym = switch_branch(br, k, (0.15, 0.9), options=EXACT)[0]
    j = [i for i, s in enumerate(asym.special) if s.kind == "period-doubling"][0]
    pd = asym.special[j]
    t1 = time.perf_counter()
    (dbl,) = switch_branch(asym, j, (0.15, 0.9), options=EXACT)
    t_switch = time.perf_counter() - t1
    T1 = 2 * math.pi / pd.parameter
    pts = []
    for o in dbl.points[:30]:
        mu = o.floquet_multipliers
        pts.append(
            {
                "Omega": o.params["Omega"],
                "period": o.period,
                "period_over_T": o.period * o.params["Omega"] / (2 * math.pi),
                "multipliers": [complex(m) for m in mu],
                "stability": o.stability,
                "mu_by_run": _multiplier_by_run(fo, o) if len(pts) % 2 == 0 and len(pts) < 12 else None,
            }
        )
    # one doubled orbit: periodic over 2T, not over T
    o = dbl.points[min(6, len(dbl.points) - 1)]
    T = o.period / 2
    x0 = dict(zip(fo.variable_names, o.x0, strict=True))
    tr = hybrid.simulate(
        fo, o.params, (o.t0, o.t0 + 2 * T), x0, mode0=o.mode0, t_eval=[o.t0 + T, o.t0 + 2 * T], options=EXACT
    )
    check = {
        "Omega": o.params["Omega"],
        "x(T) - x0": float(tr["x"][0] - o.x0[0]),
        "x(2T) - x0": float(tr["x"][1] - o.x0[0]),
        "v(2T) - v0": float(tr["v"][1] - o.x0[1]),
    }
    res = {
        "model": "friction_oscillator (Shaw's), m = k = F = 1, c = 0, Rs = 0.9, Rk = 0.2",
        "period_doubling": {
            "Omega": pd.parameter,
            "status": str(pd.status),
            "accuracy": pd.accuracy,
            "interval": pd.interval,
            "multipliers_there": [complex(m) for m in asym.points[pd.index].floquet_multipliers],
        },
        "doubled_branch": str(dbl),
        "doubled_message": dbl.message,
        "doubled_special": [repr(s) for s in dbl.special],
        "doubled_points": pts,
        "run_check": check,
        "T_at_doubling": T1,
        "wall_time_s": time.perf_counter() - t0,
        "switch_wall_time_s": t_switch,
        "load": load(),
    }
    fig, ax = figure((1, 2), (11, 4.2))
    for b, lab, c in ((br, "symmetric", "k"), (asym, "asymmetric", "C0"), (dbl, "period 2", "C3")):
        ax[0].plot(b.values, b.amplitude("x"), "-", color=c, lw=1.1, label=lab)
        ax[1].plot(
            b.values,
            [
                float(o.floquet_multipliers.real[np.argmax(np.abs(o.floquet_multipliers))])
                if o.floquet_multipliers.size
                else np.nan
                for o in b.points
            ],
            "-",
            color=c,
            lw=1.1,
            label=lab,
        )
    for s in asym.special + dbl.special:
        if s.kind == "period-doubling":
            ax[0].axvline(s.parameter, color="C4", ls=":", lw=1)
            ax[1].axvline(s.parameter, color="C4", ls=":", lw=1)
    ax[1].axhline(-1.0, color="0.5", lw=0.8)
    ax[0].set(
        xlabel="Omega [rad/s]",
        ylabel="max |x| [m]",
        xlim=(0.29, 0.45),
        title="period doubling of the asymmetric orbits",
    )
    ax[1].set(
        xlabel="Omega [rad/s]", ylabel="dominant multiplier (real part)", xlim=(0.29, 0.45), ylim=(-1.5, 1.1)
    )
    ax[0].legend(fontsize=8)
    fig.savefig(out / "doubling.png", dpi=120)
    print(json.dumps({k: v for k, v in res.items() if k != "doubled_points"}, indent=1, default=str))
    for q in pts[:8]:
        print(
            f"  {q['Omega']:.10f}  T/T0 = {q['period_over_T']:.6f}  {q['stability']}  "
            f"{np.round(q['multipliers'], 6)}  run: {q['mu_by_run']}"
        )
    return res


# ----------------------------------------------------------------------------
def edges(out: Path) -> dict:
    ab = hybrid_models.absorber()
    pa = ab.preset("standard")
    res = {"loci": []}
    all_rows = []
    for window, lab in (((0.852, 0.858), 1), ((1.166, 1.175), 2)):
        br = continue_orbits(ab, pa, "Omega", window, options=EXACT)
        for k, s in enumerate(br.special):
            if s.kind not in ("mode-gained", "mode-lost"):
                continue
            t0 = time.perf_counter()
            lc = continue_locus(br, k, "R", (0.3, 0.8), step=0.05, options=EXACT)
            wall = time.perf_counter() - t0
            errs = []
            for q in lc.points:
                R = q.values["R"]
                lo_hi = band_edges("absorber", {**pa, "R": R}, window[0] - 0.06, window[1] + 0.03)
                ref = lo_hi[0] if s.kind == "mode-gained" else lo_hi[1]
                if q.located != "Omega":
                    continue
                errs.append(abs(q.values["Omega"] - ref))
                all_rows.append(
                    {
                        "band": lab,
                        "edge": s.kind,
                        "R": R,
                        "Omega": q.values["Omega"],
                        "closed_form": ref,
                        "error": q.values["Omega"] - ref,
                        "status": str(q.status),
                        "accuracy": q.accuracy,
                        "holds": bool(q.interval[0] <= ref <= q.interval[1]),
                    }
                )
            res["loci"].append(
                {
                    "band": lab,
                    "edge": s.kind,
                    "points": len(lc.points),
                    "R_span": [float(lc.values("R").min()), float(lc.values("R").max())],
                    "max_error": max(errs),
                    "all_hold": all(r["holds"] for r in all_rows if r["band"] == lab and r["edge"] == s.kind),
                    "wall_time_s": wall,
                    "load": load(),
                    "message": lc.message,
                }
            )
    write_csv(out / "edges.csv", all_rows)
    res["max_error"] = max(lc["max_error"] for lc in res["loci"])
    print(json.dumps(res, indent=1, default=str))
    return res


# ----------------------------------------------------------------------------
def rmin(out: Path) -> dict:
    res = []
    for model in ("absorber", "isolator"):
        for mode in (1, 2):
            r = bounded_response_limit(model, mode)
            res.append({**r.__dict__, "load": load()})
            print(r, load())
    write_csv(out / "rmin.csv", res)
    return {"limits": res}


# ----------------------------------------------------------------------------
def _band_loci(model: str, p2: str, rng2, windows, step: float):
    system = hybrid_models.BUILTIN[model]()
    p = study_params(model)
    loci, branches = [], []
    for window in windows:
        br = continue_orbits(system, p, "Omega", window, options=EXACT)
        branches.append(br)
        for k, s in enumerate(br.special):
            if s.kind in ("mode-gained", "mode-lost"):
                loci.append(continue_locus(br, k, p2, rng2, step=step, options=EXACT))
    return loci, branches


def planes(out: Path) -> dict:
    from hybrid.plot.locus import locus_figure

    res = {}
    windows = {"absorber": ((0.852, 0.858), (1.166, 1.175)), "isolator": ((0.85, 0.86), (1.166, 1.175))}
    ranges = {
        ("absorber", "R"): (0.3, 0.8),
        ("absorber", "c3"): (2.0, 50.0),
        ("isolator", "R"): (0.9, 3.0),
        ("isolator", "c3"): (10.0, 300.0),
    }
    for model in ("absorber", "isolator"):
        for p2 in ("R", "c3"):
            t0 = time.perf_counter()
            loci, branches = _band_loci(model, p2, ranges[(model, p2)], windows[model], 0.05)
            wall = time.perf_counter() - t0
            key = f"{model}_{p2}"
            res[key] = {
                "loci": [
                    {
                        "kind": lc.kind,
                        "points": len(lc.points),
                        "wall_time_s": lc.wall_time,
                        "message": lc.message,
                        "located": sum(q.status == "located" for q in lc.points),
                    }
                    for lc in loci
                ],
                "wall_time_s": wall,
                "load": load(),
            }
            rows = [{"locus": i, **r} for i, lc in enumerate(loci) for r in lc.to_rows()]
            write_csv(out / f"band_{key}.csv", rows)
            fig = locus_figure(loci, branches, "x1")
            fig.savefig(out / f"band_{key}.png", dpi=110)
            print(key, res[key])
    # the boundary of bounded response in (R, c3): R_min at each c3
    rows = []
    t0 = time.perf_counter()
    for model, c3s in (("absorber", (2.0, 5.0, 10.0, 20.0, 50.0)), ("isolator", (10.0, 30.0, 100.0, 300.0))):
        for mode in (1, 2):
            for c3 in c3s:
                pr = {**study_params(model), "c3": c3}
                r = bounded_response_limit(model, mode, pr, delta=0.0)
                rows.append(
                    {
                        "model": model,
                        "mode": mode,
                        "c3": c3,
                        "R_star": r.R_star,
                        "R_averaging": r.R_averaging,
                        "omega": r.omega,
                        "points": r.points,
                        "wall_time_s": r.wall_time,
                    }
                )
                print(rows[-1])
    res["bounded"] = {"rows": rows, "wall_time_s": time.perf_counter() - t0, "load": load()}
    write_csv(out / "bounded.csv", rows)
    fig, ax = figure((1, 2), (11, 4.2))
    for a, model in zip(ax, ("absorber", "isolator"), strict=True):
        for mode in (1, 2):
            rr = [r for r in rows if r["model"] == model and r["mode"] == mode]
            a.plot([r["c3"] for r in rr], [r["R_star"] for r in rr], "o-", label=f"resonance {mode}")
            a.plot(
                [r["c3"] for r in rr],
                [r["R_averaging"] for r in rr],
                "x--",
                color=a.lines[-1].get_color(),
                label=f"averaging {mode}",
            )
        a.set(xscale="log", xlabel="c3 [N/m]", ylabel="smallest R with a bounded response [N]", title=model)
        a.legend(fontsize=8)
    fig.savefig(out / "bounded.png", dpi=120)
    # the belt: Hopf (belt_stribeck) and grazing (belt, damped, exact) in (v_b, c)
    for name, model, preset, kind, opts, rng in (
        ("hopf", "belt_stribeck", "standard", "hopf", SolverOptions(), (0.02, 0.4)),
        ("grazing", "belt", "damped", "grazing", EXACT, (0.01, 0.2)),
    ):
        system = hybrid_models.BUILTIN[model]()
        p = system.preset(preset)
        t0 = time.perf_counter()
        if kind == "hopf":
            br = hybrid.equilibrium_branch(system, p, "slip-", "v_b", np.linspace(0.5, 2.5, 41))
        else:
            o = hybrid.autonomous_orbit(system, p, options=opts)
            br = hybrid.orbit_branch(
                o,
                "v_b",
                (0.3, 3.0),
                options=opts,
                settings=replace(AUTONOMOUS_CONTINUATION, ds=0.058, ds_max=0.145),
            )
        k = [i for i, s in enumerate(br.special) if s.kind == kind][0]
        lc = continue_locus(br, k, "c", rng, options=opts)
        errs = []
        for q in lc.points:
            c, vb = q.values["c"], q.values["v_b"]
            if kind == "hopf":
                ref_vb = p["vs"] * math.log((p["Fs"] - p["Fk"]) / (p["vs"] * (c + p["cf"])))
            else:
                ref_vb = (
                    belt_grazing_speed(p["m"], p["k"], c, p["Fs"], p["Fk"], (0.05, 5.0))
                    if q.located == "v_b"
                    else math.nan
                )
            if q.located == "v_b":
                errs.append(abs(vb - ref_vb))
        res[f"belt_{name}"] = {
            "points": len(lc.points),
            "wall_time_s": time.perf_counter() - t0,
            "load": load(),
            "max_error_v_b": max(errs) if errs else None,
            "message": lc.message,
        }
        write_csv(out / f"belt_{name}.csv", lc.to_rows())
        fig = locus_figure([lc], [br], None)
        fig.savefig(out / f"belt_{name}.png", dpi=110)
        print(name, res[f"belt_{name}"])
    return res


# ----------------------------------------------------------------------------
def check(out: Path) -> dict:
    """The points of the band loci written by ``planes`` (``band_*.csv``), located in Omega,
    against ``band_edges``: the largest error and the intervals that miss the closed form."""
    res = {}
    for model in ("absorber", "isolator"):
        base = study_params(model)
        for p2 in ("R", "c3"):
            path = out / f"band_{model}_{p2}.csv"
            if not path.exists():
                continue
            worst, missing, n, loose = 0.0, [], 0, 0
            for r in csv.DictReader(open(path)):
                if r["located_in"] != "Omega":
                    continue
                W = float(r["Omega"])
                lo, hi = band_edges(
                    model, {**base, p2: float(r[p2])}, *((0.78, 0.93) if W < 1 else (1.08, 1.26))
                )
                ref = lo if abs(W - lo) < abs(W - hi) else hi
                n += 1
                loose += r["status"] != "located"
                worst = max(worst, abs(W - ref))
                if not float(r["interval_lo"]) <= ref <= float(r["interval_hi"]):
                    missing.append({p2: float(r[p2]), "error": W - ref, "status": r["status"]})
            res[f"{model}_{p2}"] = {"points": n, "not_located": loose, "max_error": worst, "missing": missing}
            print(
                f"{model} ({p2}, Omega): {n} points, max error {worst:.2g}, not located {loose}, missing {missing}"
            )
    return res


SECTIONS = {
    "table": table,
    "shaw": shaw,
    "doubling": doubling,
    "edges": edges,
    "rmin": rmin,
    "planes": planes,
    "check": check,
}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("sections", nargs="*", default=list(SECTIONS), choices=list(SECTIONS) + [[]])
    ap.add_argument("--out", default=str(ROOT / "docs" / "bifurcation"))
    args = ap.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    for name in args.sections or list(SECTIONS):
        t0 = time.perf_counter()
        print(f"== {name} ({load()})", flush=True)
        data = SECTIONS[name](out)
        data = {**data, "section_wall_time_s": time.perf_counter() - t0, "load_at_end": load()}
        write(out, name, data)
        print(f"== {name}: {time.perf_counter() - t0:.1f} s ({load()})", flush=True)


if __name__ == "__main__":
    main()
