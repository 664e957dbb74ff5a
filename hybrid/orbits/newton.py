"""Newton's method on the stroboscopic map ``P(y) = y`` from a section state: :func:`newton`.

Least-squares steps (``I - M`` is singular on a family of orbits and nearly singular for weakly
damped ones), the model's gauge on a family, a coarse first stage on the IDA path
(:func:`coarse_shooter`), Broyden updates between exact monodromies, a line search, the switch-time
Newton of :mod:`hybrid.orbits.sequence` on the exact path, and the tests that decide when the
residual has reached the noise of the map.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..core.errors import AlgebraicSolveError, GrazingSwitchError
from ..engine.trajectory import DeferredTrajectory, Trajectory
from ..integrators.flows import exact_flows
from .orbit import (
    PeriodicOrbit,
    balanced,
    failed_orbit,
    family_dimension,
    finish_orbit,
    is_family,
)
from .section import choose_section_period
from .sequence import sequence_events, solve_sequence
from .shooter import Shooter

#: What projecting a state onto a mode's constraint manifold (:meth:`NewtonMap.project`) raises
#: where no consistent point is found there: the slave solve failed, or the model's own arithmetic
#: did (a division by zero, a logarithm of a negative number). Anything else (a TypeError, ...) is
#: a defect and propagates (issue 29).
NO_CONSISTENT_POINT = (AlgebraicSolveError, ArithmeticError, ValueError)

__all__ = ["NewtonMap", "coarse_shooter", "newton", "state_scale"]


#: What to try when Newton's method fails where an orbit may exist.
HINT = (
    "an orbit may still exist: try a longer transient (transient_periods; CLI --transient, e.g. 1000), "
    "another guess (x0; --x0) or a continuation from a nearby parameter value (hybrid frc)"
)


def state_scale(y: np.ndarray, d: np.ndarray) -> float:
    return max(float(np.max(np.abs(y[d]))) if d.size else 0.0, 1e-300)


class NewtonMap:
    """One section mode's Newton system: unknowns are its differential (non-quadrature) variables."""

    def __init__(self, shooter: Shooter, mode: str):
        self.sh = shooter
        cm = shooter.cs.modes[shooter.cs.mode_id(mode)]
        s = shooter.s
        self.d = np.array([i for i in s if cm.is_diff[i]], dtype=int)  # unknowns (state indices)
        self.pos = np.array([int(np.flatnonzero(s == i)[0]) for i in self.d], dtype=int)  # in s
        self.cm = cm

    def residual(self, tr: Trajectory, y0: np.ndarray) -> np.ndarray:
        return tr.y_final[self.d] - y0[self.d]

    def project(self, t: float, y: np.ndarray) -> np.ndarray:
        return self.cm.solve_algebraic(t, y)


def newton(
    shooter: Shooter,
    y: np.ndarray,
    mode0: str,
    t0: float,
    tol: float,
    max_iter: int,
    samples: int,
    at: list | None = None,
) -> PeriodicOrbit:
    """Newton's method on ``P(y) = y`` from a section state (see :func:`periodic_orbit`).

    ``at`` (a list) receives the current section state, mode, time and iteration.

    On the IDA path the first iterations run the map at a looser tolerance (:func:`coarse_shooter`)
    while the residual is far above what such a run resolves, then at the requested one; the
    converged orbit, its residual and its monodromy are always those of ``shooter``. The coarse
    stage is for the plain case only (no resonance, a decrease along every Newton direction):
    anything else there, and Newton's method starts again from the guess at the requested
    tolerances.
    """
    at = [] if at is None else at
    coarse = coarse_shooter(shooter, tol)
    if coarse is not None:
        stage = ["coarse"]
        try:
            out = _newton(shooter, coarse, y, mode0, t0, tol, max_iter, samples, at, stage)
        except (RuntimeError, GrazingSwitchError, ZeroDivisionError):
            # a failed run or monodromy (IDA, a grazing switch, the model's equations dividing by zero)
            if stage[0] != "coarse":
                raise  # at the requested tolerances: the caller reports it
            out = None
        finally:
            shooter.nfev += coarse.nfev
        if out is not None:
            return out
    return _newton(shooter, None, y, mode0, t0, tol, max_iter, samples, at, ["fine"])


