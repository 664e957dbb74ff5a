"""Parameter studies and design values (issue 9, parts 2-3), against independent results."""

import math

import numpy as np
import pytest

import hybrid
import hybrid_models
from hybrid_models.averaging import breakaway_force, characteristic_amplitudes, physical_amplitudes, rho_opt
from hybrid_models.figures import intersections
from hybrid_models.studies import (
    STUDIES,
    WINDOWS,
    optimal_friction,
    resonance_curve,
    study_params,
)


@pytest.fixture(scope="module")
def absorber_curve():
    return resonance_curve("absorber", study_params("absorber"), WINDOWS[1])


@pytest.mark.slow
def test_curve_peak_is_the_periodic_orbit_found_from_rest_at_that_frequency(absorber_curve):
    c = absorber_curve
    assert c.bounded
    assert not c.gaps
    assert WINDOWS[1][0] < c.peak_omega < WINDOWS[1][1]
    # an independent orbit: IDA, from rest with a transient, at the peak frequency
    system = hybrid_models.absorber()
    opts = hybrid.SolverOptions(method=hybrid.IDA(rtol=1e-10, atol=1e-12))
    o = hybrid.periodic_orbit(
        system,
        {**c.params, "Omega": c.peak_omega},
        options=opts,
        settings=hybrid.ShootingOptions(samples_per_period=256),
    )
    assert o.converged
    assert o.half_peak_to_peak["x1"] == pytest.approx(c.peak_x1, rel=1e-6)
    # it is a maximum: a little to either side the amplitude is lower
    for dw in (-2e-5, 2e-5):
        side = hybrid.periodic_orbit(
            system,
            {**c.params, "Omega": c.peak_omega + dw},
            x0=o.x0,
            mode0=o.mode0,
            t0=o.t0,
            options=opts,
            settings=hybrid.ShootingOptions(transient_periods=0),
        )
        assert side.converged, side.message
        assert side.half_peak_to_peak["x1"] < c.peak_x1
    # the refined peak is at least the largest continued point
    assert c.peak_x1 >= c.x1.max()


@pytest.mark.slow
def test_below_the_smallest_bounded_friction_the_curve_says_unbounded():
    # R = 0.25 N is 15 % below R_min = 0.2936 N of the averaging model (resonance 1)
    c = resonance_curve("absorber", study_params("absorber", R=0.25), WINDOWS[1])
    assert not c.bounded
    (band,) = [g for g in c.gaps if g[2] == "unbounded"]
    slip = hybrid_models.linear.slip_eigenfrequencies("absorber", c.params)[0]
    assert band[0] - 1e-4 < slip < band[1] + 1e-4


def test_optimiser_finds_the_known_optimum_of_the_averaging_peak():
    # a cheap problem with a closed-form optimum: the averaging model's X1,max(R) is smallest at R_opt
    base = study_params("absorber")
    calls = []

    def peak(R):
        a = characteristic_amplitudes("absorber", {**base, "R": R}, 1).A_max
        calls.append(float(physical_amplitudes("absorber", base, 1, a)[0]) if math.isfinite(a) else 1e12)
        return calls[-1]

    expected = breakaway_force("absorber", base, rho_opt("absorber", base, 1))
    opt = optimal_friction("absorber", 1, peak=peak, xatol=1e-7)
    assert opt.R == pytest.approx(expected, rel=1e-6)
    assert opt.relative_difference == pytest.approx(0.0, abs=1e-6)
    # the count it reports is the number of times the peak was computed
    assert opt.evaluations == len(calls), (opt.evaluations, len(calls))
    assert opt.evaluations < 60
    assert opt.peak_x1 == min(calls)  # the smallest peak it computed


def _polynomial_intersections(p):
    # |A1| = A_L  <=>  F m2 W^2 c2 = R |Delta(W)|: R Delta(s) -/+ F m2 c2 s = 0 with s = W^2
    m1, m2, c1, c2, R, F = (p[k] for k in ("m1", "m2", "c1", "c2", "R", "F"))
    out = []
    for sign in (1.0, -1.0):
        coeffs = [R * m1 * m2, -(R * (c1 * m2 + (m1 + m2) * c2)) - sign * F * m2 * c2, R * c1 * c2]
        for s in np.roots(coeffs):
            if abs(s.imag) < 1e-12 and s.real > 0:
                out.append(math.sqrt(s.real))
    return sorted(out)


@pytest.mark.parametrize(("preset", "count"), [("fig3a", 4), ("fig3b", 2)])
def test_structural_change_intersections_of_fig3(preset, count):
    p = hybrid_models.absorber().preset(preset)
    expected = _polynomial_intersections(p)
    assert len(expected) == count
    assert np.allclose(intersections("absorber", p), expected, rtol=1e-9)


def test_studies_have_the_papers_ranges_and_steps():
    r = STUDIES["absorber-R"].values
    assert len(r) == 26
    assert r[0] == 0.3
    assert r[-1] == 0.8
    assert np.allclose(np.diff(r), 0.02)
    c = STUDIES["absorber-c3"].values
    assert len(c) == 100 + 9
    assert c[0] == 0.01
    assert c[99] == 1.0
    assert c[-1] == 10.0
    assert STUDIES["isolator-R"].values[0] == 0.9
    assert STUDIES["isolator-R"].values[-1] == 2.0
    assert len(STUDIES["isolator-R"].values) == 23
    i = STUDIES["isolator-c3"].values
    assert len(i) == 10 + 9 + 9
    assert i[0] == 0.1
    assert i[9] == 1.0
    assert i[18] == 10.0
    assert i[-1] == 100.0
