"""Periodic orbits of autonomous hybrid systems: the period is an unknown.

A model without a forcing ``period`` (e.g. a self-excited oscillator) has periodic orbits whose
period must be found with the orbit. Two phase conditions fix the time origin:

* **a switch as the section** (``phase`` = a transition's name, or the model's
  ``[orbit] section``): the orbit starts just after that switch and ends when it fires again;
  Newton's method solves ``P(y) = y`` for the return map ``P`` (:meth:`FlowMap.returned`), whose
  Jacobian has the flow direction in its kernel, so ``P - I`` is regular at an isolated orbit;
  the period is the return time;
* **an anchor** (``phase="anchor"``): the orbit starts on the hyperplane through a reference
  point ``y_ref`` orthogonal to the flow there, ``f(y_ref) . (y0 - y_ref) = 0``; unknowns
  ``(y0, T)``, equations ``y(T) - y0 = 0`` and the anchor (the bordered Newton system
  ``[[M - I, f(y(T))], [f(y_ref), 0]]``). For orbits that cross no switch (a smooth
  self-excited cycle).

The monodromy ``M = dy(T)/dy(0)`` over one period always has the **trivial multiplier 1**, with
the flow direction ``f(y0)`` as its eigenvector (a shift along the orbit stays on it); it is
labelled ``"trivial"`` in ``multiplier_kinds`` (the eigenvector most nearly parallel to
``f(y0)``) and its distance from 1 is a check of the monodromy's accuracy (stated in the
orbit's message). Stability is decided by the others.
"""

from __future__ import annotations

import math
import types
from collections.abc import Mapping
from typing import NamedTuple

import numpy as np

from ..core.errors import BudgetExceeded, GrazingSwitchError, InputError, InputTypeError, ParameterOutOfDomain
from ..core.notices import collected
from ..core.options import ShootingOptions, reject_keywords
from ..core.status import SolveStatus
from ..core.threads import with_blas_threads
from ..engine.simulate import initial_state
from ..integrators.options import SolverOptions
from ..model.orbit_hints import period_guess
from ..model.system import HybridSystem
from .flowmap import Evaluation, FlowMap
from .orbit import (
    ORBIT_OPTIONS,
    PeriodicOrbit,
    _Extrema,
    check_orbit_inputs,
    failed_orbit,
    mode_fractions,
    with_options,
)

__all__ = ["autonomous_orbit", "AutonomousSolver", "TRIVIAL"]

#: Kind of the multiplier 1 of an autonomous orbit (flow direction).
TRIVIAL = "trivial"

#: Step halvings of Newton's line search.
MAX_BACKTRACKS = 10


def resolve_phase(system: HybridSystem, phase: str) -> str:
    """``"anchor"`` or a transition name (``"auto"``: the model's ``[orbit] section``, else the anchor)."""
    if not isinstance(phase, str):
        raise InputTypeError(f"`phase` must be a string, got {type(phase).__name__}")
    if phase == "auto":
        return system.parsed.autonomous["section"] or "anchor"
    names = [tr.name for tr in system.transitions]
    if phase != "anchor" and phase not in names:
        raise InputError(
            f"`phase` must be 'auto', 'anchor' or a transition of model `{system.name}` "
            f"({', '.join(names)}), got {phase!r}"
        )
    return phase


def time_scale(system: HybridSystem, params: Mapping[str, float], period: float | None) -> float:
    """The period guess [s]: ``period`` if given, else the model's ``[orbit] period_guess``."""
    if period is not None:
        if not (isinstance(period, int | float) and not isinstance(period, bool) and math.isfinite(period)):
            raise InputError(f"`period` must be a finite number > 0, got {period!r}")
        if period <= 0:
            raise InputError(f"`period` must be a finite number > 0, got {period!r}")
        return float(period)
    T = period_guess(system, system.parameter_values(params))
    if T is None:
        raise InputError(
            f"model `{system.name}` is autonomous (no forcing period) and declares no `[orbit] period_guess`: "
            "give `period` (a guess of the orbit's period, s)"
        )
    return T


