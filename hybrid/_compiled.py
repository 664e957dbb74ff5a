"""A hybrid system compiled for one set of parameter values.

Every expression of the system, with the parameter values folded in, becomes
a closure over the flat list ``v = [t, y_0, ..., y_{n-1}]``; exact partial
derivatives come from :func:`hybrid._expr.diff` on the same trees. This module
knows the DAE form used by the integrator backend:

* differential variable ``i`` of a mode: residual ``F_i = y'_i - f_i(t, y)``;
* slave variable ``j`` of a mode: residual ``F_j = g_j(t, y)``;

so that the iteration matrix is ``dF/dy + cj dF/dy'``.
"""

from __future__ import annotations

import math
import weakref
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from ._expr import Expr, diff, free_symbols, neg, num, runtime_namespace, set_runtime, substitute, taylor_eval
from ._expr import compile_scalar as _compile_scalar
from ._system import HybridSystem

__all__ = ["CompiledSystem", "CompiledMode", "CompiledGuard", "AlgebraicSolveError"]


class AlgebraicSolveError(RuntimeError):
    """The slave variables of a mode could not be solved from their algebraic equations."""


@dataclass(frozen=True)
class CompiledGuard:
    """A transition's guard compiled in its source mode."""

    index: int  # position among the source mode's guards
    transition: int  # position in system.transitions
    name: str
    target: int  # target mode index
    direction: int
    expr: Expr
    fn: object  # closure v -> float
    grad: tuple  # closures v -> dh/dy_j (None where identically zero)
    grad_t: object
    reset: tuple  # ((var index, closure), ...)
    reset_expr: tuple = ()  # ((var index, Expr), ...)


