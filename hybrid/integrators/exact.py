"""The exact integrator for affine modes: guard roots of the exact flow, and its sensitivities.

With a mode's exact linear flow (:mod:`hybrid.integrators.affine`, :mod:`hybrid.integrators.flow`),
a guard is a linear function ``h = w_h . z`` of the augmented state, so its value along a step
is ``w_h expm(M s) z``, an entire function whose Taylor series at the step's start is known
(``w_h M^j z / j!``); steps are short enough (``|M| h`` bounded) that the series truncated at
degree :data:`TAYLOR_DEGREE` equals it to rounding, and its real roots in the step are all found
as the roots of that polynomial (Chebyshev basis), so two crossings within one step are never
missed; each root is polished by Newton steps on the exact flow. The fundamental matrix of
``y_d`` over a step is the ``d``-block of ``expm(M h)``.

:class:`ExactModeSolver` offers the interface of :class:`hybrid.integrators.ida.ModeSolver`
(the contract of :mod:`hybrid.integrators.base`), so the event loop of :func:`hybrid.simulate`
(switch location, resets, chains, Zeno) is the same for both integrators;
:class:`Exact` is the method as a whole (``SolverOptions(method=Exact())``).
"""

from __future__ import annotations

from dataclasses import dataclass
from math import comb
from typing import TYPE_CHECKING

import numpy as np
from numpy.polynomial import chebyshev as cheb

from ..core.errors import InputError, InputTypeError, NotAffineError
from ..core.options import check_positive, plain_number
from ..model.compiled import CompiledSystem
from ..model.system import HybridSystem
from .affine import AffineMode, affine_flows
from .assembly import ComposedFlows, SparseAffineMode
from .base import ROOT, SUCCESS, TSTOP, Method, StepResult
from .flows import exact_flows

if TYPE_CHECKING:
    from .options import SolverOptions

__all__ = ["Exact", "ExactModeSolver", "ExactSensitivity", "ExactVariational", "TAYLOR_DEGREE"]

#: Degree of the Taylor polynomial of a guard along one step (steps are sized so that it is exact to rounding).
TAYLOR_DEGREE = 24


# ----------------------------------------------------------------------------
# Propagation
# ----------------------------------------------------------------------------


def _bernstein_matrix(pieces: int, degree: int) -> np.ndarray:
    """The linear map from monomial coefficients on [0, 1] to the Bernstein coefficients of the same
    polynomial on each of ``pieces`` equal subintervals, stacked: shape (pieces * (degree + 1),
    degree + 1). Where every Bernstein coefficient of a piece has one strict sign the polynomial
    has that sign on the whole piece (it is a convex combination of them)."""
    K = degree
    to_bern = np.array(
        [[comb(i, j) / comb(K, j) if j <= i else 0.0 for j in range(K + 1)] for i in range(K + 1)]
    )
    rows = []
    for m in range(pieces):
        u, w = m / pieces, 1.0 / pieces
        # p(u + w s) = sum_j a_j (u + w s)^j: its monomial coefficients in s
        shift = np.zeros((K + 1, K + 1))
        for j in range(K + 1):
            for i in range(j + 1):
                shift[i, j] = comb(j, i) * u ** (j - i) * w**i
        rows.append(to_bern @ shift)
    return np.vstack(rows)


