"""A hybrid system compiled for one set of parameter values.

Every expression of the system, with the parameter values folded in, becomes
a closure over the flat list ``v = [t, y_0, ..., y_{n-1}]``; exact partial
derivatives come from :func:`hybrid.model.expr.diff` on the same trees. This module
knows the DAE form used by the integrator backend:

* differential variable ``i`` of a mode: residual ``F_i = y'_i - f_i(t, y)``;
* slave variable ``j`` of a mode: residual ``F_j = g_j(t, y)``;

so that the iteration matrix is ``dF/dy + cj dF/dy'``.
"""

from __future__ import annotations

import math
import threading
import weakref
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from ..core.errors import AlgebraicSolveError, InputError
from .codegen import compile_many, runtime_namespace, set_runtime
from .expr import Expr, diff, free_symbols, neg, num, sub, substitute, sym
from .system import HybridSystem
from .taylor import taylor_eval, taylor_eval_many

__all__ = ["CompiledSystem", "CompiledMode", "CompiledGuard", "CompiledPool", "lend"]

#: Prefix of the generated residual's slots for ``y'`` (not a valid model name: no clash).
_YP = " yp"


@dataclass(frozen=True)
class CompiledGuard:
    """A transition's guard compiled in its source mode."""

    index: int  # position among the source mode's guards
    transition: int  # position in system.transitions
    name: str
    target: int  # target mode index
    direction: int
    expr: Expr
    fn: object  # function v -> float
    grad: tuple  # closures v -> dh/dy_j (None where identically zero)
    grad_t: object
    reset: tuple  # ((var index, closure), ...)
    reset_expr: tuple = ()  # ((var index, Expr), ...)


