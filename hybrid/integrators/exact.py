"""The exact integrator for affine modes: matrix exponentials and guard roots of the exact flow.

A mode is *affine* when its derivatives and algebraic equations are affine in
the state, with time entering only through ``sin`` and ``cos`` of one forcing
frequency ``w`` (arguments ``k t + phi`` with ``|k| = w``), and its guards are
affine too. Then, with the slave variables ``y_a`` eliminated from the
algebraic equations (``y_a = -G_a^-1 (G_d y_d + g(t))``) and the state
augmented by ``S = sin(w t)``, ``C = cos(w t)`` and ``1``, the flow is linear::

    z = [y_d, S, C, 1],   z' = M z,   z(t + h) = expm(M h) z(t)

(quadratures excluded from ``y_d``). Everything follows exactly:

* a guard is a linear function ``h = w_h . z`` of the augmented state, so its
  value along a step is ``w_h expm(M s) z``, an entire function whose Taylor
  series at the step's start is known (``w_h M^j z / j!``); steps are short
  enough (``|M| h`` bounded) that the series truncated at degree
  :data:`TAYLOR_DEGREE` equals it to rounding, and its real roots in the step
  are all found as the roots of that polynomial (Chebyshev basis), so two
  crossings within one step are never missed; each root is polished by Newton
  steps on the exact flow;
* a quadrature whose rate is a quadratic form of the state (work, dissipated
  power) integrates exactly: ``q(t + h) - q(t) = z^T K(h) z`` with
  ``K(h) = int_0^h expm(M^T s) Q expm(M s) ds`` (Van Loan's block exponential);
* the fundamental matrix of ``y_d`` over a step is the ``d``-block of ``expm(M h)``.

The analysis is done once per system (:func:`system_analysis`) on its own
expressions, the parameters kept as symbols: every coefficient (of the state,
of ``S``, ``C`` and 1, the forcing rates and phases, guard rows, quadrature
forms) is an expression in the parameters, and all are compiled into one
function of the parameter vector, so the flows at a new parameter set
(:func:`affine_flows`) cost a fraction of a millisecond instead of a
compilation of the system.

:class:`ExactModeSolver` offers the interface of :class:`hybrid.integrators.ida.ModeSolver`
(``start``, ``step``, ``interpolate``, ``armed``, ``safe``), so the event loop of
:func:`hybrid.simulate` (switch location, resets, chains, Zeno) is the same for
both integrators. :func:`affine_mode` refuses a non-affine mode naming the first
non-affine term.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
from numpy.polynomial import chebyshev as cheb

from ..core.balance import balance
from ..core.errors import NotAffineError
from ..model.compiled import CompiledMode, CompiledSystem
from ..model.expr import (
    ZERO,
    Expr,
    compile_many,
    diff,
    postorder,
    replace_nodes,
    substitute,
    sym,
    to_string,
)
from ..model.expr import add as e_add
from ..model.expr import call as e_call
from ..model.expr import mul as e_mul
from ..model.expr import num as e_num
from ..model.expr import sub as e_sub
from .base import ROOT, SUCCESS, TSTOP, StepResult

__all__ = [
    "NotAffineError",
    "AffineMode",
    "AffineAnalysis",
    "affine_mode",
    "affine_system",
    "exact_flows",
    "affine_flows",
    "system_analysis",
    "ExactModeSolver",
    "TAYLOR_DEGREE",
]

#: Degree of the Taylor polynomial of a guard along one step (steps are sized so that it is exact to rounding).
TAYLOR_DEGREE = 24
_S, _C = "__sin_wt", "__cos_wt"


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

    @property
    def nz(self) -> int:
        return self.M.shape[0]

    def flow(self) -> Flow:
        """The mode's :class:`Flow` (built on first use; shared by every mode with the same matrices,
        e.g. a run's and its monodromy's at one parameter value)."""
        f = self.__dict__.get("_flow")
        if f is None:
            f = self.__dict__["_flow"] = shared_flow(self.M, self.Q)
        return f

    def augment(self, t: float, y: np.ndarray) -> np.ndarray:
        """``z`` at ``(t, y)`` (the slave variables of ``y`` are not read)."""
        forcing = [math.sin(self.omega * t), math.cos(self.omega * t)] if self.omega is not None else []
        return np.concatenate([np.asarray(y, dtype=float)[self.d], forcing, [1.0]])

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
        PM = self.__dict__.get("_PM")
        if PM is None:
            PM = self.__dict__["_PM"] = self.P @ self.M
        yp = PM @ z
        if self.q.size:
            yp[self.q] = np.einsum("j,qjk,k->q", z, self.Q, z)
        return yp

    def second_derivatives(self, z: np.ndarray) -> np.ndarray:
        """``y''`` at ``z``, exactly: ``P M^2 z``; quadrature rows ``z^T Q_j M z + (M z)^T Q_j z``."""
        PMM = self.__dict__.get("_PMM")
        if PMM is None:
            PMM = self.__dict__["_PMM"] = self.P @ self.M @ self.M
        ypp = PMM @ z
        if self.q.size:
            mz = self.M @ z
            ypp[self.q] = np.einsum("j,qjk,k->q", z, self.Q, mz) + np.einsum("j,qjk,k->q", mz, self.Q, z)
        return ypp


def _phase_nodes(
    exprs: list[Expr], where: str, params: frozenset, first: int
) -> tuple[list[Expr], dict[Expr, Expr]]:
    """Replacements of the ``sin``/``cos`` terms of the time by the symbols ``S``, ``C``.

    Returns the rates ``k`` of the arguments ``k t + phi`` (expressions in the parameters; the
    frequency is ``w = |k|``) and the replacements, which read the sign of the ``j``-th rate
    from the symbol ``__sg{first + j}``.
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
                "in sin/cos of one forcing frequency times t (plus a phase)"
            )
        k = diff(arg, "t")
        if k.free - params or (k.op == "num" and k.args[0] == 0.0):
            raise NotAffineError(f"{where}: `{to_string(node, 80)}` is not sin/cos of (constant * t + phase)")
        phi = substitute(arg, {"t": e_num(0.0)})
        sg = sym(f"__sg{first + len(rates)}")
        rates.append(k)
        s, c = sym(_S), sym(_C)
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