#: Subintervals of a step on which a guard's Bernstein coefficients are looked at.
BERNSTEIN_PIECES = 4
_BERNSTEIN = _bernstein_matrix(BERNSTEIN_PIECES, TAYLOR_DEGREE)

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
        self.h, T = am.guard_taylor_rows(float(max_step), TAYLOR_DEGREE)
        self._T = T
        self.flow = am.flow()
        self._direction = [int(d) for d in am.cm.guard_directions]
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
            z[k : k + 2 * len(am.harmonics)] = am.forcing(t)
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
        C = self._guard_coefficients(z) * scale  # (ng, K+1): guards as polynomials in s/h on [0, 1]
        A = np.abs(C)
        mag = A.sum(axis=1)
        a0 = A[:, 0]
        back = self._return(C, mag)  # a disarmed guard's crossing after it has left zero
        if np.all((a0 > mag - a0) | ~self.armed):
            return None if back is None else (back[0] * h, back[1])  # (no armed guard can vanish)
        # cannot vanish on [0, 1]: |p| at 17 nodes exceeds what its slope bound allows in between
        near = np.abs(C @ _VANDER.T).min(axis=1) <= (0.5 / (_GRID.size - 1)) * (A @ _DEGREES)
        cand = np.flatnonzero(self.armed & near & (mag > 0.0))
        first = np.zeros(cand.size, dtype=int)
        if cand.size:
            # and not where its Bernstein coefficients keep one strict sign on every piece of the step
            # (a bound on |p| from below: no root there; 1e-13 of the coefficients' size covers rounding)
            B = (C[cand] @ _BERNSTEIN.T).reshape(cand.size, BERNSTEIN_PIECES, -1)
            tol = 1e-13 * mag[cand][:, None, None]
            signed = np.all(B > tol, axis=2) | np.all(B < -tol, axis=2)  # (cand, piece)
            keep = ~np.all(signed, axis=1)
            cand, signed = cand[keep], signed[keep]
            first = np.argmin(signed, axis=1)  # the first piece where a root may lie
        best = None
        for k, piece in sorted(zip(cand.tolist(), first.tolist(), strict=True), key=lambda kp: kp[1]):
            if best is not None and best[0] < piece / BERNSTEIN_PIECES:
                break  # this guard and the rest cannot cross before the crossing found
            for r in self._crossings(C[k], self._direction[k], float(mag[k]), self._stepped):
                if best is None or r < best[0]:
                    best = (r, int(k))
                break  # crossings come sorted: the first counts
        if back is not None and (best is None or back[0] < best[0]):
            best = back
        if best is None:
            return None
        return best[0] * h, best[1]

    #: A disarmed guard has left zero where its value on its safe side exceeds this fraction of its
    #: polynomial's size on the step (rounding of the polynomial's value is about 1e-16 of it).
    LEFT_ZERO = 1e-12

    def _return(self, C: np.ndarray, mag: np.ndarray) -> tuple[float, int] | None:
        """The earliest crossing ``(s / h, guard)`` in its direction of a disarmed guard after it has
        left zero towards its safe side (by :data:`LEFT_ZERO` of its size), from the exact polynomial
        on the step, or None.

        The engine disarms a guard that starts at zero and leaves it towards its safe side (a stop
        guard after a reversal of the slip), and arms it again only at a step's end beyond its noise
        level; a phase shorter than a step ended within the step, and its crossing was located
        afterwards on the interpolant with a warning (about 370 on the tutorial's frequency
        response, issue 30). The exact polynomial finds it as any other crossing.
        """
        best = None
        for k in np.flatnonzero(~self.armed & (self.safe != 0.0) & (mag > 0.0)).tolist():
            sigma = float(self.safe[k])
            c = C[k]
            lift = sigma * c
            lift[0] -= self.LEFT_ZERO * mag[k]
            if lift[0] > 0.0:
                left = 0.0
            else:
                ups = self._crossings(lift, 1, float(mag[k]))
                if not ups:
                    continue
                left = ups[0]
            for r in self._crossings(c, self._direction[k], float(mag[k])):
                if r > left:
                    if best is None or r < best[0]:
                        best = (r, int(k))
                    break
        return best

    def _guard_coefficients(self, z: np.ndarray) -> np.ndarray:
        """``W_g M^j z / j!`` for every guard ``g`` and ``j <= TAYLOR_DEGREE``, shape (ng, K+1)."""
        return self._T @ z

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
                # A guard strictly on its safe side there is armed beyond its noise band (the
                # engine's, at rounding for this flow): a crossing that short is a real one.
                c0 = float(c[0])
                if (direction >= 0 and c0 < 0.0 < v_hi) or (direction <= 0 and c0 > 0.0 > v_hi):
                    out.append(r)
                elif stepped and (
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
            Z[:, k : k + 2 * len(am.harmonics)] = am.forcing_columns(ts)
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


#: Largest ``||M h||`` (infinity norm) of a step of :class:`TaylorModeSolver`: the Taylor series
#: of the flow truncated at degree :data:`TAYLOR_DEGREE` then equals it to rounding
#: (``1.5**25 / 25! < 1e-21``).
TAYLOR_THETA = 1.5


class TaylorModeSolver(ExactModeSolver):
    """The exact flow of one affine mode of a large system, by its Taylor series on short steps.

    Where the augmented state is large (a system of many contacts) the generator ``M`` is
    sparse and an eigen-decomposition per mode would cost ``O(nz^3)``. Here a step of length
    ``h <= TAYLOR_THETA / ||M||_inf`` takes the coefficients ``c_j = M^j z / j!``
    (``j <= TAYLOR_DEGREE``, sparse products): the flow ``z(s) = sum_j c_j s^j`` and the guards
    ``W c_j`` as polynomials in ``s`` equal the exact ones to rounding, so crossings are found as
    by :class:`ExactModeSolver` (the same root search), the state at any time of the step is the
    polynomial's value, and the quadratures are the integrals of ``z^T Q z`` of the series.
    Nothing is decomposed: a mode costs its assembly, a step ``O(TAYLOR_DEGREE * nnz(M))``.

    Parameters
    ----------
    am : SparseAffineMode
    max_step : float
        Upper bound of a step [s].
    """

    def __init__(self, am, *, max_step: float):
        self.am = am
        self.mode = am.cm
        ng = am.W.shape[0]
        self.armed = np.ones(ng, dtype=bool)
        self.safe = np.zeros(ng)
        self.nfev_last = 0
        self.njev_last = 0
        nz = am.nz
        norm = float(np.max(np.abs(am.M).sum(axis=1))) if nz else 0.0
        self.h = float(max_step) if norm == 0.0 else min(float(max_step), TAYLOR_THETA / norm)
        self.flow = _TaylorFlow(am, self.h)
        self._direction = [int(d) for d in am.cm.guard_directions]
        self._scales: dict[float, np.ndarray] = {}
        self.t = 0.0
        self.z = np.zeros(nz)
        self.quad = np.zeros(am.q.size)
        self._t_call = 0.0
        self._z_call = self.z
        self._quad_call = self.quad
        self._pending = None
        self._stepped = False

    def _guard_coefficients(self, z: np.ndarray) -> np.ndarray:
        return np.asarray(self.am.W @ self.flow.prepare(z).T)

    def _advance(self, z: np.ndarray, quad: np.ndarray, h: float) -> tuple[np.ndarray, np.ndarray]:
        if h == 0.0:
            return z.copy(), quad.copy()
        z1, dq = self.flow.advance(z, h)
        return z1, quad + dq

    def _polish(self, z0: np.ndarray, s: float, k: int, h: float) -> float:
        """Newton steps on the guard's polynomial (exact on the step) from its root ``s``."""
        cols, w = self.am.guard_row(k)
        c = self.flow.prepare(z0)[:, cols] @ w  # W_k c_j
        powers = np.arange(c.size)
        dc = c[1:] * powers[1:]
        for _ in range(3):
            val = float(np.polynomial.polynomial.polyval(s, c))
            der = float(np.polynomial.polynomial.polyval(s, dc))
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

    def interpolate_many(self, ts: np.ndarray) -> np.ndarray:
        """Exact states at the times ``ts`` [s] (increasing) since the start of the last :meth:`step`
        call: the series from the start of each step of at most ``h`` they fall in (the exact flow
        does not depend on how its time is cut)."""
        ts = np.asarray(ts, dtype=float)
        am = self.am
        out = np.empty((ts.size, am.P.shape[0]))
        t, z, quad = self._t_call, self._z_call.copy(), self._quad_call.copy()
        i = 0
        while i < ts.size:
            j = int(np.searchsorted(ts, t + self.h, side="right"))
            if j > i:
                Z, dQ = self.flow.evaluate(z, ts[i:j] - t)
                if am.omega is not None:
                    k = am.d.size
                    Z[:, k : k + 2 * len(am.harmonics)] = am.forcing_columns(ts[i:j])
                Z[:, -1] = 1.0
                Y = np.asarray(am.P @ Z.T).T
                if am.q.size:
                    Y[:, am.q] = quad[None, :] + dQ
                out[i:j] = Y
                i = j
            if i < ts.size:
                z, dq = self.flow.advance(z, self.h)
                quad = quad + dq
                t = t + self.h
                self._fix_forcing(t, z)
        return out


class _TaylorFlow:
    """The flow of a (sparse) affine mode by its Taylor series (see :class:`TaylorModeSolver`)."""

    eigen = False

    def __init__(self, am, h: float):
        self.am = am
        self.h = h
        self._z = None
        self._C = None

    def prepare(self, z: np.ndarray) -> np.ndarray:
        """The coefficients ``c_j = M^j z / j!`` as rows, shape (K+1, nz) (kept for the last ``z``)."""
        if self._z is not None and self._z.shape == z.shape and np.array_equal(self._z, z):
            return self._C
        M = self.am.M
        C = np.empty((TAYLOR_DEGREE + 1, z.size))
        c = np.array(z, dtype=float)
        for j in range(TAYLOR_DEGREE + 1):
            C[j] = c
            c = (M @ c) / (j + 1)
        self._z, self._C = np.array(z, dtype=float), C
        return C

    def evaluate(self, z: np.ndarray, s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``z(s_i)`` (rows) and the quadratures' increments at ``0 <= s_i <= h``."""
        C = self.prepare(z)
        V = np.asarray(s, dtype=float)[:, None] ** np.arange(TAYLOR_DEGREE + 1)[None, :]
        Z = V @ C
        am = self.am
        if not am.q.size:
            return Z, np.zeros((V.shape[0], 0))
        K = TAYLOR_DEGREE + 1
        degs = np.arange(K)[:, None] + np.arange(K)[None, :] + 1  # of s in the integral of c_j s^j c_k s^k
        dQ = np.empty((V.shape[0], am.q.size))
        for q, Qj in enumerate(am.Q):
            G = C @ np.asarray(Qj @ C.T)  # (K, K): c_j^T Q c_k
            coef = np.zeros(2 * K)
            np.add.at(coef, degs.ravel(), (G / degs).ravel())
            dQ[:, q] = np.polynomial.polynomial.polyval(np.asarray(s, dtype=float), coef)
        return Z, dQ

    def advance(self, z: np.ndarray, h: float, prep=None) -> tuple[np.ndarray, np.ndarray]:
        """``(z(h), q(h) - q(0))`` for ``0 <= h <= self.h``."""
        Z, dQ = self.evaluate(z, np.array([h]))
        return Z[0], dQ[0]


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
        at = {i: k for k, i in enumerate(s)}  # not s.index per variable: O(n^2) in a large system
        self.pos_d = np.array([at[int(i)] for i in am.d], dtype=int)
        self.pos_a = np.array([at[int(i)] for i in am.a], dtype=int)
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
        if am.omega is not None:  # the forcing phases n w t0 of the start
            dw = (plus.omega - minus.omega) / (2.0 * delta)
            k = am.d.size
            dz0[k : k + 2 * len(am.harmonics)] = am.forcing_rate(t0, dw)
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
        Y0 = np.asarray(Y0)
        if self.am_pm is None and isinstance(self.am, SparseAffineMode):  # no dense flow (issue 32)
            Yd = self.am.propagate_d(h, Y0[self.pos_d])
        else:
            E = self._cache.get(h)
            if E is None:
                nd = self.am.d.size
                E = self.am.flow().matrix(h)[:nd, :nd]
                if len(self._cache) > 256:
                    self._cache.clear()
                self._cache[h] = E
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


class ExactVariational:
    """The exact flows' variational solvers of one compiled system's modes (one
    :class:`ExactSensitivity` per mode, for one value of the free parameters at a time; see
    :meth:`Exact.variational`).

    The flows come from the system's parametric affine analysis (microseconds per parameter
    set); the column of a free parameter is the Frechet derivative of the exact flow, with the
    matrices' derivatives by central differences at ``p +- delta``.
    """

    def __init__(self, cs: CompiledSystem, s: np.ndarray):
        self.cs, self.s = cs, s
        self._key: tuple | None = None
        self._modes: dict[int, ExactSensitivity] = {}

    #: Residual evaluations (none: the exact flow evaluates no residual).
    nfev = 0

    def _flows(self, params: dict):
        if self.cs.form is not None:  # a system with components: its modes as the run interned them
            return ComposedFlows(self.cs, params)
        try:
            return affine_flows(self.cs.system, params)
        except NotAffineError:  # affine only at these values: analysed on folded expressions
            return exact_flows(CompiledSystem(self.cs.system, params))

    def solver(self, m: int, extend: np.ndarray) -> ExactSensitivity:
        """Mode ``m``'s solver at the free parameters' values ``extend`` (made when first asked for)."""
        key = tuple(float(v) for v in extend)
        if self._key != key:
            cs = self.cs
            params = {**cs.params, **dict(zip(cs.free, key, strict=True))}
            self._base = self._flows(params)
            self._pm = None
            if cs.free:
                if len(cs.free) > 1:
                    raise InputError("the exact integrator differentiates by one free parameter at most")
                p = cs.free[0]
                delta = 1e-6 * max(abs(params[p]), 1e-3)
                plus = self._flows({**params, p: params[p] + delta})
                minus = self._flows({**params, p: params[p] - delta})
                self._pm = (plus, minus, delta)
            self._modes = {}
            self._key = key
        hit = self._modes.get(m)
        if hit is None:
            pm = self._pm
            hit = self._modes[m] = ExactSensitivity(
                self._base[m] if pm is None else _dense(self._base[m]),
                self.s,
                None if pm is None else (_dense(pm[0][m]), _dense(pm[1][m]), pm[2]),
            )
        return hit


def _dense(am: AffineMode) -> AffineMode:
    return am.dense() if isinstance(am, SparseAffineMode) else am


@dataclass(frozen=True, init=False)
class Exact(Method):
    """The exact flow of affine modes: matrix exponentials and exact guard roots, for models whose
    modes and guards are affine in the state with time only in sin/cos of one forcing frequency.

    It has no tolerances: its runs are exact to rounding, and so is the noise band of its guards,
    whatever the model's form (mode-level, network file, ``sign()``: issue 30).

    Attributes
    ----------
    guard_noise : float
        Safety factor on the rounding of a guard's value (:meth:`guard_band`): within it a guard
        counts as zero at a switch and stays disarmed until it has left it.

    Examples
    --------
    >>> from hybrid import Exact, SolverOptions
    >>> SolverOptions(method=Exact()).method
    Exact(guard_noise=10.0)
    >>> Exact(rtol=1e-9)  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    hybrid.core.errors.InputTypeError: Exact: `rtol` does not apply: ...
    """

    guard_noise: float = 10.0

    name = "exact"
    flows_exact = True
    needs_derivatives = False
    resolves_slaves = False
    runtime_parameters = True

    #: Relative accuracy of one run of a map: rounding.
    NOISE_RTOL = 1e-15

    def __init__(self, *, guard_noise: float = 10.0, **unexpected):
        if unexpected:
            tol = [k for k in unexpected if k in ("rtol", "atol", "atol_default", "max_num_steps")]
            raise InputTypeError(
                f"Exact: {', '.join(f'`{k}`' for k in unexpected)} "
                + (
                    "does not apply: the exact flow has no tolerances (its runs are exact to rounding); "
                    "leave it out, or use IDA(rtol=..., atol=...) for a method with tolerances"
                    if tol
                    else "is not a setting of Exact (its one setting: guard_noise)"
                )
            )
        guard_noise = plain_number(guard_noise)
        check_positive("Exact", "guard_noise", guard_noise)
        object.__setattr__(self, "guard_noise", guard_noise)

    def check(self, cs: CompiledSystem) -> None:
        """Refuse a compiled system whose modes are not all affine (:func:`exact_flows`).

        Raises
        ------
        hybrid.core.errors.NotAffineError
            Naming the model, the first mode and the term that is not affine.
        """
        exact_flows(cs)

    def check_model(self, system: HybridSystem, params) -> None:
        """Refuse a model that is not affine at ``params`` (compiled at them for the check)."""
        exact_flows(CompiledSystem(system, params))

    @property
    def noise_rtol(self) -> float:
        """:attr:`NOISE_RTOL`: rounding (no tolerances apply to the exact flow)."""
        return self.NOISE_RTOL

    #: Relative rounding of a state of the exact flow and of a time, for the guards' noise band.
    ROUNDING = 1e-15

    def guard_band(
        self,
        atol: np.ndarray,
        grad: np.ndarray,
        ht: float,
        t: float,
        y: np.ndarray,
        size: float,
    ) -> float:
        """The rounding of a guard's value, not a tolerances' band: ``guard_noise x eps x
        (sum |dh/dy| (|y| + size) + |dh/dt| |t|)`` with ``eps`` of :meth:`rounding`.

        The exact flow's state is right to the rounding of the matrix exponentials (relative to
        the state's size, ``size``) and the time to its own rounding; a band as wide as the
        tolerances' (1e-9 of the state) would hide every stick or slip phase shorter than about
        1e-8 s (Den Hartog's oscillator just inside its non-stop boundary), which this flow
        resolves (a phase of 1e-13 s: ``tests/hybrid/test_bifurcation.py``).
        """
        eps = self.rounding(y)
        scale = eps * (np.abs(y) + size)
        return self.guard_noise * (float(np.abs(grad) @ scale) + abs(ht) * eps * abs(t)) + 1e-300

    def rounding(self, y: np.ndarray) -> float:
        """Relative rounding of a state of ``y.size`` variables from the exact flow:
        ``ROUNDING x sqrt(n)`` (each variable a sum over the state of products of the flow's
        matrices: the rounding of a sum of ``n`` terms grows like ``sqrt(n)``; a ring of 8 equal
        blocks, whose copies differ only by rounding, drifted apart by 1.3e-14 in a velocity)."""
        return self.ROUNDING * max(1.0, float(np.sqrt(np.size(y))))

    def guard_bands(self, cm, atol: np.ndarray, t: float, y: np.ndarray, size: float) -> np.ndarray | None:
        """:meth:`guard_band` for every guard of the composed mode ``cm`` at once (a network file,
        ``sign()``): the same rounding noise as the guard-by-guard path, not a tolerances' band
        (issue 30: that band hid the stick phases shorter than about 1e-8 s of Den Hartog's
        oscillator written as a network file); None where the mode has no batched gradients."""
        fn = getattr(cm, "guard_noise_scale", None)
        if fn is None:
            return None
        eps = self.rounding(y)
        return self.guard_noise * fn(t, y, eps * (np.abs(y) + size), eps * abs(t)) + 1e-300

    def mode_solver(
        self,
        cs: CompiledSystem,
        mode: int,
        options: SolverOptions,
        *,
        max_step: float,
        first_step: float = 0.0,
    ) -> ExactModeSolver:
        """An :class:`ExactModeSolver` on the mode's exact flow (tolerances and first step do not apply);
        a :class:`TaylorModeSolver` for the sparse mode of a large system."""
        am = exact_flows(cs)[mode]
        if isinstance(am, SparseAffineMode):
            return TaylorModeSolver(am, max_step=max_step)
        return ExactModeSolver(am, max_step=max_step)

    def guard_series(self, cs: CompiledSystem, mode: int, t: float, y: np.ndarray, order: int):
        """The guards' series of the exact flow: ``W_k M^j z / j!``."""
        am = exact_flows(cs)[mode]
        return lambda k: am.guard_series(k, t, y, order)

    def variational(
        self, cs: CompiledSystem, s: np.ndarray, options: SolverOptions, max_step: float
    ) -> ExactVariational:
        """The exact flows' fundamental matrices (:class:`ExactSensitivity`)."""
        return ExactVariational(cs, s)

    def exact_flows(self, cs: CompiledSystem) -> list[AffineMode]:
        """:func:`hybrid.integrators.affine.exact_flows`."""
        return exact_flows(cs)
