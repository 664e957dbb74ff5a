"""This library's IDA path against peers on three non-smooth problems (issue 34, item 5).

Problems (each from rest; errors against a tight reference of the same problem):

* **belt**: the Stribeck belt (models/belt_stribeck.toml, preset `standard`), 500 s, 153 switches.
  Reference: the scipy loop with DOP853 at rtol 1e-13 (it agrees with Radau at 1e-8 and with this
  library's IDA at 1e-12 to 3e-9).
* **duffing**: a forced Duffing oscillator with Coulomb friction and stiction (the friction
  oscillator of models/friction_oscillator.toml with a cubic spring ``k3 x^3``), 50 forcing
  periods. Reference: the scipy loop with DOP853 at rtol 1e-13.
* **chain**: the forced Burridge-Knopoff chain of 20 blocks (models/bk_chain.toml), 50 s.
  Reference: the exact-flow Taylor backend of benchmarks/reference_chain.py (order 24).

Methods:

* ``hybrid IDA``: :func:`hybrid.simulate` with ``IDA(rtol, atol=rtol/100)``, only the end of the run
  sampled (``t_eval=[t_end]``); its internal steps are counted in a second, one-step run (the same
  steps). On the chain also ``hybrid Exact`` (the exact integrator).
* ``scipy LSODA | Radau | DOP853``: hand-written loops of ``scipy.integrate.solve_ivp``, one call
  per smooth phase with terminal events (the belt's stick phases in closed form; the chain's is
  benchmarks/reference_chain.py's ``run_ivp``), the step bounded as this library's is (a sixteenth
  of the forcing period) on the forced problems.
* ``raw scikit-sundae`` (belt only): benchmarks/belt_loops.py's loop over scikit-sundae's IDA.
* ``heyoka``: Taylor integrator compiled through LLVM with exact event location (belt and duffing;
  the package heyoka from PyPI, not a requirement of this project: skipped where it is not
  installed), one integrator per mode.

Each method runs at rtol 1e-6, 1e-8 and 1e-10 (atol = rtol/100; heyoka: tol = rtol); for each
the table gives wall time (best of ``REPEAT``), steps, the largest error of the final state
(displacements and velocities) and of the switch times (``-`` where the run switched a different
number of times). The last lines name, per problem, the fastest setting of each method at equal or
better accuracy than this library's IDA at rtol 1e-8, and the ratio of times.

Run: ``python benchmarks/peer_ivp.py`` (a few minutes on 2 cores); ``--quick`` for rtol 1e-8 only.
"""

from __future__ import annotations

import math
import os
import sys
import time
import tomllib
from pathlib import Path

import numpy as np
import reference_chain as rc
from belt_loops import scipy_loop as belt_scipy
from belt_loops import sundae_loop as belt_sundae

import hybrid_models
from hybrid import IDA, Exact, SolverOptions, simulate, system_from_dict

REPEAT = 2
RTOLS = (1e-6, 1e-8, 1e-10)
SCIPY = ("LSODA", "Radau", "DOP853")

# ----------------------------------------------------------------------------- problems

BELT_T = 500.0

#: Duffing oscillator with Coulomb friction: the friction oscillator with a cubic spring.
DUFFING = {"m": 1.0, "k": 1.0, "k3": 0.5, "c": 0.05, "Rs": 0.3, "Rk": 0.25, "F": 1.0, "Omega": 0.8}
DUFFING_PERIODS = 50
CHAIN_N = 20
CHAIN_T = 50.0


def duffing_system():
    """The friction oscillator of models/friction_oscillator.toml with a cubic spring term."""
    path = Path(hybrid_models.__file__).parent / "friction_oscillator.toml"
    data = tomllib.loads(path.read_text())
    data["model"]["name"] = "duffing_coulomb"
    data["parameters"]["k3"] = {"unit": "N/m^3", "description": "cubic stiffness", "domain": "nonnegative"}
    data["presets"] = {"standard": dict(DUFFING)}
    data["definitions"]["H"] = "k*x + k3*x**3 - force"
    data["definitions"]["E"] = "0.5*m*v**2 + 0.5*k*x**2 + 0.25*k3*x**4"
    data["equations"]["v"] = "(force - k*x - k3*x**3 - c*v + friction)/m"
    return system_from_dict(data)


