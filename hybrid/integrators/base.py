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

A method of integration as a whole is a :class:`Method`: a frozen object holding its own settings
(:class:`hybrid.integrators.ida.IDA` its tolerances, :class:`hybrid.integrators.exact.Exact` none),
passed as ``SolverOptions(method=...)`` and found by its name for the command line in
:mod:`hybrid.integrators.registry`. It knows everything in which the methods differ: what it refuses,
the solvers it builds for a run and for the variational equations, the noise of its runs and of a
guard, a copy at tighter or looser tolerances. Callers ask it these questions (capabilities), never
its name.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable, Mapping, Sequence
from dataclasses import asdict, dataclass
from typing import TYPE_CHECKING, ClassVar, Protocol

import numpy as np

from ..core.budget import Budget
from ..model.compiled import CompiledSystem
from ..model.system import HybridSystem

if TYPE_CHECKING:  # (the options hold a method: imported for the annotations only)
    from .options import SolverOptions

__all__ = [
    "StepResult",
    "SUCCESS",
    "TSTOP",
    "ROOT",
    "FlowSolver",
    "VariationalSolver",
    "VariationalSolvers",
    "Method",
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


class Method(ABC):
    """A method of integration of a mode's flow and its own settings: what differs between IDA and
    the exact flow, in one place.

    Subclasses are frozen dataclasses (hashable, comparable, printable: ``IDA(rtol=1e-09, ...)``);
    they hold no state of a run (caches live with the compiled system or the caller).

    Attributes
    ----------
    name : str
        Its name on the command line (``--integrator``).
    flows_exact : bool
        Its runs are exact to rounding: no tolerance applies, a run is not improved by a tighter
        one, and the uncertainty of a computed switch or special point is rounding.
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
    """

    name: ClassVar[str]
    flows_exact: ClassVar[bool]
    needs_derivatives: ClassVar[bool]
    resolves_slaves: ClassVar[bool]
    runtime_parameters: ClassVar[bool]

    def settings(self) -> dict:
        """Its settings as plain data (``{"name": ..., field: value, ...}``), e.g. for a result file."""
        return {"name": self.name, **asdict(self)}

    @property
    @abstractmethod
    def noise_rtol(self) -> float:
        """Relative accuracy of one run of a map (e.g. one forcing period)."""

    def atol_vector(self, names: Sequence[str]) -> np.ndarray:
        """Absolute accuracy of each variable of ``names`` (default: none, zeros)."""
        return np.zeros(len(names))

    def tightened(self, factor: float) -> Method | None:
        """The same method at tolerances ``factor`` times tighter, to estimate a run's error by a
        rerun; None where it has no tolerances (default)."""
        return None

    def loosened_to(self, rtol: float) -> Method | None:
        """The same method at the looser relative tolerance ``rtol`` (absolute ones scaled alike),
        for cheap first iterations; None where it has no tolerances or is already near it (default)."""
        return None

    def check(self, cs: CompiledSystem) -> None:
        """Refuse, before any run, a compiled system this integrator cannot take (default: none)."""
        return None  # takes every model

    def check_model(self, system: HybridSystem, params: Mapping[str, float]) -> None:
        """Refuse, before any run, a model at ``params`` this integrator cannot take (compiling it
        only where the check needs to; default: none)."""
        return None  # takes every model

    @abstractmethod
    def guard_band(
        self,
        atol: np.ndarray,
        grad: np.ndarray,
        ht: float,
        t: float,
        y: np.ndarray,
        size: float,
    ) -> float:
        """The noise band of a guard at ``(t, y)``: a guard within it of zero is judged by its
        Taylor series along the flow, not by its sign (:meth:`hybrid.engine.eventloop.Run.enter`).

        Parameters
        ----------
        atol : ndarray
            Absolute accuracy per variable (:meth:`atol_vector`).
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

    @abstractmethod
    def guard_bands(self, cm, atol: np.ndarray, t: float, y: np.ndarray, size: float) -> np.ndarray | None:
        """The noise band of every guard of the compiled mode ``cm`` at once, where the mode offers
        the guards' gradients in one call (``cm.guard_noise_scale``, a mode of a system with
        components); else None (the caller asks :meth:`guard_band` guard by guard)."""

    @abstractmethod
    def mode_solver(
        self,
        cs: CompiledSystem,
        mode: int,
        options: SolverOptions,
        *,
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
            The run's options (its budget of steps).
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
        of ``cs`` appended to its state), with this method's tolerances, ``options``' budget and
        the step bound ``max_step`` [s]."""

    def exact_flows(self, cs: CompiledSystem) -> list | None:
        """The modes' exact flows (:class:`hybrid.integrators.affine.AffineMode`) where this
        method integrates with them, else None."""
        return None
