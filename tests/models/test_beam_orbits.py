"""Orbits and the frequency response of the FE beam with a tip Jenkins contact (issue 32).

References are independent of the library: scipy's LAPACK balancing and ``expm`` for the flow of
a badly scaled generator; the other integrator (IDA) for the orbits; the energy balance over a
period; the linear response of the stuck structure solved directly with numpy,
``(K + kt e e^T - Omega^2 M + i Omega C) X = F e``, for the stuck band of the frequency response and
(with scipy's ``brentq``) for the forcing frequency where the stuck contact's force reaches the
slip force.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import scipy.linalg

from hybrid import Exact, SolverOptions, load_system
from hybrid.integrators.flow import Flow, matrix_exp
from hybrid.integrators.flows import exact_flows
from hybrid.model.compiled import CompiledSystem

MODELS = Path(__file__).resolve().parents[2] / "models"
EXACT = SolverOptions(method=Exact())


def _row_error(A: np.ndarray, B: np.ndarray) -> float:
    """Largest error of a row of ``A`` against ``B``, relative to that row's ``sum |B_ij|``."""
    return float(np.max(np.abs(A - B).sum(axis=1) / np.abs(B).sum(axis=1)))


@pytest.mark.parametrize("model", ["beam_tip.toml", "beam_tip_cb.toml"])
def test_the_flow_of_the_stuck_beam_equals_scipys_balanced_expm(model):
    # issue 32: the stuck beam's generator mixes displacements [m] and rotations [rad] through
    # M^-1 K (||M||_1 = 2.2e11 against a spectral radius of 8.9e4 for 10 elements); the unbalanced
    # Pade exponential was wrong by 5e-5 of a row and Newton's method on the orbit stalled at 2.7e-6
    system = load_system(MODELS / model)
    p = dict(system.preset("standard"), Omega=90.0)
    cs = CompiledSystem(system, p)
    M = exact_flows(cs)[cs.mode_id("motion|stick")].M
    flow = Flow(M, np.zeros((0,) + M.shape))
    Mb, T = scipy.linalg.matrix_balance(M, permute=False)  # LAPACK gebal: M = T Mb T^-1
    s = np.diag(T)
    ref = {
        h: scipy.linalg.expm(Mb * h) * (s[:, None] / s[None, :]) for h in (1e-5, 1e-4, 2 * np.pi / 90.0 / 16)
    }
    for h, E in ref.items():
        assert _row_error(flow.matrix(h), E) < 1e-10, h
    if model == "beam_tip.toml":  # what the balancing is for: the plain Pade exponential is not exact
        assert _row_error(matrix_exp(M * 1e-4), ref[1e-4]) > 1e-6
