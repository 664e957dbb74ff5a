"""Pseudo-arclength continuation of periodic orbits in one parameter: :func:`continuation`.

Unknowns are the section state ``y_d`` (differential variables of the
section's mode) and the parameter ``p``; the section lies at a fixed
fraction ``phi`` of the forcing period, ``t0 = phi T(p)``. The residual is
``P(y_d, p) - y_d`` (plus the model's gauge on a family of orbits, see
:func:`hybrid.periodic_orbit`); its Jacobian ``[M_dd - I, dP/dp]`` is exact:
``M`` from the variational equations and saltation matrices, ``dP/dp`` from
the same run with ``p`` appended to the state, plus the motion of ``t0`` and
``t0 + T`` with ``p``. Steps are taken in scaled coordinates (state relative
to its current size, parameter relative to the range), with step control by
Newton's iteration count and step halving on failure.

Special points are detected between consecutive points and located along the
arclength of the step (:mod:`hybrid.continuation.special`). A branch ends when it leaves
the range, reaches ``max_points``, grows without bound (``"unbounded"``), or
stalls (``max_failures`` failed steps in a row); ``Branch.reason`` says which.
Settings are a :class:`hybrid.ContinuationOptions`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from functools import partial

import numpy as np

from ..core.callbacks import OnPoint, Progress
from ..core.errors import BudgetExceeded, GrazingSwitchError, InputError, InputTypeError
from ..core.notices import collected
from ..core.options import FIRST_ORBIT_MAX_ITER, ContinuationOptions, reject_keywords
from ..core.threads import with_blas_threads
from ..engine.simulate import check_time_range, initial_state
from ..engine.trajectory import Status
from ..integrators.options import SolverOptions
from ..model.system import HybridSystem
from ..orbits.newton import COARSE_RTOL, COARSE_SWITCH, NewtonMap, coarse_shooter, state_scale
from ..orbits.orbit import (
    FAMILY_TOL,
    ORBIT_OPTIONS,
    PeriodicOrbit,
    balance_scales,
    balanced,
    family_dimension,
    finish_orbit,
    is_family,
    local_fractions,
    mode_fractions,
)
from ..orbits.section import choose_section_period
from ..orbits.shooter import Shooter
from ..orbits.shooting import solve_orbit
from .branch import Branch, forcing_parameter
from .special import SpecialPoint, detect, locate

__all__ = [
    "SpecialPoint",
    "continue_orbits",
    "ContinuationPoint",
    "OrbitContinuer",
    "StepFailed",
    "STEP_FAILURES",
    "follow_branch",
    "row_weights",
]

#: The exceptions of a run or a linear solve that make a corrector step fail (as :class:`StepFailed`
#: does): the step is retried shorter, or the branch stops, instead of the exception propagating.
STEP_FAILURES = (ArithmeticError, RuntimeError, np.linalg.LinAlgError)

#: How much tighter (rtol and atol) the rerun of a probe is that estimates the integration error of
#: its phases (:meth:`OrbitContinuer.rerun`).
TIGHTER = 100.0


# ----------------------------------------------------------------------
class _Summary:
    """What a located mode change needs of an orbit not finished yet: its run (events, mode
    intervals) and the time fraction of each mode."""

    def __init__(self, tr, period: float, system):
        self.trajectory = tr
        self.system = system
        self.mode_fractions = mode_fractions(tr, period)
        self.local_fractions = local_fractions(system, self.mode_fractions)


class ContinuationPoint:
    """A point of the branch: section state, parameter, section mode and phase; its orbit (made on
    first use where the corrector was asked for a light point) and tangent."""

    def __init__(self, y, p, mode, phi, tangent=None, orbit=None, iterations=0):
        self.y = y  # full state at the section
        self.p = float(p)
        self.mode = mode
        self.phi = phi  # section phase (fraction of the period)
        self.tangent = tangent  # scaled (y_d, p)
        self._orbit = orbit
        self.iterations = iterations
        self.make = None  # builds the orbit of a light point
        self.summary = None  # _Summary of a light point
        self.jump = 0.0  # the corrector's distance from the predictor, relative to the step

    @property
    def orbit(self) -> PeriodicOrbit | None:
        if self._orbit is None and self.make is not None:
            self._orbit, self.make = self.make(), None
        return self._orbit

    @orbit.setter
    def orbit(self, o) -> None:
        self._orbit = o

    def view(self):
        """The orbit if made, else the light summary (for signatures and mode fractions)."""
        return self._orbit if self._orbit is not None or self.summary is None else self.summary


#: The least size of a branch's first orbit from which growth is measured, for a method without
#: absolute tolerances (an orbit at rest has a size of rounding noise).
SIZE_FLOOR = 1e-12


def _gauge_member(
    c: OrbitContinuer, pt: ContinuationPoint, new: ContinuationPoint, ds: float, samples: int
) -> ContinuationPoint | None:
    """The gauge member of the neutral family that ``new`` (a boundary member: one grazing switch
    per period) belongs to, or None: corrected with the gauge enforced from ``pt`` along the
    step, else from ``new`` moved onto the gauge's zero set (``y - g grad g / |grad g|^2``) at
    its parameter value."""
    starts = [(pt, ds)]
    g = c.sh.gauge(new.y)
    if g is not None and np.any(g.grad != 0.0):
        c.at(new.p)
        # the least change of the state that zeroes every gauge (to first order)
        G = g.grad
        y = new.y - (
            g.values[0] * G[0] / float(G[0] @ G[0])
            if g.size == 1
            else np.linalg.lstsq(G, g.values, rcond=None)[0]
        )
        starts.append((ContinuationPoint(y, new.p, new.mode, new.phi, tangent=new.tangent), 0.0))
    for start, step in starts:
        try:
            alt = c.correct(start, step, samples, force_gauge=True)
        except (StepFailed, *STEP_FAILURES):
            continue
        if alt.orbit.transitions_per_period == 0:
            return alt
    return None


class OrbitContinuer:
    """What following one branch of forced periodic orbits needs: the period map with the
    continuation parameter free (:class:`hybrid.orbits.shooter.Shooter`, and its coarse and tight
    variants), the scaled coordinates of the arclength, the bordered Newton corrector
    (:meth:`correct`) and the tangent (:meth:`tangent`).

    Parameters
    ----------
    system : HybridSystem
    params : mapping
        Parameter values at the start (the continuation parameter among them).
    parameter : str
        The continuation parameter.
    p_range : (float, float)
        The parameter's range ``(a, b)``; its length scales the parameter in the arclength.
    options : SolverOptions
    settings : ContinuationOptions
    periods : int
        Forcing periods the map spans (2 on the branch born at a period doubling).
    """

    def __init__(
        self, system, params, parameter, p_range, options, settings: ContinuationOptions, periods: int = 1
    ):
        self.system = system
        self.parameter = parameter
        self.base = dict(params)
        self.a, self.b = p_range
        self.sp = abs(self.b - self.a)
        self.settings = settings
        self.tol = settings.newton.tol
        self.sh = Shooter(system, params, options, free=parameter, periods=periods)
        # The map at a looser tolerance for the iterations that cannot be accepted (IDA only).
        self.coarse = coarse_shooter(self.sh, self.tol)
        self._coarse_jac = True  # the Newton system last seen fit for a coarse M (see correct)
        self.bs: np.ndarray | None = None  # balancing scales of the state, from the first point
        self.tight: Shooter | None = None  # the map at tighter tolerances (see rerun)
        self._frame = None  # (d, D) of coords

    def at(self, p: float) -> None:
        params = {**self.base, self.parameter: p}
        self.sh.set_params(params)
        if self.coarse is not None:
            self.coarse.set_params(params)

    # scaled coordinates -------------------------------------------------
    def scale_of(self, pt: ContinuationPoint, d: np.ndarray) -> float:
        return state_scale(pt.y, d)

    def scales(self, pt: ContinuationPoint, d: np.ndarray) -> np.ndarray:
        """``D``: unscaled = scaled x D, the state by its size in the balanced units of the
        branch's first point (:func:`hybrid.orbits.orbit.balance_scales`, kept along the branch: the
        units do not change, and scales that changed from point to point, as they do near a fold,
        would change the arclength under the corrector; all ones for a model in consistent units,
        where this is the state's largest component), the parameter by the range."""
        bs = self.bs if self.bs is not None and self.bs.size == d.size else np.ones(d.size)
        size = max(float(np.max(np.abs(pt.y[d]) / bs)) if d.size else 0.0, 1e-300)
        return np.concatenate([bs * size, [self.sp]])

    def system_matrix(self, y, Jy, Jp, r, d, force_gauge: bool = False, ref=None, isolated: bool = False):
        """Rows of the (scaled) Newton system, and on a family of orbits (a neutral multiplier 1) a
        row that picks the member: the model's gauge, or without one the family's own direction
        (the null vector of ``I - M``) held at its value at ``ref`` (the last point: the member
        nearest it, so that the branch does not wander along the family). A fold, where ``I - M``
        is singular too but ``[I - M, dP/dp]`` is not, gets no such row.

        Returns ``(A, rhs, family, gauge value or None)``.
        """
        Jb, bs = balanced(Jy)  # rank tests in balanced units
        _, sv, vt = np.linalg.svd(Jb)
        family = force_gauge or (not isolated and is_family(sv))
        A = np.hstack([Jy, Jp[:, None]])
        rhs = -r
        g = self.sh.gauge(y)
        gval = None
        picked = g.pick(vt, max(1, family_dimension(sv)), d, bs) if (family and g is not None) else None
        if picked is not None and picked.size:
            rows, gval = g.grad[picked][:, d], g.values[picked]
        elif family and is_family(np.linalg.svd(A / bs[:, None], compute_uv=False)):
            # a family: [I - M, dP/dp] is rank-deficient too (at a fold only I - M is, and the
            # branch moves along that null vector: nothing may hold it there)
            row = vt[-1] / bs
            rows, gval = row[None, :], np.array([float(row @ (y[d] - (y if ref is None else ref)[d]))])
        if gval is not None:
            A = np.vstack([A, np.hstack([rows, np.zeros((rows.shape[0], 1))])])
            rhs = np.concatenate([rhs, -gval])
        return A, rhs, family, gval

    def correct(
        self,
        pt: ContinuationPoint,
        ds: float,
        samples: int,
        force_gauge: bool = False,
        light: bool = False,
        polish: bool = False,
        isolated: bool = False,
    ) -> ContinuationPoint:
        """Predict along ``pt.tangent`` by ``ds`` (scaled arclength), correct on the normal hyperplane.

        Returns the converged point with its orbit and tangent (from the orbit's own Jacobian);
        ``light``: without them (no sampled run, no amplitudes) until its ``orbit`` is asked for
        (e.g. the probes that locate a mode change, of which only one is kept). ``polish``: the
        converged point takes one more Newton step where that decreases the residual (a point
        accepted at ``tol`` may lie 1e-9 off, which moves a grazing by 1e-12 on the absorber: the
        probes that locate a special point on a noise-free map are polished). ``isolated``: the orbit
        is no member of a family whatever the singular values of ``I - M`` say (a branch point's
        probes: there ``I - M`` and ``[I - M, dP/dp]`` are singular too, and within 1e-8 of Shaw's
        branch point the family's row pulled each probe towards the last point: the locator
        stalled near 1e-8; issue 30).
        Damped Newton: an iterate whose residual is larger than the last one's is replaced by a
        shorter step (down to 1/16); if none decreases the residual the step fails (a worse
        iterate is never kept). Converged: residual below ``tol`` and the scaled update below
        ``step_tol`` (or the noise level of the map, ``10 cond rtol``, if larger).

        On the IDA path the iterations that cannot be accepted use the map at a looser tolerance
        where that is enough: the predicted point is run at ``COARSE_RTOL`` unless its residual
        there is near that run's noise, and the Newton system of an iterate whose residual is
        above ``tol`` takes ``M`` from a monodromy at ``COARSE_RTOL`` where it is well
        conditioned (``COARSE_COND``; last seen so), has a neutral direction or not whichever
        map it comes from (``_ambiguous``) and, on a family, a gauge of the model's to hold it. An accepted point, its residual, its convergence test and
        its monodromy are always those of the requested tolerances. A step expected to end at
        the point (from a residual below ``SAMPLE_AHEAD``) is run with samples at once.
        """
        max_iter = self.settings.newton.max_iter
        nw = NewtonMap(self.sh, pt.mode)
        d = nw.d
        sy = self.scale_of(pt, d)
        D = self.scales(pt, d)  # unscaled = scaled * D
        tau = pt.tangent
        X0 = np.concatenate([pt.y[d], [pt.p]])
        Xp = X0 + ds * tau * D
        y = pt.y.copy()
        y[d] = Xp[:-1]
        p = float(Xp[-1])
        it, prev, lam = 0, None, 1.0
        saved = None  # the accepted point while it is polished
        # Coarse runs and runs with samples ahead of acceptance only on a model with a gauge: without
        # one a family of orbits is held by its own direction, from the member nearest the last
        # point, which may graze a guard; a run of another accuracy or with samples (other steps)
        # may see that grazing where the requested unsampled run does not, and the branch wanders.
        gauged = self.sh.gauge(pt.y) is not None
        coarse = self.coarse if not force_gauge and gauged else None
        staged = coarse is not None  # the predicted point is run on the coarse map first
        ahead = False  # run the next iterate with samples (expected to be accepted)
        while True:
            self.at(p)
            T = self.sh.period
            t0 = pt.phi * T
            y = nw.project(t0, y)
            if staged:
                tr = self._coarse_run(y, pt.mode, t0)
                if tr is None:
                    staged = False  # anything but a plain run: at the requested tolerances
                    continue
            elif ahead:
                tr = self.sh.run_now(y, pt.mode, t0, samples)
            else:
                tr = self.sh.run(y, pt.mode, t0, samples=samples)
            if not tr.success:
                if saved is not None:
                    return saved
                raise StepFailed(
                    f"run failed at {self.parameter}={p:.8g}: {tr.message}", "run-failed", tr.status
                )
            r = nw.residual(tr, y)
            scale = state_scale(y, d)
            res = float(np.max(np.abs(r))) / scale
            if saved is not None and (res > prev[2] or tr.mode_final != pt.mode):
                return saved  # the polishing step did not help: the point as accepted
            if staged and (res <= COARSE_SWITCH * COARSE_RTOL or scale > 1e3 * max(sy, 1e-300)):
                staged = False  # near the coarse map's noise (or far off): the requested map here
                continue
            if not np.all(np.isfinite(tr.y_final)) or scale > 1e6 * max(sy, 1e-300):
                raise StepFailed(
                    f"the response grows without bound near {self.parameter}={p:.8g}", "unbounded"
                )
            if prev is not None and res > max(prev[2], 1e-3 * self.tol):
                # Damped Newton: the map is only piecewise smooth and I - M nearly singular (below
                # tol / 1000 the residual is not compared: there the update decides convergence).
                if lam <= 1.0 / 16:
                    raise StepFailed(
                        f"corrector: no step decreases the residual ({prev[2]:.3g}) near "
                        f"{self.parameter}={prev[1]:.8g}",
                        "no-decrease",
                    )
                lam *= 0.5
                y = prev[0].copy()
                y[d] += lam * prev[3][:-1]
                p = float(prev[1] + lam * prev[3][-1])
                ahead = False
                continue
            # The Newton system: from the coarse map's monodromy where that is enough for a step
            # that cannot be accepted here, else (and always at acceptance) the requested map's.
            use = coarse is not None and self._coarse_jac and (staged or res > self.tol)
            for src in (coarse, self.sh) if use else (self.sh,):
                try:
                    Jy, Jp, M = self.jacobian(tr, y, p, pt.mode, pt.phi, nw, sh=src)
                except (*STEP_FAILURES, GrazingSwitchError):
                    if src is self.sh:
                        raise
                    continue  # (e.g. a grazing switch): the requested map's
                A, rhs, family, gval = self.system_matrix(
                    y, Jy, Jp, r, d, force_gauge, ref=pt.y, isolated=isolated
                )
                w = row_weights(D, d.size, A.shape[0])  # the residual rows in balanced units
                A, rhs = A * w[:, None], rhs * w
                X = np.concatenate([y[d], [p]])
                Ab = np.vstack([A, tau / D])
                rhs = np.concatenate([rhs, [-(tau @ ((X - Xp) / D))]])
                sv = np.linalg.svd(Ab * D[None, :], compute_uv=False)
                kappa = sv[0] / max(sv[-1], 1e-300)
                # (a family held by its own direction, the null vector of I - M, takes it from
                # the requested map: the coarse one's would move the member held)
                own = family and gval is not None and self.sh.gauge(y) is None
                fit = kappa <= COARSE_COND and not own and not _ambiguous(Jy)
                if coarse is not None:
                    self._coarse_jac = fit  # the conditioning last seen
                if src is self.sh or fit:
                    break
            gauge_ok = gval is None or float(np.max(np.abs(gval))) <= self.tol * scale
            delta = np.linalg.lstsq(Ab, rhs, rcond=1e-10)[0]
            # Converged: small residual and a Newton update at the noise level of the map
            # (integration error amplified by the conditioning of the bordered system).
            step_tol = max(self.settings.step_tol, 10.0 * kappa * self.sh.noise_rtol)
            if (
                src is self.sh
                and not staged
                and res <= self.tol
                and gauge_ok
                and float(np.max(np.abs(delta / D))) <= step_tol
            ):
                if tr.mode_final != pt.mode:
                    raise StepFailed("section reached a switch", "section-switch")
                new = ContinuationPoint(y, p, pt.mode, pt.phi, iterations=it)
                new.tangent = self.null_vector(A, D, tau)
                # how far the corrector moved from the predictor, relative to the step (a jump
                # onto another branch that crosses this one is far larger than the turn of a step)
                new.jump = float(np.linalg.norm((np.concatenate([y[d], [p]]) - Xp) / D)) / max(
                    abs(ds), 1e-300
                )
                if light:
                    new.summary = _Summary(tr, T, self.system)
                    new.make = partial(self.complete, new, nw, t0, it, res, samples, M)
                else:
                    new.orbit = finish_orbit(
                        self.sh, nw, y, pt.mode, t0, it, res, self.tol, samples, "", tr=tr, M=M
                    )
                if polish and saved is None and res > 0.0:
                    saved = new  # one more step from it (kept if that does not help)
                    prev, lam = (y.copy(), p, res, delta), 1.0
                    y = y.copy()
                    y[d] += delta[:-1]
                    p = float(p + delta[-1])
                    staged = ahead = False
                    continue
                return new
            if it == max_iter:
                if saved is not None:
                    return saved
                break
            it += 1
            ahead = gauged and bool(samples) and not light and not staged and res <= SAMPLE_AHEAD
            staged = False
            prev, lam = (y.copy(), p, res, delta), 1.0
            y = y.copy()
            y[d] += delta[:-1]
            p = float(p + delta[-1])
        raise StepFailed(
            f"corrector did not converge in {max_iter} iterations near {self.parameter}={p:.8g}",
            "not-converged",
        )

    def _coarse_run(self, y, mode: str, t0: float):
        """A plain run of the coarse map, or None if it fails (anything but a plain run)."""
        try:
            tr = self.coarse.run(y, mode, t0)
        except STEP_FAILURES:
            tr = None
        finally:
            self.sh.nfev += self.coarse.nfev
            self.coarse.nfev = 0
        if tr is None or not tr.success or not np.all(np.isfinite(tr.y_final)):
            return None
        return tr

    def between(self, q1: ContinuationPoint, q2: ContinuationPoint, lam: float) -> ContinuationPoint:
        """The point ``lam`` of the way along the chord from ``q1`` to ``q2`` (same section), with the
        chord's direction as its tangent: :meth:`correct` from it with ``ds = 0`` corrects on the
        chord's normal hyperplane there."""
        y = q1.y + lam * (q2.y - q1.y)
        p = q1.p + lam * (q2.p - q1.p)
        nw = NewtonMap(self.sh, q1.mode)
        D = self.scales(q1, nw.d)
        t = (np.concatenate([q2.y[nw.d] - q1.y[nw.d], [q2.p - q1.p]])) / D
        pt = ContinuationPoint(y, p, q1.mode, q1.phi, tangent=t / max(float(np.linalg.norm(t)), 1e-300))
        return pt

    def coords(self, pt: ContinuationPoint) -> np.ndarray:
        """``pt``'s section state and parameter in the scaled units of the branch's first point
        that gets here (to compare points of one step: see :func:`hybrid.continuation.special.locate`)."""
        nw = NewtonMap(self.sh, pt.mode)
        if self._frame is None or self._frame[0].size != nw.d.size:
            self._frame = (nw.d, self.scales(pt, nw.d))
        d, D = self._frame
        return np.concatenate([pt.y[d], [pt.p]]) / D

    def rerun(self, pt: ContinuationPoint, factor: float = TIGHTER) -> _Summary | None:
        """The run from ``pt``'s section state at tolerances ``factor`` times tighter (IDA), as a
        summary (events, mode fractions): the difference of its phases from ``pt``'s estimates
        their integration error. None on the exact integrator, or if the run fails."""
        tight = self.sh.method.tightened(factor)
        if tight is None:
            return None
        if self.tight is None:
            opts = self.sh.options.with_method(tight)
            self.tight = Shooter(self.system, self.sh.params, opts, None, self.sh.periods)
        self.at(pt.p)
        self.tight.set_params({**self.base, self.parameter: pt.p})
        try:
            tr = self.tight.run(pt.y, pt.mode, pt.phi * self.sh.period)
        except STEP_FAILURES:
            return None
        return _Summary(tr, self.tight.period, self.system) if tr.success else None

    def complete(
        self, pt: ContinuationPoint, nw, t0: float, it: int, res: float, samples: int, M
    ) -> PeriodicOrbit:
        """The orbit of a light point: its sampled run and amplitudes (the monodromy ``M`` is known)."""
        self.at(pt.p)
        tr = self.sh.run(pt.y, pt.mode, t0, samples=samples)
        return finish_orbit(self.sh, nw, pt.y, pt.mode, t0, it, res, self.tol, samples, "", tr=tr, M=M)

    def jacobian(self, tr, y, p, mode, phi, nw, sh: Shooter | None = None):
        """``(dP/dy_d - I, dP/dp, M)`` at a run ``tr`` from ``(y, p)`` (``M`` from ``sh``'s
        monodromy, by default the requested map's)."""
        M = (sh or self.sh).monodromy(tr)  # sensitivity variables: states in s, then the parameter
        ns = self.sh.s.size
        My, Mp = M[:ns, :ns], M[:ns, ns]
        T = self.sh.period
        t0 = phi * T
        cm0 = self.sh.cs.modes[self.sh.cs.mode_id(mode)]
        cmT = self.sh.cs.modes[self.sh.cs.mode_id(tr.mode_final)]
        dT = self.sh.dT()
        s = self.sh.s
        yd0 = cm0.derivatives(t0, y)[s]
        yd1 = cmT.derivatives(t0 + T, tr.y_final)[s]
        dPdp = Mp + yd1 * (1.0 + phi) * dT - My @ yd0 * (phi * dT)
        Jy = My[np.ix_(nw.pos, nw.pos)] - np.eye(nw.d.size)
        return Jy, dPdp[nw.pos], M

    def null_vector(self, A: np.ndarray, D: np.ndarray, prev: np.ndarray | None, direction: float = 1.0):
        _, _, vt = np.linalg.svd(A * D[None, :])
        tau = vt[-1]
        if prev is not None and prev.size == tau.size:
            if tau @ prev < 0:
                tau = -tau
        elif tau[-1] * direction < 0:
            tau = -tau
        return tau

    def tangent(self, pt: ContinuationPoint, prev: np.ndarray | None, direction: float) -> np.ndarray:
        nw = NewtonMap(self.sh, pt.mode)
        d = nw.d
        self.at(pt.p)
        t0 = pt.phi * self.sh.period
        y = nw.project(t0, pt.y)
        tr = self.sh.run(y, pt.mode, t0)
        r = nw.residual(tr, y)
        Jy, Jp, _ = self.jacobian(tr, y, pt.p, pt.mode, pt.phi, nw)
        A, _, _, _ = self.system_matrix(y, Jy, Jp, r, d)
        if self.bs is None or self.bs.size != d.size:
            self.bs = balance_scales(Jy, GEOMETRY_RATIO)  # the units of the state: once per branch
        D = self.scales(pt, d)
        return self.null_vector(A * row_weights(D, d.size, A.shape[0])[:, None], D, prev, direction)