def _newton(shooter, coarse, y, mode0, t0, tol, max_iter, samples, at, stage) -> PeriodicOrbit | None:
    """:func:`newton` from ``coarse`` (a Shooter at a looser tolerance, or None) then ``shooter``.

    Returns None where the coarse stage gives up (``stage[0]`` is ``"coarse"`` until it ends).
    """
    nw = NewtonMap(shooter, mode0)
    d = nw.d
    rcond = 1e-7
    try:
        y = nw.project(t0, np.array(y, dtype=float))
    except NO_CONSISTENT_POINT as exc:
        return failed_orbit(
            shooter, y, mode0, t0, 0, math.inf, f"guess is not consistent: {exc}", "inconsistent-guess"
        )
    scale0 = state_scale(y, d)
    res_norm = math.inf

    def fail(why: str, reason: str) -> PeriodicOrbit:
        """The failed result at the current iterate (``reason``: its code)."""
        return failed_orbit(shooter, y, mode0, t0, it, res_norm, why, reason)

    note = ""
    reason = ""  # a code if the orbit is not accepted although its residual met tol
    family = False
    picked = None  # the gauges that hold the member of a family (indices), on a family with gauges
    it = 0
    rephased = 0
    resonant = False  # I - M singular with the mismatch outside its range, at the last iteration
    tr = None  # the run from y, when the line search already has it
    sampled = False  # tr is a sampled run (samples per period), usable for the result
    J = None  # M_dd - I: exact after a monodromy, then Broyden-updated (None: recompute)
    uphill = 0  # steps far from the orbit accepted without a decrease (reported)
    stalled = False  # the exact Newton step vanishes while the residual does not
    J_here = False  # J is the exact one at the current iterate
    M_y = None  # the monodromy at y at the requested tolerances, if made (the result's, if y is)
    policy = NewtonPolicy.for_method(shooter.method)
    broyden = policy.broyden
    # Relative accuracy of one run of the map (the exact integrator's is rounding).
    noise_rtol = shooter.noise_rtol
    settle = False  # the residual met the tolerance and a further correction found no decrease
    sh = coarse or shooter  # the map of the current iteration
    pending = None  # the coarse run from y, for I - M at the first step of the requested map
    seq_tried = False  # the switch-time Newton of the exact integrator (once, from the first run)
    while True:
        at[:] = [y, mode0, t0, it]
        if tr is None:
            tr, sampled = sh.run(y, mode0, t0), False
        if sh is coarse and not tr.success:
            return None
        if not tr.success:
            return fail(f"run failed at iteration {it}: {tr.message}", "run-failed")
        r = nw.residual(tr, y)
        scale = state_scale(y, d)
        res_norm = float(np.max(np.abs(r))) / scale
        if sh is coarse and (it >= max_iter or scale > 1e3 * max(scale0, 1e-300)):
            return None
        if sh is coarse and res_norm <= COARSE_SWITCH * coarse.noise_rtol:
            # Near the coarse map's noise: from here on the requested map. Its first Newton step
            # takes I - M from the coarse run here (accurate to about its rtol, made only if
            # needed); Broyden's updates follow from runs of the requested accuracy only.
            sh, pending, tr, J, stage[0] = shooter, tr, None, None, "fine"
            continue
        if (
            not seq_tried
            and policy.switch_time_newton
            and res_norm > tol
            and it < max_iter
            and tr.mode_final == mode0
        ):
            # the exact integrator: Newton in the switch times of this run's sequence, checked by a run
            seq_tried = True
            cand = _sequence_candidate(shooter, nw, tr, y, mode0, t0, samples, res_norm, tol)
            if cand is not None:
                y, tr, sampled = cand
                it += 1
                J, J_here, M_y, pending = None, False, None, None
                continue
        g = shooter.gauge(y)
        gauge_bad = (
            family
            and picked is not None
            and picked.size > 0
            and float(np.max(np.abs(g.values[picked]))) > tol * scale
        )
        if res_norm <= tol and not gauge_bad and J is None and policy.cheap_jacobian and 0 < it < max_iter:
            # the exact integrator: judge the correction with the exact Jacobian here (cheap)
            M_y = shooter.monodromy(tr)
            J, J_here = M_y[np.ix_(nw.pos, nw.pos)] - np.eye(d.size), True
        elif (
            res_norm <= tol
            and not gauge_bad
            and not settle
            and M_y is None
            and not policy.cheap_jacobian
            and it < max_iter
            and tr.mode_final == mode0
        ):
            # IDA: the correction is judged with the exact Jacobian here, from the monodromy the
            # result needs if y is accepted (not from Broyden's estimate, nor accepted unjudged)
            M_y = shooter.monodromy(tr)
            J, J_here = M_y[np.ix_(nw.pos, nw.pos)] - np.eye(d.size), True
        if (
            res_norm <= tol
            and not gauge_bad
            and (settle or _settled(J, r, tol, scale, rcond, noise_rtol, it, max_iter))
        ):
            if tr.mode_final == mode0:
                break
            if rephased < 3:  # converged onto a section at a switch: move the section
                rephased += 1
                trx = shooter.run(y, mode0, t0, samples=256)
                t1, y1, m1 = choose_section_period(trx, shooter.period)
                t0, y, mode0 = t1, y1, m1
                nw = NewtonMap(shooter, mode0)
                d = nw.d
                tr, J, M_y = None, None, None
                continue
            note = "the mode at t0 + T differs from the section's mode; "
            reason = "mode-mismatch"
            break
        if it >= max_iter or stalled:
            grows = scale > 1e3 * max(scale0, 1e-300)
            if grows:
                why, code = "the response grows without bound: no bounded periodic orbit", "unbounded"
            elif resonant and res_norm > 1e-4:
                why = (
                    "no bounded periodic orbit near the guess: a Floquet multiplier is 1 and the mismatch "
                    "P(x) - x lies outside the range of I - M (a resonance: the response grows by the same "
                    "amount every period); if something limits that growth at larger amplitude, " + HINT
                )
                code = "resonance"
            else:
                why = "Newton's method did not converge; " + _noisy(J, res_norm, tol, noise_rtol) + HINT
                code = "not-converged"
            return fail(f"{why} ({it} iterations, residual {res_norm:.3g})", code)
        if not np.all(np.isfinite(tr.y_final)) or scale > 1e6 * max(scale0, 1.0):
            return fail(
                "the response grows without bound: no bounded periodic orbit "
                f"(max |x| = {scale:.3g} after {it} Newton iterations)",
                "unbounded",
            )
        it += 1
        while True:  # a Newton direction, then an Armijo line search along it
            if J is None and pending is not None:
                try:
                    M = coarse.monodromy(pending)
                    J = M[np.ix_(nw.pos, nw.pos)] - np.eye(d.size)
                except (RuntimeError, GrazingSwitchError, ZeroDivisionError):
                    pass  # the requested map's own, below
                pending = None
            exact = J is None or J_here  # (not the coarse one: without descent it is made exact)
            if J is None:
                M = sh.monodromy(tr)
                J = M[np.ix_(nw.pos, nw.pos)] - np.eye(d.size)
                if sh is shooter:
                    M_y = M
            J_here = False
            # In balanced coordinates (the units of the state do not decide rank and truncation)
            Js, bs = balanced(J)
            sv = np.linalg.svd(Js, compute_uv=False)
            family = is_family(sv)
            # on a family, the gauges that fix its directions (picked against its null space)
            picked = (
                g.pick(np.linalg.svd(Js)[2], family_dimension(sv), d, bs)
                if (family and g is not None)
                else None
            )
            A = np.vstack([Js, g.grad[picked][:, d] * bs]) if picked is not None else Js
            rhs = _rhs(r, g, picked)
            w = np.concatenate([1.0 / bs, np.ones(rhs.size - bs.size)])  # rows in balanced units
            pinv = np.linalg.pinv(A, rcond=rcond) * w[None, :]  # rhs -> balanced step
            step_b = pinv @ rhs
            step = bs * step_b
            rhs = rhs * w
            if exact:  # judged on the exact I - M only; once seen, kept for the diagnosis
                rn = float(np.linalg.norm(rhs))
                resonant = resonant or bool(
                    (
                        sv[-1] <= 1e-6 * max(sv[0], 1e-300)
                        and rn > 0
                        and np.linalg.norm(A @ step_b - rhs) > 0.5 * rn
                    )
                    # a Newton step thousands of times the state: I - M nearly singular, mismatch
                    # outside its range (the line search then keeps the iterates from growing)
                    or float(np.max(np.abs(step))) > 1e3 * max(scale, scale0)
                )
            if sh is coarse and resonant:
                return None  # not the plain case: diagnosed at the requested tolerances
            # The linear model corrects almost none of the mismatch (it lies outside the range of
            # the matrix): no progress is possible along Newton's step.
            if float(np.linalg.norm(A @ step_b)) <= 1e-3 * float(np.linalg.norm(rhs)):
                if exact:
                    stalled = True  # the mismatch lies outside the range of I - M
                    break
                J = None
                continue
            # A step expected to end at the orbit is run with samples: accepted, its run is
            # the result's (nothing is integrated twice).
            ahead = samples if (sh is shooter and res_norm <= SAMPLE_AHEAD * tol) else None
            found, best = _line_search(
                sh,
                nw,
                y,
                mode0,
                t0,
                step,
                pinv,
                picked,
                float(np.linalg.norm(rhs / w)),
                ahead,
                phi0=float(np.linalg.norm(step_b)),
            )
            if found is not None or exact:
                break
            J = None  # the updated Jacobian gave no descent: recompute it exactly at y
        if sh is coarse and (stalled or resonant or found is None):
            return None  # not the plain case: diagnosed at the requested tolerances
        if stalled:
            continue
        if found is None and res_norm <= tol:
            settle = True  # the correction asked for by _settled is below what the runs resolve
            continue
        if found is None:
            if res_norm <= 0.1:
                return fail(
                    "Newton's method found no decrease of the residual along its direction (the map "
                    f"is not smooth here, or not accurate enough for the tolerance); "
                    f"{_noisy(J, res_norm, tol, noise_rtol)}{HINT} ({it} iterations, residual {res_norm:.3g})",
                    "no-decrease",
                )
            # Far from the orbit (a transient's guess): take the best point tried, uphill, and say so.
            found = best
            if found is None:
                return fail(f"every run along the Newton step failed ({HINT})", "run-failed")
            uphill += 1
        y_new, tr, lam = found
        sampled = not isinstance(tr, DeferredTrajectory) and ahead is not None and lam == 1.0
        # Broyden's update of J from the step taken (exact again whenever the line search cut it).
        r_new = nw.residual(tr, y_new)
        s_d = y_new[d] - y[d]
        ss = float(s_d @ s_d)
        if lam == 1.0 and ss > 0 and not family and broyden:
            J = J + np.outer((r_new - r) - J @ s_d, s_d) / ss
        else:
            J = None
        y, M_y, pending = y_new, None, None
    if uphill:
        note += f"{uphill} Newton step(s) far from the orbit accepted without a decrease of the residual; "
        reason = reason or "uphill"
    at[:] = [y, mode0, t0, it]
    return finish_orbit(
        shooter,
        nw,
        y,
        mode0,
        t0,
        it,
        res_norm,
        tol,
        samples,
        note,
        tr=tr if sampled else None,
        M=M_y,
        reason=reason,
    )


