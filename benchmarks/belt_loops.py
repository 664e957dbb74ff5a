"""The Stribeck belt (models/belt_stribeck.toml, preset `standard`) by hand-written loops, for the
benchmarks of issue 34: stick phases in closed form (the mass rides the belt, x' = v_b, until the
spring and damper force H = k x + c v_b reaches +-Fs), slip phases integrated to the first stop
(w = 0 in the direction of the phase) by

* :func:`scipy_loop`: ``scipy.integrate.solve_ivp`` (LSODA, Radau, DOP853, ...), one terminal event;
* :func:`sundae_loop`: raw scikit-sundae IDA (one solver object per slip direction, re-entered
  with ``init_step``), in one-step or normal mode, with a plain Python residual.

Both return ``(final state [x, w], internal steps, switch times, final mode)`` (mode 0 stick, -1
slip-, +1 slip+).
"""

from __future__ import annotations

import math

import numpy as np

#: The preset `standard` of models/belt_stribeck.toml.
P = {"m": 1.0, "k": 1.0, "c": 0.1, "Fs": 1.0, "Fk": 0.5, "vs": 0.5, "cf": 0.0, "v_b": 0.8}


def friction(s: int, w: float, p=P) -> float:
    """Sliding force [N] in slip- (``s = -1``, w < 0) or slip+ (``s = +1``) at slip speed ``w`` [m/s]."""
    if s < 0:
        return p["Fk"] + (p["Fs"] - p["Fk"]) * math.exp(w / p["vs"]) - p["cf"] * w
    return -(p["Fk"] + (p["Fs"] - p["Fk"]) * math.exp(-w / p["vs"]) + p["cf"] * w)


def stick_exit(t: float, x: float, p=P) -> tuple[float, float, int]:
    """From stick at ``(t, x)``: the breakaway time, position and slip direction (closed form)."""
    H = p["k"] * x + p["c"] * p["v_b"]
    if H >= p["Fs"]:
        return t, x, -1
    if H <= -p["Fs"]:
        return t, x, +1
    xb = (p["Fs"] - p["c"] * p["v_b"]) / p["k"]
    return t + (xb - x) / p["v_b"], xb, -1


def _stick(t, x, t1, switches, p=P):
    tb, xb, s = stick_exit(t, x, p)
    if tb >= t1:
        return t1, x + p["v_b"] * (t1 - t), 0
    switches.append(tb)
    return tb, xb, s


def scipy_loop(t1: float, method: str = "LSODA", rtol: float = 1e-8, atol: float = 1e-10, p=P):
    """The belt from rest in stick to ``t1`` [s] with ``solve_ivp(method)`` on the slip phases."""
    from scipy.integrate import solve_ivp

    m, k, c, vb = p["m"], p["k"], p["c"], p["v_b"]
    t, x, w, mode, steps, switches = 0.0, 0.0, 0.0, 0, 0, []
    while t < t1:
        if mode == 0:
            t, x, mode = _stick(t, x, t1, switches, p)
            w = 0.0
            continue
        s = mode

        def rhs(_t, y, s=s):
            return [y[1] + vb, (friction(s, y[1], p) - k * y[0] - c * (y[1] + vb)) / m]

        def stop(_t, y):
            return y[1]

        stop.terminal, stop.direction = True, -s
        sol = solve_ivp(rhs, (t, t1), [x, w], method=method, rtol=rtol, atol=atol, events=stop)
        steps += sol.t.size - 1
        if sol.status == 1:
            t, x, w, mode = float(sol.t_events[0][0]), float(sol.y_events[0][0][0]), 0.0, 0
            switches.append(t)
        else:
            t, x, w = float(sol.t[-1]), float(sol.y[0, -1]), float(sol.y[1, -1])
    return np.array([x, w]), steps, np.array(switches), mode


def sundae_loop(t1: float, rtol: float = 1e-8, atol: float = 1e-10, one_step: bool = False, p=P):
    """The belt from rest in stick to ``t1`` [s] with raw scikit-sundae IDA on the slip phases."""
    from sksundae.ida import IDA

    m, k, c, vb = p["m"], p["k"], p["c"], p["v_b"]
    solvers = {}

    def make(s):
        def res(_t, y, yp, r):
            r[0] = yp[0] - (y[1] + vb)
            r[1] = yp[1] - (friction(s, y[1], p) - k * y[0] - c * (y[1] + vb)) / m

        def ev(_t, y, yp, g):
            g[0] = y[1]

        ev.terminal, ev.direction = [True], [-s]
        ida = IDA(
            res, rtol=rtol, atol=atol, eventsfn=ev, num_events=1, max_step=t1 / 50, max_num_steps=50_000
        )
        return ida, ev

    t, x, w, mode, steps, switches = 0.0, 0.0, 0.0, 0, 0, []
    while t < t1:
        if mode == 0:
            t, x, mode = _stick(t, x, t1, switches, p)
            w = 0.0
            continue
        s = mode
        if s not in solvers:
            solvers[s] = make(s)
        ida, ev = solvers[s]
        yp = np.array([w + vb, (friction(s, w, p) - k * x - c * (w + vb)) / m])
        ida.init_step(t, np.array([x, w]), yp)
        while True:
            r = ida.step(t1, "onestep" if one_step else "normal", tstop=t1)
            steps += 1
            ev._i.clear()  # (scikit-sundae keeps every event on the function: see shared notes)
            ev._t.clear()
            ev._y.clear()
            ev._yp.clear()
            ev._i_cnt[:] = 0
            if r.status < 0:
                raise RuntimeError(r.message)
            if r.status == 2:
                t, x, w, mode = float(r.t), float(r.y[0]), 0.0, 0
                switches.append(t)
                break
            if r.t >= t1:
                t, x, w = float(r.t), float(r.y[0]), float(r.y[1])
                break
    return np.array([x, w]), steps, np.array(switches), mode
