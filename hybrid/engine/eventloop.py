"""The event loop of a simulation: :class:`Run`, one smooth segment after another.

The run is a sequence of smooth segments, each integrated by a mode solver (IDA, or the exact
flow of an affine mode: the contract of :mod:`hybrid.integrators.base`) in one mode. At a
located guard crossing the transition's reset is applied, the slave variables of the new mode
are solved from its algebraic equations, consistent derivatives are computed, and the new mode
is checked for admissibility:

* a guard of the new mode that already lies beyond zero on its firing side
  is taken at once (chained switch at the same instant);
* a guard of the new mode that starts at zero (within its noise level) is
  judged by the Taylor series of the guard along the new mode's flow: if it
  leaves zero towards its firing side, it is taken at once; otherwise it is
  *disarmed* (reported to the solver as a constant of the safe sign) until it has
  left zero by more than its noise level, so that rounding flicker of a guard
  that leaves zero only quadratically (slip -> stick) cannot re-fire it.

The successor mode is therefore decided by the vector fields, not by the sign
of a guard value that is zero up to rounding.
"""

from __future__ import annotations

import math
import warnings
from collections import deque

import numpy as np

from ..core.budget import Budget
from ..core.errors import AlgebraicSolveError, BudgetExceeded, SampleCapReached, SimulationError
from ..integrators.base import ROOT, TSTOP, FlowSolver, StepResult
from ..integrators.ida import explain
from ..integrators.options import SolverOptions
from ..model.compiled import CompiledMode, CompiledSystem, lead_sign
from ..model.linear import fast_dynamics
from .record import Recorder
from .sampling import SampleGrid
from .trajectory import Status, Trajectory, TransitionRecord

__all__ = ["step_bound"]


#: First step of the restart after IDA failed on its first step, as a fraction of the step bound.
CAREFUL_FIRST_STEP = 1e-6

#: Output times handed to IDA in one call (:meth:`Run.segment_outputs`; fewer for a large state, whose
#: rows IDA's wrapper allocates at once: at most OUTPUT_VALUES_PER_CALL values). A segment whose
#: samples left to the end of the run are more goes step by step (:meth:`Run.segment`): a call that
#: ended before the end of the run would start IDA again, and a run of other steps has another error.
OUTPUTS_PER_CALL = 8192
OUTPUT_VALUES_PER_CALL = 2**19


class _CallbackFailed(Exception):
    """The user's progress callback raised (re-raised unchanged by :func:`simulate`)."""

    def __init__(self, exc: BaseException):
        super().__init__(str(exc))
        self.exc = exc


def _ending(Y: np.ndarray, ts: np.ndarray, r: StepResult) -> np.ndarray:
    """Rows ``Y`` of samples at ``ts`` with the one at the step's end ``r.t`` (if any) set to ``r.y``."""
    Y[ts == r.t] = r.y
    return Y


class _Stop(Exception):
    def __init__(self, status: Status, message: str):
        super().__init__(message)
        self.status = status
        self.message = message


def step_bound(cs: CompiledSystem, options: SolverOptions, t0: float, t1: float) -> float:
    """IDA's step bound [s]: ``max_step``, else a sixteenth of the period, else a fiftieth of the span."""
    return options.max_step or (cs.period / 16.0 if cs.period else (t1 - t0) / 50.0)


