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

Special points are detected between consecutive points and located by
bisection along the arclength: folds (the parameter component of the tangent
changes sign), period doubling (``det(M + I)`` changes sign), Neimark-Sacker
(a complex pair crosses the unit circle), and changes of the mode sequence
(a mode gained or lost, e.g. the onset of slip; or a change of the number of
switches per period with the same modes: grazing).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field

import numpy as np

from ._budget import BudgetExceeded
from ._options import SolverOptions
from ._orbit import (
    ORBIT_OPTIONS,
    PeriodicOrbit,
    Shooter,
    _choose_section_period,
    _finish,
    _Newton,
    _scale,
    check_samples,
    is_family,
    solve_orbit,
)
from ._simulate import check_time_range, initial_state
from ._system import HybridSystem

__all__ = ["Branch", "SpecialPoint", "continuation"]


@dataclass(frozen=True)
class SpecialPoint:
    """A bifurcation or mode-sequence change located on a branch.

    Attributes
    ----------
    kind : str
        ``"fold"``, ``"period-doubling"``, ``"neimark-sacker"``, ``"mode-gained"``,
        ``"mode-lost"`` or ``"grazing"``.
    index : int
        Index in ``Branch.points`` of the located orbit.
    parameter : float
        Parameter value at the point.
    amplitude : dict
        ``max |x|`` per variable and output at the point.
    description : str
        What changes there.
    """

    kind: str
    index: int
    parameter: float
    amplitude: dict
    description: str


@dataclass
class Branch:
    """A branch of periodic orbits.

    Attributes
    ----------
    system : HybridSystem
    params : dict
        Parameter values (the continued one at its start value).
    parameter : str
        The continued parameter.
    points : list of PeriodicOrbit
        Orbits in branch order (located special points included).
    special : list of SpecialPoint
    status : str
        ``"completed"`` (left the range or reached ``max_points``) or ``"stopped"``.
    message : str
    """

    system: HybridSystem
    params: dict
    parameter: str
    points: list = field(default_factory=list)
    special: list = field(default_factory=list)
    status: str = "completed"
    message: str = ""

    @property
    def p(self) -> np.ndarray:
        """Parameter value of every point."""
        return np.array([o.params[self.parameter] for o in self.points])

    def amplitude(self, name: str) -> np.ndarray:
        """``max |x|`` of ``name`` at every point."""
        return np.array([o.amplitude[name] for o in self.points])

    def half_peak_to_peak(self, name: str) -> np.ndarray:
        return np.array([o.half_peak_to_peak[name] for o in self.points])

    @property
    def stability(self) -> list[str]:
        return [o.stability for o in self.points]

    def to_rows(self) -> list[dict]:
        """One dict per point (for CSV)."""
        rows = []
        for o in self.points:
            row = {
                self.parameter: o.params[self.parameter],
                "stability": o.stability,
                "transitions_per_period": o.transitions_per_period,
                "stick_fraction": o.stick_fraction,
                "mode_sequence": " ".join(o.mode_sequence),
                "max_abs_multiplier": float(np.max(np.abs(o.floquet_multipliers)))
                if o.floquet_multipliers.size
                else float("nan"),
                "residual": o.residual,
            }
            for n, v in o.amplitude.items():
                row[f"amplitude_{n}"] = v
            for n, v in o.half_peak_to_peak.items():
                row[f"half_peak_to_peak_{n}"] = v
            rows.append(row)
        return rows

    def __repr__(self) -> str:
        kinds = ", ".join(f"{s.kind}@{s.parameter:.6g}" for s in self.special)
        if not self.points:
            return f"Branch({self.system.name}, {self.parameter}, no point, {self.status}: {self.message})"
        return (
            f"Branch({self.system.name}, {self.parameter} in [{self.p.min():.6g}, {self.p.max():.6g}], "
            f"{len(self.points)} points, special: [{kinds}], {self.status})"
        )


# ----------------------------------------------------------------------
@dataclass
class _Point:
    y: np.ndarray  # full state at the section
    p: float
    mode: str
    phi: float  # section phase (fraction of the period)
    tangent: np.ndarray | None = None  # scaled (y_d, p)
    orbit: PeriodicOrbit | None = None
    iterations: int = 0


