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
from ..engine.simulate import initial_state
from ..model.compiled import CompiledSystem
from ..model.system import HybridSystem

__all__ = ["Equilibrium", "equilibrium", "locate_hopf", "reduced_jacobian"]


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
    converged : bool
    residual : float
        ``max |f|`` at ``x``.
    message : str
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
    converged: bool
    residual: float
    message: str

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
    tol: float = 1e-12,
    max_iter: int = 50,
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
    tol : float
        Tolerance on ``max |f|`` relative to ``max(1, max |x|)`` [1/s].
    max_iter : int

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
    system.mode(mode)
    params = system.parameter_values(params)
    cs = CompiledSystem(system, params)
    if cs.depends_on_time():
        raise ModelError(f"model `{system.name}` depends on t: equilibria need an autonomous model")
    cm = cs.modes[cs.mode_id(mode)]
    y = initial_state(system, np.zeros(len(system.variable_names)) if x0 is None else x0, mode)
    return _solve(system, params, cm, y, tol, max_iter)


def _solve(system, params, cm, y, tol, max_iter) -> Equilibrium:
    d = _unknowns(system, cm)
    msg = ""
    res = math.inf
    try:
        y = cm.solve_algebraic(0.0, y)
        for it in range(max_iter + 1):
            f = cm.rhs(0.0, y)[d]
            res = float(np.max(np.abs(f))) if f.size else 0.0
            A = reduced_jacobian(cm, y, d)
            if res <= tol * max(1.0, float(np.max(np.abs(y[d]))) if d.size else 1.0):
                break
            if it == max_iter:
                msg = f"Newton's method did not converge ({max_iter} iterations, max |f| = {res:.3g})"
                break
            y = y.copy()
            y[d] -= np.linalg.lstsq(A, f, rcond=None)[0]
            y = cm.solve_algebraic(0.0, y)
            if not np.all(np.isfinite(y)):
                msg = "Newton's iterates diverged"
                break
    except (RuntimeError, np.linalg.LinAlgError, ArithmeticError) as exc:
        msg = f"Newton's method failed: {exc}"
        A = np.full((d.size, d.size), np.nan)
    if not msg and d.size:
        sv = np.linalg.svd(A, compute_uv=False)
        if sv[-1] <= 1e-12 * max(sv[0], 1.0):
            msg = "the Jacobian is singular there: not an isolated equilibrium (a continuum of steady states)"
    ev = np.linalg.eigvals(A) if np.all(np.isfinite(A)) else np.full(d.size, np.nan, dtype=complex)
    ev = ev[np.argsort(-ev.real, kind="stable")]
    h = cm.guard_values(0.0, y)
    dirs = np.array([g.direction for g in cm.guards])
    # a guard with direction +1 fires when it rises through 0: admissible while it is negative
    admissible = (
        bool(np.all(np.where(dirs > 0, h < 0, np.where(dirs < 0, h > 0, h != 0)))) if h.size else True
    )
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
        converged=not msg,
        residual=res,
        message=msg or "converged",
    )


def locate_hopf(
    system: HybridSystem,
    params: Mapping[str, float],
    mode: str,
    parameter: str,
    bracket: tuple[float, float],
    x0=None,
    *,
    tol: float = 1e-13,
    max_iter: int = 60,
) -> tuple[float, Equilibrium]:
    """The parameter value in ``bracket`` where the equilibrium's largest real part crosses 0.

    Secant method with the Illinois modification on ``max Re(lambda)(p)``, each value an
    equilibrium solved from the previous one.

    Returns
    -------
    (float, Equilibrium)
        The value and the equilibrium there (a Hopf point if its critical eigenvalues are a
        complex pair: ``abs(eigenvalues[0].imag) > 0``).

    Raises
    ------
    ValueError
        The largest real part does not change sign over ``bracket``.
    """
    cache: dict[float, Equilibrium] = {}
    guess = [x0]

    def g(p: float) -> float:
        eq = equilibrium(system, {**params, parameter: p}, mode, guess[0])
        if not eq.converged:
            raise ConvergenceError(f"no equilibrium at {parameter} = {p!r}: {eq.message}")
        guess[0] = eq.x
        cache[p] = eq
        return float(eq.eigenvalues[0].real)

    a, b = (float(v) for v in bracket)
    ga, gb = g(a), g(b)
    if ga * gb > 0:
        raise InputError(
            f"the largest real part of the eigenvalues does not change sign over {parameter} in [{a}, {b}] "
            f"({ga:.3g}, {gb:.3g})"
        )
    side = 0
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
            break
    return b, cache[b]
