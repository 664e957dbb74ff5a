"""Affine modes as exact linear flows: the analysis the exact integrator runs on.

A mode is *affine* when its derivatives and algebraic equations are affine in
the state, with time entering only through ``sin`` and ``cos`` of integer multiples
``n w`` of one forcing frequency ``w`` (arguments ``k t + phi`` with ``|k| = n w``: a
forcing that is a sum of harmonics), and its guards are affine too. Then, with the slave
variables ``y_a`` eliminated from the algebraic equations (``y_a = -G_a^-1 (G_d y_d + g(t))``)
and the state augmented by ``S_n = sin(n w t)``, ``C_n = cos(n w t)`` for each multiple ``n``
that occurs, and ``1``, the flow is linear::

    z = [y_d, S_1, C_1, S_2, C_2, ..., 1],   z' = M z,   z(t + h) = expm(M h) z(t)

(one harmonic: ``z = [y_d, S, C, 1]``). The base frequency ``w`` is the lowest of the
system's forcing frequencies; each other must be an integer multiple of it.

(quadratures excluded from ``y_d``; a quadrature whose rate is a quadratic form of the state
integrates exactly too, see :mod:`hybrid.integrators.flow`).

The analysis is done once per system (:func:`system_analysis`) on its own
expressions, the parameters kept as symbols: every coefficient (of the state,
of ``S``, ``C`` and 1, the forcing rates and phases, guard rows, quadrature
forms) is an expression in the parameters, and all are compiled into one
function of the parameter vector, so the flows at a new parameter set
(:func:`affine_flows`) cost a fraction of a millisecond instead of a
compilation of the system. :func:`affine_mode` refuses a non-affine mode naming the first
non-affine term.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp

from ..core.budget import check_deadline
from ..core.cache import LRUCache
from ..core.errors import NotAffineError
from ..model.codegen import compile_many
from ..model.compiled import CompiledMode, CompiledSystem
from ..model.expr import ZERO, Expr, diff, postorder, replace_nodes, substitute, sym, to_string
from ..model.expr import add as e_add
from ..model.expr import call as e_call
from ..model.expr import mul as e_mul
from ..model.expr import num as e_num
from ..model.expr import sub as e_sub
from ..model.gradient import gradient
from .flow import Flow, _cond1, shared_flow

#: Step bounds whose guard Taylor rows an :class:`AffineMode` keeps (:meth:`AffineMode.guard_taylor_rows`).
GUARD_ROWS_KEPT = 8
#: Parameter vectors whose matrices an :class:`AffineAnalysis` keeps (:meth:`AffineAnalysis.evaluate`).
EVALUATED_KEPT = 16

#: Symbols of ``sin(w t)`` and ``cos(w t)`` in the augmented state (not valid model names).
_S, _C = "__sin_wt", "__cos_wt"

__all__ = [
    "AffineAnalysis",
    "AffineMode",
    "affine_coefficients",
    "affine_flows",
    "affine_mode",
    "affine_system",
    "system_analysis",
]


@dataclass
class AffineMode:
    """One mode as an exact linear flow of the augmented state ``z = [y_d, S, C, 1]``.

    Attributes
    ----------
    cm : CompiledMode or None
        The compiled mode (name and guards; None for a flow alone).
    omega : float or None
        Forcing frequency ``w`` [rad/s] (None: autonomous; then ``z = [y_d, 1]``).
    d, a, q : ndarray of int
        State indices of the differential (non-quadrature), slave and quadrature variables.
    M : ndarray, shape (nz, nz)
        Generator of the augmented flow.
    P : ndarray, shape (n, nz)
        The full state from the augmented one (quadrature rows zero).
    Q : ndarray, shape (len(q), nz, nz)
        Quadrature rates as quadratic forms ``z^T Q_j z``.
    W : ndarray, shape (n_guards, nz)
        Guards as linear functions ``W z``.
    harmonics : tuple of int
        The multiples ``n`` of ``omega`` in the forcing, one pair ``S_n, C_n`` each in ``z``
        after ``y_d``, in this order (``(1,)``: the one-frequency layout ``[y_d, S, C, 1]``).

    Notes
    -----
    What is made from the matrices on first use is kept in fields of its own (not arguments):
    the :class:`Flow`, ``P M`` and ``P M^2``, and the guards' Taylor rows of
    :meth:`guard_taylor_rows` (at most :data:`GUARD_ROWS_KEPT` step bounds).
    """

    cm: CompiledMode | None
    omega: float | None
    d: np.ndarray
    a: np.ndarray
    q: np.ndarray
    M: np.ndarray
    P: np.ndarray
    Q: np.ndarray
    W: np.ndarray
    harmonics: tuple = (1,)
    _flow: Flow | None = field(default=None, init=False, repr=False, compare=False)
    _PM: np.ndarray | None = field(default=None, init=False, repr=False, compare=False)
    _PMM: np.ndarray | None = field(default=None, init=False, repr=False, compare=False)
    _guard_rows: LRUCache = field(
        default_factory=lambda: LRUCache(GUARD_ROWS_KEPT), init=False, repr=False, compare=False
    )

    @property
    def nz(self) -> int:
        return self.M.shape[0]

    def flow(self) -> Flow:
        """The mode's :class:`Flow` (built on first use; shared by every mode with the same matrices,
        e.g. a run's and its monodromy's at one parameter value)."""
        if self._flow is None:
            self._flow = shared_flow(self.M, self.Q)
        return self._flow

    def guard_taylor_rows(self, max_step: float, degree: int) -> tuple[float, np.ndarray]:
        """Step length ``h`` and Taylor rows ``T[g, j] = W_g M^j / j!``, ``j <= degree``, of the guards
        (made once per ``(max_step, degree)``).

        ``h`` is ``max_step`` [s] halved until the guards' Taylor terms of degrees ``degree + 1`` to
        ``degree + 8`` are below ``1e-17`` of the first ones on a step of length ``h``.
        """
        return self._guard_rows.get_or_make((max_step, degree), lambda: self._taylor_rows(max_step, degree))

    def _taylor_rows(self, max_step: float, K: int) -> tuple[float, np.ndarray]:
        ng, nz = self.W.shape
        extra = 8
        T = np.zeros((ng, K + 1 + extra, nz))
        row = self.W.copy()
        for j in range(K + 1 + extra):
            T[:, j, :] = row
            row = row @ self.M / (j + 1)
        # Step length: the guards' Taylor tails beyond the degree are below rounding on a step.
        norms = np.max(np.abs(T).sum(axis=2), axis=0) if ng else np.zeros(K + 1 + extra)
        h = max_step
        while ng and h > 0:
            powers = h ** np.arange(K + 1 + extra)
            if np.sum(norms[K + 1 :] * powers[K + 1 :]) <= 1e-17 * np.sum(norms[: K + 1] * powers[: K + 1]):
                break
            h *= 0.5
        return h, np.ascontiguousarray(T[:, : K + 1, :])

    def augment(self, t: float, y: np.ndarray) -> np.ndarray:
        """``z`` at ``(t, y)`` (the slave variables of ``y`` are not read)."""
        return np.concatenate([np.asarray(y, dtype=float)[self.d], self.forcing(t), [1.0]])

    def forcing(self, t: float) -> list[float]:
        """The forcing part of ``z`` at ``t``: ``[sin(n w t), cos(n w t)]`` for each harmonic ``n``."""
        if self.omega is None:
            return []
        out = []
        for n in self.harmonics:
            wt = n * self.omega * t  # n = 1: exactly w t
            out += [math.sin(wt), math.cos(wt)]
        return out

    def forcing_columns(self, ts: np.ndarray) -> np.ndarray:
        """:meth:`forcing` at each time of ``ts`` (rows)."""
        ts = np.asarray(ts, dtype=float)
        if self.omega is None:
            return np.zeros((ts.size, 0))
        cols = []
        for n in self.harmonics:
            wt = n * self.omega * ts
            cols += [np.sin(wt), np.cos(wt)]
        return np.stack(cols, axis=1)

    def forcing_rate(self, t: float, dw: float) -> np.ndarray:
        """``d/dp`` of the forcing part of ``z`` at ``t`` for a base frequency changing at ``dw`` per
        unit of ``p``: ``[n t cos(n w t), -n t sin(n w t)] dw`` per harmonic."""
        out = []
        for n in self.harmonics:
            wt = n * self.omega * t
            out += [n * t * math.cos(wt) * dw, -n * t * math.sin(wt) * dw]
        return np.array(out)

    def state(self, z: np.ndarray, quad: np.ndarray) -> np.ndarray:
        """The full state from ``z`` and the quadrature values."""
        y = self.P @ z
        y[self.q] = quad
        return y

    def guard_series(self, k: int, t: float, y: np.ndarray, order: int) -> np.ndarray:
        """Taylor coefficients ``W_k M^j z / j!``, ``j <= order``, of guard ``k`` along the flow from ``(t, y)``."""
        z = self.augment(t, y)
        out = np.empty(order + 1)
        row = self.W[k]
        for j in range(order + 1):
            out[j] = row @ z
            row = (row @ self.M) / (j + 1)
        return out

    def derivatives(self, z: np.ndarray) -> np.ndarray:
        """Consistent ``y'`` at ``z`` (slave rows ``P_a M z``, quadrature rows ``z^T Q_j z``)."""
        if self._PM is None:
            self._PM = self.P @ self.M
        yp = self._PM @ z
        if self.q.size:
            yp[self.q] = np.einsum("j,qjk,k->q", z, self.Q, z)
        return yp

    def second_derivatives(self, z: np.ndarray) -> np.ndarray:
        """``y''`` at ``z``, exactly: ``P M^2 z``; quadrature rows ``z^T Q_j M z + (M z)^T Q_j z``."""
        if self._PMM is None:
            self._PMM = self.P @ self.M @ self.M
        ypp = self._PMM @ z
        if self.q.size:
            mz = self.M @ z
            ypp[self.q] = np.einsum("j,qjk,k->q", z, self.Q, mz) + np.einsum("j,qjk,k->q", mz, self.Q, z)
        return ypp


