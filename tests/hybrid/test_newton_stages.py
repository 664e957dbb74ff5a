"""Newton's method on the IDA path: its coarse first stage, the runs it reuses, and IDA's callbacks.

The references are independent of the code under test: the exact integrator
(``SolverOptions(method=Exact())``, matrix exponentials and exact guard roots) and the
compiled modes' own residual and Jacobian.
"""

import numpy as np
import pytest
from problems import nonlinear_dae, riccati

import hybrid
import hybrid.orbits.newton as newton
import hybrid.orbits.shooter as shooting
import hybrid_models
from hybrid import IDA, Exact, SolverOptions, periodic_orbit
from hybrid.integrators.ida import ModeSolver, SensitivitySolver
from hybrid.model.compiled import CompiledSystem

IDA_OPTS = SolverOptions(method=IDA(rtol=1e-10, atol=1e-12))
EXACT = SolverOptions(method=Exact())


@pytest.fixture(scope="module")
def absorber_neighbours():
    """An absorber orbit on its first stick-slip band (exact integrator) and the parameters of
    its neighbour 2e-4 rad/s above: the guess is 20 % of the state away from that orbit."""
    system = hybrid_models.absorber()
    base = system.preset("standard")
    p0 = {**base, "Omega": 0.8544}
    start = periodic_orbit(system, p0, options=EXACT)
    assert start.converged, start.message
    return system, start, {**base, "Omega": 0.8546}


def _counting(monkeypatch):
    """Count the runs and monodromies made, per relative tolerance."""
    count: dict[tuple[str, float], int] = {}
    run, mono = shooting.Shooter.run_now, shooting.Shooter.monodromy

    def _run(self, *args, **kwargs):
        key = ("run", self.options.method.noise_rtol)
        count[key] = count.get(key, 0) + 1
        return run(self, *args, **kwargs)

    def _mono(self, *args, **kwargs):
        key = ("monodromy", self.options.method.noise_rtol)
        count[key] = count.get(key, 0) + 1
        return mono(self, *args, **kwargs)

    monkeypatch.setattr(shooting.Shooter, "run_now", _run)
    monkeypatch.setattr(shooting.Shooter, "monodromy", _mono)
    return count


def _neighbour(system, start, p, options, tol=1e-9):
    return periodic_orbit(
        system,
        p,
        start.x0,
        start.mode0,
        t0=start.t0 * start.params["Omega"] / p["Omega"],  # the same forcing phase
        options=options,
        settings=hybrid.ShootingOptions(
            newton=hybrid.NewtonOptions(tol=tol), transient_periods=0, samples_per_period=16
        ),
    )


def test_orbit_from_a_neighbour_through_the_coarse_stage_is_as_accurate_as_requested(
    absorber_neighbours, monkeypatch
):
    system, start, p = absorber_neighbours
    count = _counting(monkeypatch)
    o = _neighbour(system, start, p, IDA_OPTS)
    assert o.converged, o.message
    # the first iterations ran at the coarse tolerance, the result at the requested one
    assert count.get(("run", newton.COARSE_RTOL), 0) >= 2
    assert count[("monodromy", IDA_OPTS.method.rtol)] == 1  # the result's, at its section state
    ref = periodic_orbit(
        system, p, o.x0, o.mode0, t0=o.t0, options=EXACT, settings=hybrid.ShootingOptions(transient_periods=0)
    )
    assert ref.converged
    assert ref.t0 == o.t0
    x, xr = o.x0[:5], ref.x0[:5]
    # accurate to cond(I - M) x rtol (the orbit's documented accuracy), here about 1e-7
    assert np.max(np.abs(x - xr)) / np.max(np.abs(xr)) <= 10 * o.condition * IDA_OPTS.method.rtol
    mu, mur = np.sort_complex(o.floquet_multipliers), np.sort_complex(ref.floquet_multipliers)
    assert np.max(np.abs(mu - mur)) <= 1e-7


def test_the_result_s_monodromy_is_the_one_at_its_section(absorber_neighbours):
    # made once, at the accepted state, and used both to judge the last correction and for the
    # multipliers: equal to the exact integrator's at the same section state
    system, start, p = absorber_neighbours
    o = _neighbour(system, start, p, IDA_OPTS)
    sh = shooting.Shooter(system, p, EXACT)
    M = sh.monodromy(sh.run(o.x0, o.mode0, o.t0))[:5, :5]
    assert np.max(np.abs(o.monodromy - M)) <= 1e-7 * np.max(np.abs(M))


