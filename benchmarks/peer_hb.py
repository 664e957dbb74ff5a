"""Harmonic balance side by side with exact results (issue 31, item 3): accuracy and cost against H.

Two problems, both on the single oscillator m = k = 1 with a Jenkins element (kt = 1, slip force
Fs = 1) to ground (``benchmarks/hb_jenkins.py`` holds the mathematics):

* **backbone (EPMC)**: omega(a) and D(a) at 10 amplitudes from 1.01 Fs/kt to 50 Fs/kt. Exact
  reference: :func:`exact_backbone`, an independent half-period shooting of the piecewise-linear
  motion (closed-form flows, brentq, fsolve); where the library's ``hybrid.backbone`` exists (issue
  31, item 1) it is run too and its difference printed.
* **forced response** (cases by name in :data:`FORCED`; today ``jenkins_forced``, the same
  oscillator with a damper c = 0.05 forced by F = 1 at 6 frequencies): the amplitude max x. Exact
  reference: this library's periodic orbit with the exact integrator on the network file
  ``benchmarks/data/jenkins_forced.toml``.

Harmonic balance on the odd harmonics 1, 3, ..., H for H = 1, 3, ..., 63, with N = max(1024, 256 (H+1))
time samples per period (alternating frequency-time; the sampled play operator errs by O(1/N^2)
where a turning point falls between samples, as in a forced orbit: with 64 (H+1) samples that error
was the floor near 1e-6 beyond H = 31, measured), by

* ``aft``: the minimal harmonic balance of ``hb_jenkins.HarmonicBalance`` (numpy, exact Jacobian of
  the sampled play operator), backbone and forced response;
* ``pyharm``: pyHarm's ``Jenkins`` element, linear spring, damper and ``CosinusForcing`` (its
  residual and analytic Jacobian, its Newton-Raphson solver), forced response at each fixed
  frequency. pyHarm 1.2.2 has no EPMC: its ``NLM_Backbone`` is a phase-resonance continuation
  under a harmonic-1 modal force (another definition of the backbone, without xi or D), so the
  backbone columns are ``aft`` only (``docs/networks.md``, "Against harmonic balance").

Each H starts from the previous H's solution (padded with zeros), H = 1 from the single-harmonic
estimate; times are wall times of the solves only (one BLAS thread for every method), the exact
references' from their own start. Printed: the table of relative errors (largest over the points)
and times; the H at which each error first falls below 1e-6 (or the best reached); the ratio of
times at equal accuracy. Written: ``docs/networks/peer_hb.json``, ``.csv`` and ``.png``.

Run: ``python benchmarks/peer_hb.py [--hmax 63] [--forced jenkins_forced]`` (about 8 minutes on 2
busy cores, most of it at high H). pyHarm (``pip install pyharm-os``, or the ``peers`` extra) is optional: without it its
columns are skipped with a message.
"""

from __future__ import annotations

import argparse
import csv
import json
import logging
import os
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from threadpoolctl import threadpool_limits

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from hb_jenkins import HarmonicBalance, Jenkins, exact_backbone, single_harmonic_backbone  # noqa: E402

OUT = HERE.parent / "docs" / "networks" / "peer_hb"
TARGET = 1e-6
BACKBONE = Jenkins(m=1.0, k=1.0, kt=1.0, Fs=1.0)
AMPLITUDES = np.geomspace(1.01, 50.0, 10) * BACKBONE.slip_amplitude


def load() -> float:
    return round(os.getloadavg()[0], 2)


def samples(H: int) -> int:
    """Time samples per period at H (both harmonic-balance codes)."""
    return max(1024, 256 * (H + 1))


# --------------------------------------------------------------------------------------------------
# forced cases, by name


@dataclass
class ForcedCase:
    """A forced response compared point by point: its exact reference and its harmonic balances.

    ``reference(omegas) -> (amplitudes, seconds cold, seconds warm)`` is this library's exact result
    (each orbit from the default guess; from the previous frequency's orbit); ``osc`` the
    parameters both harmonic-balance codes take; ``pyharm(osc, H, N) -> input dict`` pyHarm's model.
    """

    title: str
    omegas: list[float]
    osc: Jenkins
    reference: Callable
    pyharm: Callable | None = None
    notes: list[str] = field(default_factory=list)