class Run:
    """State of one simulation (kept out of :func:`simulate` for readability)."""

    def __init__(
        self,
        cs: CompiledSystem,
        options: SolverOptions,
        atol,
        t0,
        t1,
        samples,
        include_events,
        max_transitions,
        progress,
        with_outputs: bool = True,
    ):
        self.cs = cs
        self.opt = options
        self.integ = options.method
        self.atol = np.asarray(atol)
        self.t0, self.t1 = t0, t1
        self.samples = samples
        self.next_sample = 0
        self.include_events = include_events
        self.record_steps = samples is None
        self.max_transitions = max_transitions
        self.progress = progress
        self.max_step = step_bound(cs, options, t0, t1)
        # Without a period the window is absolute (a fraction of the span would call any run long
        # enough a Zeno burst).
        self.zeno_window = options.zeno_window or (1e-6 * cs.period if cs.period else 1e-6)
        self.solvers: dict[int, FlowSolver] = {}
        self.careful: dict[int, FlowSolver] = {}  # solvers with a small first step (see segment)
        self.budget: Budget | None = None
        self.events: list[TransitionRecord] = []
        # a burst counts this many switches (per component of a composed system: contacts may switch
        # together at one instant)
        self.recent = deque(maxlen=options.zeno_count * (1 + len(cs.system.components)))
        self.nfev = self.njev = self.n_steps = 0
        self.stepwise = False  # True once a call from output to output outgrew its allowance (watch)
        self._next_progress = 0.0
        self.current: tuple[float, np.ndarray, int] = (t0, np.zeros(len(cs.names)), 0)
        self.unresolved = 0  # consecutive switches whose guard never left its noise band
        # Switches at one instant: each component of a composed system may switch in one chain (a
        # symmetric chain of contacts sticks all at once), a few times each.
        self.max_chain = options.max_chain * (1 + len(cs.system.components))
        self.with_outputs = with_outputs  # evaluate the outputs (samples, start and final values)
        quad = set(cs.system.quadratures)  # the variables that are not quadratures (for noise)
        self.dynamic = np.array([i for i, n in enumerate(cs.names) if n not in quad], dtype=int)

    # ------------------------------------------------------------------
    def solver(self, mode: int, careful: bool = False) -> FlowSolver:
        """The mode's solver (``careful``: with a tiny first step), from the integrator
        (:meth:`hybrid.integrators.base.Method.mode_solver`), kept for the run."""
        store = self.careful if careful else self.solvers
        s = store.get(mode)
        if s is None:
            h0 = CAREFUL_FIRST_STEP * self.max_step if careful else 0.0
            s = store[mode] = self.integ.mode_solver(
                self.cs, mode, self.opt, max_step=self.max_step, first_step=h0
            )
        return s

    def noises(self, cm, t: float, y: np.ndarray) -> np.ndarray | None:
        """The noise level of every guard of ``cm`` at once (see :meth:`noise`: the method's
        model), where the mode offers it in one call (a mode of a system with components); else None."""
        size = float(np.max(np.abs(y[self.dynamic]))) if self.dynamic.size else 0.0
        return self.integ.guard_bands(cm, self.atol, t, y, size)

    def noise(self, cm: CompiledMode, k: int, t: float, y: np.ndarray) -> float:
        grad, ht = cm.guard_gradient(k, t, y)
        size = float(np.max(np.abs(y[self.dynamic]))) if self.dynamic.size else 0.0
        return self.integ.guard_band(self.atol, grad, ht, t, y, size)

    def record(self, t: float, y: np.ndarray, mode: int) -> None:
        # completed switches go to the recorder first: no switch is pending while a sample is taken
        for ev in self.events:
            self.rec.add_event(ev)
        self.events.clear()
        cm = self.cs.modes[mode]
        try:
            # (the recorder copies y: no copy here where there is no slave variable to re-solve)
            self.rec.add(t, self.project(cm, t, y) if cm.alg_idx.size else y, mode)
        except SampleCapReached as exc:
            raise _Stop(Status.MAX_SAMPLES, str(exc)) from None

    def outputs(self, t: np.ndarray, y: np.ndarray, m: np.ndarray) -> dict[str, np.ndarray]:
        """The system's outputs at samples ``(t, y, mode index)``."""
        out = {o: np.empty(t.size) for o in self.cs.system.outputs}
        if not out:
            return out
        for k in np.unique(m).tolist():
            cm = self.cs.modes[k]
            idx = np.flatnonzero(m == k)
            vals = cm.outputs_at(t[idx], y[idx])
            if vals is not None:
                for o, v in zip(out, vals, strict=True):
                    out[o][idx] = v
                continue
            fns = [(out[o], o, cm.outputs[o]) for o in out]  # sample by sample: which one fails
            for i in idx:
                v = [t[i], *y[i].tolist()]
                for col, o, fn in fns:
                    try:
                        col[i] = fn(v)
                    except (ArithmeticError, ValueError) as exc:
                        raise _Stop(
                            Status.EVALUATION_FAILED,
                            f"evaluating output `{o}` of mode `{cm.name}` at t={float(t[i])!r} failed: "
                            f"{type(exc).__name__}: {exc}",
                        ) from None
        return out

    def values(self, t: float, y: np.ndarray, mode: int) -> dict[str, float]:
        """Every variable and output at ``(t, y)`` in ``mode`` (slave variables re-solved)."""
        y = self.project(self.cs.modes[mode], t, y)
        out = self.outputs(np.array([t]), y[None, :], np.array([mode]))
        return {
            **dict(zip(self.cs.names, y.tolist(), strict=True)),
            **{o: float(v[0]) for o, v in out.items()},
        }

    def project(self, cm: CompiledMode, t: float, y: np.ndarray) -> np.ndarray:
        """``y`` with the slave variables of ``cm`` re-solved (IDA's interpolant satisfies the
        algebraic equations only to the integration tolerance; the exact flow satisfies them)."""
        if cm.alg_idx.size == 0 or not self.integ.resolves_slaves:
            return np.array(y, dtype=float)
        try:
            return cm.solve_algebraic(t, y)
        except AlgebraicSolveError as exc:
            raise _Stop(Status.ALGEBRAIC_FAILED, str(exc)) from None

    def _independent(self, name: str, fired: list[str], after_switch: bool) -> bool:
        """Whether the transition ``name``, due at the instant of the switches ``fired`` (and of
        the logged switch that led here, if ``after_switch``), belongs to a component none of
        them belongs to (a system without components: never)."""
        if not self.cs.system.composed:
            return False
        before = list(fired)
        if after_switch and self.events:
            before.append(self.events[-1].guard)
        part = name.split(".", 1)[0] if "." in name else ""
        return all((f.split(".", 1)[0] if "." in f else "") != part for f in before)

    # ------------------------------------------------------------------
    def enter(self, mode: int, t: float, y: np.ndarray, after_switch: bool):
        """Consistent state in ``mode`` at ``t``, following switches the vector fields force.

        Returns ``(mode, y, yp, disarmed)`` (``yp`` None where the integrator does not need it) with
        ``disarmed`` mapping guard index to the safe sign reported to the solver while it is disarmed.
        """
        visited: list[tuple[int, np.ndarray]] = []
        states: dict[int, list[np.ndarray]] = {}  # the states each mode of the chain was entered with
        fired: list[str] = []  # the transitions of the chain
        unresolved: list[str] = []  # switches of the chain decided within a guard's noise level
        pending = len(self.events) - 1 if after_switch else None
        while True:
            cm = self.cs.modes[mode]
            try:
                y = cm.solve_algebraic(t, y)
            except AlgebraicSolveError as exc:
                raise _Stop(Status.ALGEBRAIC_FAILED, str(exc)) from None
            if pending is not None and pending >= 0:
                self.set_plus(pending, y)
            self.current = (t, y, mode)
            vals = cm.guard_values(t, y)
            fire, disarmed = None, {}
            series_at = None  # the guards' Taylor series along the flow from (t, y), made if a guard needs it
            etas = self.noises(cm, t, y)
            if etas is None:
                candidates = cm.guards
            else:  # the guards that may fire or need a look, in order (the others do nothing)
                dirs = cm.guard_directions
                look = np.flatnonzero((np.abs(vals) <= etas) | (dirs * vals > 0))
                candidates = (cm.guards[int(k)] for k in look)
            for g in candidates:
                h = vals[g.index]
                d = g.direction
                eta = etas[g.index] if etas is not None else self.noise(cm, g.index, t, y)
                if abs(h) <= eta:
                    if series_at is None:
                        series_at = self.integ.guard_series(self.cs, mode, t, y, self.opt.taylor_order)
                    s = lead_sign(series_at(g.index), eta)
                    if d != 0 and s == d:
                        # coincident (reached zero by itself, not put there by this instant's
                        # switches): only a guard of another component than those that switched;
                        # a component's own next switch (a stop and the breakaway it lands on
                        # when the friction level is 0) is caused by its previous one
                        fire, coincident = g, self._independent(g.name, fired, after_switch)
                        unresolved.append(f"`{g.name}` of mode `{cm.name}` ({h:.3g} within {eta:.3g})")
                        break
                    disarmed[g.index] = s if s != 0 else (-float(d) if d else 1.0)
                elif d != 0 and d * h > 0:
                    fire, coincident = g, False
                    break
            if fire is None:
                halt = cm.halt
                if halt:
                    raise _Stop(Status.HALTED, f"halted at t={t!r} in mode `{cm.name}`: {halt}")
                if not np.all(np.isfinite(y)):
                    raise _Stop(
                        Status.SOLVER_FAILED, f"state became non-finite at t={t!r} in mode `{cm.name}`"
                    )
                # (the exact flow starts from the state alone: no consistent y' to compute)
                yp = cm.derivatives(t, y) if self.integ.needs_derivatives else None
                return mode, y, yp, disarmed
            visited.append((mode, y))
            fired.append(fire.name)
            y_new = self.apply_reset(fire, t, y)
            target = fire.target
            # A chain may pass a mode twice if the state changed on the way (an inconsistent
            # initial state relaxes through an instantaneous slip); the same mode with the same
            # state is a loop.
            seen = states.setdefault(mode, [])
            seen.append(y)
            loop = any(np.allclose(ym, y_new, rtol=1e-13, atol=1e-15) for ym in states.get(target, ()))
            if loop or len(visited) > self.max_chain:
                if self.cs.system.composed:  # its modes' names are long: the switches say what happened
                    path = f"mode `{self.cs.mode_name(visited[0][0])}` through the switches " + " -> ".join(
                        fired
                    )
                else:
                    path = " -> ".join(
                        [self.cs.mode_name(m) for m, _ in visited] + [self.cs.mode_name(target)]
                    )
                if target == mode:
                    raise _Stop(
                        Status.ZENO,
                        f"Zeno point at t={t!r}: transition `{fire.name}` of mode `{cm.name}` fires again at "
                        "the instant it was taken (switches accumulate here)",
                    )
                if unresolved:
                    raise _Stop(
                        Status.NO_ADMISSIBLE_MODE,
                        f"no admissible mode at t={t!r}: the state goes around {path} on switches decided "
                        f"within the guards' noise levels ({'; '.join(unresolved)}; noise = guard_noise x "
                        "sum |dh/dy| (atol + rtol |y|)): the tolerances cannot resolve these guards here "
                        "(a large gradient of a guard, or a band between guards narrower than their noise); "
                        "tighten rtol/atol (--rtol, --atol) or rescale the model",
                    )
                raise _Stop(
                    Status.NO_ADMISSIBLE_MODE,
                    f"no admissible mode at t={t!r}: the vector fields send the state around {path}; "
                    "check the guards' directions and the model's sliding modes (a state that both neighbours "
                    "push onto a surface needs a mode that holds it there)",
                )
            self.log(t, cm, fire, vals[fire.index], y, y_new, target, chained=True, coincident=coincident)
            pending = len(self.events) - 1
            mode, y = target, y_new

    def apply_reset(self, g, t: float, y: np.ndarray) -> np.ndarray:
        if not g.reset:
            return np.array(y)
        v = [t, *y.tolist()]
        out = np.array(y)
        for i, fn in g.reset:
            out[i] = fn(v)
        return out

    def log(self, t, cm, g, h, y_minus, y_plus, target, chained, coincident=False) -> None:
        target_name = self.cs.mode_name(target)
        self.current = (t, np.array(y_minus), cm.index)
        # x_plus is completed (slave variables re-solved) lazily: store the reset state.
        if self.rec.n_events + len(self.events) >= self.max_transitions:
            raise _Stop(
                Status.MAX_TRANSITIONS,
                f"stopped after {self.max_transitions} transitions, at t={t!r} before `{g.name}`; "
                "raise `max_transitions` to go on",
            )
        self.events.append(
            TransitionRecord(
                t,
                cm.name,
                target_name,
                g.name,
                float(h),
                np.array(y_minus),
                np.array(y_plus),
                chained,
                coincident and chained,
            )
        )
        self.recent.append(t)
        if len(self.recent) == self.recent.maxlen and self.recent[-1] - self.recent[0] <= self.zeno_window:
            raise _Stop(
                Status.ZENO,
                f"Zeno burst: {len(self.recent)} transitions within {self.recent[-1] - self.recent[0]:.3g} s "
                f"before t={t!r} (last {cm.name} -> {target_name} by `{g.name}`); the model accumulates switches "
                "in a vanishing time",
            )

    def set_plus(self, index: int, y_plus: np.ndarray) -> None:
        """Store the consistent post-switch state (slave variables solved in the target mode)."""
        ev = self.events[index]
        self.events[index] = TransitionRecord(
            ev.t,
            ev.source,
            ev.target,
            ev.guard,
            ev.guard_value,
            ev.x_minus,
            np.array(y_plus),
            ev.chained,
            ev.coincident,
        )

    # ------------------------------------------------------------------
    def execute(self, y0: np.ndarray, mode0: int, throw: bool, recorder: Recorder) -> Trajectory:
        self.rec = recorder
        self.start: tuple[float, np.ndarray, int] | None = None
        t, y, mode = self.t0, y0, mode0
        start_mode = self.cs.mode_name(mode0)
        status, message = Status.COMPLETED, "reached the end of the time span"
        reason = ""  # the budget's kind, if one stopped the run
        self.budget = Budget(self.opt, self.t0, self.t1)
        try:
            mode, y, yp, disarmed = self.enter(mode, t, y, after_switch=False)
            self.start = (t, y, mode)
            self.emit_samples_upto(t, lambda s: (y, mode), inclusive=True)
            if self.record_steps:
                self.record(t, y, mode)
            while t < self.t1:
                t, y, mode, yp, disarmed = self.segment(t, y, yp, mode, disarmed)
        except _Stop as stop:
            status, message = stop.status, stop.message
            t, y, mode = self.current
        except BudgetExceeded as exc:
            t, y, mode = self.current
            steps = exc.kind in ("steps", "projected")
            status, reason = (Status.STEP_LIMIT if steps else Status.TIME_LIMIT), exc.kind
            message = exc.message + (self.why_slow(t, y, mode) if steps else "")
        except _CallbackFailed as exc:
            raise exc.exc from None
        except (ArithmeticError, ValueError) as exc:
            # raised while evaluating the model's expressions (division by zero, log of a
            # negative number, overflow, a negative base to a fractional power, ...)
            t, y, mode = self.current
            status = Status.EVALUATION_FAILED
            message = (
                f"evaluating the equations of mode `{self.cs.modes[mode].name}` near t={t!r} failed: "
                f"{type(exc).__name__}: {exc}"
            )
        return self.finish(t, y, mode, status, message, start_mode, throw, reason)

    def emit_samples_upto(self, t: float, state_at, inclusive: bool, many=None) -> None:
        """Record the samples before ``t`` (and at it, if ``inclusive``): each from ``state_at(ts)
        -> (y, mode)``, or all at once from ``many(ts) -> (rows of y, mode)`` if given."""
        if self.samples is None:
            return
        s = self.samples
        if many is not None:
            side = "right" if inclusive else "left"
            grid = isinstance(s, SampleGrid)  # (a long run's times, made on demand)
            j = s.searchsorted(t, side) if grid else int(np.searchsorted(s, t, side=side))
            if j > self.next_sample:
                ts = s.times(self.next_sample, j) if grid else s[self.next_sample : j]
                Y, m = many(ts)
                if not self.integ.resolves_slaves or self.cs.modes[m].alg_idx.size == 0:
                    for ev in self.events:  # as record(), for all at once (no slave variable to re-solve)
                        self.rec.add_event(ev)
                    self.events.clear()
                    try:
                        self.rec.add_many(ts, np.asarray(Y, dtype=float), m)
                    except SampleCapReached as exc:
                        raise _Stop(Status.MAX_SAMPLES, str(exc)) from None
                else:
                    for t_s, ys in zip(ts.tolist(), Y, strict=True):
                        self.record(t_s, ys, m)
                self.next_sample = j
            return
        while self.next_sample < s.size and (
            s[self.next_sample] < t or (inclusive and s[self.next_sample] <= t)
        ):
            ts = float(s[self.next_sample])
            ys, m = state_at(ts)
            self.record(ts, ys, m)
            self.next_sample += 1

    def segment(self, t, y, yp, mode, disarmed, careful: bool = False, stepwise: bool = False):
        """Integrate in ``mode`` from ``(t, y)`` up to the next switch or the end (``careful``:
        with a small first step, after IDA failed on its own first step; ``stepwise``: with a call
        into the solver per output or step, not :meth:`segment_outputs`)."""
        cm = self.cs.modes[mode]
        solver = self.solver(mode, careful)
        solver.armed[:] = True
        for k, s in disarmed.items():
            solver.armed[k] = False
            solver.safe[k] = s
        noise = {k: self.noise(cm, k, t, y) for k in disarmed}
        solver.start(t, y, yp)
        t_start = t
        # Samples at the start or within rounding after it (a switch that lands on a sample time)
        # are the start state: IDA cannot be asked for a time that close (flag -60).
        self.emit_samples_upto(
            t + 4.0 * np.finfo(float).eps * max(1.0, abs(t)), lambda s: (y, mode), inclusive=True
        )
        where = f" in mode `{cm.name}`"
        # A solver with exact dense output (the exact integrator) is not stepped to each sample:
        # the samples of a step are taken from its flow afterwards, all at once.
        dense = getattr(solver, "dense", False)
        stepwise = stepwise or careful or self.stepwise
        if not (self.record_steps or disarmed or dense or stepwise or self.samples is None) and hasattr(
            solver, "advance"
        ):
            return self.segment_outputs(solver, cm, t, y, yp, mode)
        many = (lambda ts: (solver.interpolate_many(ts), mode)) if dense else None
        try:
            while True:
                one_step = self.record_steps or bool(disarmed)
                if (
                    not one_step
                    and not dense
                    and self.samples is not None
                    and self.next_sample < self.samples.size
                ):
                    tout = float(self.samples[self.next_sample])
                else:
                    tout = self.t1
                t_prev = self.current[0]
                r = solver.step(tout, self.t1, one_step=one_step)
                self.n_steps += 1
                self.budget.check(self.nfev + solver.nfev_last, self.current[0], where)
                if r.status == -1 and r.t > self.current[0]:
                    # max_num_steps reached within one call but time advanced: go on (within max_steps)
                    self.current = (r.t, r.y, mode)
                    continue
                if r.status in (-3, -4) and self.current[0] == t_start and not careful:
                    # Failed on the first step: IDA's own first step can be far too large (a state at
                    # rest, a strong forcing). Restart once with a small first step.
                    return self.segment(t, y, yp, mode, disarmed, careful=True)
                if r.status < 0:
                    t_fail = r.t if math.isfinite(r.t) else self.current[0]
                    raise _Stop(
                        Status.SOLVER_FAILED,
                        f"IDA failed in mode `{cm.name}` at t={t_fail!r}"
                        + (" (also with a small first step)" if careful and t_fail == t_start else "")
                        + f": {explain(r.status, r.message)}"
                        + self.advice(r.status),
                    )
                if not np.isfinite(r.y).all():  # (the method, not np.all: a step of IDA is ~20 us)
                    raise _Stop(
                        Status.SOLVER_FAILED, f"state became non-finite at t={r.t!r} in mode `{cm.name}`"
                    )
                missed = None
                if disarmed:
                    v = [r.t, *r.y.tolist()]
                    for k in list(disarmed):
                        h = cm.guards[k].fn(v)
                        if disarmed[k] * h > noise[k]:
                            solver.armed[k] = True
                            del disarmed[k]
                        elif -disarmed[k] * h > noise[k] and (cm.guards[k].direction in (0, -disarmed[k])):
                            # (the exact flow's interpolant is the flow: its crossing is located to
                            # rounding, nothing for the user to do; issue 30)
                            if not dense:
                                warnings.warn(
                                    f"guard `{cm.guards[k].name}` of mode `{cm.name}` crossed zero at t~{r.t!r} "
                                    "before it could be armed; the crossing is located on the step's interpolant. "
                                    "Lower `max_step` or `guard_noise` if this matters.",
                                    RuntimeWarning,
                                    stacklevel=2,
                                )
                            missed = k
                            break
                self.current = (r.t, r.y, mode)
                if missed is not None:
                    r = self.locate_missed(solver, cm, missed, t_prev, r)
                fired = r.fired[0] if (r.status == ROOT and r.fired) else missed
                if fired is not None:
                    self.unresolved = self.unresolved + 1 if missed is not None else 0
                    if self.unresolved >= 3:
                        raise _Stop(
                            Status.ZENO,
                            f"Zeno point near t={r.t!r}: {self.unresolved} consecutive switches by "
                            f"`{cm.guards[fired].name}` happen within the guard's noise band (below the "
                            "resolution of the tolerances); the switches accumulate here",
                        )
                    self.emit_samples_upto(
                        r.t, lambda s: (solver.interpolate(s)[0], mode), inclusive=False, many=many
                    )
                    return self.switch(cm, fired, r.t, r.y)
                if self.samples is not None:
                    self.emit_samples_upto(
                        r.t,
                        lambda s, r=r: (r.y if s == r.t else solver.interpolate(s)[0], mode),
                        inclusive=True,
                        many=(lambda ts, r=r: (_ending(solver.interpolate_many(ts), ts, r), mode))
                        if dense
                        else None,
                    )
                else:  # every step is a sample
                    self.record(r.t, r.y, mode)
                if self.progress is not None:
                    self.report(r.t)
                if r.status == TSTOP or r.t >= self.t1:
                    return self.t1, r.y, mode, r.yp, {}
        finally:
            self.nfev += solver.nfev_last
            self.njev += solver.njev_last

    def upcoming(self, t: float) -> np.ndarray | None:
        """The output times of a solver's call from ``t`` to the end of the run: the samples after
        ``t``, then the end if they do not reach it; None where they are more than one call takes
        (:data:`OUTPUTS_PER_CALL`, :data:`OUTPUT_VALUES_PER_CALL` values) or fewer than two."""
        s = self.samples
        per_call = min(OUTPUTS_PER_CALL, OUTPUT_VALUES_PER_CALL // max(len(self.cs.names), 1))
        if s.size - self.next_sample > per_call:
            return None
        ts = (
            s.times(self.next_sample, s.size)
            if isinstance(s, SampleGrid)
            else np.asarray(s[self.next_sample :])
        )
        ts = ts[ts > t]
        if ts.size == 0 or ts[-1] < self.t1:
            ts = np.append(ts, self.t1)
        return ts if ts.size >= 2 else None

    def watch(self, calls: int) -> bool:
        """Whether a call into the solver from output to output must stop (:meth:`segment_outputs`):
        it took more than the budget's allowance of one call, or the run's budget is spent."""
        return calls > self.budget.call_allowance or self.budget.overdue(self.nfev + calls)

    def segment_outputs(self, solver, cm: CompiledMode, t, y, yp, mode: int):
        """:meth:`segment` where IDA goes from output to output itself: the samples left and the end
        of the run in one call (issue 34), no Python call per sample or internal step.

        The same run as :meth:`segment`'s to the last bit: IDA's stop time is the end of the run as
        there, and the first output the same (IDA's first step is 0.001 x the distance to it). Where
        :meth:`upcoming` has no call (more samples left than a call takes, or a lone output: one call
        of step() anyway), where anything but a crossing or the end comes back (IDA's failures, its
        steps per output interval spent, a non-finite state) and where the call outgrows the budget's
        allowance (:meth:`watch`: then for the rest of the run, its budget checked after each step), the
        segment is made by :meth:`segment` (``stepwise``) from its start, which says what happened
        as it does without this path."""
        ts = self.upcoming(t)
        if ts is None:
            return self.segment(t, y, yp, mode, {}, stepwise=True)
        got = solver.advance(ts, watch=self.watch)
        if got is None:  # the call outgrew its allowance: step by step, for the rest of the run
            self.stepwise = True
            return self.segment(t, y, yp, mode, {}, stepwise=True)
        rows_t, rows_y, r = got
        if (
            (r.status < 0 or (r.status != ROOT and r.t < self.t1))
            or not np.isfinite(r.y).all()
            or (rows_y.size and not np.isfinite(rows_y).all())
        ):
            return self.segment(t, y, yp, mode, {}, stepwise=True)
        self.n_steps += 1
        self.nfev += solver.nfev_last
        self.njev += solver.njev_last
        self.current = (r.t, r.y, mode)
        self.budget.check(self.nfev, r.t, f" in mode `{cm.name}`")

        def many(q):
            return rows_y[np.searchsorted(rows_t, q)], mode

        if r.status == ROOT and r.fired:
            self.emit_samples_upto(r.t, None, inclusive=False, many=many)
            self.unresolved = 0
            return self.switch(cm, r.fired[0], r.t, r.y)
        self.emit_samples_upto(r.t, None, inclusive=True, many=many)
        if self.progress is not None:
            self.report(r.t)
        return self.t1, r.y, mode, r.yp, {}

    def switch(self, cm: CompiledMode, k: int, t: float, y_minus: np.ndarray):
        g = cm.guards[k]
        t, y_minus, h = self.polish(cm, k, t, y_minus)
        y_reset = self.apply_reset(g, t, y_minus)
        if self.include_events:
            self.record(t, y_minus, cm.index)
        self.log(t, cm, g, h, y_minus, y_reset, g.target, chained=False)
        mode, y, yp, disarmed = self.enter(g.target, t, y_reset, after_switch=True)
        if self.include_events:
            self.record(t, y, mode)
        return t, y, mode, yp, disarmed

    def locate_missed(self, solver: FlowSolver, cm: CompiledMode, k: int, t_prev: float, r):
        """Locate on the last step a crossing of guard ``k`` seen only at the step's end."""
        fn = cm.guards[k].fn

        def h(tau: float) -> float:
            return fn([tau, *solver.interpolate(tau)[0].tolist()])

        h_end = fn([r.t, *r.y.tolist()])
        if not t_prev < r.t:
            return r
        lo, hi = t_prev, r.t
        h_lo = h(lo)
        if h_lo * h_end >= 0:
            # The guard started at zero (disarmed) and went to its safe side before crossing back
            # within the step (a long step of the exact flow): bisect from the last point on that side.
            inner = [tau for tau in np.linspace(t_prev, r.t, 65)[1:-1] if h(tau) * h_end < 0]
            if not inner:
                # a dip too short for that grid (the exact flow's noise band is at rounding): look
                # near the start, where it began
                near = t_prev + (r.t - t_prev) * 2.0 ** -np.arange(60, 6, -1)
                inner = [tau for tau in near if t_prev < tau and h(tau) * h_end < 0]
            if not inner:
                return r
            lo = inner[-1]
            h_lo = h(lo)
        for _ in range(200):  # bisection to rounding of t
            mid = 0.5 * (lo + hi)
            if not lo < mid < hi:
                break
            h_mid = h(mid)
            if h_mid * h_lo > 0:
                lo, h_lo = mid, h_mid
            else:
                hi = mid
        y, yp = solver.interpolate(hi)
        return StepResult(r.status, hi, y, yp, r.fired, r.message)

    def polish(self, cm: CompiledMode, k: int, t: float, y: np.ndarray) -> tuple[float, np.ndarray, float]:
        """Refine a root located by IDA (whose time tolerance grows with |t|) by Newton steps on
        the guard along the local flow, ``y(t + dt) = y + y' dt``; slave variables re-solved."""
        g = cm.guards[k]
        y = self.project(cm, t, y)  # IDA interpolates slave variables only to the tolerance
        h = g.fn([t, *y.tolist()])
        for _ in range(3):
            yp = cm.derivatives(t, y)
            grad, ht = cm.guard_gradient(k, t, y)
            hdot = float(grad @ yp + ht)
            if hdot == 0.0:
                break
            dt = -h / hdot
            if abs(dt) > 1e-6 * max(1.0, abs(t)):  # not a small correction: keep IDA's root
                break
            t_new = t + dt
            y_new = self.project(cm, t_new, y + yp * dt)
            h_new = g.fn([t_new, *y_new.tolist()])
            if not abs(h_new) < abs(h):
                break
            t, y, h = t_new, y_new, h_new
        return t, y, h

    def report(self, t: float) -> None:
        if self.progress is None:
            return
        frac = (t - self.t0) / (self.t1 - self.t0)
        if frac >= self._next_progress:
            try:
                self.progress(min(frac, 1.0))
            except Exception as exc:  # the caller's, not the model's: re-raised unchanged
                raise _CallbackFailed(exc) from exc
            self._next_progress = frac + 0.005

    def advice(self, status: int) -> str:
        """What to change after IDA failed with ``status``."""
        if status in (-3, -4):
            return (
                f"; try another rtol (--rtol; it is {self.integ.noise_rtol:g}) or a smaller step bound "
                "(SolverOptions.max_step), and check the parameters"
            )
        return ""

    def why_slow(self, t: float, y: np.ndarray, mode: int) -> str:
        """Why a run used up its steps (see :func:`hybrid.model.linear.fast_dynamics`)."""
        if self.nfev <= 0 or not t > self.t0:
            return ""
        quad = {self.cs.names.index(q) for q in self.cs.system.quadratures}
        per = (t - self.t0) / self.nfev
        return fast_dynamics(
            self.cs.modes[mode], t, y, quad, period=self.cs.period, per_eval=per, max_step=self.max_step
        )

    def finish(self, t, y, mode, status, message, start_mode, throw, reason: str = "") -> Trajectory:
        cs = self.cs
        if self.progress is not None and status == Status.COMPLETED:
            self.progress(1.0)
        start_values = final_values = None
        for ev in self.events:
            self.rec.add_event(ev)
        self.events.clear()
        try:
            self.rec.flush()  # a block whose outputs cannot be evaluated is dropped
            if self.start is not None and self.with_outputs:
                start_values = self.values(*self.start)
                final_values = self.values(float(t), np.asarray(y, dtype=float), mode)
        except _Stop as stop:  # an output cannot be evaluated, or the final slave variables not solved
            start_values = final_values = None
            if status >= 0:
                status, message = stop.status, stop.message
        ts, ys, ms, outputs = self.rec.finish(float(t))
        streamed = self.rec.sink is not None
        traj = Trajectory(
            t=ts,
            y=ys,
            mode=cs.mode_names_of(ms),
            names=cs.names,
            outputs=outputs,
            events=tuple(self.rec.events),
            status=status,
            message=message,
            nfev=self.nfev,
            njev=self.njev,
            n_steps=self.n_steps,
            params=dict(cs.params),
            system=cs.system,
            t_final=float(t),
            y_final=np.array(y, dtype=float),
            mode_final=cs.mode_name(mode),
            t_start=self.t0,
            mode_start=start_mode,
            start_values=start_values,
            final_values=final_values,
            samples_dropped=self.rec.samples_dropped,
            events_dropped=self.rec.events_dropped,
            kept_from=max(self.rec.cutoff, self.t0) if streamed else None,
            kept_from_mode=(self.rec.mode_after_dropped or start_mode) if streamed else None,
            reason=reason,
            options=self.opt,
        )
        if throw and status < 0:
            raise SimulationError(message)
        return traj