def test_a_failing_coarse_stage_falls_back_on_the_requested_tolerances(absorber_neighbours, monkeypatch):
    system, start, p = absorber_neighbours
    mono = shooting.Shooter.monodromy

    def fails_when_coarse(self, tr):
        if self.options.method.noise_rtol == newton.COARSE_RTOL:
            raise RuntimeError("IDA failed in the variational equations")
        return mono(self, tr)

    monkeypatch.setattr(shooting.Shooter, "monodromy", fails_when_coarse)
    o = _neighbour(system, start, p, IDA_OPTS)
    assert o.converged, o.message
    ref = periodic_orbit(
        system, p, o.x0, o.mode0, t0=o.t0, options=EXACT, settings=hybrid.ShootingOptions(transient_periods=0)
    )
    assert np.max(np.abs(o.x0[:5] - ref.x0[:5])) / np.max(np.abs(ref.x0[:5])) <= 10 * o.condition * 1e-10


def test_no_coarse_stage_where_it_cannot_save_anything(absorber_neighbours, monkeypatch):
    system, start, p = absorber_neighbours
    count = _counting(monkeypatch)
    # At rtol 2e-9 the residual of the period map is resolved to about 1e-9 only (the final
    # residuals from guesses 1e-13 apart: 1e-10 to 1.3e-9): the tolerance asked of it is 1e-8.
    for options, tol in ((SolverOptions(method=IDA(rtol=2e-9, atol=2e-11)), 1e-8), (EXACT, 1e-9)):
        count.clear()
        o = _neighbour(system, start, p, options, tol)
        assert o.converged, o.message
        assert all(rtol == options.method.noise_rtol for _, rtol in count), count


def _models():
    for name, build in hybrid_models.BUILTIN.items():
        system = build()
        yield name, system, system.preset(next(iter(system.presets)))
    for make in (riccati, nonlinear_dae):
        system, params, _, _ = make()
        yield system.name, system, params


@pytest.mark.parametrize(("name", "system", "params"), list(_models()), ids=[m[0] for m in _models()])
def test_ida_callbacks_are_the_compiled_residual_and_jacobian(name, system, params):
    # the callbacks call the generated functions directly: the same values as the CompiledMode's
    cs = CompiledSystem(system, params)
    rng = np.random.default_rng(7)
    for cm in cs.modes:
        solver = ModeSolver(cm, rtol=1e-8, atol=np.full(cm.n, 1e-10), max_step=0.1, max_num_steps=500)
        for _ in range(3):
            t, cj = float(rng.uniform(0, 5)), float(rng.uniform(0.1, 1e3))
            y, yp = rng.uniform(0.5, 2.0, cm.n), rng.standard_normal(cm.n)
            r1, r2 = np.zeros(cm.n), np.zeros(cm.n)
            solver._resfn(t, y, yp, r1)
            cm.residual(t, y, yp, r2)
            assert np.array_equal(r1, r2)
            J1, J2 = np.full((cm.n, cm.n), np.nan), np.zeros((cm.n, cm.n))
            solver._jacfn(t, y, yp, r1, cj, J1)
            cm.jacobian(t, y, cj, J2)
            assert np.allclose(J1, J2, rtol=1e-15, atol=0.0)


@pytest.mark.parametrize(("name", "system", "params"), list(_models()), ids=[m[0] for m in _models()])
def test_variational_callbacks_are_the_linearised_dae(name, system, params):
    # residual mask * Y' + dF/dy Y of every column of Y (stored column by column after y), and
    # the block-diagonal Newton matrix, written out plainly
    cs = CompiledSystem(system, params)
    rng = np.random.default_rng(11)
    s = np.array([i for i, v in enumerate(system.variable_names) if v not in system.quadratures])
    ns = s.size
    for cm in cs.modes:
        n, N = cm.n, cm.n + ns * ns
        sv = SensitivitySolver(
            cm, s, rtol=1e-8, atol=np.full(n, 1e-10), atol_sens=1e-8, max_step=0.1, max_num_steps=500
        )
        mask = cm.is_diff[s].astype(float)
        for _ in range(3):
            t, cj = float(rng.uniform(0, 5)), float(rng.uniform(0.1, 1e3))
            z, zp = rng.uniform(0.5, 2.0, N), rng.standard_normal(N)
            dFdy = cm.dFdy(t, z[:n])[np.ix_(s, s)]
            Y, Yp = z[n:].reshape((ns, ns), order="F"), zp[n:].reshape((ns, ns), order="F")
            ref = np.zeros(N)
            cm.residual(t, z[:n], zp[:n], ref)
            ref[n:] = (mask[:, None] * Yp + dFdy @ Y).ravel(order="F")
            got = np.full(N, np.nan)
            sv._resfn(t, z, zp, got)
            assert np.allclose(got, ref, rtol=1e-14, atol=1e-14)
            Jref = np.zeros((N, N))
            top = np.zeros((n, n))
            cm.jacobian(t, z[:n], cj, top)
            Jref[:n, :n] = top
            for j in range(ns):
                b = slice(n + j * ns, n + (j + 1) * ns)
                Jref[b, b] = dFdy + cj * np.diag(mask)
            Jgot = np.full((N, N), np.nan)
            sv._jacfn(t, z, zp, got, cj, Jgot)
            assert np.allclose(Jgot, Jref, rtol=1e-15, atol=0.0)
