"""The belt-driven stick-slip oscillators (issue 11) against closed forms derived in docs/selfexcited.md.

Coulomb stiction, no damping: stick from x = (2 Fk - Fs)/k to Fs/k at the belt speed, then a
harmonic slip about Fk/k from (Fs/k, v_b) until v returns to v_b. With d = (Fs - Fk)/k and
omega = sqrt(k/m): T = 2 d / v_b + (pi + 2 atan(v_b / (omega d))) / omega, half peak-to-peak of
x = sqrt(d^2 + (v_b/omega)^2). Stribeck friction mu(s) = Fk + (Fs - Fk) exp(-s/vs) + cf s:
steady sliding at x* = mu(v_b)/k, eigenvalues of m l^2 + (c + mu'(v_b)) l + k = 0, Hopf at
v_b* = vs ln((Fs - Fk) / (vs (c + cf))).
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

import hybrid
import hybrid_models
from hybrid import (
    IDA,
    NewtonOptions,
    SolverOptions,
    autonomous_orbit,
    equilibrium,
    hopf_branch,
    locate_hopf,
    method_named,
    orbit_branch,
    simulate,
)
from hybrid.continuation.autonomous import AUTONOMOUS_CONTINUATION

P = {"m": 2.0, "k": 3.0, "c": 0.0, "Fs": 1.2, "Fk": 0.5}


def closed_form(v_b: float, m=P["m"], k=P["k"], Fs=P["Fs"], Fk=P["Fk"]) -> tuple[float, float]:
    d, om = (Fs - Fk) / k, math.sqrt(k / m)
    return 2 * d / v_b + (math.pi + 2 * math.atan(v_b / (om * d))) / om, math.hypot(d, v_b / om)


@pytest.mark.parametrize(("integrator", "rtol", "err"), [("exact", 1e-10, 1e-9), ("ida", 1e-10, 1e-7)])
def test_coulomb_stick_slip_cycle_against_closed_form(integrator, rtol, err):
    belt = hybrid_models.belt()
    opts = SolverOptions(
        method=(IDA(rtol=rtol, atol=rtol * 1e-2) if integrator == "ida" else method_named(integrator))
    )
    for v_b in (0.13, 0.41, 0.97, 2.3):
        T, A = closed_form(v_b)
        for phase in ("auto", "anchor"):
            o = autonomous_orbit(
                belt,
                {**P, "v_b": v_b},
                phase=phase,
                options=opts,
                settings=hybrid.ShootingOptions(newton=hybrid.NewtonOptions(tol=1e-12)),
            )
            assert o.converged, o.message
            assert abs(o.period / T - 1) <= err, (v_b, phase)
            assert abs(o.half_peak_to_peak["x"] / A - 1) <= err, (v_b, phase)
            triv = o.multipliers[o.multiplier_kinds.index("trivial")]
            assert abs(triv - 1) <= 1e-8
            assert o.stability == "stable"
            assert o.mode_fractions.keys() == {"stick", "slip-"}


def mu(s, p):
    return p["Fk"] + (p["Fs"] - p["Fk"]) * math.exp(-s / p["vs"]) + p["cf"] * s


@pytest.mark.parametrize("cf", [0.0, 0.04])
def test_stribeck_steady_sliding_and_hopf_against_closed_form(cf):
    belt = hybrid_models.belt_stribeck()
    p = belt.preset("standard", cf=cf, m=1.3)
    for v_b in (0.6, 1.7):
        q = {**p, "v_b": v_b}
        eq = equilibrium(belt, q, "slip-", {"x": 0.5, "w": -v_b})
        assert eq.converged, eq.message
        assert eq.admissible
        assert abs(eq.state("x") - mu(v_b, q) / q["k"]) <= 1e-12
        assert abs(eq.state("w") + v_b) <= 1e-12
        slope = -(q["Fs"] - q["Fk"]) / q["vs"] * math.exp(-v_b / q["vs"]) + cf  # mu'(v_b)
        lam = np.roots([q["m"], q["c"] + slope, q["k"]])
        assert np.allclose(
            sorted(eq.eigenvalues, key=lambda z: z.imag),
            sorted(lam, key=lambda z: z.imag),
            rtol=0,
            atol=1e-12,
        )
    v_star = p["vs"] * math.log((p["Fs"] - p["Fk"]) / (p["vs"] * (p["c"] + cf)))
    hp = locate_hopf(belt, p, "slip-", "v_b", (0.6, 2.5), {"x": 0.5, "w": -0.6})
    assert hp.kind == "hopf"
    assert hp.status == "located"
    assert abs(hp.parameter - v_star) <= 1e-10 * v_star
    assert hp.interval[0] <= hp.parameter <= hp.interval[1]
    assert hp.equilibrium.params["v_b"] == hp.parameter
    assert abs(abs(hp.equilibrium.eigenvalues[0].imag) - math.sqrt(p["k"] / p["m"])) <= 1e-10
    assert hp.frequency == abs(hp.equilibrium.eigenvalues[0].imag)


@pytest.mark.slow
def test_stribeck_hopf_branch_meets_the_stick_slip_branch_at_a_grazing():
    belt = hybrid_models.belt_stribeck()
    p = belt.preset("standard")
    hp = locate_hopf(belt, p, "slip-", "v_b", (0.6, 2.5), {"x": 0.5, "w": -0.6})
    v_h, eq = hp.parameter, hp.equilibrium
    # orbits periodic to 1e-11
    settings = replace(
        AUTONOMOUS_CONTINUATION, ds=0.04, ds_max=0.15, newton=NewtonOptions(tol=1e-11, max_iter=8)
    )
    opts = SolverOptions(
        method=IDA(rtol=1e-12, atol=1e-14)
    )  # the trivial multiplier to 1e-8 (7e-8 at rtol 1e-10)
    smooth = hopf_branch(eq, "v_b", (0.3, 3.0), settings=settings, options=opts)
    assert smooth.status == "stopped"
    assert smooth.reason == "grazing"
    assert all(o.stability == "unstable" for o in smooth.points)  # subcritical (the cubic term of mu)
    assert all(set(o.mode_sequence) == {"slip-"} for o in smooth.points)
    assert all(o.params["v_b"] > v_h for o in smooth.points)
    # near the Hopf point the period tends to 2 pi / omega
    assert abs(smooth.points[0].period - 2 * math.pi) <= 1e-4
    cycle = autonomous_orbit(belt, p, options=opts)
    stick_slip = orbit_branch(cycle, "v_b", (0.3, 3.0), settings=settings, options=opts)
    assert stick_slip.reason == "grazing"
    assert all(o.stability == "stable" for o in stick_slip.points)
    # both branches end where the cycle touches w = 0 (independent computations of one point)
    assert abs(smooth.values[-1] - stick_slip.values[-1]) <= 1e-5
    for o in smooth.points + stick_slip.points:
        triv = o.multipliers[o.multiplier_kinds.index("trivial")]
        assert abs(triv - 1) <= 1e-8


def test_long_simulation_from_steady_sliding_settles_on_the_cycle():
    belt = hybrid_models.belt_stribeck()
    p = belt.preset("standard")  # v_b = 0.8 < v_b*: steady sliding is unstable
    cycle = autonomous_orbit(belt, p)
    assert cycle.converged, cycle.message
    assert cycle.stability == "stable"
    x_star = mu(p["v_b"], p) / p["k"]
    tr = simulate(
        belt,
        p,
        (0.0, 400.0),
        {"x": x_star + 1e-3, "w": -p["v_b"]},
        mode0="slip-",
        options=SolverOptions(method=IDA(rtol=1e-10, atol=1e-12)),
    )
    hits = [e for e in tr.events if e.guard == "breakaway-"]
    assert len(hits) >= 10
    assert hits[0].t > 100.0  # it took the slow growth before the first stick
    assert abs((hits[-1].t - hits[-2].t) / cycle.period - 1) <= 1e-8
    assert np.max(np.abs(hits[-1].x_plus - cycle.x0)) <= 1e-8
