"""Pieces of a frequency response computed at once in forked worker processes."""

import multiprocessing
import pickle

import numpy as np
import pytest

import hybrid_models
from hybrid import Exact, SolverOptions, WorkerError, frequency_response

EXACT = SolverOptions(method=Exact())
RANGE = (0.85, 1.175)  # both resonances of the absorber: two pieces


@pytest.mark.slow
def test_two_workers_give_the_same_curve_and_the_same_orbits_in_the_same_order():
    """Each piece is computed by the same code from the same start, so the result is identical
    (not merely close) to the serial one, and ``on_point`` sees the same orbits in branch order."""
    system = hybrid_models.absorber()
    p = system.preset("standard")
    runs = {}
    for workers in (1, 2):
        seen, fractions, waiting = [], [], []
        before = set(multiprocessing.active_children())  # (other tests' pools may still be alive)
        fr = frequency_response(
            system,
            p,
            RANGE,
            options=EXACT,
            workers=workers,
            on_point=lambda k, o, seen=seen: seen.append((k, o.params["Omega"], o.amplitude["x1"])),
            progress=fractions.append,
            # called once with workers, when every one has started; never without
            while_computing=lambda w=waiting, b=before: w.append(
                len(set(multiprocessing.active_children()) - b)
            ),
        )
        assert waiting == ([] if workers == 1 else [2])
        assert len(fr.pieces) == 2, fr.messages()
        assert not fr.gaps, fr.messages()
        assert fractions
        assert fractions[-1] == pytest.approx(1.0)
        assert max(fractions) <= 1.0
        runs[workers] = (seen, fr)
    (seen1, fr1), (seen2, fr2) = runs[1], runs[2]
    assert seen1 == seen2
    assert [k for k, _, _ in seen2] == sorted(k for k, _, _ in seen2)
    assert len(fr1.branches) == len(fr2.branches)
    for b1, b2 in zip(fr1.branches, fr2.branches, strict=True):
        np.testing.assert_array_equal(b1.values, b2.values)
        assert [o.amplitude for o in b1.points] == [o.amplitude for o in b2.points]
        assert [(s.kind, s.parameter, s.interval) for s in b1.special] == [
            (s.kind, s.parameter, s.interval) for s in b2.special
        ]
    assert all(o.system is system for b in fr2.branches for o in b.points)  # the parent's own model


def test_an_interrupt_stops_the_workers_and_keeps_the_orbits_passed_on():
    system = hybrid_models.absorber()
    seen = []
    calls = {"n": 0}

    def progress(fraction):
        calls["n"] += 1
        if calls["n"] == 20:
            raise KeyboardInterrupt

    before = set(multiprocessing.active_children())  # (other tests' pools may still be alive)
    with pytest.raises(KeyboardInterrupt):
        frequency_response(
            system,
            system.preset("standard"),
            RANGE,
            options=EXACT,
            workers=2,
            progress=progress,
            on_point=lambda k, o: seen.append(k),
        )
    assert set(multiprocessing.active_children()) <= before
    assert seen == sorted(seen)


def test_a_model_is_not_pickled_by_value():
    system = hybrid_models.coulomb()
    with pytest.raises(TypeError, match="not pickled by value"):
        pickle.dumps(system)


@pytest.mark.parametrize("workers", [0, -1, 1.5, True, "2"])
def test_workers_must_be_a_positive_integer(workers):
    system = hybrid_models.coulomb()
    with pytest.raises(ValueError, match="`workers` must be an integer >= 1"):
        frequency_response(system, system.preset("forced"), (0.5, 0.6), workers=workers)


def test_an_error_in_a_worker_is_raised_here_with_its_message(monkeypatch):
    import hybrid.continuation.frc as frc

    def boom(self, a, b, w, progress, on_point):
        if a > 1.0:
            raise ValueError("boom in the second piece")
        return frc.Piece(a, b, w)

    monkeypatch.setattr(frc._PieceJob, "piece", boom)  # (the forked workers inherit it)
    system = hybrid_models.absorber()
    before = set(multiprocessing.active_children())
    with pytest.raises(
        WorkerError, match=r"the worker of piece 1 failed: ValueError: boom in the second piece"
    ):
        frequency_response(system, system.preset("standard"), RANGE, options=EXACT, workers=2)
    assert set(multiprocessing.active_children()) <= before