class _Continuer:
    def __init__(self, system, params, parameter, p_range, options, tol):
        self.system = system
        self.parameter = parameter
        self.base = dict(params)
        self.a, self.b = p_range
        self.sp = abs(self.b - self.a)
        self.tol = tol
        self.sh = Shooter(system, params, options, free=parameter)

    def at(self, p: float) -> None:
        self.sh.set_params({**self.base, self.parameter: p})

    # scaled coordinates -------------------------------------------------
    def scale_of(self, pt: _Point, d: np.ndarray) -> float:
        return _scale(pt.y, d)

    def system_matrix(self, y, Jy, Jp, r, d, force_gauge: bool = False):
        """Rows of the (scaled) Newton system; adds the gauge on a family."""
        sv = np.linalg.svd(Jy, compute_uv=False)
        family = force_gauge or is_family(sv)
        A = np.hstack([Jy, Jp[:, None]])
        rhs = -r
        g = self.sh.gauge(y)
        if family and g is not None:
            A = np.vstack([A, np.concatenate([g[1][d], [0.0]])])
            rhs = np.concatenate([rhs, [-g[0]]])
        return A, rhs, family

    def correct(
        self, pt: _Point, ds: float, samples: int, max_iter: int = 8, force_gauge: bool = False
    ) -> _Point:
        """Predict along ``pt.tangent`` by ``ds`` (scaled arclength), correct on the normal hyperplane.

        Returns the converged point with its orbit and tangent (from the orbit's own Jacobian).
        """
        nw = _Newton(self.sh, pt.mode)
        d = nw.d
        sy = self.scale_of(pt, d)
        D = np.concatenate([np.full(d.size, sy), [self.sp]])  # unscaled = scaled * D
        tau = pt.tangent
        X0 = np.concatenate([pt.y[d], [pt.p]])
        Xp = X0 + ds * tau * D
        y = pt.y.copy()
        y[d] = Xp[:-1]
        p = float(Xp[-1])
        it, prev, lam = 0, None, 1.0
        while True:
            self.at(p)
            T = self.sh.period
            t0 = pt.phi * T
            y = nw.project(t0, y)
            tr = self.sh.run(y, pt.mode, t0, samples=samples)
            if not tr.success:
                raise _Fail(f"run failed at {self.parameter}={p:.8g}: {tr.message}")
            r = nw.residual(tr, y)
            scale = _scale(y, d)
            res = float(np.max(np.abs(r))) / scale
            if not np.all(np.isfinite(tr.y_final)) or scale > 1e6 * max(sy, 1e-300):
                raise _Fail(f"the response grows without bound near {self.parameter}={p:.8g}")
            if prev is not None and res > prev[2] and lam > 1.0 / 16:
                # Damped Newton: the map is only piecewise smooth and I - M nearly singular.
                lam *= 0.5
                y = prev[0].copy()
                y[d] += lam * prev[3][:-1]
                p = float(prev[1] + lam * prev[3][-1])
                continue
            g = self.sh.gauge(y)
            Jy, Jp, M = self.jacobian(tr, y, p, pt.mode, pt.phi, nw)
            A, rhs, family = self.system_matrix(y, Jy, Jp, r, d, force_gauge)
            gauge_ok = not family or g is None or abs(g[0]) <= self.tol * scale
            X = np.concatenate([y[d], [p]])
            Ab = np.vstack([A, tau / D])
            rhs = np.concatenate([rhs, [-(tau @ ((X - Xp) / D))]])
            delta = np.linalg.lstsq(Ab, rhs, rcond=1e-10)[0]
            # Converged: small residual and a Newton update at the noise level of the map
            # (integration error amplified by the conditioning of the bordered system).
            sv = np.linalg.svd(Ab * D[None, :], compute_uv=False)
            kappa = sv[0] / max(sv[-1], 1e-300)
            step_tol = max(1e-7, 10.0 * kappa * self.sh.options.rtol)
            if res <= self.tol and gauge_ok and float(np.max(np.abs(delta / D))) <= step_tol:
                if tr.mode_final != pt.mode:
                    raise _Fail("section reached a switch")
                new = _Point(y, p, pt.mode, pt.phi, iterations=it)
                new.orbit = _finish(self.sh, nw, y, pt.mode, t0, it, res, self.tol, samples, "", tr=tr, M=M)
                new.tangent = self.null_vector(A, D, tau)
                return new
            if it == max_iter:
                break
            it += 1
            prev, lam = (y.copy(), p, res, delta), 1.0
            y = y.copy()
            y[d] += delta[:-1]
            p = float(p + delta[-1])
        raise _Fail(f"corrector did not converge in {max_iter} iterations near {self.parameter}={p:.8g}")

    def jacobian(self, tr, y, p, mode, phi, nw):
        """``(dP/dy_d - I, dP/dp, M)`` at a run ``tr`` from ``(y, p)``."""
        M = self.sh.monodromy(tr)  # sensitivity variables: states in s, then the parameter
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

    def tangent(self, pt: _Point, prev: np.ndarray | None, direction: float) -> np.ndarray:
        nw = _Newton(self.sh, pt.mode)
        d = nw.d
        self.at(pt.p)
        t0 = pt.phi * self.sh.period
        y = nw.project(t0, pt.y)
        tr = self.sh.run(y, pt.mode, t0)
        r = nw.residual(tr, y)
        Jy, Jp, _ = self.jacobian(tr, y, pt.p, pt.mode, pt.phi, nw)
        A, _, _ = self.system_matrix(y, Jy, Jp, r, d)
        D = np.concatenate([np.full(d.size, self.scale_of(pt, d)), [self.sp]])
        return self.null_vector(A, D, prev, direction)


