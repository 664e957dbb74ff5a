"""Reference problems of the engine tests, each with an independent closed-form solution.

Every ``problem()`` function returns ``(system, params, x0, exact)`` in the manner of scipy's
``fun_linear``/``sol_linear``: ``exact(t)`` gives the state, shape ``(len(t), n_vars)``, in the
system's variable order (the event-driven problems also expose their switch times).
"""

from __future__ import annotations

import math

import numpy as np

from hybrid import IDA, HybridSystem, Mode, Parameter, SolverOptions, Transition, Variable

#: Tolerances for the closed-form comparisons (the lead's tests use the same).
TIGHT = SolverOptions(method=IDA(rtol=1e-11, atol=1e-13))


def scaled_error(y, y_true, rtol: float, atol: float) -> float:
    """Largest error in units of ``atol + rtol |y_true|`` (scipy's ``compute_error`` pattern)."""
    y, y_true = np.asarray(y, dtype=float), np.asarray(y_true, dtype=float)
    return float(np.max(np.abs(y - y_true) / (atol + rtol * np.abs(y_true))))


# ----------------------------------------------------------------------------
# Smooth problems (one mode)
# ----------------------------------------------------------------------------
def oscillator(w: float = 2.0, x0: float = 1.0, v0: float = 0.5):
    """x'' = -w^2 x: x = x0 cos(w t) + v0/w sin(w t)."""
    system = HybridSystem(
        name="oscillator",
        variables=[Variable("x", "m"), Variable("v", "m/s")],
        parameters=[Parameter("w", "rad/s", domain="positive")],
        modes=[Mode("free", derivatives={"x": "v", "v": "-w**2*x"})],
        transitions=[],
        initial_mode="free",
    )

    def exact(t):
        t = np.atleast_1d(np.asarray(t, dtype=float))
        x = x0 * np.cos(w * t) + v0 / w * np.sin(w * t)
        v = -x0 * w * np.sin(w * t) + v0 * np.cos(w * t)
        return np.column_stack([x, v])

    return system, {"w": w}, {"x": x0, "v": v0}, exact


def forced_oscillator(m=1.0, c=0.1, k=1.0, F=1.0, Omega=1.7, declare_period=True):
    """m x'' + c x' + k x = F sin(Omega t) from rest: steady state plus the decaying transient."""
    system = HybridSystem(
        name="forced",
        variables=["x", "v"],
        parameters=["m", "c", "k", "F", "Omega"],
        modes=[Mode("free", derivatives={"x": "v", "v": "(F*sin(Omega*t) - c*v - k*x)/m"})],
        transitions=[],
        period="2*pi/Omega" if declare_period else None,
        initial_mode="free",
    )
    X = F / (k - m * Omega**2 + 1j * c * Omega)  # complex amplitude of the steady state
    sigma = c / (2 * m)
    wd = math.sqrt(k / m - sigma**2)
    A = -X.imag  # x(0) = 0
    B = (-Omega * X.real + sigma * A) / wd  # v(0) = 0

    def exact(t):
        t = np.atleast_1d(np.asarray(t, dtype=float))
        ph = np.exp(1j * Omega * t)
        decay = np.exp(-sigma * t)
        x = (X * ph).imag + decay * (A * np.cos(wd * t) + B * np.sin(wd * t))
        v = (1j * Omega * X * ph).imag + decay * (
            (-sigma * A + wd * B) * np.cos(wd * t) + (-sigma * B - wd * A) * np.sin(wd * t)
        )
        return np.column_stack([x, v])

    exact.amplitude = abs(X)
    params = {"m": m, "c": c, "k": k, "F": F, "Omega": Omega}
    return system, params, {"x": 0.0, "v": 0.0}, exact


