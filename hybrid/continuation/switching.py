"""Branch switching: the branches born at a special point of a branch (:func:`switch_branch`).

* a ``branch-point`` of forced orbits (a multiplier through +1 without a fold: a pitchfork or a
  transcritical point): the branch that crosses there, both of its halves;
* a ``period-doubling``: the branch of orbits of twice the period (on the map over two forcing
  periods, where the point is a branch point of the same kind);
* a ``hopf`` point of equilibria: the periodic orbits born there (:func:`hybrid.hopf_branch`).

At a branch point the Jacobian ``[M - I, dP/dp]`` of the (scaled) fixed-point problem has a
two-dimensional null space, spanned by the branch's own tangent and the direction of the branch
that crosses it. The new branch is started as BifurcationKit's ``continuation(br, ind_bif)``
starts it: from the point, a step ``ds`` along the null direction orthogonal to the old tangent,
corrected on the hyperplane normal to that direction (which meets the new branch and not the old
one), then followed by the pseudo-arclength continuation of :func:`hybrid.continue_orbits`
pointing away from the point.
"""

from __future__ import annotations

import math

import numpy as np

from ..core.callbacks import Progress
from ..core.errors import InputError, InputTypeError
from ..core.options import ContinuationOptions, reject_keywords
from ..integrators.options import SolverOptions
from ..orbits.newton import NewtonMap
from ..orbits.orbit import ORBIT_OPTIONS
from .autonomous import hopf_branch
from .branch import Branch
from .forced import STEP_FAILURES, ContinuationPoint, OrbitContinuer, StepFailed, follow_branch, row_weights

__all__ = ["switch_branch", "SWITCHABLE"]

#: The kinds of special point a branch can be switched at, by the kind of the branch.
SWITCHABLE = {"forced-orbits": ("branch-point", "period-doubling"), "equilibria": ("hopf",)}


def switch_branch(
    branch: Branch,
    index: int,
    p_range: tuple[float, float] | None = None,
    *,
    ds: float | None = None,
    options: SolverOptions | None = None,
    settings: ContinuationOptions | None = None,
    progress: Progress | None = None,
    **unexpected,
) -> list[Branch]:
    """The branches born at special point ``index`` of ``branch``.

    Parameters
    ----------
    branch : Branch
        A branch of forced orbits (``hybrid.continue_orbits``, ``hybrid.frequency_response``'s
        branches) or of equilibria (``hybrid.equilibrium_branch``).
    index : int
        Position in ``branch.special`` of a ``"branch-point"`` or ``"period-doubling"`` (forced
        orbits) or a ``"hopf"`` point (equilibria).
    p_range : (float, float), optional
        The new branches end when they leave it (default: the span of ``branch``'s parameter).
    ds : float, optional
        The first step from the point along the new branch, in the scaled arclength of
        :func:`hybrid.continue_orbits` (default a quarter of ``settings.ds``).
    options : SolverOptions, optional
        Tolerances of the runs (default :data:`hybrid.ORBIT_OPTIONS`; use the branch's own).
    settings : ContinuationOptions, optional
        As for :func:`hybrid.continue_orbits`.
    progress : callable, optional
        ``progress(fraction)``.

    Returns
    -------
    list of Branch
        At a branch point, the two halves of the crossing branch (each starting next to the point
        and going away from it); at a period doubling, the doubled branch (orbits of twice the
        period: its two halves are one orbit shifted by a forcing period), its message saying so;
        at a Hopf point, the branch of :func:`hybrid.hopf_branch`. A half whose first step fails
        is a branch with no point, ``status`` ``"stopped"``, ``reason`` ``"no-start"``.

    Raises
    ------
    hybrid.core.errors.InputError
        ``index`` is not a special point of ``branch`` where a branch can be switched.
    """
    reject_keywords("switch_branch", unexpected, options=SolverOptions, settings=ContinuationOptions)
    if not isinstance(branch, Branch):
        raise InputTypeError(f"`branch` must be a Branch, got {type(branch).__name__}")
    if not (isinstance(index, int | np.integer) and -len(branch.special) <= index < len(branch.special)):
        raise InputError(
            f"`index` must be the position of a special point of the branch (0 to {len(branch.special) - 1}), "
            f"got {index!r}"
        )
    sp = branch.special[index]
    kinds = SWITCHABLE.get(branch.kind, ())
    if sp.kind not in kinds:
        where = ", ".join(f"{k} ({kd})" for k, kd in enumerate(s.kind for s in branch.special) if kd in kinds)
        raise InputError(
            f"special point {index} of the branch is a {sp.kind}: a branch of {branch.kind} is switched at a "
            f"{' or a '.join(kinds) or '(nothing: not supported)'}"
            + (f"; its switchable points: {where}" if where else "")
        )
    options = ORBIT_OPTIONS if options is None else options
    settings = ContinuationOptions() if settings is None else settings
    if p_range is None:
        v = branch.values
        p_range = (float(np.min(v)), float(np.max(v)))
    lo, hi = (float(x) for x in p_range)
    if not (math.isfinite(lo) and math.isfinite(hi) and lo != hi):
        raise InputError(f"`p_range` must be two different finite numbers, got {p_range!r}")
    if branch.kind == "equilibria":
        eq = branch.points[sp.index]
        return [hopf_branch(eq, branch.parameter, (min(lo, hi), max(lo, hi)), options=options)]
    return _switch_orbits(branch, sp, (lo, hi), ds, options, settings, progress)


