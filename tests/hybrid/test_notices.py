"""Warnings collected once per run of a public function (issue 30: ``hybrid.frequency_response``
printed one RuntimeWarning per disarmed guard crossing, about 150 on the tutorial's damper)."""

from __future__ import annotations

import warnings

import pytest

from hybrid.core.notices import collected, kind_of


@collected
def _inner(n: int) -> int:
    for i in range(n):
        warnings.warn(
            f"guard `g` crossed zero at t~{0.1 * i!r}; lower max_step", RuntimeWarning, stacklevel=2
        )
    return n


@collected
def _outer() -> int:
    warnings.warn("another kind; do this", UserWarning, stacklevel=2)
    return _inner(4) + _inner(3)


def test_one_warning_per_kind_with_its_count():
    with warnings.catch_warnings(record=True) as got:
        warnings.simplefilter("always")
        assert _outer() == 7
    texts = [str(w.message) for w in got]
    assert len(texts) == 2, texts
    assert texts[0] == "another kind; do this"
    assert texts[1].startswith("guard `g` crossed zero at t~0.0; lower max_step")
    assert texts[1].endswith("(7 times in this run; the first shown)")
    assert [w.category for w in got] == [UserWarning, RuntimeWarning]


def test_warnings_are_emitted_when_the_call_raises_and_filters_still_apply():
    @collected
    def bad():
        warnings.warn("before the error; act", RuntimeWarning, stacklevel=2)
        raise ValueError("no")

    with warnings.catch_warnings(record=True) as got:
        warnings.simplefilter("always")
        with pytest.raises(ValueError):
            bad()
    assert [str(w.message) for w in got] == ["before the error; act"]
    with warnings.catch_warnings(record=True) as got:
        warnings.simplefilter("always")
        warnings.filterwarnings("ignore", message=".*crossed zero")  # the tutorial's advice still works
        _inner(5)
    assert got == []


def test_kind_of_leaves_the_numbers_out():
    assert kind_of("at t~0.25 and 1e-3, 7 times") == kind_of("at t~3 and 2.5e+07, 12 times")
