"""Angles reduced mod 2 pi on input, the same on both integrators (issue 30: a phase of 1e300 gave
2.82 J per period on the exact integrator and 0.00067 J on IDA, which lost the time in
``2 Omega t + phi``)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

import hybrid
from hybrid import IDA, SolverOptions, method_named
from hybrid.model.elements import MAX_ANGLE, reduce_angle

TMD2 = Path(__file__).resolve().parents[2] / "examples" / "tmd_harmonics.toml"


def test_reduce_angle_is_exact_mod_2pi():
    # against the double's exact value reduced with 2 pi to 80 digits, computed apart: fractions
    from fractions import Fraction

    two_pi = Fraction("6.28318530717958647692528676655900576839433879875021164194988918461563281257")
    for v in (0.5, 7.0, -3.5, 1e3 + 0.25, -98765.4321, 999999.0):
        q = Fraction(v) / two_pi
        n = round(q)
        want = float(Fraction(v) - n * two_pi)
        assert reduce_angle(v) == want
        assert -math.pi < reduce_angle(v) <= math.pi
        assert 0.0 <= reduce_angle(v, "nonnegative") < 2 * math.pi
        assert math.isclose(math.sin(reduce_angle(v)), math.sin(v), abs_tol=1e-9)


def test_a_phase_is_reduced_on_input_and_a_huge_one_refused():
    system = hybrid.load_system(TMD2)
    assert system.preset("standard", phi2=0.5 + 2 * math.pi * 1000)["phi2"] == pytest.approx(0.5, abs=1e-12)
    with pytest.raises(hybrid.InputError, match=r"phi2.*angle of 1e\+300 rad: at most 1e\+06 rad.*mod 2 pi"):
        system.preset("standard", phi2=1e300)
    assert MAX_ANGLE == 1e6


@pytest.mark.slow
def test_a_large_phase_gives_the_same_motion_on_both_integrators():
    """phi2 = 0.5 + 2 pi 10^5: both integrators give the motion of phi2 = 0.5 (to IDA's tolerance)."""
    system = hybrid.load_system(TMD2)
    finals = []
    for phi in (0.5, 0.5 + 2 * math.pi * 1e5):
        p = system.preset("standard", phi2=phi)
        T = 2 * math.pi / p["Omega"]
        x0 = {"x1": 0.0, "v_x1": 0.0, "x2": 0.0, "v_x2": 0.0}
        for integ in ("exact", "ida"):
            tr = hybrid.simulate(
                system,
                p,
                (0.0, 5 * T),
                x0,
                options=SolverOptions(
                    method=(IDA(rtol=1e-10, atol=1e-13) if integ == "ida" else method_named(integ))
                ),
            )
            finals.append(tr.y_final[:4])
    ex_small, ida_small, ex_big, ida_big = finals
    scale = float(np.max(np.abs(ex_small)))
    # the large phase is the small one to its own spacing (1.2e-10 rad at 6.3e5 rad)
    np.testing.assert_allclose(ex_big, ex_small, rtol=0, atol=1e-9 * scale)
    # and the two integrators agree on it to IDA's tolerance (rtol 1e-10, five periods with switches)
    np.testing.assert_allclose(ida_big, ex_big, rtol=0, atol=1e-7 * scale)
    np.testing.assert_allclose(ida_small, ex_small, rtol=0, atol=1e-7 * scale)
