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
:class:`ExactIntegrator` is the integrator as a whole (``SolverOptions(integrator="exact")``).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.polynomial import chebyshev as cheb

from ..core.errors import InputError, NotAffineError
from ..core.options import SolverOptions
from ..model.compiled import CompiledSystem
from ..model.system import HybridSystem
from .affine import AffineMode, affine_flows, exact_flows
from .base import ROOT, SUCCESS, TSTOP, Integrator, StepResult

__all__ = ["ExactIntegrator", "ExactModeSolver", "ExactSensitivity", "ExactVariational", "TAYLOR_DEGREE"]

#: Degree of the Taylor polynomial of a guard along one step (steps are sized so that it is exact to rounding).
TAYLOR_DEGREE = 24


# ----------------------------------------------------------------------------
# Propagation
# ----------------------------------------------------------------------------


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


class ExactVariational:
    """The exact flows' variational solvers of one compiled system's modes (one
    :class:`ExactSensitivity` per mode, for one value of the free parameters at a time; see
    :meth:`ExactIntegrator.variational`).

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

    def _flows(self, params: dict) -> list[AffineMode]:
        try:
            return affine_flows(self.cs.system, params)
        except NotAffineError:  # affine only at these values: analysed on folded expressions
            return exact_flows(CompiledSystem(self.cs.system, params))

    def solver(self, m: int, extend: np.ndarray) -> ExactSensitivity:
        """Mode ``m``'s solver at the free parameters' values ``extend``."""
        key = tuple(float(v) for v in extend)
        if self._key != key:
            cs = self.cs
            params = {**cs.params, **dict(zip(cs.free, key, strict=True))}
            base = self._flows(params)
            pm = None
            if cs.free:
                if len(cs.free) > 1:
                    raise InputError("the exact integrator differentiates by one free parameter at most")
                p = cs.free[0]
                delta = 1e-6 * max(abs(params[p]), 1e-3)
                plus = self._flows({**params, p: params[p] + delta})
                minus = self._flows({**params, p: params[p] - delta})
                pm = (plus, minus, delta)
            self._modes = {
                k: ExactSensitivity(base[k], self.s, None if pm is None else (pm[0][k], pm[1][k], pm[2]))
                for k in range(len(base))
            }
            self._key = key
        return self._modes[m]


class ExactIntegrator(Integrator):
    """The exact flow of affine modes: matrix exponentials and exact guard roots, for models whose
    modes and guards are affine in the state with time only in sin/cos of one forcing frequency."""

    name = "exact"
    exact = True
    needs_derivatives = False
    resolves_slaves = False
    runtime_parameters = True
    broyden = False
    coarse_stage = False
    switch_time_newton = True

    #: Relative accuracy of one run of a map: rounding.
    NOISE_RTOL = 1e-15

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

    def noise_rtol(self, options: SolverOptions) -> float:
        """:attr:`NOISE_RTOL`: the tolerances do not apply to the exact flow."""
        return self.NOISE_RTOL

    #: Relative rounding of a state of the exact flow and of a time, for the guards' noise band.
    ROUNDING = 1e-15

    def guard_noise(
        self,
        options: SolverOptions,
        atol: np.ndarray,
        grad: np.ndarray,
        ht: float,
        t: float,
        y: np.ndarray,
        size: float,
    ) -> float:
        """The rounding of a guard's value, not the tolerances' band: ``guard_noise x ROUNDING x
        (sum |dh/dy| (|y| + size) + |dh/dt| |t|)``.

        The exact flow's state is right to the rounding of the matrix exponentials (relative to
        the state's size, ``size``) and the time to its own rounding; a band as wide as the
        tolerances' (1e-9 of the state) would hide every stick or slip phase shorter than about
        1e-8 s (Den Hartog's oscillator just inside its non-stop boundary), which this flow
        resolves (a phase of 1e-13 s: ``tests/hybrid/test_bifurcation.py``).
        """
        scale = self.ROUNDING * (np.abs(y) + size)
        return options.guard_noise * (float(np.abs(grad) @ scale) + abs(ht) * self.ROUNDING * abs(t)) + 1e-300

    def mode_solver(
        self,
        cs: CompiledSystem,
        mode: int,
        options: SolverOptions,
        *,
        atol: np.ndarray,
        max_step: float,
        first_step: float = 0.0,
    ) -> ExactModeSolver:
        """An :class:`ExactModeSolver` on the mode's exact flow (tolerances and first step do not apply)."""
        return ExactModeSolver(exact_flows(cs)[mode], max_step=max_step)

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
