"""The exact integrator for affine modes (issue 7): flows, guard roots and quadratures against closed forms.

References: the closed-form response of a forced undamped oscillator, cos/sin crossings at known
angles, the work integral of a harmonic force in closed form, and the reduced Jacobian of
:mod:`hybrid.model.linear` (slave variables eliminated independently).
"""

import math

import numpy as np
import pytest

import hybrid
import hybrid_models
from hybrid import (
    IDA,
    Exact,
    HybridSystem,
    Mode,
    NotAffineError,
    SolverOptions,
    Transition,
    method_named,
    simulate,
)
from hybrid.integrators.affine import affine_mode, affine_system
from hybrid.integrators.base import ROOT, TSTOP
from hybrid.integrators.exact import ExactModeSolver
from hybrid.model.compiled import CompiledSystem, lend
from hybrid.model.linear import reduced_jacobian


def _oscillator(guard: str | None = None, direction: int = 0, extra: dict | None = None) -> HybridSystem:
    """x'' + w0^2 x = F sin(W t + phi); W' = F sin(W t + phi) v (work)."""
    eqs = {"x": "v", "v": "-w0**2*x + F*sin(W*t + phi)", "P": "F*sin(W*t + phi)*v"}
    eqs.update(extra or {})
    return HybridSystem(
        name="osc",
        variables=["x", "v", "P"],
        parameters=["w0", "F", "W", "phi", "a"],
        modes=[Mode("free", derivatives=eqs)],
        transitions=[Transition("free", "free", guard=guard, direction=direction, name="hit")]
        if guard
        else [],
        quadratures=("P",),
        period="2*pi/W",
        initial_mode="free",
    )


PARAMS = {"w0": 1.3, "F": 0.7, "W": 0.9, "phi": 0.4, "a": 0.5}


def _exact_response(t, x0, v0, p):
    """Closed form of x'' + w0^2 x = F sin(W t + phi), x(0) = x0, x'(0) = v0 (W != w0)."""
    w0, F, W, phi = p["w0"], p["F"], p["W"], p["phi"]
    A = F / (w0**2 - W**2)
    xp = A * np.sin(W * t + phi)
    vp = A * W * np.cos(W * t + phi)
    c1 = x0 - A * math.sin(phi)
    c2 = (v0 - A * W * math.cos(phi)) / w0
    x = c1 * np.cos(w0 * t) + c2 * np.sin(w0 * t) + xp
    v = -c1 * w0 * np.sin(w0 * t) + c2 * w0 * np.cos(w0 * t) + vp
    return x, v


def _solver(system, params, max_step=0.3):
    cs = CompiledSystem(system, params)
    am = affine_system(cs)[0]
    return am, ExactModeSolver(am, max_step=max_step)


def test_forced_oscillator_and_its_work_integral_are_exact():
    am, ex = _solver(_oscillator(), PARAMS)
    assert am.omega == PARAMS["W"]
    x0, v0 = 0.3, -0.2
    ex.start(0.0, np.array([x0, v0, 0.0]), None)
    ts = np.linspace(0.0, 25.0, 11)[1:]
    for t in ts:
        r = ex.step(t, 30.0, one_step=False)
        x, v = _exact_response(t, x0, v0, PARAMS)
        assert r.t == t
        assert r.status != ROOT
        assert r.y[0] == pytest.approx(x, abs=1e-13)
        assert r.y[1] == pytest.approx(v, abs=1e-13)
    # work: int F sin(W t + phi) v dt, by Simpson on a fine grid of the closed form (error ~1e-13)
    tt = np.linspace(0.0, 25.0, 200_001)
    _, vv = _exact_response(tt, x0, v0, PARAMS)
    f = PARAMS["F"] * np.sin(PARAMS["W"] * tt + PARAMS["phi"]) * vv
    h = tt[1] - tt[0]
    work = h / 3 * (f[0] + f[-1] + 4 * f[1:-1:2].sum() + 2 * f[2:-1:2].sum())
    assert r.y[2] == pytest.approx(work, rel=1e-11)


