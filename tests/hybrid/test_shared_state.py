"""No shared mutable state (issue 21): a compiled system belongs to one owner at a time, caches are
explicit objects, and a HybridSystem is frozen and hashable.

The defect this guards against: ``Shooter(Omega=0.87)`` took from the model's cache the compiled
system that a live ``Shooter(Omega=0.86)`` was using and set its run-time parameter to 0.87 in
place, so the older shooter's map ran at the wrong frequency (its ``period`` no longer matched
its compiled system's).
"""

from __future__ import annotations

import dataclasses
import gc
import math

import numpy as np
import pytest

import hybrid_models
from hybrid import ORBIT_OPTIONS, Exact, SolverOptions
from hybrid.model.compiled import POOL_SIZE, lend
from hybrid.orbits.shooter import Shooter

OMEGAS = (0.85, 0.86, 0.87)


@pytest.fixture(scope="module")
def absorber():
    return hybrid_models.absorber()


@pytest.mark.parametrize("options", [ORBIT_OPTIONS, SolverOptions(method=Exact())], ids=["ida", "exact"])
def test_live_shooters_keep_their_own_parameters(absorber, options):
    shooters = [Shooter(absorber, absorber.preset("standard", Omega=w), options) for w in OMEGAS]
    for sh, w in zip(shooters, OMEGAS, strict=True):
        assert sh.cs.params["Omega"] == w
        assert sh.cs.period == pytest.approx(2 * math.pi / w, rel=1e-15)
        assert sh.period == sh.cs.period
    assert len({id(sh.cs) for sh in shooters}) == len(shooters)


def test_a_shooters_map_is_unchanged_by_a_later_shooter(absorber):
    """The map of a shooter, run before and after another is made at another frequency (the model's
    second compiled system read Omega at run time, and the third shooter took it over)."""
    y0 = np.array([0.3, 0.0, 0.5, 0.0, 0.5, 0.0, 0.0])  # x1 v1 x2 v2 u, quadratures W D
    first = Shooter(absorber, absorber.preset("standard", Omega=OMEGAS[0]), ORBIT_OPTIONS)
    second = Shooter(absorber, absorber.preset("standard", Omega=OMEGAS[1]), ORBIT_OPTIONS)
    before = second.run(y0, "stick", 0.0).y_final.copy()
    third = Shooter(absorber, absorber.preset("standard", Omega=OMEGAS[2]), ORBIT_OPTIONS)
    after = second.run(y0, "stick", 0.0).y_final
    np.testing.assert_array_equal(after, before)
    assert first.cs.params["Omega"] == OMEGAS[0]
    assert third.cs.params["Omega"] == OMEGAS[2]


def test_a_released_compiled_system_is_reused_not_shared(absorber):
    absorber = dataclasses.replace(absorber)  # a system of its own: its pool starts empty
    p = absorber.preset("standard")

    class Owner:
        pass

    a, b = Owner(), Owner()
    cs_a, release_a = lend(absorber, p, a)
    cs_b, _ = lend(absorber, p, b)
    assert cs_b is not cs_a  # both live: never the same object
    release_a()
    c = Owner()
    cs_c, _ = lend(absorber, p, c)
    assert cs_c is cs_a  # free again: reused, not compiled anew
    del b
    gc.collect()
    d = Owner()
    cs_d, _ = lend(absorber, p, d)
    assert cs_d is cs_b  # returned when its owner was collected


def test_the_pool_keeps_at_most_its_size(absorber):
    absorber = dataclasses.replace(absorber)
    owners = [type("Owner", (), {})() for _ in range(POOL_SIZE + 3)]
    loans = [
        lend(absorber, absorber.preset("standard", Omega=0.8 + 0.01 * k), o) for k, o in enumerate(owners)
    ]
    for _, release in loans:
        release()
    pool = absorber.cache.get("compiled_pool", lambda: None)
    assert len(pool._free) == POOL_SIZE


def test_a_system_is_hashable_and_frozen(absorber):
    other = dataclasses.replace(absorber)  # the same content, another system
    assert other == absorber  # equal fields: equal systems
    assert hash(other) == hash(absorber)
    assert {absorber: 1}[other] == 1
    assert other.cache is not absorber.cache  # each keeps what is derived from it
    assert dataclasses.replace(absorber, title="another title") != absorber
    with pytest.raises(dataclasses.FrozenInstanceError):
        absorber.name = "other"
    before = set(vars(absorber))
    Shooter(absorber, absorber.preset("standard"), SolverOptions(method=Exact()))
    Shooter(absorber, absorber.preset("standard"), ORBIT_OPTIONS).run(np.zeros(7), "stick", 0.0)
    assert set(vars(absorber)) == before  # nothing written into the system after construction


def test_shared_systems_are_a_bounded_cache_and_a_dropped_one_fails_to_unpickle(absorber):
    # issue 29, item 4: every system ever shared was kept until the process exited
    import pickle

    from hybrid.core.errors import InputTypeError
    from hybrid.model import system as system_mod

    systems = [dataclasses.replace(absorber) for _ in range(system_mod.MAX_SHARED_SYSTEMS + 5)]
    system_mod.shared(systems[0])
    first = pickle.dumps(systems[0])
    assert pickle.loads(first) is systems[0]  # by reference, the same object
    for s in systems[1:]:
        system_mod.shared(s)
    assert len(system_mod._SHARED) == system_mod.MAX_SHARED_SYSTEMS
    last = systems[-1]
    assert pickle.loads(pickle.dumps(last)) is last
    system_mod.shared(last)  # shared again: the same reference still holds
    assert pickle.loads(pickle.dumps(last)) is last
    limit = f"among the {system_mod.MAX_SHARED_SYSTEMS} systems shared last"
    with pytest.raises(InputTypeError, match=limit):
        pickle.loads(first)  # dropped since: refused, not another system
    with pytest.raises(InputTypeError, match=limit):  # a later system at a freed one's address
        system_mod._shared_system(id(last), -1)
    with pytest.raises(InputTypeError, match=r"not pickled by value"):
        pickle.dumps(systems[0])