def _sequence_candidate(shooter, nw, tr, y, mode0, t0, samples, res_norm, tol):
    """The orbit with the switching sequence of ``tr`` by Newton in its switch times
    (:mod:`hybrid.orbits.sequence`), run with samples from its section state (it is expected to be the
    orbit: a rejected candidate costs one sampled run): ``(y, run, True)`` where that run returns
    to within ``max(tol, 1e-3 x res_norm)`` of it, else None (nothing changes)."""

    cs = shooter.cs
    modes = exact_flows(cs)
    m0 = cs.mode_id(mode0)
    try:
        events = sequence_events(tr, cs, t0, shooter.period)
        yd = None if events is None else solve_sequence(modes, m0, t0, shooter.period, y, events)
    except (ArithmeticError, ValueError, np.linalg.LinAlgError):
        return None
    if yd is None:
        return None
    y_new = np.array(y, dtype=float)
    y_new[modes[m0].d] = yd
    try:
        y_new = nw.project(t0, y_new)
    except NO_CONSISTENT_POINT:  # no consistent point there
        return None
    run = shooter.run_now(y_new, mode0, t0, samples)
    if not run.success or not np.all(np.isfinite(run.y_final)):
        return None
    res = float(np.max(np.abs(nw.residual(run, y_new)))) / state_scale(y_new, nw.d)
    if not res <= max(tol, 1e-3 * res_norm):
        return None
    return y_new, run, True


