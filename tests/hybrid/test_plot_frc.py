"""The frequency-response figure draws only what was computed."""

from __future__ import annotations

import pytest

from hybrid.plot.frc import _runs


def test_runs_join_at_a_located_change_and_stop_at_a_bracketed_one():
    stab = ["stable", "stable", "neutral", "neutral"]
    # located: the segment up to the first orbit of the new regime belongs to the old one
    assert _runs(stab) == [(0, 2, "stable"), (2, 3, "neutral")]
    # bracketed between points 1 and 2: that segment was not computed, no run crosses it
    assert _runs(stab, frozenset({1})) == [(0, 1, "stable"), (2, 3, "neutral")]


# --- issue 24: figures that fit any model


def test_crowded_labels_do_not_overlap_and_the_rest_are_counted():
    from hybrid.plot.frc import _label_special
    from hybrid.plot.trajectory import _new_figure

    fig = _new_figure((5.0, 3.0), layout=None)
    ax = fig.add_subplot(111)
    ax.set_xlim(0.0, 1.0)
    ax.set_ylim(0.0, 1.0)
    kinds = ["fold", "mode-gained", "mode-lost", "grazing"]
    items = [
        {"kind": kinds[k % 4], "x": 0.3 + 0.01 * k, "y": 0.5 + 0.005 * k, "interval": None} for k in range(24)
    ]
    renderer = fig.canvas.get_renderer()
    dropped = _label_special(ax, items, renderer, "rad/s")
    boxes = [t.get_window_extent(renderer) for t in ax.texts]
    assert len(boxes) >= 3
    assert dropped > 0  # 24 labels do not fit
    assert len(boxes) + dropped <= 24  # one label per cluster of one kind, the others left out
    axbox = ax.get_window_extent(renderer)
    for i, a in enumerate(boxes):
        assert axbox.x0 <= a.x0
        assert a.x1 <= axbox.x1
        for b in boxes[i + 1 :]:
            assert not a.overlaps(b)


def test_a_bracket_is_labelled_with_digits_enough_to_tell_its_ends_apart():
    from hybrid.plot.frc import _interval

    assert _interval(51.6356822, 51.63569202) == "[51.63568, 51.63569]"
    assert _interval(0.51, 0.61) == "[0.51, 0.61]"


@pytest.mark.slow
def test_the_absorbers_zoom_panels_hold_its_stick_slip_bands_and_their_resonances():
    import hybrid_models
    from hybrid import Exact, SolverOptions, frequency_response
    from hybrid.plot.frc import zoom_windows

    absorber = hybrid_models.absorber()
    p = absorber.preset("standard")
    lo, hi = 0.8, 0.9  # the first resonance (0.8543 rad/s) and its stick-slip band
    fr = frequency_response(absorber, p, (lo, hi), options=SolverOptions(method=Exact()))
    zooms = zoom_windows(fr)
    assert len(zooms) == 1
    for (a, b, w), res in zip(zooms, fr.resonances[:1], strict=True):
        assert b - a < 0.1 * (hi - lo)  # detail too narrow to see over the whole range
        assert w == res
        assert a < res < b
        kinds = {sp.kind for br in fr.branches for sp in br.special if a <= sp.parameter <= b}
        assert {"mode-gained", "mode-lost"} <= kinds