def _harmonic_symbols(g: int) -> tuple[str, str]:
    """The symbols of ``sin``/``cos`` of the ``g``-th distinct forcing rate (the first: ``S``, ``C``)."""
    return (_S, _C) if g == 0 else (f"{_S}{g}", f"{_C}{g}")


def _phase_nodes(
    exprs: list[Expr], where: str, params: frozenset, first: int, groups: list[Expr] | None = None
) -> tuple[list[Expr], dict[Expr, Expr]]:
    """Replacements of the ``sin``/``cos`` terms of the time by the symbols ``S``, ``C``.

    Returns the rates ``k`` of the arguments ``k t + phi`` (expressions in the parameters; the
    frequency is ``|k|``) and the replacements, which read the sign of the ``j``-th rate
    from the symbol ``__sg{first + j}``. Rates equal up to their sign (the same expression, or
    its negation) share one group and its symbols (:func:`_harmonic_symbols`); ``groups`` (the
    rate of each group, without sign) is extended with new ones. Without ``groups`` every rate
    is of group 0 (one forcing frequency).
    """
    rates: list[Expr] = []
    mapping: dict[Expr, Expr] = {}
    for node in postorder(exprs):
        if node.op != "call" or "t" not in node.free:
            continue
        fname, arg = node.args
        if fname not in ("sin", "cos") or arg.free - params != {"t"}:
            raise NotAffineError(
                f"{where}: time enters through `{to_string(node, 80)}`; the exact integrator allows time only "
                "in sin/cos of integer multiples of one forcing frequency times t (plus a phase)"
            )
        k = diff(arg, "t")
        if k.free - params or (k.op == "num" and k.args[0] == 0.0):
            raise NotAffineError(f"{where}: `{to_string(node, 80)}` is not sin/cos of (constant * t + phase)")
        phi = substitute(arg, {"t": e_num(0.0)})
        sg = sym(f"__sg{first + len(rates)}")
        rates.append(k)
        g = 0
        if groups is not None:
            key = k.args[0] if k.op == "neg" else k
            if key not in groups:
                groups.append(key)
            g = groups.index(key)
        s_name, c_name = _harmonic_symbols(g)
        s, c = sym(s_name), sym(c_name)
        cphi, sphi = e_call("cos", phi), e_call("sin", phi)
        # sin(sg w t + phi) = cos(phi) sg S + sin(phi) C;  cos(sg w t + phi) = cos(phi) C - sin(phi) sg S
        if fname == "sin":
            rep = e_add(e_mul(e_mul(sg, cphi), s), e_mul(sphi, c))
        else:
            rep = e_sub(e_mul(cphi, c), e_mul(e_mul(sg, sphi), s))
        mapping[node] = rep
    return rates, mapping


