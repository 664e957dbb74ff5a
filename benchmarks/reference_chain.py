#!/usr/bin/env python3
"""Independent event-driven reference for the forced Burridge-Knopoff friction chain.

    m x_i'' = -k x_i + kc (x_{i-1} - x_i) + kc (x_{i+1} - x_i) - c v_i - f_i + F sin(Omega t)
    f_i in R_i Sgn(v_i)   (set-valued; equal static/kinetic levels), free ends.

Written from scratch (numpy/scipy only): no Siconos, nothing from the library ``hybrid``.

Between events every contact is in a fixed mode: stuck (v_i = 0, x_i frozen) or sliding with
direction s_i = +-1 (f_i = R_i s_i).  The phase dynamics is then LINEAR with constant coefficients
in the augmented state z = [x (N), v (N), sin(Omega t), cos(Omega t), 1], z' = M z.

Two independent phase integrators ("backends") share the event logic:
  * taylor : exact linear flow.  On sub-intervals of length <= delta the flow is the Taylor series
             z(s) = sum_n s^n/n! M^n z_a (order 24, ||M delta|| ~ 0.2 -> truncation ~1e-35),
             so every event function g = w.z is an explicit polynomial in s; its first root is
             bracketed on 16 samples (plus local minima through g') and polished with brentq.
  * ivp    : scipy solve_ivp (DOP853) with terminal event functions, rtol/atol given.

Events (all event functions are linear in z):
  sliding i :  g = s_i v_i        (velocity reaches zero)
  stuck i   :  g = R_i -+ f_req_i (required holding force reaches +-R_i),
               f_req_i = F sin(Omega t) - (K x)_i      (net non-friction force at v_i = 0)

Successor mode at an event.  The contact problem at an instant is an LCP / relay problem whose
Delassus matrix is diag(1/m) (friction acts on each block separately, the springs couple only
through the positions, which are continuous).  Hence for all contacts at a switching condition
at once (v_i = 0):  |f_req_i| < R_i -> stick;  |f_req_i| > R_i -> slide with s_i = sign(f_req_i);
|f_req_i| = R_i (breakaway / tangency) -> decided by the sign of d f_req_i/dt = F Omega cos -
(K v)_i (continuous, independent of the other contacts' modes).  After the decision the
successor is checked for consistency for all contacts simultaneously (stick forces inside the
bounds, accelerations of sliding-from-rest blocks in their sliding direction).

Output: one JSON object on stdout.
"""

import argparse
import json
import math
import sys
import time

import numpy as np
from scipy.optimize import brentq

# ----------------------------------------------------------------------------- parameters


def default_params(N):
    i = np.arange(1, N + 1)
    return dict(N=N, m=1.0, k=1.0, kc=1.0, c=0.1, F=1.0, Omega=1.0, R=0.3 * (1.0 + 0.1 * (-1.0) ** i))


def stiffness(p):
    N = p["N"]
    K = np.diag(np.full(N, p["k"]))
    for i in range(N - 1):
        K[i, i] += p["kc"]
        K[i + 1, i + 1] += p["kc"]
        K[i, i + 1] -= p["kc"]
        K[i + 1, i] -= p["kc"]
    return K