def _switch_orbits(branch: Branch, sp, p_range, ds, options, settings, progress) -> list[Branch]:
    system, par = branch.system, branch.parameter
    orbit = branch.points[sp.index]
    p0 = float(orbit.params[par])
    base = system.period_value(orbit.params)
    periods = max(1, round(orbit.period / base))
    doubling = sp.kind == "period-doubling"
    new_periods = 2 * periods if doubling else periods
    lo, hi = sorted(p_range)
    if not lo <= p0 <= hi:
        raise InputError(f"`p_range` ({lo:g}, {hi:g}) must contain the point's {par} = {p0:.10g}")
    c = OrbitContinuer(system, orbit.params, par, (lo, hi), options, settings, new_periods)
    c.at(p0)
    pt0 = ContinuationPoint(orbit.x0.copy(), p0, orbit.mode0, orbit.t0 / c.sh.period)
    t_old, t_new, sv = _kernel(c, pt0, _neighbour(branch, sp.index))
    step = settings.ds / 4.0 if ds is None else float(ds)
    samples = settings.samples_per_period
    out = []
    what = "the doubled branch" if doubling else "the crossing branch"
    for sign in (1.0,) if doubling else (1.0, -1.0):
        new = Branch("forced-orbits", system, dict(orbit.params), par, options=options, settings=settings)
        pt0.tangent = sign * t_new
        try:
            first = c.correct(pt0, step, samples)
        except (StepFailed, *STEP_FAILURES) as exc:
            new.stop("no-start", f"no orbit of {what} a step {step:g} from {par}={p0:.10g}: {exc}")
            out.append(new)
            continue

        def add(o, new=new) -> int:
            new.points.append(o)
            return len(new.points) - 1

        # (the continuer's range is (lo, hi): direction +1 ends the branch outside it either way;
        # the first tangent points away from the point)
        follow_branch(c, new, first.orbit, 1.0, add, progress, orient=sign * t_new)
        note = (
            f"switched at the {sp.kind} at {par} = {p0:.10g} ({what}"
            + (f", orbits of {new_periods} forcing periods" if doubling else f", half {'+-'[sign < 0]}")
            + f"; null space of [M - I, dP/dp] there: singular values {sv[-2]:.2g}, {sv[-1]:.2g} of {sv[0]:.2g})"
        )
        new.message = f"{note}; {new.message}" if new.message else note
        out.append(new)
    return out


def _neighbour(branch: Branch, k: int):
    """An orbit of the branch next to orbit ``k`` (its old direction), the nearer in the parameter."""
    cands = [j for j in (k - 1, k + 1) if 0 <= j < len(branch.points)]
    if not cands:
        raise InputError("the branch has a single orbit: its direction at the point is not known")
    p = branch.values
    return branch.points[min(cands, key=lambda j: abs(p[j] - p[k]) if p[j] != p[k] else math.inf)]


def _kernel(c: OrbitContinuer, pt: ContinuationPoint, other) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(old tangent, new direction, singular values)`` at ``pt`` in the continuer's scaled
    coordinates: the two right singular vectors of the smallest singular values of the scaled
    ``[M - I, dP/dp]`` span the null space at a branch point; the old branch's direction (towards
    the neighbouring orbit ``other``, projected on it) and the one orthogonal to it there."""
    nw = NewtonMap(c.sh, pt.mode)
    d = nw.d
    c.at(pt.p)
    t0 = pt.phi * c.sh.period
    y = nw.project(t0, pt.y)
    tr = c.sh.run(y, pt.mode, t0)
    r = nw.residual(tr, y)
    Jy, Jp, _ = c.jacobian(tr, y, pt.p, pt.mode, pt.phi, nw)
    A, _, _, _ = c.system_matrix(y, Jy, Jp, r, d)
    D = c.scales(pt, d)
    A = A * row_weights(D, d.size, A.shape[0])[:, None]
    _, sv, vt = np.linalg.svd(A * D[None, :])
    ker = vt[-2:]  # rows
    # the old branch's direction: towards the neighbouring orbit (its state at the same phase)
    y_other = _state_at(other, pt.phi)
    chord = np.concatenate([y_other[d] - y[d], [other.params[c.parameter] - pt.p]]) / D
    t_old = ker.T @ (ker @ chord)
    if not float(np.linalg.norm(t_old)) > 0:
        t_old = ker[0]
    t_old /= np.linalg.norm(t_old)
    t_new = ker[0] - (ker[0] @ t_old) * t_old
    if float(np.linalg.norm(t_new)) < 0.5:
        t_new = ker[1] - (ker[1] @ t_old) * t_old
    t_new /= np.linalg.norm(t_new)
    return t_old, t_new, sv


def _state_at(orbit, phi: float) -> np.ndarray:
    """The orbit's state at the phase ``phi`` (fraction of its period): its section state if that
    is where its section lies, else its nearest sample."""
    if abs(orbit.t0 / orbit.period - phi) < 1e-12:
        return orbit.x0.copy()
    tr = orbit.trajectory
    t = tr.t_start + ((phi * orbit.period - tr.t_start) % orbit.period)
    return np.asarray(tr.y[int(np.argmin(np.abs(tr.t - t)))], dtype=float)
