#!/usr/bin/python3
"""Forced Burridge-Knopoff friction chain in Siconos (first-order linear DS + relay contacts).

    m x_i'' = -k x_i + kc (x_{i-1} - x_i) + kc (x_{i+1} - x_i) - c v_i - f_i + F sin(Omega t)
    f_i in R_i Sgn(v_i),  free ends,  x(0) = v(0) = 0.

State X = [x_1..x_N, v_1..v_N] (size 2N):
    X' = A X + b(t) + r,   A = [[0, I], [-K/m, -c/m I]],   b(t) = [0; F/m sin(Omega t) 1]
    y  = C X = v                                  (C = [0 I], one row per contact)
    r  = B lambda,   B = [0; diag(R_i/m)]         (lambda_i enters v_i' with +R_i/m)
    RelayNSL(lb=-1, ub=1):  -y in N_[-1,1](lambda)  <=>  lambda in -Sgn(y)
so the friction force is f_i = -R_i lambda_i = R_i Sgn(v_i) as required.

Uses only numpy, siconos (Debian python3-siconos 4.4.0, system /usr/bin/python3) and stdlib.
Prints ONE JSON object on stdout.

Example:  python3 siconos_chain.py --N 6 --h 1e-3 --t-end 50 --theta 0.5 --solver LEMKE
"""

import argparse
import json
import math
import os
import subprocess
import sys
import tempfile
import time

# one BLAS thread unless the caller says otherwise: with 2 cores shared with other jobs, the
# OpenBLAS worker threads (dgetrf_parallel in EulerMoreauOSI's LU) only add contention
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

try:
    import siconos.kernel as sk  # noqa: E402
    import siconos.numerics as sn  # noqa: E402
except ImportError as e:  # Debian's python3-siconos exists only for the system interpreter
    sys.exit(f"cannot import siconos ({e}): run with /usr/bin/python3 (apt-get install python3-siconos)")

SOLVERS = ["LEMKE", "ENUM", "PGS", "PATH", "AVI_CAOFERRIS", "AVI_CAOFERRIS_TEST"]

PLUGIN_SRC = r"""
#include <math.h>
/* b(t) for FirstOrderLinearDS: z = [F/m, Omega, N] ; b = [0 (N) ; F/m sin(Omega t) (N)] */
void chain_b(double time, unsigned int sizeOfB, double* b, unsigned int sizeOfZ, double* z)
{
  unsigned int n = sizeOfB / 2, i;
  double f = z[0] * sin(z[1] * time);
  for (i = 0; i < n; i++) b[i] = 0.0;
  for (i = n; i < sizeOfB; i++) b[i] = f;
}
"""


def params(N):
    i = np.arange(1, N + 1)
    return dict(m=1.0, k=1.0, kc=1.0, c=0.1, F=1.0, Omega=1.0, R=0.3 * (1.0 + 0.1 * (-1.0) ** i))


def stiffness(N, k, kc):
    K = np.diag(np.full(N, k))
    for i in range(N - 1):
        K[i, i] += kc
        K[i + 1, i + 1] += kc
        K[i, i + 1] -= kc
        K[i + 1, i] -= kc
    return K


