"""Equilibria of one mode of an autonomous hybrid system, their eigenvalues, and Hopf points.

An equilibrium of mode ``m`` is a state with ``f_m(x, z) = 0`` for its differential variables
``x`` (quadratures excluded) and ``g_m(x, z) = 0`` for its slave variables ``z``. Newton's method
uses the mode's exact Jacobian reduced to the differential variables,

    A = f_x - f_z g_z^-1 g_x,

whose eigenvalues decide stability (all real parts < 0: stable). An equilibrium is only a
steady state of the hybrid system if the mode's guards do not fire there (``admissible``).

Along a parameter, the equilibrium loses stability where a real part crosses 0; a complex pair
crossing is a Hopf point, located by the secant method (Illinois) on the largest real part,
each iterate an equilibrium solved at that parameter value.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from ..core.errors import ConvergenceError, InputError, InputTypeError, ModelError
from ..core.options import NewtonOptions
from ..core.status import SolveStatus
from ..engine.simulate import initial_state
from ..model.compiled import CompiledSystem
from ..model.system import HybridSystem

__all__ = [
    "Equilibrium",
    "HopfPoint",
    "equilibrium",
    "locate_hopf",
    "reduced_jacobian",
    "EQUILIBRIUM_NEWTON",
    "HOPF_SECANT",
]

#: Newton options of :func:`equilibrium` by default: ``max |f| <= 1e-12 max(1, max |x|)``.
EQUILIBRIUM_NEWTON = NewtonOptions(tol=1e-12, max_iter=50)
#: Secant options of :func:`locate_hopf` by default: the bracket within 1e-13 of the parameter.
HOPF_SECANT = NewtonOptions(tol=1e-13, max_iter=60)


@dataclass(frozen=True)
class Equilibrium:
    """A steady state of one mode.

    Attributes
    ----------
    system : HybridSystem
    params : dict
        Parameter values.
    mode : str
        The mode.
    x : ndarray, shape (n_vars,)
        The state (quadratures 0; slave variables consistent).
    state_names : tuple of str
        The differential variables of ``jacobian`` and ``eigenvalues``.
    jacobian : ndarray, shape (n, n)
        ``A = f_x - f_z g_z^-1 g_x`` [1/s].
    eigenvalues : ndarray of complex, shape (n,)
        Eigenvalues of ``A`` [1/s], by decreasing real part.
    stability : str
        ``"stable"`` (all real parts < 0), ``"unstable"`` (one > 0) or ``"neutral"``.
    admissible : bool
        No guard of the mode has left its admissible side there (the steady state exists in
        the hybrid system, not only in the mode's equations).
    status : SolveStatus
        ``"converged"`` or ``"failed"`` (:attr:`converged` says the same as a bool).
    residual : float
        ``max |f|`` at ``x``.
    message : str
    reason : str
        Why it failed, a code of :data:`hybrid.core.status.SOLVE_REASONS`
        (``"not-converged"``, ``"diverged"``, ``"solve-failed"``, ``"singular"``); ``""`` if
        converged.
    margin : float
        How far the mode's guards are from firing there: the least of ``-h`` (a guard that fires
        rising), ``h`` (falling) and ``|h|`` (either way) over its guards, in their units; negative
        where it is not admissible, zero at a boundary equilibrium (``inf`` without guards).
    """

    system: HybridSystem
    params: dict
    mode: str
    x: np.ndarray
    state_names: tuple
    jacobian: np.ndarray
    eigenvalues: np.ndarray
    stability: str
    admissible: bool
    status: SolveStatus
    residual: float
    message: str
    reason: str = ""
    margin: float = math.inf

    @property
    def converged(self) -> bool:
        """True if :attr:`status` is ``"converged"``."""
        return self.status == SolveStatus.CONVERGED

    @property
    def stable(self) -> bool | None:
        return {"stable": True, "unstable": False}.get(self.stability)

    def state(self, name: str) -> float:
        """Value of variable ``name``."""
        return float(self.x[self.system.variable_names.index(name)])

    def to_dict(self) -> dict:
        """JSON-ready summary."""
        return {
            "model": self.system.name,
            "parameters": dict(self.params),
            "mode": self.mode,
            "x": {n: float(v) for n, v in zip(self.system.variable_names, self.x, strict=True)},
            "eigenvalues": [[float(z.real), float(z.imag)] for z in self.eigenvalues],
            "stability": self.stability,
            "admissible": self.admissible,
            "converged": self.converged,
            "residual": self.residual,
            "message": self.message,
        }

    def __repr__(self) -> str:
        if not self.converged:
            return f"Equilibrium({self.system.name}, mode {self.mode}, failed ({self.reason}))"
        top = complex(self.eigenvalues[0]) if self.eigenvalues.size else complex("nan")
        return (
            f"Equilibrium({self.system.name}, mode {self.mode}, {self.stability}"
            + ("" if self.admissible else ", not admissible")
            + f", leading eigenvalue {top.real:.6g}{top.imag:+.6g}j 1/s, residual {self.residual:.2g})"
        )


def _unknowns(system: HybridSystem, cm) -> np.ndarray:
    quad = set(system.quadratures)
    return np.array(
        [i for i in cm.diff_idx if cm.names[i] not in quad and i < len(system.variable_names)], dtype=int
    )


def reduced_jacobian(cm, y: np.ndarray, d: np.ndarray, extra: np.ndarray | None = None) -> np.ndarray:
    """``f_x - f_z g_z^-1 g_x`` at the consistent point ``y`` over the columns ``d`` (and ``extra``)."""
    J = -cm.dFdy(0.0, y)  # differential rows: df/dy; slave rows: -dg/dy
    a = cm.alg_idx
    cols = d if extra is None else np.concatenate([d, extra])
    A = J[np.ix_(d, cols)]
    if a.size:
        Gz = J[np.ix_(a, a)]
        A = A - J[np.ix_(d, a)] @ np.linalg.solve(Gz, J[np.ix_(a, cols)])
    return A


def _verdict(ev: np.ndarray, tol: float) -> str:
    top = float(np.max(ev.real)) if ev.size else -math.inf
    return "unstable" if top > tol else ("stable" if top < -tol else "neutral")


def equilibrium(
    system: HybridSystem,
    params: Mapping[str, float],
    mode: str,
    x0=None,
    *,
    settings: NewtonOptions | None = None,
) -> Equilibrium:
    """Equilibrium of ``mode`` by Newton's method with the exact Jacobian.

    Parameters
    ----------
    system : HybridSystem
    params : mapping of str to float
        All parameter values.
    mode : str
        The mode whose steady state is sought.
    x0 : mapping or array_like, optional
        Guess (default all 0).
    settings : NewtonOptions, optional
        ``tol`` on ``max |f|`` relative to ``max(1, max |x|)`` [1/s], ``max_iter`` iterations
        (default :data:`EQUILIBRIUM_NEWTON`: 1e-12, 50).

    Returns
    -------
    Equilibrium
        ``converged`` False (with the reason) if Newton's method failed.

    Raises
    ------
    ValueError
        Unknown mode, bad parameters or guess, a model that depends on ``t``.
    """

    if not isinstance(system, HybridSystem):
        raise InputTypeError(f"`system` must be a HybridSystem, got {type(system).__name__}")
    settings = EQUILIBRIUM_NEWTON if settings is None else settings
    if not isinstance(settings, NewtonOptions):
        raise InputTypeError(f"`settings` must be a NewtonOptions, got {type(settings).__name__}")
    system.mode(mode)
    params = system.parameter_values(params)
    cs = CompiledSystem(system, params)
    if cs.depends_on_time():
        raise ModelError(f"model `{system.name}` depends on t: equilibria need an autonomous model")
    cm = cs.modes[cs.mode_id(mode)]
    y = initial_state(system, np.zeros(len(system.variable_names)) if x0 is None else x0, mode)
    return _solve(system, params, cm, y, settings.tol, settings.max_iter)


def _solve(system, params, cm, y, tol, max_iter) -> Equilibrium:
    d = _unknowns(system, cm)
    msg, reason = "", ""
    res = math.inf
    try:
        y = cm.solve_algebraic(0.0, y)
        for it in range(max_iter + 1):
            f = cm.rhs(0.0, y)[d]
            res = float(np.max(np.abs(f))) if f.size else 0.0
            A = reduced_jacobian(cm, y, d)
            if res <= tol * max(1.0, float(np.max(np.abs(y[d]))) if d.size else 1.0):
                # one more step where it lowers the residual: the state to rounding, not to tol (an
                # equilibrium 1e-12 off moved a Hopf point by 9e-13 on belt_stribeck)
                if res > 0.0:
                    z = y.copy()
                    z[d] -= np.linalg.lstsq(A, f, rcond=None)[0]
                    z = cm.solve_algebraic(0.0, z)
                    fz = cm.rhs(0.0, z)[d]
                    rz = float(np.max(np.abs(fz)))
                    if np.all(np.isfinite(z)) and rz < res:
                        y, res, A = z, rz, reduced_jacobian(cm, z, d)
                break
            if it == max_iter:
                msg = f"Newton's method did not converge ({max_iter} iterations, max |f| = {res:.3g})"
                reason = "not-converged"
                break
            y = y.copy()
            y[d] -= np.linalg.lstsq(A, f, rcond=None)[0]
            y = cm.solve_algebraic(0.0, y)
            if not np.all(np.isfinite(y)):
                msg, reason = "Newton's iterates diverged", "diverged"
                break
    except (RuntimeError, np.linalg.LinAlgError, ArithmeticError) as exc:
        msg, reason = f"Newton's method failed: {exc}", "solve-failed"
        A = np.full((d.size, d.size), np.nan)
    if not msg and d.size:
        sv = np.linalg.svd(A, compute_uv=False)
        if sv[-1] <= 1e-12 * max(sv[0], 1.0):
            msg = "the Jacobian is singular there: not an isolated equilibrium (a continuum of steady states)"
            reason = "singular"
    ev = np.linalg.eigvals(A) if np.all(np.isfinite(A)) else np.full(d.size, np.nan, dtype=complex)
    ev = ev[np.argsort(-ev.real, kind="stable")]
    h = cm.guard_values(0.0, y)
    dirs = np.array([g.direction for g in cm.guards])
    # a guard with direction +1 fires when it rises through 0: admissible while it is negative
    admissible = (
        bool(np.all(np.where(dirs > 0, h < 0, np.where(dirs < 0, h > 0, h != 0)))) if h.size else True
    )
    margin = float(np.min(np.where(dirs > 0, -h, np.where(dirs < 0, h, np.abs(h))))) if h.size else math.inf
    return Equilibrium(
        system=system,
        params=dict(params),
        mode=cm.name,
        x=y,
        state_names=tuple(cm.names[i] for i in d),
        jacobian=A,
        eigenvalues=ev,
        stability=_verdict(ev, 1e-12) if not msg else "unknown",
        admissible=admissible,
        margin=margin,
        status=SolveStatus.FAILED if reason else SolveStatus.CONVERGED,
        residual=res,
        message=msg or "converged",
        reason=reason,
    )


@dataclass(frozen=True)
class HopfPoint:
    """Where an equilibrium's largest real part crosses 0 (the result of :func:`locate_hopf`).

    Attributes
    ----------
    kind : str
        ``"hopf"`` (a complex pair crosses the imaginary axis) or ``"real-eigenvalue"`` (a real
        eigenvalue crosses 0), the kinds of :class:`hybrid.SpecialPoint` a branch records.
    parameter : float
        The parameter's value there.
    equilibrium : Equilibrium
        The equilibrium at ``parameter`` (the start of :func:`hybrid.hopf_branch`).
    frequency : float
        ``|Im lambda|`` of the critical eigenvalue [rad/s] (0 for a real one).
    status : str
        ``"located"`` (the bracket closed to the tolerance, or to the rounding of the eigenvalues
        where that is wider) or ``"bracketed"`` (the iterations ran out first: the point lies in
        ``interval``).
    accuracy : float
        Bound on the error of ``parameter``: its largest distance to the ends of ``interval``.
    interval : tuple of float
        The last bracket, widened by what the rounding of the eigenvalues moves the crossing.
    """

    kind: str
    parameter: float
    equilibrium: Equilibrium
    frequency: float
    status: str
    accuracy: float
    interval: tuple

    def __repr__(self) -> str:
        return (
            f"HopfPoint({self.kind} at {self.parameter:.12g} ({self.status}, +-{self.accuracy:.2g}), "
            f"frequency {self.frequency:.9g} rad/s)"
        )


def locate_hopf(
    system: HybridSystem,
    params: Mapping[str, float],
    mode: str,
    parameter: str,
    p_range: tuple[float, float],
    x0=None,
    *,
    settings: NewtonOptions | None = None,
) -> HopfPoint:
    """The parameter value in ``p_range`` where the equilibrium's largest real part crosses 0.

    Secant method with the Illinois modification on ``max Re(lambda)(p)``, each value an
    equilibrium solved from the previous one.

    Parameters
    ----------
    system : HybridSystem
    params : mapping of str to float
        All parameter values.
    mode : str
    parameter : str
        The parameter that moves.
    p_range : (float, float)
        A bracket: the largest real part has opposite signs at its ends.
    x0 : mapping or array_like, optional
        Guess of the equilibrium at ``p_range[0]``.
    settings : NewtonOptions, optional
        ``tol``: the bracket's width relative to ``max(1, |p|)``; ``max_iter`` secant steps
        (default :data:`HOPF_SECANT`: 1e-13, 60).

    Returns
    -------
    HopfPoint
        The value, the equilibrium there, the kind (``"hopf"`` if the critical eigenvalues are a
        complex pair) and its frequency.

    Raises
    ------
    ValueError
        The largest real part does not change sign over ``p_range``.
    RuntimeError
        No equilibrium at one of the secant's values.
    """
    settings = HOPF_SECANT if settings is None else settings
    if not isinstance(settings, NewtonOptions):
        raise InputTypeError(f"`settings` must be a NewtonOptions, got {type(settings).__name__}")
    tol, max_iter = settings.tol, settings.max_iter
    cache: dict[float, Equilibrium] = {}
    guess = [x0]

    def g(p: float) -> float:
        eq = equilibrium(system, {**params, parameter: p}, mode, guess[0])
        if not eq.converged:
            raise ConvergenceError(f"no equilibrium at {parameter} = {p!r}: {eq.message}")
        guess[0] = eq.x
        cache[p] = eq
        return float(eq.eigenvalues[0].real)

    a, b = (float(v) for v in p_range)
    ga, gb = g(a), g(b)
    if ga * gb > 0:
        raise InputError(
            f"the largest real part of the eigenvalues does not change sign over {parameter} in [{a}, {b}] "
            f"({ga:.3g}, {gb:.3g})"
        )
    side = 0
    located = False
    for _ in range(max_iter):
        c = b - gb * (b - a) / (gb - ga)
        gc = g(c)
        if gc * gb < 0:
            a, ga = b, gb
            side = 0
        else:
            ga = ga * 0.5 if side == 1 else ga
            side = 1
        b, gb = c, gc
        if abs(b - a) <= tol * max(1.0, abs(b)) or gc == 0.0:
            located = True
            break
    eq = cache[b]
    om = abs(float(eq.eigenvalues[0].imag))
    # The interval: the last bracket, widened by what the rounding of the eigenvalues (relative to
    # the largest, a hundred times the machine's) moves the crossing, at the bracket's slope.
    slope = abs((gb - ga) / (b - a)) if b != a else math.inf
    lam = float(np.max(np.abs(eq.eigenvalues))) if eq.eigenvalues.size else 0.0
    noise = 100.0 * np.finfo(float).eps * lam / slope if slope > 0 else math.inf
    if gb == 0.0:  # the secant landed on the crossing of the computed real part itself
        a = b
    lo, hi = min(a, b) - noise, max(a, b) + noise
    # located: to the tolerance, or to the rounding where the tolerance asks for less than that
    located = max(b - lo, hi - b) <= max(tol * max(1.0, abs(b)), 4.0 * noise)
    return HopfPoint(
        kind="hopf" if om > 1e-9 else "real-eigenvalue",
        parameter=b,
        equilibrium=eq,
        frequency=om,
        status="located" if located else "bracketed",
        accuracy=max(b - lo, hi - b),
        interval=(lo, hi),
    )
