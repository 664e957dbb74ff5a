"""The IDA backend: the only module that imports scikit-sundae.

One :class:`ModeSolver` per mode wraps one ``sksundae.ida.IDA`` object (the
slave-variable indices and the number of guards are fixed per object) and is
re-entered with ``init_step`` at every switch. Backend conventions (in-place
callbacks, integer flags, the event bookkeeping kept on the events function)
stay here.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from ..core.budget import Budget
from ..core.errors import BudgetExceeded, InputError, InputTypeError, IntegratorError
from ..core.options import check_positive, plain_number
from ..model.compiled import CompiledMode, CompiledSystem
from ..model.linear import fast_dynamics
from .base import ROOT, SUCCESS, TSTOP, Method, StepResult
from .solver_output import kept_prints

if TYPE_CHECKING:
    from .options import SolverOptions

__all__ = [
    "IDA",
    "ModeSolver",
    "SensitivitySolver",
    "IDAVariational",
    "explain",
    "MAX_SHARED_SOLVERS",
]

UNKNOWN_FLAG = -99

#: IDA solvers kept per compiled system (by mode, settings and first step).
MAX_SHARED_SOLVERS = 64
#: Most IDA steps of one call of a variational solver (it goes on after, within the budget).
VARIATIONAL_CALL_STEPS = 100


def _ida(resfn, opts: dict):
    """A new ``sksundae.ida.IDA`` object (scikit-sundae is imported on first use: it pulls in
    scipy.optimize, half a second that a run of the exact integrator never needs)."""
    from sksundae.ida import IDA

    return IDA(resfn, **opts)


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


def _call(ida, t: float, method: str, tstop: float | None):
    """``ida.step`` as ``(result, failure, words)``: SUNDIALS' message of this call (``words``,
    ``""`` if none: scikit-sundae prints it, :func:`~hybrid.integrators.solver_output.kept_prints`
    keeps it off stdout), and a flag unknown to scikit-sundae (a ``KeyError`` there) returned as
    ``failure = (flag, message)`` with ``result`` None."""
    with kept_prints() as kept:
        try:
            return ida.step(t, method, tstop=tstop), None, kept.text
        except KeyError as exc:
            flag = exc.args[0] if exc.args and isinstance(exc.args[0], int) else UNKNOWN_FLAG
            detail = f": {kept.text}" if kept.text else ""
            return None, (int(flag), f"IDA returned flag {flag}, unknown to scikit-sundae{detail}"), kept.text


#: Residual evaluations between two calls of the watch of :meth:`ModeSolver.advance`.
WATCH_EVERY = 256


class Overrun(Exception):
    """Raised inside IDA's call by the residual function where :meth:`ModeSolver.advance`'s watch
    says stop (caught there: the call returns None)."""


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
    band : (int, int), optional
        Lower and upper bandwidth of the iteration matrix in every mode (a system with components
        whose couplings are local, e.g. a chain): IDA's banded solver instead of the dense one.
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
        band: tuple[int, int] | None = None,
    ):
        self.mode = mode
        ng = len(mode.guards)
        self.armed = np.ones(ng, dtype=bool)
        self.safe = np.zeros(ng)
        self.nfev_last = 0
        self.njev_last = 0

        # The callbacks are the hot path of a run (about 2000 calls per forcing period): the
        # mode's generated functions are called directly, without the CompiledMode wrappers.
        # dF/dy + cj dF/dy' = jac_base + cj diag(is_diff), then the varying entries (flat indices).
        res_fn, jac_fn, base = mode.residual_function, mode.jacobian_function, mode.jac_base
        cj_mask = np.diag(mode.is_diff.astype(float))
        flat_at = mode.jacobian_entries[0] * mode.n + mode.jacobian_entries[1]
        cj_at = cj_mask.reshape(-1)[flat_at]  # cj's share of a varying entry on the diagonal
        if not cj_at.any():
            cj_at = None

        # The watch of an :meth:`advance` call: [residual calls so far, its function or None]
        self._watch = watch = [0, None]

        def resfn(t, y, yp, res):
            res[:] = res_fn([t, *y.tolist(), *yp.tolist()])
            if watch[1] is not None:
                watch[0] += 1
                if watch[0] % WATCH_EVERY == 0 and watch[1](watch[0]):
                    raise Overrun  # (out of IDA's call: scikit-sundae re-raises it)

        # The constant entries are written once into scikit-sundae's Jacobian buffer (the same array
        # at every call, read, never written, by scikit-sundae): a call writes the diagonal and the
        # varying entries only, O(n) instead of O(n^2) (a chain of 256 blocks: n = 770).
        n = mode.n
        diag = np.arange(n) * (n + 1)
        base_diag = np.diag(base).copy()
        is_diff = mode.is_diff.astype(float)
        filled: list = [None]

        def jacfn(t, y, yp, res, cj, JJ):
            if filled[0] is not JJ:
                JJ[...] = base
                filled[0] = JJ
            np.put(JJ, diag, base_diag + cj * is_diff)
            if jac_fn is not None:
                v = jac_fn([t, *y.tolist()])
                np.put(JJ, flat_at, v if cj_at is None else np.asarray(v, dtype=float) + cj * cj_at)

        self._resfn, self._jacfn = resfn, jacfn
        opts = dict(
            rtol=rtol,
            atol=atol,
            max_step=max_step,
            max_num_steps=max_num_steps,
            first_step=first_step,
            jacfn=jacfn,
            calc_initcond=None,
        )
        if band is not None:
            opts.update(linsolver="band", lband=int(band[0]), uband=int(band[1]))
        if mode.alg_idx.size:
            opts["algebraic_idx"] = mode.alg_idx.tolist()
        if ng:
            gfn = mode.guards_function
            # The disarmed guards and their safe values, refreshed at every call into IDA (the caller
            # (dis)arms between calls only): (indices, values), or None where all are armed.
            self._disarmed = disarmed = [None]
            self._armed_key = self.armed.tobytes() + self.safe.tobytes()

            def eventsfn(t, y, yp, out):
                out[:] = gfn([t, *y.tolist()])  # all guards in one generated function
                d = disarmed[0]
                if d is not None:
                    out[d[0]] = d[1]

            eventsfn.terminal = [True] * ng
            eventsfn.direction = [int(d) for d in mode.guard_directions]
            opts["eventsfn"] = eventsfn
            opts["num_events"] = ng
            self._events = eventsfn
        else:
            self._events = None
        self._ida = _ida(resfn, opts)

    def _arm(self) -> None:
        """Hand the events function the guards disarmed now (``armed``, ``safe``; compared as bytes:
        this runs before every call into IDA, once per internal step in one-step mode)."""
        key = self.armed.tobytes() + self.safe.tobytes()
        if key == self._armed_key:
            return
        self._armed_key = key
        if self.armed.all():
            self._disarmed[0] = None
        else:
            off = np.flatnonzero(~self.armed)
            self._disarmed[0] = (off, self.safe[off].copy())

    def start(self, t: float, y: np.ndarray, yp: np.ndarray) -> None:
        """(Re)initialise at a consistent point ``(t, y, y')``."""
        self._ida.init_step(float(t), np.asarray(y, dtype=float), np.asarray(yp, dtype=float))
        if self._events is not None:
            self._arm()
        self.nfev_last = self.njev_last = 0
        self._t = float(t)
        self._y, self._yp = np.array(y, dtype=float), np.array(yp, dtype=float)

    def _clear_events(self) -> None:
        # sksundae keeps every event ever found on the events function and
        # rebuilds arrays of all of them after each call: keep it empty.
        ev = self._events
        if ev is not None and ev._i:  # (the counts grow only with the list)
            ev._i.clear()
            ev._t.clear()
            ev._y.clear()
            ev._yp.clear()
            ev._i_cnt[:] = 0

    def step(self, tout: float, tstop: float, *, one_step: bool) -> StepResult:
        """Advance towards ``tout`` (one internal step if ``one_step``), never past ``tstop``."""
        if self._events is not None:
            self._arm()  # the caller (dis)arms between calls only
        r, bad, words = _call(self._ida, float(tout), "onestep" if one_step else "normal", float(tstop))
        if bad is not None:
            self._clear_events()
            return StepResult(bad[0], self._t, self._y, self._yp, (), bad[1])
        fired: tuple[int, ...] = ()
        if r.status == ROOT and r.i_events is not None:
            fired = tuple(int(k) for k in np.flatnonzero(r.i_events[-1]))
        self._clear_events()
        self.nfev_last, self.njev_last = int(r.nfev), int(r.njev)
        msg = str(r.message) + (f" {words}" if r.status < 0 and words else "")
        # r.y, r.yp are scikit-sundae's copies, owned by this result alone
        res = StepResult(int(r.status), float(r.t), np.asarray(r.y), np.asarray(r.yp), fired, msg)
        if res.status >= 0:
            self._t, self._y, self._yp = res.t, res.y, res.yp
        return res

    def advance(self, ts: np.ndarray, watch=None) -> tuple[np.ndarray, np.ndarray, StepResult] | None:
        """From the point of the last :meth:`start` through the output times ``ts`` (increasing,
        after it; at least two) in one call into IDA, never past ``ts[-1]`` (IDA's stop time, as
        :meth:`step`'s ``tstop``), stopping at a crossing.

        Returns the times and states of the outputs reached (rows) and the end (a :class:`StepResult`:
        at ``ts[-1]``, at a crossing, or where IDA failed). IDA loops over the outputs itself: no
        Python call per output or internal step (issue 34). Its internal steps are those of
        :meth:`step` in normal mode towards each output with ``tstop = ts[-1]``: the same run to the
        last bit (the outputs are interpolated, they do not cut steps). Afterwards the solver must be
        started again (:meth:`start`) before :meth:`step` or :meth:`interpolate`.

        ``watch(calls)``, if given, is called every :data:`WATCH_EVERY` residual evaluations of the
        call with their number; where it returns True the call is abandoned and None returned (the
        caller goes on another way, e.g. with :meth:`step`, from the point of :meth:`start`).
        """
        if self._events is not None:
            self._arm()
        tspan = np.concatenate([[self._t], np.asarray(ts, dtype=float)])
        self._watch[:] = [0, watch]
        try:
            with kept_prints() as kept:
                try:
                    r = self._ida.solve(tspan, self._y, self._yp)
                except KeyError as exc:
                    r = None
                    flag = exc.args[0] if exc.args and isinstance(exc.args[0], int) else UNKNOWN_FLAG
        except Overrun:
            self._clear_events()
            return None
        finally:
            self._watch[1] = None
        words = kept.text
        if r is None:
            detail = f": {words}" if words else ""
            self._clear_events()
            end = StepResult(
                int(flag),
                self._t,
                self._y,
                self._yp,
                (),
                f"IDA returned flag {flag}, unknown to scikit-sundae{detail}",
            )
            return np.zeros(0), np.zeros((0, self._y.size)), end
        fired: tuple[int, ...] = ()
        if r.status == ROOT and r.i_events is not None:
            fired = tuple(int(k) for k in np.flatnonzero(r.i_events[-1]))
        self._clear_events()
        self.nfev_last, self.njev_last = int(r.nfev), int(r.njev)
        msg = str(r.message) + (f" {words}" if r.status < 0 and words else "")
        t, y, yp = np.asarray(r.t), np.asarray(r.y), np.asarray(r.yp)
        end = StepResult(int(r.status), float(t[-1]), y[-1], yp[-1], fired, msg)
        if end.status >= 0 or float(t[-1]) > self._t:
            self._t, self._y, self._yp = end.t, end.y, end.yp
        n = t.size - 1 if (end.status == ROOT or end.status < 0) else t.size
        return t[1:n], y[1:n], end

    def interpolate(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        """State at ``t`` inside the last internal step (no advance)."""
        if self._events is not None:
            self._arm()
        r, bad, _ = _call(self._ida, float(t), "normal", None)
        self._clear_events()
        if bad is not None or r.status < 0:
            raise IntegratorError(f"IDA could not interpolate at t={t!r}: {bad[1] if bad else r.message}")
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
        jac_fn = mode.jacobian_function
        self._ix = ix
        N = n + ns * ns

        def J_ss(t, y):
            if self._J_const is not None:
                return self._J_const
            J = base.copy()
            J[at] = np.asarray(jac_fn([t, *y.tolist()]), dtype=float)[sel]
            return J

        self.J_ss = J_ss

        # The residual of the sensitivities in transposed form, written in place: row j of the
        # C-ordered (ns, ns) view of z[n:] is column j of Y, so the residual's rows are
        # Y^T J^T + Y'^T diag(mask) (one product, no reshaped copies).
        res_fn = mode.residual_function
        mrow = mask[None, :]
        J_const_T = self._J_const.T.copy() if self._J_const is not None else None

        def resfn(t, z, zp, res):
            res[:n] = res_fn([t, *z[:n].tolist(), *zp[:n].tolist()])
            R = res[n:].reshape((ns, ns))
            Jt = J_const_T if J_const_T is not None else J_ss(t, z[:n]).T
            np.matmul(z[n:].reshape((ns, ns)), Jt, out=R)
            R += zp[n:].reshape((ns, ns)) * mrow

        dmask = np.diag(mask)
        top = np.empty((n, n))
        # Flat positions of the ns diagonal blocks (one per column of Y) in the N x N matrix.
        k = np.arange(ns)
        flat_blocks = (
            (n + k[:, None, None] * ns + k[None, :, None]) * N + n + k[:, None, None] * ns + k[None, None, :]
        ).ravel()

        def jacfn(t, z, zp, res, cj, JJ):
            JJ.fill(0.0)
            mode.jacobian(t, z[:n], cj, top)
            JJ[:n, :n] = top
            B = J_ss(t, z[:n]) + cj * dmask
            np.put(JJ, flat_blocks, np.broadcast_to(B, (ns, ns, ns)))

        self._resfn, self._jacfn = resfn, jacfn
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
        self._ida = _ida(resfn, opts)
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
        (:class:`hybrid.core.errors.BudgetExceeded`).

        Raises
        ------
        hybrid.core.errors.IntegratorError
            IDA failed (its flag explained).
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
            r, bad, words = _call(self._ida, float(t1), "normal", float(t1))
            if bad is not None:
                raise IntegratorError(f"IDA failed{where} near t={t!r}: {explain(*bad)}")
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
                msg = str(r.message) + (f" {words}" if words else "")
                raise IntegratorError(f"IDA failed{where} at t={r.t!r}: {explain(int(r.status), msg)}")
            z = np.array(r.y)
            if float(r.t) >= t1 or r.status in (SUCCESS, TSTOP):
                return z[:n], z[n:].reshape((ns, ns), order="F")
            t = float(r.t)


class IDAVariational:
    """IDA's variational solvers of one compiled system's modes (one :class:`SensitivitySolver`
    per mode, built on first use; see :meth:`IDAIntegrator.variational`)."""

    def __init__(
        self, cs: CompiledSystem, s: np.ndarray, method: IDA, options: SolverOptions, max_step: float
    ):
        self.cs, self.s, self.method, self.options, self.max_step = cs, s, method, options, max_step
        self.nb = len(cs.system.variable_names)
        self._solvers: dict[int, SensitivitySolver] = {}

    @property
    def nfev(self) -> int:
        """Residual evaluations of every solver so far."""
        return sum(sv.nfev for sv in self._solvers.values())

    def solver(self, m: int, extend: np.ndarray | None = None) -> SensitivitySolver:
        """Mode ``m``'s solver (the free parameters are part of its state: ``extend`` is not needed)."""
        sv = self._solvers.get(m)
        if sv is None:
            o = self.method
            n = self.cs.modes[m].n
            atol = np.concatenate([o.atol_vector(self.cs.names[: self.nb]), [o.atol_default] * (n - self.nb)])
            sv = self._solvers[m] = SensitivitySolver(
                self.cs.modes[m],
                self.s,
                rtol=o.rtol,
                atol=atol,
                atol_sens=o.rtol,
                max_step=self.max_step,
                # IDA returns every VARIATIONAL_CALL_STEPS steps so that the budget and the deadline
                # are checked (issue 33: one call of 50,000 steps on a ring of blades ran for minutes)
                max_num_steps=min(o.max_num_steps, self.options.max_steps, VARIATIONAL_CALL_STEPS),
            )
            sv.period = self.cs.period
        return sv


@dataclass(frozen=True, init=False)
class IDA(Method):
    """SUNDIALS IDA (through scikit-sundae): any model, to its tolerances.

    Attributes
    ----------
    rtol : float
        Relative tolerance (1e-14 <= rtol <= 1e-2).
    atol : float or mapping of str to float
        Absolute tolerance, one value or per variable name (unnamed variables get
        ``atol_default``).
    atol_default : float
        Absolute tolerance of variables not named in a mapping ``atol``.
    max_num_steps : int
        Internal steps IDA may take per call (the engine goes on from where a call stopped,
        within ``SolverOptions.max_steps``).
    guard_noise : float
        Safety factor on the noise level of a guard, ``sum_j |dh/dy_j| (atol_j + rtol |y_j|)``:
        within it a guard counts as zero at a switch and stays disarmed until it has left it.

    Examples
    --------
    >>> from hybrid import IDA, SolverOptions
    >>> SolverOptions(method=IDA(rtol=1e-9, atol=1e-11)).method.noise_rtol
    1e-09
    """

    rtol: float = 1e-8
    atol: float | Mapping[str, float] = 1e-10
    atol_default: float = 1e-10
    max_num_steps: int = 50_000
    guard_noise: float = 10.0
    _atol_map: Mapping[str, float] | None = field(default=None, init=False, repr=False, compare=False)

    name = "ida"
    flows_exact = False
    needs_derivatives = True
    resolves_slaves = True
    runtime_parameters = False

    def __init__(
        self,
        *,
        rtol: float = 1e-8,
        atol: float | Mapping[str, float] = 1e-10,
        atol_default: float = 1e-10,
        max_num_steps: int = 50_000,
        guard_noise: float = 10.0,
        **unexpected,
    ):
        if unexpected:
            raise InputTypeError(
                f"IDA: no setting {', '.join(map(repr, unexpected))}; settings: rtol, atol, atol_default, "
                "max_num_steps, guard_noise (the run's budgets and step bound are SolverOptions')"
            )
        rtol, atol, atol_default, max_num_steps, guard_noise = (
            plain_number(v) for v in (rtol, atol, atol_default, max_num_steps, guard_noise)
        )
        check_positive("IDA", "rtol", rtol)
        if not 1e-14 <= rtol <= 1e-2:
            raise InputError(f"IDA: `rtol` must lie in [1e-14, 1e-2], got {rtol!r}")
        amap = None
        if isinstance(atol, Mapping):
            for k, v in atol.items():
                check_positive("IDA", f"atol[{k!r}]", v)
            amap = dict(atol)
        else:
            check_positive("IDA", "atol", atol)
        check_positive("IDA", "atol_default", atol_default)
        check_positive("IDA", "guard_noise", guard_noise)
        if isinstance(max_num_steps, bool) or not isinstance(max_num_steps, int) or max_num_steps < 1:
            raise InputError(f"IDA: `max_num_steps` must be an integer >= 1, got {max_num_steps!r}")
        for k, v in (
            ("rtol", rtol),
            ("atol", atol),
            ("atol_default", atol_default),
            ("max_num_steps", max_num_steps),
            ("guard_noise", guard_noise),
            ("_atol_map", amap),
        ):
            object.__setattr__(self, k, v)

    def __hash__(self) -> int:
        atol = tuple(sorted(self._atol_map.items())) if self._atol_map is not None else self.atol
        return hash((self.rtol, atol, self.atol_default, self.max_num_steps, self.guard_noise))

    def settings(self) -> dict:
        """Its settings as plain data (``atol`` a dict where it is a mapping)."""
        return {
            "name": self.name,
            "rtol": self.rtol,
            "atol": dict(self._atol_map) if self._atol_map is not None else self.atol,
            "atol_default": self.atol_default,
            "max_num_steps": self.max_num_steps,
            "guard_noise": self.guard_noise,
        }

    def atol_vector(self, names: Sequence[str]) -> np.ndarray:
        """Absolute tolerance per variable, in ``names`` order.

        Raises
        ------
        hybrid.core.errors.InputError
            ``atol`` names a variable that is not in ``names``.
        """
        if self._atol_map is None:
            return np.full(len(names), float(self.atol))
        unknown = set(self._atol_map) - set(names)
        if unknown:
            raise InputError(
                f"IDA: `atol` names unknown variable(s) {sorted(unknown)}; variables: {list(names)}"
            )
        return np.array([float(self._atol_map.get(n, self.atol_default)) for n in names])

    def _scaled(self, f: float, rtol: float) -> IDA:
        atol = {k: v * f for k, v in self._atol_map.items()} if self._atol_map is not None else self.atol * f
        return IDA(
            rtol=rtol,
            atol=atol,
            atol_default=self.atol_default * f,
            max_num_steps=self.max_num_steps,
            guard_noise=self.guard_noise,
        )

    def tightened(self, factor: float) -> IDA:
        """This method at tolerances ``factor`` times tighter (relative and absolute alike)."""
        return self._scaled(1.0 / factor, self.rtol / factor)

    def loosened_to(self, rtol: float) -> IDA | None:
        """This method at the looser ``rtol`` (absolute tolerances scaled alike); None where
        ``rtol`` is not at least 100 times looser than its own (nothing to save)."""
        if rtol < 100.0 * self.rtol:
            return None
        return self._scaled(rtol / self.rtol, rtol)

    @property
    def noise_rtol(self) -> float:
        """``rtol``: IDA controls each step's error relative to the state."""
        return self.rtol

    def guard_band(self, atol, grad, ht, t, y, size) -> float:
        """``guard_noise x sum |dh/dy| (atol + rtol |y|) + 1e-14``: the accuracy of the state the
        tolerances allow, carried to the guard (see :meth:`hybrid.integrators.base.Method.guard_band`)."""
        scale = atol + self.rtol * np.abs(y)
        return self.guard_noise * float(np.abs(grad) @ scale) + 1e-14

    def guard_bands(self, cm, atol, t, y, size) -> np.ndarray | None:
        """:meth:`guard_band` of every guard of a composed mode at once (None: no batched gradients)."""
        fn = getattr(cm, "guard_noise_scale", None)
        if fn is None:
            return None
        return self.guard_noise * fn(t, y, atol + self.rtol * np.abs(y)) + 1e-14

    def mode_solver(
        self,
        cs: CompiledSystem,
        mode: int,
        options: SolverOptions,
        *,
        max_step: float,
        first_step: float = 0.0,
    ) -> ModeSolver:
        """An IDA :class:`ModeSolver` of the mode, kept on ``cs`` per mode and settings and reused
        by later runs (building one costs about 2 ms; at most :data:`MAX_SHARED_SOLVERS` kept)."""
        cm = cs.modes[mode]
        # Slave variables are re-solved at every sample and switch; in IDA's error test their
        # absolute tolerance is floored at rtol: a far tighter one on a slave variable crossing
        # zero makes IDA stall in step-size cycles (tests/hybrid: nonlinear_dae).
        atol = self.atol_vector(cs.system.variable_names)
        atol[cm.alg_idx] = np.maximum(atol[cm.alg_idx], self.rtol)
        max_num_steps = min(self.max_num_steps, options.max_steps)
        shared = cs.solvers
        skey = (mode, first_step, self.rtol, atol.tobytes(), max_step, max_num_steps)
        s = shared.get(skey)
        if s is None:
            if len(shared) >= MAX_SHARED_SOLVERS:
                shared.clear()
            s = shared[skey] = ModeSolver(
                cm,
                rtol=self.rtol,
                atol=atol,
                max_step=max_step,
                max_num_steps=max_num_steps,
                first_step=first_step,
                band=cs.form.band if cs.form is not None else None,
            )
        return s

    def guard_series(self, cs: CompiledSystem, mode: int, t: float, y: np.ndarray, order: int):
        """The guards' series from the flow's Taylor series of the mode's equations (computed once)."""
        cm = cs.modes[mode]
        flow: list[np.ndarray] = []
        parts: list[tuple[frozenset, np.ndarray]] = []  # series over cones, reused by guards inside one
        jac: list[np.ndarray] = []  # dF/dy at (t, y), shared by the cones

        def series(k: int) -> np.ndarray:
            # Only the variables the guard's series depends on where they are few (a guard of one
            # block of a chain), else the whole flow's series, once for all guards (issue 34)
            cone = cm.taylor_cone(cm.guards[k].expr, order)
            if 2 * len(cone) < cm.n:
                X = next((X for c, X in parts if cone <= c), None)
                if X is None:
                    if not jac and cm.alg_idx.size:
                        jac.append(cm.dFdy(t, y))
                    X = cm.taylor(t, y, order, rows=cone, dFdy=jac[0] if jac else None)
                    parts.append((cone, X))
                return cm.guard_series(k, t, y, order, X)
            if not flow:
                flow.append(cm.taylor(t, y, order))
            return cm.guard_series(k, t, y, order, flow[0])

        return series

    def variational(
        self, cs: CompiledSystem, s: np.ndarray, options: SolverOptions, max_step: float
    ) -> IDAVariational:
        """IDA on each mode's DAE with its variational equations (:class:`SensitivitySolver`)."""
        return IDAVariational(cs, s, self, options, max_step)
