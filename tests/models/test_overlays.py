"""FRC overlays of the dampers (entry points `hybrid.frc_overlays`) and the generic default range."""

from importlib.metadata import entry_points

import numpy as np
import pytest

import hybrid_models
from hybrid.continuation.frc import default_range
from hybrid.model.linear import natural_frequencies, reduced_jacobian
from hybrid_models.linear import limit_amplitude, stick_amplitudes, stick_eigenfrequencies
from hybrid_models.overlays import STICK


@pytest.mark.parametrize("name", ["absorber", "isolator"])
def test_entry_point_gives_the_closed_forms(name):
    eps = {ep.name: ep for ep in entry_points(group="hybrid.frc_overlays")}
    system = getattr(hybrid_models, name)()
    p = system.preset("standard")
    w = np.linspace(0.5, 1.5, 11)
    curves = eps[name].load()(p, w)
    a1, a2 = stick_amplitudes(p, w)
    assert np.array_equal(curves[STICK]["x1"], np.abs(a1))
    assert np.array_equal(curves[STICK]["x2"], np.abs(a2))
    (limit,) = (c for c in curves if c.startswith("structural-change limit"))
    assert np.allclose(curves[limit]["x1"], limit_amplitude(name, p, w), rtol=1e-15)
    # the limit of x2 is the limit of x1 mapped through the stick relation x2 = c2 x1 / (c2 - m2 W^2)
    off = w != 1.0  # the antiresonance sqrt(c2/m2): A_L(x1) = 0 there
    ratio = curves[limit]["x2"][off] / curves[limit]["x1"][off]
    assert np.allclose(ratio, np.abs(a2[off] / a1[off]), rtol=1e-12)


def test_absorber_limit_in_x2_is_where_the_stuck_element_holds_R():
    # absorber, offset 0: H = c2 (x2 - x1) while stuck, so |H| = R at |x2| = R / (m2 W^2)
    p = hybrid_models.absorber().preset("standard")
    w = np.array([0.8, 0.9, 1.2])
    (limit,) = (c for c in hybrid_models.overlays.absorber(p, w) if c.startswith("structural"))
    assert np.allclose(
        hybrid_models.overlays.absorber(p, w)[limit]["x2"], p["R"] / (p["m2"] * w**2), rtol=1e-12
    )


@pytest.mark.parametrize("name", ["absorber", "isolator"])
def test_natural_frequencies_of_the_stuck_dampers(name):
    system = getattr(hybrid_models, name)()
    p = system.preset("standard")
    assert np.allclose(natural_frequencies(system, p), stick_eigenfrequencies(p), rtol=1e-12)
    lo, hi = default_range(system, p)
    w1, w2 = stick_eigenfrequencies(p)
    assert np.isclose(lo, 0.8 * w1)
    assert np.isclose(hi, 1.2 * w2)


def test_reduced_jacobian_eliminates_slave_variables():
    # absorber slipping: u is a slave variable; eliminating it gives the slip stiffness c2 c3 / (c2 + c3)
    system = hybrid_models.absorber()
    p = system.preset("standard")
    names, A = reduced_jacobian(system, p, "slip+")
    assert names == ("x1", "v1", "x2", "v2")
    w = natural_frequencies(system, p, "slip+")
    assert np.allclose(w, hybrid_models.linear.slip_eigenfrequencies("absorber", p), rtol=1e-12)


def test_no_natural_frequency_no_default_range():
    system = hybrid_models.coulomb()
    with pytest.raises(ValueError, match=r"no natural frequency .*--omega-range"):
        default_range(system, system.preset("forced"))