def duffing_scipy(t1: float, method: str, rtol: float, atol: float, p=DUFFING):
    """Duffing + Coulomb from rest in stick by ``solve_ivp`` loops: stick (x, v frozen) to a
    breakaway ``H = +-Rs``, slip to the stop ``v = 0``; the successor from ``H`` (|H| < Rs: stick)."""
    from scipy.integrate import solve_ivp

    m, k, k3, c, Rs, Rk, F, Om = (p[n] for n in ("m", "k", "k3", "c", "Rs", "Rk", "F", "Omega"))
    hmax = 2 * math.pi / Om / 16.0

    def H(t, x):
        return k * x + k3 * x**3 - F * math.sin(Om * t)

    def successor(t, x):
        h = H(t, x)
        if abs(h) < Rs:
            return 0
        return 1 if h < 0 else -1  # slip+ where the net force pushes forward

    t, x, v, steps, switches = 0.0, 0.0, 0.0, 0, []
    mode = successor(t, x)
    while t < t1:
        if mode == 0:

            def rhs(_t, y):
                return [0.0, 0.0]

            def up(tt, y):
                return H(tt, y[0]) - Rs

            def down(tt, y):
                return H(tt, y[0]) + Rs

            up.terminal, up.direction = True, 1
            down.terminal, down.direction = True, -1
            evs = [up, down]
        else:
            s = mode

            def rhs(tt, y, s=s):
                return [y[1], (F * math.sin(Om * tt) - k * y[0] - k3 * y[0] ** 3 - c * y[1] - s * Rk) / m]

            def stop(_t, y):
                return y[1]

            stop.terminal, stop.direction = True, -s
            evs = [stop]
        sol = solve_ivp(rhs, (t, t1), [x, v], method=method, rtol=rtol, atol=atol, events=evs, max_step=hmax)
        steps += sol.t.size - 1
        if sol.status != 1:
            t, x, v = float(sol.t[-1]), float(sol.y[0, -1]), float(sol.y[1, -1])
            break
        j = next(i for i, te in enumerate(sol.t_events) if te.size)
        t, x = float(sol.t_events[j][0]), float(sol.y_events[j][0][0])
        v = 0.0
        switches.append(t)
        if mode == 0:
            mode = -1 if j == 0 else 1
        else:
            mode = successor(t, x)
    return np.array([x, v]), steps, np.array(switches)


def _heyoka_phase(ta, t1):
    """Propagate ``ta`` to ``t1`` or its first terminal event after its start (heyoka reports a
    root at the start of a phase, where the guard is zero, with no step taken: go on)."""
    t_start, steps = ta.time, 0
    while True:
        r = ta.propagate_until(t1)
        steps += int(r[3])
        code = int(r[0].value) if hasattr(r[0], "value") else int(r[0])
        if code < 0 and code > -100 and ta.time == t_start:
            continue  # the guard at zero where the phase starts
        return code, steps


def belt_heyoka(t1: float, tol: float):
    """The belt by heyoka: one integrator per slip direction, stick phases in closed form."""
    import heyoka as hy
    from belt_loops import P, stick_exit

    x, w = hy.make_vars("x", "w")
    m, k, c, vb, Fs, Fk, vs = (P[n] for n in ("m", "k", "c", "v_b", "Fs", "Fk", "vs"))
    tas = {}
    for s in (-1, 1):
        fr = Fk + (Fs - Fk) * hy.exp(w / vs) if s < 0 else -(Fk + (Fs - Fk) * hy.exp(-w / vs))
        ev = hy.t_event(
            w,
            direction=hy.event_direction.positive if s < 0 else hy.event_direction.negative,
            cooldown=1e-9,
        )
        tas[s] = hy.taylor_adaptive(
            [(x, w + vb), (w, (fr - k * x - c * (w + vb)) / m)], [0.0, 0.0], tol=tol, t_events=[ev]
        )
    t, xx, ww, mode, steps, switches = 0.0, 0.0, 0.0, 0, 0, []
    while t < t1:
        if mode == 0:
            tb, xb, s = stick_exit(t, xx)
            if tb >= t1:
                xx, t = xx + vb * (t1 - t), t1
                break
            t, xx, ww, mode = tb, xb, 0.0, s
            switches.append(t)
            continue
        ta = tas[mode]
        ta.time, ta.state[:] = t, [xx, ww]
        code, n = _heyoka_phase(ta, t1)
        steps += n
        t, (xx, ww) = float(ta.time), (float(ta.state[0]), float(ta.state[1]))
        if code == -1:  # the stop
            ww, mode = 0.0, 0
            switches.append(t)
        elif t < t1:
            raise RuntimeError(f"heyoka stopped at t={t}: outcome {code}")
    return np.array([xx, ww]), steps, np.array(switches)