class _Fail(Exception):
    pass


def _signature(o: PeriodicOrbit) -> tuple[int, frozenset]:
    """Switch instants per period and the modes occupied for a positive time.

    A mode passed through at one instant (a chained switch, e.g. slip -> stick -> slip at a
    velocity reversal) does not count, so the loss of a stick phase is seen.
    """
    instants = sum(1 for e in o.trajectory.events if not e.chained)
    return instants, frozenset(m for m, f in o.mode_fractions.items() if f > 0)


def _tests(o: PeriodicOrbit) -> tuple[float, float] | None:
    """(det(M + I), prod over pairs (l_i l_j - 1)) on the Floquet multipliers; None on a family."""
    if o.family:
        return None
    lam = o.floquet_multipliers
    pd = float(np.real(np.prod(lam + 1.0)))
    ns = 1.0 + 0j
    for i in range(lam.size):
        for j in range(i + 1, lam.size):
            ns *= lam[i] * lam[j] - 1.0
    return pd, float(np.real(ns))


def continuation(
    system: HybridSystem,
    params: Mapping[str, float],
    parameter: str = "Omega",
    p_range: tuple[float, float] | None = None,
    *,
    x0=None,
    mode0: str | None = None,
    ds: float = 0.02,
    ds_min: float = 1e-7,
    ds_max: float = 0.5,
    max_points: int = 2000,
    options: SolverOptions | None = None,
    tol: float = 1e-9,
    transient_periods: int = 10,
    samples_per_period: int = 256,
    locate: bool = True,
    progress: Callable[[float], None] | None = None,
) -> Branch:
    """Continue periodic orbits in ``parameter`` from ``p_range[0]`` towards ``p_range[1]``.

    Parameters
    ----------
    system : HybridSystem
        A periodically forced model.
    params : mapping
        All parameter values (the continued one is replaced by ``p_range[0]``).
    parameter : str
        Any parameter of the model (default the forcing frequency ``Omega``).
    p_range : (float, float)
        Start and end value; the branch stops when it leaves the range.
    x0, mode0 : optional
        Guess of the first orbit (see :func:`hybrid.periodic_orbit`).
    ds, ds_min, ds_max : float
        Initial, smallest and largest step in scaled arclength (state relative
        to its size, parameter relative to ``|p_range[1] - p_range[0]|``).
    max_points : int
        Points computed at most (special points not counted).
    options : SolverOptions, optional
        Tolerances (default :data:`hybrid.ORBIT_OPTIONS`).
    tol : float
        Newton tolerance (scaled).
    transient_periods : int
        Periods simulated from ``x0`` before the first orbit.
    samples_per_period : int
        Samples of each stored orbit's trajectory.
    locate : bool
        Locate special points by bisection (else report the first point past them).
    progress : callable, optional
        Called with the fraction of the parameter range covered.

    Returns
    -------
    Branch
    """
    options = ORBIT_OPTIONS if options is None else options
    if not isinstance(system, HybridSystem):
        raise TypeError(f"`system` must be a HybridSystem, got {type(system).__name__}")
    if parameter not in system.parameter_names:
        raise ValueError(
            f"model `{system.name}` has no parameter `{parameter}`; parameters: {', '.join(system.parameter_names)}"
        )
    if p_range is None or len(p_range) != 2:
        raise ValueError(f"`p_range` must be two numbers (start, end), got {p_range!r}")
    a, b = (float(v) for v in p_range)
    if not (math.isfinite(a) and math.isfinite(b)) or a == b:
        raise ValueError(f"`p_range` must be two different finite numbers, got {p_range!r}")
    for nm, v in (("ds", ds), ("ds_min", ds_min), ("ds_max", ds_max), ("tol", tol)):
        if not (isinstance(v, int | float) and math.isfinite(v) and v > 0):
            raise ValueError(f"`{nm}` must be a number > 0, got {v!r}")
    if not ds_min <= ds <= ds_max:
        raise ValueError(f"need ds_min <= ds <= ds_max, got {ds_min}, {ds}, {ds_max}")
    check_samples(samples_per_period)
    start_params = system.parameter_values({**dict(params), parameter: a})
    mode0 = mode0 if mode0 is not None else system.initial_mode
    if mode0 is None:
        raise ValueError(f"`mode0` is required: model `{system.name}` declares no initial mode")
    system.mode(mode0)
    y0 = initial_state(system, np.zeros(len(system.variable_names)) if x0 is None else x0, mode0)
    c = _Continuer(system, start_params, parameter, (a, b), options, tol)
    for p in (b, a):  # both ends of the range must be resolvable in time (a at its transient)
        c.at(p)
        n = transient_periods + 1 if p == a else 2
        check_time_range(c.sh.cs, options, 0.0, n * c.sh.period)
    direction = 1.0 if b > a else -1.0
    branch = Branch(system, dict(start_params), parameter)

    first = solve_orbit(c.sh, y0, mode0, 0.0, transient_periods, tol, 30, samples_per_period)
    try:
        _follow(
            c, branch, first, direction, ds, ds_min, ds_max, max_points, samples_per_period, locate, progress
        )
    except BudgetExceeded as exc:  # the budget of a run or the computation's deadline: stop here
        branch.status = "stopped"
        last = branch.points[-1].params[parameter] if branch.points else a
        branch.message = f"stopped at {parameter}={last:.8g}: {exc}"
    return branch