class StepFailed(Exception):
    """A failed corrector step: ``reason`` (``"run-failed"``, ``"unbounded"``, ``"no-decrease"``,
    ``"section-switch"``, ``"not-converged"``) and, for a failed run, its ``status``."""

    def __init__(self, message: str, reason: str, status: Status | None = None):
        super().__init__(message)
        self.reason = reason
        self.status = status


def _at_a_switch(exc: Exception) -> bool:
    """A failed step that a switch at the section causes: the run ends in another mode than the
    section's, a switch there grazes (no saltation matrix), or switches pile up at an instant
    (a Zeno point, no admissible mode). The section is moved and the step tried again."""
    if isinstance(exc, StepFailed):
        return exc.reason == "section-switch" or exc.status in (Status.ZENO, Status.NO_ADMISSIBLE_MODE)
    return isinstance(exc, GrazingSwitchError)


#: The branch's arclength takes the balanced units of its first point (Parlett-Reinsch factors of
#: ``I - M``, powers of 2) only where those factors span more than this ratio: a spread that large
#: comes from the state's units (velocities hundreds of times the displacements in a model written
#: in engineering units), a smaller one from its dynamics, which the arclength should not reweight.
#: (Measured: a model in engineering units spreads 512 and more; the shipped models at most 32;
#: docs/orbits.md, "Units of the state".)
GEOMETRY_RATIO = 64.0


