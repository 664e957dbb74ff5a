"""Cold starts that find the orbit (issue 7, item 4; ``hybrid/continuation/coldstart.py``).

Where Newton's method from a 10-period transient fails (close to a peak, Floquet multipliers
0.99 and more), :func:`hybrid.periodic_orbit` falls back on a continuation in the forcing
frequency. Its orbit is checked against an independent route: a continuation started on the
other side of the requested frequency (from a pure-stick orbit of the undamped stuck system
below the first stick-slip band), corrected at exactly that frequency from the branch's nearest
point. The two orbits have different sections: the fallback's is carried to the reference's
section time by a tight run (rtol 1e-12) before the states are compared.
"""

from __future__ import annotations

import json
import re
from dataclasses import replace

import numpy as np
import pytest

import hybrid
from hybrid import (
    IDA,
    ContinuationOptions,
    SolverOptions,
    continue_orbits,
    periodic_orbit,
    resolve_model,
    simulate,
)
from hybrid.cli import main
from hybrid.continuation.coldstart import find_by_continuation
from hybrid.model.linear import natural_frequencies

TIGHT = SolverOptions(method=IDA(rtol=1e-12, atol=1e-14))


def _route_start(route: str) -> float:
    assert route.startswith("continuation in Omega from "), route
    return float(route.rsplit(" ", 1)[1])


def _state_at(orbit, t: float) -> np.ndarray:
    """The orbit's state at time ``t`` (modulo the period), by a tight run from its section."""
    T = orbit.period
    dt = (t - orbit.t0) % T
    if dt < 1e-12 * T:
        return orbit.x0.copy()
    tr = simulate(orbit.system, orbit.params, (orbit.t0, orbit.t0 + dt), orbit.x0, orbit.mode0, options=TIGHT)
    return tr.y_final.copy()


def _reference(system, params, start: float):
    """The orbit at ``params`` on a continuation from ``Omega = start``: the branch's point nearest
    ``params["Omega"]``, corrected there (Newton from that point, no transient)."""
    om = params["Omega"]
    br = continue_orbits(system, params, "Omega", (start, om), settings=ContinuationOptions(locate=False))
    ps = br.values
    assert ps.size, br.message
    assert (ps.min() - om) * (ps.max() - om) <= 0, br.message  # it passed through om
    o = br.points[int(np.argmin(np.abs(ps - om)))]
    ref = periodic_orbit(
        system,
        params,
        o.x0,
        o.mode0,
        t0=o.t0 / o.period * (2 * np.pi / om),
        settings=hybrid.ShootingOptions(transient_periods=0),
    )
    assert ref.converged, ref.message
    return ref


def _relative_difference(orbit, ref) -> float:
    names = orbit.system.variable_names
    keep = [i for i, n in enumerate(names) if n not in orbit.system.quadratures]
    x = _state_at(orbit, ref.t0)[keep]
    y = ref.x0[keep]
    return float(np.max(np.abs(x - y)) / np.max(np.abs(y)))


def _polished(orbit):
    """The orbit corrected at rtol 1e-12 from its own section (Newton, no transient)."""
    o = periodic_orbit(
        orbit.system,
        orbit.params,
        orbit.x0,
        orbit.mode0,
        t0=orbit.t0,
        options=TIGHT,
        settings=hybrid.ShootingOptions(transient_periods=0),
    )
    assert o.converged, o.message
    return o


def _check_against_independent_continuation(orbit, system, params) -> None:
    start = _route_start(orbit.route)
    w1 = float(natural_frequencies(system, params)[0])
    # a start on the other side of Omega (below the peak of the stuck system, where Newton from a
    # transient converges), which the fallback did not take
    other = w1 * (1 - 5e-4)
    assert (other - params["Omega"]) * (start - params["Omega"]) < 0
    ref = _reference(system, params, other)
    assert ref.mode_sequence
    assert set(ref.mode_sequence) == set(orbit.mode_sequence)
    assert np.allclose(np.abs(orbit.floquet_multipliers), np.abs(ref.floquet_multipliers), rtol=0, atol=1e-6)
    # at the default rtol 1e-10 each orbit is accurate to about cond(I - M) x rtol
    assert _relative_difference(orbit, ref) <= 10 * max(orbit.condition, ref.condition) * 1e-10
    # both corrected at rtol 1e-12: the same orbit to 1e-8
    assert _relative_difference(_polished(orbit), _polished(ref)) <= 1e-8


