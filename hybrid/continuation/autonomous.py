"""Branches of an autonomous system in one parameter: equilibria, Hopf points, periodic orbits.

* :func:`equilibrium_branch`: the equilibria of one mode over a grid of parameter values (each
  from its neighbour), with every loss of stability located (:func:`hybrid.orbits.equilibria.locate_hopf`);
* :func:`hopf_branch`: the periodic orbits born at a Hopf point, started from the critical
  eigenvector (the predictor is a small displacement along ``Re q``, the corrector the
  pseudo-arclength one of :mod:`hybrid.continuation.palc`), period along the branch;
* :func:`orbit_branch`: a branch of autonomous orbits from a computed one (any phase
  condition).

A branch of orbits that meets a switch it did not have (a grazing: e.g. a smooth cycle that
touches a switching surface) stops there when asked (``stop_on_mode_change``): beyond it the
orbit is another kind (a stick-slip cycle), computed as its own branch.

Each returns a :class:`hybrid.Branch` (``kind`` ``"equilibria"`` or ``"autonomous-orbits"``)
with its special points as :class:`hybrid.SpecialPoint` objects: an equilibrium's loss of
stability ``"hopf"`` or ``"real-eigenvalue"`` (located), an orbit branch's ``"fold"`` and
``"mode-gained"``/``"mode-lost"``/``"grazing"`` (bracketed by the points around them).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import replace

import numpy as np

from ..core.budget import deadline_passed, limit_text
from ..core.errors import InputError, InputTypeError, ParameterOutOfDomain
from ..core.options import ContinuationOptions, reject_keywords
from ..core.status import BranchStatus
from ..core.threads import with_blas_threads
from ..integrators.options import SolverOptions
from ..model.system import HybridSystem
from ..orbits.autonomous import AutonomousSolver, finish, resolve_phase
from ..orbits.equilibria import Equilibrium, equilibrium, locate_hopf
from ..orbits.flowmap import FlowMap
from ..orbits.orbit import ORBIT_OPTIONS, PeriodicOrbit
from .autolocate import FAILURES, AutoPoint, Locator, locate_end
from .branch import Branch, with_options
from .palc import RETRY, follow
from .special import SpecialPoint, detect, locate

__all__ = ["AUTONOMOUS_CONTINUATION", "equilibrium_branch", "hopf_branch", "orbit_branch"]

#: Continuation options of an autonomous branch by default: the steps are in the unknowns' own
#: units (state, period, parameter), shorter than a forced branch's scaled ones.
AUTONOMOUS_CONTINUATION = ContinuationOptions(
    ds=0.02, ds_min=1e-6, ds_max=0.2, max_points=200, samples_per_period=256
)


@with_blas_threads
def equilibrium_branch(
    system: HybridSystem,
    params: Mapping[str, float],
    mode: str,
    parameter: str,
    values: Sequence[float],
    x0=None,
) -> Branch:
    """Equilibria of ``mode`` at each of ``values`` of ``parameter`` (each Newton from the last),
    with every change of stability between two values located.

    Returns
    -------
    Branch
        ``kind`` ``"equilibria"``: the equilibrium at each value (converged or not, in the order
        of ``values``) and, after the value before each change of stability, the equilibrium
        where it happens; ``special`` holds that change (``"hopf"`` for a complex pair,
        ``"real-eigenvalue"`` for a real eigenvalue, located by
        :func:`hybrid.orbits.equilibria.locate_hopf`; its ``index`` is that equilibrium's).
        ``status`` is ``"completed"``; ``message`` counts the values without an equilibrium.
        Inside a :func:`hybrid.time_limit` whose deadline passes, the values after it are not
        computed: ``status`` ``"stopped"``, ``reason`` ``"budget"``.

    Raises
    ------
    ValueError
        Unknown parameter or mode, fewer than two values.
    """
    if parameter not in system.parameter_names:
        raise InputError(
            f"model `{system.name}` has no parameter `{parameter}`; parameters: {', '.join(system.parameter_names)}"
        )
    values = np.asarray(values, dtype=float)
    if values.ndim != 1 or values.size < 2:
        raise InputError("`values` must hold at least two parameter values")
    grid: list[Equilibrium] = []
    guess = x0
    for v in values:
        if deadline_passed():  # the computation's deadline (hybrid.time_limit): stop at this value
            break
        eq = equilibrium(system, {**params, parameter: float(v)}, mode, guess)
        grid.append(eq)
        if eq.converged:
            guess = eq.x
    branch = Branch("equilibria", system, {**params, parameter: float(values[0])}, parameter)
    for k, a in enumerate(grid):
        branch.points.append(a)
        b = grid[k + 1] if k + 1 < len(grid) else None
        if b is None or not (a.converged and b.converged):
            continue
        if a.admissible != b.admissible:
            branch.points.append(_boundary(system, params, mode, parameter, a, b, branch))
        ra, rb = a.eigenvalues[0].real, b.eigenvalues[0].real
        if ra * rb < 0:
            hp = locate_hopf(system, params, mode, parameter, (a.params[parameter], b.params[parameter]), a.x)
            branch.points.append(hp.equilibrium)
            desc = (
                f"a complex pair of eigenvalues crosses the imaginary axis (frequency {hp.frequency:.9g} rad/s)"
                if hp.kind == "hopf"
                else "a real eigenvalue crosses zero"
            )
            amp = {n: abs(float(x)) for n, x in zip(system.variable_names, hp.equilibrium.x, strict=True)}
            sp = SpecialPoint(
                hp.kind, len(branch.points) - 1, hp.parameter, amp, desc, hp.status, hp.accuracy, hp.interval
            )
            branch.special.append(sp)
    missing = sum(1 for e in grid if not e.converged)
    if missing:
        branch.message = f"no equilibrium found at {missing} of {len(grid)} values"
    if len(grid) < values.size:
        branch.status, branch.reason = BranchStatus.STOPPED, "budget"
        branch.message = (
            f"time limit reached ({limit_text()}) after {len(grid)} of {values.size} "
            f"values of {parameter}" + (f"; {branch.message}" if branch.message else "")
        )
    return branch


#: Regula falsi on a boundary equilibrium's margin: iterations at most, and the bracket's width at
#: which it is located (relative to ``max(1, |p|)``).
BOUNDARY_ITER, BOUNDARY_TOL = 80, 1e-13


def _boundary(system, params, mode: str, parameter: str, a, b, branch: Branch):
    """The equilibrium where ``a``'s admissibility changes to ``b``'s (a guard of the mode reaches
    zero there: a boundary equilibrium), by regula falsi (Illinois) on the margin
    (:attr:`hybrid.Equilibrium.margin`, smooth in the parameter); the special point recorded on
    ``branch``. Returns the equilibrium there."""
    pa, pb = a.params[parameter], b.params[parameter]
    fa, fb = a.margin, b.margin
    best, side = (a if abs(fa) < abs(fb) else b), 0
    for _ in range(BOUNDARY_ITER):
        if abs(pb - pa) <= BOUNDARY_TOL * max(1.0, abs(pa)) or not fa * fb < 0:
            break
        p = (pa * fb - pb * fa) / (fb - fa)
        w = pb - pa
        p = min(max(p, min(pa, pb) + 1e-3 * abs(w)), max(pa, pb) - 1e-3 * abs(w))
        e = equilibrium(system, {**params, parameter: p}, mode, best.x)
        if not e.converged:
            break
        best, f = e, e.margin
        if f == 0.0:
            pa = pb = p
            break
        if f * fa > 0:
            pa, fa = p, f
            if side == -1:
                fb *= 0.5
            side = -1
        else:
            pb, fb = p, f
            if side == 1:
                fa *= 0.5
            side = 1
    lo, hi = min(pa, pb), max(pa, pb)
    ok = hi - lo <= BOUNDARY_TOL * max(1.0, abs(lo))
    amp = {n: abs(float(x)) for n, x in zip(system.variable_names, best.x, strict=True)}
    desc = (
        f"the equilibrium of mode `{mode}` reaches a switching surface: it is "
        f"{'not ' if a.admissible else ''}admissible beyond"
    )
    branch.special.append(
        SpecialPoint(
            "boundary-equilibrium",
            len(branch.points),
            best.params[parameter],
            amp,
            desc if ok else f"{desc}; not located to the tolerance",
            "located" if ok else "bracketed",
            max(abs(best.params[parameter] - lo), abs(hi - best.params[parameter])),
            (lo, hi),
        )
    )
    return best


def _branch(
    fm: FlowMap,
    solver: AutonomousSolver,
    mode: str,
    y_base: np.ndarray,
    u0: np.ndarray,
    t0: np.ndarray,
    p_range,
    settings: ContinuationOptions,
    stop_on_mode_change: bool,
    period: float,
    stop_on_mode_loss: bool = True,
) -> Branch:
    d, pos = solver.unknowns(mode)
    nd = d.size
    anchored = solver.phase == "anchor"
    cm = fm.mode(mode)
    state = {"anchor": None, "T": period, "modes": None, "beyond": None}
    par = fm.free
    samples = settings.samples_per_period

    def unpack(u):
        y = y_base.copy()
        y[d] = u[:nd]
        fm.set_parameter(u[-1])
        return cm.solve_algebraic(0.0, y)

    def evaluate(u):
        y = unpack(u)
        if anchored:
            if not u[nd] > 0:
                raise ParameterOutOfDomain("nonpositive period")
            if state["anchor"] is None:
                f = fm.field(mode, y)[d]
                state["anchor"] = (y.copy(), f / np.linalg.norm(f))
            ev = fm.timed(y, mode, float(u[nd]))
        else:
            ev = fm.returned(y, mode, solver.phase, 3.0 * state["T"])
        anchor = state["anchor"] if anchored else None
        return solver.residual(ev, y, d, anchor), solver.jacobian(ev, d, pos, anchor), (y, ev)

    branch = Branch("autonomous-orbits", fm.system, dict(fm.params), par)
    orbits = branch.points

    def make_orbit(u, info):
        y, ev = info
        T = float(u[nd]) if anchored else ev.time
        return finish(solver, y, mode, T, ev, 0, 0.0, samples)

    def accept(u, info):
        orbit = make_orbit(u, info)
        modes = frozenset(orbit.mode_sequence)
        changed = bool(orbits) and modes != state["modes"]
        if changed and (stop_on_mode_change or (state["modes"] - modes and stop_on_mode_loss)):
            # an orbit of another kind (a switch met, or a phase lost: with IDA also a switch missed
            # inside its guard's noise band near a grazing): approach the boundary instead
            state["beyond"] = orbit.params[par]
            return RETRY
        if orbits and orbit.period > PERIOD_JUMP * orbits[-1].period:
            return "period jump"  # a switch missed at a grazing (or an orbit of another kind): not kept
        orbits.append(orbit)
        state["modes"], state["T"] = modes, orbit.period
        if anchored:
            y = info[0]
            f = fm.field(mode, y)[d]
            state["anchor"] = (y.copy(), f / np.linalg.norm(f))
        return None

    points, why = follow(evaluate, u0, t0, settings, index=len(u0) - 1, p_range=p_range, accept=accept)
    pts = [AutoPoint(u, t, o) for (u, _, t), o in zip(points, orbits, strict=False)]
    loc = Locator(evaluate, make_orbit, settings, fm)
    tol = settings.locate_tol * abs(p_range[1] - p_range[0])
    _special_points(branch, pts, loc, settings, tol)
    last = orbits[-1].params[par] if orbits else math.nan
    if orbits and (
        why == "boundary"
        or (why in ("stalled", "period jump") and guard_margin(fm, orbits[-1]) <= GRAZING_MARGIN)
    ):
        sp, extra = locate_end(loc, pts, state["beyond"] if why == "boundary" else None, tol)
        k = len(orbits) - 1
        if sp is None:
            desc = "the branch ended with a guard within the grazing margin: a grazing just beyond the last orbit"
            iv = (last, math.inf) if len(orbits) < 2 or last >= orbits[-2].params[par] else (-math.inf, last)
            sp = SpecialPoint(
                "grazing", k, last, dict(orbits[k].amplitude), desc, "not located", math.inf, iv
            )
        else:
            orbits.extend(extra)
            sp = replace(sp, index=k + sp.index)
        branch.special.append(sp)
        branch.stop("grazing", f"stopped at {par}={last:.8g}: {sp.description}")
    elif why == "stalled" and not orbits:
        branch.stop("no-start", "no first orbit: the corrector failed at the start")
    elif why == "stalled":
        branch.stop(
            "stalled",
            f"stalled at {par}={last:.8g}: the corrector failed down to ds_min = {settings.ds_min:g}",
        )
    elif why == "period jump":
        branch.stop(
            "period-jump",
            f"stopped at {par}={last:.8g}: the next orbit's period is over {PERIOD_JUMP:g} times this one's "
            "(a switch missed, or an orbit of another kind)",
        )
    elif why == "max_points":
        branch.message = f"reached max_points = {settings.max_points} at {par}={last:.8g}"
    else:  # "range"
        branch.message = f"left the range at {par}={last:.8g}"
    return branch


def _special_points(branch: Branch, pts: list, loc: Locator, settings, tol: float) -> None:
    """Detect the special points between consecutive points of an autonomous branch and locate
    them (:func:`hybrid.continuation.special.locate` on the branch's corrector); the orbit at each
    located point is inserted into ``branch.points`` after the step's first orbit."""
    if len(pts) < 2:
        return
    st = replace(settings, locate_tol=tol)  # (locate takes it relative to the continuer's scale, 1)
    out, special = [pts[0].orbit], []
    for a, b in zip(pts, pts[1:], strict=False):
        ds = float(a.tangent @ (b.u - a.u))
        found = detect(a, b) if ds > 0 else []
        located = []
        for kind, desc in found:
            if kind == "nonsmooth":
                located.append((kind, desc, None))
                continue
            located.append((kind, desc, locate(loc, a, b, kind, ds, st, FAILURES)))
        for kind, desc, lc in located:
            if lc is None:
                prev = next((x for x in reversed(located) if x[2] is not None), None)
                lc = prev[2] if prev else None
            if lc is None:
                k = len(out)
                lo, hi = sorted((a.p, b.p))
                p, acc, iv, status = 0.5 * (lo + hi), 0.5 * (hi - lo), (lo, hi), "bracketed"
            else:
                if lc.point is None or lc.point is b:
                    k = len(out)  # b, appended below
                elif lc.point is a:
                    k = len(out) - 1
                else:
                    out.append(lc.point.orbit)
                    k = len(out) - 1
                p, acc, iv, status = lc.parameter, lc.accuracy, lc.interval, lc.status
                if lc.note:
                    desc = f"{desc}; {lc.note}"
            special.append((kind, k, p, desc, status, acc, iv))
        out.append(b.orbit)
    branch.points[:] = out
    for kind, k, p, desc, status, acc, iv in special:
        k = min(k, len(out) - 1)
        branch.special.append(SpecialPoint(kind, k, p, dict(out[k].amplitude), desc, status, acc, iv))


#: A point whose period exceeds this multiple of its predecessor's ends the branch.
PERIOD_JUMP = 1.5

#: A branch that stalls with a guard within this distance (relative to the state) of firing
#: (or an orbit that touches a switch with a vanishing phase) ends at a grazing.
GRAZING_MARGIN = 1e-3


def guard_margin(fm: FlowMap, orbit: PeriodicOrbit) -> float:
    """How near the orbit comes to a switch it does not take, relative to ``max |y|``: the least
    distance from zero of each mode's guards on the fire side of their direction over the
    samples, or the shortest mode phase's fraction of the period (a phase about to vanish)."""
    tr = orbit.trajectory
    scale = max(float(np.max(np.abs(tr.y))), 1e-300)
    best = min(orbit.mode_fractions.values()) if len(orbit.mode_fractions) > 1 else math.inf
    for cm in fm.cs.modes:
        at_switch = np.isin(tr.t, [0.0, tr.t[-1], *(e.t for e in tr.events)])  # where guards are 0 anyway
        rows = np.flatnonzero((tr.mode == cm.name) & ~at_switch)
        if not rows.size or not cm.guards:
            continue
        dirs = np.array([g.direction for g in cm.guards], dtype=float)
        h = np.array([cm.guard_values(0.0, tr.y[k]) for k in rows])
        gap = np.where(dirs != 0, -dirs * h, np.abs(h))
        best = min(best, float(np.min(gap)) / scale)
    return best


def _check_settings(settings) -> ContinuationOptions:
    settings = AUTONOMOUS_CONTINUATION if settings is None else settings
    if not isinstance(settings, ContinuationOptions):
        raise InputTypeError(f"`settings` must be a ContinuationOptions, got {type(settings).__name__}")
    return settings


@with_blas_threads
def orbit_branch(
    orbit: PeriodicOrbit,
    parameter: str,
    p_range: tuple[float, float],
    *,
    direction: int = 1,
    phase: str = "auto",
    options: SolverOptions | None = None,
    settings: ContinuationOptions | None = None,
    stop_on_mode_change: bool = False,
    **unexpected,
) -> Branch:
    """Continue the autonomous orbit ``orbit`` in ``parameter`` (``direction`` +1: increasing).

    The branch goes on through a mode that an orbit gains (a new phase, e.g. both contacts stuck
    at once; a special point ``"mode-gained"``), and ends at a grazing where a phase vanishes (a
    mode lost) or, with ``stop_on_mode_change``, at any change of the modes visited.

    Parameters
    ----------
    orbit : PeriodicOrbit
        The start: an autonomous orbit (its own section state; for a switch section, ``orbit``
        must have been computed on that section).
    parameter : str
        The parameter to continue in.
    p_range : (float, float)
        The branch ends when the parameter leaves this interval.
    direction : {1, -1}
        +1: towards increasing values first.
    phase : str
        As in :func:`hybrid.orbits.autonomous.autonomous_orbit`.
    options : SolverOptions, optional
        Tolerances of the runs (default :data:`hybrid.ORBIT_OPTIONS`).
    settings : ContinuationOptions, optional
        Steps, corrector, points and samples (default :data:`AUTONOMOUS_CONTINUATION`).
    stop_on_mode_change : bool
        End the branch at any change of the modes visited.

    Returns
    -------
    Branch
        ``kind`` ``"autonomous-orbits"``; ``status`` ``"stopped"`` with ``reason`` ``"grazing"``,
        ``"stalled"``, ``"period-jump"`` or ``"no-start"`` where it ended inside the range.
    """
    reject_keywords(
        "orbit_branch",
        unexpected,
        options=options if isinstance(options, SolverOptions) else SolverOptions,
        settings=settings if isinstance(settings, ContinuationOptions) else ContinuationOptions,
    )
    system = orbit.system
    if parameter not in system.parameter_names:
        raise InputError(
            f"model `{system.name}` has no parameter `{parameter}`; parameters: {', '.join(system.parameter_names)}"
        )
    if direction not in (1, -1):
        raise InputError(f"`direction` must be 1 or -1, got {direction!r}")
    phase = resolve_phase(system, phase)
    options = ORBIT_OPTIONS if options is None else options
    settings = _check_settings(settings)
    fm = FlowMap(system, orbit.params, options, orbit.period, free=parameter)
    solver = AutonomousSolver(fm, phase, settings.newton.tol, settings.newton.max_iter)
    d, _ = solver.unknowns(orbit.mode0)
    extra = [orbit.period] if phase == "anchor" else []
    u0 = np.concatenate([orbit.x0[d], extra, [orbit.params[parameter]]])
    t0 = np.zeros(u0.size)
    t0[-1] = direction
    branch = _branch(
        fm,
        solver,
        orbit.mode0,
        orbit.x0.copy(),
        u0,
        t0,
        p_range,
        settings,
        stop_on_mode_change,
        orbit.period,
    )
    return with_options(branch, options, settings)


@with_blas_threads
def hopf_branch(
    eq: Equilibrium,
    parameter: str,
    p_range: tuple[float, float],
    *,
    options: SolverOptions | None = None,
    settings: ContinuationOptions | None = None,
    stop_on_mode_change: bool = True,
    **unexpected,
) -> Branch:
    """The periodic orbits born at the Hopf point ``eq`` (an equilibrium at the critical value).

    The first orbit is corrected from ``eq.x + ds Re(q)`` (``q`` the critical eigenvector,
    normalised) with period ``2 pi / omega``, on the hyperplane orthogonal to ``Re(q)``; the
    branch follows with the anchor phase condition, and (by default) stops where the orbit meets
    a switch (a grazing).

    Parameters
    ----------
    eq : Equilibrium
        The equilibrium at the Hopf point (e.g. ``locate_hopf(...).equilibrium``, or the point of
        an equilibrium branch at its special point ``"hopf"``).
    parameter : str
    p_range : (float, float)
        The branch ends when the parameter leaves this interval.
    options : SolverOptions, optional
        Tolerances of the runs (default :data:`hybrid.ORBIT_OPTIONS`).
    settings : ContinuationOptions, optional
        Default :data:`AUTONOMOUS_CONTINUATION` (``ds`` is also the first orbit's displacement
        from the equilibrium).
    stop_on_mode_change : bool

    Returns
    -------
    Branch
        ``kind`` ``"autonomous-orbits"``, as :func:`orbit_branch`'s.
    """
    reject_keywords(
        "hopf_branch",
        unexpected,
        options=options if isinstance(options, SolverOptions) else SolverOptions,
        settings=settings if isinstance(settings, ContinuationOptions) else ContinuationOptions,
    )
    system = eq.system
    settings = _check_settings(settings)
    options = ORBIT_OPTIONS if options is None else options
    lam, vec = np.linalg.eig(eq.jacobian)
    k = int(np.argmax(lam.real))
    om = abs(float(lam[k].imag))
    if not om > 0:
        raise InputError("the critical eigenvalue of `eq` is real: not a Hopf point")
    q = vec[:, k]
    q = q * np.exp(-1j * np.angle(q[np.argmax(np.abs(q))]))  # largest component real
    qr = q.real / np.linalg.norm(q.real)
    T = 2.0 * math.pi / om
    fm = FlowMap(system, eq.params, options, T, free=parameter)
    solver = AutonomousSolver(fm, "anchor", settings.newton.tol, settings.newton.max_iter)
    d, _ = solver.unknowns(eq.mode)
    x_eq = eq.x[d]
    u0 = np.concatenate([x_eq + settings.ds * qr, [T, eq.params[parameter]]])
    t0 = np.concatenate([qr, [0.0, 0.0]])
    branch = _branch(fm, solver, eq.mode, eq.x.copy(), u0, t0, p_range, settings, stop_on_mode_change, T)
    return with_options(branch, options, settings)