def duffing_heyoka(t1: float, tol: float, p=DUFFING):
    """Duffing + Coulomb by heyoka: the forcing as a state (sin, cos of Omega t), one integrator
    per mode (stick: breakaway events on H = +-Rs; slip: the stop v = 0)."""
    import heyoka as hy

    m, k, k3, c, Rs, Rk, F, Om = (p[n] for n in ("m", "k", "k3", "c", "Rs", "Rk", "F", "Omega"))
    x, v, sn, cs = hy.make_vars("x", "v", "sn", "cs")
    osc = [(sn, Om * cs), (cs, -Om * sn)]
    H = k * x + k3 * x * x * x - F * sn  # (x**3: heyoka's pow at x = 0 gives no usable series)
    pos, neg = hy.event_direction.positive, hy.event_direction.negative
    stick = hy.taylor_adaptive(
        [(x, 0.0 * v), (v, 0.0 * v), *osc],
        [0.0] * 4,
        tol=tol,
        t_events=[
            hy.t_event(H - Rs, direction=pos, cooldown=1e-9),
            hy.t_event(H + Rs, direction=neg, cooldown=1e-9),
        ],
    )
    slips = {
        s: hy.taylor_adaptive(
            [(x, v), (v, (F * sn - k * x - k3 * x * x * x - c * v - s * Rk) / m), *osc],
            [0.0] * 4,
            tol=tol,
            t_events=[hy.t_event(v, direction=neg if s > 0 else pos, cooldown=1e-9)],
        )
        for s in (-1, 1)
    }

    def successor(t, xx):
        h = k * xx + k3 * xx**3 - F * math.sin(Om * t)
        return 0 if abs(h) < Rs else (1 if h < 0 else -1)

    t, xx, vv, steps, switches = 0.0, 0.0, 0.0, 0, []
    mode = successor(t, xx)
    while t < t1:
        ta = stick if mode == 0 else slips[mode]
        ta.time, ta.state[:] = t, [xx, vv, math.sin(Om * t), math.cos(Om * t)]
        code, n = _heyoka_phase(ta, t1)
        steps += n
        t, xx, vv = float(ta.time), float(ta.state[0]), float(ta.state[1])
        if code >= 0 or t >= t1:
            break
        switches.append(t)
        vv = 0.0
        mode = (-1 if code == -1 else 1) if mode == 0 else successor(t, xx)
    return np.array([xx, vv]), steps, np.array(switches)


# ----------------------------------------------------------------------------- this library


def hybrid_run(system, params, t1, x0, names, method):
    """``(final state over names, steps, switch times)`` of :func:`hybrid.simulate` (timed: the run
    sampled at its end only); the steps from a one-step twin run."""
    opts = SolverOptions(method=method)
    tr = simulate(system, params, (0.0, t1), x0, t_eval=[t1], options=opts)
    y = np.array([tr.final(n) for n in names])
    return y, tr, np.array([e.t for e in tr.events if not e.chained])


def count_steps(system, params, t1, x0, method) -> int:
    if isinstance(method, Exact):
        return -1  # (its steps are the flow's, not comparable)
    return simulate(system, params, (0.0, t1), x0, options=SolverOptions(method=method)).n_steps


# ----------------------------------------------------------------------------- table


def best(fn):
    t_best, out = math.inf, None
    for _ in range(REPEAT):
        t0 = time.perf_counter()
        out = fn()
        t_best = min(t_best, time.perf_counter() - t0)
    return t_best, out


def error(y, sw, ref_y, ref_sw):
    ey = float(np.max(np.abs(np.asarray(y) - ref_y)))
    es = float(np.max(np.abs(sw - ref_sw))) if len(sw) == len(ref_sw) and len(sw) else math.nan
    return ey, es