def _shown(text: str) -> str:
    return text.replace(_S, "sin(w t)").replace(_C, "cos(w t)")


#: Largest distance of a ratio of forcing frequencies from an integer that counts as that integer.
HARMONIC_TOL = 1e-12


def affine_terms(e: Expr, index: Mapping[str, int], params: frozenset, where: str) -> dict[int, Expr]:
    """The coefficients of an expression affine in the symbols of ``index`` that are not the
    constant zero, by column: ``d e/d u_j`` at ``index[u_j]``, ``e(u = 0)`` at ``len(index)``.

    Only the symbols ``e`` depends on are visited, so a row of a part of a large system costs the
    size of the row, not of the system (issue 32: set-up of 1000 contacts).
    """
    extra = {s for s in e.free if s not in index and s not in params}  # not `- index.keys()`: O(N)
    if extra:
        name = sorted(extra)[0]
        raise NotAffineError(f"{where} depends on `{name}` otherwise than affinely through sin/cos of t")
    out: dict[int, Expr] = {}
    grad = gradient(e, index)  # one sweep for all the row's symbols
    for s in sorted(grad, key=index.__getitem__):
        g = grad[s]
        if g.free & index.keys():
            shown = {_S: "sin(w t)", _C: "cos(w t)"}.get(s, s)
            raise NotAffineError(
                _shown(f"{where} is not affine in `{shown}`: its derivative is `{to_string(g, 120)}`")
            )
        out[index[s]] = g
    rest = substitute(e, {s: ZERO for s in e.free if s in index})
    if rest is not ZERO:
        out[len(index)] = rest
    return out