class Chain:
    def __init__(self, p):
        self.p = p
        self.N = p["N"]
        self.K = stiffness(p)
        self.R = np.asarray(p["R"], float)
        N = self.N
        self.nz = 2 * N + 3
        self.iS, self.iC, self.i1 = 2 * N, 2 * N + 1, 2 * N + 2

    def matrix(self, mode):
        """z' = M z for the mode vector (0 = stuck, +-1 = sliding direction)."""
        p, N = self.p, self.N
        m, c, F, Om = p["m"], p["c"], p["F"], p["Omega"]
        M = np.zeros((self.nz, self.nz))
        sl = np.nonzero(mode != 0)[0]
        for i in sl:
            M[i, N + i] = 1.0
            M[N + i, :N] = -self.K[i] / m
            M[N + i, N + i] = -c / m
            M[N + i, self.iS] = F / m
            M[N + i, self.i1] = -self.R[i] * mode[i] / m
        M[self.iS, self.iC] = Om
        M[self.iC, self.iS] = -Om
        return M

    def events(self, mode):
        """Rows w of the event functions g = w.z (all > 0 inside the phase) and owning contact."""
        p, N = self.p, self.N
        W, owner = [], []
        for i in range(N):
            if mode[i] != 0:
                w = np.zeros(self.nz)
                w[N + i] = mode[i]
                W.append(w)
                owner.append(i)
            else:
                for sgn in (+1.0, -1.0):  # R - sgn * f_req, f_req = F sin - (K x)_i
                    w = np.zeros(self.nz)
                    w[self.i1] = self.R[i]
                    w[self.iS] = -sgn * p["F"]
                    w[:N] = sgn * self.K[i]
                    W.append(w)
                    owner.append(i)
        return np.array(W), np.array(owner, int)

    def freq(self, t, x):
        return self.p["F"] * math.sin(self.p["Omega"] * t) - self.K @ x

    def dfreq(self, t, v):
        return self.p["F"] * self.p["Omega"] * math.cos(self.p["Omega"] * t) - self.K @ v

    # --------------------------------------------------------------- successor mode at event
    def decide(self, t, x, v, mode, tol_v, tol_f):
        """Return new mode (and v with the switching contacts' velocities set to 0)."""
        fr = self.freq(t, x)
        dfr = self.dfreq(t, v)
        new = mode.copy()
        v = v.copy()
        for i in range(self.N):
            at_zero = (mode[i] == 0) or (abs(v[i]) < tol_v)
            if not at_zero:
                continue
            v[i] = 0.0
            a = abs(fr[i])
            if a < self.R[i] - tol_f:
                new[i] = 0
            elif a > self.R[i] + tol_f:
                new[i] = 1 if fr[i] > 0 else -1
            else:  # at the friction limit: does |f_req| grow?
                s = 1.0 if fr[i] > 0 else -1.0
                if s * dfr[i] > 0:
                    new[i] = int(s)
                else:
                    new[i] = 0
        # consistency check of the successor, all contacts at once
        m = self.p["m"]
        for i in range(self.N):
            if new[i] == 0:
                assert abs(fr[i]) <= self.R[i] + 10 * tol_f, ("stick force out of bounds", t, i)
            elif v[i] == 0.0:
                acc = (fr[i] - self.R[i] * new[i]) / m
                assert acc * new[i] >= -10 * tol_f, ("inconsistent slide", t, i)
        return new, v


# ----------------------------------------------------------------------------- taylor backend


def _horner(coef, s):
    """coef: (nf, n+1) with g(s) = sum_n coef[:, n] s^n ; vectorised in s (scalar)."""
    r = coef[:, -1].copy()
    for n in range(coef.shape[1] - 2, -1, -1):
        r = r * s + coef[:, n]
    return r


def _first_root_poly(c, delta, just, tol_g, nsamp=16):
    """First root in (0, delta] of g(s) = sum_n c[n] s^n at which g goes from > 0 to < 0.

    Touching minima with g_min >= -tol_g are ignored (tangencies / round-off); a function that
    is exactly 0 at s = 0 (just-switched contact) is allowed to start at 0.
    """
    P = np.polynomial.polynomial
    dc = P.polyder(c)

    def f(s):
        return P.polyval(s, c)

    def fd(s):
        return P.polyval(s, dc)

    ss = np.linspace(0.0, delta, nsamp + 1)
    g = P.polyval(ss, c)
    dg = P.polyval(ss, dc)
    if g[0] < -tol_g and not just:
        raise RuntimeError(f"event function negative at the start of a phase: {g[0]!r}")
    for j in range(nsamp):
        a, b = ss[j], ss[j + 1]
        ga, gb = g[j], g[j + 1]
        if ga <= 0.0:
            # start of a just-switched contact (g(0) = 0) or just after a touching minimum:
            # a genuine crossing needs an interior maximum with g > 0 first
            if gb <= 0.0 and dg[j] > 0 > dg[j + 1]:
                sc = brentq(fd, a, b, xtol=1e-17, rtol=8.9e-16)
                if f(sc) > 0 and (gb < -tol_g or dg[j + 1] < 0):
                    return brentq(f, sc, b, xtol=1e-17, rtol=8.9e-16)
            if gb < -tol_g and j > 0:
                raise RuntimeError("event function stays negative")
            continue
        if gb < -tol_g or (gb <= 0.0 and dg[j + 1] < 0):
            return brentq(f, a, b, xtol=1e-17, rtol=8.9e-16)
        if dg[j] < 0 < dg[j + 1]:  # interior minimum
            sc = brentq(fd, a, b, xtol=1e-17, rtol=8.9e-16)
            if f(sc) < -tol_g:
                return brentq(f, a, sc, xtol=1e-17, rtol=8.9e-16)
    return None