def row_weights(D: np.ndarray, nd: int, rows: int) -> np.ndarray:
    """Weights of the Newton system's rows: a residual row in the balanced units of ``D`` (its
    state part relative to its largest entry: all ones for a model in consistent units), a gauge
    row as it is."""
    b = D[:nd] / max(float(np.max(D[:nd])), 1e-300) if nd else D[:0]
    return np.concatenate([1.0 / b, np.ones(rows - nd)])


#: A corrector step from an iterate whose scaled residual is below this is run with samples (its
#: point is expected to be accepted, and the accepted orbit needs its sampled run).
SAMPLE_AHEAD = 1e-5

#: Largest condition number of the (scaled) bordered Newton system for which a step may take
#: ``M`` from the coarse map (relative error about ``COARSE_RTOL``, 1e-7 to 1e-6): the Newton step
#: it gives is then wrong by at most ``COARSE_COND x 1e-6``, a tenth, so the corrector still
#: contracts; beyond it, the monodromy of the requested map. (Measured: thresholds from 1e4 to
#: 1e6 give the same iteration counts on the shipped models' branches; docs/orbits.md.)
COARSE_COND = 1e5


def _ambiguous(Jy: np.ndarray) -> bool:
    """True if whether ``Jy = M - I`` has a neutral direction (a family, ``FAMILY_TOL``) may depend
    on an error of about 1e-6 in ``M``: its smallest singular value is neither far below the
    threshold (a structural family, e.g. the free offset of a component that does not move) nor
    far above it."""
    sv = np.linalg.svd(balanced(Jy)[0], compute_uv=False)
    if not sv.size or not sv[0] > 0.0:
        return True
    return 1e-3 * FAMILY_TOL * sv[0] < sv[-1] < 1e-4 * sv[0]