class AutonomousSolver:
    """Newton's method for one autonomous orbit on a :class:`FlowMap` (a free parameter held fixed).

    Parameters
    ----------
    fm : FlowMap
    phase : str
        ``"anchor"`` or the name of the section's transition.
    tol : float
        Tolerance on ``max |P(y) - y|`` relative to ``max |y|`` (differential variables).
    max_iter : int
    """

    def __init__(self, fm: FlowMap, phase: str, tol: float, max_iter: int):
        self.fm, self.phase, self.tol, self.max_iter = fm, phase, tol, max_iter

    def unknowns(self, mode: str) -> tuple[np.ndarray, np.ndarray]:
        """Differential (non-quadrature) variables of ``mode``, as state indices and positions in ``s``."""
        cm = self.fm.mode(mode)
        s = self.fm.s
        d = np.array([i for i in s if cm.is_diff[i]], dtype=int)
        pos = np.array([int(np.flatnonzero(self.fm.sens.s == i)[0]) for i in d], dtype=int)
        return d, pos

    def evaluate(self, y: np.ndarray, mode: str, T: float, derivatives: bool = True) -> Evaluation:
        if self.phase == "anchor":
            return self.fm.timed(y, mode, T, derivatives=derivatives)
        return self.fm.returned(y, mode, self.phase, RETURN_WINDOW * T, derivatives=derivatives)

    def residual(self, ev: Evaluation, y, d, anchor) -> np.ndarray:
        r = ev.end[d] - y[d]
        if anchor is None:
            return r
        y_ref, f_ref = anchor
        return np.concatenate([r, [f_ref @ (y[d] - y_ref[d])]])

    def jacobian(self, ev: Evaluation, d, pos, anchor) -> np.ndarray:
        """Newton matrix in the unknowns (``y_d``, then ``T`` for the anchor; free parameter last)."""
        J = ev.jacobian
        n = d.size
        cols = list(pos) + ([J.shape[1] - 1] if self.fm.free else [])
        A = J[np.ix_(pos, cols)]
        A[:, :n] -= np.eye(n)
        if anchor is None:
            return A
        f_end = ev.field[d]
        A = np.hstack([A[:, :n], f_end[:, None], A[:, n:]])
        row = np.zeros(A.shape[1])
        row[:n] = anchor[1]
        return np.vstack([A, row])

    def solve(self, y: np.ndarray, mode: str, T: float, anchor=None):
        """Newton from ``(y, mode, T)``; returns ``(y, T, evaluation, iterations, residual, reason,
        message)``.

        ``reason`` (a code of :data:`hybrid.core.status.SOLVE_REASONS`) and ``message`` are empty
        on convergence. With the anchor phase, ``anchor = (y_ref, f_ref)``
        (default: the guess and the flow there).
        """
        fm = self.fm
        d, pos = self.unknowns(mode)
        y = fm.mode(mode).solve_algebraic(0.0, np.array(y, dtype=float))
        if self.phase == "anchor" and anchor is None:
            f = fm.field(mode, y)[d]
            anchor = (y.copy(), f / max(float(np.linalg.norm(f)), 1e-300))
        if self.phase != "anchor":
            anchor = None
        ev = self.evaluate(y, mode, T)
        res = math.inf
        for it in range(self.max_iter + 1):
            if self.phase != "anchor":
                T = ev.time
            r = self.residual(ev, y, d, anchor)
            scale = max(float(np.max(np.abs(y[d]))), 1e-300)
            res = float(np.max(np.abs(r))) / scale
            A = self.jacobian(ev, d, pos, anchor)
            step = np.linalg.lstsq(A, -r, rcond=None)[0]
            if res <= self.tol and float(np.max(np.abs(step[: d.size]))) <= self.tol * scale:
                if ev.end_mode != mode:
                    msg = f"the orbit ends in mode `{ev.end_mode}`, not `{mode}`"
                    return y, T, ev, it, res, "mode-mismatch", msg
                return y, T, ev, it, res, "", ""
            if it == self.max_iter:
                break
            lam, r0 = 1.0, float(np.linalg.norm(r))
            for _ in range(MAX_BACKTRACKS):
                y_new = y.copy()
                y_new[d] += lam * step[: d.size]
                T_new = T + lam * step[d.size] if self.phase == "anchor" else T
                try:
                    y_new = fm.mode(mode).solve_algebraic(0.0, y_new)
                    if not T_new > 0:
                        raise ParameterOutOfDomain("negative period")
                    ev_new = self.evaluate(y_new, mode, T_new)
                    if float(np.linalg.norm(self.residual(ev_new, y_new, d, anchor))) < (1 - 1e-4 * lam) * r0:
                        break
                except (RuntimeError, GrazingSwitchError, ZeroDivisionError):
                    pass  # a failed run, a grazing switch, the model's equations dividing by zero
                lam *= 0.5
            else:
                return (
                    y,
                    T,
                    ev,
                    it,
                    res,
                    "no-decrease",
                    (
                        f"Newton's method found no decrease of the residual ({it} iterations, residual {res:.3g})"
                    ),
                )
            y, T, ev = y_new, T_new, ev_new
        return (
            y,
            T,
            ev,
            self.max_iter,
            res,
            "not-converged",
            f"Newton's method did not converge ({self.max_iter} iterations, residual {res:.3g})",
        )


