"""One physical system written three ways gives the same special points (issue 30): Den Hartog's
oscillator (m = k = F = 1, c = 0.1, R = 0.3) as a network file, with ``sign()`` and as the built-in
``friction_oscillator --preset denhartog``, on both integrators. The boundary where its stick
phases vanish is the closed form of :func:`hybrid_models.classics.den_hartog_boundary`
(0.507205316752581, also in docs/bifurcation.md).

Before issue 30 the network file and the ``sign()`` file took the event loop's tolerance band as
their guards' noise on the exact integrator: it hid the stick phases shorter than about 8e-9 s,
and the located boundary lay 1.6e-10 (network) and 6.7e-10 (``sign()``) from the closed form,
outside its own interval of +-1.7e-12.
"""

from __future__ import annotations

from pathlib import Path

import pytest

import hybrid
import hybrid_models
from hybrid import SolverOptions, method_named
from hybrid_models.classics import den_hartog_boundary

DATA = Path(__file__).with_name("data")
OMEGA_B = 0.507205316752581


def _system(form: str):
    if form == "built-in":
        return hybrid_models.friction_oscillator()
    return hybrid.load_system(DATA / f"denhartog_{form}.toml")


def test_the_closed_form_is_the_documented_one():
    assert den_hartog_boundary(1.0, 1.0, 0.1, 0.3, 1.0, (0.49, 0.52)) == pytest.approx(OMEGA_B, rel=1e-14)


@pytest.mark.parametrize("integrator", ["exact", pytest.param("ida", marks=pytest.mark.slow)])
@pytest.mark.parametrize("form", ["network", "sign", "built-in"])
def test_den_hartogs_boundary_holds_the_closed_form_whatever_the_models_form(form, integrator):
    system = _system(form)
    params = system.preset("denhartog")
    fr = hybrid.frequency_response(
        system, params, (0.49, 0.52), options=SolverOptions(method=method_named(integrator))
    )
    lost = [r for r in fr.special_rows if r["kind"] == "mode-lost"]
    assert len(lost) == 1, [(r["kind"], r["Omega"]) for r in fr.special_rows]
    row = lost[0]
    assert row["interval_lo"] <= OMEGA_B <= row["interval_hi"], row
    half = 0.5 * (row["interval_hi"] - row["interval_lo"])
    if integrator == "exact":
        assert row["status"] == "located"
        assert half <= 5e-10
    assert not fr.gaps