def _noisy(J, res_norm: float, tol: float, rtol: float) -> str:
    """Why a residual that stalls near the tolerance may not go lower: ``I - M`` (``J``, its last
    estimate) so ill-conditioned that the runs' error, amplified by it, exceeds the tolerance
    (a multiplier near 1: a resonance, a degenerate orbit, a family); '' otherwise."""
    if J is None or not res_norm <= 100.0 * tol or not np.all(np.isfinite(J)):
        return ""
    sv = np.linalg.svd(J, compute_uv=False)  # in the state's own units, as the orbit's `condition`
    cond = float(sv[0] / sv[-1]) if sv.size and sv[-1] > 0 else math.inf
    if not cond * rtol > tol:
        return ""
    cure = (
        "tighten rtol (--rtol) or use the exact integrator (--integrator exact) where the model is affine"
        if rtol > 1e-14
        else "loosen the tolerance (tol, --tol)"
    )
    return (
        f"the residual stalls near the tolerance because I - M is nearly singular here (cond {cond:.3g}: a "
        f"multiplier near 1), so the runs' relative error {rtol:.2g} becomes about {cond * rtol:.2g} on the "
        f"state; {cure}; "
    )


def coarse_shooter(shooter: Shooter, tol: float) -> Shooter | None:
    """The period map at the looser tolerance ``COARSE_RTOL`` (absolute tolerances scaled alike),
    for the first Newton iterations on the IDA path; None where it would not save anything (the
    exact integrator, a requested rtol already near it, or a tolerance it cannot approach)."""
    rc = COARSE_RTOL
    loose = shooter.method.loosened_to(rc) if NewtonPolicy.for_method(shooter.method).coarse_stage else None
    if loose is None or COARSE_SWITCH * rc <= 10.0 * tol:
        return None
    opts = shooter.options.with_method(loose)
    return Shooter(shooter.system, shooter.params, opts, shooter.free, shooter.periods)


