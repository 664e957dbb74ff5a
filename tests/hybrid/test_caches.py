"""Caches are declared fields or bounded LRU maps of their owner, never values slipped into an object's
``__dict__`` (issue 29, item 4; hybrid/core/cache.py).

Before: a Flow's step kernels, an AffineMode's flow, ``P M``, ``P M^2`` and (written by another
module, ``integrators/exact.py``) its guards' Taylor rows, an AffineAnalysis' evaluations, a sparse
mode's dense form and a composed mode's rows and slave pattern were put into ``obj.__dict__`` on first
use, some unbounded. The results are those of the existing tests (test_exact, test_components,
test_filippov_components); here: each cache's bound, its owner, and values against closed forms.
"""

from __future__ import annotations

import ast
import dataclasses
import math
import threading
from pathlib import Path

import numpy as np
from chains import chain_params, composed_chain

import hybrid_models
from hybrid.core.cache import LRUCache
from hybrid.integrators import affine, assembly, flow
from hybrid.integrators.affine import AffineMode, system_analysis
from hybrid.integrators.flow import Flow, shared_flow
from hybrid.model.compiled import CompiledSystem

HYBRID = Path(__file__).resolve().parents[2] / "hybrid"


def test_no_module_of_hybrid_reads_or_writes_an_objects_dict():
    hits = [
        f"{path.relative_to(HYBRID.parent)}:{node.lineno}"
        for path in sorted(HYBRID.rglob("*.py"))
        for node in ast.walk(ast.parse(path.read_text()))
        if isinstance(node, ast.Attribute) and node.attr == "__dict__"
    ]
    assert hits == []


# ----------------------------------------------------------------------------------------------
# LRUCache
def test_get_or_make_makes_once_and_keeps_the_most_recent():
    cache = LRUCache(3)
    made = []

    def make(k):
        made.append(k)
        return k * 10

    for k in [1, 2, 3, 1, 4, 1, 2]:  # 4 drops 2 (least recent: 1 was used again); 2 is made again
        assert cache.get_or_make(k, lambda k=k: make(k)) == k * 10
    assert made == [1, 2, 3, 4, 2]
    assert len(cache) == 3
    assert [k in cache for k in (1, 2, 3, 4)] == [True, True, False, True]


def test_lru_cache_stays_bounded_under_threads():
    cache = LRUCache(8)
    errors = []

    def work(offset):
        try:
            for i in range(3000):
                cache.get_or_make((offset + i) % 50, lambda i=i: i)
                cache.get((offset + 2 * i) % 50)
        except Exception as exc:  # noqa: BLE001 - reported below
            errors.append(exc)

    threads = [threading.Thread(target=work, args=(k * 7,)) for k in range(4)]
    for th in threads:
        th.start()
    for th in threads:
        th.join()
    assert errors == []
    assert len(cache) == 8


# ----------------------------------------------------------------------------------------------
# Flow: step kernels; shared flows
def _oscillator(w: float) -> Flow:
    M = np.array([[0.0, 1.0], [-(w**2), 0.0]])
    return Flow(M, np.zeros((0, 2, 2)))


def test_flow_kernels_are_bounded_and_exact():
    w = 1.7
    f = _oscillator(w)
    before = set(vars(f))
    hs = np.linspace(0.01, 2.0, flow.KERNELS_KEPT + 9)
    for h in hs:
        E, K = f.kernel(float(h))
        c, s = math.cos(w * h), math.sin(w * h)
        np.testing.assert_allclose(E, [[c, s / w], [-w * s, c]], rtol=0, atol=1e-14)
        assert K is None
    assert len(f._kernels) == flow.KERNELS_KEPT
    assert f.kernel(float(hs[-1])) is f.kernel(float(hs[-1]))  # kept: the same arrays
    assert set(vars(f)) == before  # nothing added to the object


def test_shared_flows_are_bounded():
    before = len(flow._FLOWS)
    first = shared_flow(np.array([[0.0, 1.0], [-1.0, -1e-3]]), np.zeros((0, 2, 2)))
    assert shared_flow(np.array([[0.0, 1.0], [-1.0, -1e-3]]), np.zeros((0, 2, 2))) is first  # equal matrices
    for k in range(flow.MAX_SHARED_FLOWS + 3):
        shared_flow(np.array([[0.0, 1.0], [-1.0 - k, -0.1]]), np.zeros((0, 2, 2)))
    assert before <= len(flow._FLOWS) == flow.MAX_SHARED_FLOWS


