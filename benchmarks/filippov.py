"""Filippov models written with sign() against the hand-written automata (issue 12, "Must show").

1. Coulomb oscillator ``m v' = F sin(W t) - k x - R sign(v)`` (``models/coulomb_sign.toml``)
   against the automaton ``models/coulomb.toml`` and Den Hartog's closed form of the non-stop
   motion (:func:`hybrid_models.coulomb_exact.den_hartog`): periodic orbits over a grid of Omega
   and R/F, both integrators; the largest differences of the amplitude and of the Floquet
   multipliers (the sign() model's structural zero of its slave ``sign_1`` set aside).
2. Belt ``m v' = -k x - c v - F sign(v - v_b)`` (``models/belt_sign.toml``) against its automaton
   (``tests/hybrid/data/belt_automaton.toml``): switch times and states over 200 s, and each stick
   (sliding) phase against ``x = x0 + v_b (t - t0)`` until ``k x + c v_b = F``.
3. Time per periodic orbit of the sign() model over the automaton's, from rest (10 transient
   periods, Newton, exact monodromy), median of ``REPEAT`` runs per point, CPU time of this
   process; ``uptime`` printed (the machine may be shared).

Run: ``python benchmarks/filippov.py`` (about a minute on 2 cores).
"""

from __future__ import annotations

import os
import time
from pathlib import Path

import numpy as np

import hybrid
from hybrid import IDA, Exact, SolverOptions, Status, method_named, periodic_orbit, simulate
from hybrid_models.coulomb_exact import den_hartog

ROOT = Path(__file__).resolve().parents[1]
OMEGAS = (0.5, 0.7, 0.8, 0.9, 1.2, 1.5, 2.0, 3.0)
RATIOS = (0.05, 0.2, 0.4, 0.6, 0.8)
REPEAT = 3


def multipliers(o):
    """The multipliers other than the structural zeros (the sign() model's slave ``sign_1``)."""
    mu = [m for m, k in zip(o.multipliers, o.multiplier_kinds, strict=True) if k != "structural"]
    return np.sort_complex(np.array(mu))


def coulomb_study(options, label):
    a = hybrid.load_system(ROOT / "models" / "coulomb.toml")
    b = hybrid.load_system(ROOT / "models" / "coulomb_sign.toml")
    d_amp = d_mu = d_dh = 0.0
    n = n_dh = n_stick = 0
    times_a, times_b = [], []
    worst = {}
    for W in OMEGAS:
        for ratio in RATIOS:
            p = a.preset("forced", Omega=W, R=ratio * 0.5)
            ta, tb = [], []
            for _ in range(REPEAT):
                c0 = time.process_time()
                oa = periodic_orbit(a, p, options=options)
                c1 = time.process_time()
                ob = periodic_orbit(b, p, options=options)
                c2 = time.process_time()
                ta.append(c1 - c0)
                tb.append(c2 - c1)
            if not (oa.converged and ob.converged):
                print(f"  {label}: Omega {W}, R/F {ratio}: converged {oa.converged} / {ob.converged}")
                continue
            n += 1
            n_stick += ob.mode_fractions.get("motion|slide", 0.0) > 0
            times_a.append(np.median(ta))
            times_b.append(np.median(tb))
            e = abs(ob.amplitude["x"] / oa.amplitude["x"] - 1)
            if e > d_amp:
                d_amp, worst["amp"] = e, (W, ratio)
            mu = float(np.max(np.abs(multipliers(ob) - multipliers(oa))))
            if mu > d_mu:
                d_mu, worst["mu"] = mu, (W, ratio)
            r = W
            X = ob.amplitude["x"]
            # Den Hartog's non-stop motion: no stick phase, and a unique orbit (at W = 1/2, 1/4, ...
            # a free oscillation fits the period: a family, multiplier 1, outside the closed form).
            if ob.mode_fractions.get("motion|slide", 0.0) == 0.0 and X * r * r > p["R"] and not ob.family:
                n_dh += 1
                e = abs(X / den_hartog(1.0, 1.0, p["R"], 0.5, W) - 1)
                if e > d_dh:
                    d_dh, worst["dh"] = e, (W, ratio)
    print(
        f"  {label}: {n} orbits ({n_stick} with stick phases); sign() vs automaton: amplitude {d_amp:.2g} (relative, at Omega, R/F = {worst.get('amp')}),"
    )
    print(f"    Floquet multipliers {d_mu:.2g} (absolute, at {worst.get('mu')});")
    print(
        f"    sign() vs Den Hartog on the {n_dh} non-stop orbits: amplitude {d_dh:.2g} (relative, at {worst.get('dh')})"
    )
    ratio = np.array(times_b) / np.array(times_a)
    print(
        f"    time per orbit: automaton median {1e3 * np.median(times_a):.0f} ms, sign() {1e3 * np.median(times_b):.0f} ms; "
        f"ratio sign()/automaton median {np.median(ratio):.2f} (range {ratio.min():.2f}-{ratio.max():.2f})"
    )