def library_forced(model_file: Path, params: dict) -> Callable:
    """Exact forced amplitudes (max x) from this library's periodic orbits, exact integrator."""

    def run(omegas):
        from hybrid import Exact, ShootingOptions, SolverOptions, load_system, periodic_orbit

        system = load_system(model_file)
        ix = system.variable_names.index("x")
        p = dict(system.preset("standard"), **params)
        options = SolverOptions(method=Exact())
        out = {}
        for how in ("cold", "warm"):
            amps, secs, prev = [], 0.0, None
            for W in omegas:
                p["Omega"] = W
                t = time.perf_counter()
                if how == "cold" or prev is None:  # the default guess: a transient from rest, then Newton
                    orbit = periodic_orbit(system, p, options=options)
                else:  # from the previous frequency's orbit, as a continuation would
                    orbit = periodic_orbit(
                        system,
                        p,
                        prev.x0,
                        prev.mode0,
                        t0=prev.t0,
                        options=options,
                        settings=ShootingOptions(transient_periods=0),
                    )
                secs += time.perf_counter() - t
                if not orbit.converged:
                    raise SystemExit(
                        f"the exact periodic orbit did not converge at Omega = {W}: {orbit.message}"
                    )
                prev = orbit
                # max x is reached where v = 0, where the sliding slider stops: a switch of the orbit
                stops = [abs(e.x_minus[ix]) for e in orbit.trajectory.events if ".stop" in e.guard]
                if not stops:
                    raise SystemExit(f"Omega = {W}: the orbit does not slip; pick a frequency where it does")
                amps.append(max(stops))
            out[how] = (np.array(amps), secs)
        if np.max(np.abs(out["warm"][0] / out["cold"][0] - 1.0)) > 1e-10:
            raise SystemExit(f"the warm-started orbits differ from the cold ones: {out}")
        return out["cold"][0], out["cold"][1], out["warm"][1]

    return run


def pyharm_jenkins_input(osc: Jenkins, H: int, N: int) -> dict:
    """pyHarm's model of the forced Jenkins oscillator (odd harmonics 1..H, N samples)."""
    one = np.array([[1.0]])
    return {
        "system": {"type": "Base", "nh": list(range(1, H + 1, 2)), "nti": N},
        "substructures": {
            "sub1": {"type": "substructure", "ndofs": 1, "matrix": {"M": osc.m * one, "K": osc.k * one}}
        },
        "connectors": {
            "jenkins": {
                "type": "Jenkins",
                "connect": {"sub1": [0]},
                "dirs": [0],
                "mu": osc.Fs,
                "N0": 1.0,
                "k": osc.kt,
            },
            "damper": {"type": "LinearDamper", "connect": {"sub1": [0]}, "dirs": [0], "k": osc.c},
            "force": {"type": "CosinusForcing", "connect": {"sub1": [0]}, "dirs": [0], "amp": osc.F},
        },
        "analysis": {
            "frf": {
                "study": "frf",
                "puls_inf": 0.5,
                "puls_sup": 2.0,
                "verbose": False,
                "solver": "NewtonRaphson",
                "solver_options": {"tol_residual": 1e-11, "tol_delta_x": 1e-12, "max_iter": 60},
            }
        },
    }


FORCED = {
    "jenkins_forced": ForcedCase(
        title="forced Jenkins oscillator (m = k = kt = Fs = 1, c = 0.05, F = 1)",
        omegas=[1.1, 1.2, 1.3, 1.4, 1.5, 1.7],
        osc=Jenkins(m=1.0, k=1.0, kt=1.0, Fs=1.0, c=0.05, F=1.0),
        reference=library_forced(HERE / "data" / "jenkins_forced.toml", {}),
        pyharm=pyharm_jenkins_input,
    ),
}


# --------------------------------------------------------------------------------------------------
# the methods