# ----------------------------------------------------------------------------------------------
# AffineMode: its flow, P M, P M^2 and the guards' Taylor rows
def _mode() -> AffineMode:
    """x'' = -x - 0.2 x' forced by S = sin(t): z = [x, v, S, C, 1], one guard v - 0.5, one slave
    variable a = 2 x + 1 (state [x, v, a])."""
    M = np.zeros((5, 5))
    M[0, 1] = 1.0
    M[1, :] = [-1.0, -0.2, 1.0, 0.0, 0.0]
    M[2, 3], M[3, 2] = 1.0, -1.0  # S' = C, C' = -S
    P = np.zeros((3, 5))
    P[0, 0] = P[1, 1] = 1.0
    P[2, :] = [2.0, 0.0, 0.0, 0.0, 1.0]
    W = np.array([[0.0, 1.0, 0.0, 0.0, -0.5]])
    d, a, q = np.array([0, 1]), np.array([2]), np.array([], dtype=int)
    return AffineMode(None, 1.0, d, a, q, M, P, np.zeros((0, 5, 5)), W)


def test_an_affine_modes_kept_values_are_declared_fields_and_exact():
    am = _mode()
    declared = {f.name for f in dataclasses.fields(am)}
    z = np.array([0.3, -0.4, 0.5, 0.8, 1.0])
    # y' and y'' by hand: x' = v, v' = -x - 0.2 v + S, a' = 2 x'
    vp = -0.3 + 0.08 + 0.5
    np.testing.assert_allclose(am.derivatives(z), [-0.4, vp, -0.8], rtol=1e-15)
    np.testing.assert_allclose(am.second_derivatives(z), [vp, 0.4 - 0.2 * vp + 0.8, 2 * vp], rtol=1e-15)
    assert am.flow() is am.flow()
    max_steps = [0.1 * (k + 1) for k in range(affine.GUARD_ROWS_KEPT + 4)]
    for max_step in max_steps:
        h, T = am.guard_taylor_rows(max_step, 6)
        assert 0 < h <= max_step
        for j in range(7):  # W M^j / j!
            np.testing.assert_allclose(
                T[:, j, :],
                am.W @ np.linalg.matrix_power(am.M, j) / math.factorial(j),
                rtol=1e-15,
                atol=1e-300,
            )
    assert len(am._guard_rows) == affine.GUARD_ROWS_KEPT
    assert am.guard_taylor_rows(max_steps[-1], 6) is am.guard_taylor_rows(max_steps[-1], 6)
    assert set(vars(am)) <= declared  # no attribute but its declared fields


def test_the_evaluations_of_an_analysis_are_bounded_and_kept():
    system = hybrid_models.absorber()
    an = system_analysis(system)
    base = system.preset("standard")
    omegas = [0.8 + 0.01 * k for k in range(affine.EVALUATED_KEPT + 5)]
    for w in omegas:
        values = [{**base, "Omega": w}[p] for p in an.params]
        out = an.evaluate(values)
        assert out[0][0] == w  # each mode's forcing frequency, as given
    assert len(an._evaluated) == affine.EVALUATED_KEPT
    assert an.evaluate(values) is out  # the most recent: kept
    assert not out[0][4].flags.writeable  # shared by every flow at these values: read-only


# ----------------------------------------------------------------------------------------------
# Systems with components: a sparse mode's dense form, a composed mode's rows and pattern
def test_a_sparse_modes_dense_form_is_a_declared_field(monkeypatch):
    monkeypatch.setattr(assembly, "DENSE_LIMIT", 0)
    monkeypatch.setattr(assembly, "dense_is_cheaper", lambda am: False)  # the sparse path, whatever it costs
    n = 3
    system = composed_chain(n)
    cs = CompiledSystem(system, chain_params(n))
    from hybrid.integrators.flows import exact_flows

    am = exact_flows(cs)[cs.mode_id(system.default_mode)]
    assert isinstance(am, assembly.SparseAffineMode)
    dense = am.dense()
    assert am.dense() is dense
    for name in ("M", "P", "W"):
        np.testing.assert_array_equal(getattr(dense, name), getattr(am, name).toarray())
    assert set(vars(am)) <= {f.name for f in dataclasses.fields(am)}  # `_dense` among them


def test_a_composed_modes_rows_and_pattern_are_declared_fields():
    n = 3
    system = composed_chain(n)
    cs = CompiledSystem(system, chain_params(n))
    mode = cs.modes[cs.mode_id(system.default_mode)]
    before = set(vars(mode))
    f_expr, g_expr = mode.f_expr, mode.g_expr
    assert sorted(f_expr) == mode.diff_idx.tolist()  # one row each, differential or slave
    assert sorted(g_expr) == mode.alg_idx.tolist()
    assert mode.f_expr is f_expr
    pattern = mode._pattern()
    assert mode._pattern() is pattern
    assert set(vars(mode)) == before


def test_a_kept_kernel_is_that_of_a_fresh_flow():
    # no state carried between calls: after others were made and dropped, the same matrix
    w = 0.5
    f = _oscillator(w)
    first = f.kernel(0.3)[0]
    for h in np.linspace(0.01, 1.0, 40):
        f.kernel(float(h))
    np.testing.assert_array_equal(f.kernel(0.3)[0], first)
    np.testing.assert_array_equal(_oscillator(w).kernel(0.3)[0], first)
