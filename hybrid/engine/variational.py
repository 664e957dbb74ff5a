"""Sensitivity of a hybrid flow: variational equations per mode, saltation matrices at switches.

Between switches the fundamental matrix ``Y = dy(t)/dy(t0)`` follows the
linearised DAE of the mode (the integrator's variational solver:
:class:`hybrid.integrators.ida.SensitivitySolver`, or the exact flow's
:class:`hybrid.integrators.exact.ExactSensitivity`). At a
switch at ``t_s`` with guard ``h(t, y) = 0``, reset ``y+ = R(t, y-)`` and the
new mode's slave variables re-solved (the projection ``Pi`` onto the new
mode's constraint manifold, ``z = zeta(t, y_d)``), ``Y`` jumps by the
saltation matrix (Leine & Nijmeijer 2004; Hiskens & Pai 2000 for the DAE)::

    Xi = A + (f+ - A f- - b) h_y / (h_t + h_y f-)
    A  = Pi_y R_y,   b = Pi_y R_t + Pi_t

with ``f-``, ``f+`` the consistent derivatives (slave variables included) of
the old and new mode. A chain of switches at one instant composes the
``(A, b)`` of every step and takes the time shift from the guard that fired.
A switch from a mode where a variable is differential into one where it is a
slave variable drops a dimension (a structural zero multiplier), e.g. the
connecting point of a friction-spring element entering slip.

The nominal switch times and states come from an ordinary event-driven run
(:func:`hybrid.simulate`); this module re-integrates each smooth segment with
its variational equations, starting from the nominal post-switch state.
"""

from __future__ import annotations

import numpy as np

from ..core.budget import Budget
from ..core.errors import GrazingSwitchError, ModelError
from ..integrators.base import VariationalSolver
from ..integrators.options import SolverOptions
from ..model.codegen import compile_scalar
from ..model.compiled import CompiledMode, CompiledSystem
from ..model.expr import diff, free_symbols
from .trajectory import TransitionRecord, switch_groups

__all__ = ["Sensitivity", "projection_jacobian", "saltation"]