def library_backbone(amplitudes) -> dict | None:
    """``hybrid.backbone`` on the same oscillator (issue 31): the EPMC system of
    ``models/jenkins_oscillator.toml`` (``hybrid_models.epmc_system``) with this benchmark's
    parameters, on the exact integrator; None where the library has no backbone."""
    import hybrid

    if not hasattr(hybrid, "backbone"):
        return None
    import hybrid_models

    system = hybrid_models.epmc_system(Path(hybrid_models.__file__).parent / "jenkins_oscillator.toml")
    p = {"m": BACKBONE.m, "k": BACKBONE.k, "kt": BACKBONE.kt, "Fs": BACKBONE.Fs}
    options = hybrid.SolverOptions(method=hybrid.Exact())
    t = time.perf_counter()
    try:
        result = hybrid.backbone(system, p, coordinate="x", amplitudes=list(amplitudes), options=options)
    except (TypeError, hybrid.HybridError) as exc:
        print(f"  hybrid.backbone failed ({type(exc).__name__}: {exc}); adapt library_backbone")
        return None
    secs = time.perf_counter() - t
    pts = result.points if hasattr(result, "points") else result["points"]
    get = (lambda q, k: getattr(q, k)) if not isinstance(pts[0], dict) else (lambda q, k: q[k])
    return {
        "amplitude": np.array([get(q, "amplitude") for q in pts]),
        "omega": np.array([get(q, "omega") for q in pts]),
        "damping_ratio": np.array([get(q, "damping_ratio") for q in pts]),
        "seconds": secs,
    }


def aft_backbone(H: int, amplitudes, guesses: list | None):
    hb = HarmonicBalance(BACKBONE, H, samples(H))
    out, new = [], []
    t = time.perf_counter()
    for i, a in enumerate(amplitudes):
        g = None if guesses is None else (hb.pad(guesses[i][0]), guesses[i][1], guesses[i][2])
        p = hb.backbone_point(a, g)
        out.append((p["omega"], p["damping_ratio"]))
        new.append((p["X"], p["omega"], p["xi"]))
    secs = time.perf_counter() - t
    return np.array(out), secs, new


def aft_forced(case: ForcedCase, H: int, guesses: list | None):
    hb = HarmonicBalance(case.osc, H, samples(H))
    new, secs = [], 0.0
    for i, W in enumerate(case.omegas):
        g = hb.pad(guesses[i]) if guesses is not None else single_harmonic_forced_guess(case.osc, W, hb)
        t = time.perf_counter()
        new.append(hb.forced_point(W, g, amplitude=False)["X"])
        secs += time.perf_counter() - t
    return np.array([hb.max_of(X) for X in new]), secs, new  # max x outside the timing, as for pyHarm


def single_harmonic_forced_guess(osc: Jenkins, W: float, hb: HarmonicBalance) -> np.ndarray:
    """A start for H = 1: the describing-function amplitude on a grid, its best balance."""
    from hb_jenkins import describing_function

    a = np.geomspace(1.001 * osc.slip_amplitude, 100 * osc.slip_amplitude, 4000)
    K, C = describing_function(a, osc.kt, osc.Fs)
    mis = np.abs(np.hypot(osc.k + K - osc.m * W * W, osc.c * W + C) * a - osc.F)
    i = int(np.argmin(mis))
    z = osc.F / complex(osc.k + K[i] - osc.m * W * W, osc.c * W + C[i])  # x = Re(z e^{i W t})
    X = np.zeros(2 * len(hb.h))
    X[0], X[1] = z.real, -z.imag
    return X


def pyharm_available() -> str | None:
    try:
        import pyHarm  # noqa: F401
        from pyHarm.Maestro import Maestro  # noqa: F401
    except Exception as exc:  # ImportError or a broken install
        return f"pyHarm is not usable here ({type(exc).__name__}: {exc}); `pip install pyharm-os` to compare"
    return None


def pyharm_forced(case: ForcedCase, H: int, guesses: list | None):
    from pyHarm.Maestro import Maestro

    N = samples(H)
    logging.disable(logging.WARNING)
    try:
        maestro = Maestro(case.pyharm(case.osc, H, N))
        frf = maestro.nls["frf"]
        amps, new, secs = [], [], 0.0
        hb = HarmonicBalance(case.osc, H, N)  # for max x of the result and the guess only
        for i, W in enumerate(case.omegas):
            g = hb.pad(guesses[i]) if guesses is not None else single_harmonic_forced_guess(case.osc, W, hb)
            frf.analysis_options["puls_start"] = W
            frf.SolList = []
            t = time.perf_counter()
            frf.initialise(x0=g.copy())
            secs += time.perf_counter() - t
            sol = frf.SolList[0]
            res = float(np.max(np.abs(maestro.system.Residual(sol.x))))
            if sol.status_solver != 1 or res > 1e-9:
                raise RuntimeError(
                    f"pyHarm H={H}, Omega={W}: no convergence (status {sol.status_solver}, residual {res:.1e})"
                )
            X = np.asarray(sol.x[:-1])
            amps.append(hb.max_of(X))
            new.append(X)
    finally:
        logging.disable(logging.NOTSET)
    return np.array(amps), secs, new