def belt_study(options, label):
    a = hybrid.load_system(ROOT / "tests" / "hybrid" / "data" / "belt_automaton.toml")
    b = hybrid.load_system(ROOT / "models" / "belt_sign.toml")
    for preset in ("standard", "damped"):
        p = b.preset(preset)
        ta = simulate(a, p, (0.0, 200.0), {"x": 0.0, "v": 0.0}, mode0="slip-", options=options)
        tb = simulate(b, p, (0.0, 200.0), {"x": 0.0, "v": 0.0}, options=options)
        assert ta.status == tb.status == Status.COMPLETED
        eb = [e for e in tb.events if e.t > 0]
        assert len(eb) == len(ta.events)
        dt = max(abs(x.t - y.t) for x, y in zip(ta.events, eb, strict=True))
        dx = max(
            float(np.max(np.abs(x.x_plus[:2] - y.x_plus[:2]))) for x, y in zip(ta.events, eb, strict=True)
        )
        k, c, F, vb = p["k"], p["c"], p["F"], p["v_b"]
        d_exit = d_x = 0.0
        n_stick = 0
        for i, e in enumerate(eb):
            if e.target != "motion|slide":
                continue
            n_stick += 1
            x0, t0 = e.x_plus[0], e.t
            t_exit = t0 + ((F - c * vb) / k - x0) / vb
            if i + 1 < len(eb):
                d_exit = max(d_exit, abs(eb[i + 1].t - t_exit))
            inside = (tb.mode == "motion|slide") & (tb.t > t0) & (tb.t < t_exit)
            if inside.any():
                d_x = max(d_x, float(np.max(np.abs(tb["x"][inside] - x0 - vb * (tb.t[inside] - t0)))))
        print(
            f"  {label}, preset {preset}: {len(eb)} switches, {n_stick} stick phases; sign() vs automaton: "
            f"switch times {dt:.2g} s, states {dx:.2g}; stick vs closed form: exit times {d_exit:.2g} s, "
            f"x inside {d_x:.2g} m"
        )
        if not options.method.flows_exact:  # each IDA run against the exact flow of the same model
            ex = SolverOptions(method=Exact())
            ra = simulate(a, p, (0.0, 200.0), {"x": 0.0, "v": 0.0}, mode0="slip-", options=ex)
            rb = simulate(b, p, (0.0, 200.0), {"x": 0.0, "v": 0.0}, options=ex)
            da = max(abs(x.t - y.t) for x, y in zip(ta.events, ra.events, strict=True))
            db = max(abs(x.t - y.t) for x, y in zip(tb.events, rb.events, strict=True))
            print(f"    switch times against the exact flow: automaton {da:.2g} s, sign() {db:.2g} s")


def main() -> None:
    print(f"uptime: {os.popen('uptime').read().strip()}")
    print(f"Coulomb oscillator, Omega in {OMEGAS}, R/F in {RATIOS} (m = k = 1, F = 0.5):")
    for integ in ("exact", "ida"):
        coulomb_study(
            SolverOptions(method=(IDA(rtol=1e-10, atol=1e-12) if integ == "ida" else method_named(integ))),
            integ,
        )
    print("Belt (200 s from rest):")
    for integ in ("exact", "ida"):
        belt_study(
            SolverOptions(method=(IDA(rtol=1e-10, atol=1e-12) if integ == "ida" else method_named(integ))),
            integ,
        )
    print(f"uptime: {os.popen('uptime').read().strip()}")


if __name__ == "__main__":
    main()
