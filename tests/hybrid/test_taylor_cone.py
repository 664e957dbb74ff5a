"""The series of a guard from the variables it depends on only (issue 34): at a switch, IDA's event
loop judges a guard at zero by its Taylor series along the flow; for a guard of one block of a chain
that series needs the blocks within ``order`` springs of it, not the whole chain's series."""

from __future__ import annotations

import tomllib
from pathlib import Path

import numpy as np
import pytest

import hybrid_models
from hybrid import IDA, simulate, system_from_dict
from hybrid.model.compiled import CompiledSystem

N = 16
ORDER = 4


@pytest.fixture(scope="module")
def chain_state():
    data = tomllib.loads((Path(hybrid_models.__file__).parent / "bk_chain.toml").read_text())
    data["cells"]["block"]["count"] = N
    system = system_from_dict(data)
    p = system.preset("standard")
    ts = np.linspace(0.0, 12.0, 121)
    tr = simulate(system, p, (0.0, 12.0), dict.fromkeys(system.variable_names, 0.0), t_eval=ts)
    # the last sample in a mode with stuck and sliding blocks (slave and differential rows)
    j = max(i for i, m in enumerate(tr.mode) if "stick" in str(m) and "slip" in str(m))
    cs = CompiledSystem(system, p)
    cm = cs.modes[cs.mode_id(str(tr.mode[j]))]
    return cs, cm, float(tr.t[j]), tr.y[j]


def test_a_guards_series_from_its_cone_is_the_full_series(chain_state):
    cs, cm, t, y = chain_state
    full = cm.taylor(t, y, ORDER)
    checked = 0
    for k, g in enumerate(cm.guards):
        cone = cm.taylor_cone(g.expr, ORDER)
        want = cm.guard_series(k, t, y, ORDER, full)
        got = cm.guard_series(k, t, y, ORDER, cm.taylor(t, y, ORDER, rows=cone))
        np.testing.assert_allclose(got, want, rtol=1e-14, atol=1e-300)
        checked += bool(cone)
    assert checked >= N


def test_the_cone_of_a_blocks_guard_spans_the_blocks_within_order_springs(chain_state):
    _, cm, _, _ = chain_state
    names = cm.names[: cm.n]
    for g in cm.guards:
        if not g.name.startswith("contact_8."):
            continue
        blocks = {int(names[i].rsplit("_", 1)[1]) for i in cm.taylor_cone(g.expr, ORDER) if "_" in names[i]}
        # x_8'' couples x_7, x_9; each further derivative one spring further: 8 +- 4 at most
        assert blocks <= set(range(8 - ORDER, 8 + ORDER + 1))
        assert 8 in blocks and len(blocks) < N


def test_ida_guard_series_of_a_small_model_is_unchanged():
    # (the whole flow's series where a cone would hold most variables: the belt's two)
    belt = hybrid_models.belt_stribeck()
    cs = CompiledSystem(belt, belt.preset("standard"))
    y = np.array([0.3, -0.2])
    for m, cm in enumerate(cs.modes):
        full = cm.taylor(0.0, y, ORDER)
        series = IDA().guard_series(cs, m, 0.0, y, ORDER)
        for k in range(len(cm.guards)):
            np.testing.assert_array_equal(series(k), cm.guard_series(k, 0.0, y, ORDER, full))