def pyharm_backbone(H: int, amplitudes, guesses: list | None):
    """EPMC with pyHarm's harmonic balance: its residual and Jacobian of the Jenkins oscillator with a
    ``LinearDamper`` of coefficient ``-xi m`` (no forcing), closed here by the amplitude and phase
    conditions of :meth:`HarmonicBalance.backbone_point` (pyHarm has no EPMC), Newton on (X, omega,
    xi) as there."""
    from pyHarm.Maestro import Maestro

    osc = BACKBONE
    N = samples(H)
    one = np.array([[1.0]])
    inp = {
        "system": {"type": "Base", "nh": list(range(1, H + 1, 2)), "nti": N},
        "substructures": {
            "sub1": {"type": "substructure", "ndofs": 1, "matrix": {"M": osc.m * one, "K": osc.k * one}}
        },
        "connectors": {
            "jenkins": {
                "type": "Jenkins",
                "connect": {"sub1": [0]},
                "dirs": [0],
                "mu": osc.Fs,
                "N0": 1.0,
                "k": osc.kt,
            },
            "xi": {"type": "LinearDamper", "connect": {"sub1": [0]}, "dirs": [0], "k": 0.0},
        },
    }
    logging.disable(logging.WARNING)
    try:
        system = Maestro(inp).system
    finally:
        logging.disable(logging.NOTSET)
    damper = next(e for e in system.LE if type(e).__name__ == "LinearDamper")
    hb = HarmonicBalance(osc, H, N)  # its matrices only (the derivative operator), for the closure
    nX = 2 * len(hb.h)
    amp_row = np.zeros(nX)
    amp_row[0::2] = 1.0
    phase_row = np.zeros(nX)
    phase_row[1::2] = hb.h
    out, new = [], []
    t = time.perf_counter()
    for i, a in enumerate(amplitudes):
        if guesses is None:
            g = single_harmonic_backbone([a], osc)
            z = np.zeros(nX + 2)
            z[0], z[nX], z[nX + 1] = a, g["omega"][0], g["xi"][0]
        else:
            z = np.concatenate([hb.pad(guesses[i][0]), guesses[i][1:]])
        for _ in range(50):
            X, omega, xi = z[:nX], z[nX], z[nX + 1]
            damper.k = -xi * osc.m
            q = np.concatenate([X, [omega]])
            R = system.Residual(q)
            Jx, Jom = system.Jacobian(q)
            r = np.concatenate([R, [amp_row @ X - a, phase_row @ X]])
            J = np.zeros((nX + 2, nX + 2))
            J[:nX, :nX], J[:nX, nX] = Jx, np.ravel(Jom)
            J[:nX, nX + 1] = -osc.m * omega * (hb.D1 @ X)
            J[nX, :nX], J[nX + 1, :nX] = amp_row, phase_row
            dz = np.linalg.solve(J, -r)
            z = z + dz
            if np.max(np.abs(dz)) <= 1e-12 * max(1.0, np.max(np.abs(z))):
                break
        else:
            raise RuntimeError(f"pyHarm EPMC H={H}, a={a}: Newton did not converge")
        out.append((z[nX], z[nX + 1] / (2 * z[nX])))
        new.append((z[:nX], z[nX], z[nX + 1]))
    secs = time.perf_counter() - t
    return np.array(out), secs, new


# --------------------------------------------------------------------------------------------------
# the study


def rel(x, ref) -> float:
    return float(np.max(np.abs(np.asarray(x) / np.asarray(ref) - 1.0)))