class CompiledMode:
    """One mode's equations, Jacobians, guards and outputs as closures.

    Parameters named in ``free`` are not folded in: they are appended to the
    state as differential variables with zero derivative, so that Jacobians
    include the derivatives with respect to them (parameter sensitivities).
    Parameters named in ``runtime`` are not folded in either: the closures
    read them from the namespace ``shared`` at call time
    (:meth:`CompiledSystem.set_runtime`).
    """

    def __init__(
        self,
        system: HybridSystem,
        index: int,
        params: Mapping[str, float],
        free: tuple[str, ...] = (),
        runtime: tuple[str, ...] = (),
        shared: dict | None = None,
    ):
        mode = system.modes[index]
        data = system._cache["modes"][mode.name]
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
        self._shared = shared

        def compile_scalar(e: Expr, slots: dict, constants: dict):
            return _compile_scalar(e, slots, constants, shared)

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
        self.f = [(int(i), compile_scalar(e, slots, {})) for i, e in self.f_expr.items()]
        self.g = [(int(i), compile_scalar(e, slots, {})) for i, e in self.g_expr.items()]

        # dF/dy: constant entries in a dense base matrix, the rest as closures.
        self.jac_base = np.zeros((n, n))
        self.jac_terms: list[tuple[int, int, object]] = []
        rows = [(i, self.f_expr[i], -1.0) for i in self.diff_idx] + [
            (i, self.g_expr[i], 1.0) for i in self.alg_idx
        ]
        for i, e, sgn in rows:
            for j, nm in enumerate(names):
                d = diff(e, nm)
                if d.op == "num":
                    self.jac_base[i, j] = sgn * d.args[0]
                else:
                    dd = d if sgn > 0 else neg(d)
                    self.jac_terms.append((int(i), j, compile_scalar(dd, slots, {})))
        self.cj_mask = np.diag(self.is_diff.astype(float))
        # d g / d t for the derivatives of slave variables.
        self.g_t = [(int(i), compile_scalar(diff(e, "t"), slots, {})) for i, e in self.g_expr.items()]

        # Guards of transitions leaving this mode.
        guards = []
        mode_index = {m.name: k for k, m in enumerate(system.modes)}
        for k, (tr, td) in enumerate(zip(system.transitions, system._cache["transitions"], strict=True)):
            if tr.source != mode.name:
                continue
            h = fold(td["guard"])
            grad = []
            for nm in names:
                d = diff(h, nm)
                grad.append(None if (d.op == "num" and d.args[0] == 0.0) else compile_scalar(d, slots, {}))
            reset_expr = tuple((names.index(v), fold(e)) for v, e in td["reset"].items())
            reset = tuple((i, compile_scalar(e, slots, {})) for i, e in reset_expr)
            guards.append(
                CompiledGuard(
                    index=len(guards),
                    transition=k,
                    name=tr.name,
                    target=mode_index[tr.target],
                    direction=tr.direction,
                    expr=h,
                    fn=compile_scalar(h, slots, {}),
                    grad=tuple(grad),
                    grad_t=compile_scalar(diff(h, "t"), slots, {}),
                    reset=reset,
                    reset_expr=reset_expr,
                )
            )
        self.guards: tuple[CompiledGuard, ...] = tuple(guards)
        self.outputs = {o: compile_scalar(fold(data["defs"][o]), slots, {}) for o in system.outputs}

    # ------------------------------------------------------------------
    # Residual and Jacobian (backend-independent: plain arrays in and out)
    def residual(self, t: float, y: np.ndarray, yp: np.ndarray, out: np.ndarray) -> None:
        """Fill ``out`` with the DAE residual ``F(t, y, y')``."""
        v = [t, *y.tolist()]
        for i, f in self.f:
            out[i] = yp[i] - f(v)
        for i, g in self.g:
            out[i] = g(v)

    def jacobian(self, t: float, y: np.ndarray, cj: float, out: np.ndarray) -> None:
        """Fill ``out`` with ``dF/dy + cj dF/dy'``."""
        out[:, :] = self.jac_base
        if self.jac_terms:
            v = [t, *y.tolist()]
            for i, j, fn in self.jac_terms:
                out[i, j] = fn(v)
        out += cj * self.cj_mask

    def dFdy(self, t: float, y: np.ndarray) -> np.ndarray:
        """``dF/dy`` (rows: -df/dy for differential, dg/dy for slave variables)."""
        out = np.empty((self.n, self.n))
        self.jacobian(t, y, 0.0, out)
        return out

    # ------------------------------------------------------------------
    def rhs(self, t: float, y: np.ndarray) -> np.ndarray:
        """Derivatives of the differential variables (zeros at slave positions)."""
        v = [t, *np.asarray(y, dtype=float).tolist()]
        out = np.zeros(self.n)
        for i, f in self.f:
            out[i] = f(v)
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
        for _ in range(maxiter):
            self.residual(t, y, np.zeros(self.n), res)
            r = res[a]
            J = self.dFdy(t, y)[np.ix_(a, a)]
            try:
                step = np.linalg.solve(J, r)
            except np.linalg.LinAlgError:
                raise AlgebraicSolveError(
                    f"mode `{self.name}`: the algebraic equations are singular in the slave variables at t={t!r}"
                ) from None
            y[a] -= step
            scale = 1.0 + np.abs(y[a])
            if np.all(np.abs(step) <= tol * scale):
                self.residual(t, y, np.zeros(self.n), res)
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
            rhs = -(J[np.ix_(a, d)] @ yp[d] + gt)
            yp[a] = np.linalg.solve(J[np.ix_(a, a)], rhs)
        return yp

    def guard_values(self, t: float, y: np.ndarray) -> np.ndarray:
        """Values of this mode's guards at ``(t, y)``."""
        v = [t, *np.asarray(y, dtype=float).tolist()]
        return np.array([g.fn(v) for g in self.guards])

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
        for k in range(order):
            env = {"t": tj, **self._runtime_values(), **{nm: X[i] for i, nm in enumerate(self.names)}}
            for i, e in self.f_expr.items():
                X[i, k + 1] = taylor_eval(e, env)[k] / (k + 1)
            if a.size:
                r = np.array([taylor_eval(self.g_expr[i], env)[k + 1] for i in a])
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
        env = {"t": tj, **self._runtime_values(), **{nm: X[i] for i, nm in enumerate(self.names)}}
        return taylor_eval(self.guards[k].expr, env)

    def _runtime_values(self) -> dict[str, float]:
        return {p: self._shared[f"_p_{p}"] for p in self._runtime}


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
        shared = runtime_namespace({p: self.params[p] for p in self.runtime}) if self.runtime else None
        self._shared = shared
        self.modes = tuple(
            CompiledMode(system, k, self.params, self.free, self.runtime, shared)
            for k in range(len(system.modes))
        )
        self.mode_index = {m.name: k for k, m in enumerate(self.modes)}
        self.period = system.period_value(self.params)
        self.names = tuple(system.variable_names) + self.free
        self._affine = None

    @classmethod
    def borrow(cls, system: HybridSystem, params: Mapping[str, float], owner: object) -> CompiledSystem:
        """A compiled system with every parameter read at call time, set to ``params``, lent to ``owner``.

        Taken from a pool kept with ``system`` (compiled only if the pool is
        empty) and returned to it when ``owner`` is garbage-collected, so
        that repeated short-lived users (one periodic orbit after another at
        new parameter values) do not recompile the system; two owners never
        share one.
        """
        pool = system.__dict__.setdefault("_compiled_pool", [])
        cs = pool.pop() if pool else cls(system, params, runtime=tuple(system.parameter_names))
        cs.set_runtime(system.parameter_values(params))
        weakref.finalize(owner, pool.append, cs)
        return cs

    def set_runtime(self, values: Mapping[str, float]) -> None:
        """New values of ``runtime`` parameters (checked; the others must not change)."""
        bad = [k for k in values if k not in self.runtime]
        if bad:
            raise ValueError(f"`{bad[0]}` is not a runtime parameter of this compiled system")
        self.params = self.system.parameter_values({**self.params, **values})
        set_runtime(self._shared, {p: self.params[p] for p in self.runtime})
        for m in self.modes:
            m._params = self.params
        self.period = self.system.period_value(self.params)
        self._affine = None

    def affine(self) -> list:
        """Every mode as an exact affine flow (:func:`hybrid._exact.affine_system`), analysed once.

        Raises
        ------
        hybrid._exact.NotAffineError
            Naming the first mode and term that is not affine.
        """
        if self._affine is None:
            from ._exact import affine_system  # the exact integrator builds on this module

            try:
                self._affine = affine_system(self)
            except ValueError as exc:
                raise type(exc)(f"model `{self.system.name}`: {exc}") from None
        return self._affine

    def depends_on_time(self) -> bool:
        """True if an equation or guard of any mode depends explicitly on ``t``."""
        for cm in self.modes:
            exprs = list(cm.f_expr.values()) + list(cm.g_expr.values()) + [g.expr for g in cm.guards]
            if any("t" in free_symbols(e) for e in exprs):
                return True
        return False

    def mode_id(self, name: str) -> int:
        if name not in self.mode_index:
            raise ValueError(
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