#: The return to the section is sought within this multiple of the period estimate.
RETURN_WINDOW = 3.0


@collected
@with_blas_threads
def autonomous_orbit(
    system: HybridSystem,
    params: Mapping[str, float],
    x0=None,
    mode0: str | None = None,
    *,
    period: float | None = None,
    phase: str = "auto",
    options: SolverOptions | None = None,
    settings: ShootingOptions | None = None,
    **unexpected,
) -> PeriodicOrbit:
    """Periodic orbit of an autonomous model (no forcing): state, period, monodromy and multipliers.

    Parameters
    ----------
    system : HybridSystem
        A model without a forcing ``period`` whose equations do not depend on ``t``.
    params : mapping of str to float
        All parameter values.
    x0 : mapping or array_like, optional
        Start of the transient (default: all 0 in the initial mode).
    mode0 : str, optional
        Its mode (default: the model's initial mode).
    period : float, optional
        A guess of the period [s] (default: the model's ``[orbit] period_guess``).
    phase : str
        ``"auto"`` (the model's ``[orbit] section`` if declared, else ``"anchor"``), ``"anchor"``
        (a hyperplane orthogonal to the flow at a point of the transient), or a transition's name
        (the orbit starts just after that switch).
    options : SolverOptions, optional
        Tolerances (default :data:`hybrid.ORBIT_OPTIONS`, rtol 1e-10).
    settings : ShootingOptions, optional
        Newton's method (tolerance relative to ``max |y|``, iterations), the transient before it
        in period guesses (``transient_periods`` >= 1) and the samples of the returned
        one-period trajectory; default ``ShootingOptions()``.

    Returns
    -------
    PeriodicOrbit
        ``period`` is the computed period [s], ``t0`` is 0; ``multiplier_kinds`` labels the
        trivial multiplier 1 ``"trivial"``. ``status`` ``"failed"`` with its ``reason`` and
        ``message`` if no orbit was found.

    Raises
    ------
    ValueError
        Bad input (before any integration).

    Examples
    --------
    >>> import hybrid_models
    >>> belt = hybrid_models.belt()
    >>> orbit = autonomous_orbit(belt, belt.preset("standard"))
    >>> round(orbit.period, 6)   # 2 (Fs - Fk) / (k v_b) + (pi + 2 atan(v_b / (omega d))) / omega
    6.712389
    """
    reject_keywords(
        "autonomous_orbit",
        unexpected,
        options=options if isinstance(options, SolverOptions) else SolverOptions,
        settings=settings if isinstance(settings, ShootingOptions) else ShootingOptions,
    )
    options = ORBIT_OPTIONS if options is None else options
    settings = ShootingOptions() if settings is None else settings
    check_orbit_inputs(system, options, settings, forced=False)
    if settings.periods != 1:
        raise InputError(
            f"ShootingOptions: `periods` = {settings.periods!r} is for periodically forced models (a "
            "subharmonic of the forcing); an autonomous orbit's period is an unknown found with it"
        )
    phase = resolve_phase(system, phase)
    mode0 = mode0 if mode0 is not None else system.default_mode
    if mode0 is None:
        raise InputError(f"`mode0` is required: model `{system.name}` declares no initial mode")
    system.mode(mode0)
    params = system.parameter_values(params)
    Tg = time_scale(system, params, period)
    fm = FlowMap(system, params, options, Tg)
    y = initial_state(system, np.zeros(len(system.variable_names)) if x0 is None else x0, mode0)
    solver = AutonomousSolver(fm, phase, settings.newton.tol, settings.newton.max_iter)
    return with_options(_solve(fm, solver, phase, y, mode0, Tg, settings), options, settings)