def affine_coefficients(e: Expr, symbols: list[str], params: frozenset, where: str) -> list[Expr]:
    """Coefficients ``[d e/d u_j ..., e(u = 0)]`` of an expression affine in ``symbols``."""
    terms = affine_terms(e, {s: j for j, s in enumerate(symbols)}, params, where)
    return [terms.get(j, ZERO) for j in range(len(symbols) + 1)]


def _quadratic(
    e: Expr, index: Mapping[str, int], params: frozenset, where: str
) -> dict[tuple[int, int], Expr]:
    """The entries of ``Q`` (expressions) that are not the constant zero, by ``(row, column)``, with
    ``e = u^T Q u``, ``u = [symbols, 1]`` (``index``: the column of each symbol), for a quadratic
    ``e``; only the symbols ``e`` depends on are visited (a sum of N energies costs N)."""
    n = len(index)
    Q: dict[tuple[int, int], Expr] = {}
    state = index.keys()
    half = e_num(0.5)
    present = sorted(e.free & state, key=index.__getitem__)
    zeros = {s: ZERO for s in present}

    def put(j: int, k: int, value: Expr) -> None:
        if value is not ZERO and not (value.op == "num" and value.args[0] == 0.0):
            Q[j, k] = Q[k, j] = value

    grad = gradient(e, index)
    for s in sorted(grad, key=index.__getitem__):
        j = index[s]
        g = grad[s]
        put(j, n, e_mul(half, substitute(g, zeros)))
        hess = gradient(g, index)
        for s2 in sorted(hess, key=index.__getitem__):
            k = index[s2]
            if k < j:
                continue
            h = hess[s2]
            if h.free & state:
                raise NotAffineError(f"{where} is not quadratic in the state: `{to_string(h, 120)}`")
            put(j, k, e_mul(half, h))
    extra = {s for s in e.free if s not in state and s not in params}
    if extra:
        raise NotAffineError(f"{where} depends on `{sorted(extra)[0]}` otherwise than through sin/cos of t")
    put(n, n, substitute(e, zeros))
    return Q


def _index_matrix(entries: list[dict], width: int) -> sp.csr_array:
    """Rows of positions (``{column: position}`` each) as a sparse matrix of shape
    ``(len(entries), width)``: a position left out is 0, the analysis' constant zero. Built from
    its row pointers (a sevenfold cheaper constructor than from triplets: one per part's mode)."""
    items = [sorted(r.items()) for r in entries]
    indptr = np.zeros(len(entries) + 1, dtype=np.int64)
    indptr[1:] = np.cumsum([len(r) for r in items])
    cols = np.array([c for r in items for c, _ in r], dtype=np.int64)
    data = np.array([k for r in items for _, k in r], dtype=np.int64)
    return sp.csr_array((data, cols, indptr), shape=(len(entries), width))