class CompiledMode:
    """One mode's equations, Jacobians, guards and outputs as generated functions.

    The residual of all rows, the non-constant entries of ``dF/dy`` and the values of all guards
    are each one straight-line function of the mode (:func:`hybrid.model.expr.compile_many`: shared
    sub-expressions computed once per call).

    Parameters named in ``free`` are not folded in: they are appended to the
    state as differential variables with zero derivative, so that Jacobians
    include the derivatives with respect to them (parameter sensitivities).
    Parameters named in ``runtime`` are not folded in either: the generated
    functions read them from ``namespace`` (:func:`hybrid.model.expr.runtime_namespace`)
    at every call, so that :meth:`CompiledSystem.set_runtime` changes them
    without compiling again.
    """

    def __init__(
        self,
        system: HybridSystem,
        index: int,
        params: Mapping[str, float],
        free: tuple[str, ...] = (),
        runtime: tuple[str, ...] = (),
        namespace: dict | None = None,
    ):
        mode = system.modes[index]
        data = system.parsed.modes[mode.name]
        names = tuple(system.variable_names) + tuple(free)
        self.name = mode.name
        self.index = index
        self.n = n = len(names)
        self.names = names
        slots = {"t": 0, **{nm: i + 1 for i, nm in enumerate(names)}}
        pconst = {k: num(v) for k, v in params.items() if k not in free and k not in runtime}
        self._slots = slots
        self._params = dict(params)
        self._runtime = tuple(runtime)
        self._ns = namespace if namespace is not None else runtime_namespace({})

        def comp(e: Expr):
            return compile_many([e], slots, namespace=self._ns, scalar=True)

        def fold(e: Expr) -> Expr:
            return substitute(e, pconst)

        derivs = {**data["derivatives"], **{p: num(0.0) for p in free}}
        self.diff_idx = np.array([i for i, nm in enumerate(names) if nm in derivs], dtype=int)
        self.alg_idx = np.array([i for i, nm in enumerate(names) if nm in data["algebraic"]], dtype=int)
        self.is_diff = np.zeros(n, dtype=bool)
        self.is_diff[self.diff_idx] = True
        # Row expressions: derivative for differential rows, residual for algebraic rows.
        self.f_expr = {i: fold(derivs[names[i]]) for i in self.diff_idx}
        self.g_expr = {i: fold(data["algebraic"][names[i]]) for i in self.alg_idx}
        # The residual F(t, y, y') of all rows, as one function of v = [t, y..., y'...].
        res_slots = {**slots, **{f"{_YP}{i}": n + 1 + i for i in range(n)}}
        rows: list[Expr] = [num(0.0)] * n
        for i, e in self.f_expr.items():
            rows[i] = sub(sym(f"{_YP}{i}"), e)
        for i, e in self.g_expr.items():
            rows[i] = e
        self._res_fn = compile_many(rows, res_slots, f"residual_{mode.name}", namespace=self._ns)
        self._f_pos = np.array(sorted(self.f_expr), dtype=int)

        # dF/dy: constant entries in a dense base matrix, the rest in one function.
        self.jac_base = np.zeros((n, n))
        self.jac_terms: list[tuple[int, int, Expr]] = []
        jrows = [(i, self.f_expr[i], -1.0) for i in self.diff_idx] + [
            (i, self.g_expr[i], 1.0) for i in self.alg_idx
        ]
        for i, e, sgn in jrows:
            for j, nm in enumerate(names):
                d = diff(e, nm)
                if d.op == "num":
                    self.jac_base[i, j] = sgn * d.args[0]
                else:
                    self.jac_terms.append((int(i), j, d if sgn > 0 else neg(d)))
        self._jac_fn = (
            compile_many(
                [e for _, _, e in self.jac_terms], slots, f"jacobian_{mode.name}", namespace=self._ns
            )
            if self.jac_terms
            else None
        )
        self._jac_at = (
            np.array([i for i, _, _ in self.jac_terms], dtype=int),
            np.array([j for _, j, _ in self.jac_terms], dtype=int),
        )
        self.cj_mask = np.diag(self.is_diff.astype(float))
        # g_z constant (every entry of the slave block in jac_base): its inverse, for solve_algebraic.
        self._gzz_inv = None
        a = self.alg_idx
        if a.size and not any(i in set(a.tolist()) and j in set(a.tolist()) for i, j, _ in self.jac_terms):
            gzz = self.jac_base[np.ix_(a, a)]
            if np.linalg.cond(gzz) < 1e12:
                self._gzz_inv = np.linalg.inv(gzz)
        # d g / d t for the derivatives of slave variables.
        self.g_t = [(int(i), comp(diff(e, "t"))) for i, e in self.g_expr.items()]
        self._ix_ad = np.ix_(self.alg_idx, self.diff_idx)  # blocks of dF/dy for the slave rates
        self._ix_aa = np.ix_(self.alg_idx, self.alg_idx)

        # Guards of transitions leaving this mode.
        guards = []
        mode_index = {m.name: k for k, m in enumerate(system.modes)}
        for k, (tr, td) in enumerate(zip(system.transitions, system.parsed.transitions, strict=True)):
            if tr.source != mode.name:
                continue
            h = fold(td["guard"])
            grad = []
            for nm in names:
                d = diff(h, nm)
                grad.append(None if (d.op == "num" and d.args[0] == 0.0) else comp(d))
            reset_expr = tuple((names.index(v), fold(e)) for v, e in td["reset"].items())
            reset = tuple((i, comp(e)) for i, e in reset_expr)
            guards.append(
                CompiledGuard(
                    index=len(guards),
                    transition=k,
                    name=tr.name,
                    target=mode_index[tr.target],
                    direction=tr.direction,
                    expr=h,
                    fn=comp(h),
                    grad=tuple(grad),
                    grad_t=comp(diff(h, "t")),
                    reset=reset,
                    reset_expr=reset_expr,
                )
            )
        self.guards: tuple[CompiledGuard, ...] = tuple(guards)
        self._guards_fn = (
            compile_many([g.expr for g in guards], slots, f"guards_{mode.name}", namespace=self._ns)
            if guards
            else None
        )
        self.outputs = {o: comp(fold(data["defs"][o])) for o in system.outputs}
        # all outputs at once on arrays of samples (one column per slot): see outputs_at
        self._outputs_vec = (
            compile_many(
                [fold(data["defs"][o]) for o in system.outputs],
                slots,
                f"outputs_{mode.name}",
                namespace=self._ns,
                vector=True,
            )
            if system.outputs
            else None
        )

    def outputs_at(self, t: np.ndarray, Y: np.ndarray) -> list[np.ndarray] | None:
        """The system's outputs at samples ``(t[i], Y[i])`` of this mode, one array per output (in
        the order of ``system.outputs``), evaluated elementwise at once; None where a value is not
        finite (the caller evaluates sample by sample, where the scalar functions say why)."""
        if self._outputs_vec is None:
            return []
        with np.errstate(all="ignore"):
            vals = self._outputs_vec([t, *Y.T])
        out = [np.broadcast_to(np.asarray(v, dtype=float), t.shape) for v in vals]
        return out if all(np.all(np.isfinite(v)) for v in out) else None

    def _env(self, tj: np.ndarray, X: np.ndarray) -> dict:
        env = {"t": tj, **{nm: X[i] for i, nm in enumerate(self.names)}}
        for p in self._runtime:
            env[p] = self._ns[f"_p_{p}"]
        return env

    # ------------------------------------------------------------------
    # Residual and Jacobian (backend-independent: plain arrays in and out)
    def residual(self, t: float, y: np.ndarray, yp: np.ndarray, out: np.ndarray) -> None:
        """Fill ``out`` with the DAE residual ``F(t, y, y')``."""
        out[: self.n] = self._res_fn([t, *y[: self.n].tolist(), *yp[: self.n].tolist()])

    def jacobian(self, t: float, y: np.ndarray, cj: float, out: np.ndarray) -> None:
        """Fill ``out`` with ``dF/dy + cj dF/dy'``."""
        out[:, :] = self.jac_base
        if self._jac_fn is not None:
            out[self._jac_at] = self._jac_fn([t, *y.tolist()])
        d = self.diff_idx
        out[d, d] += cj

    def dFdy(self, t: float, y: np.ndarray) -> np.ndarray:
        """``dF/dy`` (rows: -df/dy for differential, dg/dy for slave variables)."""
        out = np.empty((self.n, self.n))
        self.jacobian(t, y, 0.0, out)
        return out

    # ------------------------------------------------------------------
    def rhs(self, t: float, y: np.ndarray) -> np.ndarray:
        """Derivatives of the differential variables (zeros at slave positions)."""
        y = np.asarray(y, dtype=float)
        out = np.zeros(self.n)
        F = self._res_fn([t, *y.tolist(), *([0.0] * self.n)])
        p = self._f_pos
        out[p] = np.negative(np.take(F, p))
        return out

    def solve_algebraic(
        self, t: float, y: np.ndarray, *, tol: float = 1e-14, maxiter: int = 50
    ) -> np.ndarray:
        """Return ``y`` with the slave variables solved by Newton's method (exact Jacobian)."""
        y = np.array(y, dtype=float)
        if self.alg_idx.size == 0:
            return y
        a = self.alg_idx
        res = np.zeros(self.n)
        zero = np.zeros(self.n)
        for _ in range(maxiter):
            self.residual(t, y, zero, res)
            r = res[a]
            try:
                if self._gzz_inv is not None:  # constant g_z: no Jacobian to evaluate or factor
                    step = self._gzz_inv @ r
                else:
                    step = np.linalg.solve(self.dFdy(t, y)[np.ix_(a, a)], r)
            except np.linalg.LinAlgError:
                raise AlgebraicSolveError(
                    f"mode `{self.name}`: the algebraic equations are singular in the slave variables at t={t!r}"
                ) from None
            y[a] -= step
            scale = 1.0 + np.abs(y[a])
            if np.all(np.abs(step) <= tol * scale):
                self.residual(t, y, zero, res)
                if np.all(np.isfinite(res[a])):
                    return y
        raise AlgebraicSolveError(
            f"mode `{self.name}`: Newton's method did not solve the algebraic equations at t={t!r} "
            f"(residual {np.max(np.abs(res[a])):.3g})"
        )

    def derivatives(self, t: float, y: np.ndarray) -> np.ndarray:
        """Consistent ``y'`` at a point that satisfies the algebraic equations.

        Differential rows from the vector field; slave rows from the
        differentiated constraint ``g_z z' = -(g_x x' + g_t)``.
        """
        yp = self.rhs(t, y)
        if self.alg_idx.size:
            a, d = self.alg_idx, self.diff_idx
            J = self.dFdy(t, y)
            v = [t, *np.asarray(y, dtype=float).tolist()]
            gt = np.array([fn(v) for _, fn in self.g_t])
            rhs = -(J[self._ix_ad] @ yp[d] + gt)
            gzz = J[self._ix_aa]
            yp[a] = rhs / gzz[0, 0] if a.size == 1 else np.linalg.solve(gzz, rhs)
        return yp

    def guard_values(self, t: float, y: np.ndarray) -> np.ndarray:
        """Values of this mode's guards at ``(t, y)``."""
        if self._guards_fn is None:
            return np.zeros(0)
        return np.array(self._guards_fn([t, *np.asarray(y, dtype=float).tolist()]))

    def guard_gradient(self, k: int, t: float, y: np.ndarray) -> tuple[np.ndarray, float]:
        """``(dh/dy, dh/dt)`` of guard ``k`` at ``(t, y)``."""
        v = [t, *np.asarray(y, dtype=float).tolist()]
        g = self.guards[k]
        grad = np.array([0.0 if d is None else d(v) for d in g.grad])
        return grad, g.grad_t(v)

    # ------------------------------------------------------------------
    def taylor(self, t: float, y: np.ndarray, order: int) -> np.ndarray:
        """Taylor coefficients of this mode's flow through ``(t, y)``.

        Differential variables: ``x_{k+1} = f(x)_k / (k+1)``; slave variables:
        the order-``k`` coefficient of ``g(x, z) = 0`` is linear in ``z_k``.

        Returns
        -------
        ndarray, shape (n, order + 1)
        """
        n = self.n
        X = np.zeros((n, order + 1))
        X[:, 0] = y
        tj = np.zeros(order + 1)
        tj[0] = t
        if order >= 1:
            tj[1] = 1.0
        a = self.alg_idx
        Jzz = None
        if a.size:
            Jzz = self.dFdy(t, y)[np.ix_(a, a)]
        f_rows, f_roots = list(self.f_expr), tuple(self.f_expr.values())
        g_roots = tuple(self.g_expr[i] for i in a)
        for k in range(order):
            env = self._env(tj, X)  # views of the rows of X: they see the coefficients set below
            series = taylor_eval_many(f_roots, env)  # shared sub-expressions once
            for i, c in zip(f_rows, series, strict=True):
                X[i, k + 1] = c[k] / (k + 1)
            if a.size:
                r = np.array([c[k + 1] for c in taylor_eval_many(g_roots, env)])
                X[a, k + 1] = -np.linalg.solve(Jzz, r)
        return X

    def guard_series(
        self, k: int, t: float, y: np.ndarray, order: int, X: np.ndarray | None = None
    ) -> np.ndarray:
        """Taylor coefficients of guard ``k`` along this mode's flow from ``(t, y)``.

        ``X`` may pass the flow's series from :meth:`taylor` (same point and order) to reuse it.
        """
        if X is None:
            X = self.taylor(t, y, order)
        tj = np.zeros(order + 1)
        tj[0] = t
        if order >= 1:
            tj[1] = 1.0
        return taylor_eval(self.guards[k].expr, self._env(tj, X))


