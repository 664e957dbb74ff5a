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

:class:`ExactModeSolver` offers the interface of :class:`hybrid._dae.ModeSolver`
(``start``, ``step``, ``interpolate``, ``armed``, ``safe``), so the event loop of
:func:`hybrid.simulate` (switch location, resets, chains, Zeno) is the same for
both integrators. :func:`affine_mode` refuses a non-affine mode naming the first
non-affine term.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.polynomial import chebyshev as cheb

from ._compiled import CompiledMode, CompiledSystem
from ._dae import ROOT, SUCCESS, TSTOP, StepResult
from ._expr import Expr, ExpressionError, compile_scalar, diff, postorder, replace_nodes, sym, to_string
from ._expr import add as e_add
from ._expr import mul as e_mul
from ._expr import num as e_num

__all__ = ["NotAffineError", "AffineMode", "affine_mode", "affine_system", "ExactModeSolver", "TAYLOR_DEGREE"]

#: Degree of the Taylor polynomial of a guard along one step (steps are sized so that it is exact to rounding).
TAYLOR_DEGREE = 24
_S, _C = "__sin_wt", "__cos_wt"


class NotAffineError(ExpressionError):
    """A mode is not affine in its state (or time enters otherwise than through one forcing frequency)."""


@dataclass
class AffineMode:
    """One mode as an exact linear flow of the augmented state ``z = [y_d, S, C, 1]``.

    Attributes
    ----------
    cm : CompiledMode
        The compiled mode (its closures give outputs and consistent derivatives).
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

    cm: CompiledMode
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
        """The mode's :class:`Flow` (built on first use)."""
        f = self.__dict__.get("_flow")
        if f is None:
            f = self.__dict__["_flow"] = Flow(self.M, self.Q)
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


def _phase_nodes(exprs: list[Expr], where: str) -> tuple[float | None, dict[Expr, Expr]]:
    """Replacements of the ``sin``/``cos`` terms of the time by the symbols ``S``, ``C``; the frequency."""
    omega: float | None = None
    mapping: dict[Expr, Expr] = {}
    for node in postorder(exprs):
        if node.op != "call" or "t" not in node.free:
            continue
        fname, arg = node.args
        if fname not in ("sin", "cos") or arg.free != {"t"}:
            raise NotAffineError(
                f"{where}: time enters through `{to_string(node, 80)}`; the exact integrator allows time only "
                "in sin/cos of one forcing frequency times t (plus a phase)"
            )
        k = diff(arg, "t")
        if k.op != "num" or k.args[0] == 0.0:
            raise NotAffineError(f"{where}: `{to_string(node, 80)}` is not sin/cos of (constant * t + phase)")
        kv = k.args[0]
        phi = compile_scalar(arg, {"t": 0}, {})([0.0])
        if omega is None:
            omega = abs(kv)
        elif not math.isclose(abs(kv), omega, rel_tol=1e-15):
            raise NotAffineError(
                f"{where}: two forcing frequencies ({omega!r} and {abs(kv)!r} rad/s); the exact integrator "
                "handles one"
            )
        s, c = sym(_S), sym(_C)
        sg = 1.0 if kv > 0 else -1.0
        # sin(sg w t + phi) = cos(phi) sg S + sin(phi) C;  cos(sg w t + phi) = cos(phi) C - sin(phi) sg S
        if fname == "sin":
            rep = e_add(e_mul(e_num(sg * math.cos(phi)), s), e_mul(e_num(math.sin(phi)), c))
        else:
            rep = e_add(e_mul(e_num(math.cos(phi)), c), e_mul(e_num(-sg * math.sin(phi)), s))
        mapping[node] = rep
    return omega, mapping