def test_interpolation_inside_the_last_call_is_exact():
    _, ex = _solver(_oscillator(), PARAMS)
    ex.start(0.0, np.array([1.0, 0.0, 0.0]), None)
    ex.step(10.0, 10.0, one_step=False)
    for t in (0.1, 3.3, 9.99):
        y, yp = ex.interpolate(t)
        x, v = _exact_response(t, 1.0, 0.0, PARAMS)
        assert y[0] == pytest.approx(x, abs=1e-13)
        assert yp[0] == pytest.approx(v, abs=1e-13)


@pytest.mark.parametrize(("direction", "angle"), [(-1, math.acos(0.5)), (1, 2 * math.pi - math.acos(0.5))])
def test_guard_crossing_is_located_to_rounding(direction, angle):
    # free oscillation x = cos(w0 t): x = 1/2 falling at w0 t = pi/3, rising at 5 pi/3
    p = {**PARAMS, "F": 0.0}
    _, ex = _solver(_oscillator(guard="x - a", direction=direction), p, max_step=10.0)
    ex.start(0.0, np.array([1.0, 0.0, 0.0]), None)
    r = ex.step(20.0, 20.0, one_step=False)
    assert r.status == ROOT
    assert r.fired == (0,)
    assert r.t == pytest.approx(angle / p["w0"], rel=1e-14)
    assert abs(r.y[0] - 0.5) <= 1e-15


def test_two_crossings_within_one_step_are_not_missed():
    # x = cos(w0 t) passes x = 0.999 twice, 2 acos(0.999)/w0 = 0.0688 s apart around its maximum at
    # 2 pi / w0; a step of the full period would jump over both with a sign test at its ends.
    p = {**PARAMS, "F": 0.0, "a": 0.999}
    _, ex = _solver(_oscillator(guard="x - a", direction=1), p, max_step=2 * math.pi / p["w0"] * 0.9)
    ex.start(0.5, np.array([math.cos(0.5 * p["w0"]), -p["w0"] * math.sin(0.5 * p["w0"]), 0.0]), None)
    r = ex.step(20.0, 20.0, one_step=False)
    expected = (2 * math.pi - math.acos(0.999)) / p["w0"]
    assert r.status == ROOT
    assert r.t == pytest.approx(expected, rel=1e-13)


def test_step_to_tstop_without_crossing():
    _, ex = _solver(_oscillator(guard="x - 5", direction=0), {**PARAMS})
    ex.start(0.0, np.array([0.1, 0.0, 0.0]), None)
    r = ex.step(50.0, 7.0, one_step=False)
    assert r.status == TSTOP
    assert r.t == 7.0


def test_absorber_modes_reduce_to_the_linearisation_with_slave_variables_eliminated():
    absorber = hybrid_models.absorber()
    p = absorber.preset("standard", Omega=0.854)
    cs = CompiledSystem(absorber, p)
    for am in affine_system(cs):
        names, A = reduced_jacobian(absorber, p, am.cm.name)
        assert names == tuple(absorber.variable_names[i] for i in am.d)
        nd = am.d.size
        assert np.allclose(am.M[:nd, :nd], A, rtol=1e-14, atol=1e-14)
        assert am.omega == 0.854
        assert am.q.size == 2