def _size(o: PeriodicOrbit) -> float:
    """Largest amplitude of the orbit's state variables."""
    return max((o.amplitude[n] for n in o.state_names if n in o.amplitude), default=0.0)


def _growth(o: PeriodicOrbit, first: PeriodicOrbit, floor: dict) -> float:
    """The median over the state variables of each one's amplitude over its amplitude in ``first``
    (at least ``floor``, its absolute tolerance): how much the orbit has grown, in no unit.

    :func:`_size` mixes units: on the tutorial's damper with R = 4 N (issue 30) the contact force
    (4 N, bounded by R) was the first orbit's size, and the displacements grew 5.8e6 times (to
    11570 m) towards the undamped sliding resonance while the largest amplitude, a velocity in
    m/s, grew only 1.5e5 times. A median is not moved by one variable that grows from nothing
    (a symmetric orbit's antisymmetric part after a symmetry-breaking bifurcation)."""
    ratios = [
        o.amplitude[n] / max(first.amplitude[n], floor[n])
        for n in o.state_names
        if n in o.amplitude and n in first.amplitude
    ]
    return float(np.median(ratios)) if ratios else 0.0


@collected
@with_blas_threads
def continue_orbits(
    system: HybridSystem,
    params: Mapping[str, float],
    parameter: str | None = None,
    p_range: tuple[float, float] | None = None,
    *,
    x0=None,
    mode0: str | None = None,
    t0: float = 0.0,
    periods: int = 1,
    options: SolverOptions | None = None,
    settings: ContinuationOptions | None = None,
    progress: Progress | None = None,
    on_point: OnPoint | None = None,
    **unexpected,
) -> Branch:
    """Continue periodic orbits in ``parameter`` from ``p_range[0]`` towards ``p_range[1]``.

    Parameters
    ----------
    system : HybridSystem
        A periodically forced model.
    params : mapping
        All parameter values (the continued one is replaced by ``p_range[0]``).
    parameter : str, optional
        Any parameter of the model (default: the one the forcing period depends on,
        :func:`forcing_parameter`).
    p_range : (float, float)
        Start and end value; the branch stops when it leaves the range.
    x0, mode0 : optional
        Guess of the first orbit (see :func:`hybrid.periodic_orbit`).
    t0 : float
        Time of the guess [s] (a state of a computed orbit at its ``t0``: with
        ``settings.transient_periods = 0`` Newton's method starts from it).
    periods : int
        Forcing periods of the orbits (2: the branch of orbits of twice the forcing period, e.g.
        born at a period doubling, :func:`hybrid.switch_branch`).
    options : SolverOptions, optional
        Tolerances of the runs (default :data:`hybrid.ORBIT_OPTIONS`).
    settings : ContinuationOptions, optional
        Steps, tolerances, location of special points, limits of a branch.
    progress : callable, optional
        ``progress(fraction)`` with the fraction of the parameter range covered
        (:data:`hybrid.core.callbacks.Progress`).
    on_point : callable, optional
        ``on_point(0, orbit)`` with every orbit as it is appended to the branch (in branch
        order), e.g. to write it at once (:data:`hybrid.core.callbacks.OnPoint`; the branch's
        index is 0: this is the only branch).

    Returns
    -------
    Branch
        ``kind`` ``"forced-orbits"``. Ends when it leaves the range, reaches ``max_points``,
        grows without bound (a special point ``"unbounded"``; ``reason`` ``"unbounded"``) or
        stalls (``reason`` ``"stalled"``); see :data:`hybrid.core.status.BRANCH_REASONS`.

    Raises
    ------
    ValueError
        Bad input (before any integration).
    TypeError
        A keyword that is a field of ``options`` or ``settings`` (the message says which).
    """
    reject_keywords(
        "continue_orbits",
        unexpected,
        options=options if isinstance(options, SolverOptions) else SolverOptions,
        settings=settings if isinstance(settings, ContinuationOptions) else ContinuationOptions,
    )
    options = ORBIT_OPTIONS if options is None else options
    settings, parameter, (a, b), start_params, mode0, y0 = _checked_input(
        system, params, parameter, p_range, x0, mode0, t0, periods, settings
    )
    c = OrbitContinuer(system, start_params, parameter, (a, b), options, settings, periods)
    for p in (b, a):  # both ends of the range must be resolvable in time (a at its transient)
        c.at(p)
        n = settings.transient_periods + 1 if p == a else 2
        check_time_range(c.sh.cs, options, 0.0, n * c.sh.period)
    direction = 1.0 if b > a else -1.0
    branch = Branch(
        "forced-orbits", system, dict(start_params), parameter, options=options, settings=settings
    )

    def add(orbit: PeriodicOrbit) -> int:
        branch.points.append(orbit)
        if on_point is not None:
            on_point(0, orbit)
        return len(branch.points) - 1

    _start_and_follow(c, branch, y0, mode0, float(t0), direction, add, progress)
    return branch