class CompiledSystem:
    """All modes of a system compiled for one parameter set.

    ``free`` parameters are appended to the state (see :class:`CompiledMode`);
    ``runtime`` parameters are read at call time, so that
    :meth:`set_runtime` changes them without recompiling.
    """

    def __init__(
        self,
        system: HybridSystem,
        params: Mapping[str, float],
        free: tuple[str, ...] = (),
        runtime: tuple[str, ...] = (),
    ):
        self.system = system
        self.params = system.parameter_values(params)
        self.free = tuple(free)
        self.runtime = tuple(runtime)
        self._ns = runtime_namespace({p: self.params[p] for p in self.runtime})
        self.modes = tuple(
            CompiledMode(system, k, self.params, self.free, self.runtime, self._ns)
            for k in range(len(system.modes))
        )
        self.mode_index = {m.name: k for k, m in enumerate(self.modes)}
        self.period = system.period_value(self.params)
        self.names = tuple(system.variable_names) + self.free
        #: What higher layers derive from this compiled system at its current parameter values
        #: (e.g. the exact integrator's flows), by key; cleared when :meth:`set_runtime` changes them.
        self.derived: dict[str, object] = {}
        #: Integrator objects built for this compiled system (e.g. IDA's per mode and settings),
        #: reused by later runs; bounded by the integrator that keeps them. They read the run-time
        #: parameters at each call, so they stay valid when :meth:`set_runtime` changes them.
        self.solvers: dict[object, object] = {}

    def set_runtime(self, params: Mapping[str, float]) -> None:
        """New parameter values that differ from the compiled ones only in ``runtime`` parameters."""
        new = self.system.parameter_values({**self.params, **params})
        changed = [k for k in new if new[k] != self.params[k] and k not in self.runtime]
        if changed:
            raise InputError(f"parameter `{changed[0]}` is compiled in as a constant: compile again")
        self.params = new
        set_runtime(self._ns, {p: new[p] for p in self.runtime})
        for m in self.modes:
            m._params = new
        self.period = self.system.period_value(new)
        self.derived.clear()

    def depends_on_time(self) -> bool:
        """True if an equation or guard of any mode depends explicitly on ``t``."""
        for cm in self.modes:
            exprs = list(cm.f_expr.values()) + list(cm.g_expr.values()) + [g.expr for g in cm.guards]
            if any("t" in free_symbols(e) for e in exprs):
                return True
        return False

    def mode_id(self, name: str) -> int:
        if name not in self.mode_index:
            raise InputError(
                f"model `{self.system.name}` has no mode `{name}`; modes: {', '.join(self.mode_index)}"
            )
        return self.mode_index[name]