def run_taylor(ch, T, delta=0.05, order=24, tol_v=1e-11, tol_f=1e-11, tol_g=1e-13, energy=False):
    N, p = ch.N, ch.p
    Om = p["Omega"]
    z = np.zeros(ch.nz)
    z[ch.i1] = 1.0
    t = 0.0
    mode = np.zeros(N, int)
    switches, reversals = [], []
    fact = np.array([1.0 / math.factorial(n) for n in range(order + 1)])
    # initial mode decision at t = 0
    mode, v = ch.decide(t, z[:N], z[N : 2 * N], mode, tol_v, tol_f)
    z[N : 2 * N] = v
    just = np.zeros(N, bool)
    M = ch.matrix(mode)
    W, owner = ch.events(mode)
    n_events = 0
    # energy bookkeeping
    gl_x, gl_w = np.polynomial.legendre.leggauss(20)
    WF = Dc = Df = 0.0
    while t < T - 1e-15:
        z[ch.iS] = math.sin(Om * t)
        z[ch.iC] = math.cos(Om * t)
        d = min(delta, T - t)
        # Krylov / Taylor matrix: P[:, n] = M^n z / n!
        Pm = np.empty((ch.nz, order + 1))
        Pm[:, 0] = z
        for n in range(1, order + 1):
            Pm[:, n] = M @ Pm[:, n - 1]
        Pm *= fact
        G = W @ Pm  # event polynomial coefficients
        sbest, _kbest = None, None
        for kf in range(G.shape[0]):
            r = _first_root_poly(G[kf], d, just[owner[kf]], tol_g)
            if r is not None and (sbest is None or r < sbest):
                sbest, _kbest = r, kf
        send = d if sbest is None else sbest
        if energy:
            # Gauss-Legendre on the polynomial pieces (exact up to round-off)
            ss = 0.5 * send * (gl_x + 1.0)
            ww = 0.5 * send * gl_w
            pw = ss[None, :] ** np.arange(order + 1)[:, None]
            Z = Pm @ pw  # (nz, nq)
            vv = Z[N : 2 * N]
            WF += p["F"] * np.sum(ww * Z[ch.iS] * vv.sum(0))
            Dc += p["c"] * np.sum(ww * (vv**2).sum(0))
        znew = Pm @ (send ** np.arange(order + 1))
        if energy:
            Df += float(np.sum(ch.R * mode * (znew[:N] - z[:N])))
        z = znew
        t = t + send
        just[:] = False
        if sbest is not None:
            n_events += 1
            old = mode.copy()
            mode, v = ch.decide(t, z[:N], z[N : 2 * N], mode, tol_v, tol_f)
            z[N : 2 * N] = v
            for i in range(N):
                if old[i] != 0 and mode[i] == 0:
                    switches.append([t, i + 1, "stick"])
                    just[i] = True
                elif old[i] == 0 and mode[i] != 0:
                    switches.append([t, i + 1, "slip"])
                    just[i] = True
                elif old[i] != 0 and mode[i] == -old[i]:
                    reversals.append([t, i + 1])
                    just[i] = True
            M = ch.matrix(mode)
            W, owner = ch.events(mode)
    out = dict(
        t=t,
        x=z[:N].copy(),
        v=z[N : 2 * N].copy(),
        mode=mode,
        switches=switches,
        reversals=reversals,
        n_events=n_events,
    )
    if energy:
        E = 0.5 * p["m"] * np.sum(z[N : 2 * N] ** 2) + 0.5 * z[:N] @ ch.K @ z[:N]
        out["energy"] = dict(W_force=WF, D_damp=Dc, D_fric=Df, E_end=E, residual=WF - Dc - Df - E)
    return out


# ----------------------------------------------------------------------------- ivp backend


