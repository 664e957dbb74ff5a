"""The frequency-response figure draws only what was computed."""

from __future__ import annotations

from hybrid.plot.frc import _runs


def test_runs_join_at_a_located_change_and_stop_at_a_bracketed_one():
    stab = ["stable", "stable", "neutral", "neutral"]
    # located: the segment up to the first orbit of the new regime belongs to the old one
    assert _runs(stab) == [(0, 2, "stable"), (2, 3, "neutral")]
    # bracketed between points 1 and 2: that segment was not computed, no run crosses it
    assert _runs(stab, frozenset({1})) == [(0, 1, "stable"), (2, 3, "neutral")]
