"""Newton in the switch times of a fixed sequence (hybrid.orbits.sequence) against independent references.

* its Jacobian against central finite differences of its own equations;
* the forced Coulomb oscillator's non-stop orbit (a reset ``v = 0`` and a chained switch at each
  stop) against Den Hartog's closed-form amplitude;
* the absorber's stick-slip orbits found through it equal those of Newton's method on the
  period map alone (the candidate switched off), with fewer runs of the map;
* where it does not apply (no switch, switch times out of order) it says so (None).
"""

from __future__ import annotations

import numpy as np
import pytest

import hybrid
import hybrid.orbits.newton as newton
import hybrid_models
from hybrid import Exact, SolverOptions, load_system, periodic_orbit
from hybrid.integrators.flows import exact_flows
from hybrid.orbits.sequence import Switch, _jumps, _residual, sequence_events, solve_sequence
from hybrid.orbits.shooter import Shooter
from hybrid_models.coulomb_exact import den_hartog

EXACT = SolverOptions(method=Exact())


def _neighbour_guess(system, preset, om1, om2):
    """The orbit at ``om1`` and the run of one period from it at ``om2`` (the section's phase kept)."""
    o1 = periodic_orbit(
        system,
        system.preset(preset, Omega=om1),
        options=EXACT,
        settings=hybrid.ShootingOptions(newton=hybrid.NewtonOptions(tol=1e-12)),
    )
    assert o1.converged, o1.message
    sh = Shooter(system, system.preset(preset, Omega=om2), EXACT)
    t0 = o1.t0 * om1 / om2
    tr = sh.run(o1.x0, o1.mode0, t0)
    return o1, sh, t0, tr


def test_jacobian_equals_finite_differences():
    ab = hybrid_models.absorber()
    o1, sh, t0, tr = _neighbour_guess(ab, "standard", 0.8536, 0.8538)
    events = sequence_events(tr, sh.cs, t0, sh.period)
    assert events is not None
    assert len(events) == 4
    modes = exact_flows(sh.cs)
    m0 = sh.cs.mode_id(o1.mode0)
    a0 = modes[m0]
    nd = a0.d.size
    seq = [m0] + [sw.target for sw in events]
    jumps = _jumps(modes, events)
    forcing0 = a0.augment(t0, np.zeros(len(ab.variable_names)))[nd:]
    u = np.concatenate([o1.x0[a0.d], [sw.t for sw in events]])

    def F(u):
        times = np.concatenate([[t0], u[nd:], [t0 + sh.period]])
        return _residual(modes, seq, jumps, events, u, nd, forcing0, times)

    _, JF = F(u)
    fd = np.empty_like(JF)
    for j in range(u.size):
        h = 1e-6 * max(1.0, abs(u[j]))
        up, um = u.copy(), u.copy()
        up[j] += h
        um[j] -= h
        fd[:, j] = (F(up)[0] - F(um)[0]) / (2 * h)
    assert np.max(np.abs(JF - fd)) <= 1e-7 * np.max(np.abs(JF))


def test_coulomb_non_stop_orbit_equals_den_hartog():
    """Each stop of the non-stop motion is a reset (v = 0) into stick and, at the same instant, a
    chained break-away: both enter the jump of one switch instant."""
    co = hybrid_models.coulomb()
    o1, sh, t0, tr = _neighbour_guess(co, "forced", 0.8, 0.83)
    events = sequence_events(tr, sh.cs, t0, sh.period)
    assert events is not None
    assert len(events) == 2  # two instants, each a stop and a break-away
    assert all(len(sw.steps) == 2 for sw in events)
    assert any(ev.chained for ev in tr.events)
    assert any(
        sh.cs.modes[sh.cs.mode_id(ev.source)].guards[0].reset_expr for ev in tr.events if not ev.chained
    )
    m0 = sh.cs.mode_id(o1.mode0)
    yd = solve_sequence(exact_flows(sh.cs), m0, t0, sh.period, o1.x0, events)
    assert yd is not None
    o2 = periodic_orbit(co, co.preset("forced", Omega=0.83), o1.x0, o1.mode0, t0=t0, options=EXACT, settings=hybrid.ShootingOptions(newton=hybrid.NewtonOptions(tol=1e-12), transient_periods=0))  # fmt: skip
    assert o2.converged
    np.testing.assert_allclose(yd, o2.x0[exact_flows(sh.cs)[m0].d], rtol=0, atol=1e-12)
    p = co.preset("forced")
    assert o2.amplitude["x"] == pytest.approx(den_hartog(p["m"], p["k"], p["R"], p["F"], 0.83), rel=1e-11)


