"""The stroboscopic map of a forced system and its derivatives: :class:`Shooter`.

``P: y(t0) -> y(t0 + T)`` over one forcing period is an event-driven run
(:mod:`hybrid.engine`); its Jacobian, the monodromy matrix, comes from the variational
equations of each mode and the saltation matrix of each switch (:mod:`hybrid.engine.variational`),
optionally with one parameter appended (for continuation). :func:`compiled` keeps a model's
recently compiled systems for reuse.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from ..core.errors import BudgetExceeded, ModelError, ParameterOutOfDomain
from ..engine.simulate import run_compiled
from ..engine.trajectory import DeferredTrajectory, Status, Trajectory
from ..engine.variational import Sensitivity
from ..integrators.auto import resolve
from ..integrators.options import SolverOptions
from ..model.codegen import compile_scalar
from ..model.compiled import CompiledSystem, lend
from ..model.expr import diff
from ..model.system import HybridSystem
from .gauge import Gauge, gauge_functions

__all__ = ["Shooter"]


class Shooter:
    """The stroboscopic map of one system and its derivatives (state and, optionally, one parameter).

    Parameters
    ----------
    system : HybridSystem
    params : mapping
        Parameter values (checked).
    options : SolverOptions
    free : str, optional
        A parameter to differentiate the map by (for continuation).
    periods : int
        Forcing periods the map spans (2: the map of orbits of twice the forcing period, e.g. the
        branch born at a period doubling).

    Attributes
    ----------
    method : hybrid.integrators.base.Method
        The integration method, ``options.method``.
    """

    def __init__(
        self,
        system: HybridSystem,
        params: Mapping[str, float],
        options: SolverOptions,
        free: str | None = None,
        periods: int = 1,
    ):
        self.system = system
        options, self.choice = resolve(options, system, params)  # Auto(): the method the model allows
        self.options = options
        self.periods = int(periods)
        self.method = options.method
        self.free = free
        self.names = system.variable_names
        self.set_params(params)
        self.method.check(self.cs)  # refused before any run (e.g. not affine: NotAffineError)
        # Without a free parameter the variational runs use the same compiled system.
        self.ext = CompiledSystem(system, self.params, (free,)) if free else self.cs
        T = self.period
        # (IDA's step bound a fraction of one forcing period, also on a map of several)
        self.sens = Sensitivity(self.ext, options, options.max_step or T / (16.0 * self.periods))
        nb = len(self.names)
        self.s = self.sens.s[self.sens.s < nb]  # state part of the sensitivity variables
        self._gauge = gauge_functions(system)
        pe = system.parsed.period
        self._dT = diff(pe, free) if free else None
        self.nfev = 0

    def set_params(self, params: Mapping[str, float]) -> None:
        cs = getattr(self, "cs", None)
        try:
            self.params = self.system.parameter_values(params)
        except ValueError as exc:
            if cs is None:
                raise  # the caller's input
            raise ParameterOutOfDomain(str(exc)) from None
        if (
            cs is not None
            and cs.runtime
            and all(v == cs.params[k] for k, v in self.params.items() if k not in cs.runtime)
        ):
            cs.set_runtime(self.params)  # only run-time parameters changed: no compilation
        else:
            self.cs = self._compiled()
        if self.cs.period is None:
            raise ModelError(
                f"model `{self.system.name}` declares no forcing `period`: periodic orbits need one"
            )
        self.period = self.periods * self.cs.period
        if self.free is not None:
            self.ext_values = np.array([self.params[self.free]])
        else:
            self.ext_values = np.zeros(0)

    def _compiled(self) -> CompiledSystem:
        """A compiled system at ``self.params`` of this shooter's own (the one it had is released)."""
        release = getattr(self, "_release", None)
        if release is not None:
            release()
        if self.method.runtime_parameters:
            # every parameter read at call time: the exact flows come from the affine analysis
            cs, self._release = lend(self.system, self.params, self, every_parameter=True)
        elif self.free is not None:
            # the free parameter is read at run time (set_runtime); private to this shooter
            cs, self._release = CompiledSystem(self.system, self.params, runtime=(self.free,)), None
        else:
            cs, self._release = lend(self.system, self.params, self)
        return cs

    @property
    def noise_rtol(self) -> float:
        """Relative accuracy of one run of the map: ``rtol`` (IDA), rounding (the exact integrator)."""
        return self.method.noise_rtol

    def dT(self) -> float:
        """d(period)/d(free parameter)."""
        if self._dT is None:
            return 0.0
        return self.periods * float(compile_scalar(self._dT, {}, self.params)(()))

    # ------------------------------------------------------------------
    def run(self, y0: np.ndarray, mode0: str, t0: float, *, samples: int | None = None) -> Trajectory:
        """One period from ``(t0, y0, mode0)`` (quadratures reset to 0).

        With ``samples`` the run is made without them and returned as a :class:`DeferredTrajectory`: the
        sampled run (about twice as costly) is made only if its samples are used, e.g. for an
        accepted orbit, not at every iteration of a corrector.

        A run that exhausts its budget raises :class:`hybrid.core.errors.BudgetExceeded`.
        """
        tr = self.run_now(y0, mode0, t0, None)
        if samples and tr.success:
            return DeferredTrajectory(tr, lambda: self.run_now(y0, mode0, t0, samples))
        return tr

    def run_now(self, y0: np.ndarray, mode0: str, t0: float, samples: int | None = None) -> Trajectory:
        """One period from ``(t0, y0, mode0)`` (quadratures reset to 0), made at once.

        Every run of the map goes through here (:meth:`run` included): its residual evaluations are
        added to ``nfev``.

        Parameters
        ----------
        y0 : ndarray, shape (n,)
            State at ``t0`` (the model's units).
        mode0 : str
            Mode at ``t0``.
        t0 : float
            Start time [s]; the run ends at ``t0 + period``.
        samples : int, optional
            A sampled run: states and outputs at ``samples + 1`` equally spaced times from ``t0``
            to ``t0 + period``. None: the end points and the switches only (an iterate of the
            map).

        Returns
        -------
        Trajectory

        Raises
        ------
        hybrid.core.errors.BudgetExceeded
            The run exhausted its step or time budget.
        """
        y = np.array(y0, dtype=float)
        for q in self.system.quadratures:
            y[self.names.index(q)] = 0.0
        T = self.period
        grid = np.linspace(t0, t0 + T, samples + 1) if samples else np.array([t0, t0 + T])
        # an unsampled run is an iterate of the map: its states and switches are read, not its outputs
        tr = run_compiled(
            self.cs,
            self.options,
            t0,
            t0 + T,
            y,
            self.cs.mode_id(mode0),
            grid,
            bool(samples),
            outputs=bool(samples),
        )
        self.nfev += tr.nfev
        if tr.status in (Status.STEP_LIMIT, Status.TIME_LIMIT):
            raise BudgetExceeded(tr.reason, tr.message)
        return tr

    def monodromy(self, tr: Trajectory) -> np.ndarray:
        """Fundamental matrix over one period along ``tr`` (sensitivity variables, free parameter last)."""
        base = tr.base if isinstance(tr, DeferredTrajectory) else tr
        return self.sens.fundamental(
            base.t_start, base.y[0], base.mode_start, base.t_final, base.events, self.ext_values
        )

    def gauge(self, y: np.ndarray) -> Gauge | None:
        """The model's gauges at state ``y`` with their gradients in the state (None without a gauge)."""
        if self._gauge is None:
            return None
        fns, grads = self._gauge
        v = [0.0, *y.tolist(), *(self.params[p.name] for p in self.system.parameters)]
        G = np.zeros((len(fns), len(self.names)))
        for r, row in enumerate(grads):
            for i, fn in row:
                G[r, i] = fn(v)
        texts = self.system.orbit["gauge"]
        texts = (texts,) if isinstance(texts, str) else tuple(texts)
        return Gauge(np.array([float(fn(v)) for fn in fns]), G, texts)