def _start_and_follow(
    c: OrbitContinuer, branch: Branch, y0, mode0: str, t0: float, direction, add, progress
) -> None:
    """The first orbit of :func:`continue_orbits` from the guess ``(t0, y0, mode0)``, then the
    branch from it; a budget that runs out stops the branch there."""
    settings = c.settings
    try:
        first = solve_orbit(
            c.sh,
            y0,
            mode0,
            t0,
            settings.transient_periods,
            settings.newton.tol,
            FIRST_ORBIT_MAX_ITER,
            settings.samples_per_period,
        )
        follow_branch(c, branch, first, direction, add, progress)
    except BudgetExceeded as exc:  # the budget of a run or the computation's deadline: stop here
        last = branch.points[-1].params[c.parameter] if branch.points else c.a
        branch.stop("budget", f"stopped at {c.parameter}={last:.8g}: {exc}")


def _checked_input(system, params, parameter, p_range, x0, mode0, t0, periods, settings):
    """The input of :func:`continue_orbits` checked (each error names what to give):
    ``(settings, parameter, (a, b), start_params, mode0, y0)`` with the defaults in place."""
    if not isinstance(system, HybridSystem):
        raise InputTypeError(f"`system` must be a HybridSystem, got {type(system).__name__}")
    if settings is None:
        settings = ContinuationOptions()
    elif not isinstance(settings, ContinuationOptions):
        raise InputTypeError(f"`settings` must be a ContinuationOptions, got {type(settings).__name__}")
    if parameter is None:
        parameter = forcing_parameter(system)
    if parameter not in system.parameter_names:
        raise InputError(
            f"model `{system.name}` has no parameter `{parameter}`; parameters: {', '.join(system.parameter_names)}"
        )
    if p_range is None or len(p_range) != 2:
        raise InputError(f"`p_range` must be two numbers (start, end), got {p_range!r}")
    a, b = (float(v) for v in p_range)
    if not (math.isfinite(a) and math.isfinite(b)) or a == b:
        raise InputError(f"`p_range` must be two different finite numbers, got {p_range!r}")
    start_params = system.parameter_values({**dict(params), parameter: a})
    mode0 = mode0 if mode0 is not None else system.default_mode
    if mode0 is None:
        raise InputError(f"`mode0` is required: model `{system.name}` declares no initial mode")
    system.mode(mode0)
    y0 = initial_state(system, np.zeros(len(system.variable_names)) if x0 is None else x0, mode0)
    if not (isinstance(periods, int) and not isinstance(periods, bool) and periods >= 1):
        raise InputError(f"`periods` must be an integer >= 1, got {periods!r}")
    if not math.isfinite(float(t0)):
        raise InputError(f"`t0` must be a finite time, got {t0!r}")
    return settings, parameter, (a, b), start_params, mode0, y0