def first_below(rows: list[dict], key: str) -> dict:
    """The first H whose error ``key`` is below TARGET, else the best; its time."""
    rows = [r for r in rows if r.get(key) is not None]
    if not rows:
        return {}
    hit = next((r for r in rows if r[key] <= TARGET), None)
    best = hit or min(rows, key=lambda r: r[key])
    return {"H": best["H"], "error": best[key], "reached": hit is not None}


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--hmax", type=int, default=63, help="highest H (odd); H = 1, 3, ..., hmax")
    ap.add_argument("--forced", nargs="*", default=list(FORCED), help=f"forced cases by name: {list(FORCED)}")
    ap.add_argument("--no-plot", action="store_true")
    ap.add_argument("--out", default=str(OUT), help="path prefix of the .json, .csv and .png written")
    args = ap.parse_args(argv)
    unknown = [n for n in args.forced if n not in FORCED]
    if unknown:
        raise SystemExit(f"peer_hb: unknown forced case(s) {unknown}; known: {list(FORCED)}")
    if args.hmax < 1 or args.hmax % 2 == 0:
        raise SystemExit(f"peer_hb: --hmax must be odd and positive, got {args.hmax}")
    Hs = list(range(1, args.hmax + 1, 2))
    why_no_pyharm = pyharm_available()
    if why_no_pyharm:
        print(f"pyHarm skipped: {why_no_pyharm}")
    result = {"load_1min_start": load(), "target": TARGET, "H": Hs}
    if why_no_pyharm is None:
        from importlib.metadata import version

        result["pyharm_version"] = version("pyharm-os")

    with threadpool_limits(1):
        # ---- backbone
        t = time.perf_counter()
        ex = exact_backbone(AMPLITUDES, BACKBONE)
        t_exact = time.perf_counter() - t
        sh = single_harmonic_backbone(AMPLITUDES, BACKBONE)
        print(
            f"EPMC backbone of the Jenkins oscillator at {len(AMPLITUDES)} amplitudes from "
            f"{AMPLITUDES[0]:.3g} to {AMPLITUDES[-1]:.3g} m: exact (half-period shooting) in {t_exact * 1e3:.1f} ms"
        )
        print(
            f"  single-harmonic (approximate): omega error {rel(sh['omega'], ex['omega']):.2e}, "
            f"D error {rel(sh['damping_ratio'], ex['damping_ratio']):.2e}"
        )
        bb = {
            "amplitudes": AMPLITUDES.tolist(),
            "exact": {k: ex[k].tolist() for k in ("omega", "xi", "damping_ratio")},
            "exact_seconds": t_exact,
            "rows": [],
        }
        lib = library_backbone(AMPLITUDES)
        if lib is None:
            print("  hybrid.backbone: not in this library yet (issue 31, item 1): not compared")
        else:
            d_om, d_D = rel(lib["omega"], ex["omega"]), rel(lib["damping_ratio"], ex["damping_ratio"])
            print(f"  hybrid.backbone against it: omega {d_om:.2e}, D {d_D:.2e} ({lib['seconds']:.3f} s)")
            bb["library"] = {"omega_error": d_om, "damping_error": d_D, "seconds": lib["seconds"]}
            if len(lib["omega"]) != len(AMPLITUDES):
                print(f"  hybrid.backbone returned {len(lib['omega'])} of {len(AMPLITUDES)} points")
        guesses = g_ph = None
        ph_ok = why_no_pyharm is None
        if ph_ok:  # compile pyHarm's numba kernels (cached on disk) outside the timings
            pyharm_backbone(1, AMPLITUDES[:1], None)
        for H in Hs:
            vals, secs, guesses = aft_backbone(H, AMPLITUDES, guesses)
            row = {
                "H": H,
                "N": samples(H),
                "aft_omega": rel(vals[:, 0], ex["omega"]),
                "aft_damping": rel(vals[:, 1], ex["damping_ratio"]),
                "aft_s": secs,
            }
            if ph_ok:
                try:
                    v_ph, s_ph, g_ph = pyharm_backbone(H, AMPLITUDES, g_ph)
                    row.update(
                        pyharm_omega=rel(v_ph[:, 0], ex["omega"]),
                        pyharm_damping=rel(v_ph[:, 1], ex["damping_ratio"]),
                        pyharm_s=s_ph,
                        aft_vs_pyharm=max(rel(v_ph[:, 0], vals[:, 0]), rel(v_ph[:, 1], vals[:, 1])),
                    )
                except RuntimeError as exc:
                    print(f"  pyHarm stopped at H = {H}: {exc}")
                    ph_ok = False
            bb["rows"].append(row)
        result["backbone"] = bb

        # ---- forced responses
        result["forced"] = {}
        for name in args.forced:
            case = FORCED[name]
            amps_ex, t_ref, t_warm = case.reference(case.omegas)
            print(
                f"\n{name}: {case.title}; exact amplitudes at Omega = {case.omegas}: "
                f"{np.round(amps_ex, 9).tolist()} in {t_ref:.3f} s cold, {t_warm:.3f} s warm-started "
                "(this library, exact integrator)"
            )
            fr = {
                "omegas": case.omegas,
                "exact": amps_ex.tolist(),
                "exact_seconds_cold": t_ref,
                "exact_seconds": t_warm,
                "rows": [],
            }
            g_aft = g_ph = None
            ph_ok = why_no_pyharm is None and case.pyharm is not None
            if ph_ok:  # compile pyHarm's numba kernels (cached on disk) outside the timings
                pyharm_forced(case, 1, None)
            for H in Hs:
                a_aft, s_aft, g_aft = aft_forced(case, H, g_aft)
                row = {"H": H, "N": samples(H), "aft_amplitude": rel(a_aft, amps_ex), "aft_s": s_aft}
                if ph_ok:
                    try:
                        a_ph, s_ph, g_ph = pyharm_forced(case, H, g_ph)
                        row.update(
                            pyharm_amplitude=rel(a_ph, amps_ex), pyharm_s=s_ph, aft_vs_pyharm=rel(a_ph, a_aft)
                        )
                    except RuntimeError as exc:
                        print(f"  pyHarm stopped at H = {H}: {exc}")
                        ph_ok = False
                fr["rows"].append(row)
            result["forced"][name] = fr
    result["load_1min_end"] = load()
    summarize(result)
    write(result, Path(args.out), plot=not args.no_plot)
    return result