def _solve(
    fm: FlowMap, solver: AutonomousSolver, phase: str, y, mode0: str, Tg: float, settings: ShootingOptions
) -> PeriodicOrbit:
    """The orbit of :func:`autonomous_orbit` from its transient (failed: the reason and message)."""
    samples_per_period = settings.samples_per_period
    try:
        start = initial_guess(fm, phase, y, mode0, Tg, settings.transient_periods)
        if isinstance(start, GuessFailed):
            return failed(fm, y, mode0, Tg, 0, start.message, start.reason)
        y, mode, T = start
        y, T, ev, it, res, reason, msg = solver.solve(y, mode, T)
        if reason:
            return failed(fm, y, mode, T, it, msg, reason, res)
        return finish(solver, y, mode, T, ev, it, res, samples_per_period)
    except BudgetExceeded as exc:
        return failed(fm, y, mode0, Tg, 0, str(exc), "budget")
    except GrazingSwitchError as exc:
        return failed(fm, y, mode0, Tg, 0, f"{exc}; at a grazing, try a nearby parameter value", "grazing")
    except ZeroDivisionError as exc:  # the model's equations (e.g. a reset's derivative): not a grazing
        return failed(
            fm,
            y,
            mode0,
            Tg,
            0,
            f"evaluating the model's equations failed: ZeroDivisionError: {exc}",
            "evaluation-failed",
        )
    except RuntimeError as exc:
        return failed(fm, y, mode0, Tg, 0, str(exc), "run-failed")


class GuessFailed(NamedTuple):
    """What :func:`initial_guess` returns where the transient gives no start on the section."""

    reason: str  # a code of hybrid.core.status.SOLVE_REASONS
    message: str


def initial_guess(fm: FlowMap, phase: str, y, mode0: str, Tg: float, periods: int):
    """``(y, mode, T)`` on the section from a transient of ``periods`` period guesses, or a
    :class:`GuessFailed`."""
    n_samples = 64 * periods
    tr = fm.run(y, mode0, periods * Tg, samples=n_samples)
    if not tr.success:
        return GuessFailed("transient-failed", f"transient failed: {tr.message}")
    if phase != "anchor":
        hits = [e for e in tr.events if e.guard == phase]
        if not hits:
            return GuessFailed(
                "no-section-crossing",
                f"the transient ({periods} x {Tg:.6g} s) never crossed the section `{phase}`: no stick-slip "
                "cycle through it from this start (another start, x0, or phase='anchor')",
            )
        last = hits[-1]
        chain = [e for e in tr.events if e.t == last.t and (e is last or (e.chained and not e.coincident))]
        T = hits[-1].t - hits[-2].t if len(hits) > 1 else Tg
        return chain[-1].x_plus.copy(), chain[-1].target, T
    # the anchor: the middle of the longest mode interval of the last period guess
    t_end = tr.t_final
    ivs = [(max(a, t_end - Tg), b, m) for a, b, m in tr.mode_intervals() if b > t_end - Tg]
    a, b, m = max(ivs, key=lambda iv: iv[1] - iv[0])
    k = int(np.argmin(np.abs(tr.t - 0.5 * (a + b)) + (tr.mode != m) * 1e300))
    y_ref, t_ref = tr.y[k].copy(), float(tr.t[k])
    d = np.array([i for i in fm.s if fm.mode(m).is_diff[i]], dtype=int)
    f = fm.field(m, y_ref)[d]
    g = (tr.y[:, d] - y_ref[d]) @ f
    span = float(np.max(np.ptp(tr.y[:, d], axis=0))) or 1.0
    # the last earlier crossing of the hyperplane in the flow's direction, near the reference
    for j in range(k - 2, 0, -1):
        if g[j] < 0.0 <= g[j + 1] and float(np.max(np.abs(tr.y[j, d] - y_ref[d]))) < 0.2 * span:
            tc = tr.t[j] + (tr.t[j + 1] - tr.t[j]) * (-g[j]) / (g[j + 1] - g[j])
            return y_ref, m, t_ref - float(tc)
    return y_ref, m, Tg


def failed(fm: FlowMap, y, mode, T, it, msg: str, reason: str, res=math.inf) -> PeriodicOrbit:
    """The failed result (``status`` ``"failed"``, ``reason`` its code, ``message`` in words)."""
    view = types.SimpleNamespace(system=fm.system, names=fm.names, params=fm.params, period=T, nfev=fm.nfev)
    return failed_orbit(view, y, mode, 0.0, it, res, msg, reason)