def follow_branch(
    c: OrbitContinuer, branch: Branch, first, direction: float, add, progress, orient=None
) -> None:
    """Follow the branch from its first orbit (see :func:`continuation`); ``orient``: a scaled
    direction the first tangent points along (default: the parameter's ``direction``)."""
    st = c.settings
    parameter = c.parameter
    a, b = c.a, c.b
    samples = st.samples_per_period

    stop = branch.stop

    # An orbit that Newton's method left just above its tolerance (noise of the map) is
    # finished by the bordered corrector at the same parameter.
    near = math.isfinite(first.residual) and first.residual <= 1e3 * st.newton.tol
    if not first.converged and not near:
        stop("no-start", f"no periodic orbit at {parameter}={a:.8g}: {first.message}")
        return
    if first.converged and not math.isfinite(first.condition):
        add(first)
        stop(
            "degenerate",
            f"no branch to follow from {parameter}={a:.8g}: I - M vanishes there (every nearby state is "
            "periodic: is the system forced at all?)",
        )
        return
    pt = ContinuationPoint(
        first.x0.copy(), first.params[parameter], first.mode0, first.t0 / first.period, orbit=first
    )
    try:
        pt.tangent = c.tangent(pt, orient, direction)
        if not first.converged:
            pt = c.correct(pt, 0.0, samples)
            first = pt.orbit
            pt.tangent = c.tangent(pt, orient, direction)
    except (StepFailed, *STEP_FAILURES) as exc:
        if not first.converged:
            stop("no-start", f"no periodic orbit at {parameter}={a:.8g}: {first.message}; {exc}")
        else:
            stop("stalled", f"stopped at {parameter}={a:.8g}: no tangent to the branch: {exc}")
        return
    add(first)
    # Growth is measured from the first orbit's size, or from the absolute tolerance if that is
    # smaller (an orbit at rest, e.g. without forcing, has a size of rounding noise); a method
    # without absolute tolerances (the exact flow) takes SIZE_FLOOR.
    atol = c.sh.method.atol_vector(c.sh.names)
    size0 = max(_size(first), float(np.min(atol, initial=np.inf)) or SIZE_FLOOR)
    floor = {n: float(a) if a > 0 else SIZE_FLOOR for n, a in zip(c.sh.names, atol, strict=True)}
    ds_cur = st.ds
    rephased = False
    n_points, fails = 1, 0
    done = 0.0
    while n_points < st.max_points:
        try:
            new = c.correct(pt, ds_cur, samples)
        except (StepFailed, *STEP_FAILURES) as exc:
            grow = isinstance(exc, StepFailed) and exc.reason == "unbounded"
            # A switch moved onto the section: move the section (once per point) to the middle of
            # the longest mode interval, and retry the same step.
            if _at_a_switch(exc) and not rephased:
                moved = _rephase(c, pt, direction)
                if moved is not None:
                    pt, rephased = moved, True
                    continue
            if ds_cur / 4.0 >= st.ds_min and fails < st.max_failures:
                ds_cur /= 4.0
                fails += 1
                continue
            if grow:
                _unbounded(c, branch, pt, None, str(exc))
            else:
                stop(
                    "stalled",
                    f"stalled at {parameter}={pt.p:.8g}: {fails + 1} failed steps in a row "
                    f"(down to ds = {ds_cur:.3g}); last failure: {exc}",
                )
            return
        fails = 0
        # The branch grows without bound: stop before accepting orbits of any size.
        if _size(new.orbit) > st.max_growth * size0 or _growth(new.orbit, first, floor) > st.max_growth:
            _unbounded(c, branch, pt, new, "")
            return
        # Leaving a band, the symmetric orbit loses its phases in other modes at once; rounding
        # lets one go first and the corrector lands on a boundary member of a neutral family
        # (one grazing switch per period). Prefer the family's gauge member when it exists.
        if (
            c.sh.gauge(new.y) is not None
            and 0 < new.orbit.transitions_per_period < pt.orbit.transitions_per_period
        ):
            alt = _gauge_member(c, pt, new, ds_cur, samples)
            if alt is not None:
                new = alt
        # Special points between pt and new, in arclength order; the orbit at each is appended
        # (unless it is `new` itself).
        found = detect(pt, new) if pt.orbit is not None else []
        located = []
        for kind, desc in found:
            if kind == "nonsmooth":
                located.append((kind, desc, None))
                continue
            located.append((kind, desc, locate(c, pt, new, kind, ds_cur, st, (StepFailed, *STEP_FAILURES))))
        located.sort(key=lambda k: k[2].parameter * direction if k[2] is not None else math.inf)
        pending = []
        for kind, desc, loc in located:
            if loc is None:  # a nonsmooth jump: at the mode change located just before
                prev = next((q for q in reversed(pending) if q[0] != "nonsmooth"), None)
                pending.append((kind, desc, prev[2] if prev else None))
                continue
            pending.append((kind, desc, loc))
        records = []
        for kind, desc, loc in pending:
            idx = None  # None: the orbit `new` (nothing computed inside the step)
            if loc is None:
                p, status, iv = 0.5 * (pt.p + new.p), "bracketed", (pt.p, new.p)
                acc = 0.5 * abs(iv[1] - iv[0])
            else:
                if loc.point is pt:
                    idx = len(branch.points) - 1
                elif loc.point is not None and loc.point is not new:
                    known = [k for k, o in enumerate(branch.points) if o is loc.point.orbit]
                    idx = known[0] if known else add(loc.point.orbit)
                p, status, acc, iv = loc.parameter, loc.status, loc.accuracy, loc.interval
                if loc.note:
                    desc = f"{desc}; {loc.note}"
            records.append((kind, idx, p, desc, status, acc, iv))
        idx_new = add(new.orbit)
        for kind, idx, p, desc, status, acc, iv in records:
            k = idx_new if idx is None else idx
            amp = dict(branch.points[k].amplitude)
            branch.special.append(SpecialPoint(kind, k, p, amp, desc, status, acc, iv))
        n_points += 1
        if progress is not None:
            done = max(done, min(1.0, max(0.0, (new.p - a) / (b - a))))
            progress(done)
        # Step control: aim at 3 corrector iterations, and at most max_angle of turn per step.
        factor = {0: 2.0, 1: 2.0, 2: 1.4, 3: 1.0}.get(new.iterations, 0.6)
        if not rephased and new.tangent is not None and pt.tangent is not None:
            turn = math.acos(min(1.0, abs(float(new.tangent @ pt.tangent))))
            if turn > 0:
                factor = min(factor, max(0.25, st.max_angle / turn))
        ds_cur = min(st.ds_max, max(st.ds_min, ds_cur * factor))
        pt, rephased = new, False
        if (new.p - b) * direction > 0 or (new.p - a) * direction < 0:
            break