def _follow(
    c, branch, first, direction, ds, ds_min, ds_max, max_points, samples_per_period, locate, progress
):
    """Follow the branch from its first orbit (see :func:`continuation`)."""
    parameter = c.parameter
    a, b = c.a, c.b
    if not first.converged:
        branch.status = "stopped"
        branch.message = f"no periodic orbit at {parameter}={a:.8g}: {first.message}"
        return
    pt = _Point(first.x0.copy(), a, first.mode0, first.t0 / first.period, orbit=first)
    branch.points.append(first)
    try:
        pt.tangent = c.tangent(pt, None, direction)
    except (_Fail, np.linalg.LinAlgError, ArithmeticError, RuntimeError) as exc:
        branch.status = "stopped"
        branch.message = f"stopped at {parameter}={a:.8g}: no tangent to the branch: {exc}"
        return
    ds_cur = ds
    rephased = False
    n_points = 1
    done = 0.0
    while n_points < max_points:
        try:
            new = c.correct(pt, ds_cur, samples_per_period)
        except (_Fail, np.linalg.LinAlgError, ArithmeticError, RuntimeError) as exc:
            if ds_cur / 4.0 >= ds_min:
                ds_cur /= 4.0
                continue
            # The section may sit at a switch now: move it once before giving up.
            if "switch" in str(exc) and not rephased:
                moved = _rephase(c, pt, direction)
                if moved is not None:
                    pt, ds_cur, rephased = moved, ds, True
                    continue
            branch.status = "stopped"
            grow = "grows without bound" in str(exc)
            branch.message = (
                f"stopped at {parameter}={pt.p:.8g}: "
                + (
                    "no bounded periodic orbit beyond this point (the response grows without bound); "
                    if grow
                    else ""
                )
                + str(exc)
            )
            break
        # Leaving a stick-slip band, the symmetric orbit loses its slip phases at once; rounding
        # lets one go first and the corrector lands on a boundary member of the neutral family
        # (one grazing slip per period). Prefer the family's gauge member when it exists.
        if (
            c.sh.gauge(new.y) is not None
            and 0 < new.orbit.transitions_per_period < pt.orbit.transitions_per_period
        ):
            try:
                alt = c.correct(pt, ds_cur, samples_per_period, force_gauge=True)
                if alt.orbit.transitions_per_period == 0:
                    new = alt
            except (_Fail, np.linalg.LinAlgError, ArithmeticError, RuntimeError):
                pass
        # Special points between pt and new.
        found = _detect(pt, new) if pt.orbit is not None else []
        for kind, desc in found:
            loc = _locate(c, pt, new, kind, ds_cur, samples_per_period) if locate else new
            branch.points.append(loc.orbit)
            branch.special.append(
                SpecialPoint(kind, len(branch.points) - 1, loc.p, dict(loc.orbit.amplitude), desc)
            )
        branch.points.append(new.orbit)
        n_points += 1
        if progress is not None:
            done = max(done, min(1.0, max(0.0, (new.p - a) / (b - a))))
            progress(done)
        # Step control: aim at 3 corrector iterations.
        factor = {0: 2.0, 1: 2.0, 2: 1.4, 3: 1.0}.get(new.iterations, 0.6)
        ds_cur = min(ds_max, max(ds_min, ds_cur * factor))
        pt, rephased = new, False
        if (new.p - b) * direction > 0 or (new.p - a) * direction < 0:
            break