def _fallback(system, params):
    """The fallback's orbit itself (whatever Newton from a transient does at ``params``)."""
    failed = periodic_orbit(
        system,
        params,
        settings=hybrid.ShootingOptions(newton=hybrid.NewtonOptions(max_iter=1), transient_periods=0),
    )
    assert not failed.converged
    assert failed.route == "none"
    o = find_by_continuation(
        system,
        params,
        failed,
        options=hybrid.ORBIT_OPTIONS,
        settings=hybrid.ShootingOptions(samples_per_period=512),
    )
    assert o.converged, o.message
    assert "found by continuation in Omega from" in o.message
    return o


def _check_cold_start(system, params) -> None:
    """From rest: converged, stable, and the orbit of the fallback and of an independent continuation."""
    cold = periodic_orbit(system, params)
    assert cold.converged, cold.message
    assert cold.stability == "stable"
    assert cold.transitions_per_period > 0
    assert np.max(np.abs(cold.floquet_multipliers)) < 1
    fb = cold if cold.route != "newton" else _fallback(system, params)
    assert fb.stability == "stable"
    _check_against_independent_continuation(fb, system, params)
    if fb is not cold:
        assert _relative_difference(cold, fb) <= 10 * max(cold.condition, fb.condition) * 1e-10


@pytest.mark.slow
def test_isolator_cold_start_close_to_the_first_peak_finds_the_stable_orbit():
    # issue 7: `hybrid orbit isolator --set R=0.9 --omega 0.85428` failed ("Newton's method did not
    # converge"), though `hybrid frc` passes through a stable stick-slip orbit there
    system = resolve_model("isolator")
    _check_cold_start(system, system.preset("standard", R=0.9, Omega=0.85428))


@pytest.mark.slow
def test_absorber_cold_start_at_the_stuck_resonance_finds_the_stable_orbit():
    # the absorber at its first natural frequency (the peak of the stuck system; Newton from the
    # 10-period transient failed there, "an orbit may still exist")
    system = resolve_model("absorber")
    base = system.preset("standard")
    _check_cold_start(system, {**base, "Omega": float(natural_frequencies(system, base)[0])})


def test_no_fallback_without_a_transient():
    # with transient_periods=0 the guess is the caller's section: Newton's result as it is
    system = resolve_model("absorber")
    o = periodic_orbit(
        system,
        system.preset("standard"),
        settings=hybrid.ShootingOptions(newton=hybrid.NewtonOptions(max_iter=1), transient_periods=0),
    )
    assert not o.converged
    assert o.route == "none"
    assert "fallback" not in o.message


def test_a_failed_fallback_says_what_it_tried(monkeypatch):
    # branches cut short (2 orbits each) never reach the requested frequency: each side is tried
    # once, and the result is Newton's failure with the fallback's attempts
    import hybrid.continuation.coldstart as cs

    real = cs.continue_orbits

    def short(*args, settings, **kwargs):
        return real(*args, settings=replace(settings, max_points=2), **kwargs)

    monkeypatch.setattr(cs, "continue_orbits", short)
    system = resolve_model("absorber")
    base = system.preset("standard")
    params = {**base, "Omega": float(natural_frequencies(system, base)[0])}
    failed = periodic_orbit(
        system,
        params,
        settings=hybrid.ShootingOptions(newton=hybrid.NewtonOptions(max_iter=1), transient_periods=0),
    )
    o = cs.find_by_continuation(
        system,
        params,
        failed,
        options=hybrid.ORBIT_OPTIONS,
        settings=hybrid.ShootingOptions(samples_per_period=64),
    )
    assert not o.converged
    assert o.route == "none"
    assert o.message.startswith(failed.message)
    assert "fallback (continuation in the forcing parameter)" in o.message
    tried = [float(x) for x in re.findall(r"continuation from Omega=([0-9.]+)", o.message)]
    assert len(tried) == 2
    assert min(tried) < params["Omega"] < max(tried)  # both sides, once each


def test_orbit_json_and_text_say_which_route_found_it(tmp_path, capsys):
    code = main(["orbit", "absorber", "--omega", "0.5", "--json", "--no-plot", "--out", str(tmp_path)])
    out = capsys.readouterr().out
    assert code == 0
    assert json.loads(out)["route"] == "newton"
    code = main(["orbit", "absorber", "--omega", "0.5", "--no-plot", "--out", str(tmp_path)])
    assert code == 0
    assert "found by: Newton's method" in capsys.readouterr().out
