"""Orbits and branches do not depend on the units of the state.

A model in engineering units (stiffnesses of 1e6 N/m and masses of 10 kg: a forcing period of a few
hundredths of a second) has velocities hundreds of times its displacements. The absorber with its
stiffnesses, sliding force and forcing amplitude multiplied by ``c`` is the standard absorber with
time divided by ``sqrt(c)``: its orbits are the standard ones at ``Omega sqrt(c)``, its velocities
``sqrt(c)`` times larger, its multipliers the same, its band edges at ``sqrt(c)`` times the closed
forms (independent references: the standard model's own orbit, and the closed-form crossings of the
stick response with the structural-change limit, :mod:`hybrid_models.linear`). Before the rank tests
and truncated pseudo-inverses of ``I - M`` were made in balanced units, ``periodic_orbit`` failed at
``c = 1e4`` and a continuation over the first band stalled inside it.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import hybrid
import hybrid_models
from hybrid import Exact, SolverOptions, continue_orbits, periodic_orbit
from hybrid.integrators.flows import exact_flows
from hybrid.orbits.orbit import balance_scales
from hybrid.orbits.shooter import Shooter

EXACT = SolverOptions(method=Exact())
#: The absorber's first band edges (standard parameters), from the closed forms (test_continuation).
ONSET, LOSS = 0.8529825446319, 0.8556511156206


def _scaled(c: float, omega: float) -> dict:
    ab = hybrid_models.absorber()
    p = ab.preset("standard")
    for k in ("c1", "c2", "c3", "R", "F"):
        p[k] *= c
    p["Omega"] = omega * math.sqrt(c)
    return p


def test_balance_scales_recover_a_change_of_units():
    rng = np.random.default_rng(7)
    J0 = rng.normal(size=(4, 4))
    assert np.all(balance_scales(J0) == 1.0)  # balanced within the ratio: left alone
    T = np.array([1.0, 1e3, 1.0, 1e3])  # e.g. velocities in mm/s
    J = J0 * T[None, :] / T[:, None]  # the same map in other units: T^-1 J0 T
    s = balance_scales(J)
    B = J * s[None, :] / s[:, None]
    cond = np.linalg.cond(B)
    assert np.linalg.cond(J) > 1e4 * np.linalg.cond(J0)
    assert cond <= 10 * np.linalg.cond(J0)
    np.testing.assert_allclose(np.sort(np.linalg.eigvals(B)), np.sort(np.linalg.eigvals(J0)), atol=1e-9)


@pytest.mark.parametrize(("integrator", "c"), [("exact", 1e4), ("ida", 1e4), ("exact", 1e6), ("ida", 1e6)])
def test_periodic_orbit_in_engineering_units_equals_the_standard_one(integrator, c):
    """Forcing periods of 74 ms (c = 1e4) and 7.4 ms (c = 1e6). At c = 1e6 the exact flows'
    eigenvectors had a condition number over 1e4 until the generator was balanced: every flow fell
    back on the Pade path and a continuation over the band stalled."""
    ab = hybrid_models.absorber()
    opts, tol = (EXACT, 1e-12) if integrator == "exact" else (None, 1e-9)
    ref = periodic_orbit(
        ab,
        _scaled(1.0, 0.85306),
        options=opts,
        settings=hybrid.ShootingOptions(newton=hybrid.NewtonOptions(tol=tol)),
    )
    o = periodic_orbit(
        ab,
        _scaled(c, 0.85306),
        options=opts,
        settings=hybrid.ShootingOptions(newton=hybrid.NewtonOptions(tol=tol)),
    )
    assert ref.converged, o.message
    assert o.converged, o.message
    assert o.mode_sequence[1:] == ref.mode_sequence[1:] or set(o.mode_sequence) == set(ref.mode_sequence)
    if integrator == "exact":
        assert all(am.flow().eigen for am in exact_flows(Shooter(ab, o.params, EXACT).cs))
    # displacements equal, velocities sqrt(c) times larger (exact: 1.6e-10 apart at c = 1e6, though
    # each orbit's residual is 5e-16); IDA to cond x rtol (about 4e-6 here)
    rel = 1e-9 if integrator == "exact" else 1e-4
    for name, f in (("x1", 1.0), ("x2", 1.0), ("v1", math.sqrt(c)), ("v2", math.sqrt(c))):
        assert o.amplitude[name] == pytest.approx(f * ref.amplitude[name], rel=rel), name
    mu, mu_ref = np.sort_complex(o.multipliers), np.sort_complex(ref.multipliers)
    assert np.max(np.abs(mu - mu_ref)) <= (1e-10 if integrator == "exact" else 1e-6)


@pytest.mark.slow
@pytest.mark.parametrize("c", [1e4, 1e6])
def test_continuation_in_engineering_units_locates_the_band_onset(c):
    w = math.sqrt(c)  # forcing periods of 74 ms and 7.4 ms
    br = continue_orbits(hybrid_models.absorber(), _scaled(c, 0.8515), "Omega", (0.8515 * w, 0.8535 * w),
                      options=EXACT)  # fmt: skip
    assert br.status == "completed", br.message
    onset = [s for s in br.special if s.kind == "mode-gained"]
    assert len(onset) == 1
    # the point is right to 1e-13 (relative), but its interval is widened by the rounding margin
    # eps |p| cond(I - M), whose condition number in the state's own units grows with the units'
    # ratio (measured: half-widths 2e-9 and 2e-7 relative at c = 1e4 and 1e6): bracketed, and the
    # interval holds the closed form
    assert onset[0].status in ("located", "bracketed")
    assert onset[0].parameter == pytest.approx(ONSET * w, rel=1e-10)
    assert onset[0].contains(ONSET * w)
    assert onset[0].accuracy <= 1e-6 * ONSET * w