def report(problem: str, rows: list[dict]) -> list[str]:
    print(f"\n{problem}: load average {os.getloadavg()[0]:.2f} (2 cores)")
    print(
        f"{'method':22s} {'rtol':>7s} {'time [s]':>9s} {'steps':>8s} {'state err':>10s} {'switch err':>10s}"
    )
    for r in rows:
        es = "-" if math.isnan(r["es"]) else f"{r['es']:.2e}"
        print(
            f"{r['method']:22s} {r['rtol']:7.0e} {r['time']:9.3f} {r['steps']:8d} {r['ey']:10.2e} {es:>10s}"
        )
    base = next((r for r in rows if r["method"] == "hybrid IDA" and r["rtol"] == 1e-8), None)
    lines = []
    if base is None:
        return lines
    for name in dict.fromkeys(r["method"] for r in rows):
        if name == "hybrid IDA":
            continue
        # equal accuracy: a final-state error at most 5 % above the library's
        ok = [
            r
            for r in rows
            if r["method"] == name and r["ey"] <= 1.05 * base["ey"] and not math.isnan(r["es"])
        ]
        if not ok:
            lines.append(f"{problem}: {name}: no setting as accurate as hybrid IDA at rtol 1e-8")
            continue
        f = min(ok, key=lambda r: r["time"])
        lines.append(
            f"{problem}: {name} at rtol {f['rtol']:.0e} ({f['ey']:.1e}) takes {f['time']:.3f} s; hybrid IDA at 1e-8 "
            f"({base['ey']:.1e}) {base['time']:.3f} s: hybrid "
            + (
                f"{f['time'] / base['time']:.2f}x faster"
                if f["time"] > base["time"]
                else f"{base['time'] / f['time']:.2f}x slower"
            )
        )
    return lines


def have_heyoka() -> bool:
    try:
        import heyoka  # noqa: F401
    except ImportError:
        print("heyoka is not installed: its rows are skipped")
        return False
    return True


def run_belt(rtols, heyoka: bool) -> list[str]:
    system = hybrid_models.belt_stribeck()
    p = system.preset("standard")
    x0 = {"x": 0.0, "w": 0.0}
    ref_y, _, ref_sw, _ = belt_scipy(BELT_T, "DOP853", 1e-13, 1e-15)
    rows = []

    def add(method, rtol, fn, steps=None):
        t, out = best(fn)
        y, st, sw = out
        ey, es = error(y, sw, ref_y, ref_sw)
        rows.append(
            dict(method=method, rtol=rtol, time=t, steps=st if steps is None else steps, ey=ey, es=es)
        )

    for rtol in rtols:
        m = IDA(rtol=rtol, atol=rtol / 100)
        add(
            "hybrid IDA",
            rtol,
            lambda m=m: (lambda o: (o[0], -1, o[2]))(hybrid_run(system, p, BELT_T, x0, ["x", "w"], m)),
            steps=count_steps(system, p, BELT_T, x0, m),
        )
        for meth in SCIPY:
            add(f"scipy {meth}", rtol, lambda r=rtol, me=meth: _drop(belt_scipy(BELT_T, me, r, r / 100)))
        add("raw scikit-sundae", rtol, lambda r=rtol: _drop(belt_sundae(BELT_T, r, r / 100)))
        if heyoka:
            add("heyoka", rtol, lambda r=rtol: belt_heyoka(BELT_T, r))
    return report("belt (Stribeck, 500 s)", rows)


def _drop(out):
    """``(y, steps, switches)`` of a belt loop's ``(y, steps, switches, mode)``."""
    return out[0], out[1], out[2]


