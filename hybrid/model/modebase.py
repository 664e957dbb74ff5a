"""What a compiled mode computes from its generated functions: :class:`ModeMethods`.

Shared by :class:`hybrid.model.compiled.CompiledMode` (a mode compiled on its own) and
:class:`hybrid.model.composed.ComposedMode` (a mode of a system with components, a view of
functions compiled once for all its modes). Both provide the public attributes listed in
:class:`ModeMethods` (what the integrators and the variational equations read) and, private to
this subpackage, ``_f_pos``, ``_gzz_inv``, ``_ix_ad``, ``_ix_aa``, ``_outputs_vec``, ``_runtime``.
"""

from __future__ import annotations

import numpy as np

from ..core.cache import LRUCache
from ..core.errors import AlgebraicSolveError
from .taylor import taylor_eval, taylor_eval_many

__all__ = ["ModeMethods"]


#: Guard cones kept per mode (:meth:`ModeMethods.taylor_cone`; a few per guard and order).
CONES_KEPT = 256


class ModeMethods:
    """Residual, Jacobian, slave variables, consistent derivatives, guards and Taylor series of a
    compiled mode (plain arrays in and out).

    The generated functions themselves are public too, for the hot paths that call them without
    these wrappers (an integrator's callbacks, about 2000 calls per forcing period). Each takes
    one flat list of floats ``v``: ``[t, y_1, ..., y_n]`` (the positions of :attr:`state_slots`),
    followed by ``[y'_1, ..., y'_n]`` for the residual.

    Attributes
    ----------
    n : int
        Number of state variables (free parameters appended last, see
        :class:`hybrid.model.compiled.CompiledMode`).
    names : tuple of str
        The state variables, in state order.
    residual_function : callable
        ``v = [t, *y, *y'] -> F``: the DAE residual, a sequence of ``n`` floats (differential rows
        ``y'_i - f_i(t, y)``, slave rows ``g_i(t, y)``); units those of the row's equation.
    is_diff : ndarray of bool, shape (n,)
        Whether each variable is differential (else a slave variable) in this mode.
    jac_base : ndarray, shape (n, n)
        The entries of ``dF/dy`` that do not depend on ``(t, y)`` (zero where they do).
    jacobian_function : callable or None
        ``v = [t, *y] ->`` the entries of ``dF/dy`` that depend on ``(t, y)``, in the order of
        :attr:`jacobian_entries`; None where every entry is constant (:attr:`jac_base` is all).
        ``dF/dy'`` is ``diag(is_diff)``.
    jacobian_entries : tuple of two int ndarrays
        ``(rows, columns)`` of the values of :attr:`jacobian_function` in ``dF/dy``.
    guards : sequence of hybrid.model.compiled.CompiledGuard
        The guards of the transitions leaving the mode, by index.
    guards_function : callable or None
        ``v = [t, *y] ->`` the values of all :attr:`guards` at once, by index (None without
        guards).
    state_slots : dict of str to int
        The position of ``t`` (0) and of each state variable in ``v``: the slots with which
        further expressions of the mode's variables compile
        (:func:`hybrid.model.codegen.compile_scalar`), e.g. the derivatives of a reset.
    parameter_namespace : dict
        The namespace from which the generated functions read the parameters set at run time
        (:func:`hybrid.model.codegen.runtime_namespace`), shared by every mode of one
        :class:`hybrid.model.compiled.CompiledSystem`; a function compiled with it follows
        :meth:`hybrid.model.compiled.CompiledSystem.set_runtime` as the mode's own do.
    """

    #: The state variables' positions by name, made on first use (:meth:`_env`).
    _name_index: dict[str, int] | None = None
    #: The guards' Taylor cones by (expression, order), made on first use (:meth:`taylor_cone`).
    _cones: LRUCache | None = None

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

    def _env(self, tj: np.ndarray, X: np.ndarray, only=None) -> dict:
        """Series of ``t`` and of the variables (rows of ``X``; ``only``: of these names only, for
        expressions that read no other) and the run-time parameters, by name."""
        if only is None:
            env = {"t": tj, **{nm: X[i] for i, nm in enumerate(self.names)}}
        else:
            index = self._name_index
            if index is None:
                index = self._name_index = {nm: i for i, nm in enumerate(self.names)}
            env = {"t": tj, **{nm: X[index[nm]] for nm in only if nm in index}}
        for p in self._runtime:
            env[p] = self.parameter_namespace[f"_p_{p}"]
        return env

    # ------------------------------------------------------------------
    # Residual and Jacobian (backend-independent: plain arrays in and out)
    def residual(self, t: float, y: np.ndarray, yp: np.ndarray, out: np.ndarray) -> None:
        """Fill ``out`` with the DAE residual ``F(t, y, y')``."""
        out[: self.n] = self.residual_function([t, *y[: self.n].tolist(), *yp[: self.n].tolist()])

    def jacobian(self, t: float, y: np.ndarray, cj: float, out: np.ndarray) -> None:
        """Fill ``out`` with ``dF/dy + cj dF/dy'``."""
        out[:, :] = self.jac_base
        if self.jacobian_function is not None:
            out[self.jacobian_entries] = self.jacobian_function([t, *y.tolist()])
        d = self.diff_idx
        out[d, d] += cj

    def dFdy(self, t: float, y: np.ndarray) -> np.ndarray:
        """``dF/dy`` (rows: -df/dy for differential, dg/dy for slave variables)."""
        out = np.empty((self.n, self.n))
        self.jacobian(t, y, 0.0, out)
        return out

    def projection(self, t: float, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Derivatives of the projection onto the mode's constraint manifold.

        The projection keeps the differential variables and replaces the slave variables ``z`` by
        the solution of ``g(t, y_d, z) = 0``.

        Returns
        -------
        P_y : ndarray, shape (n, n)
            ``d(Pi)/dy``: identity on differential rows, ``-g_z^-1 g_d`` on slave rows.
        P_t : ndarray, shape (n,)
            ``d(Pi)/dt``: ``-g_z^-1 g_t`` on slave rows.
        """
        n = self.n
        P_y = np.eye(n)
        P_t = np.zeros(n)
        a, d = self.alg_idx, self.diff_idx
        if a.size:
            J = self.dFdy(t, y)
            Gz = J[np.ix_(a, a)]
            P_y[a, :] = 0.0
            P_y[np.ix_(a, d)] = -np.linalg.solve(Gz, J[np.ix_(a, d)])
            v = [t, *np.asarray(y, dtype=float).tolist()]
            gt = np.array([fn(v) for _, fn in self.g_t])
            P_t[a] = -np.linalg.solve(Gz, gt)
        return P_y, P_t

    # ------------------------------------------------------------------
    def rhs(self, t: float, y: np.ndarray) -> np.ndarray:
        """Derivatives of the differential variables (zeros at slave positions)."""
        y = np.asarray(y, dtype=float)
        out = np.zeros(self.n)
        F = self.residual_function([t, *y.tolist(), *([0.0] * self.n)])
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
        if self.guards_function is None:
            return np.zeros(0)
        return np.array(self.guards_function([t, *np.asarray(y, dtype=float).tolist()]))

    def guard_slot(self, name: str) -> int | None:
        """The index of the guard of the transition called ``name`` (None: the mode has none)."""
        for g in self.guards:
            if g.name == name:
                return g.index
        return None

    def guard_gradient(self, k: int, t: float, y: np.ndarray) -> tuple[np.ndarray, float]:
        """``(dh/dy, dh/dt)`` of guard ``k`` at ``(t, y)``."""
        v = [t, *np.asarray(y, dtype=float).tolist()]
        g = self.guards[k]
        grad = np.zeros(self.n)
        for j, d in g.grad:
            grad[j] = d(v)
        return grad, g.grad_t(v)

    # ------------------------------------------------------------------
    def taylor_cone(self, expr, order: int) -> frozenset[int]:
        """The variables whose series the series of ``expr`` to ``order`` depends on: those of
        ``expr``, then those of the derivatives of the differential ones among them, ``order`` times
        (a slave variable brings the variables of its algebraic equation at once: its order-k
        coefficient follows theirs). See :meth:`taylor` (``rows``). Kept per expression and order."""
        kept = self._cones
        if kept is None:
            kept = self._cones = LRUCache(CONES_KEPT)
        hit = kept.get((expr, order))
        if hit is not None:
            return hit
        index = {nm: i for i, nm in enumerate(self.names[: self.n])}
        f, g = self.f_expr, self.g_expr

        def deps(e) -> set[int]:
            return {index[s] for s in e.free if s in index}

        def with_slaves(new: set[int], seen: set[int]) -> set[int]:
            stack = [i for i in new if i in g]
            while stack:
                for j in deps(g[stack.pop()]) - seen - new:
                    new.add(j)
                    if j in g:
                        stack.append(j)
            return new

        level = with_slaves(deps(expr), set())
        cone = set(level)
        for _ in range(order):
            nxt: set[int] = set()
            for i in level:
                if i in f:
                    nxt |= deps(f[i])
            level = with_slaves(nxt - cone, cone)
            if not level:
                break
            cone |= level
        cone = frozenset(cone)
        kept.put((expr, order), cone)
        return cone

    def taylor(
        self,
        t: float,
        y: np.ndarray,
        order: int,
        rows: frozenset[int] | set[int] | None = None,
        dFdy: np.ndarray | None = None,
    ) -> np.ndarray:
        """Taylor coefficients of this mode's flow through ``(t, y)``.

        Differential variables: ``x_{k+1} = f(x)_k / (k+1)``; slave variables:
        the order-``k`` coefficient of ``g(x, z) = 0`` is linear in ``z_k``.

        ``rows`` (e.g. :meth:`taylor_cone` of a guard): only these variables' series are computed;
        the others keep their value and no higher coefficient. A variable reached after ``d``
        derivatives in the cone then has its first ``order - d`` coefficients right, so the series
        of the expression the cone was made for is the full one to ``order`` (issue 34: a guard of
        one block of a chain of 256 needs the blocks within ``order`` springs of it, not all).
        ``dFdy``: :meth:`dFdy` at ``(t, y)`` if at hand (shared by the cones of one point).

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
        if rows is not None:
            a = np.array([i for i in a.tolist() if i in rows], dtype=int)
        Jzz = None
        if a.size:
            Jzz = (self.dFdy(t, y) if dFdy is None else dFdy)[np.ix_(a, a)]
        f_rows = list(self.f_expr) if rows is None else [i for i in self.f_expr if i in rows]
        f_roots = tuple(self.f_expr[i] for i in f_rows)
        g_roots = tuple(self.g_expr[i] for i in a)
        only = None if rows is None else frozenset().union(*(e.free for e in (*f_roots, *g_roots)))
        env = self._env(tj, X, only)  # views of the rows of X: they see the coefficients set below
        for k in range(order):
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
        expr = self.guards[k].expr
        return taylor_eval(expr, self._env(tj, X, expr.free))