def affine_coefficients(e: Expr, symbols: list[str], params: frozenset, where: str) -> list[Expr]:
    """Coefficients ``[d e/d u_j ..., e(u = 0)]`` of an expression affine in ``symbols``."""
    extra = e.free - set(symbols) - params
    if extra:
        name = sorted(extra)[0]
        raise NotAffineError(f"{where} depends on `{name}` otherwise than affinely through sin/cos of t")
    state = set(symbols)
    out = []
    for s in symbols:
        if s not in e.free:
            out.append(ZERO)
            continue
        g = diff(e, s)
        if g.free & state:
            shown = {_S: "sin(w t)", _C: "cos(w t)"}.get(s, s)
            raise NotAffineError(
                _shown(f"{where} is not affine in `{shown}`: its derivative is `{to_string(g, 120)}`")
            )
        out.append(g)
    out.append(substitute(e, {s: ZERO for s in symbols}))
    return out


def _quadratic(e: Expr, symbols: list[str], params: frozenset, where: str) -> list[list[Expr]]:
    """``Q`` (expressions) with ``e = u^T Q u``, ``u = [symbols, 1]``, for a quadratic ``e``."""
    n = len(symbols)
    Q = [[ZERO] * (n + 1) for _ in range(n + 1)]
    state = set(symbols)
    zeros = {s: ZERO for s in symbols}
    half = e_num(0.5)
    for j, s in enumerate(symbols):
        if s not in e.free:
            continue
        g = diff(e, s)
        Q[j][n] = Q[n][j] = e_mul(half, substitute(g, zeros))
        for k in range(j, n):
            if symbols[k] not in g.free:
                continue
            h = diff(g, symbols[k])
            if h.free & state:
                raise NotAffineError(f"{where} is not quadratic in the state: `{to_string(h, 120)}`")
            Q[j][k] = Q[k][j] = e_mul(half, h)
    extra = e.free - state - params
    if extra:
        raise NotAffineError(f"{where} depends on `{sorted(extra)[0]}` otherwise than through sin/cos of t")
    Q[n][n] = substitute(e, zeros)
    return Q


