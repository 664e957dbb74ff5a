"""Runs streamed to sinks (issue 13, item 4): CSV files equal to the in-memory ones, the kept tail,
the energy balance from the values at the start and the end, sample caps, constant memory."""

import filecmp
import tracemalloc

import numpy as np
import pytest

import hybrid.engine.eventloop as eventloop_module
import hybrid.engine.record as record_module
import hybrid.engine.simulate as simulate_module
import hybrid_models
from hybrid import (
    Envelope,
    EventsCSVWriter,
    HybridSystem,
    Mode,
    Sink,
    SolverOptions,
    Status,
    Tee,
    TrajectoryCSVWriter,
    Transition,
    simulate,
)
from hybrid.engine.io import trajectory_summary, write_events_csv, write_trajectory_csv


@pytest.fixture
def small_blocks(monkeypatch):
    """Blocks of 64 samples, so that short runs go through many of them."""
    monkeypatch.setattr(record_module, "BLOCK", 64)


def coulomb(periods: float = 12.0, **kwargs):
    """The forced Coulomb oscillator from rest: stick-slip with about 4 switches per period."""
    system = hybrid_models.coulomb()
    p = system.preset("forced")
    T = system.period_value(p)
    tr = simulate(
        system,
        p,
        (0.0, periods * T),
        {"x": 0.0, "v": 0.0},
        samples_per_period=50,
        include_events=True,
        **kwargs,
    )
    return system, T, tr


class Collect(Sink):
    """Keeps everything a sink receives."""

    def __init__(self):
        self.blocks, self.events = [], []

    def samples(self, t, y, mode, outputs):
        self.blocks.append((t, y, mode, outputs))

    def event(self, record):
        self.events.append(record)


def test_streamed_csv_files_equal_the_in_memory_ones(tmp_path, small_blocks):
    system, _, full = coulomb()
    assert full.n_transitions > 20
    assert full.t.size > 10 * 64
    write_trajectory_csv(full, tmp_path / "memory.csv")
    write_events_csv(full, tmp_path / "memory_events.csv")
    with (
        TrajectoryCSVWriter(tmp_path / "streamed.csv", system) as samples,
        EventsCSVWriter(tmp_path / "streamed_events.csv", system) as events,
    ):
        tail = coulomb(sink=Tee(samples, events))[2]
    assert filecmp.cmp(tmp_path / "memory.csv", tmp_path / "streamed.csv", shallow=False)
    assert filecmp.cmp(tmp_path / "memory_events.csv", tmp_path / "streamed_events.csv", shallow=False)
    assert samples.rows == full.t.size == tail.n_samples
    assert events.rows == full.n_transitions == tail.n_transitions
    assert tail.t.size == 1
    assert tail.t[0] == full.t_final  # the default tail: the last sample


def test_the_kept_tail_is_the_end_of_the_in_memory_run(small_blocks):
    _, T, full = coulomb()
    keep = 2.5 * T
    sink = Collect()
    tail = coulomb(sink=sink, keep_last=keep)[2]
    w = full.t_final - keep
    win = full.t >= w
    assert 0 < win.sum() < full.t.size
    np.testing.assert_array_equal(tail.t, full.t[win])
    np.testing.assert_array_equal(tail.y, full.y[win])
    np.testing.assert_array_equal(tail.mode, full.mode[win])
    for name in full.outputs:
        np.testing.assert_array_equal(tail[name], full[name][win])
    kept = [ev for ev in full.events if ev.t >= w]
    assert 0 < len(kept) < full.n_transitions
    assert [(e.t, e.source, e.target) for e in tail.events] == [(e.t, e.source, e.target) for e in kept]
    assert tail.n_transitions == full.n_transitions
    assert tail.events_dropped == full.n_transitions - len(kept)
    assert tail.n_samples == full.n_samples
    assert tail.samples_dropped == full.t.size - win.sum()
    assert tail.kept_from == w
    clipped = [(max(a, w), b, m) for a, b, m in full.mode_intervals() if b > w]
    assert tail.mode_intervals() == clipped
    # the sink got everything, in order
    np.testing.assert_array_equal(np.concatenate([b[0] for b in sink.blocks]), full.t)
    np.testing.assert_array_equal(np.concatenate([b[1] for b in sink.blocks]), full.y)
    assert [e.t for e in sink.events] == [e.t for e in full.events]


def test_a_stopped_run_keeps_the_window_before_the_stop(small_blocks):
    _, T, full = coulomb(max_transitions=15, throw=False)
    _, _, tail = coulomb(max_transitions=15, throw=False, sink=Sink(), keep_last=T)
    assert full.status == tail.status == Status.MAX_TRANSITIONS
    assert full.t_final < 12 * T
    win = full.t >= full.t_final - T
    np.testing.assert_array_equal(tail.t, full.t[win])
    assert tail.n_transitions == 15
    assert tail.mode_final == full.mode_final == full.events[-1].target


def test_energy_balance_of_a_streamed_run_equals_the_in_memory_one():
    _, _, full = coulomb()
    _, _, tail = coulomb(sink=Sink())
    a, b = trajectory_summary(full), trajectory_summary(tail)
    assert a == b
    # independently of the start/final values: from the first and last in-memory samples
    assert a["input_work"] == full["W"][-1] - full["W"][0] > 0
    assert a["dissipated_energy"] == full["D"][-1] - full["D"][0] > 0
    assert a["mechanical_energy_change"] == full["E"][-1] - full["E"][0]
    assert abs(a["energy_balance_residual"]) < 1e-6 * a["input_work"]
    assert a["samples"] == full.t.size
    assert a["transitions"] == full.n_transitions


