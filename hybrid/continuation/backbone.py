"""Backbones of autonomous systems: periodic orbits with an extra unknown parameter, by amplitude.

A system whose free motion decays has no periodic orbit; one parameter ``xi`` of the model that
feeds energy in (for the extended periodic motion concept, EPMC, a negative mass-proportional
damping ``- xi M v``: :func:`hybrid_models.epmc_system` adds it to a network) is made an unknown,
so that a periodic orbit exists at each amplitude ``a`` of a chosen coordinate ``q``
(``a = max_t q(t)``). The problem for one point is, with the orbit's start ``y0`` (the
differential variables of its mode), its period ``T``, ``xi``, the time ``t*`` of the maximum of
``q`` and ``a``:

* ``y(T; y0, xi) - y0 = 0`` (periodicity),
* ``f(y_ref) . (y0 / a - y_ref / a_ref) = 0`` (the anchor: the time origin on a hyperplane
  orthogonal to the flow at a reference point, the previous orbit's, in the state scaled by the
  amplitude: a hyperplane fixed in the unscaled state would shift the orbit's phase as ``a`` changes,
  and the tangent of the curve would be mostly that phase drift, the step in ``ln a`` its small
  share),
* ``q(t*) - a = 0`` and ``q'(t*) = 0`` (the amplitude: ``t*`` is where ``q`` is largest).

Its Jacobian is exact: the fundamental matrices of the runs to ``T`` and to ``t*`` (with the
column of ``xi``), the vector field at their ends. The curve of solutions is followed in
``ln a`` by pseudo-arclength (through turning points), the unknowns scaled to order one (the
state by ``a``, times by the linear period ``T0``, ``xi`` by ``2 pi / T0``). After each point the
orbit's start moves to where it is farthest from a switch and from ``t*`` (a start near a switch
would change its mode under Newton's steps).

The curve starts from the linear mode of the start mode (by default the model's initial mode):
the ``mode``-th oscillating pair of eigenvalues of
its reduced Jacobian at the zero state (:func:`hybrid.model.linear.reduced_jacobian`) at an
amplitude small enough that the orbit meets no switch, with ``xi`` the eigenvalue's decay rate
(0 for an undamped mode). Each point reports ``omega = 2 pi / T``, ``xi``, the damping ratio
``D = xi / (2 omega)``, the energy dissipated per period (the model's ``energy["dissipated"]``
quadrature over the period), its balance against the energy put in (``energy["input"]``), the
fraction of the period in each local mode and the Fourier coefficients of the orbit.

Two events on the curve are found between consecutive points and located by bisection in
``ln a`` (each trial a corrected orbit at fixed amplitude): ``"first-switch"`` (the orbit first
leaves the start mode) and ``"all-switched"`` (every component of a composed system has left its
start local mode somewhere in the period).

A family of orbits (a coordinate left free all period, e.g. the offset of a component that never
leaves its start mode) makes the equations singular: the model's ``[orbit] gauge`` expressions
then pick the member (as many as the family has directions, :mod:`hybrid.orbits.gauge`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

import numpy as np
import scipy.linalg as sla

from ..core.errors import (
    BudgetExceeded,
    GrazingSwitchError,
    InputError,
    InputTypeError,
    ModelError,
    ParameterOutOfDomain,
)
from ..core.options import ContinuationOptions, NewtonOptions, reject_keywords
from ..core.status import BranchStatus
from ..core.threads import with_blas_threads
from ..integrators.options import SolverOptions
from ..model.linear import natural_frequencies, reduced_jacobian
from ..model.system import HybridSystem
from ..orbits.autonomous import AutonomousSolver, finish
from ..orbits.flowmap import FlowMap
from ..orbits.gauge import GAUGE_PICK_TOL, gauge_functions
from ..orbits.orbit import FAMILY_TOL, ORBIT_OPTIONS, PeriodicOrbit
from .backbone_result import Backbone, BackboneEvent, BackbonePoint
from .palc import tangent

__all__ = ["BACKBONE_CONTINUATION", "backbone"]

#: Continuation options of a backbone by default: steps in ``ln a`` and the scaled unknowns; the
#: corrector's tolerance on the scaled residual.
BACKBONE_CONTINUATION = ContinuationOptions(
    ds=0.05,
    ds_min=1e-6,
    ds_max=0.2,
    max_points=400,
    samples_per_period=512,
    locate_tol=1e-9,
    newton=NewtonOptions(tol=1e-11, max_iter=12),
)

#: Fourier coefficients reported per variable (harmonics 0 .. HARMONICS).
HARMONICS = 15
#: Smallest start amplitude tried (relative to the first asked) before giving up on a linear start.
MIN_START = 1e-12
#: Newton iterations of one correction; bisection steps of a located event at most.
CORRECTOR_ITER, LOCATE_ITER = 12, 60
_FAILED = (
    RuntimeError,
    ValueError,
    GrazingSwitchError,
    ZeroDivisionError,
    OverflowError,
    np.linalg.LinAlgError,
)


# ----------------------------------------------------------------------------
class _Problem:
    """The scaled equations of one backbone point and their Jacobian, with a movable start."""

    def __init__(self, fm: FlowMap, coordinate: str, T0: float, samples: int):
        self.fm = fm
        self.names = fm.names
        self.iq = self.names.index(coordinate)
        self.coordinate = coordinate
        self.T0, self.w0 = T0, 2 * math.pi / T0
        self.samples = samples
        s = list(fm.sens.s)
        if self.iq not in s:
            raise InputError(
                f"`coordinate` {coordinate!r} is not a state variable the flow's derivatives cover"
            )
        self.qpos = s.index(self.iq)
        self.mode = ""
        self.d = self.pos = None
        self.y_base = None
        self.anchor = None
        self.gauge = gauge_functions(fm.system)

    def set_start(self, y: np.ndarray, mode: str, a: float) -> None:
        """The start's mode and reference state ``y`` of an orbit of amplitude ``a`` (the anchor
        through ``y / a``, orthogonal to the flow)."""
        self.mode = mode
        solver = AutonomousSolver(self.fm, "anchor", 1e-12, 1)
        self.d, self.pos = solver.unknowns(mode)
        y = self.fm.mode(mode).solve_algebraic(0.0, np.array(y, dtype=float))
        self.y_base = y.copy()
        f = self.fm.field(mode, y)[self.d]
        self.anchor = (y[self.d] / a, f / max(float(np.linalg.norm(f)), 1e-300))

    def pack(self, y, T, xi, t_star, a) -> np.ndarray:
        return np.concatenate([y[self.d] / a, [T / self.T0, xi / self.w0, t_star / self.T0, math.log(a)]])

    def unpack(self, u):
        n = self.d.size
        a = math.exp(u[-1])
        y = self.y_base.copy()
        y[self.d] = a * u[:n]
        T, xi, t_star = u[n] * self.T0, u[n + 1] * self.w0, u[n + 2] * self.T0
        return y, T, xi, t_star, a

    def _field_gradient(self, mode: str, y: np.ndarray) -> np.ndarray:
        """Gradient of the coordinate's rate ``q'`` over the sensitivity variables (differences)."""
        fm = self.fm
        cm = fm.mode(mode)
        s = fm.sens.s
        g = np.zeros(s.size)
        row = cm.dFdy(0.0, y)[self.iq] if cm.is_diff[self.iq] else None
        if row is not None and all(cm.is_diff[i] for i in np.flatnonzero(row)):
            # q' depends on differential variables only: its row of the mode's Jacobian (-f_y)
            inside = s < len(self.names)
            g[inside] = -row[s[inside]]
            return g
        base = fm.field(mode, y)[self.iq]
        scale = max(float(np.max(np.abs(y))), 1e-300)
        for j, i in enumerate(s):
            if i >= len(self.names) or not cm.is_diff[i] or self.names[i] in fm.system.quadratures:
                continue
            h = 1e-7 * max(abs(y[i]), scale)
            yp = y.copy()
            yp[i] += h
            yp = cm.solve_algebraic(0.0, yp)
            g[j] = (fm.field(mode, yp)[self.iq] - base) / h
        return g

    def evaluate(self, u):
        """``(F, J, info)``: the n + 3 scaled residuals and their Jacobian in the n + 4 unknowns."""
        fm = self.fm
        n = self.d.size
        y, T, xi, t_star, a = self.unpack(u)
        if not (T > 0 and 0 < t_star < T):
            raise ParameterOutOfDomain("period or time of the maximum out of range")
        fm.set_parameter(xi)
        y = fm.mode(self.mode).solve_algebraic(0.0, y)
        z = y[self.d] / a
        ev = fm.timed(y, self.mode, T)
        e2 = fm.timed(y, self.mode, t_star)
        J, J2 = ev.jacobian, e2.jacobian
        pos, qp = self.pos, self.qpos
        G = self._field_gradient(e2.end_mode, e2.end)
        f2 = fm.field(e2.end_mode, e2.end)
        rate = f2[self.iq]
        F = np.concatenate(
            [
                (ev.end[self.d] - y[self.d]) / a,
                [self.anchor[1] @ (z - self.anchor[0])],
                [e2.end[self.iq] / a - 1.0],
                [rate / (a * self.w0)],
            ]
        )
        A = np.zeros((n + 3, n + 4))
        Jyy = J[np.ix_(pos, pos)]
        A[:n, :n] = Jyy - np.eye(n)
        A[:n, n] = ev.field[self.d] * self.T0 / a
        A[:n, n + 1] = J[pos, -1] * self.w0 / a
        A[:n, n + 3] = (Jyy - np.eye(n)) @ z - F[:n]
        # the anchor: f_ref . (z - y_ref / a_ref), z = y / a
        A[n, :n] = self.anchor[1]
        A[n, n + 3] = 0.0
        # the amplitude: q(t*) / a - 1
        A[n + 1, :n] = J2[qp, pos]
        A[n + 1, n + 1] = J2[qp, -1] * self.w0 / a
        A[n + 1, n + 2] = rate * self.T0 / a
        A[n + 1, n + 3] = J2[qp, pos] @ z - e2.end[self.iq] / a
        # the maximum: q'(t*) / (a w0)
        GJ = G @ J2
        A[n + 2, :n] = GJ[pos] / self.w0
        A[n + 2, n + 1] = GJ[-1] / a
        A[n + 2, n + 2] = (G @ fm.on_s(f2)) * self.T0 / (a * self.w0)
        A[n + 2, n + 3] = GJ[pos] @ z / self.w0 - F[n + 2]
        return F, A, (y, ev)

    def gauge_rows(self, u, A: np.ndarray):
        """Rows ``gauge = 0`` (scaled by ``a``) for a family of orbits (``A`` singular: e.g. the free
        offset of a component that never switches), as many as its null directions, the model's ``[orbit]
        gauge`` expressions that fix them best; ``(rows, values)``, empty for an isolated orbit."""
        empty = (np.zeros((0, A.shape[1])), np.zeros(0))
        if self.gauge is None:
            return empty
        sv, vt = np.linalg.svd(A)[1:]
        q = int(np.count_nonzero(sv <= FAMILY_TOL * max(1.0, sv[0])))
        if q == 0:
            return empty
        y, _, _, _, a = self.unpack(u)
        fns, grads = self.gauge
        v = [0.0, *y.tolist(), *(self.fm.params[p] for p in self.fm.system.parameter_names)]
        n = self.d.size
        vals = np.array([f(v) for f in fns]) / a
        G = np.zeros((len(fns), A.shape[1]))
        for k, pairs in enumerate(grads):
            g = np.zeros(len(self.names))
            for i, df in pairs:
                g[i] = df(v)
            G[k, :n] = g[self.d]
            G[k, n + 3] = g[self.d] @ y[self.d] / a - vals[k]
        norms = np.linalg.norm(G, axis=1)
        live = norms > 0.0
        P = np.zeros((len(fns), q))
        P[live] = (G[live] / norms[live, None]) @ vt[-q:].T
        _, R, piv = sla.qr(P.T, mode="economic", pivoting=True)
        diag = np.abs(np.diag(R))
        keep = [int(piv[i]) for i in range(diag.size) if diag[i] > GAUGE_PICK_TOL]
        return G[keep], vals[keep]

    def tangent(self, u, J: np.ndarray, previous: np.ndarray) -> np.ndarray:
        """The unit tangent of the curve at ``u`` (sense of ``previous``), with the gauge rows of a
        family: without them its free direction (e.g. an offset) enters the tangent and the step in
        ``ln a`` shrinks to the tangent's small share (issue 31: the crawl on a beam with a stuck
        contact)."""
        Gr, _ = self.gauge_rows(u, np.vstack([J, previous]))
        return tangent(np.vstack([J, Gr]), previous)

    def correct(self, u, row: np.ndarray, target: float, tol: float):
        """Newton on ``[F(u); row . u - target]`` (with the gauges of a family); ``(u, J, info,
        iterations, residual)`` or None."""
        for it in range(CORRECTOR_ITER):
            try:
                F, J, info = self.evaluate(u)
            except _FAILED:  # a failed evaluation (also a Newton step sending ln a out of range)
                return None
            if not np.all(np.isfinite(F)):
                return None
            A = np.vstack([J, row])
            r = np.concatenate([F, [row @ u - target]])
            Gr, gv = self.gauge_rows(u, A)
            A = np.vstack([A, Gr])
            r = np.concatenate([r, gv])
            du = np.linalg.lstsq(A, -r, rcond=None)[0]
            res = float(np.max(np.abs(r)))
            if res <= tol and float(np.max(np.abs(du))) <= 10 * tol:
                return u, J, info, it, res
            u = u + du
        return None

    def orbit(self, u, info, samples: int) -> PeriodicOrbit:
        y, ev = info
        _, T, _, _, _ = self.unpack(u)
        solver = AutonomousSolver(self.fm, "anchor", 1e-12, 1)
        return finish(solver, y, self.mode, T, ev, 0, 0.0, samples)


def _harmonics(orbit: PeriodicOrbit, t_max: float, names) -> dict:
    """Fourier coefficients ``(c_k, s_k)``, k = 0 .. HARMONICS, time from ``t_max``."""
    tr = orbit.trajectory
    T = orbit.period
    t = tr.t[:-1]
    w = 2 * math.pi / T
    out = {}
    ks = np.arange(HARMONICS + 1)
    ph = np.outer(ks, w * (t - t_max))
    for n in names:
        x = tr.y[:-1, orbit.system.variable_names.index(n)]
        c = 2.0 / t.size * (np.cos(ph) @ x)
        s = 2.0 / t.size * (np.sin(ph) @ x)
        c[0] *= 0.5
        s[0] = 0.0
        out[n] = np.column_stack([c, s])
    return out


@with_blas_threads
def backbone(
    system: HybridSystem,
    params: Mapping[str, float],
    *,
    coordinate: str,
    mode: int = 1,
    amplitudes: Sequence[float] | None = None,
    amplitude_range: tuple[float, float] | None = None,
    parameter: str = "xi",
    start_mode: str | None = None,
    options: SolverOptions | None = None,
    settings: ContinuationOptions | None = None,
    **unexpected,
) -> Backbone:
    """The backbone of an autonomous system: periodic orbits and ``parameter``, by amplitude.

    Parameters
    ----------
    system : HybridSystem
        An autonomous model (no forcing) with a parameter that feeds energy in (for EPMC, built by
        :func:`hybrid_models.epmc_system`: ``xi`` [1/s] in ``+ xi M v``).
    params : mapping of str to float
        Parameter values (``parameter``'s is ignored: it is solved for).
    coordinate : str
        The variable whose maximum over the orbit is the amplitude.
    mode : int
        Which linear mode to start from (1: the lowest frequency of ``start_mode``).
    amplitudes : sequence of float, optional
        Amplitudes at which points are wanted (each corrected at exactly that amplitude).
    amplitude_range : (float, float), optional
        ``(lo, hi)``: every point of the continuation between them, ``lo`` and ``hi`` included.
        Give this or ``amplitudes``.
    parameter : str
        The parameter solved for (default ``"xi"``).
    start_mode : str, optional
        The mode whose linearisation gives the start (default: the model's initial mode).
    options : SolverOptions, optional
        The integration method and tolerances (default :data:`hybrid.ORBIT_OPTIONS`; the exact
        integrator: ``SolverOptions(method=Exact())``).
    settings : ContinuationOptions, optional
        Steps in ``ln a`` and the scaled unknowns, the corrector's tolerance, the samples per
        period of each orbit, ``locate_tol`` (relative width of a located event's interval);
        default :data:`BACKBONE_CONTINUATION`.

    Returns
    -------
    Backbone
        ``status`` ``"stopped"`` with ``reason`` ``"no-start"`` or ``"stalled"`` where the curve
        could not be followed to the end of the range, ``"budget"`` where a run's budget or the
        computation's deadline (:func:`hybrid.time_limit`) ran out (the points computed before kept).

    Raises
    ------
    ValueError
        Bad input (before any integration): unknown coordinate or parameter, a model with a
        forcing period, no oscillating linear mode number ``mode``, amplitudes not positive.

    Examples
    --------
    >>> import hybrid, hybrid_models
    >>> sys = hybrid_models.epmc_system("models/jenkins_oscillator.toml")    # doctest: +SKIP
    >>> bb = hybrid.backbone(sys, sys.preset("standard"), coordinate="x",
    ...                      amplitudes=[0.2, 1.0])                           # doctest: +SKIP
    """
    reject_keywords(
        "backbone",
        unexpected,
        options=options if isinstance(options, SolverOptions) else SolverOptions,
        settings=settings if isinstance(settings, ContinuationOptions) else ContinuationOptions,
    )
    if not isinstance(system, HybridSystem):
        raise InputTypeError(f"`system` must be a HybridSystem, got {type(system).__name__}")
    options = ORBIT_OPTIONS if options is None else options
    settings = BACKBONE_CONTINUATION if settings is None else settings
    if not isinstance(options, SolverOptions):
        raise InputTypeError(f"`options` must be a SolverOptions, got {type(options).__name__}")
    if not isinstance(settings, ContinuationOptions):
        raise InputTypeError(f"`settings` must be a ContinuationOptions, got {type(settings).__name__}")
    if system.period is not None:
        raise ModelError(
            f"model `{system.name}` has a forcing period: a backbone is computed on the free system "
            "(for a network, hybrid_models.epmc_system removes the forcing and adds the EPMC term)"
        )
    if parameter not in system.parameter_names:
        raise InputError(
            f"model `{system.name}` has no parameter `{parameter}` to solve for (the energy-feeding term of "
            "EPMC); build the model with hybrid_models.epmc_system, or name its parameter with `parameter`"
        )
    if coordinate not in system.variable_names or coordinate in system.quadratures:
        raise InputError(
            f"`coordinate` {coordinate!r} is not a state variable of model `{system.name}`; variables: "
            f"{', '.join(v for v in system.variable_names if v not in system.quadratures)}"
        )
    if isinstance(mode, bool) or not isinstance(mode, int) or mode < 1:
        raise InputError(f"`mode` must be an integer >= 1 (1: the lowest frequency), got {mode!r}")
    wanted, lo, hi = _amplitude_request(amplitudes, amplitude_range)
    params = system.parameter_values({**params, parameter: 0.0})
    start_mode = start_mode if start_mode is not None else system.default_mode
    if start_mode is None:
        raise InputError(f"model `{system.name}` declares no initial mode: give `start_mode`")
    system.mode(start_mode)
    lam, shape, names = _linear_mode(system, params, start_mode, mode)
    w_lin = float(abs(lam.imag))
    T0 = 2 * math.pi / w_lin
    refs = _references(system, params, mode)
    bb = Backbone(system, dict(params), coordinate, parameter, mode, start_mode, w_lin, refs)
    bb.options, bb.settings = options, settings
    fm = FlowMap(system, params, options, T0, free=parameter)
    prob = _Problem(fm, coordinate, T0, settings.samples_per_period)
    tol = max(settings.newton.tol, 10.0 * options.method.noise_rtol)  # not below the runs' noise
    iq_lin = names.index(coordinate) if coordinate in names else None
    if iq_lin is None:
        raise InputError(f"`coordinate` {coordinate!r} is not a differential variable of mode `{start_mode}`")
    if abs(shape[iq_lin]) == 0.0:
        raise InputError(
            f"linear mode {mode} does not move `{coordinate}`: choose another coordinate or mode"
        )
    shape = shape / shape[iq_lin]  # the coordinate's component real and 1
    # the start: the linear mode at the minimum of the coordinate (t = 0), its maximum at T0/2
    a0 = lo
    u = None
    for _ in range(int(math.log2(1.0 / MIN_START))):
        y = np.zeros(len(system.variable_names))
        y[[system.variable_names.index(n) for n in names]] = -a0 * shape.real
        prob.set_start(y, start_mode, a0)
        fm.set_parameter(-2.0 * lam.real)
        try:
            tr = fm.run(prob.y_base, start_mode, T0)
            clean = tr.success and not tr.events
        except BudgetExceeded as exc:
            bb.status, bb.reason, bb.message = (
                BranchStatus.STOPPED,
                "budget",
                f"{exc}; before the first point",
            )
            return bb
        except (RuntimeError, GrazingSwitchError, ZeroDivisionError, ValueError):
            clean = False
        if clean:
            u = prob.pack(prob.y_base, T0, -2.0 * lam.real, 0.5 * T0, a0)
            break
        a0 *= 0.25
    if u is None:
        bb.status, bb.reason = BranchStatus.STOPPED, "no-start"
        bb.message = f"no amplitude down to {a0:.3g} at which the linear mode meets no switch"
        return bb
    _follow(bb, prob, u, wanted, lo, hi, settings, tol)
    return bb


def _amplitude_request(amplitudes, amplitude_range):
    if (amplitudes is None) == (amplitude_range is None):
        raise InputError("give `amplitudes` (a list) or `amplitude_range` (lo, hi), one of them")
    if amplitudes is not None:
        try:
            vals = np.asarray(amplitudes, dtype=float).ravel()
        except (TypeError, ValueError):
            raise InputError(f"`amplitudes` must be numbers > 0, got {amplitudes!r}") from None
        if not vals.size or not np.all(np.isfinite(vals)) or np.any(vals <= 0):
            raise InputError(f"`amplitudes` must be finite numbers > 0, got {amplitudes!r}")
        vals = np.unique(vals)
        return vals, float(vals[0]), float(vals[-1])
    try:
        lo, hi = (float(v) for v in amplitude_range)
    except (TypeError, ValueError):
        raise InputError(f"`amplitude_range` must be two numbers (lo, hi), got {amplitude_range!r}") from None
    if not (math.isfinite(lo) and math.isfinite(hi) and 0 < lo < hi):
        raise InputError(f"`amplitude_range` must hold 0 < lo < hi, got {amplitude_range!r}")
    return None, lo, hi


def _linear_mode(system: HybridSystem, params, start_mode: str, mode: int):
    """The ``mode``-th oscillating eigenvalue (ascending frequency) of ``start_mode`` at the zero
    state, its eigenvector and the names of its components."""
    names, A = reduced_jacobian(system, params, start_mode)
    if A.size == 0:
        raise InputError(f"mode `{start_mode}` of model `{system.name}` has no differential variable")
    lam, V = np.linalg.eig(A)
    scale = max(float(np.max(np.abs(lam))), 1e-300)
    osc = [k for k in range(lam.size) if lam[k].imag > 1e-9 * scale]
    osc.sort(key=lambda k: abs(lam[k]))
    if len(osc) < mode:
        raise InputError(
            f"mode `{start_mode}` of model `{system.name}` linearised at rest has {len(osc)} oscillating "
            f"mode(s); `mode` = {mode} asked"
        )
    k = osc[mode - 1]
    return lam[k], V[:, k], list(names)


def _references(system: HybridSystem, params, mode: int) -> dict:
    """The frequency of linear mode ``mode`` in each mode of the ``linear_references`` hint."""
    out = {}
    for label, m in dict(system.plot.get("linear_references", {})).items():
        try:
            w = natural_frequencies(system, params, m)
        except (RuntimeError, ValueError, ArithmeticError, np.linalg.LinAlgError):
            continue
        if w.size >= mode:
            out[str(label)] = float(w[mode - 1])
    return out


def _point(prob: _Problem, u, info, res: float, samples: int) -> BackbonePoint:
    system = prob.fm.system
    orbit = prob.orbit(u, info, samples)
    _, T, xi, t_star, a = prob.unpack(u)
    omega = 2 * math.pi / T
    en = system.energy
    end, start = orbit.trajectory.y[-1], orbit.trajectory.y[0]
    names = system.variable_names

    def energy(key):
        n = en.get(key)
        if n not in names:
            return math.nan
        return float(end[names.index(n)] - start[names.index(n)])

    harm = _harmonics(orbit, t_star, [n for n in names if n not in system.quadratures])
    return BackbonePoint(
        amplitude=a,
        omega=omega,
        xi=xi,
        damping_ratio=xi / (2 * omega),
        dissipated=energy("dissipated"),
        energy_input=energy("input"),
        fractions=dict(orbit.local_fractions),
        orbit=orbit,
        t_max=t_star,
        harmonics=harm,
        residual=res,
    )


def _restart(prob: _Problem, u, orbit: PeriodicOrbit):
    """Move the orbit's start to the sample farthest from a switch and from the maximum; the new
    unknowns (in the new start's coordinates)."""
    _, T, xi, t_star, a = prob.unpack(u)
    tr = orbit.trajectory
    t = tr.t
    sw = np.array([e.t for e in tr.events] + [0.0, T])
    best, k_best = -1.0, 0
    for k in range(t.size - 1):
        d_sw = float(np.min(np.abs(sw - t[k]))) if sw.size else T
        dt = abs(t[k] - t_star) % T
        d_max = min(dt, T - dt)
        score = min(d_sw, d_max)
        if score > best:
            best, k_best = score, k
    ts = float(t[k_best])
    y = tr.y[k_best].copy()
    prob.set_start(y, str(tr.mode[k_best]), a)
    t_new = (t_star - ts) % T
    return prob.pack(prob.y_base, T, xi, t_new, a)


def _follow(bb: Backbone, prob: _Problem, u0, wanted, lo: float, hi: float, st: ContinuationOptions, tol):
    """Follow the curve from the start ``u0``; the points, events and end written into ``bb``."""
    chain: list[BackbonePoint] = []  # every point computed, in order (for the events)
    kept: list[BackbonePoint] = []
    missed: list[float] = []
    try:
        _steps(bb, prob, u0, wanted, lo, hi, st, tol, chain, kept, missed)
    except BudgetExceeded as exc:  # the run's budget or the computation's deadline: keep what is done
        bb.status, bb.reason = BranchStatus.STOPPED, "budget"
        bb.message = f"{exc}; stopped after {len(chain)} points"
    if _monotone(chain):
        kept.sort(key=lambda p: p.amplitude)
    bb.points = kept
    # the amplitude is the maximum tracked from the linear mode's: say so where the orbit's
    # largest |q| (its refined extremes) lies above it (another, higher local maximum)
    above = [p.amplitude for p in kept if p.orbit.amplitude[prob.coordinate] > p.amplitude * (1 + 1e-7)]
    if above:
        bb.message = (bb.message + "; " if bb.message else "") + (
            f"at {len(above)} point(s) (amplitude {above[0]:.8g}, ...) the orbit's largest |{prob.coordinate}| "
            "exceeds the maximum tracked (a minimum deeper than the maximum is high, or another maximum)"
        )
    if missed:
        bb.message = (bb.message + "; " if bb.message else "") + (
            "no orbit corrected at the amplitude(s) " + ", ".join(f"{a:.8g}" for a in missed)
        )
    if bb.reason != "budget":
        _events(bb, prob, chain, st, tol)


def _steps(bb, prob: _Problem, u0, wanted, lo, hi, st: ContinuationOptions, tol, chain, kept, missed) -> None:
    e_last = _last(u0.size)
    got = prob.correct(u0, e_last, u0[-1], tol)
    if got is None:
        bb.status, bb.reason = BranchStatus.STOPPED, "no-start"
        bb.message = "the corrector failed on the linear mode at the start amplitude"
        return
    u, J, info, _, res = got
    t = prob.tangent(u, J, e_last)
    pt = _point(prob, u, info, res, st.samples_per_period)
    log_lo, log_hi = math.log(lo), math.log(hi)
    chain.append(pt)
    targets = list(np.log(wanted)) if wanted is not None else [log_lo, log_hi]
    targets = [x for x in targets if x >= u[-1] - 1e-14]
    if wanted is None and u[-1] >= log_lo:
        kept.append(pt)
        targets = [x for x in targets if x > u[-1] + 1e-14]
    ds = st.ds
    uc = _restart(prob, u, pt.orbit)
    t = _carry(prob, uc, t)
    u = uc
    n_steps = 0
    while targets and n_steps < st.max_points:
        got = None
        while got is None:
            got = prob.correct(u + ds * t, t, t @ (u + ds * t), tol)
            if got is None:
                ds *= 0.5
                if ds < st.ds_min:
                    bb.status, bb.reason = BranchStatus.STOPPED, "stalled"
                    bb.message = (
                        f"stalled at amplitude {math.exp(u[-1]):.8g}: the corrector failed down to ds_min"
                    )
                    return
        un, Jn, info, iters, res = got
        # the wanted amplitudes crossed by this step: each corrected at exactly its value
        for x in [x for x in targets if min(u[-1], un[-1]) <= x <= max(u[-1], un[-1])]:
            w = (x - u[-1]) / (un[-1] - u[-1]) if un[-1] != u[-1] else 1.0
            g2 = prob.correct(u + w * (un - u), _last(u.size), x, tol)
            if g2 is not None:
                kept.append(_point(prob, g2[0], g2[2], g2[4], st.samples_per_period))
            else:
                missed.append(math.exp(x))
            targets.remove(x)
        tn = prob.tangent(un, Jn, t)
        pt = _point(prob, un, info, res, st.samples_per_period)
        chain.append(pt)
        if wanted is None and log_lo < un[-1] < log_hi:
            kept.append(pt)
        n_steps += 1
        ds = min(2 * ds, st.ds_max) if iters <= 3 else ds
        if un[-1] > log_hi + 1e-14 and not targets:
            break
        uc = _restart(prob, un, pt.orbit)
        t = _carry(prob, uc, tn)
        u = uc
    if targets:
        bb.message = f"reached max_points = {st.max_points} at amplitude {math.exp(u[-1]):.8g}"


def _last(n: int) -> np.ndarray:
    e = np.zeros(n)
    e[-1] = 1.0
    return e


def _monotone(chain) -> bool:
    a = [p.amplitude for p in chain]
    return all(b >= x for x, b in zip(a, a[1:], strict=False))


def _carry(prob: _Problem, u, t_old):
    """The tangent at ``u`` (new start coordinates), with the sense of ``t_old`` in the unknowns
    that do not depend on the start (period, parameter, amplitude)."""
    sel = [-4, -3, -1]
    prev = np.zeros(u.size)
    prev[sel] = t_old[sel]
    if not np.any(prev):
        prev[-1] = 1.0
    try:
        _, J, _ = prob.evaluate(u)
    except (RuntimeError, ValueError, GrazingSwitchError, ZeroDivisionError):
        return prev / np.linalg.norm(prev)
    return prob.tangent(u, J, prev)


def _events(bb: Backbone, prob: _Problem, chain, st: ContinuationOptions, tol) -> None:
    """The first switch and the all-switched point, each between consecutive points of ``chain``,
    located by bisection in ``ln a`` (each trial corrected from the last one below it)."""
    system = bb.system
    start_local = set(system.local_modes_of(bb.start_mode))
    comps = [c.name for c in system.components]

    def local(modes) -> set:
        return {p for m in modes for p in system.local_modes_of(m)} - start_local

    def left_start(modes) -> bool:
        return set(modes) != {bb.start_mode}

    def all_left(modes) -> bool:
        vis = local(modes)
        return all(any(m.startswith(f"{c}.") for m in vis) for c in comps)

    kinds = [("first-switch", left_start, "the orbit first leaves the start mode")]
    if comps:
        kinds.append(("all-switched", all_left, "every component leaves its start local mode in the period"))
    for kind, test, desc in kinds:
        for a, b in zip(chain, chain[1:], strict=False):
            if not test(a.orbit.mode_sequence) and test(b.orbit.mode_sequence):
                bb.events.append(_locate(prob, a, b, test, kind, desc, st, tol))
                break


def _locate(prob: _Problem, a: BackbonePoint, b: BackbonePoint, test, kind, desc, st, tol) -> BackboneEvent:
    lo, hi = math.log(a.amplitude), math.log(b.amplitude)
    o = a.orbit
    start = (o.x0, o.mode0, o.period, a.xi, a.t_max, a.amplitude)
    w_hi, d_hi = b.omega, b.damping_ratio
    for _ in range(LOCATE_ITER):
        if hi - lo <= st.locate_tol:
            break
        mid = 0.5 * (lo + hi)
        y0, mode0, T, xi, t_star, a_start = start
        prob.set_start(y0, mode0, a_start)
        u0 = prob.pack(prob.y_base, T, xi, t_star, a_start)  # the start's scaled state
        u0[-1] = mid
        got = prob.correct(u0, _last(u0.size), mid, tol)
        if got is None:
            break
        u, _, (y, ev), _, _ = got
        modes = {prob.mode} | {e.target for e in ev.events}
        _, T, xi, t_star, _ = prob.unpack(u)
        if test(modes):
            hi, w_hi, d_hi = mid, 2 * math.pi / T, xi * T / (4 * math.pi)
        else:
            lo, start = mid, (y, prob.mode, T, xi, t_star, math.exp(mid))
    status = "located" if hi - lo <= st.locate_tol else "bracketed"
    a_lo, a_hi = math.exp(lo), math.exp(hi)
    return BackboneEvent(kind, 0.5 * (a_lo + a_hi), (a_lo, a_hi), status, w_hi, d_hi, desc)