@dataclass
class _ModeForm:
    """One mode's affine form: coefficient expressions, as positions in the analysis' value vector."""

    name: str
    names: tuple[str, ...]
    d: np.ndarray
    a: np.ndarray
    q: np.ndarray
    rates: list[int]  # positions of this mode's forcing rates among the analysis' rates
    F: np.ndarray  # (nd, nu + 1) rows of the derivatives over [u, 1]
    G: np.ndarray  # (na, nu + 1) rows of the algebraic equations
    Wu: np.ndarray  # (ng, nu + 1) rows of the guards
    Qu: np.ndarray  # (nq, nu + 1, nu + 1) quadratic forms of the quadrature rates


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

    def __init__(self, modes, quadratures: tuple[str, ...], params: tuple[str, ...]):
        self.params = tuple(params)
        pset = frozenset(params)
        self._values: list[Expr] = [ZERO]  # position 0: zero
        self._where: dict[Expr, int] = {ZERO: 0}
        self._rates: list[Expr] = []
        self._rate_mode: list[str] = []
        self.forms: list[_ModeForm] = []
        for name, names, diff_idx, alg_idx, f_expr, g_expr, guards in modes:
            self.forms.append(
                self._form(name, list(names), diff_idx, alg_idx, f_expr, g_expr, guards, quadratures, pset)
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

    def _pos(self, e: Expr) -> int:
        k = self._where.get(e)
        if k is None:
            k = self._where[e] = len(self._values)
            self._values.append(e)
        return k

    def _form(self, name, names, diff_idx, alg_idx, f_expr, g_expr, guards, quadratures, pset) -> _ModeForm:
        where = f"mode `{name}`"
        qset = {names.index(q) for q in quadratures if q in names}
        d = np.array([i for i in diff_idx if i not in qset], dtype=int)
        a = np.array(alg_idx, dtype=int)
        q = np.array(sorted(qset), dtype=int)
        exprs = [f_expr[i] for i in diff_idx] + [g_expr[i] for i in a] + [e for _, e in guards]
        rates, mapping = _phase_nodes(exprs, where, pset, len(self._rates))
        first = len(self._rates)
        self._rates += rates
        self._rate_mode += [name] * len(rates)
        pset = pset | {f"__sg{j}" for j in range(first, len(self._rates))}

        def sub(e: Expr) -> Expr:
            return replace_nodes(e, mapping) if mapping else e

        symbols = names + ([_S, _C] if rates else [])

        def row(e: Expr, what: str) -> list[int]:
            return [self._pos(c) for c in affine_coefficients(sub(e), symbols, pset, f"{where}: {what}")]

        nu = len(symbols)
        F = np.array([row(f_expr[i], f"derivative of `{names[i]}`") for i in d], dtype=int).reshape(
            d.size, nu + 1
        )
        G = np.array([row(g_expr[i], f"algebraic equation of `{names[i]}`") for i in a], dtype=int).reshape(
            a.size, nu + 1
        )
        Qu = np.array(
            [
                [
                    [self._pos(c) for c in r]
                    for r in _quadratic(
                        sub(f_expr[i]), symbols, pset, f"{where}: derivative of quadrature `{names[i]}`"
                    )
                ]
                for i in q
            ],
            dtype=int,
        ).reshape(q.size, nu + 1, nu + 1)
        W = np.array([row(e, f"guard `{gname}`") for gname, e in guards], dtype=int).reshape(
            len(guards), nu + 1
        )
        return _ModeForm(name, tuple(names), d, a, q, list(range(first, len(self._rates))), F, G, W, Qu)

    def evaluate(self, values) -> list[tuple]:
        """``(omega, d, a, q, M, P, Q, W)`` of every mode at the parameter vector ``values``.

        Raises
        ------
        NotAffineError
            Forcing at a zero frequency or at different frequencies, or slave
            variables not determined by the algebraic equations, at these values.
        """
        v = [float(x) for x in values]
        key = tuple(v)
        cache = self.__dict__.setdefault("_evaluated", {})
        hit = cache.pop(key, None)
        if hit is None:
            hit = self._evaluate(v)
            for form in hit:
                for x in form:
                    if isinstance(x, np.ndarray):
                        x.flags.writeable = False  # shared by every flow at these values
            if len(cache) >= 16:
                del cache[next(iter(cache))]
        cache[key] = hit  # most recent last
        return hit

    def _evaluate(self, v: list[float]) -> list[tuple]:
        signs: list[float] = []
        omegas: list[float | None] = [None] * len(self.forms)
        if self._rate_fn is not None:
            rates = self._rate_fn(v)
            for j, k in enumerate(rates):
                where = f"mode `{self._rate_mode[j]}`"
                if k == 0.0 or not math.isfinite(k):
                    raise NotAffineError(f"{where}: the forcing frequency is {k!r} at these parameter values")
                signs.append(1.0 if k > 0 else -1.0)
            for m, form in enumerate(self.forms):
                for j in form.rates:
                    w = abs(rates[j])
                    if omegas[m] is None:
                        omegas[m] = w
                    elif not math.isclose(w, omegas[m], rel_tol=1e-15):
                        raise NotAffineError(
                            f"mode `{form.name}`: two forcing frequencies ({omegas[m]!r} and {w!r} rad/s); "
                            "the exact integrator handles one"
                        )
        vals = self._const.copy()
        if self._fn is not None:
            vals[self._dyn] = self._fn(v + signs)
        return [_assemble(form, vals, omegas[m]) for m, form in enumerate(self.forms)]


def _cond1(A: np.ndarray, Ainv: np.ndarray | None = None) -> float:
    """Condition number of ``A`` in the 1-norm (``Ainv``: its inverse, if known); inf if singular."""
    try:
        Ainv = np.linalg.inv(A) if Ainv is None else Ainv
    except np.linalg.LinAlgError:
        return math.inf
    c = float(np.abs(A).sum(axis=0).max() * np.abs(Ainv).sum(axis=0).max())
    return c if math.isfinite(c) else math.inf


def _assemble(form: _ModeForm, vals: np.ndarray, omega: float | None) -> tuple:
    """``(omega, d, a, q, M, P, Q, W)`` of one mode from the coefficient values."""
    where = f"mode `{form.name}`"
    d, a, q = form.d, form.a, form.q
    n = len(form.names)
    nf = 2 if omega is not None else 0
    nu = n + nf
    F, G = vals[form.F], vals[form.G]
    # u over z = [y_d, S, C, 1]: differential rows are z, slave rows from the algebraic equations.
    nz = d.size + nf + 1
    Pu = np.zeros((nu + 1, nz))
    Pu[d, np.arange(d.size)] = 1.0
    Pu[n + np.arange(nf), d.size + np.arange(nf)] = 1.0
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
        k = d.size
        M[k, k + 1] = omega  # S' = w C
        M[k + 1, k] = -omega  # C' = -w S
    Q = np.array([Pu.T @ vals[Qj] @ Pu for Qj in form.Qu]).reshape(q.size, nz, nz)
    W = vals[form.Wu] @ Pu
    return omega, d, a, q, M, Pu[:n], Q, W


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
    cached = system._cache.get("affine")
    if cached is None:
        names = tuple(system.variable_names)
        modes = []
        for mode in system.modes:
            data = system._cache["modes"][mode.name]
            derivs, alg = data["derivatives"], data["algebraic"]
            guards = [
                (tr.name, td["guard"])
                for tr, td in zip(system.transitions, system._cache["transitions"], strict=True)
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
            cached = AffineAnalysis(modes, tuple(system.quadratures), tuple(system.parameter_names))
        except NotAffineError as exc:
            cached = exc
        system._set_cache("affine", cached)
    if isinstance(cached, NotAffineError):
        raise NotAffineError(str(cached))
    return cached


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
    out = [affine_mode(cm, quads) for cm in cs.modes]
    _check_one_frequency(out)
    return out


def exact_flows(cs: CompiledSystem) -> list[AffineMode]:
    """Every mode of ``cs`` as an exact affine flow (:func:`affine_system`), analysed once per
    parameter set (kept in ``cs.derived`` until its parameters change).

    Raises
    ------
    NotAffineError
        Naming the model, the first mode and the term that is not affine.
    """
    hit = cs.derived.get("exact_flows")
    if hit is None:
        try:
            hit = affine_system(cs)
        except ValueError as exc:
            raise type(exc)(f"model `{cs.system.name}`: {exc}") from None
        cs.derived["exact_flows"] = hit
    return hit


# ----------------------------------------------------------------------------
# Propagation
# ----------------------------------------------------------------------------
#: Largest condition number (1-norm) of the eigenvector matrix for the eigen-decomposition path of a flow.
EIGEN_COND = 1e4
# Pade [13/13] coefficients (Higham 2005) and the norm bound of the scaled matrix.
_PADE13 = (
    64764752532480000.0, 32382376266240000.0, 7771770303897600.0, 1187353796428800.0,
    129060195264000.0, 10559470521600.0, 670442572800.0, 33522128640.0, 1323241920.0,
    40840800.0, 960960.0, 16380.0, 182.0, 1.0,
)  # fmt: skip
_THETA13 = 5.371920351148152


def matrix_exp(A: np.ndarray) -> np.ndarray:
    """``expm(A)`` by scaling and squaring with the [13/13] Pade approximant (Higham 2005), in numpy.

    (scipy's ``expm`` runs through its own threaded BLAS, which on small
    matrices costs milliseconds a call on a loaded machine; this costs tens
    of microseconds.)
    """
    n = A.shape[0]
    norm = float(np.max(np.sum(np.abs(A), axis=0))) if n else 0.0
    s = max(0, int(math.ceil(math.log2(norm / _THETA13)))) if norm > _THETA13 else 0
    A = A / 2.0**s
    b = _PADE13
    eye = np.eye(n)
    A2 = A @ A
    A4 = A2 @ A2
    A6 = A4 @ A2
    U = A @ (A6 @ (b[13] * A6 + b[11] * A4 + b[9] * A2) + b[7] * A6 + b[5] * A4 + b[3] * A2 + b[1] * eye)
    V = A6 @ (b[12] * A6 + b[10] * A4 + b[8] * A2) + b[6] * A6 + b[4] * A4 + b[2] * A2 + b[0] * eye
    E = np.linalg.solve(V - U, V + U)
    for _ in range(s):
        E = E @ E
    return E


#: Flows kept by :func:`shared_flow` (the most recent ones).
MAX_SHARED_FLOWS = 64
_FLOWS: dict[bytes, Flow] = {}


def shared_flow(M: np.ndarray, Q: np.ndarray) -> Flow:
    """The :class:`Flow` of ``(M, Q)``, built once for equal matrices (its eigen-decomposition, guard
    series and step kernels are then computed once for a parameter value, not once per run)."""
    key = M.tobytes() + b"|" + Q.tobytes() + repr((M.shape, Q.shape)).encode()
    f = _FLOWS.pop(key, None)
    if f is None:
        f = Flow(M, Q)
        if len(_FLOWS) >= MAX_SHARED_FLOWS:
            del _FLOWS[next(iter(_FLOWS))]
    _FLOWS[key] = f  # most recent last
    return f


class Flow:
    """The exact flow ``z(h) = expm(M h) z`` of one affine mode, and its quadratures.

    Where ``M`` has a well-conditioned eigenvector basis (condition number at
    most :data:`EIGEN_COND` after balancing, :func:`hybrid.core.balance.balance`),
    ``expm(M h) = V exp(L h) V^-1`` costs a few matrix-vector products for any ``h``; otherwise (a defective ``M``, e.g.
    forcing exactly at a natural frequency) :func:`matrix_exp` is used, with
    the quadratures by Van Loan's block exponential.

    Parameters
    ----------
    M : ndarray, shape (nz, nz)
    Q : ndarray, shape (nq, nz, nz)
        Quadrature rates as quadratic forms.
    """

    def __init__(self, M: np.ndarray, Q: np.ndarray):
        self.M, self.Q = M, Q
        self.nz = M.shape[0]
        self.eigen = False
        try:
            # eigenvectors of the balanced generator (a diagonal similarity by powers of 2): in
            # engineering units (velocities 1e3 times the displacements) those of M itself had a
            # condition number over EIGEN_COND, and every flow fell back on the Pade path
            b = balance(M)
            lam, Vb = np.linalg.eig(M * b[None, :] / b[:, None])
            Vbinv = np.linalg.inv(Vb)
            V, Vinv = Vb * b[:, None], Vbinv / b[None, :]
            if _cond1(Vb, Vbinv) <= EIGEN_COND:
                self.lam, self.V, self.Vinv = lam, V, Vinv
                # quadratures in the eigenbasis: int z^T Q z = c^T (V^T Q V o Phi(h)) c, c = V^-1 z
                self.QV = np.array([V.T @ Qj @ V for Qj in Q]).reshape(len(Q), self.nz, self.nz)
                self.mu = lam[:, None] + lam[None, :]
                self._mu_safe = np.where(self.mu == 0.0, 1.0, self.mu)
                self.eigen = True
        except np.linalg.LinAlgError:  # pragma: no cover - eig of a finite matrix
            pass

    def kernel(self, h: float) -> tuple[np.ndarray, np.ndarray | None]:
        """``(expm(M h), K)`` with ``q(h) - q(0) = z^T K_j z`` (None without quadratures), kept for reuse."""
        cache = self.__dict__.setdefault("_kernels", {})
        hit = cache.get(h)
        if hit is None:
            if len(cache) >= 16:
                cache.clear()
            nq, nz = self.Q.shape[0], self.nz
            E = self.matrix(h)
            K = None
            if nq and self.eigen:
                mh = self.mu * h
                small = np.abs(mh) < 1e-3
                phi = np.where(small, h * (1 + mh / 2 + mh * mh / 6 + mh**3 / 24), 0j)
                phi[~small] = (np.exp(mh[~small]) - 1.0) / self.mu[~small]
                K = np.real(np.einsum("ji,qjk,kl->qil", self.Vinv, self.QV * phi, self.Vinv))
            elif nq:
                K = np.zeros((nq, nz, nz))
                for j, Qj in enumerate(self.Q):
                    B = np.zeros((2 * nz, 2 * nz))
                    B[:nz, :nz] = -self.M.T
                    B[:nz, nz:] = Qj
                    B[nz:, nz:] = self.M
                    K[j] = E.T @ matrix_exp(B * h)[:nz, nz:]
            cache[h] = hit = (E, K)
        return hit

    def matrix(self, h: float) -> np.ndarray:
        """``expm(M h)``."""
        if self.eigen:
            return ((self.V * np.exp(self.lam * h)) @ self.Vinv).real
        return matrix_exp(self.M * h)

    def frechet(self, h: float, D: np.ndarray) -> np.ndarray:
        """``d/de expm((M + e D) h)`` at ``e = 0``: ``V (G o V^-1 D V) V^-1`` with the divided differences
        ``G_jk = (exp(l_j h) - exp(l_k h)) / (l_j - l_k)`` of the eigenvalues (``h exp(l h)`` where
        they meet); on the defective path the corner block of Van Loan's ``expm([[M, D], [0, M]] h)``."""
        if not self.eigen:
            nz = self.nz
            B = np.zeros((2 * nz, 2 * nz))
            B[:nz, :nz] = self.M
            B[:nz, nz:] = D
            B[nz:, nz:] = self.M
            return matrix_exp(B * h)[:nz, nz:]
        lam = self.lam
        e = np.exp(lam * h)
        x = (lam[:, None] - lam[None, :]) * h
        small = np.abs(x) < 1e-3
        x_safe = np.where(small, 1.0, x)
        # (e_j - e_k) / (l_j - l_k) = h e_k (exp(x) - 1) / x, x = (l_j - l_k) h: a series where x is small
        phi = np.where(small, 1.0 + x * (0.5 + x * (1.0 / 6.0 + x / 24.0)), np.expm1(x) / x_safe)
        G = h * e[None, :] * phi
        return (self.V @ ((self.Vinv @ D @ self.V) * G) @ self.Vinv).real

    def prepare(self, z: np.ndarray):
        """What :meth:`advance` from ``z`` reuses for any ``h`` (eigen path; None otherwise)."""
        if not self.eigen:
            return None
        c = self.Vinv @ z
        return c, (self.QV * np.outer(c, c) if self.Q.shape[0] else None)

    def advance(self, z: np.ndarray, h: float, prep=None) -> tuple[np.ndarray, np.ndarray]:
        """``(z(h), q(h) - q(0))`` from ``z`` (``prep``: :meth:`prepare` of ``z``, if kept)."""
        nq = self.Q.shape[0]
        if self.eigen:
            c, cc = prep if prep is not None else self.prepare(z)
            e = np.exp(self.lam * h)
            z1 = (self.V @ (e * c)).real
            if cc is None:
                return z1, np.zeros(0)
            # int_0^h exp(mu s) ds with mu_jk = lam_j + lam_k (exp(mu h) = e_j e_k); a series where mu h is small
            mh = self.mu * h
            phi = np.where(
                np.abs(mh) < 1e-3,
                h * (1.0 + mh * (0.5 + mh * (1.0 / 6.0 + mh / 24.0))),
                (np.outer(e, e) - 1.0) / self._mu_safe,
            )
            return z1, np.einsum("qjk,jk->q", cc, phi).real
        if not nq:
            return matrix_exp(self.M * h) @ z, np.zeros(0)
        nz = self.nz
        E = matrix_exp(self.M * h)
        out = np.zeros(nq)
        for j, Qj in enumerate(self.Q):
            B = np.zeros((2 * nz, 2 * nz))
            B[:nz, :nz] = -self.M.T
            B[:nz, nz:] = Qj
            B[nz:, nz:] = self.M
            X = matrix_exp(B * h)
            out[j] = z @ (E.T @ X[:nz, nz:]) @ z
        return E @ z, out


_GRID = np.linspace(0.0, 1.0, 17)
_DEGREES = np.arange(TAYLOR_DEGREE + 1, dtype=float)
_VANDER = _GRID[:, None] ** _DEGREES[None, :]
# Monomial coefficients in x on [0, 1] to Chebyshev coefficients of the same polynomial (domain [0, 1]).
_MON2CHEB = np.array(
    [
        np.pad(
            np.polynomial.Polynomial.basis(j).convert(kind=cheb.Chebyshev, domain=[0.0, 1.0]).coef,
            (0, TAYLOR_DEGREE - j),
        )
        for j in range(TAYLOR_DEGREE + 1)
    ]
).T


def _guard_series_rows(am: AffineMode, max_step: float) -> tuple[float, np.ndarray]:
    """Step length and Taylor rows ``T[g, j] = W_g M^j / j!`` of the guards (kept with the mode)."""
    cache = am.__dict__.setdefault("_series", {})
    hit = cache.get(max_step)
    if hit is not None:
        return hit
    ng, nz = am.W.shape
    K, extra = TAYLOR_DEGREE, 8
    T = np.zeros((ng, K + 1 + extra, nz))
    row = am.W.copy()
    for j in range(K + 1 + extra):
        T[:, j, :] = row
        row = row @ am.M / (j + 1)
    # Step length: the guards' Taylor tails beyond the degree are below rounding on a step.
    norms = np.max(np.abs(T).sum(axis=2), axis=0) if ng else np.zeros(K + 1 + extra)
    h = max_step
    while ng and h > 0:
        powers = h ** np.arange(K + 1 + extra)
        if np.sum(norms[K + 1 :] * powers[K + 1 :]) <= 1e-17 * np.sum(norms[: K + 1] * powers[: K + 1]):
            break
        h *= 0.5
    cache[max_step] = hit = (h, np.ascontiguousarray(T[:, : K + 1, :]))
    return hit


class ExactModeSolver:
    """The exact flow of one affine mode, behind the interface of :class:`hybrid.integrators.ida.ModeSolver`.

    Parameters
    ----------
    am : AffineMode
        The mode.
    max_step : float
        Upper bound of a step [s] (the forcing period / 16 by default in the engine).
    """

    def __init__(self, am: AffineMode, *, max_step: float):
        self.am = am
        self.mode = am.cm
        ng = am.W.shape[0]
        self.armed = np.ones(ng, dtype=bool)
        self.safe = np.zeros(ng)
        self.nfev_last = 0
        self.njev_last = 0
        nz = am.nz
        self.h, T = _guard_series_rows(am, float(max_step))
        self._T = T
        self.flow = am.flow()
        self._direction = [g.direction for g in am.cm.guards]
        # Exclusion test on a grid: |p| at the nodes against the derivative bound.
        self._scales: dict[float, np.ndarray] = {}
        self.t = 0.0
        self.z = np.zeros(nz)
        self.quad = np.zeros(am.q.size)
        self._t_call = 0.0
        self._z_call = self.z
        self._quad_call = self.quad
        # A full step taken past the last output (no crossing in it): (t0, z0, q0, t1, z1, q1, [prep]).
        self._pending: tuple | None = None
        self._stepped = False

    # ------------------------------------------------------------------
    def _advance(self, z: np.ndarray, quad: np.ndarray, h: float) -> tuple[np.ndarray, np.ndarray]:
        if h == 0.0:
            return z.copy(), quad.copy()
        if h == self.h:  # the full step: its matrices are kept
            E, K = self.flow.kernel(h)
            return E @ z, (quad + np.einsum("j,qjk,k->q", z, K, z) if K is not None else quad)
        z1, dq = self.flow.advance(z, h)
        return z1, quad + dq

    def _fix_forcing(self, t: float, z: np.ndarray) -> None:
        am = self.am
        if am.omega is not None:
            k = am.d.size
            z[k] = math.sin(am.omega * t)
            z[k + 1] = math.cos(am.omega * t)
        z[-1] = 1.0

    def _result(
        self, status: int, t: float, z: np.ndarray, quad: np.ndarray, fired=(), message=""
    ) -> StepResult:
        y = self.am.state(z, quad)
        return StepResult(status, t, y, self.am.derivatives(z), tuple(fired), message)

    def start(self, t: float, y: np.ndarray, yp: np.ndarray | None) -> None:
        """Start at a consistent point ``(t, y)`` (``yp`` is not needed)."""
        self.t = float(t)
        self.z = self.am.augment(t, y)
        self.quad = np.asarray(y, dtype=float)[self.am.q].copy()
        self._t_call, self._z_call, self._quad_call = self.t, self.z.copy(), self.quad.copy()
        self.nfev_last = self.njev_last = 0
        self._pending = None
        self._stepped = False  # a step taken since start (see _crossings)

    def _first_root(self, z: np.ndarray, h: float) -> tuple[float, int] | None:
        """Earliest crossing in ``(0, h]`` of an armed guard in its direction: ``(s, guard)``."""
        scale = self._scales.get(h)
        if scale is None:
            if len(self._scales) >= 16:
                self._scales.clear()
            scale = self._scales[h] = h ** np.arange(TAYLOR_DEGREE + 1)
        C = (self._T @ z) * scale  # (ng, K+1): guards as polynomials in s/h on [0, 1]
        A = np.abs(C)
        mag = A.sum(axis=1)
        a0 = A[:, 0]
        if np.all((a0 > mag - a0) | ~self.armed):
            return None  # |p(s)| >= |c_0| - sum_j>0 |c_j| > 0 on [0, 1] for every armed guard
        # cannot vanish on [0, 1]: |p| at 17 nodes exceeds what its slope bound allows in between
        near = np.abs(C @ _VANDER.T).min(axis=1) <= (0.5 / (_GRID.size - 1)) * (A @ _DEGREES)
        best = None
        for k in np.flatnonzero(self.armed & near & (mag > 0.0)):
            for r in self._crossings(C[k], self._direction[k], float(mag[k]), self._stepped):
                if best is None or r < best[0]:
                    best = (r, int(k))
                break  # crossings come sorted: the first counts
        if best is None:
            return None
        return best[0] * h, best[1]

    @staticmethod
    def _crossings(c: np.ndarray, direction: int, mag: float, stepped: bool = False) -> list[float]:
        """Sign changes of the polynomial ``c`` (monomial, variable in [0, 1]) in (0, 1], sorted;
        with ``stepped`` (not the first step since :meth:`start`) also within 1e-12 of 0, where the
        polynomial starts on the safe side or at zero and leaves it in the guard's direction: a
        crossing on the boundary of two steps, which the earlier step's end did not count (its value
        there rounded to the safe side).

        Roots from the colleague matrix of its Chebyshev series on [0, 1] (a fixed linear map of
        the monomial coefficients).
        """
        keep = np.flatnonzero(np.abs(c) > 1e-17 * mag)
        c = c[: keep[-1] + 1] if keep.size else c[:1]
        if c.size < 2:
            return []
        m = c.size
        roots = (np.linalg.eigvals(cheb.chebcompanion(_MON2CHEB[:m, :m] @ c)) + 1.0) * 0.5
        real = np.sort(
            roots.real[(np.abs(roots.imag) <= 1e-7) & (roots.real > -1e-9) & (roots.real <= 1.0 + 1e-9)]
        )
        out = []
        tiny = 1e-12
        for r in real:
            r = min(max(float(r), 0.0), 1.0)
            lo, hi = max(r - 1e-7, 0.0), min(r + 1e-7, 1.0)
            v_lo = float(c @ lo ** _DEGREES[:m])
            v_hi = float(c @ hi ** _DEGREES[:m])
            if r <= tiny:
                # A root at the start: at a segment's start a guard at zero is disarmed or taken
                # by the engine; later, a crossing exactly on the boundary of two steps.
                c0 = float(c[0])  # (within 1e-12 of the root: zero to the guard's rounding)
                if stepped and (
                    (direction >= 0 and c0 <= 0.0 < v_hi) or (direction <= 0 and c0 >= 0.0 > v_hi)
                ):
                    out.append(r)
                continue
            rising = v_lo < 0.0 < v_hi or (v_lo <= 0.0 < v_hi and abs(v_lo) <= 1e-15 * mag)
            falling = v_lo > 0.0 > v_hi or (v_lo >= 0.0 > v_hi and abs(v_lo) <= 1e-15 * mag)
            if (direction >= 0 and rising) or (direction <= 0 and falling):
                out.append(r)
        return out

    def _polish(self, z0: np.ndarray, s: float, k: int, h: float) -> float:
        """Newton steps on the exact guard ``W_k expm(M s) z0`` from the polynomial root ``s``."""
        am = self.am
        w = am.W[k]
        wm = w @ am.M
        fl = self.flow
        if fl.eigen:  # z(s) = V exp(L s) V^-1 z0: V^-1 z0 once, no quadratures (only z is needed)
            c = fl.Vinv @ z0
            wv, wmv = w @ fl.V, wm @ fl.V
        for _ in range(3):
            if fl.eigen:
                e = np.exp(fl.lam * s) * c
                val, der = float((wv @ e).real), float((wmv @ e).real)
            else:
                zs = fl.advance(z0, s)[0] if s > 0 else z0
                val, der = float(w @ zs), float(wm @ zs)
            if der == 0.0:
                break
            ds = -val / der
            if abs(ds) > 1e-6 * max(h, 1e-300):
                break
            s_new = min(max(s + ds, 0.0), h)
            if s_new == s:
                break
            s = s_new
        return s

    def step(self, tout: float, tstop: float, *, one_step: bool) -> StepResult:
        """Advance to ``min(tout, tstop)`` (one step of at most ``h`` if ``one_step``), stopping at a crossing.

        Like IDA's normal mode, full steps are taken and the output at
        ``tout`` inside the last one is the exact flow from its start: a step
        is searched for guard roots once, however many outputs fall in it.
        """
        t_end = min(float(tout), float(tstop))
        self._t_call, self._z_call, self._quad_call = self.t, self.z.copy(), self.quad.copy()
        t, z, quad = self.t, self.z, self.quad
        if one_step:
            self._pending = None
        while True:
            pend = self._pending
            if pend is not None and not one_step:
                t_s, z_s, q_s, t_e, z_e, q_e, prep = pend
                if t_e <= t_end:  # the pending step ends before the output: take it
                    t, z, quad = t_e, z_e, q_e
                    self._pending = None
                    self.t, self.z, self.quad = t, z, quad
                    if t >= t_end:
                        break
                    continue
                if t_end > t:  # the output falls inside the pending step: the exact flow from its start
                    if not prep:
                        prep.append(self.flow.prepare(z_s))
                    z, dq = self.flow.advance(z_s, t_end - t_s, prep[0])
                    quad = q_s + dq
                    t = t_end
                    self._fix_forcing(t, z)
                    self.t, self.z, self.quad = t, z, quad
                break
            h = min(self.h, float(tstop) - t)
            if h <= 0.0 or (t >= t_end and not one_step):
                break
            hit = self._first_root(z, h) if self.armed.any() else None
            if hit is not None:
                s, k = hit
                s = self._polish(z, s, k, h)
                z1, q1 = self._advance(z, quad, s)
                t1 = t + s
                self._fix_forcing(t1, z1)
                self.t, self.z, self.quad = t1, z1, q1
                self._pending = None
                return self._result(ROOT, t1, z1, q1, (k,))
            z1, q1 = self._advance(z, quad, h)
            self.nfev_last += 1
            self._stepped = True
            t1 = t + h if t + h < float(tstop) else float(tstop)
            self._fix_forcing(t1, z1)
            if one_step:
                t, z, quad = t1, z1, q1
                self.t, self.z, self.quad = t, z, quad
                break
            self._pending = (t, z, quad, t1, z1, q1, [])
        status = TSTOP if t >= tstop else SUCCESS
        return self._result(status, t, z, quad)

    #: Outputs anywhere in the last step call are exact: the engine need not step to each one.
    dense = True

    def interpolate_many(self, ts: np.ndarray) -> np.ndarray:
        """Exact states at the times ``ts`` [s] (rows) since the start of the last :meth:`step` call."""
        ts = np.asarray(ts, dtype=float)
        s = ts - self._t_call
        am, fl = self.am, self.flow
        if not fl.eigen:
            return np.array([self.interpolate(float(t))[0] for t in ts]).reshape(ts.size, -1)
        c = fl.Vinv @ self._z_call
        e = np.exp(np.outer(s, fl.lam))  # (k, nz)
        Z = ((e * c) @ fl.V.T).real  # rows z(s_i)
        if am.omega is not None:
            k = am.d.size
            Z[:, k] = np.sin(am.omega * ts)
            Z[:, k + 1] = np.cos(am.omega * ts)
        Z[:, -1] = 1.0
        Y = Z @ am.P.T
        if am.q.size:
            nq = am.q.size
            cc = fl.QV * np.outer(c, c)
            mh = fl.mu[None, :, :] * s[:, None, None]
            phi = np.where(
                np.abs(mh) < 1e-3,
                s[:, None, None] * (1.0 + mh * (0.5 + mh * (1.0 / 6.0 + mh / 24.0))),
                (e[:, :, None] * e[:, None, :] - 1.0) / fl._mu_safe[None],
            )
            Y[:, am.q] = self._quad_call[None, :nq] + np.einsum("qjk,ijk->iq", cc, phi).real
        return Y

    def interpolate(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        """Exact state at ``t`` between the start of the last :meth:`step` call and now."""
        s = float(t) - self._t_call
        z, quad = (
            self._advance(self._z_call, self._quad_call, s) if s != 0 else (self._z_call, self._quad_call)
        )
        z = z.copy()
        self._fix_forcing(float(t), z)
        return self.am.state(z, quad), self.am.derivatives(z)


class ExactSensitivity:
    """Fundamental matrices over one affine mode, behind the interface of :class:`hybrid.integrators.ida.SensitivitySolver`.

    ``Y`` is carried over the state indices ``s`` (no quadratures; a free
    parameter last, if any): its differential rows follow the ``d``-block of
    ``expm(M h)``, its slave rows the elimination ``y_a = P_ad y_d + ...``. The
    column of a free parameter ``p`` (``dy(t1)/dp`` at a fixed start state) is
    ``dP z1 + P (dE z0 + E dz0)`` with ``E = expm(M h)``, ``dE`` its Frechet
    derivative in the direction ``dM`` (:meth:`Flow.frechet`, from the same
    eigen-decomposition), ``dz0`` the forcing phase's derivative; ``dM`` and
    ``dP`` are central differences of the assembled matrices at ``p +- delta``
    (``am_pm``, no decomposition there): exact where they are linear in ``p``
    (a forcing frequency), else with an error about ``delta**2``.

    Parameters
    ----------
    am : AffineMode
    s : ndarray of int
        Indices of the sensitivity matrix (state variables; free parameters after them).
    am_pm : (AffineMode, AffineMode, float), optional
        The mode at ``p + delta`` and ``p - delta``, and ``delta``.
    """

    def __init__(self, am: AffineMode, s: np.ndarray, am_pm: tuple | None = None):
        self.am = am
        s = [int(i) for i in s]
        n = am.P.shape[0]
        self.n = n
        self.pos_d = np.array([s.index(int(i)) for i in am.d], dtype=int)
        self.pos_a = np.array([s.index(int(i)) for i in am.a], dtype=int)
        self.pos_p = np.array([k for k, i in enumerate(s) if i >= n], dtype=int)
        self.rows = np.array([k for k, i in enumerate(s) if i < n], dtype=int)  # state rows of Y
        self.state_idx = np.array([i for i in s if i < n], dtype=int)
        nd = am.d.size
        self.P_ad = am.P[am.a][:, :nd]
        self.ns = len(s)
        self.am_pm = am_pm
        self.nfev = 0
        self._cache: dict[float, np.ndarray] = {}

    def _column(self, t0: float, y0: np.ndarray, h: float) -> np.ndarray:
        """``dy(t0 + h)/dp`` at a fixed start ``(t0, y0)`` over the state indices."""
        am = self.am
        plus, minus, delta = self.am_pm
        fl = am.flow()
        z0 = am.augment(t0, y0)
        dz0 = np.zeros_like(z0)
        if am.omega is not None:  # the forcing phase w t0 of the start
            dw = (plus.omega - minus.omega) / (2.0 * delta)
            k = am.d.size
            dz0[k] = t0 * math.cos(am.omega * t0) * dw
            dz0[k + 1] = -t0 * math.sin(am.omega * t0) * dw
        dM = (plus.M - minus.M) / (2.0 * delta)
        dP = (plus.P - minus.P) / (2.0 * delta)
        E = fl.matrix(h)
        z1 = E @ z0
        dz1 = fl.frechet(h, dM) @ z0 + E @ dz0
        return (dP @ z1 + am.P @ dz1)[self.state_idx]

    def propagate(
        self, t0: float, y0: np.ndarray, Y0: np.ndarray, t1: float, budget=None
    ) -> tuple[None, np.ndarray]:
        """``Y(t1)`` from ``Y(t0)`` (the state is needed only for a parameter column)."""
        h = float(t1) - float(t0)
        E = self._cache.get(h)
        if E is None:
            nd = self.am.d.size
            E = self.am.flow().matrix(h)[:nd, :nd]
            if len(self._cache) > 256:
                self._cache.clear()
            self._cache[h] = E
        Y0 = np.asarray(Y0)
        Yd = E @ Y0[self.pos_d]
        Y = np.zeros((self.ns, Y0.shape[1]))
        Y[self.pos_d] = Yd
        if self.pos_a.size:
            Y[self.pos_a] = self.P_ad @ Yd
        if self.pos_p.size:
            col = self._column(float(t0), np.asarray(y0, dtype=float)[: self.n], h)
            Y[self.rows] += np.outer(col, Y0[self.pos_p[0]])
            Y[self.pos_p] = Y0[self.pos_p]
        self.nfev += 1
        return None, Y
