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

import numpy as np

from ..core.cache import LRUCache
from ..core.errors import InputError
from .codegen import compile_many, runtime_namespace, set_runtime
from .composed import ComposedForm, ComposedMode
from .expr import Expr, diff, free_symbols, neg, num, sub, substitute, sym
from .guard import CompiledGuard
from .modebase import ModeMethods
from .system import HybridSystem

__all__ = ["CompiledSystem", "CompiledMode", "CompiledGuard", "CompiledPool", "lend"]

#: Prefix of the generated residual's slots for ``y'`` (not a valid model name: no clash).
_YP = " yp"


class CompiledMode(ModeMethods):
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
        self.halt = mode.halt
        self.index = index
        self.n = n = len(names)
        self.names = names
        slots = {"t": 0, **{nm: i + 1 for i, nm in enumerate(names)}}
        pconst = {k: num(v) for k, v in params.items() if k not in free and k not in runtime}
        self.state_slots = slots
        self._params = dict(params)
        self._runtime = tuple(runtime)
        self.parameter_namespace = ns = namespace if namespace is not None else runtime_namespace({})

        def comp(e: Expr):
            return compile_many([e], slots, namespace=ns, scalar=True)

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
        self.residual_function = compile_many(rows, res_slots, f"residual_{mode.name}", namespace=ns)
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
        self.jacobian_function = (
            compile_many([e for _, _, e in self.jac_terms], slots, f"jacobian_{mode.name}", namespace=ns)
            if self.jac_terms
            else None
        )
        self.jacobian_entries = (
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
            for j, nm in enumerate(names):
                d = diff(h, nm)
                if not (d.op == "num" and d.args[0] == 0.0):
                    grad.append((j, comp(d)))
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
        self.guard_directions = np.array([g.direction for g in guards], dtype=float)
        self.guards_function = (
            compile_many([g.expr for g in guards], slots, f"guards_{mode.name}", namespace=ns)
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
                namespace=ns,
                vector=True,
            )
            if system.outputs
            else None
        )


class CompiledSystem:
    """A system compiled for one parameter set, its modes by index.

    A system without components has its modes compiled at once (:class:`CompiledMode`, index =
    position in ``system.modes``). A system with components is compiled once for all its modes
    (:class:`hybrid.model.composed.ComposedForm`); a mode gets an index when first named
    (:meth:`intern`) and its :class:`hybrid.model.composed.ComposedMode` is made when first used
    (microseconds, no code generated), at most :data:`MODE_CACHE` of them kept at once.

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
        if system.composed:
            self.form = ComposedForm(system, self.params, self.free, self.runtime, self._ns)
            self.modes = _ModeTable(self)
            self._keys: list[tuple[int, ...]] = []
            self._ids: dict[tuple[int, ...], int] = {}
            self.mode_index = _NameIndex(self)
        else:
            self.form = None
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

    def intern(self, key: tuple[int, ...]) -> int:
        """The index of the mode whose parts have the local mode indices ``key`` (see
        :meth:`hybrid.HybridSystem.mode_key`), given on first use."""
        if self.form is None:
            return int(key[0])
        k = self._ids.get(key)
        if k is None:
            k = self._ids[key] = len(self._keys)
            self._keys.append(key)
        return k

    def key(self, index: int) -> tuple[int, ...]:
        """The local mode indices of mode ``index``."""
        return (index,) if self.form is None else self._keys[index]

    def mode_name(self, index: int) -> str:
        """The name of mode ``index``."""
        return self.modes[index].name if self.form is None else self.system.mode_label(self._keys[index])

    def mode_names_of(self, indices: np.ndarray) -> np.ndarray:
        """The names of the modes ``indices`` (an integer array) as an object array."""
        indices = np.asarray(indices, dtype=int)
        if indices.size == 0:
            return np.array([], dtype=object)
        uniq, inv = np.unique(indices, return_inverse=True)
        names = np.array([self.mode_name(int(k)) for k in uniq], dtype=object)
        return names[inv].reshape(indices.shape)

    def set_runtime(self, params: Mapping[str, float]) -> None:
        """New parameter values that differ from the compiled ones only in ``runtime`` parameters."""
        new = self.system.parameter_values({**self.params, **params})
        changed = [k for k in new if new[k] != self.params[k] and k not in self.runtime]
        if changed:
            raise InputError(f"parameter `{changed[0]}` is compiled in as a constant: compile again")
        self.params = new
        set_runtime(self._ns, {p: new[p] for p in self.runtime})
        if self.form is None:
            for m in self.modes:
                m._params = new
        else:
            self.form.generation += 1  # factorisations made with the old values are stale
        self.period = self.system.period_value(new)
        self.derived.clear()

    def depends_on_time(self) -> bool:
        """True if an equation or guard of any mode depends explicitly on ``t``."""
        if self.form is not None:
            rows = [e for alts in self.form.alt for _, e in alts] + self.form.slot_exprs
            return any("t" in free_symbols(e) for e in rows)
        for cm in self.modes:
            exprs = list(cm.f_expr.values()) + list(cm.g_expr.values()) + [g.expr for g in cm.guards]
            if any("t" in free_symbols(e) for e in exprs):
                return True
        return False

    def mode_id(self, name: str) -> int:
        """The index of the mode called ``name`` (InputError naming what is wrong if none)."""
        if self.form is not None:
            return self.intern(self.system.mode_key(name))
        if name not in self.mode_index:
            raise InputError(
                f"model `{self.system.name}` has no mode `{name}`; modes: {', '.join(self.mode_index)}"
            )
        return self.mode_index[name]


#: Modes of a system with components kept built at once per compiled system (rebuilt on demand).
MODE_CACHE = 4096


class _ModeTable:
    """``cs.modes`` of a system with components: its modes by index, each made when first used."""

    def __init__(self, cs: CompiledSystem):
        self._cs = cs
        self._built = LRUCache(MODE_CACHE)

    def __getitem__(self, index: int) -> ComposedMode:
        m = self._built.get(index)
        if m is None:
            cs = self._cs
            m = ComposedMode(cs, cs.form, cs._keys[index], index)
            self._built.put(index, m)
        return m

    def __len__(self) -> int:
        return len(self._cs._keys)

    def __iter__(self):
        return (self[k] for k in range(len(self)))


class _NameIndex:
    """``cs.mode_index`` of a system with components: a mode's index by name (interned on use)."""

    def __init__(self, cs: CompiledSystem):
        self._cs = cs

    def __getitem__(self, name: str) -> int:
        return self._cs.mode_id(name)

    def __contains__(self, name: str) -> bool:
        try:
            self._cs.system.mode_key(name)
        except InputError:
            return False
        return True


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
