"""IDA from output to output inside SUNDIALS (issue 34, ``ModeSolver.advance``): the same run as the
call-per-output path, to the last bit.

Regression (issue 34, first merge reverted): the output path re-started IDA after its first two
outputs and put an output before a lone one, which changed IDA's first step; a sampled run then
differed from the unsampled run of the same iterate at the tolerance's level, and the orbits' Newton
steps, which take the sampled run for the iterate, needed more iterations (the tutorial's frequency
response on IDA stalled: a gap 49.1-71.5 rad/s).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import hybrid
import hybrid.core.budget as budget_module
import hybrid.integrators.ida as ida_module
from hybrid import IDA, SolverOptions

OPTIONS = SolverOptions(method=IDA())


def _run(t_eval):
    system = hybrid.resolve_model("coulomb")
    p = system.preset("forced", Omega=0.5)
    T = 2.0 * math.pi / p["Omega"]
    x0 = {"x": -0.13, "v": 0.33}
    return hybrid.simulate(system, p, (0.0, 2.0 * T), x0, t_eval=t_eval * T, options=OPTIONS)


def _same(a, b) -> None:
    assert a.status == b.status
    assert np.array_equal(a.y[-1], b.y[-1])  # to the bit
    assert [(e.guard, e.t) for e in a.events] == [(e.guard, e.t) for e in b.events]
    assert a.nfev == b.nfev


@pytest.fixture
def stepwise(monkeypatch):
    """The call-per-output path (the event loop takes advance only where the solver has it)."""

    def run(t_eval):
        with monkeypatch.context() as m:
            m.delattr(ida_module.ModeSolver, "advance")
            return _run(t_eval)

    return run


@pytest.fixture
def calls(monkeypatch):
    """What ModeSolver.advance returned, call by call (None: abandoned by its watch)."""
    got: list = []
    advance = ida_module.ModeSolver.advance

    def counted(self, ts, watch=None):
        r = advance(self, ts, watch)
        got.append(r)
        return r

    monkeypatch.setattr(ida_module.ModeSolver, "advance", counted)
    return got


def test_a_sampled_run_is_the_call_per_output_run(stepwise, calls):
    grid = np.linspace(0.0, 2.0, 257)
    fast = _run(grid)
    assert calls and all(c is not None for c in calls)  # (the run went from output to output in IDA)
    slow = stepwise(grid)
    _same(fast, slow)
    assert np.array_equal(fast.t, slow.t)
    assert np.array_equal(fast.y, slow.y)


def test_a_run_of_more_samples_than_a_call_goes_step_by_step(monkeypatch, stepwise, calls):
    # (a call that ended before the end of the run would start IDA again: other steps, another error;
    # tests/models/test_dampers.py's stuck absorber over 104 periods had 2.9e-8 for 1.9e-8 with one)
    import hybrid.engine.eventloop as eventloop_module

    grid = np.linspace(0.0, 2.0, 257)
    monkeypatch.setattr(eventloop_module, "OUTPUTS_PER_CALL", 16)
    fast = _run(grid)
    slow = stepwise(grid)
    _same(fast, slow)
    assert np.array_equal(fast.y, slow.y)
    assert calls == []  # (every segment here has more than 16 samples left to the end)


def test_a_call_that_outgrows_its_allowance_goes_on_step_by_step_to_the_same_run(
    monkeypatch, stepwise, calls
):
    monkeypatch.setattr(budget_module.Budget, "call_allowance", property(lambda self: 1))
    monkeypatch.setattr(ida_module, "WATCH_EVERY", 8)  # (a call here takes ~200 evaluations)
    grid = np.linspace(0.0, 2.0, 257)
    fast = _run(grid)
    assert calls == [None]  # abandoned at its first watch; the run went on step by step
    _same(fast, stepwise(grid))