def test_envelope_holds_the_extrema_of_every_bucket(small_blocks):
    _, T, full = coulomb()
    env = Envelope(["x", "H"], ["x", "v", "W", "D"], (0.0, full.t_final), buckets=37)
    coulomb(sink=env)
    edges = np.linspace(0.0, full.t_final, 38)
    b = np.clip(np.searchsorted(edges, full.t, side="right") - 1, 0, 36)
    for name in ("x", "H"):
        v = full[name]
        lo = np.array([v[b == k].min() for k in range(37)])
        hi = np.array([v[b == k].max() for k in range(37)])
        centres, elo, ehi = env.bounds(name)
        np.testing.assert_array_equal(elo, lo)
        np.testing.assert_array_equal(ehi, hi)
        np.testing.assert_allclose(centres, 0.5 * (edges[:-1] + edges[1:]))
        ts, vs = env.series(name)
        assert ts.size == 74
        assert np.all(np.diff(ts) >= 0)
        # every point of the series is a sample of the run
        i = np.searchsorted(full.t, ts)
        assert np.all(full.t[i] == ts)
        assert np.all(np.isin(vs, v))


def test_sample_caps_are_checked_before_the_run(monkeypatch):
    system = hybrid_models.coulomb()
    p = system.preset("forced")
    T = system.period_value(p)
    x0 = {"x": 0.0, "v": 0.0}
    with pytest.raises(ValueError, match=r"make 3000001 samples; at most 2000000 may be kept in memory"):
        simulate(system, p, (0.0, T), x0, samples_per_period=3_000_000)

    class Started(Exception):
        pass

    class Stop(Sink):
        def samples(self, t, y, mode, outputs):
            raise Started

    with pytest.raises(Started):  # streamed, the same run is allowed to start
        simulate(system, p, (0.0, T), x0, samples_per_period=3_000_000, sink=Stop())
    with pytest.raises(ValueError, match=r"at most 1000000000 may be handed to a sink"):
        simulate(system, p, (0.0, 2 * T), x0, samples_per_period=600_000_000, sink=Stop())
    with pytest.raises(
        ValueError, match=r"sampling every internal step of at most 1e-06 s over 10 s makes at least"
    ):
        simulate(system, p, (0.0, 10.0), x0, options=SolverOptions(max_step=1e-6))
    with pytest.raises(ValueError, match=r"`keep_last` needs a `sink`"):
        simulate(system, p, (0.0, T), x0, keep_last=1.0)
    with pytest.raises(ValueError, match=r"`keep_last` must be a number >= 0"):
        simulate(system, p, (0.0, T), x0, keep_last=-1.0, sink=Sink())
    with pytest.raises(TypeError, match=r"`sink` must have methods `samples` and `event`"):
        simulate(system, p, (0.0, T), x0, sink=[])


def test_the_in_memory_cap_also_holds_while_the_run_goes_on(monkeypatch):
    monkeypatch.setattr(simulate_module, "MAX_SAMPLES", 40)
    system = hybrid_models.coulomb()
    # 30 sample times pass the check before the run; the switches, sampled on both sides, add more
    tr = simulate(
        system,
        system.preset("free"),
        (0.0, 60.0),
        {"x": 3.0, "v": 0.0},
        t_eval=np.linspace(0.0, 60.0, 30),
        include_events=True,
        throw=False,
    )
    assert tr.status == Status.MAX_SAMPLES
    assert tr.t.size == 40
    assert tr.n_transitions >= 5
    assert "after 40 samples, the most a run may have kept in memory: stream them to a sink" in tr.message


SAW = HybridSystem(
    name="saw",
    variables=["s", "n"],
    parameters=["P"],
    modes=[Mode("up", derivatives={"s": "1/(10*P)", "n": "0"})],
    transitions=[
        Transition("up", "up", guard="s - 1", direction=1, name="wrap", reset={"s": "0", "n": "n + 1"})
    ],
    definitions={"twice": "2*s"},
    outputs=["twice"],
    period="P",
    initial_mode="up",
)


def _peak(periods: float, sink) -> tuple[int, object]:
    """Peak of traced Python memory [bytes] of a sawtooth run (a switch every 10 periods)."""
    tracemalloc.start()
    try:
        tr = simulate(
            SAW,
            {"P": 1.0},
            (0.0, periods),
            {"s": 0.03, "n": 0.0},
            samples_per_period=2,
            include_events=True,
            options=SolverOptions(max_step=2.0),
            sink=sink,
        )
        return tracemalloc.get_traced_memory()[1], tr
    finally:
        tracemalloc.stop()


def test_a_long_streamed_run_needs_no_more_memory(monkeypatch):
    monkeypatch.setattr(record_module, "BLOCK", 32)
    # (IDA hands over up to this many outputs per call into SUNDIALS, issue 34: a buffer of that
    # size per call; small here, so that the in-memory run's growth shows above it)
    monkeypatch.setattr(eventloop_module, "OUTPUTS_PER_CALL", 32)
    _peak(5, None)  # warm-up: compiled code, solver set-up
    short, _ = _peak(100, Sink())
    long, tr = _peak(1000, Sink())
    assert tr.n_samples == 2 * 1000 + 1 + 2 * 100
    assert tr.n_transitions == 100
    assert tr.t.size == 1
    assert long < 1.5 * short, (short, long)
    # the same runs kept in memory do grow: the comparison can tell
    in_memory, tr = _peak(1000, None)
    assert tr.t.size == tr.n_samples, (short, in_memory)
    assert in_memory > 3 * short, (short, in_memory)
