"""EPMC backbone of the Craig-Bampton beam with a stuck/slipping tip contact (issue 31).

``beam_tip_cb.toml``: 20 Euler-Bernoulli elements reduced to the tip DOF ``w20`` and 6
fixed-interface modes (by :func:`hybrid_models.craig_bampton.craig_bampton`, given to the network
as matrices), ``w20 --kt-- slider --]R[-- ground``. While the contact sticks (slider at rest at 0)
the structure is linear with the stiffness ``K + kt e e'``; damped 0.5 % in each of its modes, the
EPMC term cancels the first one's damping exactly, so the small-amplitude backbone is the first
:func:`scipy.linalg.eigh` mode with ``xi = 2 zeta w1``. The contact first slips where that mode's
spring force ``kt |w20|`` reaches ``R``.
"""

from __future__ import annotations

import tomllib
from pathlib import Path

import numpy as np
import pytest
import scipy.linalg as sla

import hybrid
import hybrid_models
from hybrid import Exact, SolverOptions
from hybrid_models.craig_bampton import craig_bampton
from hybrid_models.structures import Structure

MODELS = Path(hybrid_models.__file__).parent
KT, R, ZETA = 5000.0, 1.0, 0.005


def _stuck():
    """The reduced beam (tip + 6 modes), its stuck stiffness ``K + kt e e'`` and that's modes."""
    z = np.load(MODELS / "data" / "beam20.npz")
    dofs = [str(d) for d in z["dofs"]]
    red = craig_bampton(Structure.from_arrays(z["M"], z["K"], dofs), ["w20"], 6).structure
    i = red.dofs.index("w20")
    Ks = np.array(red.K, dtype=float)
    Ks[i, i] += KT
    lam, V = sla.eigh(Ks, np.array(red.M, dtype=float))  # V' M V = I
    return red, np.sqrt(lam), V, i


def _system(red, w, V):
    """beam_tip_cb.toml with the reduced beam given as matrices, damped ``ZETA`` in each stuck mode
    (``C = M V diag(2 zeta w) V' M``): the EPMC term ``xi M v`` cancels the first mode's damping
    exactly at ``xi = 2 zeta w1``, so the small-amplitude backbone is that undamped mode."""
    data = tomllib.loads((MODELS / "beam_tip_cb.toml").read_text())
    M = np.array(red.M, dtype=float)
    C = M @ V @ np.diag(2 * ZETA * w) @ V.T @ M
    data["structures"]["beam"] = {
        "matrices": Structure.from_arrays(M, np.array(red.K, dtype=float), red.dofs, C)
    }
    data["springs"]["contact"]["between"] = ["beam.w20", "slider"]
    data["forces"]["force"]["on"] = "beam.w20"
    return hybrid_models.epmc_system(data)


@pytest.mark.slow
def test_reduced_beam_backbone_through_first_slip():
    # issue 31: the continuation used to crawl in the linear range (400 steps, still below first
    # slip): the anchor was a hyperplane fixed in the unscaled state, so the curve's tangent was a
    # phase drift; with the anchor in the amplitude-scaled state the linear range is a straight line
    red, w, V, i = _stuck()
    w1, phi = w[0], V[:, 0]
    # the spring force of the stuck mode at tip amplitude a: kt |phi_tip| a / |phi_tip|; slip at R
    a_slip = R / (KT * abs(phi[i]) / abs(phi[i]))
    # not yet to 5 a_slip: near 1.4 a_slip xi reaches 2 zeta w4 (the EPMC term xi M v undamps the
    # 4th stuck mode, w4 ~ 21 omega) and the corrector stalls (docs/backbones.md)
    small, high = 0.25 * a_slip, 1.3 * a_slip
    bb = hybrid.backbone(
        _system(red, w, V),
        {"kt": KT, "R": R, "F": 0.0, "Omega": 60.0},
        coordinate="beam_w20",
        amplitudes=[small, high],
        options=SolverOptions(method=Exact()),
    )
    assert bb.status == hybrid.BranchStatus.COMPLETED and not bb.message, bb.message
    amps = [p.amplitude for p in bb.points]
    np.testing.assert_allclose(amps, [small, high], rtol=1e-12)
    lin, slip = bb.points
    assert lin.omega == pytest.approx(w1, rel=1e-9)
    assert lin.xi == pytest.approx(2 * ZETA * w1, rel=1e-9)
    assert set(lin.orbit.mode_sequence) == {bb.start_mode}
    first = [e for e in bb.events if e.kind == "first-switch"]
    assert len(first) == 1 and first[0].status == "located"
    lo, hi = first[0].interval
    assert lo <= a_slip <= hi
    assert hi - lo <= 1e-8 * a_slip
    # past first slip: the contact slips part of the period, the frequency drops, the damping grows
    assert len(set(slip.orbit.mode_sequence)) > 1
    assert slip.omega < lin.omega
    assert slip.xi > lin.xi
    # the energy put in by the EPMC term over a period is what friction and damping dissipate
    assert slip.energy_input == pytest.approx(slip.dissipated, rel=1e-7)