def _unbounded(
    c: OrbitContinuer, branch: Branch, pt: ContinuationPoint, new: ContinuationPoint | None, why: str
) -> None:
    """End the branch at ``pt``: beyond it the response grows without bound."""
    st = c.settings
    par = c.parameter
    hi = new.p if new is not None else pt.p
    size = _size(new.orbit) if new is not None else math.nan
    desc = f"no bounded periodic orbit beyond {par} = {pt.p:.8g}: the response grows without bound " + (
        f"(amplitude {size:.3g}: grown over max_growth = {st.max_growth:g} times the first orbit's)"
        if new is not None
        else f"({why})"
    )
    k = len(branch.points) - 1
    iv = (min(pt.p, hi), max(pt.p, hi))
    branch.special.append(
        SpecialPoint(
            "unbounded", k, pt.p, dict(pt.orbit.amplitude), desc, "bracketed", 0.5 * (iv[1] - iv[0]), iv
        )
    )
    branch.stop("unbounded", f"stopped at {par}={pt.p:.8g}: {desc}")


def _rephase(c: OrbitContinuer, pt: ContinuationPoint, direction: float) -> ContinuationPoint | None:
    c.at(pt.p)
    o = pt.orbit
    t, y, m = choose_section_period(c.sh.run(o.x0, o.mode0, o.t0, samples=256), c.sh.period)
    new = ContinuationPoint(y, pt.p, m, t / c.sh.period, orbit=o)
    if pt.tangent is not None and pt.tangent[-1] != 0.0:
        direction = float(np.sign(pt.tangent[-1]))  # keep the branch's sense, also past a fold
    try:
        new.tangent = c.tangent(new, None, direction)
    except (
        StepFailed,
        *STEP_FAILURES,
    ):  # as at the branch's first tangent; anything else is a defect (issue 29)
        return None
    return new
