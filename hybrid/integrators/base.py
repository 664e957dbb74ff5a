"""The contract between the event loop (:mod:`hybrid.engine`) and an integrator of one mode's flow.

A *mode solver* integrates one compiled mode from a consistent state and stops at the first
crossing of an armed guard in its direction. Its interface (the one the event loop calls):

1. ``armed`` (bool array, one per guard of the mode) and ``safe`` (float array): a disarmed
   guard is reported as the constant ``safe`` until the loop arms it again;
2. ``start(t, y, yp)``: (re)start at a consistent point (``yp`` may be None where the solver
   does not need it);
3. ``step(tout, tstop, one_step=...) -> StepResult``: advance towards ``tout`` (one internal step
   if ``one_step``), never past ``tstop``, stopping at a crossing (status :data:`ROOT`, the
   guards in ``fired``);
4. ``interpolate(t) -> (y, yp)``: the state inside the last step;
5. ``nfev_last``, ``njev_last``: evaluations of the last call (charged to the run's budget);
6. ``dense`` (optional, default False): outputs anywhere in the last ``step`` call are exact and
   ``interpolate_many(ts)`` returns them all at once.

Status codes of a step: :data:`SUCCESS` (reached ``tout``), :data:`TSTOP` (reached ``tstop``),
:data:`ROOT` (a guard crossed); negative values are failures (IDA's flags).

An integrator as a whole is an :class:`Integrator`: one object per integrator, found by its name
(``SolverOptions.integrator``) in :mod:`hybrid.integrators.registry`, that knows everything in
which the integrators differ (what it refuses, the solvers it builds for a run and for the
variational equations, the noise of its runs, which stages of Newton's method on a period map
apply). Callers ask it instead of testing the name.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import ClassVar, Protocol

import numpy as np

from ..core.budget import Budget
from ..core.options import SolverOptions
from ..model.compiled import CompiledSystem
from ..model.system import HybridSystem

__all__ = [
    "StepResult",
    "SUCCESS",
    "TSTOP",
    "ROOT",
    "FlowSolver",
    "VariationalSolver",
    "VariationalSolvers",
    "Integrator",
]

SUCCESS, TSTOP, ROOT = 0, 1, 2


@dataclass
class StepResult:
    """One call of a mode solver: where it stopped and why.

    Attributes
    ----------
    status : int
        :data:`SUCCESS`, :data:`TSTOP`, :data:`ROOT`, or < 0 (a failure).
    t : float
        Where it stopped [s].
    y, yp : ndarray, shape (n,)
        State and its derivative there.
    fired : tuple of int
        Guards (indices in the mode) that crossed (status :data:`ROOT`).
    message : str
        The solver's words on a failure.
    """

    status: int
    t: float
    y: np.ndarray
    yp: np.ndarray
    fired: tuple[int, ...]
    message: str


class FlowSolver(Protocol):
    """A mode solver: the contract of this module (:class:`hybrid.integrators.ida.ModeSolver`,
    :class:`hybrid.integrators.exact.ExactModeSolver`)."""

    armed: np.ndarray
    safe: np.ndarray
    nfev_last: int
    njev_last: int

    def start(self, t: float, y: np.ndarray, yp: np.ndarray | None) -> None: ...

    def step(self, tout: float, tstop: float, *, one_step: bool) -> StepResult: ...

    def interpolate(self, t: float) -> tuple[np.ndarray, np.ndarray]: ...


class VariationalSolver(Protocol):
    """One mode's flow with its variational equations (no events)
    (:class:`hybrid.integrators.ida.SensitivitySolver`, :class:`hybrid.integrators.exact.ExactSensitivity`).

    ``propagate(t0, y0, Y0, t1, budget)`` integrates from a consistent ``(t0, y0)`` with the
    fundamental matrix ``Y0`` (over the sensitivity indices) to ``t1`` and returns
    ``(y(t1) or None, Y(t1))``; ``budget`` is charged with its evaluations.
    """

    nfev: int

    def propagate(
        self, t0: float, y0: np.ndarray, Y0: np.ndarray, t1: float, budget: Budget | None = None
    ) -> tuple[np.ndarray | None, np.ndarray]: ...


class VariationalSolvers(Protocol):
    """The variational solvers of one compiled system's modes, built on first use and kept.

    ``solver(m, extend)``: mode ``m``'s, at the free parameters' values ``extend``; ``nfev``: the
    residual evaluations of all of them so far (IDA's; the exact flow's are not counted).
    """

    @property
    def nfev(self) -> int: ...

    def solver(self, m: int, extend: np.ndarray) -> VariationalSolver: ...


class Integrator(ABC):
    """An integrator of a mode's flow: what differs between IDA and the exact flow, in one place.

    One instance per integrator (:func:`hybrid.integrators.registry.integrator`); it holds no
    state of a run (caches live with the compiled system or the caller).

    Attributes
    ----------
    name : str
        Its name in ``SolverOptions.integrator``.
    exact : bool
        Its flow is exact to rounding (no tolerances apply to it).
    needs_derivatives : bool
        Its solvers start from a consistent ``(t, y, y')``: the derivatives are computed at every
        entry of a mode (else ``yp`` is None).
    resolves_slaves : bool
        Its states satisfy the algebraic equations only to its tolerance: the slave variables of a
        sampled state are solved again from them.
    runtime_parameters : bool
        Its flows come from an analysis with the parameters as symbols (the exact integrator's
        parametric affine analysis), so a period map takes a compiled system with every parameter
        read at run time (``hybrid.model.compiled.lend(..., every_parameter=True)``), set to the
        values of each run without compiling again.
    broyden : bool
        Newton's method on a period map updates ``I - M`` by Broyden's rule between monodromies
        (each one a variational run of IDA); without it every step takes the exact Jacobian.
    coarse_stage : bool
        Newton's method on a period map may start at looser tolerances
        (:func:`hybrid.orbits.newton.coarse_shooter`).
    switch_time_newton : bool
        Newton's method on a period map may solve for the switch times of a run's sequence
        (:mod:`hybrid.orbits.sequence`, on the exact flows).
    """

    name: ClassVar[str]
    exact: ClassVar[bool]
    needs_derivatives: ClassVar[bool]
    resolves_slaves: ClassVar[bool]
    runtime_parameters: ClassVar[bool]
    broyden: ClassVar[bool]
    coarse_stage: ClassVar[bool]
    switch_time_newton: ClassVar[bool]

    def __repr__(self) -> str:
        return f"{type(self).__name__}()"

    def check(self, cs: CompiledSystem) -> None:
        """Refuse, before any run, a compiled system this integrator cannot take (default: none)."""
        return None  # takes every model

    def check_model(self, system: HybridSystem, params: Mapping[str, float]) -> None:
        """Refuse, before any run, a model at ``params`` this integrator cannot take (compiling it
        only where the check needs to; default: none)."""
        return None  # takes every model

    @abstractmethod
    def noise_rtol(self, options: SolverOptions) -> float:
        """Relative accuracy of one run of a map (e.g. one forcing period) with ``options``."""

    def guard_noise(
        self,
        options: SolverOptions,
        atol: np.ndarray,
        grad: np.ndarray,
        ht: float,
        t: float,
        y: np.ndarray,
        size: float,
    ) -> float:
        """The noise band of a guard at ``(t, y)``: a guard within it of zero is judged by its
        Taylor series along the flow, not by its sign (:meth:`hybrid.engine.eventloop.Run.enter`).

        By default (an integrator with tolerances) ``guard_noise x sum |dh/dy| (atol + rtol |y|)
        + 1e-14``: the accuracy of the state the tolerances allow, carried to the guard.

        Parameters
        ----------
        options : SolverOptions
        atol : ndarray
            Absolute tolerance per variable.
        grad, ht : ndarray, float
            ``dh/dy`` and ``dh/dt`` of the guard at ``(t, y)``.
        t : float
            Time [s].
        y : ndarray
            State.
        size : float
            ``max |y|`` over the state's variables that are not quadratures (the scale of the
            rounding of a state that a flow computes from all of them).
        """
        scale = atol + options.rtol * np.abs(y)
        return options.guard_noise * float(np.abs(grad) @ scale) + 1e-14

    def guard_noises(
        self, options: SolverOptions, atol: np.ndarray, mode, t: float, y: np.ndarray, size: float
    ) -> np.ndarray | None:
        """The noise band of every guard of ``mode`` at once, where the mode offers its guards'
        gradients in one call (``guard_noise_scale``: a mode of a system with components); else
        None (the engine then asks :meth:`guard_noise` guard by guard). The same model as
        :meth:`guard_noise`, whatever the model's form (issue 30).
        """
        fn = getattr(mode, "guard_noise_scale", None)
        if fn is None:
            return None
        scale = atol + options.rtol * np.abs(y)
        return options.guard_noise * fn(t, y, scale) + 1e-14

    @abstractmethod
    def mode_solver(
        self,
        cs: CompiledSystem,
        mode: int,
        options: SolverOptions,
        *,
        atol: np.ndarray,
        max_step: float,
        first_step: float = 0.0,
    ) -> FlowSolver:
        """A solver of mode ``mode`` of ``cs`` for the event loop (the contract of this module).

        Parameters
        ----------
        cs : CompiledSystem
        mode : int
            Index of the mode in ``cs.modes``.
        options : SolverOptions
            The run's options (tolerances, step counts).
        atol : ndarray, shape (n,)
            Absolute tolerance per variable.
        max_step : float
            Step bound [s].
        first_step : float
            First step of every (re)start [s]; 0: the solver's own choice.
        """

    @abstractmethod
    def guard_series(
        self, cs: CompiledSystem, mode: int, t: float, y: np.ndarray, order: int
    ) -> Callable[[int], np.ndarray]:
        """The Taylor series of mode ``mode``'s guards along its flow from ``(t, y)``, to ``order``.

        Returns a function of a guard's index (in the mode) giving its coefficients (``[h, h',
        h''/2, ...]``); what the guards share (the flow's series) is computed once, on first use.
        """

    @abstractmethod
    def variational(
        self, cs: CompiledSystem, s: np.ndarray, options: SolverOptions, max_step: float
    ) -> VariationalSolvers:
        """The variational solvers of ``cs``'s modes over the state indices ``s`` (free parameters
        of ``cs`` appended to its state), with ``options``' tolerances and the step bound
        ``max_step`` [s]."""

    def exact_flows(self, cs: CompiledSystem) -> list | None:
        """The modes' exact flows (:class:`hybrid.integrators.affine.AffineMode`) where this
        integrator integrates with them, else None."""
        return None