def _coefficients(e: Expr, symbols: list[str], where: str) -> tuple[np.ndarray, float]:
    """``(gradient, constant)`` of an expression affine in ``symbols``; NotAffineError otherwise."""
    extra = e.free - set(symbols)
    if extra:
        name = sorted(extra)[0]
        raise NotAffineError(f"{where} depends on `{name}` otherwise than affinely through sin/cos of t")
    grad = np.zeros(len(symbols))
    for j, s in enumerate(symbols):
        if s not in e.free:
            continue
        g = diff(e, s)
        if g.op != "num":
            shown = {_S: "sin(w t)", _C: "cos(w t)"}.get(s, s)
            raise NotAffineError(
                f"{where} is not affine in `{shown}`: its derivative is `{to_string(g, 120)}`".replace(
                    _S, "sin(w t)"
                ).replace(_C, "cos(w t)")
            )
        grad[j] = g.args[0]
    const = compile_scalar(e, {s: i for i, s in enumerate(symbols)}, {})([0.0] * len(symbols))
    return grad, float(const)


def _quadratic(e: Expr, symbols: list[str], where: str) -> np.ndarray:
    """``Q`` with ``e = u^T Q u``, ``u = [symbols, 1]``, for a quadratic ``e``; NotAffineError otherwise."""
    n = len(symbols)
    Q = np.zeros((n + 1, n + 1))
    grad0 = np.zeros(n)
    slots = {s: i for i, s in enumerate(symbols)}
    zero = [0.0] * n
    for j, s in enumerate(symbols):
        if s not in e.free:
            continue
        g = diff(e, s)
        grad0[j] = compile_scalar(g, slots, {})(zero)
        for k in range(j, n):
            if symbols[k] not in g.free:
                continue
            h = diff(g, symbols[k])
            if h.op != "num":
                raise NotAffineError(f"{where} is not quadratic in the state: `{to_string(h, 120)}`")
            Q[j, k] = Q[k, j] = 0.5 * h.args[0]
    extra = e.free - set(symbols)
    if extra:
        raise NotAffineError(f"{where} depends on `{sorted(extra)[0]}` otherwise than through sin/cos of t")
    Q[:n, n] = Q[n, :n] = 0.5 * grad0
    Q[n, n] = compile_scalar(e, slots, {})(zero)
    return Q


def affine_mode(cm: CompiledMode, quadratures: tuple[str, ...]) -> AffineMode:
    """Analyse one compiled mode as an exact linear flow (see the module notes).

    Raises
    ------
    NotAffineError
        Naming the mode, the equation and the first non-affine term.
    """
    where = f"mode `{cm.name}`"
    names = list(cm.names)
    qset = {names.index(q) for q in quadratures if q in names}
    d = np.array([i for i in cm.diff_idx if i not in qset], dtype=int)
    a = np.array(cm.alg_idx, dtype=int)
    q = np.array(sorted(qset), dtype=int)
    exprs = [cm.f_expr[i] for i in cm.diff_idx] + [cm.g_expr[i] for i in a] + [g.expr for g in cm.guards]
    omega, mapping = _phase_nodes(exprs, where)

    def sub(e: Expr) -> Expr:
        return replace_nodes(e, mapping) if mapping else e

    forcing = [_S, _C] if omega is not None else []
    symbols = names + forcing  # u = [y (all), S, C]
    n, nf = len(names), len(forcing)
    nu = n + nf

    def affine(e: Expr, what: str) -> np.ndarray:
        grad, const = _coefficients(sub(e), symbols, f"{where}: {what}")
        return np.concatenate([grad, [const]])  # row over [u, 1]

    F = np.array([affine(cm.f_expr[i], f"derivative of `{names[i]}`") for i in d]).reshape(len(d), nu + 1)
    G = np.array([affine(cm.g_expr[i], f"algebraic equation of `{names[i]}`") for i in a]).reshape(
        len(a), nu + 1
    )
    # u over z = [y_d, S, C, 1]: differential rows are z, slave rows from the algebraic equations.
    nz = len(d) + nf + 1
    Pu = np.zeros((nu + 1, nz))
    Pu[d, np.arange(len(d))] = 1.0
    Pu[n + np.arange(nf), len(d) + np.arange(nf)] = 1.0
    Pu[nu, nz - 1] = 1.0
    if a.size:
        Ga = G[:, a]
        if np.linalg.matrix_rank(Ga) < a.size:
            raise NotAffineError(f"{where}: the algebraic equations are singular in the slave variables")
        rest = Pu.copy()
        rest[a, :] = 0.0
        Pu[a, :] = -np.linalg.solve(Ga, G @ rest)
    if any(Pu[i].any() for i in q):  # pragma: no cover - quadratures never enter equations
        raise NotAffineError(f"{where}: a quadrature enters the equations")
    M = np.zeros((nz, nz))
    M[: len(d)] = F @ Pu
    if omega is not None:
        k = len(d)
        M[k, k + 1] = omega  # S' = w C
        M[k + 1, k] = -omega  # C' = -w S
    P = Pu[:n]
    Qs = []
    for i in q:
        Qu = _quadratic(sub(cm.f_expr[i]), symbols, f"{where}: derivative of quadrature `{names[i]}`")
        Qs.append(Pu.T @ Qu @ Pu)
    W = np.array([affine(g.expr, f"guard `{g.name}`") @ Pu for g in cm.guards]).reshape(len(cm.guards), nz)
    return AffineMode(cm, omega, d, a, q, M, P, np.array(Qs).reshape(len(q), nz, nz), W)