def nonlinear_dae(x0: float = 1.0):
    """Index-1 DAE with a nonlinear constraint whose unique real root is z = x + sin(t):

    x' = -z,  0 = z^3 + z - q^3 - q,  q = x + sin(t)
    => x' + x = -sin(t):  x = (x0 - 1/2) e^{-t} + (cos t - sin t)/2,  z = x + sin t.
    """
    system = HybridSystem(
        name="dae",
        variables=["x", "z"],
        parameters=[],
        modes=[
            Mode(
                "only",
                derivatives={"x": "-z"},
                algebraic={"z": "z**3 + z - q**3 - q"},
                definitions={"q": "x + sin(t)"},
            )
        ],
        transitions=[],
        initial_mode="only",
    )

    def exact(t):
        t = np.atleast_1d(np.asarray(t, dtype=float))
        x = (x0 - 0.5) * np.exp(-t) + (np.cos(t) - np.sin(t)) / 2
        return np.column_stack([x, x + np.sin(t)])

    return system, {}, {"x": x0}, exact  # z is omitted: the engine must solve it


def riccati(x0: float = 1.0):
    """x' = -x**2 (the derivative of the right-hand side depends on x): x = 1/(1/x0 + t)."""
    system = HybridSystem(
        name="riccati",
        variables=["x"],
        parameters=[],
        modes=[Mode("only", derivatives={"x": "-x**2"})],
        transitions=[],
        initial_mode="only",
    )

    def exact(t):
        t = np.atleast_1d(np.asarray(t, dtype=float))
        return (1.0 / (1.0 / x0 + t))[:, None]

    return system, {}, {"x": x0}, exact


def logistic(r: float = 3.0, x0: float = 0.01):
    """x' = r x (1 - x): x = 1/(1 + (1/x0 - 1) e^{-r t})."""
    system = HybridSystem(
        name="logistic",
        variables=["x"],
        parameters=["r"],
        modes=[Mode("only", derivatives={"x": "r*x*(1 - x)"})],
        transitions=[],
        initial_mode="only",
    )

    def exact(t):
        t = np.atleast_1d(np.asarray(t, dtype=float))
        return (1.0 / (1.0 + (1.0 / x0 - 1.0) * np.exp(-r * t)))[:, None]

    return system, {"r": r}, {"x": x0}, exact


# ----------------------------------------------------------------------------
# Hybrid problems
# ----------------------------------------------------------------------------
def bouncing_ball(e: float = 0.5, g: float = 9.81, h0: float = 1.0):
    """h'' = -g, v -> -e v at h = 0 falling, dropped from rest at h0.

    First impact t_1 = sqrt(2 h0/g) at speed g t_1; the j-th rebound leaves at e^j g t_1 and
    flies 2 e^j t_1, so t_k = t_1 (1 + 2 sum_{j=1}^{k-1} e^j) = t_1 (1 + 2 e (1 - e^(k-1))/(1 - e)),
    accumulating at the Zeno time t_1 (1 + e)/(1 - e).
    """
    system = HybridSystem(
        name="ball",
        variables=[Variable("h", "m"), Variable("v", "m/s")],
        parameters=[Parameter("g", domain="positive"), Parameter("e", domain="nonnegative")],
        modes=[Mode("fly", derivatives={"h": "v", "v": "-g"})],
        transitions=[Transition("fly", "fly", guard="h", direction=-1, name="impact", reset={"v": "-e*v"})],
        initial_mode="fly",
    )
    t1 = math.sqrt(2 * h0 / g)

    def impact_time(k):
        k = np.asarray(k, dtype=float)
        return t1 * (1 + 2 * e * (1 - e ** (k - 1)) / (1 - e))

    def exact(t):
        t = np.atleast_1d(np.asarray(t, dtype=float))
        out = np.empty((t.size, 2))
        for i, s in enumerate(t):
            if s < t1:
                out[i] = h0 - g * s**2 / 2, -g * s
                continue
            k = 1
            while impact_time(k + 1) <= s:
                k += 1
            tau = s - impact_time(k)
            V = e**k * g * t1
            out[i] = V * tau - g * tau**2 / 2, V - g * tau
        return out

    exact.impact_time = impact_time
    exact.zeno_time = t1 * (1 + e) / (1 - e)
    return system, {"g": g, "e": e}, {"h": h0, "v": 0.0}, exact