def _rephase(c: _Continuer, pt: _Point, direction: float) -> _Point | None:
    c.at(pt.p)
    o = pt.orbit
    t, y, m = _choose_section_period(c.sh.run(o.x0, o.mode0, o.t0, samples=256), c.sh.period)
    new = _Point(y, pt.p, m, t / c.sh.period, orbit=o)
    try:
        new.tangent = c.tangent(new, None, direction)
    except Exception:
        return None
    return new


def _detect(a: _Point, b: _Point) -> list[tuple[str, str]]:
    out = []
    oa, ob = a.orbit, b.orbit
    if a.tangent.size == b.tangent.size and a.tangent[-1] * b.tangent[-1] < 0:
        out.append(("fold", "the branch turns back in the parameter (a multiplier crosses +1)"))
    ta, tb = _tests(oa), _tests(ob)
    if ta is not None and tb is not None:
        if ta[0] * tb[0] < 0:
            out.append(("period-doubling", "a multiplier crosses -1"))
        if ta[1] * tb[1] < 0:
            lam = ob.floquet_multipliers
            if np.any(np.abs(lam.imag) > 1e-9):
                out.append(("neimark-sacker", "a complex pair of multipliers crosses the unit circle"))
    sa, sb = _signature(oa), _signature(ob)
    if sa != sb:
        gained = sb[1] - sa[1]
        lost = sa[1] - sb[1]
        if gained:
            out.append(("mode-gained", f"mode(s) {', '.join(sorted(gained))} appear(s) in the orbit"))
        elif lost:
            out.append(("mode-lost", f"mode(s) {', '.join(sorted(lost))} leave(s) the orbit"))
        else:
            out.append(("grazing", f"switches per period change from {sa[0]} to {sb[0]}"))
    return out


def _locate(c: _Continuer, a: _Point, b: _Point, kind: str, ds: float, samples: int) -> _Point:
    """Bisection along the arclength from ``a`` for the change of ``kind`` between ``a`` and ``b``."""

    def side(pt: _Point) -> float:
        o = pt.orbit
        if kind == "fold":
            return float(np.sign(pt.tangent[-1]) * np.sign(a.tangent[-1]))
        if kind in ("period-doubling", "neimark-sacker"):
            t, ta = _tests(o), _tests(a.orbit)
            if t is None:
                return -1.0
            k = 0 if kind == "period-doubling" else 1
            return float(np.sign(t[k]) * np.sign(ta[k]))
        return 1.0 if _signature(o) == _signature(a.orbit) else -1.0

    lo, hi = 0.0, ds
    best = b
    for _ in range(12):
        mid = 0.5 * (lo + hi)
        try:
            pt = c.correct(a, mid, samples)
        except (_Fail, np.linalg.LinAlgError, ArithmeticError, RuntimeError):
            break
        if side(pt) > 0:
            lo = mid
        else:
            hi, best = mid, pt
    return best