@dataclass
class ModeForm:
    """One mode's affine form: coefficient expressions, as positions in the analysis' value vector."""

    name: str
    names: tuple[str, ...]
    d: np.ndarray
    a: np.ndarray
    q: np.ndarray
    rates: list[int]  # positions of this mode's forcing rates among the analysis' rates
    groups: list[int]  # the groups of those rates (distinct up to sign), in the order of their S, C in u
    # Positions in the analysis' values as sparse integer matrices (an entry left out is position 0,
    # the constant zero): a part of a large system stores its own entries only (issue 32).
    F: sp.csr_array  # (nd, nu + 1) rows of the derivatives over [u, 1]
    G: sp.csr_array  # (na, nu + 1) rows of the algebraic equations
    Wu: sp.csr_array  # (ng, nu + 1) rows of the guards
    Qu: list  # nq sparse (nu + 1, nu + 1): quadratic forms of the quadrature rates


class AffineAnalysis:
    """The affine analysis of modes, done once, parametric in the parameters (see :func:`system_analysis`).

    Every coefficient (of the state, of ``S``, ``C`` and 1; the forcing rates
    and phases; guard rows; quadrature forms) is an expression in the
    parameters; all are compiled into one function of the parameter vector,
    so :meth:`evaluate` builds ``M``, ``P``, ``Q``, ``W`` of every mode in
    microseconds.

    Parameters
    ----------
    modes : list of (name, names, diff_idx, alg_idx, f_expr, g_expr, guard exprs)
        The modes' equations (``f_expr``/``g_expr`` by state index).
    quadratures : tuple of str
    params : tuple of str
        Parameters kept as symbols (an empty tuple for folded expressions).

    Raises
    ------
    NotAffineError
        Naming the mode, the equation and the first non-affine term.
    """

    def __init__(
        self, modes, quadratures: tuple[str, ...], params: tuple[str, ...], forcing: bool | None = None
    ):
        self.params = tuple(params)
        self._forcing = forcing  # None: per mode, as its equations say; True/False: every mode alike
        pset = frozenset(params)
        self._values: list[Expr] = [ZERO]  # position 0: zero
        self._where: dict[Expr, int] = {ZERO: 0}
        self._rates: list[Expr] = []
        self._rate_mode: list[str] = []
        self._groups: list[Expr] = []  # distinct forcing rates (up to sign): one S, C pair each in u
        self._rate_group: list[int] = []
        self.forms: list[ModeForm] = []
        # the last (names, groups) and their symbols and columns: the parts of a composed system share
        # them (one tuple of names for every form, not a copy each: O(N^2) memory at N parts)
        self._index: tuple = (None, (), [], {})
        modes = [(m[0], tuple(m[1]), *m[2:]) for m in modes]  # a tuple of names, shared as given
        if forcing:
            # every form has the same u: the S, C pairs of every group of rates of any mode
            for name, _names, diff_idx, alg_idx, f_expr, g_expr, guards in modes:
                exprs = [f_expr[i] for i in diff_idx] + [g_expr[i] for i in alg_idx] + [e for _, e in guards]
                _phase_nodes(exprs, f"mode `{name}`", pset, 0, self._groups)
        qnames, qcache = set(quadratures), (None, set())
        for k, (name, names, diff_idx, alg_idx, f_expr, g_expr, guards) in enumerate(modes):
            if k and not k & 63:  # a large model's set-up honours the deadline in force (--max-time)
                check_deadline(f"analysing the modes' affine forms ({k} of {len(modes)} parts done)")
            if qcache[0] is not names:  # the parts of a composed system share their names
                qcache = (names, {j for j, nm in enumerate(names) if nm in qnames})
            self.forms.append(
                self._form(name, names, diff_idx, alg_idx, f_expr, g_expr, guards, qcache[1], pset)
            )
        nsg = len(self._rates)
        slots = {p: i for i, p in enumerate(self.params)}
        slots.update({f"__sg{j}": len(self.params) + j for j in range(nsg)})
        self._const = np.array([e.args[0] if e.op == "num" else 0.0 for e in self._values])
        self._dyn = np.array([i for i, e in enumerate(self._values) if e.op != "num"], dtype=int)
        self._fn = (
            compile_many([self._values[i] for i in self._dyn], slots, "affine") if self._dyn.size else None
        )
        self._rate_fn = compile_many(self._rates, slots, "rates") if self._rates else None
        #: :meth:`evaluate` at the most recent parameter vectors (at most EVALUATED_KEPT)
        self._evaluated = LRUCache(EVALUATED_KEPT)

    def _pos(self, e: Expr) -> int:
        k = self._where.get(e)
        if k is None:
            k = self._where[e] = len(self._values)
            self._values.append(e)
        return k

    def _form(self, name, names, diff_idx, alg_idx, f_expr, g_expr, guards, qset, pset) -> ModeForm:
        """One mode's (or part's) :class:`ModeForm`; ``qset``: the indices of the quadratures in ``names``."""
        where = f"mode `{name}`"
        d = np.array([i for i in diff_idx if i not in qset], dtype=int)
        a = np.array(alg_idx, dtype=int)
        q = np.array(sorted(qset & set(diff_idx)), dtype=int)
        exprs = [f_expr[i] for i in diff_idx] + [g_expr[i] for i in a] + [e for _, e in guards]
        rates, mapping = _phase_nodes(exprs, where, pset, len(self._rates), self._groups)
        first = len(self._rates)
        self._rates += rates
        self._rate_mode += [name] * len(rates)
        rate_groups = [self._groups.index(k.args[0] if k.op == "neg" else k) for k in rates]
        self._rate_group += rate_groups
        groups = sorted(set(rate_groups))
        pset = pset | {f"__sg{j}" for j in range(first, len(self._rates))}

        def sub(e: Expr) -> Expr:
            return replace_nodes(e, mapping) if mapping else e

        if self._forcing is not None:  # every mode alike: all groups of the analysis, or none
            groups = list(range(len(self._groups))) if self._forcing else []
        if not (self._index[0] is names and self._index[1] == tuple(groups)):
            symbols = list(names) + [sym_ for g in groups for sym_ in _harmonic_symbols(g)]
            self._index = (names, tuple(groups), symbols, {s: j for j, s in enumerate(symbols)})
        symbols, index = self._index[2], self._index[3]
        nu = len(symbols)

        def row(e: Expr, what: str) -> dict[int, int]:
            terms = affine_terms(sub(e), index, pset, f"{where}: {what}")
            return {c: k for c, x in terms.items() if (k := self._pos(x))}

        F = _index_matrix([row(f_expr[i], f"derivative of `{names[i]}`") for i in d], nu + 1)
        G = _index_matrix([row(g_expr[i], f"algebraic equation of `{names[i]}`") for i in a], nu + 1)
        Qu = []
        for i in q:
            Q = _quadratic(sub(f_expr[i]), index, pset, f"{where}: derivative of quadrature `{names[i]}`")
            Qu.append(
                sp.csr_array(
                    (
                        np.array([self._pos(x) for x in Q.values()], dtype=np.int64),
                        (
                            np.array([j for j, _ in Q], dtype=np.int64),
                            np.array([k for _, k in Q], dtype=np.int64),
                        ),
                    ),
                    shape=(nu + 1, nu + 1),
                )
            )
        W = _index_matrix([row(e, f"guard `{gname}`") for gname, e in guards], nu + 1)
        return ModeForm(name, names, d, a, q, list(range(first, len(self._rates))), groups, F, G, W, Qu)

    def evaluate(self, values) -> list[tuple]:
        """``(omega, d, a, q, M, P, Q, W, harmonics)`` of every mode at the parameter vector ``values``.

        Raises
        ------
        NotAffineError
            Forcing at a zero frequency or at frequencies that are not integer multiples of the
            lowest, or slave variables not determined by the algebraic equations, at these values.
        """
        v = [float(x) for x in values]
        return self._evaluated.get_or_make(tuple(v), lambda: self._frozen(v))

    def _frozen(self, v: list[float]) -> list[tuple]:
        out = self._evaluate(v)
        for form in out:
            for x in form:
                if isinstance(x, np.ndarray):
                    x.flags.writeable = False  # shared by every flow at these values
        return out

    def _evaluate(self, v: list[float]) -> list[tuple]:
        vals, omegas, harmonics, pairs = self.coefficients(v)
        return [
            assemble_form(form, vals, omegas[m], harmonics[m], pairs[m]) for m, form in enumerate(self.forms)
        ]

    def coefficients(
        self, v: list[float]
    ) -> tuple[np.ndarray, list[float | None], list[tuple], list[list[int]]]:
        """The values of every coefficient at the parameter vector ``v``; each form's forcing
        frequency [rad/s] (the base frequency; None where its equations have none); each form's
        harmonics (the multiples ``n`` of the base frequency in its forcing, one pair
        ``S_n, C_n`` each in ``z``) and pairs (the pair in ``z`` of each of its groups of rates),
        as :func:`assemble_form` takes them.

        Raises
        ------
        NotAffineError
            Forcing at a zero frequency, or at frequencies that are not integer multiples of the
            lowest.
        """
        signs: list[float] = []
        omegas: list[float | None] = [None] * len(self.forms)
        harmonics: list[tuple] = [(1,)] * len(self.forms)
        pairs: list[list[int]] = [[0] * len(form.groups) for form in self.forms]
        if self._rate_fn is not None:
            rates = self._rate_fn(v)
            group_w: dict[int, float] = {}
            for j, k in enumerate(rates):
                where = f"mode `{self._rate_mode[j]}`"
                if k == 0.0 or not math.isfinite(k):
                    raise NotAffineError(f"{where}: the forcing frequency is {k!r} at these parameter values")
                signs.append(1.0 if k > 0 else -1.0)
                group_w.setdefault(self._rate_group[j], abs(k))
            base = min(group_w.values())  # the base frequency: every other an integer multiple of it
            multiple = {}
            for g, w in group_w.items():
                n = round(w / base)
                if abs(w / base - n) > HARMONIC_TOL * n:
                    mode = self._rate_mode[self._rate_group.index(g)]
                    raise NotAffineError(
                        f"mode `{mode}`: forcing frequencies {base!r} and {w!r} rad/s are not integer multiples "
                        f"of one base frequency (ratio {w / base:.15g}); the exact integrator handles sums of "
                        "harmonics of one frequency"
                    )
                multiple[g] = n
            for m, form in enumerate(self.forms):
                if form.rates:
                    omegas[m] = base
                    harmonics[m] = tuple(sorted({multiple[g] for g in form.groups}))
                    pairs[m] = [harmonics[m].index(multiple[g]) for g in form.groups]
        vals = self._const.copy()
        if self._fn is not None:
            vals[self._dyn] = self._fn(v + signs)
        return vals, omegas, harmonics, pairs


