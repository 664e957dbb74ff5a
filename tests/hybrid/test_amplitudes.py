"""Amplitudes of periodic orbits located on the flow, not read from samples (issue 7, item 3).

References: the closed-form steady state of a linear forced oscillator, and a dense
tight-tolerance re-simulation of a stick-slip orbit around each extremum.
"""

from __future__ import annotations

import numpy as np
import pytest
from orbit_problems import forced_linear_2dof

import hybrid
import hybrid_models
from hybrid import IDA, Exact, SolverOptions, periodic_orbit, simulate


def closed_form_amplitudes(p: dict) -> dict[str, float]:
    """``|X|`` and ``Omega |X|`` of ``X = (K - Omega^2 M + i Omega C)^{-1} f`` for the two-mass chain."""
    M = np.diag([p["m1"], p["m2"]])
    K = np.array([[p["k1"] + p["k2"], -p["k2"]], [-p["k2"], p["k2"]]])
    C = np.array([[p["c1"] + p["c2"], -p["c2"]], [-p["c2"], p["c2"]]])
    w = p["Omega"]
    X = np.linalg.solve(K - w**2 * M + 1j * w * C, np.array([p["F"], 0.0]))
    return {"x1": abs(X[0]), "x2": abs(X[1]), "v1": w * abs(X[0]), "v2": w * abs(X[1]), "force": p["F"]}


@pytest.mark.parametrize("samples", [64, 512])
def test_amplitudes_of_a_linear_oscillator_match_the_closed_form(samples):
    system, p, _ = forced_linear_2dof()
    o = periodic_orbit(
        system, p, settings=hybrid.ShootingOptions(transient_periods=200, samples_per_period=samples)
    )
    assert o.converged, o.message
    for name, a in closed_form_amplitudes(p).items():
        assert o.amplitude[name] == pytest.approx(a, rel=1e-9), name
        # half peak-to-peak equals the amplitude for a harmonic response
        assert o.half_peak_to_peak[name] == pytest.approx(a, rel=1e-9), name


def test_sampled_maximum_alone_would_miss_the_closed_form():
    # the check above can fail: the largest sample of 64 per period is off by about 1e-3
    system, p, _ = forced_linear_2dof()
    o = periodic_orbit(
        system, p, settings=hybrid.ShootingOptions(transient_periods=200, samples_per_period=64)
    )
    a = closed_form_amplitudes(p)["x2"]
    sampled = float(np.max(np.abs(o.trajectory["x2"])))
    assert abs(sampled - a) / a > 1e-5


def test_stick_slip_amplitudes_match_a_dense_tight_resimulation():
    system = hybrid_models.absorber()
    p = system.preset("standard", Omega=0.854)
    tight = SolverOptions(method=IDA(rtol=1e-12, atol=1e-14))
    o = periodic_orbit(
        system, p, options=tight, settings=hybrid.ShootingOptions(newton=hybrid.NewtonOptions(tol=1e-11))
    )
    assert o.converged, o.message
    tr = o.trajectory
    T = o.period
    names = [n for n in system.variable_names if n not in system.quadratures]
    # dense samples (spacing ~1e-5 of the period) around each sampled extremum, both sides of the switches
    windows = []
    for n in names:
        x = tr[n]
        for k in (int(np.argmax(x)), int(np.argmin(x))):
            windows.append(np.linspace(tr.t[k] - T / 256, tr.t[k] + T / 256, 801))
    t_eval = np.unique(np.clip(np.concatenate(windows), o.t0, o.t0 + T))
    x0 = dict(zip(system.variable_names, o.x0, strict=True))
    dense = simulate(
        system, p, (o.t0, o.t0 + T), x0, o.mode0, t_eval=t_eval, include_events=True, options=tight
    )
    for n in names:
        ref = float(np.max(np.abs(dense[n])))
        assert o.amplitude[n] == pytest.approx(ref, rel=1e-9), n


@pytest.mark.slow
def test_an_extremum_just_after_a_switch_is_found():
    """The isolator at Omega = 0.8528166 (standard preset): v1 is largest 5.4 ms after the stick -> slip+
    switch, while the largest *sample* is the switch itself. The refinement must look on the slip side
    of the switch too (it used to return the switch value, 1.05e-5 low). Reference: the largest of
    200 000 samples per period of a tight re-simulation (spacing 3.7e-5 s: its error is below
    v1'' h^2 / 8 ~ 1e-10 relative)."""
    system = hybrid_models.isolator()
    p = system.preset("standard", Omega=0.8528166451871718)
    tight = SolverOptions(method=IDA(rtol=1e-12, atol=1e-14))
    o = periodic_orbit(system, p, options=SolverOptions(method=Exact()))
    assert o.converged, o.message
    x0 = dict(zip(system.variable_names, o.x0, strict=True))
    dense = simulate(
        system, p, (o.t0, o.t0 + o.period), x0, o.mode0, samples_per_period=200_000, options=tight
    )
    k = int(np.argmax(np.abs(dense["v1"])))
    switch = min(abs(e.t - dense.t[k]) for e in dense.events)
    assert 1e-3 < switch < 1e-2  # the extremum lies a few ms from a switch
    for n in ("x1", "v1", "x2", "v2", "u"):
        assert o.amplitude[n] == pytest.approx(float(np.max(np.abs(dense[n]))), rel=2e-9), n


def test_an_extreme_sample_at_the_end_of_the_period_is_refined_across_the_wrap():
    # The first and last samples of an orbit are the same state one period apart: an extremum of
    # `x` next to that sample lies in the interval before the last sample or after the first. Found
    # by the sweep's closed-form test (issue 10): along this branch half peak-to-peak was up to
    # 2.7e-4 low where the minimum of `x` fell at the section.
    from problems import forced_oscillator

    from hybrid import ContinuationOptions, frequency_response

    system, p, _, _ = forced_oscillator(k=0.8)
    fr = frequency_response(
        system,
        p,
        (0.5, 1.5),
        options=SolverOptions(method=Exact()),
        settings=ContinuationOptions(locate=False),
    )
    orbits = [o for b in fr.branches for o in b.points]
    at_ends = 0
    for o in orbits:
        x = np.asarray(o.trajectory["x"])
        at_ends += np.argmin(x) in (0, x.size - 1) or np.argmax(x) in (0, x.size - 1)
        w = o.params["Omega"]
        exact = abs(p["F"] / (p["k"] - p["m"] * w**2 + 1j * p["c"] * w))
        assert o.half_peak_to_peak["x"] == pytest.approx(exact, rel=1e-8), w
        assert o.amplitude["x"] == pytest.approx(exact, rel=1e-8), w
    assert at_ends >= 1  # the case in point occurs on this branch