def build_plugin(workdir):
    """Compile the b(t) C plugin (needs gcc); returns the path of the shared object."""
    src = os.path.join(workdir, "chain_plugin.c")
    so = os.path.join(workdir, "chain_plugin.so")
    if not os.path.exists(so):
        with open(src, "w") as f:
            f.write(PLUGIN_SRC)
        subprocess.check_call(["gcc", "-O2", "-shared", "-fPIC", src, "-o", so, "-lm"])
    return so


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--N", type=int, default=6)
    ap.add_argument("--h", type=float, default=1e-3)
    ap.add_argument("--t-end", type=float, default=50.0)
    ap.add_argument("--theta", type=float, default=0.5)
    ap.add_argument("--solver", default="LEMKE", choices=SOLVERS)
    ap.add_argument(
        "--tol",
        type=float,
        default=None,
        help="relay solver tolerance dparam[0] (default 1e-12 for PGS, 1e-10 otherwise)",
    )
    ap.add_argument("--maxiter", type=int, default=100000, help="iparam[0] for iterative solvers")
    ap.add_argument(
        "--relay",
        default="single",
        choices=["single", "per-contact"],
        help="one Interaction with RelayNSL(N,-1,1) or N Interactions with RelayNSL(1,-1,1)",
    )
    ap.add_argument(
        "--relation", default="TIR", choices=["TIR", "R"], help="FirstOrderLinearTIR or FirstOrderLinearR"
    )
    ap.add_argument(
        "--forcing",
        default="setb",
        choices=["setb", "plugin", "subclass"],
        help="setb: write b in place before each step (theta-weighted, = what a plugin gives);"
        " plugin: compiled C plugin via setComputebFunction; subclass: python override of computeb",
    )
    ap.add_argument(
        "--ds",
        default="LDS",
        choices=["LDS", "TIDS"],
        help="FirstOrderLinearDS (default) or FirstOrderLinearTIDS (only with --forcing setb)",
    )
    ap.add_argument("--no-monitor", action="store_true", help="do not classify contacts per step")
    ap.add_argument("--eps-v", type=float, default=1e-9, help="|v| below this counts as at rest")
    ap.add_argument("--eps-lam", type=float, default=1e-9, help="|lambda| < 1-eps_lam counts as interior")
    ap.add_argument("--no-switch-list", action="store_true", help="omit the switch list from the JSON")
    a = ap.parse_args(argv)

    N, h, T, theta = a.N, a.h, a.t_end, a.theta
    # TimeStepping stops at the last full step <= T: make T an integer number of steps
    # (e.g. h = 3e-6 would otherwise stop at 49.999998 s), h_used = T / ceil(T / h - 1e-9)
    n_req = T / h
    if abs(n_req - round(n_req)) > 1e-6:
        h = T / math.ceil(n_req)
    p = params(N)
    m, F, Om = p["m"], p["F"], p["Omega"]
    R = p["R"]

    # Siconos prints its warnings on the C-level stdout: divert fd 1 to a temp file so that
    # stdout carries only the JSON; the warnings are counted and echoed (first lines) on stderr
    sys.stdout.flush()
    saved_fd = os.dup(1)
    cap = tempfile.TemporaryFile(mode="w+b")
    os.dup2(cap.fileno(), 1)

    ts0 = time.perf_counter()
    K = stiffness(N, p["k"], p["kc"])
    A = np.zeros((2 * N, 2 * N))
    A[:N, N:] = np.eye(N)
    A[N:, :N] = -K / m
    A[N:, N:] = -p["c"] / m * np.eye(N)
    X0 = np.zeros(2 * N)

    # ---------------------------------------------------------------- dynamical system
    if a.forcing == "subclass":

        class ForcedDS(sk.FirstOrderLinearDS):
            def computeb(self, t):
                bb = self.b()
                bb[N:] = F / m * math.sin(Om * t)

        ds = ForcedDS(X0, A)
        ds.setb(np.zeros(2 * N))
    elif a.forcing == "plugin":
        so = build_plugin(os.path.dirname(os.path.abspath(__file__)))
        ds = sk.FirstOrderLinearDS(X0, A)
        ds.setb(np.zeros(2 * N))
        ds.setzPtr(np.array([F / m, Om, float(N)]))
        ds.setComputebFunction(so[:-3], "chain_b")
    elif a.ds == "TIDS":
        # time-invariant DS: EulerMoreauOSI uses b directly (-h b) -> same setb update works
        ds = sk.FirstOrderLinearTIDS(X0, A)
        ds.setb(np.zeros(2 * N))
    else:
        ds = sk.FirstOrderLinearDS(X0, A)
        ds.setb(np.zeros(2 * N))

    # ---------------------------------------------------------------- relations / relay
    Rel = sk.FirstOrderLinearTIR if a.relation == "TIR" else sk.FirstOrderLinearR
    inters = []
    if a.relay == "single":
        C = np.zeros((N, 2 * N))
        C[:, N:] = np.eye(N)
        B = np.zeros((2 * N, N))
        B[N:, :] = np.diag(R / m)
        inters.append(sk.Interaction(sk.RelayNSL(N, -1.0, 1.0), Rel(C, B)))
    else:
        for i in range(N):
            C = np.zeros((1, 2 * N))
            C[0, N + i] = 1.0
            B = np.zeros((2 * N, 1))
            B[N + i, 0] = R[i] / m
            inters.append(sk.Interaction(sk.RelayNSL(1, -1.0, 1.0), Rel(C, B)))

    nsds = sk.NonSmoothDynamicalSystem(0.0, T)
    nsds.insertDynamicalSystem(ds)
    for it in inters:
        nsds.link(it, ds)

    osi = sk.EulerMoreauOSI(theta)
    td = sk.TimeDiscretisation(0.0, h)
    osnspb = sk.Relay(getattr(sn, "SICONOS_RELAY_" + a.solver))
    opts = osnspb.numericsSolverOptions()
    if a.tol is None:
        a.tol = 1e-12 if a.solver == "PGS" else 1e-10
    opts.dparam[0] = a.tol
    if a.solver in ("PGS",):
        opts.iparam[0] = a.maxiter
    sim = sk.TimeStepping(nsds, td, osi, osnspb)
    sim.setWarnOnNonConvergence(False) if hasattr(sim, "setWarnOnNonConvergence") else None
    sim.initialize()

    X = ds.x()  # live numpy view of the state
    bvec = ds.b()  # live numpy view of b
    lam_views = [it.lambda_(0) for it in inters]
    setup_s = time.perf_counter() - ts0

    # ---------------------------------------------------------------- time loop
    nsteps_expected = int(round(T / h))
    s_prev = np.zeros(N)  # initial state: all blocks at rest (stick)
    eps_v = a.eps_v
    switches = []
    fb = F / m
    monitor = not a.no_monitor
    single = a.relay == "single"
    lam = np.zeros(N)
    last_s = np.zeros(N)  # last sliding direction (+-1), 0 = never slid
    n_rev = 0
    lo = 1.0 - a.eps_lam
    k = 0
    tw0 = time.perf_counter()
    while sim.hasNextEvent():
        if a.forcing == "setb":
            tk = sim.startingTime()
            tk1 = sim.nextTime()
            # EulerMoreauOSI residu uses -h[(1-theta) b(t_k) + theta b(t_k+1)]
            bvec[N:] = fb * ((1.0 - theta) * math.sin(Om * tk) + theta * math.sin(Om * tk1))
        sim.computeOneStep()
        k += 1
        if monitor:
            lam = lam_views[0] if single else np.array([lv[0] for lv in lam_views])
            # contact state: 0 = stick (|lambda| < 1 strictly inside, |v| tiny), +-1 = slip dir
            s_now = -np.sign(lam)
            s_now[(np.abs(lam) < lo) & (np.abs(X[N:]) < eps_v)] = 0.0
            if not np.array_equal(s_now, s_prev):  # rare: handle in python
                tnow = sim.nextTime()
                for i in np.nonzero(s_now != s_prev)[0]:
                    new_s, old_s = s_now[i], s_prev[i]
                    if new_s == 0:
                        switches.append([tnow, int(i) + 1, "stick"])
                    else:
                        if old_s == 0:
                            switches.append([tnow, int(i) + 1, "slip"])
                        if last_s[i] != 0 and new_s != last_s[i]:
                            n_rev += 1
                        last_s[i] = new_s
                s_prev = s_now
        sim.nextStep()
    wall = time.perf_counter() - tw0

    # stick episodes lasting a single step = discrete image of an instantaneous reversal
    short = 0
    open_stick = {}
    for t_s, i_s, kind in switches:
        if kind == "stick":
            open_stick[i_s] = t_s
        elif i_s in open_stick:
            if t_s - open_stick.pop(i_s) <= 1.5 * h:
                short += 1
    sys.stdout.flush()
    os.dup2(saved_fd, 1)
    os.close(saved_fd)
    cap.seek(0)
    log = cap.read().decode(errors="replace")
    cap.close()
    n_warn = log.count("Problem in Relay resolution")
    if log.strip():
        sys.stderr.write(f"[siconos output, first 5 lines of {log.count(chr(10))}]\n")
        sys.stderr.write("\n".join(log.splitlines()[:5]) + "\n")
    x_end = X[:N].copy()
    v_end = X[N:].copy()
    t_final = sim.startingTime()
    out = dict(
        N=N,
        h=a.h,
        h_used=h,
        t_final=t_final,
        theta=theta,
        solver=a.solver,
        relay=a.relay,
        relation=a.relation,
        forcing=a.forcing,
        ds=a.ds,
        blas_threads=os.environ.get("OPENBLAS_NUM_THREADS"),
        wall_s=wall,
        setup_s=setup_s,
        steps=k,
        steps_expected=nsteps_expected,
        t_end=T,
        x_end=[float(q) for q in x_end],
        v_end=[float(q) for q in v_end],
        lambda_end=[float(q) for lv in lam_views for q in lv],
        switches=[] if a.no_switch_list else switches,
        n_switches=len(switches) if monitor else None,
        n_stick=sum(1 for s in switches if s[2] == "stick") if monitor else None,
        n_slip=sum(1 for s in switches if s[2] == "slip") if monitor else None,
        n_one_step_sticks=short if monitor else None,
        n_switches_filtered=(len(switches) - 2 * short) if monitor else None,
        n_reversals=n_rev if monitor else None,
        tol=a.tol,
        n_solver_warnings=n_warn,
        finite=bool(np.all(np.isfinite(X))),
    )
    json.dump(out, sys.stdout)
    sys.stdout.write("\n")


if __name__ == "__main__":
    main()
