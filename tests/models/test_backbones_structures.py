"""EPMC on structures given by matrices (issue 31): ``+ xi v`` on each structure coordinate.

With Rayleigh damping ``C = a M`` (``rayleigh = [a, 0]``) the EPMC term ``- xi M v`` cancels the
damping exactly at ``xi = a``: every mode is undamped there and the backbone is the linear mode
with ``omega`` the undamped frequency. References: :func:`scipy.linalg.eigh` of the beam's matrices
(for the Craig-Bampton model, of the reduced matrices), the spring ``kt`` added by hand.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import scipy.linalg as sla

import hybrid
import hybrid_models
from hybrid import Exact, SolverOptions
from hybrid.model.linear import reduced_jacobian
from hybrid_models.craig_bampton import craig_bampton
from hybrid_models.epmc import epmc_system
from hybrid_models.structures import Structure

MODELS = Path(hybrid_models.__file__).parent
A_RAYLEIGH, KT = 0.7, 5000.0


def _beam(path: Path, reduce: int | None = None):
    z = np.load(path)
    M, K, dofs = z["M"], z["K"], [str(d) for d in z["dofs"]]
    tip = dofs[-2]  # w10 / w20
    spec = {"matrices": Structure.from_arrays(M, K, dofs), "rayleigh": [A_RAYLEIGH, 0.0]}
    spec |= {"reduce": {"modes": reduce}} if reduce is not None else {}
    net = {
        "model": {"name": "beam_rayleigh", "format": "network"},
        "structures": {"beam": spec},
        "springs": {"support": {"between": [f"beam.{tip}", "ground"], "stiffness": "kt"}},
        "parameters": {"kt": {"domain": "positive"}},
        "presets": {"standard": {"kt": KT}},
    }
    return hybrid_models.epmc_system(net), M, K, dofs, tip


def _stuck_frequencies(M, K, i):
    Ks = K.copy()
    Ks[i, i] += KT
    return np.sqrt(sla.eigh(Ks, M, eigvals_only=True))


def test_epmc_term_on_the_full_beam_undamps_every_mode():
    # issue 31: at xi = a the full beam's (10 elements) linearisation is undamped, its frequencies
    # those of eigh(K + kt e e', M): the term + xi v_X is on every coordinate's acceleration
    system, M, K, dofs, tip = _beam(MODELS / "data" / "beam10.npz")
    _, J = reduced_jacobian(system, {"kt": KT, "xi": A_RAYLEIGH}, system.default_mode)
    lam = np.linalg.eigvals(J)
    w = _stuck_frequencies(M, K, dofs.index(tip))
    up = np.sort(lam.imag[lam.imag > 0])
    np.testing.assert_allclose(up, w, rtol=1e-8)
    assert np.max(np.abs(lam.real)) <= 1e-9 * w[-1]
    # without the term (xi = 0) each mode decays at a/2 (C = a M)
    _, J0 = reduced_jacobian(system, {"kt": KT, "xi": 0.0}, system.default_mode)
    np.testing.assert_allclose(np.linalg.eigvals(J0).real, -A_RAYLEIGH / 2, rtol=1e-8)


@pytest.mark.parametrize("mode", [1, 2])
def test_reduced_beam_backbone_is_xi_a_and_the_reduced_eigh_frequency(mode):
    # issue 31: Craig-Bampton (20 elements, tip + 6 modes): the reduced M is the mass matrix of the
    # reduced coordinates, so + xi v on the modal coordinates too; xi = a and omega = the reduced
    # model's own eigh frequency, to 1e-10
    system, M, K, dofs, tip = _beam(MODELS / "data" / "beam20.npz", reduce=6)
    red = craig_bampton(Structure.from_arrays(M, K, dofs), [tip], 6).structure
    w = _stuck_frequencies(red.M, red.K, red.dofs.index(tip))[mode - 1]
    bb = hybrid.backbone(
        system,
        {"kt": KT},
        coordinate=f"beam_{tip}",
        mode=mode,
        amplitudes=[1e-3],
        options=SolverOptions(method=Exact()),
    )
    assert len(bb.points) == 1
    p = bb.points[0]
    assert p.amplitude == pytest.approx(1e-3, rel=1e-12)
    assert p.xi == pytest.approx(A_RAYLEIGH, rel=1e-10)
    assert p.omega == pytest.approx(w, rel=1e-10)
    assert p.damping_ratio == pytest.approx(A_RAYLEIGH / (2 * w), rel=1e-10)
    # the energy the term puts in (xi v'Mv) is what the Rayleigh damping (v'Cv) dissipates
    assert p.dissipated > 0
    assert p.energy_input == pytest.approx(p.dissipated, rel=1e-9)


def test_epmc_system_of_a_file_finds_the_matrices_it_names_beside_it(tmp_path, monkeypatch):
    # issue 31: a network file naming `data/beam20.npz` was read against the working directory
    monkeypatch.chdir(tmp_path)
    system = epmc_system(Path(hybrid_models.__file__).parent / "beam_tip_cb.toml")
    assert "xi" in {p.name for p in system.parameters}
    with pytest.raises(hybrid.ModelError, match="beam20.npz"):
        (tmp_path / "m.toml").write_text(
            (Path(hybrid_models.__file__).parent / "beam_tip_cb.toml").read_text()
        )
        epmc_system(tmp_path / "m.toml")