def assemble_form(
    form: ModeForm, vals: np.ndarray, omega: float | None, harmonics: tuple = (1,), pairs=(0,)
) -> tuple:
    """``(omega, d, a, q, M, P, Q, W, harmonics)`` of one mode from the coefficient values.

    ``harmonics``: the multiples ``n`` of ``omega`` in the mode's forcing, one pair
    ``S_n, C_n`` each in ``z``; ``pairs[i]``: the pair of the ``i``-th group of rates of the
    form (the ``i``-th ``S, C`` in ``u``; groups of equal frequency share a pair).
    """
    where = f"mode `{form.name}`"
    d, a, q = form.d, form.a, form.q
    n = len(form.names)
    nf = 2 * len(harmonics) if omega is not None else 0
    nu = n + 2 * len(form.groups)
    F, G = vals[form.F.toarray()], vals[form.G.toarray()]
    # u over z = [y_d, S_1, C_1, ..., 1]: differential rows are z, slave rows from the algebraic equations.
    nz = d.size + nf + 1
    Pu = np.zeros((nu + 1, nz))
    Pu[d, np.arange(d.size)] = 1.0
    if omega is not None:
        for i, pair in enumerate(pairs):
            Pu[n + 2 * i + np.arange(2), d.size + 2 * pair + np.arange(2)] = 1.0
    Pu[nu, nz - 1] = 1.0
    if a.size:
        Ga = G[:, a]
        if not _cond1(Ga) < 1e14:
            raise NotAffineError(f"{where}: the algebraic equations are singular in the slave variables")
        rest = Pu.copy()
        rest[a, :] = 0.0
        Pu[a, :] = -np.linalg.solve(Ga, G @ rest)
    M = np.zeros((nz, nz))
    M[: d.size] = F @ Pu
    if omega is not None:
        for j, m in enumerate(harmonics):
            k = d.size + 2 * j
            M[k, k + 1] = m * omega  # S_m' = m w C_m (m = 1: exactly w)
            M[k + 1, k] = -m * omega  # C_m' = -m w S_m
    Q = np.array([Pu.T @ vals[Qj.toarray()] @ Pu for Qj in form.Qu]).reshape(q.size, nz, nz)
    W = vals[form.Wu.toarray()] @ Pu
    return omega, d, a, q, M, Pu[:n], Q, W, tuple(harmonics)


