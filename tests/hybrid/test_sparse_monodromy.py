"""Fundamental matrices over the modes of a large system without a dense flow per mode (issue 32).

Above ``DENSE_LIMIT`` states a mode is a :class:`~hybrid.integrators.assembly.SparseAffineMode`;
its fundamental matrix over a step is ``expm(M h) Y`` by ``expm_multiply`` on the sparse generator,
where it was the eigen-decomposition of a new dense generator at every mode change (65 s against
0.3 s for one mode of 256 blades, measured in the issue's closing note). Compared here with the
dense eigen path, which is independent of it.
"""

from __future__ import annotations

import tomllib
from pathlib import Path

import numpy as np
import pytest

import hybrid.integrators.assembly as assembly
import hybrid_models
from hybrid import Exact, SolverOptions, periodic_orbit, system_from_dict
from hybrid.integrators.flows import exact_flows
from hybrid.model.compiled import CompiledSystem

EXACT = SolverOptions(method=Exact())


def _disk(n: int):
    data = tomllib.loads((Path(hybrid_models.__file__).parent / "bladed_disk.toml").read_text())
    data["cells"]["blade"]["count"] = n
    del data["presets"]["mistuned"]  # its list has 24 values
    return system_from_dict(data)


@pytest.mark.slow
def test_the_action_of_the_sparse_exponential_equals_the_dense_flow():
    system = _disk(24)  # 24 blades: x, v, p, f per blade, over DENSE_LIMIT
    p = system.preset("tuned")
    cs = CompiledSystem(system, p)
    key = ["motion"] + ["stick"] * 24
    key[3], key[10] = "slip+", "slip-"
    am = exact_flows(cs)[cs.mode_id("|".join(key))]
    assert isinstance(am, assembly.SparseAffineMode)
    nd = am.d.size
    rng = np.random.default_rng(32)
    Y = rng.standard_normal((nd, 5))
    for h in (1e-3, 0.4, 3.0):
        E = am.dense().flow().matrix(h)[:nd, :nd]
        np.testing.assert_allclose(am.propagate_d(h, Y), E @ Y, rtol=0, atol=1e-12 * np.abs(E @ Y).max())


@pytest.mark.slow
def test_a_periodic_orbit_of_a_large_ring_has_the_same_multipliers_on_both_paths(monkeypatch):
    # the ring of 6 blades on the sparse path (DENSE_LIMIT lowered) against the dense eigen path
    system = _disk(6)
    p = system.preset("tuned", EO=1.0, F=0.03, Omega=1.2)
    dense = periodic_orbit(system, p, options=EXACT)
    monkeypatch.setattr(assembly, "DENSE_LIMIT", 0)
    system = _disk(6)
    sparse = periodic_orbit(system, p, options=EXACT)
    assert dense.converged and sparse.converged
    cs = CompiledSystem(system, p)
    assert isinstance(exact_flows(cs)[cs.mode_id(system.default_mode)], assembly.SparseAffineMode)
    np.testing.assert_allclose(sparse.x0, dense.x0, rtol=0, atol=1e-10 * np.abs(dense.x0).max())
    np.testing.assert_allclose(
        np.sort_complex(sparse.multipliers), np.sort_complex(dense.multipliers), rtol=0, atol=1e-9
    )