def lead_sign(series: np.ndarray, noise: float) -> float:
    """Sign with which a series that starts within ``noise`` of zero leaves it.

    The order ``k >= 1`` whose term ``h_k s^k`` first reaches ``noise`` (the
    smallest ``s_k = (noise/|h_k|)^(1/k)``) decides; 0 if all vanish.
    """
    best, sign = math.inf, 0.0
    for k in range(1, series.size):
        hk = series[k]
        if hk != 0.0:
            s = (noise / abs(hk)) ** (1.0 / k)
            if s < best:
                best, sign = s, math.copysign(1.0, hk)
    return sign


#: Free compiled systems of each kind kept per model for reuse (the most recent ones).
POOL_SIZE = 4


class CompiledPool:
    """The compiled systems of one model, each lent to one owner at a time.

    A compiled system's parameters read at run time change with :meth:`CompiledSystem.set_runtime`,
    so two owners must never share one (a shooter at one parameter value once changed those of
    another's). A loan returns to the pool when its owner releases it or is garbage-collected;
    free systems are reused, so that one orbit after another, or a continuation's neighbours,
    compile the model once:

    * ``every_parameter``: every parameter read at run time (the exact integrator's flows come
      from the parametric analysis, so nothing is folded): any free one, set to the values;
    * otherwise a free one compiled for the same values; or one whose run-time parameters are
      the only ones that differ (set to the values); or, where a free one differs in a single
      parameter that no reset uses, a new one with that parameter read at run time (a sweep or
      a continuation neighbour then compiles once); else a new one with every parameter folded.

    At most :data:`POOL_SIZE` free systems of each kind are kept.
    """

    def __init__(self, system: HybridSystem):
        self.system = system
        self._free: list[CompiledSystem] = []  # folded, or one parameter at run time; oldest first
        self._free_every: list[CompiledSystem] = []  # every parameter at run time
        self._lock = threading.Lock()
        # Parameters in a reset stay folded (the saltation code compiles reset derivatives on its own).
        self._resets = set().union(
            *(e.free for td in system.parsed.transitions for e in td["reset"].values())
        )

    def lend(self, params: Mapping[str, float], owner: object, *, every_parameter: bool = False):
        """A compiled system at ``params`` for ``owner`` alone, and the function that returns it.

        Returns
        -------
        cs : CompiledSystem
        release : callable
            Returns ``cs`` to the pool (at most once; also when ``owner`` is collected).
        """
        system = self.system
        params = system.parameter_values(params)
        with self._lock:
            if every_parameter:
                free = self._free_every
                cs = free.pop() if free else None
            else:
                free = self._free
                best = None
                for k, c in enumerate(free):
                    differ = [p for p, v in params.items() if v != c.params[p]]
                    if not differ or (c.runtime and set(differ) <= set(c.runtime)):
                        best = k
                        break
                    if not c.runtime and len(differ) == 1 and best is None and differ[0] not in self._resets:
                        best = (differ[0],)
                cs = free.pop(best) if isinstance(best, int) else None
        if cs is None:
            if every_parameter:
                cs = CompiledSystem(system, params, runtime=tuple(system.parameter_names))
            else:
                cs = CompiledSystem(system, params, runtime=best if isinstance(best, tuple) else ())
        if cs.runtime:
            cs.set_runtime(params)
        release = weakref.finalize(owner, self._give_back, cs, free)
        return cs, release

    def _give_back(self, cs: CompiledSystem, free: list) -> None:
        with self._lock:
            free.append(cs)  # most recent last
            while len(free) > POOL_SIZE:
                free.pop(0)


def lend(system: HybridSystem, params: Mapping[str, float], owner: object, *, every_parameter: bool = False):
    """A compiled system of ``system`` at ``params`` lent to ``owner`` alone, from the model's
    :class:`CompiledPool` (kept in ``system.cache``); returns ``(cs, release)``."""
    pool = system.cache.get("compiled_pool", lambda: CompiledPool(system))
    return pool.lend(params, owner, every_parameter=every_parameter)