def run_duffing(rtols, heyoka: bool) -> list[str]:
    system = duffing_system()
    p = system.preset("standard")
    t1 = DUFFING_PERIODS * 2 * math.pi / p["Omega"]
    x0 = dict.fromkeys(system.variable_names, 0.0)
    ref_y, _, ref_sw = duffing_scipy(t1, "DOP853", 1e-13, 1e-15)
    rows = []

    def add(method, rtol, fn, steps=None):
        t, (y, st, sw) = best(fn)
        ey, es = error(y, sw, ref_y, ref_sw)
        rows.append(
            dict(method=method, rtol=rtol, time=t, steps=st if steps is None else steps, ey=ey, es=es)
        )

    for rtol in rtols:
        m = IDA(rtol=rtol, atol=rtol / 100)
        add(
            "hybrid IDA",
            rtol,
            lambda m=m: (lambda o: (o[0], -1, o[2]))(hybrid_run(system, p, t1, x0, ["x", "v"], m)),
            steps=count_steps(system, p, t1, x0, m),
        )
        for meth in SCIPY:
            add(f"scipy {meth}", rtol, lambda r=rtol, me=meth: duffing_scipy(t1, me, r, r / 100))
        if heyoka:
            add("heyoka", rtol, lambda r=rtol: duffing_heyoka(t1, r))
    return report(f"duffing + Coulomb ({DUFFING_PERIODS} periods)", rows)


def run_chain(rtols) -> list[str]:
    data = tomllib.loads((Path(hybrid_models.__file__).parent / "bk_chain.toml").read_text())
    data["cells"]["block"]["count"] = CHAIN_N
    system = system_from_dict(data)
    p = system.preset("standard")
    x0 = dict.fromkeys(system.variable_names, 0.0)
    names = [f"x_{i}" for i in range(1, CHAIN_N + 1)] + [f"v_{i}" for i in range(1, CHAIN_N + 1)]
    ch = rc.Chain(rc.default_params(CHAIN_N))
    ref = rc.run_taylor(ch, CHAIN_T)
    ref_y = np.concatenate([ref["x"], ref["v"]])
    ref_sw = np.array([s[0] for s in ref["switches"]])
    rows = []

    def add(method, rtol, fn, steps=None):
        t, (y, st, sw) = best(fn)
        ey, es = error(y, sw, ref_y, ref_sw)
        rows.append(
            dict(method=method, rtol=rtol, time=t, steps=st if steps is None else steps, ey=ey, es=es)
        )

    def ivp(method, rtol):
        # the step bounded as the library's (a sixteenth of the period): without it LSODA steps over
        # every breakaway of the chain at rest (three steps to t = 50, every block stuck)
        hmax = 2 * math.pi / ch.p["Omega"] / 16.0
        r = rc.run_ivp(ch, CHAIN_T, rtol=rtol, atol=rtol / 100, method=method, max_step=hmax)
        return np.concatenate([r["x"], r["v"]]), r["n_steps"], np.array([s[0] for s in r["switches"]])

    def lib(method):
        y, tr, _ = hybrid_run(system, p, CHAIN_T, x0, names, method)
        return y, -1, chain_switches(tr.events)

    add("hybrid Exact", 0.0, lambda: lib(Exact()), steps=-1)
    for rtol in rtols:
        m = IDA(rtol=rtol, atol=rtol / 100)
        add("hybrid IDA", rtol, lambda m=m: lib(m), steps=count_steps(system, p, CHAIN_T, x0, m))
        for meth in SCIPY:
            add(f"scipy {meth}", rtol, lambda r=rtol, me=meth: ivp(me, r))
    return report(f"chain of {CHAIN_N} blocks ({CHAIN_T:g} s)", rows)


def chain_switches(events) -> np.ndarray:
    """Times of the stick <-> slip changes of the contacts, as benchmarks/reference_chain.py lists
    them: the switches of one contact at one instant (a stop and the breakaway it lands on, a
    reversal through zero speed) taken together, reversals left out."""
    net: dict[tuple[float, str], list[bool]] = {}  # (t, contact) -> [stuck before, stuck after]
    for e in events:
        contact, _, guard = e.guard.partition(".")
        before, after = guard.startswith("breakaway"), guard.startswith("stop")
        key = (e.t, contact)
        if key in net:
            net[key][1] = after
        else:
            net[key] = [before, after]
    return np.array(sorted(t for (t, _), (a, b) in net.items() if a != b))


def main() -> None:
    rtols = (1e-8,) if "--quick" in sys.argv else RTOLS
    heyoka = have_heyoka()
    lines = run_belt(rtols, heyoka) + run_duffing(rtols, heyoka)
    if "--no-chain" not in sys.argv:
        lines += run_chain(rtols)
    print()
    print("\n".join(lines))
    print(f"load average {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