def summarize(result: dict) -> None:
    bb = result["backbone"]
    print("\nBackbone (EPMC): largest relative error over the amplitudes; time of the 10 points")
    ph = any("pyharm_omega" in r for r in bb["rows"])
    head = f"{'H':>5} {'N':>6} | {'aft omega':>9} {'aft D':>9} {'time s':>8}"
    print(head + (f" | {'pyH omega':>9} {'pyH D':>9} {'time s':>8} {'pyH-aft':>8}" if ph else ""))
    for r in bb["rows"]:
        line = f"{r['H']:>5} {r['N']:>6} | {r['aft_omega']:9.2e} {r['aft_damping']:9.2e} {r['aft_s']:8.3f}"
        if "pyharm_omega" in r:
            line += f" | {r['pyharm_omega']:9.2e} {r['pyharm_damping']:9.2e} {r['pyharm_s']:8.3f} {r['aft_vs_pyharm']:8.1e}"
        print(line)
    summary = {}
    for key in ("aft_omega", "aft_damping", "pyharm_omega", "pyharm_damping"):
        s = first_below(bb["rows"], key)
        if not s:
            continue
        r = next(r for r in bb["rows"] if r["H"] == s["H"])
        s["seconds"] = r[key.split("_")[0] + "_s"]
        s["ratio_to_exact"] = s["seconds"] / bb["exact_seconds"]
        summary[key] = s
    bb["summary"] = summary
    for key, s in summary.items():
        word = "reaches 1e-6 at" if s["reached"] else "best at"
        print(
            f"  {key}: {word} H = {s['H']} (error {s['error']:.1e}), {s['seconds']:.3f} s = "
            f"{s['ratio_to_exact']:.3g} x the exact shooting ({bb['exact_seconds'] * 1e3:.1f} ms)"
            + (
                f", {s['seconds'] / bb['library']['seconds']:.3g} x hybrid.backbone "
                f"({bb['library']['seconds']:.3f} s)"
                if "library" in bb
                else ""
            )
        )
        if "library" in bb:
            s["ratio_to_library"] = s["seconds"] / bb["library"]["seconds"]
    for name, fr in result["forced"].items():
        ph = any("pyharm_amplitude" in r for r in fr["rows"])
        print(
            f"\nForced response {name}: largest relative error of max x over the {len(fr['omegas'])} frequencies"
        )
        head = f"{'H':>5} {'N':>6} | {'aft':>9} {'time s':>8}"
        print(head + (f" | {'pyHarm':>9} {'time s':>8} {'pyH-aft':>9}" if ph else ""))
        for r in fr["rows"]:
            line = f"{r['H']:>5} {r['N']:>6} | {r['aft_amplitude']:9.2e} {r['aft_s']:8.3f}"
            if "pyharm_amplitude" in r:
                line += f" | {r['pyharm_amplitude']:9.2e} {r['pyharm_s']:8.3f} {r['aft_vs_pyharm']:9.1e}"
            print(line)
        fr["summary"] = {}
        for key, tkey in (("aft_amplitude", "aft_s"), ("pyharm_amplitude", "pyharm_s")):
            s = first_below(fr["rows"], key)
            if not s:
                continue
            r = next(r for r in fr["rows"] if r["H"] == s["H"])
            s["seconds"] = r[tkey]
            s["ratio_to_exact"] = r[tkey] / fr["exact_seconds"]
            fr["summary"][key] = s
            word = "reaches 1e-6 at" if s["reached"] else "best at"
            print(
                f"  {key}: {word} H = {s['H']} (error {s['error']:.1e}), {s['seconds']:.3f} s = "
                f"{s['ratio_to_exact']:.3g} x the exact orbits ({fr['exact_seconds']:.3f} s, warm-started)"
            )


