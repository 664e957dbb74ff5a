"""The flow of an autonomous hybrid system over a chosen time, and its derivatives.

A model without forcing (no ``period``) has periodic orbits whose period is an unknown. This
module gives the two maps Newton's method works on, with exact Jacobians from the variational
equations and saltation matrices of :mod:`hybrid.engine.variational`:

* the *time-T map* ``y0 -> y(T)`` (:meth:`FlowMap.timed`): its Jacobian in ``y0`` is the
  fundamental matrix, in ``T`` the vector field at the end, in a free parameter the parameter
  column of the variational run;
* the *return map* to a switch (:meth:`FlowMap.returned`): from a state just after the switch
  to the state just after the next firing of the same switch; its Jacobian is
  ``Y(tau+) + f+ dtau/dy0`` with ``dtau/dy0 = -h_y Phi(tau-) / (h_t + h_y f-)``, the return time
  ``tau`` is the period.

The runs start at ``t = 0`` (the system does not depend on ``t``).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, replace

import numpy as np

from ..core.errors import BudgetExceeded, GrazingSwitchError, ModelError, SimulationError
from ..engine.simulate import run_compiled
from ..engine.trajectory import Status, Trajectory, TransitionRecord
from ..engine.variational import Sensitivity, guard_index, saltation
from ..integrators.auto import resolve
from ..integrators.options import SolverOptions
from ..model.compiled import CompiledSystem, lend
from ..model.system import HybridSystem

__all__ = ["FlowMap", "Evaluation"]


@dataclass
class Evaluation:
    """One evaluation of a map at a start state.

    Attributes
    ----------
    run : Trajectory
        The run (unsampled), from ``t = 0``.
    end : ndarray, shape (n_vars,)
        State at the end (after the section's switch, for the return map).
    end_mode : str
        Mode at the end.
    time : float
        Duration [s] (the return time, for the return map).
    jacobian : ndarray, shape (n_s, n_s)
        ``d(end)/d(y0)`` over the sensitivity variables (free parameter last); None if not asked.
    monodromy : ndarray, shape (n_s, n_s)
        The fundamental matrix over ``[0, time]`` (after the final switch for the return map);
        None if not asked.
    field : ndarray, shape (n_vars,)
        The consistent vector field at the end.
    events : list of TransitionRecord
        The switches within ``[0, time]`` (the return's included).
    """

    run: Trajectory
    end: np.ndarray
    end_mode: str
    time: float
    jacobian: np.ndarray | None
    monodromy: np.ndarray | None
    field: np.ndarray
    events: list


class FlowMap:
    """Runs of an autonomous system from ``t = 0`` and their fundamental matrices.

    Parameters
    ----------
    system : HybridSystem
        A model that does not depend on ``t`` explicitly.
    params : mapping of str to float
        Parameter values (checked).
    options : SolverOptions
    time_scale : float
        A rough period [s]: IDA's step bound is a sixteenth of it unless ``options.max_step`` is set.
    free : str, optional
        A parameter to differentiate by (its column comes last in the Jacobians).

    Raises
    ------
    ValueError
        The model depends on ``t`` (it is not autonomous), or bad parameter values.
    """

    def __init__(
        self,
        system: HybridSystem,
        params: Mapping[str, float],
        options: SolverOptions,
        time_scale: float,
        free: str | None = None,
    ):
        self.system = system
        self.free = free
        self.params = system.parameter_values(params)
        options, self.choice = resolve(options, system, self.params)  # Auto(): the method the model allows
        self.options = replace(options, max_step=options.max_step or float(time_scale) / 16.0)
        self.method = options.method
        if self.method.runtime_parameters:
            self.cs, self._release = lend(system, self.params, self, every_parameter=True)
        elif free:
            self.cs = CompiledSystem(system, self.params, runtime=(free,))  # its own: free read at run time
        else:
            self.cs, self._release = lend(system, self.params, self)
        self.method.check(self.cs)  # refused before any run (e.g. not affine)
        if self.cs.depends_on_time():
            raise ModelError(
                f"model `{system.name}` depends on t but declares no forcing period: an autonomous "
                "periodic orbit needs a model whose equations and guards do not contain t"
            )
        self.ext = CompiledSystem(system, self.params, (free,)) if free else self.cs
        self.sens = Sensitivity(self.ext, self.options, self.options.max_step)
        self.names = system.variable_names
        self.s = self.sens.s[self.sens.s < len(self.names)]
        self.nfev = 0

    # ------------------------------------------------------------------
    def set_parameter(self, value: float) -> None:
        """A new value of the free parameter (no compilation)."""
        self.params = self.system.parameter_values({**self.params, self.free: float(value)})
        self.cs.set_runtime(self.params)

    @property
    def extend(self) -> np.ndarray:
        """Values appended to the state in the variational runs (the free parameter)."""
        return np.array([self.params[self.free]]) if self.free else np.zeros(0)

    def mode(self, name: str):
        """The compiled mode ``name``."""
        return self.cs.modes[self.cs.mode_id(name)]

    def field(self, mode: str, y: np.ndarray) -> np.ndarray:
        """Consistent vector field of ``mode`` at ``y`` (slave rows from the differentiated constraints)."""
        return self.mode(mode).derivatives(0.0, y)

    def run(self, y0: np.ndarray, mode0: str, t1: float, samples: int | None = None) -> Trajectory:
        """A run over ``[0, t1]`` (``samples + 1`` equidistant samples, else none).

        Raises
        ------
        hybrid.core.errors.BudgetExceeded
            The run exhausted its step or time budget.
        """
        y = np.array(y0, dtype=float)
        for q in self.system.quadratures:
            y[self.names.index(q)] = 0.0
        grid = np.linspace(0.0, t1, samples + 1) if samples else np.array([0.0, t1])
        tr = run_compiled(self.cs, self.options, 0.0, t1, y, self.cs.mode_id(mode0), grid, bool(samples))
        self.nfev += tr.nfev
        if tr.status in (Status.STEP_LIMIT, Status.TIME_LIMIT):
            raise BudgetExceeded(tr.reason, tr.message)
        return tr

    def _fundamental(self, y0, mode0, t1, events) -> np.ndarray:
        return self.sens.fundamental(0.0, y0, mode0, t1, list(events), self.extend)

    # ------------------------------------------------------------------
    def timed(self, y0: np.ndarray, mode0: str, T: float, *, derivatives: bool = True) -> Evaluation:
        """The time-``T`` map from ``(y0, mode0)``; with ``derivatives`` its fundamental matrix."""
        tr = self.run(y0, mode0, T)
        if not tr.success:
            raise SimulationError(f"run failed: {tr.message}")
        Y = self._fundamental(tr.y[0], mode0, T, tr.events) if derivatives else None
        f = self.field(tr.mode_final, tr.y_final)
        return Evaluation(tr, tr.y_final.copy(), tr.mode_final, float(T), Y, Y, f, list(tr.events))

    def returned(
        self, y0: np.ndarray, mode0: str, section: str, t_max: float, *, derivatives: bool = True
    ) -> Evaluation:
        """The return map to the switch ``section`` from a state just after it.

        The run goes on until ``section`` fires (after ``t = 0``), at most to ``t_max`` [s].

        Raises
        ------
        hybrid.core.errors.SimulationError
            The run failed or did not reach the section by ``t_max``.
        hybrid.core.errors.GrazingSwitchError
            (With ``derivatives``) the section's guard has a zero rate along the flow where it fires.
        """
        tr = self.run(y0, mode0, t_max)
        if not tr.success:
            raise SimulationError(f"run failed: {tr.message}")
        events = list(tr.events)
        hit = next((i for i, e in enumerate(events) if e.guard == section and e.t > 0.0), None)
        if hit is None:
            raise SimulationError(
                f"the run did not return to the section `{section}` within {t_max:.6g} s "
                f"(modes visited: {', '.join(dict.fromkeys([mode0, *(e.target for e in events)]))})"
            )
        tau = events[hit].t
        last = hit
        while (
            last + 1 < len(events)
            and events[last + 1].chained
            and not events[last + 1].coincident
            and events[last + 1].t == tau
        ):
            last += 1
        chain = events[hit : last + 1]
        end = chain[-1].x_plus.copy()
        end_mode = chain[-1].target
        f_plus = self.field(end_mode, end)
        Jr = Y = None
        if derivatives:
            y_start = self.mode(mode0).solve_algebraic(0.0, np.asarray(y0, dtype=float))
            Phi = self._fundamental(y_start, mode0, tau, events[:hit])
            Y = saltation(self.ext, chain, self.extend, self.sens.s, resets=self.sens.resets) @ Phi
            Jr = Y + np.outer(self.on_s(f_plus), self._dtau(chain[0], Phi))
        return Evaluation(tr, end, end_mode, float(tau), Jr, Y, f_plus, events[: last + 1])

    def on_s(self, f: np.ndarray) -> np.ndarray:
        """A vector over the variables as one over the sensitivity variables (0 for the free parameter)."""
        return np.concatenate([f, np.zeros(len(self.ext.names) - len(f))])[self.sens.s]

    def _dtau(self, ev: TransitionRecord, Phi: np.ndarray) -> np.ndarray:
        """``d(switch time)/d(y0) = -h_y Phi / (h_t + h_y f-)`` over the sensitivity variables."""
        src = self.ext.modes[self.ext.mode_index[ev.source]]
        y_minus = np.concatenate([ev.x_minus, self.extend])
        h_y, h_t = src.guard_gradient(guard_index(src, ev.guard), ev.t, y_minus)
        denom = h_t + h_y @ src.derivatives(ev.t, y_minus)
        if denom == 0.0:
            raise GrazingSwitchError(
                f"grazing return: the guard of `{ev.guard}` has a zero rate along the flow where it fires"
            )
        return -(h_y[self.sens.s] @ Phi) / denom