def affine_system(cs: CompiledSystem) -> list[AffineMode]:
    """Every mode of a compiled system as an exact flow, all with one forcing frequency.

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
    quads = tuple(cs.system.quadratures)
    out = [affine_mode(cm, quads) for cm in cs.modes]
    freqs = {m.omega for m in out if m.omega is not None}
    if len(freqs) > 1:
        raise NotAffineError(f"modes are forced at different frequencies: {sorted(freqs)}")
    return out


# ----------------------------------------------------------------------------
# Propagation
# ----------------------------------------------------------------------------
#: Largest condition number of the eigenvector matrix for the eigen-decomposition path of a flow.
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


class Flow:
    """The exact flow ``z(h) = expm(M h) z`` of one affine mode, and its quadratures.

    Where ``M`` has a well-conditioned eigenvector basis (condition number at
    most :data:`EIGEN_COND`), ``expm(M h) = V exp(L h) V^-1`` costs a few
    matrix-vector products for any ``h``; otherwise (a defective ``M``, e.g.
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
            lam, V = np.linalg.eig(M)
            if np.linalg.cond(V) <= EIGEN_COND:
                self.lam, self.V, self.Vinv = lam, V, np.linalg.inv(V)
                # quadratures in the eigenbasis: int z^T Q z = c^T (V^T Q V o Phi(h)) c, c = V^-1 z
                self.QV = np.array([V.T @ Qj @ V for Qj in Q]).reshape(len(Q), self.nz, self.nz)
                self.mu = lam[:, None] + lam[None, :]
                self.eigen = True
        except np.linalg.LinAlgError:  # pragma: no cover - eig of a finite matrix
            pass

    def matrix(self, h: float) -> np.ndarray:
        """``expm(M h)``."""
        if self.eigen:
            return ((self.V * np.exp(self.lam * h)) @ self.Vinv).real
        return matrix_exp(self.M * h)

    def advance(self, z: np.ndarray, h: float) -> tuple[np.ndarray, np.ndarray]:
        """``(z(h), q(h) - q(0))`` from ``z``."""
        nq = self.Q.shape[0]
        if self.eigen:
            c = self.Vinv @ z
            z1 = (self.V @ (np.exp(self.lam * h) * c)).real
            if not nq:
                return z1, np.zeros(0)
            mh = self.mu * h
            small = np.abs(mh) < 1e-3
            phi = np.where(small, h * (1 + mh / 2 + mh * mh / 6 + mh**3 / 24), 0j)
            big = ~small
            phi[big] = (np.exp(mh[big]) - 1.0) / self.mu[big]
            cc = np.outer(c, c) * phi
            return z1, np.real(np.einsum("qjk,jk->q", self.QV, cc))
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


class ExactModeSolver:
    """The exact flow of one affine mode, behind the interface of :class:`hybrid._dae.ModeSolver`.

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
        # Taylor rows of every guard, T[g, j] = W_g M^j / j!, and a few beyond the degree kept.
        K, extra = TAYLOR_DEGREE, 8
        T = np.zeros((ng, K + 1 + extra, nz))
        row = am.W.copy()
        for j in range(K + 1 + extra):
            T[:, j, :] = row
            row = row @ am.M / (j + 1)
        # Step length: the guards' Taylor tails beyond the degree are below rounding on a step.
        norms = np.max(np.abs(T).sum(axis=2), axis=0) if ng else np.zeros(K + 1 + extra)
        h = float(max_step)
        while ng and h > 0:
            powers = h ** np.arange(K + 1 + extra)
            if np.sum(norms[K + 1 :] * powers[K + 1 :]) <= 1e-17 * np.sum(norms[: K + 1] * powers[: K + 1]):
                break
            h *= 0.5
        self.h = h
        self.flow = am.flow()
        self._T = T[:, : K + 1, :]
        # Exclusion test on a grid: |p| at the nodes against the derivative bound.
        self._grid = np.linspace(0.0, 1.0, 17)
        self._vander = self._grid[:, None] ** np.arange(K + 1)[None, :]
        self._dT = None
        self.t = 0.0
        self.z = np.zeros(nz)
        self.quad = np.zeros(am.q.size)
        self._t_call = 0.0
        self._z_call = self.z
        self._quad_call = self.quad

    # ------------------------------------------------------------------
    def _advance(self, z: np.ndarray, quad: np.ndarray, h: float) -> tuple[np.ndarray, np.ndarray]:
        if h == 0.0:
            return z.copy(), quad.copy()
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
        yp = self.mode.derivatives(t, y)
        return StepResult(status, t, y, yp, tuple(fired), message)

    def start(self, t: float, y: np.ndarray, yp: np.ndarray) -> None:
        """Start at a consistent point ``(t, y)`` (``yp`` is not needed)."""
        self.t = float(t)
        self.z = self.am.augment(t, y)
        self.quad = np.asarray(y, dtype=float)[self.am.q].copy()
        self._t_call, self._z_call, self._quad_call = self.t, self.z.copy(), self.quad.copy()
        self.nfev_last = self.njev_last = 0

    def _first_root(self, z: np.ndarray, h: float) -> tuple[float, int] | None:
        """Earliest crossing in ``(0, h]`` of an armed guard in its direction: ``(s, guard)``."""
        best = None
        coef_all = self._T @ z  # (ng, K+1): Taylor coefficients at the step's start
        scale = h ** np.arange(TAYLOR_DEGREE + 1)
        for k in np.flatnonzero(self.armed):
            c = coef_all[k] * scale  # polynomial in s/h on [0, 1]
            mag = float(np.sum(np.abs(c)))
            if mag == 0.0:
                continue
            # cannot vanish on [0, 1]: |p| at 17 nodes exceeds what its slope bound allows in between
            dbound = float(np.sum(np.arange(c.size) * np.abs(c)))
            if np.min(np.abs(self._vander @ c)) > 0.5 * dbound / (self._grid.size - 1):
                continue
            for r in self._crossings(c, self.am.cm.guards[k].direction, mag):
                if best is None or r < best[0]:
                    best = (r, int(k))
                break  # crossings come sorted: the first counts
        if best is None:
            return None
        return best[0] * h, best[1]

    @staticmethod
    def _crossings(c: np.ndarray, direction: int, mag: float) -> list[float]:
        """Sign changes of the polynomial ``c`` (monomial, variable in [0, 1]) in (0, 1], sorted."""
        keep = np.flatnonzero(np.abs(c) > 1e-17 * mag)
        c = c[: keep[-1] + 1] if keep.size else c[:1]
        if c.size < 2:
            return []
        roots = np.polynomial.Polynomial(c).convert(kind=cheb.Chebyshev, domain=[0.0, 1.0]).roots()
        real = np.sort(
            roots.real[(np.abs(roots.imag) <= 1e-7) & (roots.real > -1e-9) & (roots.real <= 1.0 + 1e-9)]
        )
        out = []
        tiny = 1e-12
        for r in real:
            r = min(max(float(r), 0.0), 1.0)
            lo, hi = max(r - 1e-7, 0.0), min(r + 1e-7, 1.0)
            v_lo = np.polynomial.polynomial.polyval(lo, c)
            v_hi = np.polynomial.polynomial.polyval(hi, c)
            if r <= tiny:
                continue  # a root at the start belongs to the previous step (or is disarmed)
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
        for _ in range(3):
            zs = self.flow.advance(z0, s)[0] if s > 0 else z0
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
        """Advance to ``min(tout, tstop)`` (one step of at most ``h`` if ``one_step``), stopping at a crossing."""
        t_end = min(float(tout), float(tstop))
        self._t_call, self._z_call, self._quad_call = self.t, self.z.copy(), self.quad.copy()
        t, z, quad = self.t, self.z, self.quad
        while True:
            h = min(self.h, t_end - t)
            if h <= 0.0:
                break
            hit = self._first_root(z, h) if self.armed.any() else None
            if hit is not None:
                s, k = hit
                s = self._polish(z, s, k, h)
                z1, q1 = self._advance(z, quad, s)
                t1 = t + s
                self._fix_forcing(t1, z1)
                self.t, self.z, self.quad = t1, z1, q1
                return self._result(ROOT, t1, z1, q1, (k,))
            z1, q1 = self._advance(z, quad, h)
            self.nfev_last += 1
            t1 = t + h if t + h < t_end else t_end
            self._fix_forcing(t1, z1)
            t, z, quad = t1, z1, q1
            self.t, self.z, self.quad = t, z, quad
            if one_step:
                break
        status = TSTOP if t >= tstop else SUCCESS
        return self._result(status, t, z, quad)

    def interpolate(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        """Exact state at ``t`` between the start of the last :meth:`step` call and now."""
        s = float(t) - self._t_call
        z, quad = (
            self._advance(self._z_call, self._quad_call, s) if s != 0 else (self._z_call, self._quad_call)
        )
        z = z.copy()
        self._fix_forcing(float(t), z)
        y = self.am.state(z, quad)
        return y, self.mode.derivatives(float(t), y)


class ExactSensitivity:
    """Fundamental matrices over one affine mode, behind the interface of :class:`hybrid._dae.SensitivitySolver`.

    ``Y`` is carried over the state indices ``s`` (no quadratures; a free
    parameter last, if any): its differential rows follow the ``d``-block of
    ``expm(M h)``, its slave rows the elimination ``y_a = P_ad y_d + ...``. The
    column of a free parameter ``p`` (``dy(t1)/dp`` at a fixed start state) is
    the central difference of the exact flows at ``p +- delta`` (``am_pm``):
    the flows are exact, so its error is that of the difference alone
    (about ``delta**2``, 1e-12 relative for ``delta = 1e-6 |p|``).

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

    def _flow(self, am: AffineMode, t0: float, y0: np.ndarray, h: float) -> np.ndarray:
        z = am.flow().advance(am.augment(t0, y0), h)[0]
        return am.P[self.state_idx] @ z

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
            plus, minus, delta = self.am_pm
            yb = np.asarray(y0, dtype=float)[: self.n]
            col = (self._flow(plus, t0, yb, h) - self._flow(minus, t0, yb, h)) / (2.0 * delta)
            Y[self.rows] += np.outer(col, Y0[self.pos_p[0]])
            Y[self.pos_p] = Y0[self.pos_p]
        self.nfev += 1
        return None, Y