def write(result: dict, out: Path, plot: bool) -> None:
    out.parent.mkdir(parents=True, exist_ok=True)
    out.with_suffix(".json").write_text(json.dumps(result, indent=1) + "\n")
    columns = [("backbone", m, q) for m in ("aft", "pyharm") for q in ("omega", "damping")]
    columns += [(name, m, "amplitude") for name in result["forced"] for m in ("aft", "pyharm")]
    with out.with_suffix(".csv").open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["problem", "method", "H", "N", "quantity", "relative_error", "seconds"])
        for problem, method, quantity in columns:
            rows = result["backbone"]["rows"] if problem == "backbone" else result["forced"][problem]["rows"]
            for r in rows:
                if f"{method}_{quantity}" in r:
                    err, secs = r[f"{method}_{quantity}"], r[f"{method}_s"]
                    w.writerow([problem, method, r["H"], r["N"], quantity, f"{err:.6e}", f"{secs:.6f}"])
    print(f"\nwrote {out.with_suffix('.json')} and .csv")
    if plot:
        figure(result, out)


def figure(result: dict, out: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(11, 4.2))
    bb = result["backbone"]
    H = [r["H"] for r in bb["rows"]]
    ax1.loglog(H, [r["aft_omega"] for r in bb["rows"]], "o-", label="backbone omega(a), AFT")
    ax1.loglog(H, [r["aft_damping"] for r in bb["rows"]], "s-", label="backbone D(a), AFT")
    ax2.semilogy(H, [r["aft_s"] for r in bb["rows"]], "s-", label="backbone, AFT (10 points)")
    ph = [r for r in bb["rows"] if "pyharm_omega" in r]
    if ph:
        ax1.loglog(
            [r["H"] for r in ph],
            [r["pyharm_damping"] for r in ph],
            "+--",
            label="backbone D(a), pyHarm (+ EPMC closure)",
        )
        ax2.semilogy(
            [r["H"] for r in ph],
            [r["pyharm_s"] for r in ph],
            "+--",
            label="backbone, pyHarm (+ EPMC closure)",
        )
    ax2.axhline(bb["exact_seconds"], color="k", ls=":", label="backbone, exact shooting")
    for name, fr in result["forced"].items():
        rows = fr["rows"]
        H = [r["H"] for r in rows]
        ax1.loglog(H, [r["aft_amplitude"] for r in rows], "^-", label=f"{name} max x, AFT")
        ax2.semilogy(H, [r["aft_s"] for r in rows], "^-", label=f"{name}, AFT ({len(fr['omegas'])} points)")
        ph = [r for r in rows if "pyharm_amplitude" in r]
        if ph:
            ax1.loglog(
                [r["H"] for r in ph],
                [r["pyharm_amplitude"] for r in ph],
                "x--",
                label=f"{name} max x, pyHarm",
            )
            ax2.semilogy([r["H"] for r in ph], [r["pyharm_s"] for r in ph], "x--", label=f"{name}, pyHarm")
        ax2.axhline(fr["exact_seconds"], color="C3", ls=":", label=f"{name}, this library (exact, warm)")
        ax2.axhline(
            fr["exact_seconds_cold"], color="C3", ls="--", lw=0.8, label=f"{name}, this library (exact, cold)"
        )
    ax1.axhline(TARGET, color="gray", lw=0.8)
    ax1.set_xlabel("highest harmonic H (odd harmonics 1..H)")
    ax1.set_ylabel("largest relative error against the exact result")
    ax1.set_title("Harmonic balance: error against H")
    ax1.legend(fontsize=7)
    ax2.set_xlabel("highest harmonic H")
    ax2.set_ylabel("wall time [s]")
    ax2.set_title("Time of the solves (one BLAS thread)")
    ax2.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(out.with_suffix(".png"), dpi=110)
    print(f"wrote {out.with_suffix('.png')}")


if __name__ == "__main__":
    main()
