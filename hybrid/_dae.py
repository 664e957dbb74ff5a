"""The IDA backend: the only module that imports scikit-sundae.

One :class:`ModeSolver` per mode wraps one ``sksundae.ida.IDA`` object (the
slave-variable indices and the number of guards are fixed per object) and is
re-entered with ``init_step`` at every switch. Backend conventions (in-place
callbacks, integer flags, the event bookkeeping kept on the events function)
stay here.
"""

from __future__ import annotations

import re
import sys
from dataclasses import dataclass

import numpy as np
from sksundae.ida import IDA

from ._budget import Budget, BudgetExceeded
from ._compiled import CompiledMode
from ._linear import fast_dynamics

__all__ = ["ModeSolver", "StepResult", "SUCCESS", "TSTOP", "ROOT", "explain"]

SUCCESS, TSTOP, ROOT = 0, 1, 2
UNKNOWN_FLAG = -99

#: What a failure flag of IDA means for the model, and what to change.
_EXPLAIN = {
    -1: "IDA's step limit per call was reached",
    -2: "the demanded accuracy cannot be met (tolerances below the floating-point resolution of the "
    "state): loosen rtol/atol (--rtol, --atol)",
    -3: "the error test failed repeatedly down to the smallest step: the solution changes faster than the "
    "step can follow (a discontinuity not declared as a guard, dynamics far faster than the forcing, or a "
    "state out of range)",
    -4: "the corrector failed to converge repeatedly down to the smallest step: the equations are stiff or "
    "ill-conditioned here, or a slave variable cannot be solved",
    -8: "the residual function failed",
    -9: "the residual function failed repeatedly",
    -12: "the residual function failed on its first call",
    -14: "the residual or linear solver failed and IDA could not recover",
    -22: "an input to IDA is invalid (a non-finite value, or a step or time out of floating-point range)",
}


def explain(status: int, message: str) -> str:
    """IDA's failure ``status`` and ``message`` as one clause: what it means, then IDA's words."""
    what = _EXPLAIN.get(status)
    return (
        f"{what} (IDA: {message.rstrip('.')}, flag {status})"
        if what
        else f"{message.rstrip('.')} (IDA flag {status})"
    )


class _Notes:
    """Takes what scikit-sundae prints during a call into IDA (SUNDIALS' error messages go to
    ``print``, i.e. to stdout, where they would mix with a command's output); keeps the last."""

    text = ""

    def write(self, s: str) -> int:
        s = s.strip()
        if s:
            self.text = re.sub(r"^\[[^\]]*\]\s*", "", s)  # drop "[IDASolve, Error: -3]"
        return len(s)

    def flush(self) -> None:
        pass


_NOTES = _Notes()


def _call(ida, t: float, method: str, tstop: float | None):
    """``ida.step`` with SUNDIALS' printed messages kept (``_NOTES.text``), and a flag unknown to
    scikit-sundae (a ``KeyError`` there) returned as a failure ``(flag, message)``."""
    _NOTES.text = ""
    saved, sys.stdout = sys.stdout, _NOTES
    try:
        return ida.step(t, method, tstop=tstop), None
    except KeyError as exc:
        flag = exc.args[0] if exc.args and isinstance(exc.args[0], int) else UNKNOWN_FLAG
        detail = f": {_NOTES.text}" if _NOTES.text else ""
        return None, (int(flag), f"IDA returned flag {flag}, unknown to scikit-sundae{detail}")
    finally:
        sys.stdout = saved


@dataclass
class StepResult:
    """One call into IDA: where it stopped and why."""

    status: int  # 0 reached tout, 1 reached tstop, 2 guard root, < 0 failure
    t: float
    y: np.ndarray
    yp: np.ndarray
    fired: tuple[int, ...]  # guards that crossed (status 2)
    message: str