def coulomb_free_exact(params, x0: float, t0: float = 0.0):
    """Free Coulomb oscillator (built-in ``coulomb`` model, F = 0) released from rest at x0.

    Between velocity zeros the mass slips towards the spring with the friction force R against
    it: x = c_n + (x_n - c_n) cos(w (t - t_n)) with c_n = sign(x_n) R/k; the turning points are
    x_{n+1} = 2 c_n - x_n at t_{n+1} = t_n + pi/w, and the mass sticks for good once |x_n| <= R/k.
    Returns ``(turning, exact)``: the list of ``(t_n, x_n)`` and the state (x, v, W, D).
    """
    m, k, R = params["m"], params["k"], params["R"]
    w = math.sqrt(k / m)
    r = R / k
    turning = [(t0, x0)]
    while abs(turning[-1][1]) > r:
        tn, xn = turning[-1]
        turning.append((tn + math.pi / w, 2 * math.copysign(r, xn) - xn))
    E0 = 0.5 * k * x0**2

    def exact(t):
        t = np.atleast_1d(np.asarray(t, dtype=float))
        out = np.zeros((t.size, 4))
        for i, s in enumerate(t):
            n = 0
            while n + 1 < len(turning) and turning[n + 1][0] <= s:
                n += 1
            tn, xn = turning[n]
            if n == len(turning) - 1:  # stuck for good
                x, v = xn, 0.0
            else:
                c = math.copysign(r, xn)
                x = c + (xn - c) * math.cos(w * (s - tn))
                v = -(xn - c) * w * math.sin(w * (s - tn))
            out[i] = x, v, 0.0, E0 - (0.5 * m * v**2 + 0.5 * k * x**2)  # W = 0, D = energy lost
        return out

    return turning, exact


def tracker(a: float = 0.7, t_on: float = 1.0, t_off: float = 2.5, u0: float = 2.0):
    """A variable differential in two modes and a slave variable in the third.

    x'' = -x in all modes (x = cos t); u' = -a u in `hold1` and `hold2`, and u is fixed by
    0 = u - x in `track`; the switches are timed: hold1 -> track at t_on, track -> hold2 at t_off.
    """
    shared = {"x": "v", "v": "-x"}
    system = HybridSystem(
        name="tracker",
        variables=["x", "v", "u"],
        parameters=["a", "t_on", "t_off"],
        equations=shared,
        modes=[
            Mode("hold1", derivatives={"u": "-a*u"}),
            Mode("track", algebraic={"u": "u - x"}),
            Mode("hold2", derivatives={"u": "-a*u"}),
        ],
        transitions=[
            Transition("hold1", "track", guard="t - t_on", direction=1),
            Transition("track", "hold2", guard="t - t_off", direction=1),
        ],
        initial_mode="hold1",
    )

    def exact(t):
        t = np.atleast_1d(np.asarray(t, dtype=float))
        u = np.where(
            t < t_on,
            u0 * np.exp(-a * t),
            np.where(t < t_off, np.cos(t), np.cos(t_off) * np.exp(-a * (t - t_off))),
        )
        return np.column_stack([np.cos(t), -np.sin(t), u])

    return system, {"a": a, "t_on": t_on, "t_off": t_off}, {"x": 1.0, "v": 0.0, "u": u0}, exact


def chain_through_slave_mode():
    """A -> B -> C at the same instant, B having a slave variable z fixed by 0 = z - 2.

    A's guard x - 1 fires at t = 1; B is left at once (its guard x - 1/2 is already beyond zero), so
    the switch A -> B is recorded with x_plus = (1, 2) (z re-solved in B) and B -> C is chained.
    """
    system = HybridSystem(
        name="chain",
        variables=["x", "z"],
        parameters=[],
        modes=[
            Mode("A", derivatives={"x": "1", "z": "0"}),
            Mode("B", derivatives={"x": "1"}, algebraic={"z": "z - 2"}),
            Mode("C", derivatives={"x": "1", "z": "0"}),
        ],
        transitions=[Transition("A", "B", "x - 1", 1), Transition("B", "C", "x - 0.5", 1)],
        initial_mode="A",
    )

    def exact(t):
        t = np.atleast_1d(np.asarray(t, dtype=float))
        return np.column_stack([t, np.where(t < 1.0, 0.0, 2.0)])

    return system, {}, {"x": 0.0, "z": 0.0}, exact