def projection_jacobian(mode: CompiledMode, t: float, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Derivatives ``(P_y, P_t)`` of the projection onto ``mode``'s constraint manifold (see
    :meth:`hybrid.model.modebase.ModeMethods.projection`)."""
    return mode.projection(t, y)


class ResetJacobians:
    """Exact derivatives of transition resets, compiled on first use (once per reset, however many
    modes of a system with components share its transition)."""

    def __init__(self):
        self._cache: dict[tuple, tuple] = {}

    def __call__(self, mode: CompiledMode, k: int, t: float, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        g = mode.guards[k]
        # the modes of one compiled system share its namespace of run-time parameters (and slots)
        key = (id(mode.parameter_namespace), g.reset_expr)
        rows = self._cache.get(key)
        if rows is None:
            slots = mode.state_slots
            ns = mode.parameter_namespace
            index = {nm: j for j, nm in enumerate(mode.names)}
            rows = []
            for i, e in g.reset_expr:
                grads = tuple(
                    (index[nm], compile_scalar(diff(e, nm), slots, {}, ns))
                    for nm in sorted(free_symbols(e) & index.keys(), key=index.__getitem__)
                )
                rows.append((i, grads, compile_scalar(diff(e, "t"), slots, {}, ns)))
            rows = self._cache[key] = tuple(rows)
        n = mode.n
        R_y = np.eye(n)
        R_t = np.zeros(n)
        v = [t, *np.asarray(y, dtype=float).tolist()]
        for i, grads, gt in rows:
            R_y[i, :] = 0.0
            for j, fn in grads:
                R_y[i, j] = fn(v)
            R_t[i] = gt(v)
        return R_y, R_t


def guard_index(mode: CompiledMode, name: str) -> int:
    k = mode.guard_slot(name)
    if k is not None:
        return k
    raise ModelError(f"mode `{mode.name}` has no transition `{name}`")


def saltation(
    cs: CompiledSystem,
    chain: list[TransitionRecord],
    extend: np.ndarray,
    s: np.ndarray,
    *,
    timed: bool = True,
    resets: ResetJacobians | None = None,
) -> np.ndarray:
    """Saltation matrix of one switch or one chain of switches at the same instant.

    Parameters
    ----------
    cs : CompiledSystem
        The system (its free parameters, if any, appended to the state).
    chain : list of TransitionRecord
        The switches taken at one instant, in order.
    extend : ndarray
        Values appended to the logged states (free parameters).
    s : ndarray of int
        State indices of the sensitivity matrix.
    timed : bool
        False for switches taken at the start of a run (their instant does not
        depend on the initial state): then only the reset/projection part.
    resets : ResetJacobians, optional
        Cache of compiled reset derivatives.

    Returns
    -------
    ndarray, shape (len(s), len(s))

    Raises
    ------
    hybrid.core.errors.GrazingSwitchError
        The guard that fired has a zero rate along the flow there (``timed`` only).
    """
    resets = resets or ResetJacobians()
    t = chain[0].t
    n = cs.modes[0].n
    A = np.eye(n)
    b = np.zeros(n)
    for ev in chain:
        src = cs.modes[cs.mode_index[ev.source]]
        dst = cs.modes[cs.mode_index[ev.target]]
        k = guard_index(src, ev.guard)
        R_y, R_t = resets(src, k, t, np.concatenate([ev.x_minus, extend]))
        P_y, P_t = projection_jacobian(dst, t, np.concatenate([ev.x_plus, extend]))
        Ak = P_y @ R_y
        A = Ak @ A
        b = Ak @ b + P_y @ R_t + P_t
    ix = np.ix_(s, s)
    if not timed:
        return A[ix]
    first, last = chain[0], chain[-1]
    src = cs.modes[cs.mode_index[first.source]]
    dst = cs.modes[cs.mode_index[last.target]]
    y_minus = np.concatenate([first.x_minus, extend])
    f_minus = src.derivatives(t, y_minus)
    f_plus = dst.derivatives(t, np.concatenate([last.x_plus, extend]))
    h_y, h_t = src.guard_gradient(guard_index(src, first.guard), t, y_minus)
    denom = h_t + h_y @ f_minus
    if denom == 0.0:
        raise GrazingSwitchError(
            f"grazing switch: the guard of `{first.guard}` at t={t!r} has a zero rate along the flow where "
            "it fires (the orbit touches it tangentially, or the guard is a step such as sign(...)), so its "
            "saltation matrix is undefined"
        )
    jump = f_plus - A @ f_minus - b
    return A[ix] + np.outer(jump[s], h_y[s]) / denom


class Sensitivity:
    """Fundamental matrices of a hybrid flow along a logged run.

    Parameters
    ----------
    cs : CompiledSystem
        The compiled system, with the parameters to differentiate by as free
        parameters (appended to the state).
    options : SolverOptions
        Tolerances of the variational integration.
    max_step : float
        Step bound [s].
    """

    def __init__(self, cs: CompiledSystem, options: SolverOptions, max_step: float):
        self.cs = cs
        nb = len(cs.system.variable_names)
        quad = set(cs.system.quadratures)
        # Sensitivities of every non-quadrature variable and every free parameter.
        self.s = np.array(
            [i for i, nm in enumerate(cs.names) if i >= nb or nm not in quad],
            dtype=int,
        )
        self.nb = nb
        self.options = options
        self.max_step = max_step
        self.resets = ResetJacobians()
        # the integrator's variational solvers of the modes (kept: built on first use)
        self._solvers = options.method.variational(cs, self.s, options, max_step)
        self.nfev = 0

    def _solver(self, m: int, extend: np.ndarray | None = None) -> VariationalSolver:
        return self._solvers.solver(m, np.zeros(0) if extend is None else extend)

    def fundamental(
        self,
        t0: float,
        y0: np.ndarray,
        mode0: str,
        t1: float,
        events: list[TransitionRecord],
        extend: np.ndarray,
    ) -> np.ndarray:
        """``dy(t1)/dy(t0)`` over the sensitivity variables, along the logged run.

        Parameters
        ----------
        t0, t1 : float
            Start and end of the run [s].
        y0 : ndarray
            Start state (base variables; slave variables of ``mode0`` consistent).
        mode0 : str
            Start mode.
        events : list of TransitionRecord
            The run's switches (from :func:`hybrid.simulate`).
        extend : ndarray
            Values of the free parameters.

        Returns
        -------
        ndarray, shape (len(s), len(s))
            Columns of slave variables of ``mode0`` are zero (the start state is
            projected onto ``mode0``'s constraint manifold).

        Raises
        ------
        hybrid.core.errors.BudgetExceeded
            The run exhausted ``options.max_steps`` or ``max_wall_time``, or a
            :func:`hybrid.time_limit` ran out.
        hybrid.core.errors.GrazingSwitchError
            A switch is tangent to the flow (grazing): its saltation matrix is undefined (a
            :class:`ZeroDivisionError`).
        hybrid.core.errors.IntegratorError
            IDA failed in the variational equations.
        """
        budget = Budget(self.options, t0, t1)
        cs, s = self.cs, self.s
        m = cs.mode_index[mode0]
        y = np.concatenate([np.asarray(y0, dtype=float), extend])
        P_y, _ = projection_jacobian(cs.modes[m], t0, y)
        Y = P_y[np.ix_(s, s)]
        t = t0
        chains = switch_groups(events)
        for chain in chains:
            te = chain[0].t
            if te > t:
                _, Y = self._solver(m, extend).propagate(t, y, Y, te, budget)
            # Switches at t0 (an inadmissible start state) do not move with y0.
            Y = saltation(cs, chain, extend, s, timed=te > t0, resets=self.resets) @ Y
            y = np.concatenate([chain[-1].x_plus, extend])
            m = cs.mode_index[chain[-1].target]
            t = te
        if t1 > t:
            _, Y = self._solver(m, extend).propagate(t, y, Y, t1, budget)
        self.nfev = self._solvers.nfev
        return Y