def run_ivp(ch, T, rtol=1e-12, atol=1e-14, tol_v=1e-9, tol_f=1e-9, method="DOP853", max_step=math.inf):
    from scipy.integrate import solve_ivp

    N, p = ch.N, ch.p
    Om, _F = p["Omega"], p["F"]
    x = np.zeros(N)
    v = np.zeros(N)
    t = 0.0
    mode = np.zeros(N, int)
    mode, v = ch.decide(t, x, v, mode, tol_v, tol_f)
    switches, reversals = [], []
    n_events = 0
    n_steps = 0  # solve_ivp's steps, over all phases (benchmarks/peer_ivp.py)
    while t < T - 1e-14:
        M = ch.matrix(mode)
        A = M[: 2 * N, : 2 * N]
        bS = M[: 2 * N, ch.iS]
        b1 = M[: 2 * N, ch.i1]
        W, owner = ch.events(mode)
        Wy = W[:, : 2 * N]
        wS = W[:, ch.iS]
        wC = W[:, ch.iC]
        w1 = W[:, ch.i1]

        def rhs(tt, y, A=A, bS=bS, b1=b1):
            return A @ y + bS * math.sin(Om * tt) + b1

        evs = []
        for kf in range(W.shape[0]):

            def g(tt, y, kf=kf, Wy=Wy, wS=wS, wC=wC, w1=w1):
                return Wy[kf] @ y + wS[kf] * math.sin(Om * tt) + wC[kf] * math.cos(Om * tt) + w1[kf]

            g.terminal = True
            g.direction = -1
            evs.append(g)
        y0 = np.concatenate([x, v])
        sol = solve_ivp(
            rhs,
            (t, T),
            y0,
            method=method,
            rtol=rtol,
            atol=atol,
            events=evs,
            dense_output=False,
            max_step=max_step,
        )
        n_steps += sol.t.size - 1
        # earliest event strictly after t (ignore a re-detection of the just-switched root)
        tev, yev = None, None
        for te, ye in zip(sol.t_events, sol.y_events, strict=False):
            for tt, yy in zip(te, ye, strict=False):
                if tt > t + 1e-12 and (tev is None or tt < tev):
                    tev, yev = tt, yy
        if tev is None:
            x, v = sol.y[:N, -1], sol.y[N:, -1]
            t = sol.t[-1]
            break
        t = tev
        x, v = yev[:N].copy(), yev[N:].copy()
        old = mode.copy()
        n_events += 1
        mode, v = ch.decide(t, x, v, mode, tol_v, tol_f)
        for i in range(N):
            if old[i] != 0 and mode[i] == 0:
                switches.append([t, i + 1, "stick"])
            elif old[i] == 0 and mode[i] != 0:
                switches.append([t, i + 1, "slip"])
            elif old[i] != 0 and mode[i] == -old[i]:
                reversals.append([t, i + 1])
    return dict(
        t=t, x=x, v=v, mode=mode, switches=switches, reversals=reversals, n_events=n_events, n_steps=n_steps
    )


# ----------------------------------------------------------------------------- main


def main(argv=None):
    ap = argparse.ArgumentParser()
    ap.add_argument("--N", type=int, default=6)
    ap.add_argument("--t-end", type=float, default=50.0)
    ap.add_argument("--backend", default="taylor", choices=["taylor", "ivp"])
    ap.add_argument("--delta", type=float, default=0.05, help="taylor sub-interval")
    ap.add_argument("--order", type=int, default=24, help="taylor order")
    ap.add_argument("--rtol", type=float, default=1e-12, help="ivp rtol (atol = rtol/100)")
    ap.add_argument("--energy", action="store_true", help="taylor: energy balance check")
    ap.add_argument("--no-switch-list", action="store_true")
    a = ap.parse_args(argv)
    ch = Chain(default_params(a.N))
    t0 = time.perf_counter()
    if a.backend == "taylor":
        r = run_taylor(ch, a.t_end, delta=a.delta, order=a.order, energy=a.energy)
    else:
        r = run_ivp(ch, a.t_end, rtol=a.rtol, atol=a.rtol * 1e-2)
    wall = time.perf_counter() - t0
    out = dict(
        N=a.N,
        backend=a.backend,
        t_end=r["t"],
        wall_s=wall,
        x_end=[float(q) for q in r["x"]],
        v_end=[float(q) for q in r["v"]],
        mode_end=[int(q) for q in r["mode"]],
        switches=[] if a.no_switch_list else r["switches"],
        n_switches=len(r["switches"]),
        n_stick=sum(1 for s in r["switches"] if s[2] == "stick"),
        n_slip=sum(1 for s in r["switches"] if s[2] == "slip"),
        n_reversals=len(r["reversals"]),
        n_events=r["n_events"],
    )
    if a.backend == "taylor":
        out.update(delta=a.delta, order=a.order)
    else:
        out.update(rtol=a.rtol)
    if "energy" in r:
        out["energy"] = r["energy"]
    json.dump(out, sys.stdout)
    sys.stdout.write("\n")


if __name__ == "__main__":
    main()