def classify(mult: np.ndarray, vecs: np.ndarray, f0: np.ndarray, n_struct: int, mtol: float):
    """Order the multipliers, label the trivial one (eigenvector nearest the flow ``f0``) and the
    structural zeros, and give the verdict from the others: ``(mult, kinds, verdict, trivial)``."""
    n = mult.size
    kinds = ["floquet"] * n
    fn = f0 / max(float(np.linalg.norm(f0)), 1e-300)
    k_triv = None
    if vecs is not None and vecs.size and np.linalg.norm(f0) > 0:
        align = [
            abs(np.vdot(vecs[:, j], fn)) / max(np.linalg.norm(vecs[:, j]), 1e-300)
            for j in range(vecs.shape[1])
        ]
        k_triv = int(np.argmax(align))
    order = np.argsort(-np.abs(mult), kind="stable")
    mult = mult[order]
    if k_triv is not None:
        k_triv = int(np.flatnonzero(order == k_triv)[0])
        kinds[k_triv] = TRIVIAL
    for k in range(n - 1, -1, -1):
        if n_struct <= 0:
            break
        if kinds[k] == "floquet":
            kinds[k] = "structural"
            n_struct -= 1
    fl = np.array([abs(m) for m, kd in zip(mult, kinds, strict=True) if kd == "floquet"])
    if fl.size and fl.max() > 1.0 + mtol:
        verdict = "unstable"
    elif fl.size and fl.max() >= 1.0 - mtol:
        verdict = "neutral"
    else:
        verdict = "stable"
    trivial = complex(mult[k_triv]) if k_triv is not None else complex("nan")
    return mult, tuple(kinds), verdict, trivial


def finish(solver: AutonomousSolver, y, mode, T, ev: Evaluation, it, res, samples) -> PeriodicOrbit:
    """The orbit from its converged section state: one sampled period, multipliers, amplitudes."""
    fm = solver.fm
    system = fm.system
    d, pos = solver.unknowns(mode)
    # one sampled period; on a switch section the run stops a hair short of the return switch
    t_end = T if solver.phase == "anchor" else T * (1.0 - 1e-10)
    tr = fm.run(y, mode, t_end, samples=samples)
    M = ev.monodromy
    ns = fm.s.size
    Ms = M[:ns, :ns]
    A = Ms[np.ix_(pos, pos)]
    mu, vecs = np.linalg.eig(A)
    f0 = fm.field(mode, y)[d]
    n_slave = ns - d.size
    mult = np.concatenate([mu, np.zeros(n_slave)])
    vecs = np.vstack([vecs, np.zeros((n_slave, vecs.shape[1]))]) if n_slave else vecs
    vecs = np.hstack([vecs, np.zeros((vecs.shape[0], n_slave))]) if n_slave else vecs
    f0s = np.concatenate([f0, np.zeros(n_slave)])
    nd = {m.name: sum(1 for i in fm.s if m.is_diff[i]) for m in fm.cs.modes}
    visited = {mode} | {e.target for e in ev.events}
    n_struct = ns - min(nd[m] for m in visited)
    mtol = max(1e-6, 100.0 * fm.method.noise_rtol)
    mult, kinds, verdict, trivial = classify(mult, vecs, f0s, n_struct, mtol)
    ext = _Extrema(fm.cs, tr)
    amp, hpp = {}, {}
    series = {n: tr.y[:, i] for i, n in enumerate(fm.names) if n not in system.quadratures}
    series.update({o: tr.outputs[o] for o in system.outputs})
    for n, x in series.items():
        hi, lo = ext.extremes(n, x)
        amp[n] = max(abs(hi), abs(lo))
        hpp[n] = 0.5 * (hi - lo)
    Jn = solver.jacobian(ev, d, pos, None if solver.phase != "anchor" else (y, f0))
    Jn = Jn[:, :-1] if fm.free else Jn  # the free parameter's column is not an unknown here
    sv = np.linalg.svd(Jn, compute_uv=False)
    cond = float(sv[0] / sv[-1]) if sv.size and sv[-1] > 0 else math.inf
    where = "anchor" if solver.phase == "anchor" else f"section `{solver.phase}`"
    msg = (
        f"autonomous: period {T:.10g} s found with the orbit ({where}); trivial multiplier "
        f"1 {'+' if trivial.real >= 1 else '-'} {abs(trivial - 1.0):.2g}; converged"
    )
    return PeriodicOrbit(
        system=system,
        params=dict(fm.params),
        t0=0.0,
        period=float(T),
        x0=tr.y[0].copy(),
        mode0=mode,
        trajectory=tr,
        amplitude=amp,
        half_peak_to_peak=hpp,
        # on a switch section, the section's own switch closes the period
        # (a switch: transitions at one instant through modes held for no time, issue 30)
        mode_sequence=tuple([mode] + [e.target for e in tr.switches]),
        switch_times=np.array([e.t for e in tr.switches] + ([] if solver.phase == "anchor" else [float(T)])),
        mode_fractions=mode_fractions(tr, t_end),
        state_names=tuple(fm.names[i] for i in fm.s),
        monodromy=Ms,
        multipliers=mult,
        multiplier_kinds=kinds,
        stability=verdict,
        status=SolveStatus.CONVERGED,
        residual=res,
        iterations=it,
        condition=cond,
        family=False,
        message=msg,
        nfev=fm.nfev,
    )