def _mode_equations(cm: CompiledMode) -> tuple:
    return (
        cm.name,
        cm.names,
        [int(i) for i in cm.diff_idx],
        [int(i) for i in cm.alg_idx],
        cm.f_expr,
        cm.g_expr,
        [(g.name, g.expr) for g in cm.guards],
    )


def affine_mode(cm: CompiledMode, quadratures: tuple[str, ...]) -> AffineMode:
    """Analyse one compiled mode (parameters folded) as an exact linear flow (see the module notes).

    Raises
    ------
    NotAffineError
        Naming the mode, the equation and the first non-affine term.
    """
    (flat,) = AffineAnalysis([_mode_equations(cm)], quadratures, ()).evaluate(())
    return AffineMode(cm, *flat)


def system_analysis(system) -> AffineAnalysis:
    """The parametric affine analysis of every mode of ``system``, done once and kept with it.

    Analysed on the system's own expressions with the parameters kept as
    symbols. Raises NotAffineError (also on later calls) if a mode is not
    affine for every parameter value.
    """
    cached = system.cache.get("affine_analysis", lambda: _analyse(system))
    if isinstance(cached, NotAffineError):
        raise NotAffineError(str(cached))
    return cached


def _analyse(system) -> AffineAnalysis | NotAffineError:
    """The analysis of :func:`system_analysis` (or the error that refuses it)."""
    names = tuple(system.variable_names)
    modes = []
    for mode in system.modes:
        data = system.parsed.modes[mode.name]
        derivs, alg = data["derivatives"], data["algebraic"]
        guards = [
            (tr.name, td["guard"])
            for tr, td in zip(system.transitions, system.parsed.transitions, strict=True)
            if tr.source == mode.name
        ]
        modes.append(
            (
                mode.name,
                names,
                [i for i, nm in enumerate(names) if nm in derivs],
                [i for i, nm in enumerate(names) if nm in alg],
                {i: derivs[nm] for i, nm in enumerate(names) if nm in derivs},
                {i: alg[nm] for i, nm in enumerate(names) if nm in alg},
                guards,
            )
        )
    try:
        return AffineAnalysis(modes, tuple(system.quadratures), tuple(system.parameter_names))
    except NotAffineError as exc:
        return exc  # kept: every later call raises it again