def _settled(J, r, tol: float, scale: float, rcond: float, rtol: float, it: int, max_iter: int) -> bool:
    """A residual below the tolerance is not yet an accurate state when ``I - M`` is ill-conditioned:
    with a Jacobian at hand, the Newton correction it gives must be below the tolerance too (or at
    the noise level of the map, ``SETTLE_NOISE x cond x rtol``, relative to ``scale``), else one
    more step is taken (Broyden's iterates stop earlier than quadratic ones would)."""
    if J is None or it >= max_iter:
        return True
    Js, bs = balanced(J)  # in balanced units, as Newton's steps
    sv = np.linalg.svd(Js, compute_uv=False)
    if not sv.size or sv[0] == 0.0:
        return True
    corr = bs * np.linalg.lstsq(Js, -r / bs, rcond=rcond)[0]
    noise = SETTLE_NOISE * sv[0] / max(sv[-1], rcond * sv[0]) * rtol
    return float(np.max(np.abs(corr))) <= max(tol, noise) * scale


#: The noise level of a Newton correction in :func:`_settled`, in units of ``cond(I - M) x rtol``.
SETTLE_NOISE = 10.0


#: Broyden's updates of I - M between exact monodromies where a monodromy costs a variational run
#: with tolerances (False: exact Newton everywhere).
BROYDEN = True


@dataclass(frozen=True)
class NewtonPolicy:
    """Which stages of Newton's method on a period map apply, chosen from the method's capabilities.

    Attributes
    ----------
    broyden : bool
        Update ``I - M`` by Broyden's rule between monodromies: each monodromy is a variational
        run at the method's tolerances (IDA), worth saving; an exact monodromy is cheap and its
        exact Newton steps reach rounding.
    coarse_stage : bool
        Start at looser tolerances (:func:`coarse_shooter`): the method has tolerances to loosen.
    switch_time_newton : bool
        Solve for the switch times of a run's sequence (:mod:`hybrid.orbits.sequence`): the flows
        are exact, so a sequence's switch times are roots of exact functions.
    cheap_jacobian : bool
        Judge a correction that meets the tolerance with the exact Jacobian there (cheap where
        the flows are exact); else the monodromy is made only where the result needs it.
    """

    broyden: bool
    coarse_stage: bool
    switch_time_newton: bool
    cheap_jacobian: bool

    @classmethod
    def for_method(cls, method) -> NewtonPolicy:
        """The policy for ``method`` (a :class:`hybrid.integrators.base.Method`)."""
        exact = method.flows_exact
        return cls(
            broyden=BROYDEN and not exact,
            coarse_stage=not exact,
            switch_time_newton=exact,
            cheap_jacobian=exact,
        )