def test_second_derivatives_of_a_mode_match_the_vector_field_along_the_flow():
    """y'' = P M^2 z (quadratures: z^T Q M z + (M z)^T Q z) against a central difference of the
    compiled mode's own y' (slave rows from the differentiated constraint) along the exact flow."""
    absorber = hybrid_models.absorber()
    p = absorber.preset("standard", Omega=0.854)
    cs = CompiledSystem(absorber, p)
    rng = np.random.default_rng(3)
    for am in affine_system(cs):
        assert am.q.size == 2  # the energy integrals: quadrature rows are checked too
        cm = am.cm
        for _ in range(3):
            t = float(rng.uniform(0.0, 7.0))
            y = cm.solve_algebraic(t, rng.normal(size=cm.n))
            z = am.augment(t, y)
            dt = 1e-4
            fl = am.flow()
            zp, zm = fl.advance(z, dt)[0], fl.advance(z, -dt)[0]
            # the vector field of the compiled mode (not of the affine analysis) at the flow's states
            yp_p = cm.derivatives(t + dt, am.state(zp, np.zeros(2)))
            yp_m = cm.derivatives(t - dt, am.state(zm, np.zeros(2)))
            fd = (yp_p - yp_m) / (2.0 * dt)
            ypp = am.second_derivatives(z)
            # the differential and slave rows: O(dt^2) = 1e-8 relative
            rows = [i for i in range(cm.n) if i not in am.q]
            assert np.allclose(ypp[rows], fd[rows], rtol=1e-7, atol=1e-7 * np.max(np.abs(ypp[rows])))
            # quadrature rows: d/dt of z^T Q z along the flow
            qp = np.array([zp @ Qj @ zp for Qj in am.Q])
            qm = np.array([zm @ Qj @ zm for Qj in am.Q])
            assert np.allclose(ypp[am.q], (qp - qm) / (2.0 * dt), rtol=1e-7, atol=1e-9)
            assert np.allclose(am.derivatives(z), cm.derivatives(t, y), rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize(
    ("extra", "match"),
    [
        ({"v": "-w0**2*x**3"}, r"derivative of `v` is not affine in `x`: its derivative is"),
        ({"v": "-sin(x)"}, r"derivative of `v` is not affine in `x`"),
        ({"v": "-x*t"}, r"derivative of `v` depends on `t`"),
        ({"v": "-x + exp(t)"}, r"time enters through `exp\(t\)`"),
        ({"v": "-x + sin(W*t) + sin(sqrt(2)*W*t)"}, r"not integer multiples of one base frequency"),
        ({"v": "-x + sin(t**2)"}, r"is not sin/cos of \(constant \* t \+ phase\)"),
        ({"P": "x**3"}, r"derivative of quadrature `P` is not quadratic in the state"),
    ],
)
def test_non_affine_modes_are_refused_naming_the_term(extra, match):
    cs = CompiledSystem(_oscillator(extra=extra), PARAMS)
    with pytest.raises(NotAffineError, match=match) as info:
        affine_mode(cs.modes[0], ("P",))
    assert str(info.value).startswith("mode `free`: ")


# ----------------------------------------------------------------------------
# The exact integrator inside the engine: simulate and periodic orbits against IDA
# ----------------------------------------------------------------------------
#: Branches of the first resonance band (the stick-slip band of the dampers, which ends in a family of
#: pure-stick orbits at Omega ~ 0.8559) and of the forced Coulomb oscillator.
BRANCHES = [
    ("absorber", "standard", [0.8532, 0.8538, 0.8545, 0.8552, 0.8555]),
    ("isolator", "standard", [0.8530, 0.8538, 0.8545, 0.8552, 0.8555]),
    ("coulomb", "forced", [0.6, 0.8, 1.2]),
]


@pytest.mark.slow
@pytest.mark.parametrize(("name", "preset", "omegas"), BRANCHES, ids=[b[0] for b in BRANCHES])
def test_exact_orbits_agree_with_ida_over_a_branch(name, preset, omegas):
    """Exact orbits followed along a branch (each from its neighbour) against IDA at rtol 1e-12 from the
    same section: amplitudes to 1e-7 relative, multipliers to 1e-6, switch times to 1e-8 of the period
    (measured: 2.2e-8, 7.1e-10 and 2.2e-8 s = 3e-9 T, the largest at the branch's first point, 0.8532)."""
    from hybrid import SolverOptions, periodic_orbit

    system = getattr(hybrid_models, name)()
    tight = SolverOptions(method=IDA(rtol=1e-12, atol=1e-14))
    exact = SolverOptions(method=Exact())
    prev = None
    for om in omegas:
        p = system.preset(preset, Omega=om)
        if prev is None:
            ex = periodic_orbit(
                system,
                p,
                options=exact,
                settings=hybrid.ShootingOptions(newton=hybrid.NewtonOptions(tol=1e-12)),
            )
        else:
            t0 = prev.t0 * prev.params["Omega"] / om  # same forcing phase
            ex = periodic_orbit(
                system,
                p,
                prev.x0,
                prev.mode0,
                t0=t0,
                options=exact,
                settings=hybrid.ShootingOptions(newton=hybrid.NewtonOptions(tol=1e-12), transient_periods=0),
            )
        ref = periodic_orbit(
            system,
            p,
            ex.x0,
            ex.mode0,
            t0=ex.t0,
            options=tight,
            settings=hybrid.ShootingOptions(newton=hybrid.NewtonOptions(tol=1e-11), transient_periods=0),
        )
        assert ref.converged, (om, ref.message, ex.message)
        assert ex.converged, (om, ref.message, ex.message)
        assert ex.residual <= 1e-12  # the exact map: Newton converges to rounding (IDA's to its tolerance)
        assert ref.t0 == ex.t0, om
        assert ex.mode_sequence == ref.mode_sequence, om
        # two stick phases on the dampers' band; the Coulomb oscillator slips throughout, each
        # reversal one switch through `stick`, held for no time (issue 30)
        assert len(ex.mode_sequence) == (3 if name == "coulomb" else 5), om
        assert ex.stability == ref.stability == "stable", om
        scale = max(abs(v) for v in ref.amplitude.values())
        for k, v in ref.amplitude.items():
            assert abs(ex.amplitude[k] - v) <= 1e-7 * max(abs(v), 1e-3 * scale), (om, k)
        mu_ref = np.sort_complex(ref.multipliers)
        assert np.max(np.abs(np.sort_complex(ex.multipliers) - mu_ref)) <= 1e-6, om
        # Switch times, a state error dx moving a switch by dx/|dh/dt|: 1e-8 of the period.
        dts = np.abs(np.asarray(ex.switch_times) - np.asarray(ref.switch_times))
        assert dts.max() <= 1e-8 * ex.period, (om, dts.max())
        prev = ex


@pytest.mark.parametrize(
    ("name", "preset"), [("absorber", "standard"), ("isolator", "standard"), ("coulomb", "forced")]
)
def test_parametric_analysis_equals_the_folded_one(name, preset):
    """The analysis done once on the system's expressions (parameters as symbols), evaluated at random
    parameter values, gives the M, P, Q, W of the analysis of the expressions with the values folded in."""
    from hybrid.integrators.affine import affine_flows

    system = getattr(hybrid_models, name)()
    base = system.preset(preset)
    rng = np.random.default_rng(7)
    for _ in range(5):
        p = {k: v * rng.uniform(0.5, 2.0) for k, v in base.items()}
        cs = CompiledSystem(system, p)
        for par, cm in zip(affine_flows(system, p), cs.modes, strict=True):
            fold = affine_mode(cm, tuple(system.quadratures))
            assert par.omega == fold.omega
            for f in ("M", "P", "Q", "W"):
                a, b = getattr(par, f), getattr(fold, f)
                assert a.shape == b.shape
                assert np.allclose(
                    a, b, rtol=1e-14, atol=1e-14 * max(1.0, float(np.max(np.abs(b), initial=0)))
                ), f


def test_parametric_analysis_names_the_mode_of_a_second_frequency():
    from hybrid.integrators.affine import affine_flows

    system = _oscillator(extra={"v": "-x + sin(W*t) + sin(w0*t)"})
    with pytest.raises(
        NotAffineError, match=r"mode `free`: forcing frequencies 0\.9 and 1\.3 rad/s are not integer"
    ):
        affine_flows(system, PARAMS)
    affine_flows(system, {**PARAMS, "w0": PARAMS["W"]})  # one frequency at these values: accepted
    (am,) = affine_flows(system, {**PARAMS, "w0": 3 * PARAMS["W"]})  # harmonics 1 and 3: accepted
    assert am.harmonics == (1, 3)


def test_exact_integrator_refuses_a_non_affine_model_before_running():
    from hybrid import SolverOptions, simulate

    system = _oscillator(extra={"v": "-w0**2*x**3"})
    with pytest.raises(NotAffineError, match=r"mode `free`: derivative of `v` is not affine in `x`"):
        simulate(system, PARAMS, (0.0, 1.0), {"x": 1.0, "v": 0.0}, options=SolverOptions(method=Exact()))


def test_cli_integrator_exact(tmp_path, capsys):
    from hybrid.cli import main

    code = main(
        [
            "orbit",
            "absorber",
            "--omega",
            "0.854",
            "--integrator",
            "exact",
            "--json",
            "--out",
            str(tmp_path),
            "--no-plot",
        ]
    )
    out = capsys.readouterr().out
    assert code == 0
    import json

    d = json.loads(out)
    assert d["converged"]
    assert d["transitions_per_period"] == 4
    assert d["residual"] <= 1e-12
    bad = tmp_path / "cubic.toml"
    bad.write_text(
        '[model]\nname = "cubic"\nperiod = "2*pi/W"\ninitial_mode = "m"\n[variables.x]\n[variables.v]\n'
        '[parameters.W]\n[presets.standard]\nW = 1.0\n[modes.m]\nderivatives = { x = "v", v = "-x**3 + sin(W*t)" }\n'
    )
    code = main(
        ["simulate", str(bad), "--integrator", "exact", "--out", str(tmp_path / "o"), "--periods", "1"]
    )
    err = capsys.readouterr().err
    assert code == 2, err
    assert "derivative of `v` is not affine in `x`" in err
    assert err.count("\n") == 1


@pytest.mark.parametrize("name", ["absorber", "isolator"])
def test_parameters_read_at_call_time_equal_folded_ones(name):
    """A system compiled once with its parameters read at call time (Shooter's continued parameter, the
    pool periodic_orbit borrows from) evaluates as one compiled with the values folded in."""
    system = getattr(hybrid_models, name)()
    base = system.preset("standard")
    rt = CompiledSystem(system, base, runtime=tuple(system.parameter_names))
    rng = np.random.default_rng(3)
    for _ in range(3):
        p = {k: v * rng.uniform(0.5, 2.0) for k, v in base.items()}
        rt.set_runtime(p)
        cs = CompiledSystem(system, p)
        assert rt.period == pytest.approx(cs.period, rel=1e-15)
        y = rng.normal(size=len(system.variable_names))
        for a, b in zip(rt.modes, cs.modes, strict=True):
            t = float(rng.uniform(0, 10))
            assert np.allclose(a.guard_values(t, y), b.guard_values(t, y), rtol=1e-13, atol=1e-13)
            assert np.allclose(a.dFdy(t, y), b.dFdy(t, y), rtol=1e-13, atol=1e-13)
            assert np.allclose(a.rhs(t, y), b.rhs(t, y), rtol=1e-13, atol=1e-13)
            assert np.allclose(a.taylor(t, y, 3), b.taylor(t, y, 3), rtol=1e-12, atol=1e-12)
    borrowed, release = lend(system, base, owner := type("Owner", (), {})(), every_parameter=True)
    assert borrowed.params == system.parameter_values(base)
    release()
    del owner


@pytest.mark.slow
@pytest.mark.parametrize("name", ["absorber", "isolator"])
def test_a_whole_exact_band_agrees_with_ida(name):
    """The whole first stick-slip band of each damper (standard preset), continued with the exact
    integrator (its points, mode changes and steps chosen by the continuation), against IDA at rtol
    1e-12 (5e-13 where that stalls at its noise floor) from each exact orbit's section: amplitudes,
    switch times (relative to the period) and Floquet multipliers to 1e-8 or IDA's own error bound,
    10 cond(I - M) rtol, if larger (cond reaches 1e5-1e7 at the band's left edge;
    benchmarks/exact_vs_ida.py over the whole first piece, 0.683-1.012 rad/s: 2.0e-10, 2.3e-10 T,
    7.6e-10). Skipped, two per band at most: an orbit next to a mode change where one run resolves a
    phase the other does not (different mode sequences), and the orbit at a located mode change (a
    phase of vanishing length: what moves only in it, e.g. the slip velocity, has an amplitude like
    the square root of the state's error)."""
    from hybrid import SolverOptions, continue_orbits, periodic_orbit

    system = getattr(hybrid_models, name)()
    p = system.preset("standard")
    br = continue_orbits(system, p, "Omega", (0.8527, 0.8562), options=SolverOptions(method=Exact()))
    assert br.status == "completed", br.message
    at_change = {
        # (bracketed too: since issue 23 a mode change on the exact flow carries its rounding margin,
        # and most are bracketed though their orbit is as near the change)
        s.index
        for s in br.special
        if s.kind in ("mode-gained", "mode-lost") and s.status in ("located", "bracketed")
    }
    band = [o for k, o in enumerate(br.points) if o.transitions_per_period > 0 and k not in at_change]
    assert len(band) >= 15
    skipped = len(br.points) - len(band) - sum(1 for o in br.points if o.transitions_per_period == 0)
    for o in band:
        # At rtol 1e-12 the map's noise can reach the residual tolerance 1e-11 (absorber near 0.8548: an
        # IDA run from the exact orbit stops at 1.25e-11, no decrease possible along Newton's step);
        # there the reference is rerun at 5e-13 (which stalls elsewhere, at the band's left edge).
        for rtol in (1e-12, 5e-13):
            tight = SolverOptions(method=IDA(rtol=rtol, atol=rtol * 1e-2))
            q = periodic_orbit(
                system,
                o.params,
                o.x0,
                o.mode0,
                t0=o.t0,
                options=tight,
                settings=hybrid.ShootingOptions(newton=hybrid.NewtonOptions(tol=1e-11), transient_periods=0),
            )
            if q.converged:
                break
        assert q.converged, q.message
        if q.mode_sequence != o.mode_sequence:
            skipped += 1
            continue
        scale = max(o.amplitude[s] for s in o.state_names if s in o.amplitude)
        tol = max(1e-8, 10.0 * q.condition * rtol)
        for k, v in o.amplitude.items():
            assert abs(q.amplitude[k] - v) <= tol * scale, (o.params["Omega"], k, q.condition)
        assert np.max(np.abs(q.switch_times - o.switch_times)) <= tol * o.period
        fe, fq = o.floquet_multipliers, q.floquet_multipliers
        assert fe.size == fq.size
        assert max(float(np.min(np.abs(fq - z))) for z in fe) <= tol
    assert skipped <= 2


@pytest.mark.parametrize("defective", [False, True])
def test_frechet_derivative_of_the_flow_matches_a_central_difference(defective):
    """``Flow.frechet`` (eigen path, and Van Loan's block on a defective matrix) against a central
    difference of the exponential (``scipy.linalg.expm``, step 1e-5: error about 1e-10)."""
    from scipy.linalg import expm

    from hybrid.integrators.flow import Flow

    rng = np.random.default_rng(3)
    if defective:  # a Jordan block: no eigenvector basis
        M = np.array([[-0.1, 1.0, 0.0], [0.0, -0.1, 1.0], [0.0, 0.0, -0.1]])
    else:
        M = rng.normal(size=(5, 5))
    D = rng.normal(size=M.shape)
    fl = Flow(M, np.zeros((0, *M.shape)))
    assert fl.eigen is not defective
    h, e = 0.7, 1e-5
    fd = (expm((M + e * D) * h) - expm((M - e * D) * h)) / (2 * e)
    assert np.max(np.abs(fl.frechet(h, D) - fd)) <= 1e-8 * np.max(np.abs(fd))


def test_parameter_column_of_the_exact_monodromy_matches_ida():
    """d(P(x))/dOmega of the absorber over one stick-slip period (Frechet derivative of the exact
    flows) against IDA's variational equations at rtol 1e-12 (the central difference of two exact
    flows it replaces agreed to 6e-9 only)."""
    from hybrid import SolverOptions, periodic_orbit
    from hybrid.orbits.shooter import Shooter

    system = hybrid_models.absorber()
    p = system.preset("standard", Omega=0.8545)
    tight = SolverOptions(method=IDA(rtol=1e-12, atol=1e-14))
    o = periodic_orbit(
        system, p, options=tight, settings=hybrid.ShootingOptions(newton=hybrid.NewtonOptions(tol=1e-11))
    )
    assert o.converged, o.message
    assert o.transitions_per_period == 4, o.message
    cols = []
    for opts in (SolverOptions(method=Exact()), tight):
        sh = Shooter(system, p, opts, free="Omega")
        cols.append(sh.monodromy(sh.run(o.x0, o.mode0, o.t0))[:, -1])
    assert np.max(np.abs(cols[0] - cols[1])) <= 1e-9 * np.max(np.abs(cols[1]))


@pytest.mark.parametrize("spp", [4, 16])
def test_a_simulation_sampled_per_period_runs_on_the_exact_integrator(spp):
    """`samples_per_period` gives a grid made on demand (not an array); the exact integrator takes
    its samples from each step's flow all at once and failed on it ("object of too small depth",
    reported as an evaluation failure of the model). Same sample times as IDA, and the same states
    to IDA's accuracy."""
    system = hybrid_models.coulomb()
    p = system.preset("forced", Omega=1.5)
    T = 2 * np.pi / 1.5
    y0 = {"x": 0.0, "v": 0.0, "W": 0.0, "D": 0.0}
    runs = {
        integ: simulate(
            system,
            p,
            (0.0, 20 * T),
            y0,
            samples_per_period=spp,
            options=SolverOptions(
                method=(IDA(rtol=1e-11, atol=1e-13) if integ == "ida" else method_named(integ))
            ),
        )
        for integ in ("exact", "ida")
    }
    ex, ida = runs["exact"], runs["ida"]
    assert ex.success, (ex.message, ida.message)
    assert ida.success, (ex.message, ida.message)
    assert ex.t.size == 20 * spp + 1
    np.testing.assert_array_equal(ex.t, ida.t)
    np.testing.assert_allclose(ex["x"], ida["x"], rtol=0, atol=1e-8)


@pytest.mark.parametrize("max_step", [0.1, 0.125, 0.13])
def test_a_crossing_on_the_boundary_of_two_steps_is_taken(max_step):
    """The belt's mass sticks from rest (x = v_b t) until the spring force k x reaches the static
    level Fs: break-away at t = Fs / (k v_b) = 2 s, which is the end of a step when the step is
    0.1 or 0.125 s. The earlier step's value there rounded to the safe side (-1e-15) and the later
    step's root, 2e-14 after its start, was taken as the earlier step's: the crossing was never
    taken and the mass rode the belt for ever (found by the issue-11 helper)."""
    system = hybrid_models.belt()
    p = system.preset("standard")
    t_break = p["Fs"] / (p["k"] * p["v_b"])
    assert t_break == pytest.approx(2.0)
    tr = simulate(
        system,
        p,
        (0.0, 10.0),
        dict.fromkeys(system.variable_names, 0.0),
        options=SolverOptions(method=Exact(), max_step=max_step),
    )
    assert tr.success, tr.message
    assert tr.events, tr.message
    assert abs(tr.events[0].t - t_break) <= 1e-12