def affine_flows(system, params: Mapping[str, float], cms=None) -> list[AffineMode]:
    """Every mode of ``system`` as an exact flow at ``params`` from the parametric analysis (microseconds).

    ``cms`` gives the compiled modes to attach (None: flows only).
    """
    an = system_analysis(system)
    flat = an.evaluate([params[p] for p in an.params])
    out = [AffineMode(None if cms is None else cms[k], *f) for k, f in enumerate(flat)]
    _check_one_frequency(out)
    return out


def _check_one_frequency(modes: list[AffineMode]) -> None:
    freqs = {m.omega for m in modes if m.omega is not None}
    if len(freqs) > 1:
        raise NotAffineError(f"modes are forced at different frequencies: {sorted(freqs)}")


def affine_system(cs: CompiledSystem) -> list[AffineMode]:
    """Every mode of a compiled system as an exact flow, all with one forcing frequency.

    From the system's parametric analysis (:func:`system_analysis`); a system
    affine only at these parameter values (a non-affine term with a zero
    coefficient) is analysed on its folded expressions.

    Raises
    ------
    NotAffineError
        For the first mode that is not affine, or modes forced at different frequencies.
    """
    if cs.free:
        raise NotAffineError(
            "the exact integrator does not differentiate by a parameter in the state; "
            f"free parameters: {', '.join(cs.free)}"
        )
    try:
        return affine_flows(cs.system, cs.params, cs.modes)
    except NotAffineError:
        pass
    quads = tuple(cs.system.quadratures)
    # the modes together, so that one base frequency holds for all (a mode forced at 2 w only)
    flat = AffineAnalysis([_mode_equations(cm) for cm in cs.modes], quads, ()).evaluate(())
    out = [AffineMode(cm, *f) for cm, f in zip(cs.modes, flat, strict=True)]
    _check_one_frequency(out)
    return out
