"""A system with components, compiled once for all its modes: :class:`ComposedForm`, :class:`ComposedMode`.

A system with components has as many modes as combinations of its components' local modes
(``3**k`` for ``k`` contacts), so its modes are never enumerated, and entering a mode never seen
before generates no code. Every row of the DAE is written once for all modes as a sum over the
alternatives of its owner (the system's own mode for the variables no component owns, the
component's local mode for its own variables), each weighted by an *indicator* that is 1 for the
owner's current mode and 0 otherwise::

    F_i = sum_l  [part in mode l] * R_{l,i},    R_{l,i} = y'_i - f_{l,i}   (differential in l)
                                                R_{l,i} = g_{l,i}          (algebraic in l)

and so is every guard slot (a component's ``s``-th transition out of its current local mode, or
the constant 1 where that mode has fewer). The residual, the non-zero entries of ``dF/dy``, the
time derivatives of the rows, all guard slots and their gradients are each one generated
function of ``[t, y (, y'), indicators]``, compiled when the system is; a mode is the list of its
indicators (:class:`ComposedMode`, a view with the interface of
:class:`hybrid.model.compiled.CompiledMode`), made in microseconds per mode.

Terms of the alternatives that are not selected are evaluated too (and multiplied by 0): an
alternative must be finite wherever the system's state may be.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ..core.budget import check_deadline
from ..core.errors import AlgebraicSolveError, InputTypeError
from .codegen import compile_many
from .expr import ZERO, Expr, add, diff, free_symbols, mul, num, sub, substitute, sym
from .gradient import gradient
from .guard import CompiledGuard
from .modebase import ModeMethods

__all__ = ["ComposedForm", "ComposedMode", "Slot"]

#: Systems with at least this many variables whose iteration matrix is banded (bandwidth at most a
#: quarter of the size) get IDA's banded linear solver.
BAND_MIN = 64

#: Prefixes of the generated functions' slots (not valid model names: no clash).
_YP = " yp"
_IND = " ind"


@dataclass(frozen=True)
class Slot:
    """One transition as it sits in a guard slot: its part, source local mode, and data.

    Attributes
    ----------
    part : int
        0 for the system's own modes, ``1 + c`` for component ``c``.
    local : int
        Index of the source mode among the part's modes.
    slot : int
        Position among all guard slots.
    transition : int
        Position of the transition in ``system.transitions`` (own) or ``component.transitions``.
    name : str
        Its name in event logs (``component.transition`` for a component's).
    target_local : int
        Index of the target mode among the part's modes.
    direction : int
    expr : Expr
        The guard, parameters folded.
    reset_expr : tuple of (int, Expr)
        The reset, by state index.
    """

    part: int
    local: int
    slot: int
    transition: int
    name: str
    target_local: int
    direction: int
    expr: Expr
    reset_expr: tuple


class ComposedForm:
    """Every mode of a system with components, compiled once for one parameter set.

    Parameters
    ----------
    system : HybridSystem
    params : mapping of str to float
        Checked parameter values.
    free : tuple of str
        Parameters appended to the state (zero derivative), as for
        :class:`hybrid.model.compiled.CompiledMode`.
    runtime : tuple of str
        Parameters read at call time from ``namespace``.
    namespace : dict
        The compiled system's run-time namespace.
    """

    def __init__(self, system, params, free: tuple[str, ...], runtime: tuple[str, ...], namespace: dict):
        self.system = system
        self._ns = namespace
        self._runtime = tuple(runtime)
        names = tuple(system.variable_names) + tuple(free)
        self.names = names
        self.n = n = len(names)
        index = {nm: i for i, nm in enumerate(names)}
        pconst = {k: num(v) for k, v in params.items() if k not in free and k not in runtime}

        def fold(e: Expr) -> Expr:
            return substitute(e, pconst)

        parsed = system.parsed
        # The parts: the own modes (part 0), then each component; per part its modes' row data.
        own = [parsed.modes[m.name] for m in system.modes]
        comps = list(parsed.components)
        self.part_modes: list[list[dict]] = [own] + [
            [cd["modes"][m.name] for m in c.modes] for c, cd in zip(system.components, comps, strict=True)
        ]
        self.part_names = [tuple(m.name for m in system.modes)] + [c.mode_names for c in system.components]
        # Indicator slots: one per (part, local mode) where a part has more than one mode.
        self.ind_pos: list[list[int | None]] = []
        count = 0
        for modes in self.part_modes:
            if len(modes) > 1:
                self.ind_pos.append(list(range(count, count + len(modes))))
                count += len(modes)
            else:
                self.ind_pos.append([None])
        self.n_ind = count
        ind_syms = [f"{_IND}{k}" for k in range(count)]

        def weight(part: int, local: int, e: Expr) -> Expr:
            pos = self.ind_pos[part][local]
            return e if pos is None else mul(sym(ind_syms[pos]), e)

        # Owner of each row, and its role in each of the owner's modes.
        owner = np.zeros(n, dtype=int)  # part
        for c, cd in enumerate(comps):
            for v in cd["owned"]:
                owner[index[v]] = 1 + c
        self.owner = owner
        nfree = len(free)
        # role[i][local] = True (differential) / False (algebraic)
        self.alt: list[list[tuple[bool, Expr]]] = [[] for _ in range(n)]
        for i, nm in enumerate(names):
            if i >= n - nfree:  # a free parameter: y' = 0 in every mode
                self.alt[i] = [(True, ZERO)] * len(self.part_modes[0])
                continue
            for md in self.part_modes[owner[i]]:
                if nm in md["derivatives"]:
                    self.alt[i].append((True, fold(md["derivatives"][nm])))
                else:
                    self.alt[i].append((False, fold(md["algebraic"][nm])))
        # Rows of the residual, one expression each for every mode.
        res_slots = {"t": 0, **{nm: i + 1 for i, nm in enumerate(names)}}
        res_slots.update({f"{_YP}{i}": n + 1 + i for i in range(n)})
        res_slots.update({s: 2 * n + 1 + k for k, s in enumerate(ind_syms)})
        slots = {"t": 0, **{nm: i + 1 for i, nm in enumerate(names)}}
        #: Slots of functions of ``[t, y]`` alone (a mode's resets and their derivatives).
        self.state_slots = dict(slots)
        slots.update({s: n + 1 + k for k, s in enumerate(ind_syms)})
        self._slots = slots
        rows: list[Expr] = []
        grows: list[Expr] = []  # the same without y' (dF/dy, dF/dt)
        for i in range(n):
            if i and not i & 255:
                check_deadline("assembling the model's residual")
            part = 0 if i >= n - nfree else owner[i]
            terms, gterms = [], []
            for local, (is_d, e) in enumerate(self.alt[i]):
                r = sub(sym(f"{_YP}{i}"), e) if is_d else e
                g = mul(num(-1.0), e) if is_d else e
                terms.append(weight(part, local, r))
                gterms.append(weight(part, local, g))
            rows.append(_sum(terms))
            grows.append(_sum(gterms))
        self.res = compile_many(rows, res_slots, "residual", namespace=namespace)
        # dF/dy: every entry that may be non-zero in some mode, as one function.
        terms: list[tuple[int, int, Expr]] = []
        for i, e in enumerate(grows):
            if i and not i & 63:
                check_deadline("differentiating the model's residual")
            grad = gradient(e, index)  # one sweep per row, not one per symbol (issue 32)
            for nm in sorted(grad, key=index.__getitem__):
                d = grad[nm]
                if not (d.op == "num" and d.args[0] == 0.0):
                    terms.append((i, index[nm], d))
        self.jac_terms = terms
        self.jac = (
            compile_many([d for _, _, d in terms], slots, "jacobian", namespace=namespace) if terms else None
        )
        self.jac_at = (
            np.array([i for i, _, _ in terms], dtype=int),
            np.array([j for _, j, _ in terms], dtype=int),
        )
        self.rows_t = compile_many([diff(e, "t") for e in grows], slots, "rows_t", namespace=namespace)
        # The bandwidth of dF/dy + cj dF/dy' in every mode; IDA's banded solver where it is narrow.
        ii, jj = self.jac_at
        lower = int(max(0, np.max(ii - jj))) if ii.size else 0
        upper = int(max(0, np.max(jj - ii))) if ii.size else 0
        self.band = (lower, upper) if n >= BAND_MIN and lower + upper + 1 <= n // 4 else None
        # Guard slots: the own modes' transitions first, then each component's.
        transitions = [list(enumerate(zip(system.transitions, parsed.transitions, strict=True)))] + [
            list(enumerate(zip(c.transitions, cd["transitions"], strict=True)))
            for c, cd in zip(system.components, comps, strict=True)
        ]
        self.slot_of: list[list[list[Slot]]] = []  # [part][local] -> its slots
        self.part_slots: list[range] = []
        nslot = 0
        for part, modes in enumerate(self.part_modes):
            names_p = self.part_names[part]
            out: list[list[Slot]] = [[] for _ in modes]
            for k, (tr, td) in transitions[part]:
                src, tgt = names_p.index(tr.source), names_p.index(tr.target)
                label = tr.name if part == 0 else f"{system.components[part - 1].name}.{tr.name}"
                reset = tuple((index[v], fold(e)) for v, e in td["reset"].items())
                out[src].append(Slot(part, src, -1, k, label, tgt, tr.direction, fold(td["guard"]), reset))
            width = max((len(s) for s in out), default=0)
            self.part_slots.append(range(nslot, nslot + width))
            self.slot_of.append([[replace(s, slot=nslot + j) for j, s in enumerate(lst)] for lst in out])
            nslot += width
        self.n_slots = nslot
        # per part and local mode: the directions of its slots (0 where unused) and slots by name
        self.slot_dirs = [
            [
                np.array(
                    [lst[j].direction if j < len(lst) else 0 for j in range(len(self.part_slots[part]))],
                    dtype=float,
                )
                for lst in self.slot_of[part]
            ]
            for part in range(len(self.part_modes))
        ]
        self.slot_named = [
            [{sl.name: sl.slot for sl in lst} for lst in self.slot_of[part]]
            for part in range(len(self.part_modes))
        ]
        self.part_named = {
            sl.name: part for part in range(len(self.part_modes)) for lst in self.slot_of[part] for sl in lst
        }
        self.slot_part = (
            np.concatenate(
                [np.full(len(self.part_slots[part]), part, dtype=int) for part in range(len(self.part_modes))]
            )
            if nslot
            else np.zeros(0, dtype=int)
        )
        slot_exprs: list[Expr] = []
        for part, modes in enumerate(self.part_modes):
            for j in range(len(self.part_slots[part])):
                terms = []
                for local in range(len(modes)):
                    lst = self.slot_of[part][local]
                    e = lst[j].expr if j < len(lst) else num(1.0)  # no such transition: never crosses
                    terms.append(weight(part, local, e))
                slot_exprs.append(_sum(terms))
        self.slot_exprs = slot_exprs
        self.guards_fn = (
            compile_many(slot_exprs, slots, "guards", namespace=namespace) if slot_exprs else None
        )
        gterms: list[tuple[int, int, Expr]] = []
        for s, e in enumerate(slot_exprs):
            grad = gradient(e, index)
            for nm in sorted(grad, key=index.__getitem__):
                d = grad[nm]
                if not (d.op == "num" and d.args[0] == 0.0):
                    gterms.append((s, index[nm], d))
        self.guard_grad = (
            compile_many([d for _, _, d in gterms], slots, "guard_gradients", namespace=namespace)
            if gterms
            else None
        )
        self.guard_grad_at = (
            np.array([s for s, _, _ in gterms], dtype=int),
            np.array([j for _, j, _ in gterms], dtype=int),
        )
        # dh/dt of the slots whose expression reads the time explicitly (for the rounding of t)
        tterms = [(s, diff(e, "t")) for s, e in enumerate(slot_exprs) if "t" in free_symbols(e)]
        tterms = [(s, d) for s, d in tterms if not (d.op == "num" and d.args[0] == 0.0)]
        self.guard_grad_t = (
            compile_many([d for _, d in tterms], slots, "guard_time_rates", namespace=namespace)
            if tterms
            else None
        )
        self.guard_grad_t_at = np.array([s for s, _ in tterms], dtype=int)
        # Outputs: definitions of the own modes.
        self.outputs = []
        self.outputs_vec = []
        for md in own:
            exprs = [fold(md["defs"][o]) for o in system.outputs]
            plain = {"t": 0, **{nm: i + 1 for i, nm in enumerate(names)}}
            self.outputs.append(
                {
                    o: compile_many([e], plain, namespace=namespace, scalar=True)
                    for o, e in zip(system.outputs, exprs, strict=True)
                }
            )
            self.outputs_vec.append(
                compile_many(exprs, plain, "outputs", namespace=namespace, vector=True) if exprs else None
            )
        self._guards: dict[tuple[int, int, int], object] = {}  # compiled guards by (part, local, j)
        self.never = [_never(s) for s in range(nslot)]  # the guard of a slot a mode leaves unused
        self.zeros = np.zeros((n, n))
        self.zeros.flags.writeable = False
        # Is the block of dF/dy in the slave variables independent of the state (linear slave
        # equations, as a friction contact's)? Then each mode inverts it once.
        # Only the entries between rows that are slave in some mode matter (the block is theirs).
        # Parameters read at run time change only through set_runtime, which bumps `generation`:
        # a mode's factorisation is kept for one generation.
        state = set(names) | {"t"}
        self.generation = 0
        may_be_slave = {i for i in range(n) if not all(is_d for is_d, _ in self.alt[i])}
        self.constant_slave_block = not any(
            free_symbols(d) & state for i, j, d in self.jac_terms if i in may_be_slave and j in may_be_slave
        )
        self.halts = [[md.get("halt", "") for md in modes] for modes in self.part_modes]
        own_halts = [m.halt for m in system.modes]
        self.halts[0] = own_halts

    def indicators(self, key: tuple[int, ...]) -> list[float]:
        """The indicator values of the mode ``key`` (one local mode index per part)."""
        out = [0.0] * self.n_ind
        for part, local in enumerate(key):
            pos = self.ind_pos[part][local]
            if pos is not None:
                out[pos] = 1.0
        return out


def _sum(terms: list[Expr]) -> Expr:
    out = terms[0]
    for e in terms[1:]:
        out = add(out, e)
    return out


class ComposedMode(ModeMethods):
    """One mode of a system with components: its indicators and the shared generated functions,
    behind the interface of :class:`hybrid.model.compiled.CompiledMode` (built without compiling:
    microseconds; what only some callers read, e.g. the rows as expressions, is made on first
    use). The slave variables are solved with a sparse LU factorisation of their block of
    ``dF/dy`` (made once per mode where that block does not depend on the state)."""

    def __init__(self, cs, form: ComposedForm, key: tuple[int, ...], index: int):
        self.form = form
        self.key = key
        self.index = index
        self.name = cs.system.mode_label(key)
        self.names = form.names
        self.n = n = form.n
        ind = form.indicators(key)
        self._ind = ind
        self._runtime = form._runtime
        self.parameter_namespace = form._ns
        self.state_slots = form.state_slots  # as CompiledMode's: [t, y] (e.g. for the resets' Jacobians)
        self._params = cs.params
        owner = form.owner
        nfree = len(cs.free)
        is_diff = np.zeros(n, dtype=bool)
        for i in range(n):
            local = 0 if i >= n - nfree else key[owner[i]]
            is_diff[i] = form.alt[i][local][0]
        self.is_diff = is_diff
        self.diff_idx = np.flatnonzero(is_diff)
        self.alg_idx = np.flatnonzero(~is_diff)
        self._f_pos = self.diff_idx
        self._nfree = nfree
        res, jac, guards = form.res, form.jac, form.guards_fn
        self.residual_function = lambda v: res([*v, *ind])
        self.jacobian_function = (lambda v: jac([*v, *ind])) if jac is not None else None
        self.guards_function = (lambda v: guards([*v, *ind])) if guards is not None else None
        self.jacobian_entries = form.jac_at
        self.jac_terms = form.jac_terms
        self.jac_base = form.zeros  # every entry is in jac_terms (weighted by the indicators)
        self._ix_ad = np.ix_(self.alg_idx, self.diff_idx)
        self._ix_aa = np.ix_(self.alg_idx, self.alg_idx)
        rows_t = form.rows_t
        self._rows_t = lambda v: rows_t([*v, *ind])
        # Guards: one per slot, the part's transition where its mode has one, else never firing
        # (made when first read: a mode entered once reads few of them).
        self.guards = _Guards(cs, form, key)
        self.guard_directions = (
            np.concatenate([form.slot_dirs[part][local] for part, local in enumerate(key)])
            if form.n_slots
            else np.zeros(0)
        )
        self.outputs = form.outputs[key[0]]
        self._outputs_vec = form.outputs_vec[key[0]]
        halts = [form.halts[part][local] for part, local in enumerate(key)]
        self.halt = "; ".join(h for h in halts if h)
        self._lu = None  # the slave block's LU factorisation, where it is constant
        self._lu_generation = -1
        self._exprs: tuple[dict, dict] | None = None  # (f_expr, g_expr), made by _rows on first use
        self._slave_pattern: tuple | None = None  # made by _pattern on first use

    def guard_slot(self, name: str) -> int | None:
        """The index of the guard of the transition called ``name`` (None: the mode has none)."""
        return self.guards.slot(name)

    # -- made on first use --------------------------------------------------------------------
    def _rows(self) -> tuple[dict, dict]:
        if self._exprs is None:
            f_expr, g_expr = {}, {}
            for i in range(self.n):
                local = 0 if i >= self.n - self._nfree else self.key[self.form.owner[i]]
                d, e = self.form.alt[i][local]
                (f_expr if d else g_expr)[i] = e
            self._exprs = (f_expr, g_expr)
        return self._exprs

    @property
    def f_expr(self) -> dict:
        """``{row: derivative}`` of the differential rows (expressions, parameters folded)."""
        return self._rows()[0]

    @property
    def g_expr(self) -> dict:
        """``{row: residual}`` of the algebraic rows."""
        return self._rows()[1]

    @property
    def g_t(self) -> list:
        """``(row, v -> dg/dt)`` of the algebraic rows (as :class:`CompiledMode`'s)."""
        rows_t = self._rows_t
        return [(int(i), (lambda v, i=int(i): rows_t(v)[i])) for i in self.alg_idx]

    @property
    def cj_mask(self) -> np.ndarray:
        return np.diag(self.is_diff.astype(float))

    @property
    def _gzz_inv(self) -> None:
        return None  # the slave block is solved by sparse LU (see solve_algebraic)

    # -- the slave block of dF/dy -----------------------------------------------------------------
    def sparse_dFdy(self, t: float, y: np.ndarray) -> sp.csr_array:
        """``dF/dy`` as a sparse matrix (rows: -df/dy differential, dg/dy slave)."""
        i, j = self.jacobian_entries
        if self.jacobian_function is None:
            return sp.csr_array((self.n, self.n))
        return sp.csr_array((self._jac_vals(t, y), (i, j)), shape=(self.n, self.n))

    def _jac_vals(self, t: float, y: np.ndarray) -> np.ndarray:
        return np.asarray(self.jacobian_function([t, *np.asarray(y, dtype=float).tolist()]), dtype=float)

    def _pattern(self) -> tuple:
        """Where the entries of ``dF/dy`` fall in the slave rows: ``(entries, rows, columns)`` of
        the block in the differential variables, then of the block in the slave variables (rows
        and columns numbered within the blocks)."""
        if self._slave_pattern is None:
            i, j = self.jacobian_entries
            pa = np.full(self.n, -1)
            pa[self.alg_idx] = np.arange(self.alg_idx.size)
            pd = np.full(self.n, -1)
            pd[self.diff_idx] = np.arange(self.diff_idx.size)
            ad = np.flatnonzero((pa[i] >= 0) & (pd[j] >= 0))
            aa = np.flatnonzero((pa[i] >= 0) & (pa[j] >= 0))
            self._slave_pattern = (ad, pa[i[ad]], pd[j[ad]], aa, pa[i[aa]], pa[j[aa]])
        return self._slave_pattern

    def _slave_d(self, vals: np.ndarray):
        """``dg/dy_d``, the slave rows' block in the differential variables (dense when small)."""
        ad, r, c = self._pattern()[:3]
        shape = (self.alg_idx.size, self.diff_idx.size)
        if self.alg_idx.size <= DENSE_SLAVES:
            out = np.zeros(shape)
            np.add.at(out, (r, c), vals[ad])
            return out
        return sp.csr_array((vals[ad], (r, c)), shape=shape)

    def _slave_lu(self, t: float, y: np.ndarray, vals: np.ndarray | None = None):
        """A factorisation of the slave block of ``dF/dy`` at ``(t, y)`` (kept where it is
        constant): LU of a dense block up to :data:`DENSE_SLAVES` slave variables, sparse LU above."""
        if self._lu is not None and self._lu_generation == self.form.generation:
            return self._lu
        if vals is None:
            vals = self._jac_vals(t, y)
        aa, r, c = self._pattern()[3:]
        na = self.alg_idx.size
        if na <= DENSE_SLAVES:
            G = np.zeros((na, na))
            np.add.at(G, (r, c), vals[aa])
            lu = _DenseLU(G)
            ok = lu.regular
        else:
            try:
                lu = spla.splu(sp.csc_array((vals[aa], (r, c)), shape=(na, na)))
                ok = True
            except RuntimeError:
                ok = False
        if not ok:
            raise AlgebraicSolveError(
                f"mode `{self.name}`: the algebraic equations are singular in the slave variables at t={t!r}"
            )
        if self.form.constant_slave_block:
            self._lu, self._lu_generation = lu, self.form.generation
        return lu

    def projection(self, t: float, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Derivatives of the projection onto the mode's constraint manifold (see
        :meth:`ModeMethods.projection`), from the slave blocks."""
        n = self.n
        P_y = np.eye(n)
        P_t = np.zeros(n)
        a, d = self.alg_idx, self.diff_idx
        if a.size:
            vals = self._jac_vals(t, y)
            lu = self._slave_lu(t, y, vals)
            Gd = self._slave_d(vals)
            P_y[a, :] = 0.0
            P_y[np.ix_(a, d)] = -lu.solve(Gd if isinstance(Gd, np.ndarray) else Gd.toarray())
            gt = np.asarray(self._rows_t([t, *np.asarray(y, dtype=float).tolist()]), dtype=float)[a]
            P_t[a] = -lu.solve(gt)
        return P_y, P_t

    def solve_algebraic(
        self, t: float, y: np.ndarray, *, tol: float = 1e-14, maxiter: int = 50
    ) -> np.ndarray:
        """Return ``y`` with the slave variables solved by Newton's method (sparse LU)."""
        y = np.array(y, dtype=float)
        a = self.alg_idx
        if a.size == 0:
            return y
        zero = [0.0] * self.n
        res = None
        for _ in range(maxiter):
            res = np.asarray(self.residual_function([t, *y.tolist(), *zero]), dtype=float)
            step = self._slave_lu(t, y).solve(res[a])
            y[a] -= step
            if not np.all(np.isfinite(step)):
                break
            if np.all(np.abs(step) <= tol * (1.0 + np.abs(y[a]))):
                res = np.asarray(self.residual_function([t, *y.tolist(), *zero]), dtype=float)
                if np.all(np.isfinite(res[a])):
                    return y
        worst = np.max(np.abs(res[a])) if res is not None else float("nan")
        raise AlgebraicSolveError(
            f"mode `{self.name}`: Newton's method did not solve the algebraic equations at t={t!r} "
            f"(residual {worst:.3g})"
        )

    def derivatives(self, t: float, y: np.ndarray) -> np.ndarray:
        """Consistent ``y'``: differential rows from the vector field, slave rows from the
        differentiated constraint ``g_z z' = -(g_x x' + g_t)`` (sparse)."""
        yp = self.rhs(t, y)
        a, d = self.alg_idx, self.diff_idx
        if a.size:
            vals = self._jac_vals(t, y)
            v = [t, *np.asarray(y, dtype=float).tolist()]
            gt = np.asarray(self._rows_t(v), dtype=float)[a]
            rhs = -(self._slave_d(vals) @ yp[d] + gt)
            yp[a] = self._slave_lu(t, y, vals).solve(rhs)
        return yp

    def guard_noise_scale(
        self, t: float, y: np.ndarray, scale: np.ndarray, scale_t: float = 0.0
    ) -> np.ndarray:
        """``sum_j |dh_s/dy_j| scale_j + |dh_s/dt| scale_t`` for every guard slot ``s`` (one call
        for all; ``scale_t`` [s]: the uncertainty of the time, none by default)."""
        out = np.zeros(self.form.n_slots)
        fn = self.form.guard_grad
        v = [t, *np.asarray(y, dtype=float).tolist(), *self._ind]
        if fn is not None:
            vals = np.abs(np.asarray(fn(v), dtype=float))
            s, j = self.form.guard_grad_at
            np.add.at(out, s, vals * scale[j])
        ft = self.form.guard_grad_t
        if ft is not None and scale_t:
            np.add.at(out, self.form.guard_grad_t_at, np.abs(np.asarray(ft(v), dtype=float)) * scale_t)
        return out


class _Guards(Sequence):
    """The guards of a composed mode by slot, each made on first use (its target mode interned
    then)."""

    __slots__ = ("_cs", "_form", "_key", "_made")

    def __init__(self, cs, form: ComposedForm, key: tuple[int, ...]):
        self._cs, self._form, self._key = cs, form, key
        self._made: dict[int, CompiledGuard] = {}

    def __len__(self) -> int:
        return self._form.n_slots

    def __getitem__(self, slot: int) -> CompiledGuard:
        if not isinstance(slot, (int, np.integer)):
            raise InputTypeError("guards are read one slot at a time")
        slot = int(slot)
        if slot < 0:
            slot += self._form.n_slots
        g = self._made.get(slot)
        if g is None:
            g = self._made[slot] = self._make(slot)
        return g

    def __iter__(self):
        return (self[s] for s in range(len(self)))

    def _make(self, slot: int) -> CompiledGuard:
        form, key, cs = self._form, self._key, self._cs
        part = int(form.slot_part[slot])
        j = slot - form.part_slots[part].start
        lst = form.slot_of[part][key[part]]
        if j >= len(lst):
            return form.never[slot]
        g = _compiled_guard(cs, form, lst[j])
        tkey = key[:part] + (lst[j].target_local,) + key[part + 1 :]
        return replace(g, index=slot, target=cs.intern(tkey))

    def slot(self, name: str) -> int | None:
        """The slot of the transition called ``name`` in this mode (None: no such transition)."""
        part = self._form.part_named.get(name)
        if part is None:
            return None
        return self._form.slot_named[part][self._key[part]].get(name)


#: Up to this many slave variables, a mode's slave block is factorised as a dense matrix.
DENSE_SLAVES = 64


class _DenseLU:
    """A small dense matrix's inverse, with the ``solve`` of SuperLU's (a matrix product: the
    blocks are small and, for a contact's linear equations, inverted once per mode)."""

    def __init__(self, G: np.ndarray):
        try:
            self.inverse = np.linalg.inv(G)
            self.regular = bool(np.all(np.isfinite(self.inverse)))
        except np.linalg.LinAlgError:
            self.regular = False

    def solve(self, b: np.ndarray) -> np.ndarray:
        return self.inverse @ b


def _never(slot: int) -> CompiledGuard:
    """A guard that never fires (a slot the part's current mode does not use)."""
    return CompiledGuard(
        index=slot,
        transition=-1,
        name="",
        target=-1,
        direction=0,
        expr=num(1.0),
        fn=_one,
        grad=(),
        grad_t=_zero,
        reset=(),
        reset_expr=(),
    )


def _one(v) -> float:
    return 1.0


def _zero(v) -> float:
    return 0.0


def _compiled_guard(cs, form: ComposedForm, s: Slot) -> CompiledGuard:
    """The compiled guard of a slot's transition, made once per transition."""
    hit = form._guards.get((s.part, s.local, s.slot))
    if hit is not None:
        return hit
    slots = {"t": 0, **{nm: i + 1 for i, nm in enumerate(form.names)}}

    def comp(e: Expr):
        return compile_many([e], slots, namespace=form._ns, scalar=True)

    index = {nm: i for i, nm in enumerate(form.names)}
    grad = tuple(
        (index[nm], comp(diff(s.expr, nm)))
        for nm in sorted(free_symbols(s.expr) & index.keys(), key=index.__getitem__)
    )
    g = CompiledGuard(
        index=s.slot,
        transition=s.transition,
        name=s.name,
        target=-1,
        direction=s.direction,
        expr=s.expr,
        fn=comp(s.expr),
        grad=grad,
        grad_t=comp(diff(s.expr, "t")),
        reset=tuple((i, comp(e)) for i, e in s.reset_expr),
        reset_expr=s.reset_expr,
    )
    form._guards[(s.part, s.local, s.slot)] = g
    return g