class ModeSolver:
    """IDA integrator for one compiled mode.

    Parameters
    ----------
    mode : CompiledMode
        The mode's equations and guards.
    rtol, atol : float or ndarray
        Tolerances (``atol`` per variable, shape (n,)).
    max_step : float
        Bound on IDA's step (a fraction of the forcing period: without it IDA
        can step over the forcing one period at a time).
    max_num_steps : int
        Internal steps allowed per call.
    first_step : float
        First step of every (re)start; 0: IDA's own estimate.
    """

    def __init__(
        self,
        mode: CompiledMode,
        *,
        rtol: float,
        atol,
        max_step: float,
        max_num_steps: int,
        first_step: float = 0.0,
    ):
        self.mode = mode
        ng = len(mode.guards)
        self.armed = np.ones(ng, dtype=bool)
        self.safe = np.zeros(ng)
        self.nfev_last = 0
        self.njev_last = 0
        self._guard_fns = [g.fn for g in mode.guards]

        def resfn(t, y, yp, res):
            mode.residual(t, y, yp, res)

        def jacfn(t, y, yp, res, cj, JJ):
            mode.jacobian(t, y, cj, JJ)

        opts = dict(
            rtol=rtol,
            atol=atol,
            max_step=max_step,
            max_num_steps=max_num_steps,
            first_step=first_step,
            jacfn=jacfn,
            calc_initcond=None,
        )
        if mode.alg_idx.size:
            opts["algebraic_idx"] = mode.alg_idx.tolist()
        if ng:
            armed, safe, gfn = self.armed, self.safe, mode._guards_fn

            def eventsfn(t, y, yp, out):
                out[:] = gfn([t, *y.tolist()])  # all guards in one generated function
                if not armed.all():
                    out[~armed] = safe[~armed]

            eventsfn.terminal = [True] * ng
            eventsfn.direction = [g.direction for g in mode.guards]
            opts["eventsfn"] = eventsfn
            opts["num_events"] = ng
            self._events = eventsfn
        else:
            self._events = None
        self._ida = IDA(resfn, **opts)

    def start(self, t: float, y: np.ndarray, yp: np.ndarray) -> None:
        """(Re)initialise at a consistent point ``(t, y, y')``."""
        self._ida.init_step(float(t), np.asarray(y, dtype=float), np.asarray(yp, dtype=float))
        self.nfev_last = self.njev_last = 0
        self._t = float(t)
        self._y, self._yp = np.array(y, dtype=float), np.array(yp, dtype=float)

    def _clear_events(self) -> None:
        # sksundae keeps every event ever found on the events function and
        # rebuilds arrays of all of them after each call: keep it empty.
        ev = self._events
        if ev is not None:
            ev._i.clear()
            ev._t.clear()
            ev._y.clear()
            ev._yp.clear()
            ev._i_cnt[:] = 0

    def step(self, tout: float, tstop: float, *, one_step: bool) -> StepResult:
        """Advance towards ``tout`` (one internal step if ``one_step``), never past ``tstop``."""
        r, bad = _call(self._ida, float(tout), "onestep" if one_step else "normal", float(tstop))
        if bad is not None:
            self._clear_events()
            return StepResult(bad[0], self._t, self._y, self._yp, (), bad[1])
        fired: tuple[int, ...] = ()
        if r.status == ROOT and r.i_events is not None:
            fired = tuple(int(k) for k in np.flatnonzero(r.i_events[-1]))
        self._clear_events()
        self.nfev_last, self.njev_last = int(r.nfev), int(r.njev)
        msg = str(r.message) + (f" {_NOTES.text}" if r.status < 0 and _NOTES.text else "")
        res = StepResult(int(r.status), float(r.t), np.array(r.y), np.array(r.yp), fired, msg)
        if res.status >= 0:
            self._t, self._y, self._yp = res.t, res.y, res.yp
        return res

    def interpolate(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        """State at ``t`` inside the last internal step (no advance)."""
        r, bad = _call(self._ida, float(t), "normal", None)
        self._clear_events()
        if bad is not None or r.status < 0:
            raise RuntimeError(f"IDA could not interpolate at t={t!r}: {bad[1] if bad else r.message}")
        return np.array(r.y), np.array(r.yp)


class SensitivitySolver:
    """IDA on one mode's DAE together with its variational equations (no events).

    The unknowns are the state ``y`` (shape (n,)) and the sensitivity matrix
    ``Y = dy/dy0`` restricted to the variables ``s`` (shape (ns, ns), stored
    column by column after ``y``). For every column the residual is the
    linearised DAE ``mask * Y' + (dF/dy) Y`` (``mask``: 1 on differential rows,
    0 on slave rows), so slave rows keep ``g_y Y = 0`` and the differential rows
    follow ``Y' = f_y Y``. The Newton matrix omits the second-derivative
    coupling ``d(F_y Y)/dy`` (zero for modes linear in the state); IDA's
    corrector converges with it as an approximate Jacobian.

    Parameters
    ----------
    mode : CompiledMode
        The mode's equations (possibly with free parameters appended to the state).
    s : ndarray of int
        State indices whose sensitivities are carried (quadratures excluded).
    rtol : float
        Relative tolerance (state and sensitivities).
    atol : ndarray, shape (n,)
        Absolute tolerance of the state.
    atol_sens : float
        Absolute tolerance of the sensitivity entries.
    max_step : float
        Step bound [s].
    max_num_steps : int
        Internal steps per call.
    """

    def __init__(
        self,
        mode: CompiledMode,
        s: np.ndarray,
        *,
        rtol: float,
        atol: np.ndarray,
        atol_sens: float,
        max_step: float,
        max_num_steps: int,
    ):
        self.mode = mode
        n, ns = mode.n, int(s.size)
        self.n, self.ns, self.s = n, ns, np.asarray(s, dtype=int)
        ix = np.ix_(self.s, self.s)
        mask = mode.is_diff[self.s].astype(float)
        self._mask = mask
        where = {int(i): k for k, i in enumerate(self.s.tolist())}
        # Entries of dF/dy inside the s x s block that vary (the rest is the constant jac_base):
        # their position in the term list of the mode's generated Jacobian function, and in the block.
        varying = [
            (k, where[i], where[j]) for k, (i, j, _) in enumerate(mode.jac_terms) if i in where and j in where
        ]
        self._J_const = mode.jac_base[ix].copy() if not varying else None
        base = mode.jac_base[ix].copy()
        sel = np.array([k for k, _, _ in varying], dtype=int)
        at = (
            np.array([a for _, a, _ in varying], dtype=int),
            np.array([b for _, _, b in varying], dtype=int),
        )
        jac_fn = mode._jac_fn
        self._ix = ix
        mcol = mask[:, None]
        N = n + ns * ns
        blocks = [slice(n + j * ns, n + (j + 1) * ns) for j in range(ns)]

        def J_ss(t, y):
            if self._J_const is not None:
                return self._J_const
            J = base.copy()
            J[at] = np.asarray(jac_fn([t, *y.tolist()]), dtype=float)[sel]
            return J

        self.J_ss = J_ss

        def resfn(t, z, zp, res):
            y = z[:n]
            mode.residual(t, y, zp[:n], res)
            Y = z[n:].reshape((ns, ns), order="F")
            Yp = zp[n:].reshape((ns, ns), order="F")
            res[n:] = (mcol * Yp + J_ss(t, y) @ Y).ravel(order="F")

        dmask = np.diag(mask)

        def jacfn(t, z, zp, res, cj, JJ):
            JJ[:, :] = 0.0
            top = np.empty((n, n))
            mode.jacobian(t, z[:n], cj, top)
            JJ[:n, :n] = top
            B = J_ss(t, z[:n]) + cj * dmask
            for b in blocks:
                JJ[b, b] = B

        alg = list(mode.alg_idx.tolist())
        alg_s = [k for k, i in enumerate(self.s.tolist()) if not mode.is_diff[i]]
        for j in range(ns):
            alg += [n + j * ns + k for k in alg_s]
        atol_all = np.concatenate([np.asarray(atol, dtype=float), np.full(ns * ns, float(atol_sens))])
        opts = dict(
            rtol=rtol,
            atol=atol_all,
            max_step=max_step,
            max_num_steps=max_num_steps,
            jacfn=jacfn,
            calc_initcond=None,
        )
        if alg:
            opts["algebraic_idx"] = alg
        self._N = N
        self._max_step = max_step
        self.period: float | None = None  # the forcing period, for diagnoses
        self._ida = IDA(resfn, **opts)
        self.nfev = 0

    def _why_slow(self, budget: Budget, r) -> str:
        t = float(r.t)
        if budget.used <= 0 or not t > budget.t0:
            return ""
        quad = set(range(self.n)) - set(self.s.tolist())
        per = (t - budget.t0) / budget.used
        y = np.array(r.y)[: self.n]
        return fast_dynamics(self.mode, t, y, quad, period=self.period, per_eval=per, max_step=self._max_step)

    def propagate(
        self, t0: float, y0: np.ndarray, Y0: np.ndarray, t1: float, budget: Budget | None = None
    ) -> tuple[np.ndarray, np.ndarray]:
        """Integrate from ``(t0, y0, Y0)`` (consistent) to ``t1``; return ``(y(t1), Y(t1))``.

        ``budget`` (shared by the segments of one variational run) is charged
        with the residual evaluations and checked after every call into IDA
        (:class:`hybrid._budget.BudgetExceeded`).
        """
        mode, n, ns = self.mode, self.n, self.ns
        yp0 = mode.derivatives(t0, y0)
        J = self.J_ss(t0, y0)
        Yp0 = -(J @ Y0)
        d = np.flatnonzero(self._mask > 0)
        a = np.flatnonzero(self._mask == 0)
        if a.size:
            Yp0[a] = -np.linalg.solve(J[np.ix_(a, a)], J[np.ix_(a, d)] @ Yp0[d])
        z0 = np.concatenate([y0, Y0.ravel(order="F")])
        zp0 = np.concatenate([yp0, Yp0.ravel(order="F")])
        self._ida.init_step(float(t0), z0, zp0)
        self._nfev_seen = 0
        t = float(t0)
        where = f" in the variational equations of mode `{mode.name}`"
        while True:
            r, bad = _call(self._ida, float(t1), "normal", float(t1))
            if bad is not None:
                raise RuntimeError(f"IDA failed{where} near t={t!r}: {explain(*bad)}")
            nfev = int(r.nfev)  # since init_step: the increment of this call is charged
            self.nfev += nfev - self._nfev_seen
            if budget is not None:
                budget.used += nfev - self._nfev_seen
            self._nfev_seen = nfev
            if budget is not None:
                try:
                    budget.check(budget.used, float(r.t), where)
                except BudgetExceeded as exc:
                    raise BudgetExceeded(exc.kind, exc.message + self._why_slow(budget, r)) from None
            if r.status < 0:
                if r.status == -1 and float(r.t) > t:  # max_num_steps reached: go on, within the budget
                    t = float(r.t)
                    continue
                msg = str(r.message) + (f" {_NOTES.text}" if _NOTES.text else "")
                raise RuntimeError(f"IDA failed{where} at t={r.t!r}: {explain(int(r.status), msg)}")
            z = np.array(r.y)
            if float(r.t) >= t1 or r.status in (SUCCESS, TSTOP):
                return z[:n], z[n:].reshape((ns, ns), order="F")
            t = float(r.t)