@pytest.mark.slow
def test_absorber_band_orbits_equal_plain_newton_with_fewer_runs(monkeypatch):
    ab = hybrid_models.absorber()
    base = ab.preset("standard")
    start = periodic_orbit(
        ab,
        {**base, "Omega": 0.8542},
        options=EXACT,
        settings=hybrid.ShootingOptions(newton=hybrid.NewtonOptions(tol=1e-12)),
    )
    assert start.converged
    runs = {"n": 0}
    real_run = Shooter.run_now

    def counted(self, *args, **kw):
        runs["n"] += 1
        return real_run(self, *args, **kw)

    monkeypatch.setattr(Shooter, "run_now", counted)

    def chain():
        out, counts, prev, om_prev = [], [], start, 0.8542
        for om in (0.8544, 0.8546, 0.8548, 0.855):
            runs["n"] = 0
            o = periodic_orbit(ab, {**base, "Omega": om}, prev.x0, prev.mode0, t0=prev.t0 * om_prev / om, options=EXACT, settings=hybrid.ShootingOptions(newton=hybrid.NewtonOptions(tol=1e-10), transient_periods=0))  # fmt: skip
            assert o.converged, o.message
            out.append(o)
            counts.append(runs["n"])
            prev, om_prev = o, om
        return out, counts

    fast, fast_runs = chain()
    monkeypatch.setattr(newton, "_sequence_candidate", lambda *a, **k: None)
    plain, plain_runs = chain()
    for a, b in zip(fast, plain, strict=True):
        assert a.mode_sequence == b.mode_sequence
        assert a.t0 == b.t0
        assert np.max(np.abs(a.x0 - b.x0)) <= 1e-9 * np.max(np.abs(b.x0))
        dmu = np.max(np.abs(np.sort_complex(a.multipliers) - np.sort_complex(b.multipliers)))
        assert dmu <= 1e-9
    # a run from the guess and the sampled run of the candidate: the orbit in two runs
    assert all(n == 2 for n in fast_runs), fast_runs
    assert all(n >= 4 for n in plain_runs), plain_runs


def test_does_not_apply_without_switches_or_with_times_out_of_order():
    ab = hybrid_models.absorber()
    o1, sh, t0, tr = _neighbour_guess(ab, "standard", 0.8536, 0.8538)
    events = sequence_events(tr, sh.cs, t0, sh.period)
    m0 = sh.cs.mode_id(o1.mode0)
    modes = exact_flows(sh.cs)
    assert solve_sequence(modes, m0, t0, sh.period, o1.x0, []) is None
    swapped = [Switch(events[1].t, events[0].steps), Switch(events[0].t, events[1].steps), *events[2:]]
    assert solve_sequence(modes, m0, t0, sh.period, o1.x0, swapped) is None
    # a sequence that does not return to the section's mode
    assert solve_sequence(modes, m0, t0, sh.period, o1.x0, events[:-1]) is None


IMPACT = """
[model]
name = "impact"
period = "2*pi/Omega"
initial_mode = "free"
[variables.x]
[variables.v]
[parameters.z]
[parameters.e]
[parameters.g]
[parameters.F]
[parameters.Omega]
[presets.standard]
z = 0.05
e = 0.7
g = 1.0
F = 1.0
Omega = 1.4256
[equations]
x = "v"
v = "F*cos(Omega*t) - 2*z*v - x"
[modes.free]
[[transitions]]
name = "hit"
source = "free"
target = "free"
guard = "x - g"
direction = 1
reset = { v = "RESET" }
"""


def _impact(tmp_path, reset="-e*v"):
    path = tmp_path / "impact.toml"
    path.write_text(IMPACT.replace("RESET", reset))
    return load_system(path)


def test_a_guess_outside_newtons_contraction_keeps_the_branch(tmp_path, monkeypatch):
    """An impact oscillator with two orbits of one impact per period at Omega = 1.6923 (found by
    the review of this module): from the stable orbit at 1.4256 (19 % away) Newton's method on
    the period map reaches the stable one; the switch-time iteration, whose updates there do not
    contract, is given up instead of being followed to the unstable one."""
    s = _impact(tmp_path)
    p = periodic_orbit(
        s,
        s.preset("standard"),
        options=EXACT,
        settings=hybrid.ShootingOptions(newton=hybrid.NewtonOptions(tol=1e-12)),
    )
    assert p.converged
    assert p.stable
    q = s.preset("standard", Omega=1.6923)

    def solve():
        o = periodic_orbit(s, q, p.x0, p.mode0, t0=p.t0 * 1.4256 / 1.6923, options=EXACT, settings=hybrid.ShootingOptions(newton=hybrid.NewtonOptions(tol=1e-12), transient_periods=0))  # fmt: skip
        assert o.converged, o.message
        return o

    with_sequence = solve()
    monkeypatch.setattr(newton, "_sequence_candidate", lambda *a, **k: None)
    plain = solve()
    assert plain.stable
    assert with_sequence.stable
    assert np.max(np.abs(with_sequence.x0 - plain.x0)) <= 1e-10 * np.max(np.abs(plain.x0))


def test_a_reset_that_is_not_affine_is_not_linearised(tmp_path):
    s = _impact(tmp_path, reset="-e*v - 0.01*v*v")
    p = periodic_orbit(
        s,
        s.preset("standard"),
        options=EXACT,
        settings=hybrid.ShootingOptions(newton=hybrid.NewtonOptions(tol=1e-12)),
    )
    assert p.converged
    assert len(p.switch_times) == 1
    sh = Shooter(s, s.preset("standard"), EXACT)
    tr = sh.run(p.x0, p.mode0, p.t0)
    assert sequence_events(tr, sh.cs, p.t0, sh.period) is None
    affine = _impact(tmp_path, reset="-e*v - 0.01")
    sh = Shooter(affine, affine.preset("standard"), EXACT)
    assert sequence_events(sh.run(p.x0, p.mode0, p.t0), sh.cs, p.t0, sh.period) is not None