#: Relative tolerance of the coarse runs of the map (the first Newton iterations on the IDA path).
COARSE_RTOL = 1e-7


#: The coarse runs are used while the residual is above this multiple of their rtol.
COARSE_SWITCH = 1e3


#: A Newton step from a residual below this multiple of the tolerance is run with samples (it is
#: expected to end at the orbit, whose sampled run the result needs).
SAMPLE_AHEAD = 100.0


#: Armijo's sufficient-decrease constant.
ARMIJO = 1e-4


#: Step halvings of the line search.
MAX_BACKTRACKS = 8


def _rhs(r: np.ndarray, g, picked: np.ndarray | None) -> np.ndarray:
    """Right-hand side of the Newton system: ``-r``, and ``-gauge`` for the gauges ``picked`` on a
    family (:meth:`hybrid.orbits.gauge.Gauge.pick`)."""
    return np.concatenate([-r, -g.values[picked]]) if picked is not None else -r


def _line_search(shooter, nw, y, mode0, t0, step, pinv, picked, res0, samples=None, phi0=None):
    """Armijo backtracking along the Newton step ``step = pinv @ rhs(y)``.

    The first ``lam = 1, 1/2, ...`` is taken where the residual norm ``|rhs|`` decreases
    sufficiently, ``|rhs(y + lam step)| <= (1 - c lam) res0`` (``res0 = |rhs(y)|``), or the
    residual in Newton's natural norm does, ``|pinv @ rhs(y + lam step)| <= (1 - c lam) |step|``
    (``pinv``: the pseudo-inverse of the iteration's own matrix). The natural norm is invariant
    under a rescaling of the equations: far from a weakly damped orbit the plain residual of a
    nearly singular ``I - M`` decreases only along steps thousands of times shorter than
    Newton's; near the orbit it is the plain residual that is reliable (the natural norm
    amplifies the integration noise by ``cond(I - M)``).

    The first trial (``lam = 1``) is run with ``samples`` per period if given (a step expected to
    end at the orbit). ``phi0`` is ``|pinv @ rhs(y)|`` (default ``|step|``: ``pinv`` gives the step
    itself; the caller's may give it in balanced units, :func:`hybrid.orbits.orbit.balance_scales`).

    Returns ``(found, best)``: ``found = (y_new, run, lam)`` or None (the run is kept for the
    next iteration: nothing is integrated twice); without one, ``best`` is the tried point of
    least merit in the same form (for a step far from the orbit, reported by the caller), or None.
    """
    d = nw.d
    phi0 = float(np.linalg.norm(step)) if phi0 is None else phi0
    lam = 1.0
    best = None
    for _ in range(MAX_BACKTRACKS):
        y_new = y.copy()
        y_new[d] += lam * step
        try:
            y_new = nw.project(t0, y_new)
        except NO_CONSISTENT_POINT:  # no consistent point there: a shorter step
            lam *= 0.5
            continue
        tr = (
            shooter.run_now(y_new, mode0, t0, samples)
            if (samples and lam == 1.0)
            else shooter.run(y_new, mode0, t0)
        )
        if tr.success and np.all(np.isfinite(tr.y_final)):
            rhs = _rhs(nw.residual(tr, y_new), shooter.gauge(y_new), picked)
            phi = float(np.linalg.norm(pinv @ rhs))
            if (
                phi <= (1.0 - ARMIJO * lam) * phi0
                or float(np.linalg.norm(rhs)) <= (1.0 - ARMIJO * lam) * res0
            ):
                return (y_new, tr, lam), None
            if best is None or phi < best[0]:
                best = (phi, y_new, tr, lam)
        lam *= 0.5
    return None, (best[1:] if best is not None else None)
